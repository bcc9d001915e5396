//! volindex: the empty-space-skipping (majorant) index of a volume.
//!
//! A [`MinMaxIndex`] splits the volume into *macrocells* of `N³` voxels
//! (default `N = 8`) and stores, per cell, the smallest and largest sample
//! of the cell's interpolation footprint: along each axis cell `c` covers
//! the points `[c·N, c·N + N)` and therefore reads voxels `c·N ..= c·N + N`
//! (one voxel of apron on the far side, clamped to the volume). Every
//! trilinear value inside the cell is a blend of those voxels, so it lies in
//! the stored range (each blend `a + (b − a)·t` has `0 <= t < 1`; the tests
//! check this with `volcore`'s own sampler, for `f32` samples too).
//! Coarser [`Level`]s hold the range over 2×2×2 children,
//! down to a single cell, so a ray can skip large empty regions at once.
//!
//! The index does not depend on the transfer function: a renderer builds a
//! [`RangeMaxTable`] from its transfer function once and asks it, per cell,
//! for the largest opacity (or extinction) over the cell's value range.
//!
//! NaN rule: NaN samples are ignored everywhere (cell ranges, the global
//! range, the histogram, which counts them apart). A cell whose footprint
//! holds only NaNs has the empty range `(+inf, −inf)` and counts as empty.
//! An interpolated value that blends a NaN is NaN and is not bounded.
//!
//! The index is built in one parallel pass over the samples in storage
//! order (see
//! [`build`]); it depends only on the sample values, never on the layout or
//! the thread count. It can be saved as a `.vidx` sidecar file ([`vidx`],
//! format in `FORMAT.md`).

#![warn(missing_docs)]

pub mod build;
pub mod error;
pub mod histogram;
pub mod index;
pub mod level;
pub mod memo;
mod piece;
pub mod rangemax;
mod scan;
pub mod shard;
pub mod vidx;
mod walk;

#[cfg(test)]
mod testutil;

pub use build::BuildOptions;
pub use error::IndexError;
pub use histogram::Histogram;
pub use index::{IndexStats, MinMaxIndex};
pub use level::Level;
pub use memo::Memo;
pub use rangemax::RangeMaxTable;
