//! The end-to-end tests: they run the built tools on files and pipes. One
//! test binary with a module per topic, so that the workspace is linked
//! into one test executable instead of one per topic file. Run one topic
//! with a filter, e.g. `cargo test -p volkit --test it convert::`.
//!
//! `tests/fixtures/` holds the small files other tools wrote; tests find
//! them through `CARGO_MANIFEST_DIR`.

mod accuracy;
mod channels;
mod common;
mod convert;
mod dicom;
mod dicom_codecs;
mod dicom_enhanced;
mod dicom_export;
mod dicom_mosaic;
mod docs;
mod formats;
mod gen;
mod hard_cases;
mod index;
mod module_graph;
mod path;
mod preprocess;
mod psnr;
mod render;
mod scene;
mod shard;
mod stats;
mod time_series;
mod units;
mod vocabulary;

// The data-parallel renderer under mpirun: only with the cargo feature
// `mpi`, which scripts/test.sh runs on its own (`--test it mpi::`).
#[cfg(feature = "mpi")]
mod mpi;
