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

use crate::scan::{range_to_f32, Bounds, ExactCounts, Order, ScanSample};
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

/// Accumulator elements a piece aims for (per bound), so that its
/// accumulator rows stay in cache.
const PIECE_ACC: u64 = 1 << 15;
/// Most slices in one piece (fewer streams through memory at once).
const PIECE_SLICES: u64 = 32;

/// Slices and rows of the pieces of a block `width × depth` voxels wide
/// and deep: at most [`PIECE_SLICES`] slices, and rows (a multiple of the
/// cell edge when more than one fits) keeping the accumulators near
/// [`PIECE_ACC`] elements.
pub(crate) fn piece_shape(width: u64, depth: u64, edge: u64) -> (u64, u64) {
    let slices = depth.min(PIECE_SLICES);
    let layers = slices / edge + 2;
    let bands = PIECE_ACC / (layers * width);
    let rows = (bands.saturating_sub(2) * edge).max(1);
    (slices, rows)
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
        let n = cells.iter().map(|r| (r.end - r.start) as usize).product();
        CellBox {
            cells,
            lo: vec![T::TOP; n],
            hi: vec![T::BOTTOM; n],
        }
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

    /// The range of cell `(cx, cy, cz)` (inside the box), widened to
    /// `f32` with [`range_to_f32`].
    #[inline(always)]
    pub fn range(&self, cx: u64, cy: u64, cz: u64) -> (f32, f32) {
        let i = self.offset(cx, cy, cz);
        range_to_f32(self.lo[i], self.hi[i])
    }
}

/// Element-wise ranges of the rows of one box of voxels (a *piece*), kept
/// per cell layer and cell row the piece meets, so that each sample is
/// folded with SIMD-friendly element-wise min/max and each cell's range is
/// reduced from its `edge + 1` columns only once per piece.
pub(crate) struct PieceRanges<T> {
    edge: u64,
    order: Order,
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
    /// folding samples that come from memory as `order` says.
    pub fn new(edge: u64, order: Order) -> Self {
        PieceRanges {
            edge,
            order,
            xs: 0..0,
            ys: 0..0,
            layers: 0..0,
            bands: 0..0,
            lo: Vec::new(),
            hi: Vec::new(),
            windows: Windows::new(),
        }
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

    /// Fold voxels `xs × ys` (inside the piece) of slice `z` into the
    /// piece, their rows starting `stride` samples apart in `plane`, and
    /// count them into `counts`. Each row goes into every cell row whose
    /// footprint holds it: one, two (a boundary row or slice) or four; it
    /// is counted once.
    #[inline(always)]
    pub fn add_slice(
        &mut self,
        z: u64,
        xs: Range<u64>,
        ys: Range<u64>,
        plane: &[T],
        stride: usize,
        counts: &mut ExactCounts,
    ) {
        let (e, w, order) = (self.edge, self.width(), self.order);
        let nb = (self.bands.end - self.bands.start) as usize;
        let (cz, az) = owners(z, e);
        // The columns of `xs` in every accumulator row.
        let x0 = (xs.start - self.xs.start) as usize;
        let cols = x0..x0 + (xs.end - xs.start) as usize;
        let first = (cz - self.layers.start) as usize * nb * w;
        // A boundary slice goes into the rows of two layers.
        let layers = [first, first + nb * w];
        let layers = &layers[..1 + usize::from(az)];
        // y = c·e + r: one division per slice, not per cell row.
        let (mut y, mut c, mut r) = (ys.start, ys.start / e, ys.start % e);
        while y < ys.end {
            // Rows y .. y1 are the rows of cell row c; a first row (r = 0)
            // is also the far apron of cell row c − 1.
            let y1 = (y + e - r).min(ys.end);
            let block = &plane[(y - ys.start) as usize * stride..];
            let rows = (y1 - y) as usize;
            let band = (c - self.bands.start) as usize * w;
            let apron = r == 0 && y > 0;
            for (k, &l) in layers.iter().enumerate() {
                let counts = (k == 0).then_some(&mut *counts);
                let (acc, prev) = self.rows_mut(l + band, &cols, apron);
                T::fold_block(acc, prev, block, stride, rows, counts, order);
            }
            (y, c, r) = (y1, c + 1, 0);
        }
    }

    /// Columns `cols` of the accumulator row at offset `o` and, with
    /// `apron`, of the row before it (the previous cell row's).
    #[inline(always)]
    fn rows_mut(
        &mut self,
        o: usize,
        cols: &Range<usize>,
        apron: bool,
    ) -> (Bounds<'_, T>, Option<Bounds<'_, T>>) {
        let w = self.width();
        let (lo_before, lo) = self.lo.split_at_mut(o);
        let (hi_before, hi) = self.hi.split_at_mut(o);
        let acc = Bounds {
            lo: &mut lo[cols.clone()],
            hi: &mut hi[cols.clone()],
        };
        let prev = apron.then(|| {
            let r = o - w + cols.start..o - w + cols.end;
            Bounds {
                lo: &mut lo_before[r.clone()],
                hi: &mut hi_before[r],
            }
        });
        (acc, prev)
    }

    /// Fold the piece's range of each cell it meets into `cells`.
    #[inline(always)]
    pub fn finish(&mut self, cells: &mut CellBox<T>) {
        let (e, xs, w) = (self.edge, self.xs.clone(), self.width());
        let full = e as usize + 1;
        let cxs = cells_meeting(xs.clone(), e);
        for cz in self.layers.clone() {
            for cy in self.bands.clone() {
                let o = self.at(cy, cz);
                let (lo, hi) = (&self.lo[o..o + w], &self.hi[o..o + w]);
                self.windows.prepare(lo, hi, full);
                let (out_lo, out_hi) = cells.row_mut(cxs.clone(), cy, cz);
                let outs = out_lo.iter_mut().zip(out_hi.iter_mut());
                for (cx, (out_lo, out_hi)) in cxs.clone().zip(outs) {
                    let a = ((cx * e).max(xs.start) - xs.start) as usize;
                    let b = ((cx * e + e).min(xs.end - 1) - xs.start) as usize;
                    // Cells cut by the piece's or the volume's edge: a fold.
                    let (l, h) = match b + 1 - a == full {
                        true => self.windows.range(a, full),
                        false => span(lo, hi, a, b),
                    };
                    *out_lo = T::lower(*out_lo, l);
                    *out_hi = T::upper(*out_hi, h);
                }
            }
        }
    }
}

/// The ranges of windows of one length over an accumulator row, by
/// doubling: after `k` passes element `i` holds the range of elements
/// `i .. i + 2^k`, so a window is the union of two overlapping
/// power-of-two spans. A cell then costs two lookups, not a fold over its
/// `edge + 1` columns, and the passes vectorise.
struct Windows<T> {
    lo: Vec<T>,
    hi: Vec<T>,
    spare_lo: Vec<T>,
    spare_hi: Vec<T>,
    span: usize,
}

impl<T: ScanSample> Windows<T> {
    fn new() -> Self {
        Windows {
            lo: Vec::new(),
            hi: Vec::new(),
            spare_lo: Vec::new(),
            spare_hi: Vec::new(),
            span: 1,
        }
    }

