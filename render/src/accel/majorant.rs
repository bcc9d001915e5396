//! Majorants: per macrocell, an upper bound of the extinction any sample
//! in it can take, for shadow rays and delta (Woodcock) tracking. The
//! index's value ranges go through a function of the range (a transfer
//! function's range-maximum table, or a density mapping), once per frame.

use volindex::{MinMaxIndex, RangeMaxTable};

/// The largest extinction a medium takes, per world unit: a transfer
/// function's opacity 1 (infinite optical depth) is this, so tracking
/// stays finite (a unit of it transmits `e^−1e6`, nothing).
pub const MAX_SIGMA_T: f32 = 1e6;

/// Per-cell majorants of one index level.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    level: usize,
    values: Vec<f32>,
    /// Per cell, a control extinction for residual ratio tracking (empty:
    /// none, every control 0).
    controls: Vec<f32>,
    global: f32,
}

/// The value range `(min, max)` of every cell of `index`'s level `level`,
/// in cell order.
fn ranges(index: &MinMaxIndex, level: usize) -> impl Iterator<Item = (f32, f32)> + '_ {
    let l = index.level(level);
    l.min().iter().copied().zip(l.max().iter().copied())
}

/// `b` clamped to `[0, cap]`, NaN taken as 0.
fn clamp_positive(b: f32, cap: f32) -> f32 {
    // NaN fails the comparison: 0.
    if b > 0.0 {
        b.min(cap)
    } else {
        0.0
    }
}

impl MajorantGrid {
    /// Majorants of `index`'s level `level` from `bound(lo, hi)`, which
    /// must bound the extinction of every value in `[lo, hi]` (cells whose
    /// range is empty, `lo > hi`, hold only NaN and get 0). Every majorant
    /// is finite: clamped to `[0, MAX_SIGMA_T]`, a NaN bound taken as 0
    /// (the media clamp their extinction alike).
    pub fn from_ranges(
        index: &MinMaxIndex,
        level: usize,
        bound: impl Fn(f32, f32) -> f32,
    ) -> MajorantGrid {
        let values: Vec<f32> = ranges(index, level)
            .map(|(lo, hi)| {
                if lo > hi {
                    0.0
                } else {
                    clamp_positive(bound(lo, hi), MAX_SIGMA_T)
                }
            })
            .collect();
        let global = values.iter().copied().fold(0.0, f32::max);
        MajorantGrid {
            level,
            values,
            controls: Vec::new(),
            global,
        }
    }

    /// The grid with a control extinction per cell from `control(lo, hi)`
    /// over the cell's value range, for residual ratio tracking: a value
    /// near the smallest extinction in the cell (the residual majorant is
    /// the cell's majorant less it). Controls are clamped to `[0, majorant]`
    /// (a NaN control is 0), so the residual majorant is never negative.
    pub fn with_controls(
        mut self,
        index: &MinMaxIndex,
        control: impl Fn(f32, f32) -> f32,
    ) -> MajorantGrid {
        self.controls = ranges(index, self.level)
            .zip(&self.values)
            .map(|((lo, hi), &m)| {
                if lo > hi || m <= 0.0 {
                    0.0
                } else {
                    clamp_positive(control(lo, hi), m)
                }
            })
            .collect();
        self
    }

    /// The control extinction of the cell with linear index `cell` (0
    /// without controls).
    #[inline(always)]
    pub fn control(&self, cell: usize) -> f32 {
        self.controls.get(cell).copied().unwrap_or(0.0)
    }

    /// Majorants from a table of extinction per value bin: each cell's
    /// largest table value over its range.
    pub fn from_table(index: &MinMaxIndex, level: usize, table: &RangeMaxTable) -> MajorantGrid {
        MajorantGrid::from_ranges(index, level, |lo, hi| table.max_over(lo, hi))
    }

    /// The level the grid is for.
    pub fn level(&self) -> usize {
        self.level
    }

    /// The majorant of the cell with linear index `cell`.
    #[inline(always)]
    pub fn get(&self, cell: usize) -> f32 {
        self.values[cell]
    }

    /// The largest majorant: one bound for the whole volume.
    pub fn global(&self) -> f32 {
        self.global
    }

    /// Per cell, 1 where the majorant is 0 (a sample there has no
    /// extinction).
    pub fn empty_flags(&self) -> Vec<u8> {
        self.values.iter().map(|&m| u8::from(m <= 0.0)).collect()
    }

    /// The fraction of cells whose majorant is 0 (crossed without a
    /// sample).
    pub fn empty_fraction(&self) -> f64 {
        let n = self.values.iter().filter(|&&m| m == 0.0).count();
        n as f64 / self.values.len().max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use volcore::region::pack_sliced;
    use volcore::scene::{NoiseKind, NoiseScene, SceneSource};
    use volcore::{Dims, Volume};
    use volindex::BuildOptions;

    /// Every trilinear sample inside a cell has extinction at most the
    /// cell's majorant, for a density mapping and for a table.
    #[test]
    fn majorants_bound_every_sample_in_their_cell() {
        let dims = Dims::new(40, 33, 29).unwrap();
        let v = Volume::from_samples(
            dims,
            pack_sliced(&SceneSource::<f32>::new(&NoiseScene::new(
                dims,
                9,
                NoiseKind::Gradient,
                9.0,
                3,
                255.0,
            ))),
        )
        .unwrap();
        let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
        let density = |x: f32| 0.3 * x.max(0.0) / 255.0;
        let table = RangeMaxTable::from_fn(-255.0, 255.0, 512, |x| (x / 100.0).powi(2)).unwrap();
        let sq = |x: f32| (x / 100.0).powi(2);
        for level in 0..ix.level_count() {
            let g = MajorantGrid::from_ranges(&ix, level, |_, hi| density(hi));
            let t = MajorantGrid::from_table(&ix, level, &table);
            let l = ix.level(level);
            let e = l.edge() as f32;
            let mut rng = fastrand::Rng::with_seed(level as u64);
            for _ in 0..4000 {
                let p = Vec3::new(rng.f32() * 39.0, rng.f32() * 32.0, rng.f32() * 28.0);
                let c = p.to_array().map(|x| (x / e) as u64);
                let i = l.index(c[0], c[1], c[2]);
                let s = v.trilinear(p.into());
                assert!(density(s) <= g.get(i), "level {level} at {p}");
                // The table is exact at bin edges only, with its slack; the
                // square is convex, so a bin's maximum is at an edge.
                assert!(
                    sq(s) <= t.get(i) * (1.0 + 1e-6) + 1e-6,
                    "level {level} at {p}"
                );
            }
            assert!(g.global() >= g.get(0));
        }
    }
}
