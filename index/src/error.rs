//! Errors raised while building, reading or querying an index.

use volcore::{Dims, SampleType};

/// What went wrong with an index.
#[derive(Debug, thiserror::Error)]
pub enum IndexError {
    /// Build options out of their allowed range.
    #[error("invalid index options: {0}")]
    Options(String),
    /// The index of this volume would not fit in memory or in 64 bits.
    #[error("volume is too large to index: {0}")]
    TooLarge(String),
    /// The volume reported an error while its samples were read.
    #[error("reading the volume failed: {0}")]
    Source(String),
    /// A range-maximum table was given unusable parameters.
    #[error("invalid range table: {0}")]
    Table(String),
    /// The file does not start with the `.vidx` magic.
    #[error("not a volkit index file (bad magic bytes)")]
    BadMagic,
    /// The file has a format version this build cannot read.
    #[error(
        "unsupported index format version {found} (this build reads version {supported}): \
         rebuild the index with vol-index"
    )]
    Version {
        /// Version found in the file.
        found: u32,
        /// Version this build reads.
        supported: u32,
    },
    /// The file ends before the named section is complete.
    #[error("index file is truncated: it ends inside the {0}")]
    Truncated(&'static str),
    /// The index was built for another volume.
    #[error("index belongs to another volume: fingerprint {found:016x}, expected {expected:016x}")]
    Fingerprint {
        /// Fingerprint stored in the file.
        found: u64,
        /// Fingerprint of the volume at hand.
        expected: u64,
    },
    /// The index was built for a volume of other dimensions.
    #[error("index is for a {found} volume, but the volume is {expected}")]
    Dims {
        /// Dimensions stored in the file.
        found: Dims,
        /// Dimensions of the volume at hand.
        expected: Dims,
    },
    /// The index was built for another sample type.
    #[error("index is for {found} samples, but the volume has {expected} samples")]
    SampleType {
        /// Sample type stored in the file.
        found: SampleType,
        /// Sample type of the volume at hand.
        expected: SampleType,
    },
    /// The file is inconsistent (bad field, checksum, or contents).
    #[error("corrupt index file: {0}")]
    Corrupt(String),
    /// Shards that cannot be built or joined (missing, doubled, mixed).
    #[error("{0}")]
    Shard(String),
    /// An I/O failure other than a short read.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}
