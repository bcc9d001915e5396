//! Pieces: the cell ranges of one box of voxels, from element-wise
//! accumulator rows.
//!
//! Along each axis cell `c` reads voxels `c·N ..= c·N + N`, so a voxel on a
//! cell boundary belongs to two cells (it is the far apron of the one
//! before). A piece keeps one accumulator row per cell layer and cell row
//! it meets, as wide as the piece: every row of samples is folded
//! element-wise into the accumulator rows of the cells holding it (two or
//! four for boundary rows and slices), then each cell's range is reduced
//! from its `N + 1` columns once, when the piece is finished, into a
//! [`CellBox`]. A cell cut by the piece's edges gets the part of its range
//! the piece holds; other pieces add the rest.

use crate::scan::{Avx2, Bounds, BoxTargets, ExactCounts, RowBox, ScanSample};
use crate::walk::Block;
use std::ops::Range;

/// The cells along one axis whose footprint holds voxel `v`: cell
/// `v / edge` and, when `v` starts a cell (`v > 0`), the one before it too,
/// whose apron it is. Returns the first cell and whether there are two.
#[inline(always)]
pub(crate) fn owners(v: u64, edge: u64) -> (u64, bool) {
    let c = v / edge;
    let apron = v > 0 && v == c * edge;
    (if apron { c - 1 } else { c }, apron)
}

/// The cells whose footprints meet voxels `vs` along one axis (`vs` not
/// empty).
#[inline]
pub(crate) fn cells_meeting(vs: Range<u64>, edge: u64) -> Range<u64> {
    owners(vs.start, edge).0..(vs.end - 1) / edge + 1
}

/// The range of `lo[a ..= b]` and `hi[a ..= b]` in the native type.
#[inline(always)]
fn span<T: ScanSample>(lo: &[T], hi: &[T], a: usize, b: usize) -> (T, T) {
    let l = lo[a..=b].iter().fold(T::TOP, |m, &v| T::lower(m, v));
    let h = hi[a..=b].iter().fold(T::BOTTOM, |m, &v| T::upper(m, v));
    (l, h)
}

/// Native-type ranges of a box of cells, x fastest: the part of each
/// cell's footprint that one task's voxels cover.
pub(crate) struct CellBox<T> {
    cells: [Range<u64>; 3],
    lo: Vec<T>,
    hi: Vec<T>,
}

impl<T: ScanSample> CellBox<T> {
    /// Empty ranges for the cells `cells` (per axis).
    pub fn new(cells: [Range<u64>; 3]) -> Self {
        let mut part = CellBox {
            cells: cells.clone(),
            lo: Vec::new(),
            hi: Vec::new(),
        };
        part.reset(cells);
        part
    }

    /// Empty ranges for the cells `cells`, reusing the storage.
    pub fn reset(&mut self, cells: [Range<u64>; 3]) {
        let n = cells.iter().map(|r| (r.end - r.start) as usize).product();
        self.cells = cells;
        self.lo.clear();
        self.lo.resize(n, T::TOP);
        self.hi.clear();
        self.hi.resize(n, T::BOTTOM);
    }

    /// The cells covered, per axis.
    pub fn cells(&self) -> &[Range<u64>; 3] {
        &self.cells
    }

    /// Offset of cell `(cx, cy, cz)` (inside the box).
    #[inline(always)]
    fn offset(&self, cx: u64, cy: u64, cz: u64) -> usize {
        let c = &self.cells;
        let (nx, ny) = (c[0].end - c[0].start, c[1].end - c[1].start);
        ((cx - c[0].start) + nx * ((cy - c[1].start) + ny * (cz - c[2].start))) as usize
    }

    /// The ranges of cells `cxs` of cell row `(cy, cz)` (inside the box).
    #[inline(always)]
    fn row_mut(&mut self, cxs: Range<u64>, cy: u64, cz: u64) -> (&mut [T], &mut [T]) {
        let i = self.offset(cxs.start, cy, cz);
        let n = (cxs.end - cxs.start) as usize;
        (&mut self.lo[i..i + n], &mut self.hi[i..i + n])
    }

    /// The native ranges (lower, upper bounds) of the whole cell row
    /// `(cy, cz)` (inside the box).
    #[inline(always)]
    pub fn row(&self, cy: u64, cz: u64) -> (&[T], &[T]) {
        let i = self.offset(self.cells[0].start, cy, cz);
        let n = (self.cells[0].end - self.cells[0].start) as usize;
        (&self.lo[i..i + n], &self.hi[i..i + n])
    }

