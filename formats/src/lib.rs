//! volformats: reading and writing volume files.
//!
//! - [`vvol`]: volkit's native format (sliced or bricked, optional zstd per
//!   brick, memory-mappable, streamable through pipes); see `FORMAT.md`.
//! - [`thesis`]: the `.vol` format of the thesis generator (`vol_gen`).
//! - [`raw`]: headerless sample arrays, Open SciVis naming.
//! - [`tiff`], [`nrrd`], [`mhd`]: TIFF stacks, NRRD and MetaImage, and
//!   [`convert`], which turns any input into any output slice by slice.
//! - [`image`]: the image files tools write (8-bit PNG, PFM, heat maps).
//! - [`prepflags`]: the preprocessing flags (`--resample`, `--orient`,
//!   `--smooth`, ...), resolved into the stages [`convert`] runs through
//!   the `volprep` kernels.
//! - [`reader`] and [`slice`](mod@slice): what every reader hands out (z slices of any
//!   sample type, errors located at a file), below the readers, [`open`](mod@open)
//!   and [`convert`]; `tests/it/module_graph.rs` keeps the modules free of
//!   import cycles.
//!
//! Writers pull samples from a [`volcore::RegionSource`] and produce them in
//! parallel batches that one thread writes in file order
//! ([`pipeline::ordered`]), so memory stays bounded whatever the volume size.
//! Output files go through [`output::AtomicFile`]: written under a temporary
//! name and renamed into place only on success.

pub mod convert;
pub mod datafile;
pub mod detect;
pub mod dicom;
pub mod error;
pub mod fingerprint;
pub mod gzip;
pub mod image;
pub mod mhd;
pub mod nifti;
pub mod nrrd;
pub mod omezarr;
pub mod open;
pub mod output;
pub mod pipeline;
pub mod prepflags;
pub mod raw;
pub mod reader;
pub mod rescale;
pub mod select;
pub mod slice;
pub mod stacks;
pub mod stream;
pub mod thesis;
pub mod tiff;
pub mod vvol;

pub use detect::FileKind;
pub use error::{Error, Result};
pub use fingerprint::fingerprint;
pub use open::{open, open_input, open_volume, ReadOptions};
pub use prepflags::PrepFlags;
pub use select::Selection;

#[cfg(test)]
mod tests;
