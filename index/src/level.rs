//! One level of the macrocell pyramid and the reduction to the next one.
//!
//! Level 0 has cells of `N` voxels per axis; level `l` has cells of
//! `N·2^l` voxels, each the union of the (up to) 2×2×2 level `l − 1` cells
//! it covers. Along an axis of `d` voxels level 0 has `ceil(d / N)` cells and
//! each coarser level `ceil(previous / 2)`, down to a single cell. Cells are
//! stored x fastest: index = cx + nx·(cy + ny·cz).

use crate::error::IndexError;
use crate::rangemax::RangeMaxTable;
use rayon::prelude::*;
use volcore::grid::clamp_axis;
use volcore::Dims;

/// The cell ranges of one pyramid level.
#[derive(Clone, Debug)]
pub struct Level {
    cells: [u64; 3],
    edge: u64,
    min: Vec<f32>,
    max: Vec<f32>,
}

/// Cells per axis of every level for `dims` and level-0 cell edge `edge`,
/// finest first, ending with `[1, 1, 1]`.
pub fn level_shapes(dims: Dims, edge: u32) -> Vec<[u64; 3]> {
    let e = u64::from(edge.max(1));
    let mut cells = dims.as_array().map(|d| d.div_ceil(e));
    let mut out = vec![cells];
    while cells != [1, 1, 1] {
        cells = cells.map(|c| c.div_ceil(2));
        out.push(cells);
    }
    out
}

/// Number of cells in a level of shape `cells`, checked to fit a `usize`.
pub(crate) fn cell_count(cells: [u64; 3]) -> Result<usize, IndexError> {
    cells[0]
        .checked_mul(cells[1])
        .and_then(|n| n.checked_mul(cells[2]))
        .and_then(|n| usize::try_from(n).ok())
        .ok_or_else(|| {
            IndexError::TooLarge(format!(
                "{}x{}x{} cells overflow the address space",
                cells[0], cells[1], cells[2]
            ))
        })
}

/// `len` zeroed values, allocated fallibly (a volume's header can ask for
/// any size). The pages are zeroed by the system when first touched, so
/// an array that is about to be overwritten costs nothing here, and the
/// threads that first write each part pay for it in parallel.
pub(crate) fn try_zeroed(len: usize) -> Result<Vec<f32>, IndexError> {
    bytemuck::allocation::try_zeroed_vec(len)
        .map_err(|()| IndexError::TooLarge(format!("{len} cells do not fit in memory")))
}

impl Level {
    /// A level from its parts; `min` and `max` hold one value per cell.
    pub(crate) fn from_parts(
        cells: [u64; 3],
        edge: u64,
        min: Vec<f32>,
        max: Vec<f32>,
    ) -> Result<Level, IndexError> {
        let n = cell_count(cells)?;
        if min.len() != n || max.len() != n {
            return Err(IndexError::Corrupt(format!(
                "level of {n} cells given {} minima and {} maxima",
                min.len(),
                max.len()
            )));
        }
        Ok(Level {
            cells,
            edge,
            min,
            max,
        })
    }

    /// The level of the volume with x and z swapped: cell `(cx, cy, cz)`
    /// of the result is cell `(cz, cy, cx)` of this one.
    pub(crate) fn transposed_xz(&self) -> Level {
        let [nx, ny, nz] = self.cells;
        let cells = [nz, ny, nx];
        let (mut min, mut max) = (
            Vec::with_capacity(self.len()),
            Vec::with_capacity(self.len()),
        );
        // Output order (x fastest in the result) is z fastest here.
        for cx in 0..nx {
            for cy in 0..ny {
                let row = self.index(cx, cy, 0);
                let plane = (nx * ny) as usize;
                for cz in 0..nz as usize {
                    min.push(self.min[row + cz * plane]);
                    max.push(self.max[row + cz * plane]);
                }
            }
        }
        Level {
            cells,
            edge: self.edge,
            min,
            max,
        }
    }