    /// The range of cell `(cx, cy, cz)` (inside the box), widened to
    /// `f32` with [`range_to_f32`].
    #[cfg(test)]
    pub fn range(&self, cx: u64, cy: u64, cz: u64) -> (f32, f32) {
        let i = self.offset(cx, cy, cz);
        crate::scan::range_to_f32(self.lo[i], self.hi[i])
    }
}

/// Element-wise ranges of the rows of one box of voxels (a *piece*), kept
/// per cell layer and cell row the piece meets, so that each sample is
/// folded with SIMD-friendly element-wise min/max and each cell's range is
/// reduced from its `edge + 1` columns only once per piece.
pub(crate) struct PieceRanges<T> {
    edge: u64,
    cpu: Option<Avx2>,
    xs: Range<u64>,
    ys: Range<u64>,
    layers: Range<u64>,
    bands: Range<u64>,
    lo: Vec<T>,
    hi: Vec<T>,
    windows: Windows<T>,
}

impl<T: ScanSample> PieceRanges<T> {
    /// An accumulator for cells of `edge` voxels (no piece started),
    /// folding on AVX2 registers if `cpu` is given.
    pub fn new(edge: u64, cpu: Option<Avx2>) -> Self {
        PieceRanges {
            edge,
            cpu,
            xs: 0..0,
            ys: 0..0,
            layers: 0..0,
            bands: 0..0,
            lo: Vec::new(),
            hi: Vec::new(),
            windows: Windows::new(),
        }
    }

    /// The proof of AVX2 it folds with, if any.
    pub fn cpu(&self) -> Option<Avx2> {
        self.cpu
    }

    /// Start a piece of voxels `xs × ys × zs` (none empty), forgetting the
    /// previous one.
    pub fn start(&mut self, xs: Range<u64>, ys: Range<u64>, zs: Range<u64>) {
        self.layers = cells_meeting(zs, self.edge);
        self.bands = cells_meeting(ys.clone(), self.edge);
        self.xs = xs;
        self.ys = ys;
        let n = self.rows() * self.width();
        self.lo.clear();
        self.lo.resize(n, T::TOP);
        self.hi.clear();
        self.hi.resize(n, T::BOTTOM);
    }

    /// Accumulator elements (per bound) a piece of voxels `xs × ys × zs`
    /// needs.
    pub fn len_for(edge: u64, xs: Range<u64>, ys: Range<u64>, zs: Range<u64>) -> u64 {
        let n = |r: Range<u64>| r.end - r.start;
        n(cells_meeting(zs, edge)) * n(cells_meeting(ys, edge)) * n(xs)
    }

    fn width(&self) -> usize {
        (self.xs.end - self.xs.start) as usize
    }

    fn rows(&self) -> usize {
        ((self.layers.end - self.layers.start) * (self.bands.end - self.bands.start)) as usize
    }

    /// Offset of the element-wise row of cell layer `cz`, cell row `cy`.
    #[inline(always)]
    fn at(&self, cy: u64, cz: u64) -> usize {
        let nb = self.bands.end - self.bands.start;
        ((cz - self.layers.start) * nb + (cy - self.bands.start)) as usize * self.width()
    }

    /// Fold the voxels of `block` (inside the piece) into the piece and
    /// count them into `counts`. Each row goes into every cell row whose
    /// footprint holds it: one, two (a boundary row or slice) or four; it
    /// is counted once. The rows of one cell row and layer are folded
    /// together, a [`RowBox`] at a time.
    #[inline(always)]
    pub fn add_block(&mut self, block: &Block<'_, T>, counts: &mut ExactCounts) {
        let (xs, ys, zs) = (
            block.region.axis(0),
            block.region.axis(1),
            block.region.axis(2),
        );
        let (data, stride, plane) = block.samples();
        let e = self.edge;
        let x0 = (xs.start - self.xs.start) as usize;
        let cols = x0..x0 + (xs.end - xs.start) as usize;
        // Slices z .. z1 hold voxels of cell layer cz; a first slice at a
        // layer's start is also the far apron of the layer before (and
        // likewise for rows y .. y1 of cell row cy).
        let mut z = zs.start;
        while z < zs.end {
            let cz = z / e;
            let z1 = ((cz + 1) * e).min(zs.end);
            let slice_apron = z > 0 && z == cz * e;
            let mut y = ys.start;
            while y < ys.end {
                let cy = y / e;
                let y1 = ((cy + 1) * e).min(ys.end);
                let row_apron = y > 0 && y == cy * e;
                let at = (z - zs.start) as usize * plane + (y - ys.start) as usize * stride;
                let rows = RowBox {
                    data: &data[at..],
                    stride,
                    plane,
                    rows: (y1 - y) as usize,
                    slices: (z1 - z) as usize,
                };
                let cpu = self.cpu;
                let targets = self.targets(cy, cz, row_apron, slice_apron, &cols);
                T::fold_box(cpu, targets, rows, Some(&mut *counts));
                y = y1;
            }
            z = z1;
        }
    }

