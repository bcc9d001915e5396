//! Light sources, as the shading models see them: from where light
//! arrives at a point and how much of it.

use glam::Vec3;

/// A light source. Radiance and intensity are linear RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A light at the eye: at every point of a ray it comes from the ray's
    /// origin, against the viewing direction.
    Headlight {
        /// Radiance arriving.
        radiance: Vec3,
    },
    /// A light infinitely far away.
    Directional {
        /// Unit vector from the scene towards the light (against the
        /// direction the light travels).
        towards: Vec3,
        /// Radiance arriving.
        radiance: Vec3,
    },
    /// A point light: radiance falls off with the square of the distance.
    Point {
        /// Where the light is, world units.
        position: Vec3,
        /// Intensity: the radiance arriving at unit distance.
        intensity: Vec3,
    },
}

/// What arrives from a light at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    /// Unit vector from the point towards the light.
    pub towards: Vec3,
    /// Radiance arriving (linear RGB).
    pub radiance: Vec3,
    /// Distance to the light (infinite for distant lights).
    pub distance: f32,
}

/// Point lights closer than this (world units, squared) light as if they
/// were this far: radiance stays finite at the light itself.
pub(crate) const MIN_DISTANCE2: f32 = 1e-12;

impl Light {
    /// The default light: a white headlight.
    pub const HEADLIGHT: Light = Light::Headlight {
        radiance: Vec3::ONE,
    };

    /// A white directional light from a direction towards it, of any
    /// length (see [`crate::ray::unit`]); `None` for the zero or a
    /// non-finite vector.
    pub fn directional(towards: Vec3) -> Option<Light> {
        crate::ray::unit(towards).map(|towards| Light::Directional {
            towards,
            radiance: Vec3::ONE,
        })
    }

    /// Whether the light arrives from the same direction at every point
    /// of a ray, so shading can work that out once per ray.
    pub fn is_per_ray(&self) -> bool {
        !matches!(self, Light::Point { .. })
    }

    /// The light at any point of a ray travelling along unit `view_dir`,
    /// for lights that are [`Light::is_per_ray`] (a point light is taken at
    /// unit distance from the direction towards it from the origin).
    #[inline(always)]
    pub fn for_ray(&self, view_dir: Vec3) -> Incident {
        match *self {
            Light::Headlight { radiance } => Incident {
                towards: -view_dir,
                radiance,
                distance: f32::INFINITY,
            },
            Light::Directional { towards, radiance } => Incident {
                towards,
                radiance,
                distance: f32::INFINITY,
            },
            Light::Point {
                position,
                intensity,
            } => Incident {
                towards: position.normalize_or_zero(),
                radiance: intensity,
                distance: 1.0,
            },
        }
    }

    /// The light arriving at world point `p` of a ray travelling along
    /// unit `view_dir`.
    #[inline]
    pub fn at(&self, p: Vec3, view_dir: Vec3) -> Incident {
        match *self {
            Light::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                let d2 = d.length_squared();
                let towards = crate::ray::unit(d);
                let (Some(towards), false) = (towards, d2.is_nan() || d2 <= MIN_DISTANCE2) else {
                    // At the light itself: any direction, the nearest
                    // finite radiance.
                    return Incident {
                        towards: -view_dir,
                        radiance: intensity * (1.0 / MIN_DISTANCE2),
                        distance: 0.0,
                    };
                };
                // Past f32's range (d2 infinite) the light is out of
                // reach: no radiance, the direction still exact.
                let dist = d2.sqrt();
                Incident {
                    towards,
                    radiance: intensity * (1.0 / d2),
                    distance: dist,
                }
            }
            _ => self.for_ray(view_dir),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_lights_fall_off_with_the_square_and_stay_finite() {
        let l = Light::Point {
            position: Vec3::new(0.0, 0.0, 10.0),
            intensity: Vec3::splat(100.0),
        };
        let a = l.at(Vec3::ZERO, Vec3::X);
        assert_eq!(a.towards, Vec3::Z);
        assert_eq!(a.radiance, Vec3::ONE);
        assert_eq!(a.distance, 10.0);
        let b = l.at(Vec3::new(0.0, 0.0, 5.0), Vec3::X);
        assert_eq!(b.radiance, Vec3::splat(4.0));
        // At the light: finite, and a unit direction.
        let c = l.at(Vec3::new(0.0, 0.0, 10.0), Vec3::X);
        assert!(c.radiance.is_finite() && (c.towards.length() - 1.0).abs() < 1e-6);
        assert!(!l.is_per_ray() && Light::HEADLIGHT.is_per_ray());
    }

    #[test]
    fn directional_lights_keep_their_direction_at_any_scale() {
        for s in [1e-30f32, 1.0, 1e30] {
            let Some(Light::Directional { towards, .. }) = Light::directional(Vec3::new(s, s, s))
            else {
                panic!("{s}")
            };
            assert!((towards - Vec3::ONE.normalize()).length() < 1e-6);
        }
        assert!(Light::directional(Vec3::ZERO).is_none());
    }

    #[test]
    fn a_point_light_past_f32_range_gives_no_light_and_a_unit_direction() {
        let l = Light::Point {
            position: Vec3::new(3e38, 3e38, 0.0),
            intensity: Vec3::ONE,
        };
        let inc = l.at(Vec3::ZERO, Vec3::NEG_Z);
        assert_eq!(inc.radiance, Vec3::ZERO);
        assert!((inc.towards - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
    }
}
