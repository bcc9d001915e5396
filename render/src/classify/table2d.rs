//! The 2D lookup table over (value, gradient magnitude), and which
//! macrocells it leaves transparent.
//!
//! Skipping stays exact: a cell is transparent only if no (value,
//! gradient) pair it can produce has nonzero opacity. Values are bounded
//! by the cell's range in the index. Gradient magnitudes are bounded per
//! cell from ranges too: the analytic gradient of a trilinear cell has
//! components that are blends of differences of its corners, so each is
//! at most the cell's own range; a central difference `(f(p + e) −
//! f(p − e))/2` along an axis reads at most one voxel past the cell along
//! that axis, so that component is at most half the range over the cell
//! and its two neighbours along the axis. A
//! rounding allowance is added, and the per-axis bounds are scaled by the
//! inverse spacing. Coarser levels are transparent when all their
//! children are.

use super::table::{Bins, TfTable};
use super::{entry, Classifier, GradientBound};
use crate::error::RenderError;
use crate::settings::GradientMethod;
use crate::tf::TransferFunction2d;
use rayon::prelude::*;
use volindex::{MinMaxIndex, RangeMaxTable};

/// Gradient-magnitude bins of a 2D table.
pub const GRADIENT_BINS: usize = 64;

/// A 2D transfer function sampled at the centres of value and gradient
/// bins, opacities corrected for the frame's step; colours linear.
#[derive(Clone, Debug)]
pub struct TfTable2d {
    values: Bins,
    gradients: Bins,
    /// `[r, g, b, alpha]`, gradient-major: `entries[gb · nv + vb]`.
    entries: Vec<[f32; 4]>,
}

impl TfTable2d {
    /// Sample `tf` over values `[lo, hi]` in `value_bins` bins (the same
    /// bins a 1D table would use) and gradients `[glo, ghi]` in
    /// `gradient_bins`, for a step of `step` world units.
    pub fn new(
        tf: &TransferFunction2d,
        (lo, hi): (f32, f32),
        value_bins: usize,
        (glo, ghi): (f32, f32),
        gradient_bins: usize,
        step: f32,
    ) -> TfTable2d {
        let values = Bins::new(lo, hi, value_bins);
        let gradients = Bins::new(glo, ghi, gradient_bins.clamp(1, 4096));
        let ratio = step as f64 / tf.base.reference_step as f64;
        let (nv, ng) = (values.count(), gradients.count());
        let entries = (0..nv * ng)
            .into_par_iter()
            .map(|i| {
                let (rgb, alpha) = tf.eval(values.centre(i % nv), gradients.centre(i / nv));
                entry(rgb, alpha, ratio)
            })
            .collect();
        TfTable2d {
            values,
            gradients,
            entries,
        }
    }

    /// Number of entries (value bins × gradient bins).
    pub fn entries(&self) -> usize {
        self.entries.len()
    }

    /// The value domain.
    pub fn domain(&self) -> (f32, f32) {
        self.values.domain()
    }

    /// The gradient-magnitude domain.
    pub fn gradient_domain(&self) -> (f32, f32) {
        self.gradients.domain()
    }

    /// `[r, g, b, alpha]` at value `v` and gradient magnitude `g`; a NaN
    /// value is transparent, a NaN gradient falls in the first bin.
    #[inline(always)]
    pub fn lookup(&self, v: f32, g: f32) -> [f32; 4] {
        if v.is_nan() {
            return [0.0; 4];
        }
        let i = self.gradients.bin(g) * self.values.count() + self.values.bin(v);
        self.entries[i]
    }

    /// For each gradient bin `j`: the largest opacity over gradient bins
    /// `0..=j`, per value bin, as a range-maximum table over values.
    fn prefix_bounds(&self) -> Result<Vec<RangeMaxTable>, RenderError> {
        let nv = self.values.count();
        let (lo, hi) = self.values.domain();
        let mut running = vec![0.0f32; nv];
        let mut out = Vec::with_capacity(self.gradients.count());
        for row in self.entries.chunks_exact(nv) {
            for (m, e) in running.iter_mut().zip(row) {
                *m = m.max(e[3]);
            }
            out.push(
                RangeMaxTable::from_bin_maxima(lo, hi, running.clone())
                    .map_err(|e| RenderError::Index(e.to_string()))?,
            );
        }
        Ok(out)
    }
}

impl Classifier for TfTable2d {
    const NEEDS_GRADIENT: bool = true;

    #[inline(always)]
    fn classify(&self, v: f32, gradient: f32) -> [f32; 4] {
        self.lookup(v, gradient)
    }

    fn to_optical_depth(&self) -> Self {
        let mut t = self.clone();
        for e in &mut t.entries {
            e[3] = super::optical_depth(e[3]);
        }
        t
    }

