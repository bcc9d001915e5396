//! Scene files: everything one render needs, in TOML, with the same keys
//! as vol-render's command-line options (`look-at = [0, 0, 0]` is
//! `--look-at 0,0,0`), plus `[[lights]]` and `ambient`. This module reads,
//! checks and writes the file; [`crate::merge`] fills the options from it.

pub use crate::choices::{GradientArg, InterpArg, ModeArg, ShadingArg, TonemapArg, UpArg};
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use volrender::Light;

/// A scene file as written: every key optional (the command line and the
/// defaults fill the rest).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub struct Scene {
    /// The volume.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume: Option<PathBuf>,
    /// A .vidx index for the volume.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub index: Option<PathBuf>,
    /// DICOM: the series to read (number, UID or a unique UID prefix).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series: Option<String>,
    /// Multichannel input: the channel to read.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub channel: Option<u16>,
    /// Input with a time axis: the time point to read.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_point: Option<u64>,
    /// What each ray computes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode: Option<ModeArg>,
    /// Transfer function: a preset or a file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tf: Option<String>,
    /// Transfer function text written in the scene (instead of `tf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tf_text: Option<String>,
    /// Iso value (`mode = "iso"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iso: Option<f32>,
    /// Image width and height.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size: Option<[u32; 2]>,
    /// Camera position.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eye: Option<[f32; 3]>,
    /// Point the camera looks at.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f32; 3]>,
    /// Up vector, or `"patient"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub up: Option<Up>,
    /// Orbit camera: azimuth, elevation (degrees), distance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orbit: Option<[f32; 3]>,
    /// Vertical field of view, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fov: Option<f32>,
    /// Orthographic image height (0: fit the volume).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ortho: Option<f32>,
    /// Distance between samples, world units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step: Option<f32>,
    /// Early ray termination threshold.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ert: Option<f32>,
    /// Early ray termination off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_ert: Option<bool>,
    /// Empty-space skipping off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_ess: Option<bool>,
    /// Reconstruction between voxels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interp: Option<InterpArg>,
    /// Shading (DVR).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shading: Option<ShadingArg>,
    /// Gradient method.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient: Option<GradientArg>,
    /// Ambient light: a grey level or linear r, g, b.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ambient: Option<Colour>,
    /// The lights (none given: a headlight).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lights: Option<Vec<LightSpec>>,
    /// Shadows: `ray`, `grid` or `grid:DIV`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadows: Option<String>,
    /// Distance between shadow samples, world units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_step: Option<f32>,
    /// Ambient occlusion by sampled directions: `N` or `N:R`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao: Option<String>,
    /// Ambient occlusion from a precomputed field: `K` or `K:R`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_field: Option<String>,
    /// Voxels between the AO field's points.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_field_cell: Option<u32>,
    /// Background colour r, g, b (0-255).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background: Option<[f32; 3]>,
    /// RGBA output with coverage alpha.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<bool>,
    /// Output PNG.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<PathBuf>,
    /// Linear float image (.pfm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hdr: Option<PathBuf>,
    /// Samples-per-pixel heat map (.png).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heatmap: Option<PathBuf>,
    /// Path tracing: samples per pixel.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spp: Option<u64>,
    /// Path tracing: a time budget, seconds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
    /// The old key for `seconds` (and `time-point`): refused, naming both.
    #[serde(skip_serializing)]
    pub time: Option<toml::Value>,
    /// Path tracing: stop at this relative standard error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub until_error: Option<f64>,
    /// Path tracing: scattering events per path.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    /// Path tracing: Henyey-Greenstein asymmetry.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub g: Option<f32>,
    /// Path tracing: hybrid scattering, `off` or a gradient scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hybrid: Option<String>,
    /// Path tracing: extinction per world unit at normalised value 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_scale: Option<f32>,
    /// Path tracing: albedo of the density medium.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub albedo: Option<Colour>,
    /// Path tracing: suns, `dx,dy,dz[:E]` each.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun: Option<Vec<String>>,
    /// Path tracing: constant environment radiance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub env: Option<Colour>,
    /// Path tracing: an equirectangular environment map (.pfm or .exr).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub env_map: Option<PathBuf>,
    /// Path tracing: `grid` or `global`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub majorant: Option<String>,
    /// Path tracing: the sampler's seed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Path tracing: exposure of the PNG.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposure: Option<f32>,
    /// Path tracing: the PNG's tone map.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tonemap: Option<TonemapArg>,
}

/// `up`: a vector or a name (`"patient"`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Up {
    /// This vector.
    Vector([f32; 3]),
    /// `"patient"`: the data's superior direction.
    Named(String),
}

