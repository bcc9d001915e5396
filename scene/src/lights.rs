//! The lights of a scene file (`[[lights]]`), the one thing a scene says
//! that no flag does (`--light` is one directional light), and the colour
//! form they share with `ambient`.

use glam::Vec3;
use serde::{Deserialize, Serialize};
use volrender::Light;

/// A colour: one grey level, or linear r, g, b.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Colour {
    /// The same level in every channel.
    Grey(f32),
    /// Linear r, g, b.
    Rgb([f32; 3]),
}

impl Colour {
    /// As linear RGB.
    pub fn rgb(self) -> Vec3 {
        match self {
            Colour::Grey(g) => Vec3::splat(g),
            Colour::Rgb(c) => Vec3::from(c),
        }
    }
}

/// One light of a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum LightSpec {
    /// Light from the eye, along each ray.
    Headlight {
        /// Linear RGB (default white).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        colour: Option<Colour>,
        /// Scales the colour (default 1).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        intensity: Option<f32>,
    },
    /// Parallel light travelling along `direction`.
    Directional {
        /// The direction the light travels (from the light into the scene).
        direction: [f32; 3],
        /// Linear RGB (default white).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        colour: Option<Colour>,
        /// Scales the colour (default 1).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        intensity: Option<f32>,
    },
    /// Light from a point, falling off with the square of the distance.
    Point {
        /// Where the light is, world units.
        position: [f32; 3],
        /// Linear RGB (default white).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        colour: Option<Colour>,
        /// Scales the colour: the radiance at distance 1 (default 1).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        intensity: Option<f32>,
    },
}

impl LightSpec {
    /// The light, or what is wrong with it.
    pub fn light(&self) -> std::result::Result<Light, String> {
        let radiance = |colour: &Option<Colour>, intensity: &Option<f32>| {
            let c = colour.map_or(Vec3::ONE, Colour::rgb);
            let i = intensity.unwrap_or(1.0);
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err("colour must be finite and not negative".to_string());
            }
            if !(i.is_finite() && i >= 0.0) {
                return Err("intensity must be finite and not negative".to_string());
            }
            Ok(c * i)
        };
        match self {
            LightSpec::Headlight { colour, intensity } => Ok(Light::Headlight {
                radiance: radiance(colour, intensity)?,
            }),
            LightSpec::Directional {
                direction,
                colour,
                intensity,
            } => {
                let towards = volrender::ray::unit(-Vec3::from(*direction))
                    .ok_or("direction must be a finite, non-zero vector")?;
                Ok(Light::Directional {
                    towards,
                    radiance: radiance(colour, intensity)?,
                })
            }
            LightSpec::Point {
                position,
                colour,
                intensity,
            } => {
                let position = Vec3::from(*position);
                if !position.is_finite() {
                    return Err("position must be finite".to_string());
                }
                Ok(Light::Point {
                    position,
                    intensity: radiance(colour, intensity)?,
                })
            }
        }
    }

    /// The scene-file form of `light`.
    pub fn of(light: &Light) -> LightSpec {
        let rgb = |c: Vec3| Some(Colour::Rgb(c.to_array()));
        match *light {
            Light::Headlight { radiance } => LightSpec::Headlight {
                colour: rgb(radiance),
                intensity: None,
            },
            Light::Directional { towards, radiance } => LightSpec::Directional {
                direction: (-towards).to_array(),
                colour: rgb(radiance),
                intensity: None,
            },
            Light::Point {
                position,
                intensity,
            } => LightSpec::Point {
                position: position.to_array(),
                colour: rgb(intensity),
                intensity: None,
            },
        }
    }
}