    fn transparent_cells(
        &self,
        index: &MinMaxIndex,
        gb: &GradientBound,
    ) -> Result<Vec<Vec<bool>>, RenderError> {
        let bounds = self.prefix_bounds()?;
        let l0 = index.level(0);
        let (lo, hi) = (l0.min(), l0.max());
        let cells = l0.cells();
        // Per axis, the range the gradient's component along it can span:
        // the cell's own (analytic), or the cell's and its two neighbours
        // along that axis (central differences reach one voxel into them);
        // central differences halve it.
        let axis_ranges: Vec<(Vec<f32>, Vec<f32>)> = (0..3)
            .map(|a| match gb.method {
                GradientMethod::Analytic => (lo.to_vec(), hi.to_vec()),
                GradientMethod::Central => (
                    dilate_axis(lo, cells, a, f32::min),
                    dilate_axis(hi, cells, a, f32::max),
                ),
            })
            .collect();
        let half = match gb.method {
            GradientMethod::Analytic => 1.0f32,
            GradientMethod::Central => 0.5,
        };
        let inv = gb.inv_spacing;
        let level0: Vec<bool> = (0..lo.len())
            .into_par_iter()
            .map(|i| {
                if lo[i] > hi[i] {
                    return true;
                }
                let mut g2 = 0.0f32;
                for (a, (rlo, rhi)) in axis_ranges.iter().enumerate() {
                    let (x, y) = (rlo[i], rhi[i]);
                    // Rounding: a few ulps of the largest magnitude involved.
                    let slack = 8.0 * f32::EPSILON * x.abs().max(y.abs());
                    let c = ((y - x) * half + slack) * inv[a];
                    g2 += c * c;
                }
                let g = g2.sqrt() * (1.0 + 1e-4);
                let j = if g.is_finite() {
                    self.gradients.bin(g)
                } else {
                    self.gradients.count() - 1
                };
                bounds[j].max_over(lo[i], hi[i]) <= 0.0
            })
            .collect();
        let mut out = vec![level0];
        for l in 1..index.level_count() {
            let (fine, coarse) = (index.level(l - 1), index.level(l));
            let below = &out[l - 1];
            let fc = fine.cells();
            let cc = coarse.cells();
            let flags = (0..coarse.len())
                .into_par_iter()
                .map(|i| {
                    let i = i as u64;
                    let c = [i % cc[0], (i / cc[0]) % cc[1], i / (cc[0] * cc[1])];
                    let mut all = true;
                    for dz in 0..2 {
                        for dy in 0..2 {
                            for dx in 0..2 {
                                let f = [2 * c[0] + dx, 2 * c[1] + dy, 2 * c[2] + dz];
                                if f[0] < fc[0] && f[1] < fc[1] && f[2] < fc[2] {
                                    all &= below[fine.index(f[0], f[1], f[2])];
                                }
                            }
                        }
                    }
                    all
                })
                .collect();
            out.push(flags);
        }
        Ok(out)
    }
}

/// Each cell's value of `op` over itself and its two neighbours along
/// `axis` (one at the faces).
fn dilate_axis(data: &[f32], cells: [u64; 3], axis: usize, op: fn(f32, f32) -> f32) -> Vec<f32> {
    let [nx, ny, nz] = cells.map(|c| c as usize);
    let (stride, n) = match axis {
        0 => (1, nx),
        1 => (nx, ny),
        _ => (nx * ny, nz),
    };
    (0..data.len())
        .into_par_iter()
        .map(|i| {
            let c = (i / stride) % n;
            let mut v = data[i];
            if c > 0 {
                v = op(v, data[i - stride]);
            }
            if c + 1 < n {
                v = op(v, data[i + stride]);
            }
            v
        })
        .collect()
}

/// Whether a 1D and a 2D table bin values the same way (then a 2D function
/// constant along the gradient axis classifies exactly as the 1D one).
pub fn same_value_bins(a: &TfTable, b: &TfTable2d) -> bool {
    a.domain() == b.domain() && a.bins() == b.values.count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dilation_reaches_one_cell_along_its_axis() {
        let cells = [3u64, 2, 2];
        let mut d = vec![0.0f32; 12];
        d[4] = 5.0; // cell (1, 1, 0)
        let want = |axis: usize| -> Vec<usize> {
            match axis {
                0 => vec![3, 4, 5],
                1 => vec![1, 4],
                _ => vec![4, 10],
            }
        };
        for axis in 0..3 {
            let m = dilate_axis(&d, cells, axis, f32::max);
            for (i, v) in m.iter().enumerate() {
                let hit = want(axis).contains(&i);
                assert_eq!(*v, if hit { 5.0 } else { 0.0 }, "axis {axis} cell {i}");
            }
        }
    }
}
