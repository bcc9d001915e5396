//! Light sources, as the shading models see them: where light comes from
//! at a point and how much of it arrives.

use glam::Vec3;

/// A light source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// A light at the eye: at every point of a ray it comes from the ray's
    /// origin, against the viewing direction.
    Headlight,
    /// A light infinitely far away, in the unit direction `towards` (from
    /// the scene towards the light).
    Directional {
        /// Unit vector from the scene towards the light.
        towards: Vec3,
    },
}

/// What arrives from a light at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    /// Unit vector from the point towards the light.
    pub towards: Vec3,
    /// Radiance arriving (linear RGB).
    pub radiance: Vec3,
}

impl Light {
    /// A directional light from a direction towards it, of any length
    /// (scaled by its largest component before normalising, so very small
    /// and very large vectors keep their direction); `None` for the zero or
    /// a non-finite vector.
    pub fn directional(towards: Vec3) -> Option<Light> {
        crate::ray::unit(towards).map(|towards| Light::Directional { towards })
    }

    /// Whether the light's direction is the same at every point of a ray,
    /// so shading can work it out once per ray.
    pub fn is_per_ray(&self) -> bool {
        true
    }

    /// The light at any point of a ray travelling along unit `view_dir`.
    #[inline(always)]
    pub fn for_ray(&self, view_dir: Vec3) -> Incident {
        let towards = match *self {
            Light::Headlight => -view_dir,
            Light::Directional { towards } => towards,
        };
        Incident {
            towards,
            radiance: Vec3::ONE,
        }
    }
}