impl Up {
    /// As the command line's `--up`.
    pub fn arg(&self) -> std::result::Result<UpArg, String> {
        match self {
            Up::Vector(v) => {
                let v = Vec3::from(*v);
                if v.is_finite() && v != Vec3::ZERO {
                    Ok(UpArg::Vector(v))
                } else {
                    Err("key `up`: must be a finite, non-zero vector or \"patient\"".into())
                }
            }
            Up::Named(n) if n == "patient" => Ok(UpArg::Patient),
            Up::Named(_) => Err("key `up`: must be x, y, z or \"patient\"".into()),
        }
    }

    /// The scene-file form of `--up`.
    pub fn of(up: UpArg) -> Up {
        match up {
            UpArg::Vector(v) => Up::Vector(v.to_array()),
            UpArg::Patient => Up::Named("patient".into()),
        }
    }
}

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

impl Scene {
    /// Read and check the scene file at `path`.
    pub fn read(path: &Path) -> Result<Scene> {
        let name = volcore::text::escape(&path.display().to_string());
        let text = match std::fs::read(path) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(t) => t,
                Err(_) => return Err(Error::file(format!("{name}: not a UTF-8 text file"))),
            },
            Err(e) => return Err(Error::file(format!("{name}: {e}"))),
        };
        Scene::parse(&text).map_err(|e| Error::file(format!("{name}: {e}")))
    }

    /// Parse scene text; an error says where (line and key) and what.
    pub fn parse(text: &str) -> std::result::Result<Scene, String> {
        let scene: Scene = toml::from_str(text).map_err(|e| describe(text, &e))?;
        scene.check()?;
        Ok(scene)
    }

    /// Read and check a scene from JSON, with the file's keys (a viewer's
    /// state, Python's keywords); an error says which key and what.
    pub fn from_json(value: serde_json::Value) -> std::result::Result<Scene, String> {
        let scene: Scene = serde_json::from_value(value).map_err(|e| {
            let what = e.to_string();
            match what.split_once(", expected one of") {
                Some((head, _)) => head.replace("unknown field", "unknown key"),
                None => what,
            }
        })?;
        scene.check()?;
        Ok(scene)
    }

    /// Checks serde cannot make: lights that are lights, finite numbers.
    fn check(&self) -> std::result::Result<(), String> {
        if let Some(lights) = &self.lights {
            for (i, l) in lights.iter().enumerate() {
                l.light().map_err(|e| format!("lights[{i}]: {e}"))?;
            }
        }
        if let Some(a) = self.ambient {
            let c = a.rgb();
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err("key `ambient`: must be finite and not negative".into());
            }
        }
        if let Some(up) = &self.up {
            up.arg()?;
        }
        let vectors = [
            ("eye", self.eye),
            ("look-at", self.look_at),
            ("orbit", self.orbit),
            ("background", self.background),
        ];
        for (key, v) in vectors {
            if v.is_some_and(|v| !Vec3::from(v).is_finite()) {
                return Err(format!("key `{key}`: must be three finite numbers"));
            }
        }
        // Ranges are the command line's to check; NaN and infinities are
        // never a setting (and would not survive a printed scene).
        let scalars = [
            ("iso", self.iso),
            ("fov", self.fov),
            ("ortho", self.ortho),
            ("step", self.step),
            ("ert", self.ert),
            ("shadow-step", self.shadow_step),
            ("g", self.g),
            ("density-scale", self.density_scale),
            ("exposure", self.exposure),
        ];
        for (key, v) in scalars {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(format!("key `{key}`: must be a finite number"));
            }
        }
        if self.time.is_some() {
            return Err("key `time` is gone: use `seconds` for the path-tracing time budget (vol-render --seconds); the volume's time point is vol-render's --time-point".into());
        }
        for (key, v) in [("seconds", self.seconds), ("until-error", self.until_error)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(format!("key `{key}`: must be a finite number"));
            }
        }
        for (key, c) in [("albedo", self.albedo), ("env", self.env)] {
            if c.is_some_and(|c| !c.rgb().is_finite()) {
                return Err(format!("key `{key}`: must be finite"));
            }
        }
        if self.tf.is_some() && self.tf_text.is_some() {
            return Err("give `tf` or `tf-text`, not both".into());
        }
        if let Some([w, h]) = self.size {
            if !(1..=32768).contains(&w) || !(1..=32768).contains(&h) {
                return Err("key `size`: width and height must be 1..=32768".into());
            }
        }
        Ok(())
    }
}

/// A TOML or type error as `line N, key `k`: what` (the key as written on
/// that line, when there is one).
fn describe(text: &str, e: &toml::de::Error) -> String {
    let what = e.message();
    // serde's list of expected keys is long: the key is what matters.
    let what = match what.split_once(", expected one of") {
        Some((head, _)) => head.replace("unknown field", "unknown key"),
        None => what.to_string(),
    };
    let what = volcore::text::clip(&volcore::text::escape(&what), 160);
    let Some(span) = e.span() else {
        return what;
    };
    let start = span.start.min(text.len());
    let line_no = text[..start].matches('\n').count() + 1;
    let line = text.lines().nth(line_no - 1).unwrap_or("");
    match line.split_once('=') {
        Some((key, _)) if !key.trim().is_empty() && !key.trim_start().starts_with('[') => {
            let key = volcore::text::clip(&volcore::text::escape(key.trim()), 40);
            format!("line {line_no}, key `{key}`: {what}")
        }
        // Errors inside a light point at its table (serde reads tagged
        // tables whole).
        _ if line.trim_start().starts_with('[') => {
            let table = volcore::text::clip(&volcore::text::escape(line.trim()), 40);
            format!("line {line_no}, table `{table}`: {what}")
        }
        _ => format!("line {line_no}: {what}"),
    }
}

