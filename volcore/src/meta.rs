//! Volume metadata: everything about a volume except its samples.

use crate::brick::BrickGeometry;
use crate::dims::Dims;
use crate::sample::SampleType;
use std::fmt;

/// How samples are ordered in storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// One array, x fastest, then y, then z: index = x + X·(y + Y·z).
    Sliced,
    /// Cubic bricks; see [`BrickGeometry`] for the apron and brick order.
    Bricked(BrickGeometry),
}

impl Layout {
    /// Short name: `sliced` or `bricked:B`.
    pub fn describe(&self) -> String {
        match self {
            Layout::Sliced => "sliced".into(),
            Layout::Bricked(g) => format!("bricked:{}", g.brick()),
        }
    }
}

/// How bricks are compressed on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    /// Stored as is.
    None,
    /// Each brick compressed on its own with zstd at this level.
    Zstd(i32),
}

/// The smallest and largest sample value. NaN samples are ignored; a volume
/// of only NaNs has the empty range (`min > max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    /// Smallest non-NaN sample.
    pub min: f64,
    /// Largest non-NaN sample.
    pub max: f64,
}

impl ValueRange {
    /// The empty range, identity of [`ValueRange::merge`].
    pub const EMPTY: ValueRange = ValueRange {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    /// Whether no sample contributed.
    pub fn is_empty(&self) -> bool {
        self.min > self.max
    }

    /// Widen to include `v` (NaN is ignored).
    #[inline]
    pub fn add(&mut self, v: f64) {
        if v < self.min {
            self.min = v;
        }
        if v > self.max {
            self.max = v;
        }
    }

    /// The union of two ranges.
    pub fn merge(self, o: ValueRange) -> ValueRange {
        ValueRange {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Range of a slice of samples, ignoring NaN.
    pub fn of<T: crate::Sample>(data: &[T]) -> ValueRange {
        let (lo, hi) = T::min_max(data);
        ValueRange {
            min: lo as f64,
            max: hi as f64,
        }
    }
}

/// Everything about a volume but its samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeMeta {
    /// Voxels per axis.
    pub dims: Dims,
    /// World distance between neighbouring voxels along x, y, z.
    pub spacing: [f32; 3],
    /// Stored sample type.
    pub sample_type: SampleType,
    /// Smallest and largest sample (may be empty when not yet known).
    pub range: ValueRange,
    /// Sample order in storage.
    pub layout: Layout,
    /// Per-brick compression (always `None` for sliced layouts).
    pub compression: Compression,
}

impl VolumeMeta {
    /// Metadata for a sliced, uncompressed volume with unit spacing.
    pub fn sliced(dims: Dims, sample_type: SampleType) -> VolumeMeta {
        VolumeMeta {
            dims,
            spacing: [1.0; 3],
            sample_type,
            range: ValueRange::EMPTY,
            layout: Layout::Sliced,
            compression: Compression::None,
        }
    }

    /// The far corner of the volume's box in world units,
    /// `(dims − 1)·spacing` per axis (the box starts at the origin: voxel
    /// `(i, j, k)` sits at `(i·sx, j·sy, k·sz)`).
    pub fn world_extent(&self) -> [f32; 3] {
        let d = self.dims.as_array();
        std::array::from_fn(|a| (d[a] - 1) as f32 * self.spacing[a])
    }

    /// The smallest of the three voxel spacings.
    pub fn min_spacing(&self) -> f32 {
        self.spacing.iter().copied().fold(f32::INFINITY, f32::min)
    }
}

impl fmt::Display for VolumeMeta {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} {} spacing {},{},{}",
            self.dims,
            self.sample_type,
            self.layout.describe(),
            self.spacing[0],
            self.spacing[1],
            self.spacing[2]
        )?;
        if let Compression::Zstd(l) = self.compression {
            write!(f, " zstd:{l}")?;
        }
        Ok(())
    }
}
