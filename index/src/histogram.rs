//! The sample histogram stored with the index: volcore's
//! ([`volcore::histogram`]), whose binning rule `vol-info --stats` follows
//! too.

pub use volcore::histogram::{bin_of, Histogram, DEFAULT_BINS, MAX_BINS};