    /// Columns `cols` of the accumulator rows a box of cell row `cy`, layer
    /// `cz` folds into: its own and, when its first row and/or slice is an
    /// apron, the previous cell row's, layer's, or both.
    #[inline(always)]
    fn targets(
        &mut self,
        cy: u64,
        cz: u64,
        row_apron: bool,
        slice_apron: bool,
        cols: &Range<usize>,
    ) -> BoxTargets<'_, T> {
        let w = self.width();
        // Row offsets in increasing order: corner, slice apron, row apron.
        let aprons = [
            (row_apron && slice_apron).then(|| self.at(cy - 1, cz - 1)),
            slice_apron.then(|| self.at(cy, cz - 1)),
            row_apron.then(|| self.at(cy - 1, cz)),
        ];
        let own = self.at(cy, cz);
        let (mut lo, mut hi) = (self.lo.as_mut_slice(), self.hi.as_mut_slice());
        let mut base = 0;
        let mut out = [None, None, None];
        for (slot, o) in out.iter_mut().zip(aprons) {
            let Some(o) = o else { continue };
            let (row_lo, rest_lo) = lo[o - base..].split_at_mut(w);
            let (row_hi, rest_hi) = hi[o - base..].split_at_mut(w);
            *slot = Some(Bounds {
                lo: &mut row_lo[cols.clone()],
                hi: &mut row_hi[cols.clone()],
            });
            (lo, hi, base) = (rest_lo, rest_hi, o + w);
        }
        let [corner, slice_apron, row_apron] = out;
        BoxTargets {
            cell: Bounds {
                lo: &mut lo[own - base..][cols.clone()],
                hi: &mut hi[own - base..][cols.clone()],
            },
            row_apron,
            slice_apron,
            corner,
        }
    }

    /// Fold the piece's range of each cell it meets into `cells`.
    #[inline(always)]
    pub fn finish(&mut self, cells: &mut CellBox<T>) {
        let (e, xs, w) = (self.edge, self.xs.clone(), self.width());
        let full = e as usize + 1;
        let cxs = cells_meeting(xs.clone(), e);
        // Cells whose whole footprint `c·e ..= c·e + e` lies in the piece's
        // columns, as a range of cells and of offsets in the output rows.
        let first_whole = xs.start.div_ceil(e).clamp(cxs.start, cxs.end);
        let end_whole = match xs.end > e {
            true => ((xs.end - 1 - e) / e + 1).clamp(first_whole, cxs.end),
            false => first_whole,
        };
        let whole = (first_whole - cxs.start) as usize..(end_whole - cxs.start) as usize;
        let a0 = (first_whole * e).saturating_sub(xs.start) as usize;
        for cz in self.layers.clone() {
            for cy in self.bands.clone() {
                let o = self.at(cy, cz);
                let (lo, hi) = (&self.lo[o..o + w], &self.hi[o..o + w]);
                let (out_lo, out_hi) = cells.row_mut(cxs.clone(), cy, cz);
                // A row of one value (empty space, mostly) gives every cell
                // that value (a branch-free test, so it vectorises).
                let v = lo[0];
                if lo
                    .iter()
                    .zip(hi)
                    .fold(true, |one, (&l, &h)| one & (l == v) & (h == v))
                {
                    for (out_lo, out_hi) in out_lo.iter_mut().zip(out_hi.iter_mut()) {
                        *out_lo = T::lower(*out_lo, v);
                        *out_hi = T::upper(*out_hi, v);
                    }
                    continue;
                }
                self.windows.prepare(lo, hi, full);
                // Whole cells (a row holds one only if it is longer than
                // the edge): two lookups each.
                if !whole.is_empty() {
                    let ranges = self.windows.ranges(a0, e as usize, full);
                    let outs = out_lo[whole.clone()].iter_mut();
                    let outs = outs.zip(out_hi[whole.clone()].iter_mut());
                    for ((out_lo, out_hi), (l, h)) in outs.zip(ranges) {
                        *out_lo = T::lower(*out_lo, l);
                        *out_hi = T::upper(*out_hi, h);
                    }
                }
                // Cells cut by the piece's or the volume's edge: a fold.
                let cut = (0..whole.start).chain(whole.end..out_lo.len());
                for k in cut {
                    let cx = cxs.start + k as u64;
                    let a = ((cx * e).max(xs.start) - xs.start) as usize;
                    let b = ((cx * e + e).min(xs.end - 1) - xs.start) as usize;
                    let (l, h) = span(lo, hi, a, b);
                    out_lo[k] = T::lower(out_lo[k], l);
                    out_hi[k] = T::upper(out_hi[k], h);
                }
            }
        }
    }
}

