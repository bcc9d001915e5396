//! volformats: reading and writing volume files.
//!
//! Formats, each a reader beside its decoder (and a writer where volkit
//! writes it):
//! - [`vvol`]: volkit's native format (sliced or bricked, optional zstd per
//!   brick, memory-mappable, streamable through pipes); see `FORMAT.md`.
//! - [`thesis`]: the `.vol` format of the thesis generator (`vol_gen`).
//! - [`raw`]: headerless sample arrays, Open SciVis naming.
//! - [`tiff`], [`nrrd`], [`mhd`], [`nifti`]: TIFF stacks, NRRD, MetaImage
//!   and NIfTI-1/2; [`datafile`] is the sample file the last three
//!   describe, [`stream`] reads samples front to back from pipes and
//!   decompressors, [`gzip`] writes gzip on every core.
//! - [`dicom`]: DICOM series read as one volume.
//! - [`omezarr`]: OME-Zarr (NGFF 0.4 and 0.5), read and written with a
//!   multiscale pyramid.
//! - [`image`]: the image files tools write (8-bit PNG, PFM, heat maps).
//!
//! Opening and converting:
//! - [`open`](mod@open): the one way every tool opens a volume, whatever
//!   its format; [`select`] is what to read from an input that holds more
//!   than one volume (the input-selection flags), [`stacks`] how many
//!   channels and time points an input holds, [`rescale`] maps stored
//!   values to real ones as slices are read, [`stats`] streams an
//!   input's statistics (inside a mask, per label).
//! - [`convert`], which turns any input into any output slice by slice;
//!   [`prepflags`]: the preprocessing flags (`--resample`, `--orient`,
//!   `--smooth`, ...), resolved into the stages [`convert`] runs through
//!   the `volprep` kernels.
//! - [`output_kind`]: which native format an output path's extension
//!   names; [`fingerprint`](mod@fingerprint): a volume file's fingerprint, for sidecar
//!   files that must notice when it is replaced.
//!
//! Below them all:
//! - [`reader`] and [`slice`](mod@slice): what every reader hands out (z slices of any
//!   sample type, errors located at a file), below the readers, [`open`](mod@open)
//!   and [`convert`]; [`error`] is the errors of files; `tests/it/module_graph.rs`
//!   keeps the modules free of import cycles.
//! - [`pipeline`] and [`output`]: parallel production with in-order
//!   writing, and output files that appear only when complete.
//!
//! Writers pull samples from a [`volcore::RegionSource`] and produce them in
//! parallel batches that one thread writes in file order
//! ([`pipeline::ordered`]), so memory stays bounded whatever the volume size.
//! Output files go through [`output::AtomicFile`]: written under a temporary
//! name and renamed into place only on success.

pub mod convert;
pub mod datafile;
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
pub mod output_kind;
pub mod pipeline;
pub mod prepflags;
pub mod raw;
pub mod reader;
pub mod rescale;
pub mod select;
pub mod slice;
pub mod stacks;
pub mod stats;
pub mod stream;
pub mod thesis;
pub mod tiff;
pub mod vvol;

pub use error::{Error, Result};
pub use fingerprint::fingerprint;
pub use open::{open, open_input, open_volume, ReadOptions};
pub use output_kind::FileKind;
pub use prepflags::PrepFlags;
pub use select::{Selection, TimePoint};

#[cfg(test)]
mod tests;
