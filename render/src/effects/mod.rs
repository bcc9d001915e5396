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
pub mod shadow_ray;

pub use crate::film::EffectStats;
pub use crate::settings::{Ao, AoMethod, ShadowMethod, Shadows};
pub use crate::trace::RayEffects;
pub use ao::{outward_normal, outward_normals8, AoField, AoLookup, AoSource};
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