/// Elements per step of a doubling pass: whole vector registers, so that
/// no pass ends in a scalar tail.
const STEP: usize = 32;

/// The ranges of windows of one length over an accumulator row, by
/// doubling: after `k` passes element `i` holds the range of elements
/// `i .. i + 2^k`, so a window is the union of two overlapping
/// power-of-two spans. A cell then costs two lookups, not a fold over its
/// `edge + 1` columns, and the passes vectorise. The row is padded with
/// empty ranges (the folds' identities) to whole steps and beyond.
struct Windows<T> {
    lo: Vec<T>,
    hi: Vec<T>,
    span: usize,
}

impl<T: ScanSample> Windows<T> {
    fn new() -> Self {
        Windows {
            lo: Vec::new(),
            hi: Vec::new(),
            span: 1,
        }
    }

    /// Prepare for windows of `len` elements of the row `lo`, `hi`.
    #[inline(always)]
    fn prepare(&mut self, lo: &[T], hi: &[T], len: usize) {
        let n = lo.len().min(hi.len());
        let steps = n.div_ceil(STEP) * STEP;
        // A pass reads `s < len` elements past each step.
        padded(&mut self.lo, &lo[..n], steps + len, T::TOP);
        padded(&mut self.hi, &hi[..n], steps + len, T::BOTTOM);
        // A row shorter than a window holds no window: stop when the
        // passes run out of elements.
        let mut s = 1;
        while 2 * s <= len && s < n {
            double(&mut self.lo, steps, s, T::lower);
            double(&mut self.hi, steps, s, T::upper);
            s *= 2;
        }
        self.span = s;
    }

    /// The ranges of the windows of `len` elements (as prepared) starting
    /// at `a`, `a + step`, `a + 2·step`, … (a window reaching past the
    /// row's end holds the range of its part in the row). Each window is
    /// the union of the spans from its start and from `len − span` further
    /// on, which must be less than `step`.
    #[inline(always)]
    fn ranges(&self, a: usize, step: usize, len: usize) -> impl Iterator<Item = (T, T)> + '_ {
        let d = len - self.span;
        debug_assert!(d < step, "windows of {len} every {step}");
        let lo = self.lo[a..].chunks(step);
        let hi = self.hi[a..].chunks(step);
        lo.zip(hi)
            .map(move |(l, h)| (T::lower(l[0], l[d]), T::upper(h[0], h[d])))
    }
}

/// `buf` set to `row` followed by `pad` up to `len` elements.
#[inline(always)]
fn padded<T: Copy>(buf: &mut Vec<T>, row: &[T], len: usize, pad: T) {
    buf.clear();
    buf.extend_from_slice(row);
    buf.resize(len, pad);
}

