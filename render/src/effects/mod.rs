//! Lighting effects beyond local shading: shadows and ambient
//! occlusion, each switched on by the frame's settings and costing nothing
//! when off but a branch per shaded sample (no grid is built, no shadow or
//! occlusion ray cast, no counter moved).
//!
//! - [`occluder`]: what blocks light, as optical depth per sample: the
//!   classified volume (DVR) or the iso-surface's inside (iso).
//! - [`shadow_ray`]: transmittance toward a light by marching a shadow ray
//!   with the frame's macrocell skipping.
//! - [`light_grid`]: a transmittance grid per directional light, swept
//!   slab by slab away from the light once per frame, read trilinearly.
//! - [`caster`]: the per-light choice between the two, and the counters
//!   (the DVR shading that applies effects to samples is
//!   [`crate::integrator::dvr::shading::Phong`]).
//! - [`occlusion_grid`]: the classified volume's extinction on a coarse
//!   grid, and the march of an occlusion ray through it.
//! - [`ao`]: ambient occlusion by sampled directions or a precomputed
//!   field of fixed directions.

pub mod ao;
pub mod caster;
pub mod light_grid;
pub mod occluder;
pub mod occlusion_grid;
pub mod setup;
pub mod shadow_ray;

pub use ao::{outward_normal, outward_normals8, Ao, AoField, AoLookup, AoMethod, AoSource};
pub use caster::ShadowCaster;
pub use light_grid::LightGrid;
pub use occluder::{Classified, IsoInside, Occluder};
pub use occlusion_grid::OcclusionGrid;

/// A shadow ray stops once its transmittance falls below this and counts
/// as fully shadowed: the light it drops is at most this fraction of the
/// light's radiance (well under half of one 8-bit level).
pub const SHADOW_CUTOFF: f32 = 1e-3;

/// The optical depth past which a shadow ray stops (`−ln SHADOW_CUTOFF`).
pub const SHADOW_DEPTH_CUTOFF: f32 = 6.907_755;

/// How shadows are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowMethod {
    /// A shadow ray per shaded sample and light, marched with skipping.
    Ray,
    /// A transmittance grid per directional light, one point every
    /// `divisor` voxels along each axis (1, 2 or 4); other lights fall
    /// back to shadow rays.
    Grid {
        /// Voxels per grid cell along each axis.
        divisor: u32,
    },
}

/// Shadow settings of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shadows {
    /// The method.
    pub method: ShadowMethod,
    /// Distance between shadow samples, world units (`None`: the frame's
    /// step).
    pub step: Option<f32>,
}

/// What the effects did in a frame (all zero when they are off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EffectStats {
    /// Shadow rays marched.
    pub shadow_rays: u64,
    /// Samples those shadow rays took.
    pub shadow_samples: u64,
    /// Light grids built.
    pub shadow_grids: u32,
    /// Seconds spent building them.
    pub shadow_grid_s: f64,
    /// Their memory, bytes.
    pub shadow_grid_bytes: u64,
    /// Samples their build took.
    pub shadow_grid_samples: u64,
    /// Occlusion rays marched (`--ao N`: N per shaded sample).
    pub ao_rays: u64,
    /// Grid reads those rays took.
    pub ao_samples: u64,
    /// Seconds spent building the occlusion grid.
    pub ao_grid_s: f64,
    /// Its memory, bytes.
    pub ao_grid_bytes: u64,
    /// Samples its build took.
    pub ao_grid_samples: u64,
    /// Seconds spent precomputing the AO field (`--ao-field K`; not
    /// counted in the frame's render time).
    pub ao_field_s: f64,
    /// The field's memory, bytes.
    pub ao_field_bytes: u64,
    /// Grid reads its build took.
    pub ao_field_samples: u64,
}

/// Per-ray effect counters, carried in a ray's result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayEffects {
    /// Shadow rays this ray's samples cast.
    pub shadow_rays: u32,
    /// Samples those shadow rays took.
    pub shadow_samples: u64,
    /// Occlusion rays this ray's samples cast.
    pub ao_rays: u32,
    /// Grid reads those occlusion rays took.
    pub ao_samples: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_depth_cutoff_is_the_transmittance_cutoff() {
        let from_t = -(SHADOW_CUTOFF as f64).ln();
        assert!((SHADOW_DEPTH_CUTOFF as f64 - from_t).abs() < 1e-5);
        assert!(((-SHADOW_DEPTH_CUTOFF).exp() - SHADOW_CUTOFF).abs() < 1e-8);
    }
}
