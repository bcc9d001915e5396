//! The stage interface: one preprocessing operation, slice by slice.

use crate::grid::Grid;
use std::ops::Range;
use volcore::Dims;

/// How many bytes of `f32` slices one stage may hold at once. A stage
/// whose window of input slices would exceed it reads a copy of its input
/// on disk instead (mapped, so memory stays bounded), or is refused when
/// even that would be too slow (a median window, say).
pub const SLAB_BUDGET: u64 = 1 << 30;

/// Consecutive z slices of one grid (each `dims.x * dims.y` samples, x
/// fastest), as a stage reads them.
pub struct Slab<'a> {
    first: u64,
    dims: Dims,
    slices: Vec<&'a [f32]>,
}

impl<'a> Slab<'a> {
    /// Slices `first .. first + slices.len()` of a grid of `dims`.
    pub fn new(first: u64, dims: Dims, slices: Vec<&'a [f32]>) -> Slab<'a> {
        debug_assert!(slices.iter().all(|s| s.len() as u64 == dims.slice_len()));
        Slab {
            first,
            dims,
            slices,
        }
    }

    /// The dims of the grid the slices belong to.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// The z slices held.
    pub fn range(&self) -> Range<u64> {
        self.first..self.first + self.slices.len() as u64
    }

    /// Slice `z`. Panics when `z` is not held: a stage reads only what its
    /// [`Stage::needs`] asked for, so that is a bug in the stage.
    #[inline]
    pub fn slice(&self, z: u64) -> &'a [f32] {
        let i = z
            .checked_sub(self.first)
            .filter(|&i| (i as usize) < self.slices.len())
            .unwrap_or_else(|| panic!("slice {z} outside the slab {:?}", self.range()));
        self.slices[i as usize]
    }

    /// Slice `z` clamped to the slab's grid (0 .. dims.z): the replicate
    /// border rule every stage follows.
    #[inline]
    pub fn slice_clamped(&self, z: i64) -> &'a [f32] {
        let z = z.clamp(0, self.dims.z as i64 - 1) as u64;
        self.slice(z)
    }
}

/// One preprocessing operation from an input grid to an output grid,
/// computed one output z slice at a time from a bounded run of input
/// slices. Stages are pure: an output slice depends only on the input
/// samples, never on which slices were asked for before, so any order of
/// requests (threads, shards) gives the same bytes.
pub trait Stage: Send + Sync {
    /// Short name for messages (`resample`, `gauss`, `median`, ...).
    fn name(&self) -> &str;

    /// The grid this stage writes.
    fn output(&self) -> Grid;

    /// The input z slices that output slices `zs` read: a range inside
    /// `0 .. input.dims.z`. Its ends move up with `zs` for every stage
    /// but an orientation that reverses z, which reads down: the chain
    /// serves any order, and `vol-convert` copies a stream to disk first
    /// when it is oriented.
    fn needs(&self, zs: Range<u64>) -> Range<u64>;

    /// The most input slices one output slice reads (its window), for
    /// the memory budget: a stage that reads everything (a permutation
    /// that moves z) says the input's nz.
    fn window(&self) -> u64;

    /// Output slice `z` (x fastest, `output().dims`) into `out`, from
    /// `input`, which holds at least `needs(z..z + 1)`. Kernels do not
    /// fail; a stage that reads a second file (a mask) says why it could
    /// not, in one line that names the file.
    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String>;
}