    /// Cells along x, y, z.
    pub fn cells(&self) -> [u64; 3] {
        self.cells
    }

    /// Edge of one cell in voxels (`N·2^level`).
    pub fn edge(&self) -> u64 {
        self.edge
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.min.len()
    }

    /// Whether the level has no cells (never true for a built index).
    pub fn is_empty(&self) -> bool {
        self.min.is_empty()
    }

    /// Per-cell minima, x fastest (`+inf` for an empty cell).
    pub fn min(&self) -> &[f32] {
        &self.min
    }

    /// Per-cell maxima, x fastest (`−inf` for an empty cell).
    pub fn max(&self) -> &[f32] {
        &self.max
    }

    /// Linear index of cell `(cx, cy, cz)`.
    #[inline(always)]
    pub fn index(&self, cx: u64, cy: u64, cz: u64) -> usize {
        (cx + self.cells[0] * (cy + self.cells[1] * cz)) as usize
    }

    /// `(min, max)` of cell `(cx, cy, cz)`. Panics if the cell is outside
    /// the level.
    #[inline(always)]
    pub fn range(&self, cx: u64, cy: u64, cz: u64) -> (f32, f32) {
        let i = self.index(cx, cy, cz);
        (self.min[i], self.max[i])
    }

    /// The cell holding a point in voxel coordinates, after the sampler's
    /// clamping to the volume `dims` (NaN clamps to 0): the cell whose range
    /// bounds the trilinear value at `p`.
    #[inline]
    pub fn cell_of(&self, p: [f32; 3], dims: Dims) -> [u64; 3] {
        let d = dims.as_array();
        std::array::from_fn(|a| {
            let base = clamp_axis(p[a], d[a]) as u64;
            (base / self.edge).min(self.cells[a] - 1)
        })
    }

    /// Whether cell `i` (linear index) holds no value above `threshold`:
    /// its maximum is `<= threshold` or its range is empty.
    #[inline]
    pub fn is_empty_cell(&self, i: usize, threshold: f32) -> bool {
        self.max[i] <= threshold || self.min[i] > self.max[i]
    }

    /// The largest table value over each cell's range, x fastest: the
    /// per-cell majorant for the transfer function behind `table` (0 for
    /// empty cells).
    pub fn majorants(&self, table: &RangeMaxTable) -> Vec<f32> {
        self.min
            .par_iter()
            .zip(&self.max)
            .map(|(&lo, &hi)| table.max_over(lo, hi))
            .collect()
    }

    /// Per cell, x fastest: whether the function behind `table` is at most
    /// 0 over the cell's whole range (empty cells: yes), which is
    /// `majorants(table)[i] <= 0.0` without the majorants. Cells are taken
    /// in parallel runs.
    pub fn zero_cells(&self, table: &RangeMaxTable) -> Vec<bool> {
        const RUN: usize = 1 << 14;
        let mut out = vec![false; self.min.len()];
        out.par_chunks_mut(RUN)
            .zip(self.min.par_chunks(RUN).zip(self.max.par_chunks(RUN)))
            .for_each(|(out, (lo, hi))| {
                for ((o, &a), &b) in out.iter_mut().zip(lo).zip(hi) {
                    *o = table.zero_over(a, b);
                }
            });
        out
    }

    /// The next coarser level: each cell the union of its 2×2×2 children
    /// (fewer at the far faces).
    pub(crate) fn coarsen(&self) -> Result<Level, IndexError> {
        let cells = self.cells.map(|c| c.div_ceil(2));
        let n = cell_count(cells)?;
        // Every parent cell is written below.
        let mut min = try_zeroed(n)?;
        let mut max = try_zeroed(n)?;
        let plane = (cells[0] * cells[1]) as usize;
        min.par_chunks_mut(plane)
            .zip(max.par_chunks_mut(plane))
            .enumerate()
            .for_each(|(k, (mn, mx))| self.coarsen_plane(cells, k as u64, mn, mx));
        Level::from_parts(cells, self.edge * 2, min, max)
    }

