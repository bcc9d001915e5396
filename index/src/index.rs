//! The index itself: metadata, global statistics and the level pyramid,
//! with the queries renderers use while marching rays.

use crate::error::IndexError;
use crate::histogram::Histogram;
use crate::level::{level_shapes, Level};
use crate::memo::Memo;
use volcore::{Dims, SampleType};

/// Min/max macrocell pyramid of one volume, plus its value range and
/// histogram (see the crate docs).
#[derive(Clone, Debug)]
pub struct MinMaxIndex {
    dims: Dims,
    sample_type: SampleType,
    fingerprint: u64,
    range: (f32, f32),
    histogram: Histogram,
    levels: Vec<Level>,
    /// A value a renderer derived from the index (see [`Memo`]).
    memo: Memo,
}

/// Summary figures of an index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexStats {
    /// Smallest and largest non-NaN sample (`(+inf, −inf)` if none).
    pub value_range: (f32, f32),
    /// Fraction of level-0 cells that are empty for threshold 0: their
    /// maximum is `<= 0` or their range is empty.
    pub empty_fraction: f64,
    /// Level-0 cells.
    pub cells: u64,
    /// Number of levels.
    pub levels: usize,
    /// NaN samples in the volume.
    pub nan_count: u64,
}

impl MinMaxIndex {
    /// An index from its parts, checking that the levels form the pyramid
    /// `dims` and the level-0 edge call for.
    pub(crate) fn from_parts(
        dims: Dims,
        sample_type: SampleType,
        fingerprint: u64,
        range: (f32, f32),
        histogram: Histogram,
        levels: Vec<Level>,
    ) -> Result<MinMaxIndex, IndexError> {
        let edge = levels.first().map_or(0, |l| l.edge());
        let edge32 = u32::try_from(edge).unwrap_or(0);
        let shapes = level_shapes(dims, edge32);
        let consistent = edge32 > 0
            && shapes.len() == levels.len()
            && levels
                .iter()
                .zip(&shapes)
                .enumerate()
                .all(|(l, (lv, s))| lv.cells() == *s && lv.edge() == edge << l);
        if !consistent {
            return Err(IndexError::Corrupt(format!(
                "levels do not form the pyramid of a {dims} volume with cell edge {edge}"
            )));
        }
        Ok(MinMaxIndex {
            dims,
            sample_type,
            fingerprint,
            range,
            histogram,
            levels,
            memo: Memo::default(),
        })
    }

    /// The index of the volume with axes x and z swapped (a z-fastest
    /// volume is indexed as the x-fastest volume its storage order spells,
    /// then transposed: every per-cell range and global figure is the same
    /// under the swap, as the cells' bounds are the same on every axis).
    pub(crate) fn transposed_xz(self) -> MinMaxIndex {
        let d = self.dims;
        MinMaxIndex {
            dims: Dims::new(d.z, d.y, d.x).unwrap_or(d),
            levels: self.levels.iter().map(Level::transposed_xz).collect(),
            memo: Memo::default(),
            ..self
        }
    }

    /// The value `make` derives from this index under `key` (see [`Memo`]:
    /// kept from the last call with the same key and type, so a renderer's
    /// set-up for one transfer function is done once across frames). The
    /// key must name everything besides the index that the value depends
    /// on.
    pub fn memo<T: std::any::Any + Send + Sync, E>(
        &self,
        key: u64,
        make: impl FnOnce() -> Result<T, E>,
    ) -> Result<std::sync::Arc<T>, E> {
        self.memo.get_or_try(key, make)
    }

    /// Dimensions of the indexed volume.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Sample type of the indexed volume.
    pub fn sample_type(&self) -> SampleType {
        self.sample_type
    }

    /// The caller's fingerprint of the indexed volume.
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Level-0 cell edge in voxels.
    pub fn cell_edge(&self) -> u32 {
        // Checked to fit a u32 in `from_parts`.
        self.levels[0].edge() as u32
    }

    /// Smallest and largest non-NaN sample (`(+inf, −inf)` if none).
    pub fn value_range(&self) -> (f32, f32) {
        self.range
    }

    /// The sample histogram.
    pub fn histogram(&self) -> &Histogram {
        &self.histogram
    }

    /// Number of levels (level 0 finest, the last a single cell).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// All levels, finest first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Level `l`. Panics if `l >= level_count()`.
    pub fn level(&self, l: usize) -> &Level {
        &self.levels[l]
    }

    /// Cell edge in voxels at level `l` (`cell_edge · 2^l`).
    pub fn level_edge(&self, l: usize) -> u64 {
        self.levels[l].edge()
    }

    /// `(min, max)` of cell `(cx, cy, cz)` of level `l`; `(+inf, −inf)` for
    /// an empty cell. Panics if the cell is outside the level.
    #[inline]
    pub fn cell_range(&self, level: usize, cx: u64, cy: u64, cz: u64) -> (f32, f32) {
        self.levels[level].range(cx, cy, cz)
    }

    /// Fraction of level-0 cells that are empty for `threshold`: maximum
    /// `<= threshold`, or empty range (only NaNs).
    pub fn empty_fraction(&self, threshold: f32) -> f64 {
        let l = &self.levels[0];
        let empty = (0..l.len())
            .filter(|&i| l.is_empty_cell(i, threshold))
            .count();
        empty as f64 / l.len() as f64
    }

    /// Summary figures (empty fraction for threshold 0).
    pub fn stats(&self) -> IndexStats {
        IndexStats {
            value_range: self.range,
            empty_fraction: self.empty_fraction(0.0),
            cells: self.levels[0].len() as u64,
            levels: self.levels.len(),
            nan_count: self.histogram.nan_count(),
        }
    }

    /// Check that this index was built for a volume of `dims` and
    /// `sample_type`.
    pub fn check_volume(&self, dims: Dims, sample_type: SampleType) -> Result<(), IndexError> {
        if self.dims != dims {
            return Err(IndexError::Dims {
                found: self.dims,
                expected: dims,
            });
        }
        if self.sample_type != sample_type {
            return Err(IndexError::SampleType {
                found: self.sample_type,
                expected: sample_type,
            });
        }
        Ok(())
    }
}
