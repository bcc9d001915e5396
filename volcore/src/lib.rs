//! volcore: the data model every volkit tool shares.
//!
//! A volume is a 3D grid of samples with [`Dims`], voxel spacing, a
//! [`SampleType`], a value range and a [`Layout`]. Samples are stored either
//! *sliced* (x fastest, then y, then z; or z fastest, as the thesis `.vol`
//! files are, sampled in place) or *bricked* (cubic bricks with an
//! apron so that interpolation and gradients never cross a brick), in memory,
//! in a memory map, or as zstd-compressed bricks decoded on demand.
//!
//! Renderers and analysis code reach the samples only through the
//! [`VoxelSource`] / [`Cursor`] interface, dispatched once per job from a
//! [`Volume`] with a [`VolumeVisitor`], so the inner loops are monomorphised
//! for one layout and one sample type.

pub mod brick;
pub mod cache;
pub mod dims;
pub mod error;
pub mod grid;
pub mod histogram;
pub mod lanes;
pub mod meta;
pub mod region;
pub mod sample;
pub mod scene;
pub mod shard;
pub mod storage;
pub mod text;
pub mod unit;
pub mod volume;

pub use brick::BrickGeometry;
pub use dims::Dims;
pub use error::{Error, Result};
pub use grid::{BrickedGrid, CompressedGrid, Cursor, SliceOrder, SlicedGrid, VoxelSource};
pub use meta::{Compression, Geometry, Layout, Narrowing, ValueRange, VolumeMeta};
pub use region::RegionSource;
pub use sample::{Sample, SampleType};
pub use shard::Shard;
pub use storage::Data;
pub use unit::LengthUnit;
pub use volume::{Volume, VolumeData, VolumeVisitor};