/// The scene as TOML text.
pub fn to_toml(scene: &Scene) -> Result<String> {
    toml::to_string(scene).map_err(|e| Error::option(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_lights_parse() {
        let s = Scene::parse(
            r#"
volume = "a.vvol"
mode = "dvr"
size = [64, 32]
look-at = [1, 2, 3]
ambient = 0.2
[[lights]]
type = "directional"
direction = [0, -1, 0]
colour = [1, 0.5, 0.25]
intensity = 2
[[lights]]
type = "point"
position = [10, 10, 10]
"#,
        )
        .unwrap();
        assert_eq!(s.size, Some([64, 32]));
        assert_eq!(s.look_at, Some([1.0, 2.0, 3.0]));
        let lights = s.lights.unwrap();
        assert_eq!(lights.len(), 2);
        match lights[0].light().unwrap() {
            // Travelling down: towards the light is up.
            Light::Directional { towards, radiance } => {
                assert_eq!(towards, Vec3::Y);
                assert_eq!(radiance, Vec3::new(2.0, 1.0, 0.5));
            }
            l => panic!("{l:?}"),
        }
        assert!(matches!(lights[1].light().unwrap(), Light::Point { .. }));
    }

    #[test]
    fn errors_name_the_line_and_the_key() {
        let e = Scene::parse("mode = \"dvr\"\nfov = \"wide\"\n").unwrap_err();
        assert!(e.starts_with("line 2, key `fov`: invalid type"), "{e}");
        let e = Scene::parse("mode = \"dvr\"\n\nfovv = 3\n").unwrap_err();
        assert_eq!(e, "line 3, key `fovv`: unknown key `fovv`");
        let e = Scene::parse("mode = \"sideways\"\n").unwrap_err();
        assert!(e.starts_with("line 1, key `mode`: unknown variant"), "{e}");
        let e = Scene::parse("[[lights]]\ntype = \"point\"\nposition = [0, 0]\n").unwrap_err();
        assert_eq!(
            e,
            "line 1, table `[[lights]]`: invalid length 2, expected an array of length 3"
        );
        let e = Scene::parse("[[lights]]\ntype = \"laser\"\n").unwrap_err();
        assert!(e.contains("laser"), "{e}");
        let e = Scene::parse("[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 0]\n")
            .unwrap_err();
        assert_eq!(e, "lights[0]: direction must be a finite, non-zero vector");
        let e = Scene::parse("[[lights]]\ntype = \"headlight\"\nbrightness = 2\n").unwrap_err();
        assert!(e.contains("brightness"), "{e}");
        let e = Scene::parse("size = [0, 10]\n").unwrap_err();
        assert!(e.contains("size"), "{e}");
        let e = Scene::parse("fov = nan\n").unwrap_err();
        assert_eq!(e, "key `fov`: must be a finite number");
        let e = Scene::parse("step = -inf\n").unwrap_err();
        assert_eq!(e, "key `step`: must be a finite number");
        let e = Scene::parse("eye = [1, 2,\n").unwrap_err();
        assert!(e.starts_with("line "), "{e}");
    }

    #[test]
    fn a_printed_scene_reads_back_the_same() {
        let s = Scene {
            volume: Some("/data/a.vvol".into()),
            mode: Some(ModeArg::Iso),
            iso: Some(0.1),
            size: Some([7, 9]),
            orbit: Some([30.0, 20.0, 1.0e-3]),
            ambient: Some(Colour::Rgb([0.25, 0.25, 0.25])),
            lights: Some(vec![
                LightSpec::of(&Light::HEADLIGHT),
                LightSpec::of(&Light::Point {
                    position: Vec3::new(1.0, 2.0, 3.0),
                    intensity: Vec3::splat(1.0e6),
                }),
            ]),
            tf_text: Some("domain 0 1\npoint 0 0 0 0 0\n".into()),
            spp: Some(64),
            bounces: Some(8),
            g: Some(-0.5),
            density_scale: Some(0.1),
            albedo: Some(Colour::Grey(0.8)),
            sun: Some(vec!["-1,-1.2,0.4:4".into()]),
            env: Some(Colour::Rgb([0.1, 0.2, 0.3])),
            majorant: Some("global".into()),
            tonemap: Some(TonemapArg::Aces),
            ..Default::default()
        };
        let text = to_toml(&s).unwrap();
        assert_eq!(Scene::parse(&text).unwrap(), s, "{text}");
    }
}
