//! Acceleration over the index's macrocells: empty-space skipping for the
//! ray caster, and majorant segments for tracking along a ray.
//!
//! - [`hierarchy`]: the index's levels queried at a point, answering "how
//!   far can the ray jump from here" under a rule.
//! - [`skip`]: the rules (transparent under the transfer function, zero,
//!   cannot beat the running MIP/MinIP value, on one side of the iso
//!   value), each an [`Accel`] the march loop is compiled for; their flags
//!   stay private.
//! - [`distance`]: per level-0 cell and octant of directions, the
//!   chessboard distance to the nearest cell ahead that a rule keeps (one
//!   jump crosses the whole clear block ahead).
//! - [`dda`]: the macrocells a ray crosses, in order, as segments
//!   `(t_enter, t_exit, cell)` (pbrt's majorant-iterator shape).
//! - [`cull`]: the image tiles whose rays meet no cell a rule keeps.
//! - [`open_sky`]: per column along a distant light, the height past
//!   which no busy cell lies (shadow rays stop there).
//! - [`majorant`]: per-cell maximum extinction under a transfer function
//!   (or a density mapping), for shadow rays and delta tracking.

pub mod cull;
pub mod dda;
pub mod distance;
pub mod hierarchy;
pub mod majorant;
pub mod open_sky;
pub mod skip;
pub mod strides;

pub use hierarchy::{Hierarchy, Step};
pub use skip::{ClearBoxes, FixedCells, IsoSides, RunningMax, RunningMin};

use glam::Vec3;

/// A ray in voxel coordinates: `o + t·d`, with `t` the world-space ray
/// parameter (the direction is the world direction divided by the
/// spacing), and `d`'s element-wise reciprocal in f64 (infinite along
/// axes the ray does not move along).
#[derive(Clone, Copy, Debug)]
pub struct VoxelRay {
    /// Origin, voxel units.
    pub o: Vec3,
    /// Direction, voxels per unit of the ray parameter.
    pub d: Vec3,
    /// `1 / d` per axis.
    pub inv_d: [f64; 3],
    /// The octant `d` points into (see [`distance::octant`]).
    pub octant: usize,
}

impl VoxelRay {
    /// The voxel-space ray with origin `o` and direction `d`.
    pub fn new(o: Vec3, d: Vec3) -> VoxelRay {
        VoxelRay {
            o,
            d,
            inv_d: d.to_array().map(|c| 1.0 / c as f64),
            octant: distance::octant(d.to_array()),
        }
    }

    /// The point at ray parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Empty-space skipping under one rule, as the march loop sees it. `Q` is
/// what the ray's own state adds to the rule (`()` for rules fixed for the
/// frame, the running value for MIP, the side for iso).
pub trait Accel<Q: Copy>: Sync {
    /// Whether this type can skip at all (the loop leaves the skipping
    /// code out when it cannot).
    const ON: bool;
    /// Whether this value skips in this frame (a rule that is off, such as
    /// `None` for an `Option` of a rule, answers `false`, and the loop
    /// then takes every sample without asking it).
    #[inline(always)]
    fn active(&self) -> bool {
        Self::ON
    }
    /// What to do at voxel-space point `p` of `ray`.
    fn step(&self, p: Vec3, ray: &VoxelRay, q: Q) -> Step;
    /// The rule's per-frame flag of a level-0 cell (0 when it has none).
    fn flag(&self, _cell: usize) -> u8 {
        0
    }
    /// Whether this frame's steps are adaptive: a sample in a busy
    /// level-0 cell stands for `2^stride_log2(cell)` steps.
    #[inline(always)]
    fn strided(&self) -> bool {
        false
    }
    /// `log2` of the steps one sample in busy level-0 cell `cell` stands
    /// for (see [`strides`]); 0 when steps are not adaptive.
    #[inline(always)]
    fn stride_log2(&self, _cell: usize) -> u32 {
        0
    }
}

/// No skipping: every sample is taken.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoSkipping;

impl<Q: Copy> Accel<Q> for NoSkipping {
    const ON: bool = false;
    #[inline(always)]
    fn step(&self, _: Vec3, _: &VoxelRay, _: Q) -> Step {
        Step::Busy {
            exit: f32::INFINITY,
            cell: 0,
        }
    }
}

impl<Q: Copy, A: Accel<Q>> Accel<Q> for &A {
    const ON: bool = A::ON;
    #[inline(always)]
    fn active(&self) -> bool {
        (**self).active()
    }
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, q: Q) -> Step {
        (**self).step(p, ray, q)
    }
    #[inline(always)]
    fn flag(&self, cell: usize) -> u8 {
        (**self).flag(cell)
    }
    #[inline(always)]
    fn strided(&self) -> bool {
        (**self).strided()
    }
    #[inline(always)]
    fn stride_log2(&self, cell: usize) -> u32 {
        (**self).stride_log2(cell)
    }
}

/// A rule that is on for some frames and off for others: one compiled
/// loop serves both (with `None` the loop asks nothing, as for
/// [`NoSkipping`], deciding so once per ray).
impl<Q: Copy, A: Accel<Q>> Accel<Q> for Option<A> {
    const ON: bool = A::ON;
    #[inline(always)]
    fn active(&self) -> bool {
        self.as_ref().is_some_and(|a| a.active())
    }
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, q: Q) -> Step {
        match self {
            Some(a) => a.step(p, ray, q),
            None => Step::Busy {
                exit: f32::INFINITY,
                cell: 0,
            },
        }
    }
    #[inline(always)]
    fn flag(&self, cell: usize) -> u8 {
        self.as_ref().map_or(0, |a| a.flag(cell))
    }
    #[inline(always)]
    fn strided(&self) -> bool {
        self.as_ref().is_some_and(|a| a.strided())
    }
    #[inline(always)]
    fn stride_log2(&self, cell: usize) -> u32 {
        self.as_ref().map_or(0, |a| a.stride_log2(cell))
    }
}
