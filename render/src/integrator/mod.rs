//! The integrators: what happens along one ray, per mode.
//!
//! Each mode is a generic function whose options (interpolation, gradient
//! method, shading, skipping, early termination) are const parameters, so
//! the frame picks one specialised loop and an option that is off costs
//! nothing: with shading off no gradient is ever computed, and MIP, MinIP
//! and X-ray never touch a transfer function.

mod dvr;
mod iso;
mod project;
mod sample;

pub use dvr::dvr;
pub use iso::iso;
pub use project::{mip, xray};

use crate::light::Lighting;
use crate::ray::Ray;
use crate::skip::SkipGrid;
use crate::tf::TfTable;
use glam::Vec3;
use volcore::grid::Locator;

/// What a ray computes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Emission-absorption, front to back, through a transfer function.
    Dvr,
    /// Maximum intensity projection.
    Mip,
    /// Minimum intensity projection.
    Minip,
    /// X-ray: the integral of the value along the ray (value × length).
    XraySum,
    /// X-ray: the mean sample value along the ray.
    XrayMean,
    /// The first crossing of this iso value, refined by bisection, shaded.
    Iso(f32),
}

/// How values between voxels are reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interp {
    /// The nearest voxel.
    Nearest,
    /// Trilinear interpolation.
    Trilinear,
}

/// How gradients for shading are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GradientMethod {
    /// Central differences of the interpolant (six more samples).
    Central,
    /// The exact gradient of the trilinear cell (no extra samples).
    Analytic,
}

/// Everything a ray needs that is the same for the whole frame.
pub struct RayCtx<'a> {
    /// Distance between samples, world units.
    pub step: f32,
    /// 1 / spacing, to go from world to voxel coordinates.
    pub inv_spacing: Vec3,
    /// The transfer function table (DVR).
    pub table: Option<&'a TfTable>,
    /// Shading model.
    pub lighting: Lighting,
    /// Shade only where the world-space gradient is longer than this.
    pub gradient_threshold: f32,
    /// Stop DVR rays at this accumulated opacity.
    pub ert: f32,
    /// Skipping data (when skipping is on).
    pub skip: Option<&'a SkipGrid<'a>>,
    /// The volume's largest and smallest values (MIP/MinIP termination).
    pub value_range: (f32, f32),
    /// Linear surface colour (iso).
    pub iso_colour: Vec3,
    /// Locates sample points in the volume.
    pub locator: Locator,
}

/// What one ray produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayResult {
    /// Linear colour, premultiplied by alpha, and alpha.
    pub rgba: [f32; 4],
    /// The mode's scalar: MIP/MinIP value, X-ray sum or mean (NaN when no
    /// sample was taken).
    pub value: f32,
    /// Ray parameter of the iso hit or MIP maximum (NaN when none).
    pub depth: f32,
    /// Samples taken.
    pub samples: u32,
    /// Skips made.
    pub skips: u32,
}

impl RayResult {
    fn empty() -> RayResult {
        RayResult {
            value: f32::NAN,
            depth: f32::NAN,
            ..Default::default()
        }
    }
}

/// The ray in voxel coordinates and its sample range `k0 ..= k1`
/// (samples at `t = k·step`).
#[derive(Clone, Copy)]
pub(crate) struct Walk {
    pub o: Vec3,
    pub d: Vec3,
    pub k0: i64,
    pub k1: i64,
    pub step: f64,
    /// `1 / step`.
    pub inv_step: f64,
    /// `1 / d` per axis, in f64 (infinite along axes the ray does not move
    /// along).
    pub inv_d: [f64; 3],
    /// Locates sample points in the volume.
    pub loc: Locator,
}

impl Walk {
    pub fn new(ctx: &RayCtx, ray: &Ray, t0: f32, t1: f32) -> Walk {
        let (o, d) = (ray.origin * ctx.inv_spacing, ray.dir * ctx.inv_spacing);
        Walk::voxel_space(o, d, t0, t1, ctx.step as f64, ctx.locator)
    }

    /// The walk of a ray already in voxel coordinates (origin `o`,
    /// direction `d`) over `[t0, t1]` with samples `step` apart.
    pub fn voxel_space(o: Vec3, d: Vec3, t0: f32, t1: f32, step: f64, loc: Locator) -> Walk {
        Walk {
            o,
            d,
            k0: (t0 as f64 / step).ceil() as i64,
            k1: (t1 as f64 / step).floor() as i64,
            step,
            inv_step: 1.0 / step,
            inv_d: d.to_array().map(|c| 1.0 / c as f64),
            loc,
        }
    }

    /// Ray parameter of sample `k` (always this expression, so a sample
    /// lands at the same place whatever skipped or refined around it).
    #[inline(always)]
    pub fn t(&self, k: i64) -> f32 {
        (k as f64 * self.step) as f32
    }

    /// Voxel-space position at ray parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }

    /// After a skip covering every sample up to parameter `u`, the first
    /// sample past `u`, if that moves past `k` (every sample from `k` to it
    /// is skipped; the one returned is taken normally).
    #[inline(always)]
    pub fn after_skip(&self, k: i64, u: f32) -> Option<i64> {
        let last = self.last_before(u);
        (last >= k).then_some(last.saturating_add(1))
    }

    /// The last sample at or before ray parameter `u`.
    #[inline(always)]
    pub fn last_before(&self, u: f32) -> i64 {
        // A reciprocal instead of a division (on the path from one skip to
        // the next sample): in f64, its rounding can move `u / step` across
        // an integer only when `u` lies within ~1e-12 of a sample, far
        // inside the margin skips keep from cell faces.
        floor_i64(u as f64 * self.inv_step)
    }
}

/// `floor(x)` as an integer (saturating; NaN gives 0), without a call to
/// libm's `floor`, which the baseline x86-64 target cannot inline.
#[inline(always)]
fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    i - ((i as f64) > x) as i64
}
