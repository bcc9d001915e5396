//! The axis-aligned path: the output's directions equal the input's, so
//! each output index reads a fixed run of input indices along each axis,
//! and the tensor product is computed one axis at a time (z, then y, then
//! x) from per-axis weight tables.

use super::kernel::AxisSampler;
use super::{inside, ZNeed};
use crate::stage::Slab;

/// One axis's weights: for each output index, the first input index and
/// `taps` weights (taps outside the volume already folded onto the edge).
pub(crate) struct Table {
    taps: usize,
    first: Vec<usize>,
    w: Vec<f32>,
    inside: Vec<bool>,
}

impl Table {
    /// Output index `u` at continuous input index `c0 + u·step`.
    pub(crate) fn new(s: &AxisSampler, n_out: u64, n_in: u64, c0: f64, step: f64) -> Table {
        let taps = s.taps();
        let mut first = Vec::with_capacity(n_out as usize);
        let mut w = vec![0.0f32; taps * n_out as usize];
        let mut ins = Vec::with_capacity(n_out as usize);
        for u in 0..n_out as usize {
            let c = c0 + u as f64 * step;
            first.push(s.weights(c, &mut w[u * taps..(u + 1) * taps]));
            ins.push(inside(c, n_in));
        }
        Table {
            taps,
            first,
            w,
            inside: ins,
        }
    }

    /// The input indices with a non-zero weight for output `u`, as a
    /// half-open range (a single index when every weight is zero).
    pub(crate) fn support(&self, u: usize) -> (u64, u64) {
        let w = &self.w[u * self.taps..(u + 1) * self.taps];
        let f = self.first[u] as u64;
        let lo = w.iter().position(|&v| v != 0.0).unwrap_or(0) as u64;
        let hi = w.iter().rposition(|&v| v != 0.0).unwrap_or(0) as u64;
        (f + lo, f + hi + 1)
    }

    /// The input indices any inside output index reads (half-open), or
    /// `None` when no output index is inside.
    fn span(&self) -> Option<(usize, usize)> {
        let mut r: Option<(usize, usize)> = None;
        for (u, &ok) in self.inside.iter().enumerate() {
            if ok {
                let (a, b) = (self.first[u], self.first[u] + self.taps);
                r = Some(r.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
            }
        }
        r
    }

    #[inline]
    fn entry(&self, u: usize) -> (usize, &[f32]) {
        (self.first[u], &self.w[u * self.taps..(u + 1) * self.taps])
    }
}

/// The three tables and the part of each input slice they read.
pub(crate) struct Separable {
    x: Table,
    y: Table,
    z: Table,
    /// Input columns and rows read by inside outputs (half-open).
    cols: (usize, usize),
    rows: (usize, usize),
    nx_in: usize,
}

impl Separable {
    /// Tables for the axes' samplers; `c0`/`step`: the continuous input
    /// index of output index 0 and its increment, per axis.
    pub(crate) fn new(
        s: &[AxisSampler; 3],
        n_out: [u64; 3],
        n_in: [u64; 3],
        c0: [f64; 3],
        step: [f64; 3],
    ) -> Separable {
        let t: [Table; 3] =
            std::array::from_fn(|a| Table::new(&s[a], n_out[a], n_in[a], c0[a], step[a]));
        let [x, y, z] = t;
        let cols = x.span().unwrap_or((0, 0));
        let rows = y.span().unwrap_or((0, 0));
        Separable {
            x,
            y,
            z,
            cols,
            rows,
            nx_in: n_in[0] as usize,
        }
    }

    /// Input z slices each output slice reads.
    pub(crate) fn z_need(&self) -> ZNeed {
        ZNeed::new((0..self.z.first.len()).map(|u| self.z.support(u)).collect())
    }

    /// Output slice `z` (`nx` × `ny` samples) into `out`.
    pub(crate) fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32], nx: usize, bg: f32) {
        let z = z as usize;
        let no_x = self.cols.1 <= self.cols.0;
        let no_y = self.rows.1 <= self.rows.0;
        if !self.z.inside[z] || no_x || no_y {
            out.fill(bg);
            return;
        }
        let (c0, cw) = (self.cols.0, self.cols.1 - self.cols.0);
        let (r0, rh) = (self.rows.0, self.rows.1 - self.rows.0);
        // z pass: the needed input slices combined into one in-plane slice.
        let mut tmp = vec![0.0f32; cw * rh];
        let (fz, wz) = self.z.entry(z);
        let mut started = false;
        for (t, &wt) in wz.iter().enumerate() {
            if wt == 0.0 {
                continue;
            }
            let s = input.slice((fz + t) as u64);
            for r in 0..rh {
                let src = &s[(r0 + r) * self.nx_in + c0..][..cw];
                let dst = &mut tmp[r * cw..(r + 1) * cw];
                if started {
                    for (d, &v) in dst.iter_mut().zip(src) {
                        *d += wt * v;
                    }
                } else {
                    for (d, &v) in dst.iter_mut().zip(src) {
                        *d = wt * v;
                    }
                }
            }
            started = true;
        }
        // y pass into one row, then the x pass from it.
        let mut row = vec![0.0f32; cw];
        let tx = self.x.taps;
        for (y, o) in out.chunks_exact_mut(nx).enumerate() {
            if !self.y.inside[y] {
                o.fill(bg);
                continue;
            }
            let (fy, wy) = self.y.entry(y);
            let mut started = false;
            for (t, &wt) in wy.iter().enumerate() {
                if wt == 0.0 {
                    continue;
                }
                let src = &tmp[(fy + t - r0) * cw..][..cw];
                if started {
                    for (d, &v) in row.iter_mut().zip(src) {
                        *d += wt * v;
                    }
                } else {
                    for (d, &v) in row.iter_mut().zip(src) {
                        *d = wt * v;
                    }
                }
                started = true;
            }
            match tx {
                1 => {
                    for (x, v) in o.iter_mut().enumerate() {
                        *v = if self.x.inside[x] {
                            self.x.w[x] * row[self.x.first[x] - c0]
                        } else {
                            bg
                        };
                    }
                }
                2 => {
                    for (x, v) in o.iter_mut().enumerate() {
                        *v = if self.x.inside[x] {
                            let f = self.x.first[x] - c0;
                            let w = &self.x.w[2 * x..2 * x + 2];
                            w[0] * row[f] + w[1] * row[f + 1]
                        } else {
                            bg
                        };
                    }
                }
                _ => {
                    for (x, v) in o.iter_mut().enumerate() {
                        *v = if self.x.inside[x] {
                            let (f, w) = self.x.entry(x);
                            let s = &row[f - c0..f - c0 + tx];
                            w.iter().zip(s).map(|(a, b)| a * b).sum()
                        } else {
                            bg
                        };
                    }
                }
            }
        }
    }
}
