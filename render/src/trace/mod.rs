//! What one ray's trace is, below the integrators that trace rays and the
//! effects that march shadow and occlusion rays: the [`Integrator`] trait,
//! the frame's sample placement ([`FrameGeometry`]), the part of a ray a
//! trace takes ([`Span`]), what it brings back ([`RayResult`]), the one
//! sample loop ([`march::march`]) and reconstruction between voxels
//! ([`reconstruct`]).

pub mod march;
pub mod reconstruct;

use crate::ray::Ray;
use crate::settings::Interp;
use glam::Vec3;
use volcore::grid::Locator;
use volcore::Cursor;

/// One ray's integral through the volume, specialised for a frame.
pub trait Integrator: Sync {
    /// Integrate `ray` (through pixel `pixel`, which keys any random
    /// numbers the ray takes) over `span` (the part inside the volume's
    /// box, or a share of it), reading samples through `cur`.
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, pixel: [u32; 2], span: Span) -> RayResult;
}

/// The samples a trace takes: those of the ray's parameter range
/// `[t0, t1]` inside the volume's box (samples `k0 ..= k1` at
/// `t = k·step`), or only samples `lo ..= hi` of them, a share of the ray
/// that other traces (other ranks' boxes) take the rest of. A share's
/// trace takes exactly those samples, at the places the whole trace
/// takes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Where the ray enters the volume's box.
    pub t0: f32,
    /// Where it leaves.
    pub t1: f32,
    /// The share of the samples, `(lo, hi)` inclusive; `None` for all.
    pub share: Option<(i64, i64)>,
}

impl Span {
    /// All the samples over `[t0, t1]`.
    pub fn whole(t0: f32, t1: f32) -> Span {
        Span {
            t0,
            t1,
            share: None,
        }
    }
}

/// What is the same for every ray of a frame: where samples go and how
/// world positions map to voxels.
#[derive(Clone, Copy, Debug)]
pub struct FrameGeometry {
    /// Distance between samples, world units.
    pub step: f32,
    /// 1 / spacing, to go from world to voxel coordinates.
    pub inv_spacing: Vec3,
    /// Locates sample points in the volume.
    pub locator: Locator,
    /// How values between voxels are reconstructed.
    pub interp: Interp,
}

/// What one ray produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayResult {
    /// Linear colour, premultiplied by alpha, and alpha.
    pub rgba: [f32; 4],
    /// The mode's scalar: MIP/MinIP value, X-ray sum or mean, iso value
    /// (NaN when none). f64, so an X-ray sum past f32's range (a long ray
    /// through values near 3.4e38) stays finite.
    pub value: f64,
    /// Ray parameter of the iso hit or MIP extreme (NaN when none).
    pub depth: f32,
    /// Samples taken.
    pub samples: u32,
    /// Skips made.
    pub skips: u32,
    /// What the frame's effects (shadows) did for this ray.
    pub effects: RayEffects,
}

impl RayResult {
    /// A ray that met nothing.
    pub fn empty() -> RayResult {
        RayResult {
            value: f64::NAN,
            depth: f32::NAN,
            ..Default::default()
        }
    }
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
