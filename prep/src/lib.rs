//! volprep: the preprocessing operations of `vol-convert` (and the Python
//! package), as streaming stages over z slices of `f32` samples.
//!
//! A [`Stage`] turns the slices of one [`Grid`] into the slices of another:
//! output slice `z` reads a bounded run of input slices
//! ([`Stage::needs`]), so a [`Chain`] of stages holds only the slabs its
//! stages need, whatever the volume's size. The stages apply in one fixed
//! order (select → crop → orient → resample → smooth / median → clamp /
//! threshold / mask → type and window → write); this crate holds the
//! kernels from orient to mask, one module each.
//!
//! - [`grid`]: where samples lie (dims, spacing, origin, directions).
//! - [`stage`]: the stage interface and the slab a stage reads.
//! - [`chain`]: runs stages one after another with bounded memory.
//! - the stages, in their order: [`orient`], [`resample`], [`gauss`],
//!   [`median`], [`pointwise`] (clamp, threshold, mask).

pub mod chain;
pub mod gauss;
pub mod grid;
pub mod median;
pub mod orient;
pub mod pointwise;
pub mod resample;
pub mod stage;

pub use chain::Chain;
pub use grid::Grid;
pub use stage::{Slab, Stage, SLAB_BUDGET};