    /// Fill parent plane `k` of shape `cells` from this level: each child
    /// row is folded into its parent row pairwise, which vectorises (a
    /// loop over each parent's up to eight children would not).
    fn coarsen_plane(&self, cells: [u64; 3], k: u64, mn: &mut [f32], mx: &mut [f32]) {
        mn.fill(f32::INFINITY);
        mx.fill(f32::NEG_INFINITY);
        let c = self.cells;
        let (w, pw) = (c[0] as usize, cells[0] as usize);
        for z in 2 * k..(2 * k + 2).min(c[2]) {
            for y in 0..c[1] {
                let at = self.index(0, y, z);
                let parent = (y / 2) as usize * pw..(y / 2 + 1) as usize * pw;
                let kids = self.min[at..at + w]
                    .chunks(2)
                    .zip(self.max[at..at + w].chunks(2));
                for ((p_lo, p_hi), (lo, hi)) in
                    mn[parent.clone()].iter_mut().zip(&mut mx[parent]).zip(kids)
                {
                    // A lone child at the far face pairs with itself.
                    let (l, h) = (lo[0].min(lo[lo.len() - 1]), hi[0].max(hi[hi.len() - 1]));
                    *p_lo = p_lo.min(l);
                    *p_hi = p_hi.max(h);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_halve_down_to_one_cell() {
        let d = Dims::new(17, 8, 1).unwrap();
        assert_eq!(level_shapes(d, 8), vec![[3, 1, 1], [2, 1, 1], [1, 1, 1]]);
        assert_eq!(
            level_shapes(Dims::new(1, 1, 1).unwrap(), 8),
            vec![[1, 1, 1]]
        );
        assert_eq!(level_shapes(Dims::new(9, 9, 9).unwrap(), 8).len(), 2);
    }

    /// Over more cells than one parallel run, with empty cells (min above
    /// max) and NaN ranges among them.
    #[test]
    fn zero_cells_are_the_cells_with_no_positive_majorant() {
        let mut rng = fastrand::Rng::with_seed(4);
        let n = 40 * 30 * 20;
        let (mut min, mut max) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let a = rng.f32() * 260.0 - 2.0;
            let (lo, hi) = match rng.u8(..10) {
                0 => (f32::INFINITY, f32::NEG_INFINITY),
                1 => (f32::NAN, a),
                _ => (a, a + rng.f32() * 12.0),
            };
            min.push(lo);
            max.push(hi);
        }
        let l = Level::from_parts([40, 30, 20], 4, min, max).unwrap();
        let maxima: Vec<f32> = (0..256)
            .map(|v| f32::from((90..110).contains(&v)))
            .collect();
        let table = RangeMaxTable::from_bin_maxima(0.0, 255.0, maxima).unwrap();
        let want: Vec<bool> = l.majorants(&table).iter().map(|&m| m <= 0.0).collect();
        let got = l.zero_cells(&table);
        assert_eq!(got, want);
        assert!(got.iter().any(|&z| z) && got.iter().any(|&z| !z));
    }

    #[test]
    fn cell_of_clamps_like_the_sampler() {
        let d = Dims::new(17, 8, 1).unwrap();
        let l = Level::from_parts([3, 1, 1], 8, vec![0.0; 3], vec![0.0; 3]).unwrap();
        assert_eq!(l.cell_of([7.99, 3.0, 0.0], d), [0, 0, 0]);
        assert_eq!(l.cell_of([8.0, 3.0, 0.0], d), [1, 0, 0]);
        assert_eq!(l.cell_of([16.0, 99.0, 5.0], d), [2, 0, 0]);
        assert_eq!(l.cell_of([f32::NAN, -3.0, 0.5], d), [0, 0, 0]);
    }
}