    /// Prepare for windows of `len` elements of the row `lo`, `hi`.
    #[inline(always)]
    fn prepare(&mut self, lo: &[T], hi: &[T], len: usize) {
        // The first pass reads the row itself.
        let mut s = 1;
        if 2 <= len && 1 < lo.len() {
            double(lo, &mut self.lo, 1, T::lower);
            double(hi, &mut self.hi, 1, T::upper);
            s = 2;
        } else {
            self.lo.clear();
            self.lo.extend_from_slice(lo);
            self.hi.clear();
            self.hi.extend_from_slice(hi);
        }
        // A row shorter than a window holds no window: stop when the
        // passes run out of elements.
        while 2 * s <= len && s < self.lo.len() {
            double(&self.lo, &mut self.spare_lo, s, T::lower);
            double(&self.hi, &mut self.spare_hi, s, T::upper);
            std::mem::swap(&mut self.lo, &mut self.spare_lo);
            std::mem::swap(&mut self.hi, &mut self.spare_hi);
            s *= 2;
        }
        self.span = s;
    }

    /// The range of the window of `len` elements (as prepared) from `a`;
    /// the window must lie in the row.
    #[inline(always)]
    fn range(&self, a: usize, len: usize) -> (T, T) {
        let b = a + len - self.span;
        (
            T::lower(self.lo[a], self.lo[b]),
            T::upper(self.hi[a], self.hi[b]),
        )
    }
}

/// One doubling pass: `dst[i] = f(src[i], src[i + s])`.
#[inline(always)]
fn double<T: Copy>(src: &[T], dst: &mut Vec<T>, s: usize, f: impl Fn(T, T) -> T) {
    dst.clear();
    dst.extend(src.iter().zip(&src[s..]).map(|(&a, &b)| f(a, b)));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_folds_skip_nan_and_canonicalise_zero() {
        let n = f32::NAN;
        let mut r = PieceRanges::<f32>::new(2, Order::Cached);
        r.start(0..5, 0..1, 0..2);
        let mut counts = ExactCounts::new::<f32>();
        r.add_slice(0, 0..5, 0..1, &[1.0, n, -0.0, n, n], 5, &mut counts);
        r.add_slice(1, 0..5, 0..1, &[n, 3.0, n, n, n], 5, &mut counts);
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
        let mut r = PieceRanges::<u8>::new(2, Order::Stream);
        let mut counts = ExactCounts::new::<u8>();
        let v: Vec<u8> = (0..75).collect();
        // Three pieces splitting y at 3 and z at 2, the last one fed in
        // two parts split at x = 3: each voxel once.
        for (ys, zs) in [(0..3, 0..2), (3..5, 0..2), (0..5, 2..3)] {
            r.start(0..5, ys.clone(), zs.clone());
            for z in zs {
                let at = (5 * ys.start + 25 * z) as usize;
                if z < 2 {
                    r.add_slice(z, 0..5, ys.clone(), &v[at..], 5, &mut counts);
                } else {
                    r.add_slice(z, 0..3, ys.clone(), &v[at..], 5, &mut counts);
                    r.add_slice(z, 3..5, ys.clone(), &v[at + 3..], 5, &mut counts);
                }
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
                for a in 0..(n + 1).saturating_sub(len) {
                    assert_eq!(
                        w.range(a, len),
                        span(&lo, &hi, a, a + len - 1),
                        "{n} {len} {a}"
                    );
                }
            }
        }
    }
}