/// One doubling pass in place over the first `steps` elements (a multiple
/// of [`STEP`]; `v` holds at least `s` more): `v[i] = f(v[i], v[i + s])`.
/// Going up, `v[i + s]` still holds the previous pass's value when read.
#[inline(always)]
fn double<T: Copy>(v: &mut [T], steps: usize, s: usize, f: impl Fn(T, T) -> T) {
    for i in (0..steps).step_by(STEP) {
        let ahead = &v[i + s..i + s + STEP];
        let b: [T; STEP] = std::array::from_fn(|k| ahead[k]);
        let a = &mut v[i..i + STEP];
        for k in 0..STEP {
            a[k] = f(a[k], b[k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::walk::Region;

    fn region(xs: Range<u64>, ys: Range<u64>, zs: Range<u64>) -> Region {
        Region {
            lo: [xs.start, ys.start, zs.start],
            hi: [xs.end, ys.end, zs.end],
        }
    }

    #[test]
    fn f32_folds_skip_nan_and_canonicalise_zero() {
        let n = f32::NAN;
        let mut r = PieceRanges::<f32>::new(2, None);
        r.start(0..5, 0..1, 0..2);
        let mut counts = ExactCounts::new::<f32>();
        let v = [1.0, n, -0.0, n, n, n, 3.0, n, n, n];
        r.add_block(&Block::new(region(0..5, 0..1, 0..2), &v, 5, 5), &mut counts);
        let mut cells = CellBox::new([0..3, 0..1, 0..1]);
        r.finish(&mut cells);
        let bits = |(lo, hi): (f32, f32)| (lo.to_bits(), hi.to_bits());
        assert_eq!(bits(cells.range(0, 0, 0)), bits((0.0, 3.0)));
        assert_eq!(bits(cells.range(1, 0, 0)), bits((0.0, 0.0)));
        let (lo, hi) = cells.range(2, 0, 0);
        assert!(lo > hi, "only NaNs must give the empty range");
    }

    #[test]
    fn pieces_fold_boundary_rows_into_both_cells() {
        // Edge 2 over 5 x 5 x 3 voxels: voxel 2 on each axis is also the
        // apron of cell 0, voxel 4 of cell 1.
        let mut cells = CellBox::new([0..3, 0..3, 0..2]);
        let mut r = PieceRanges::<u8>::new(2, None);
        let mut counts = ExactCounts::new::<u8>();
        let v: Vec<u8> = (0..75).collect();
        let block = |xs: Range<u64>, ys: Range<u64>, zs: Range<u64>| {
            let at = (xs.start + 5 * ys.start + 25 * zs.start) as usize;
            Block::new(region(xs, ys, zs), &v[at..], 5, 25)
        };
        // Three pieces splitting y at 3 and z at 2, the last one fed in
        // two blocks split at x = 3: each voxel once.
        for (ys, zs) in [(0..3, 0..2), (3..5, 0..2), (0..5, 2..3)] {
            r.start(0..5, ys.clone(), zs.clone());
            if zs.start < 2 {
                r.add_block(&block(0..5, ys, zs), &mut counts);
            } else {
                r.add_block(&block(0..3, ys.clone(), zs.clone()), &mut counts);
                r.add_block(&block(3..5, ys, zs), &mut counts);
            }
            r.finish(&mut cells);
        }
        assert!(counts.per_value()[..75].iter().all(|&n| n == 1));
        for cz in 0..2u64 {
            for cy in 0..3u64 {
                for cx in 0..3u64 {
                    let hi = |c: u64| (2 * c + 2).min(4);
                    let want = (
                        (2 * cx + 10 * cy + 50 * cz) as f32,
                        (hi(cx) + 5 * hi(cy) + 25 * (2 * cz + 2).min(2)) as f32,
                    );
                    assert_eq!(cells.range(cx, cy, cz), want, "{cx},{cy},{cz}");
                }
            }
        }
        assert_eq!(cells_meeting(2..4, 2), 0..2);
        assert_eq!(cells_meeting(3..4, 2), 1..2);
        assert_eq!(owners(0, 2), (0, false));
    }

    #[test]
    fn windows_match_folds() {
        let mut rng = fastrand::Rng::with_seed(5);
        let mut w = Windows::<i16>::new();
        for n in [1usize, 2, 3, 8, 9, 10, 33, 100] {
            let lo: Vec<i16> = (0..n).map(|_| rng.i16(..)).collect();
            let hi: Vec<i16> = (0..n).map(|_| rng.i16(..)).collect();
            for len in [2usize, 3, 4, 5, 9, 17, 33, 65] {
                w.prepare(&lo, &hi, len);
                let starts = (n + 1).saturating_sub(len);
                for a in 0..starts {
                    // Windows a, a + len, a + 2·len, … in the row.
                    let count = (starts - a).div_ceil(len);
                    for (k, got) in w.ranges(a, len, len).take(count).enumerate() {
                        let a = a + len * k;
                        assert_eq!(got, span(&lo, &hi, a, a + len - 1), "{n} {len} {a}");
                    }
                }
            }
        }
    }
}
