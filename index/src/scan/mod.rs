//! Per-sample-type kernels of the build pass: element-wise min/max of
//! boxes of rows in the native sample type (no `f32` conversion per
//! voxel; the AVX2 build is in its child module `avx2`), and exact per-value
//! counting for integer types.

#[cfg(target_arch = "x86_64")]
mod avx2;

use std::ops::Range;
use volcore::Sample;

/// A sample type the build pass scans natively.
pub(crate) trait ScanSample: Sample {
    /// Identity of [`ScanSample::lower`] (largest value, `+inf` for `f32`).
    const TOP: Self;
    /// Identity of [`ScanSample::upper`] (smallest value, `−inf` for `f32`).
    const BOTTOM: Self;
    /// Distinct values counted exactly by [`ExactCounts`] (0: not counted).
    const EXACT_VALUES: usize;
    /// Interleaved count tables, to break store-to-load dependencies when
    /// neighbouring samples repeat a value.
    const COUNT_LANES: usize;
    /// Smallest value of the type, for the exact count slots.
    const TYPE_MIN: f64;

    /// The smaller of `acc` and `v`; a NaN `v` leaves `acc` unchanged.
    fn lower(acc: Self, v: Self) -> Self;
    /// The larger of `acc` and `v`; a NaN `v` leaves `acc` unchanged.
    fn upper(acc: Self, v: Self) -> Self;
    /// Slot of `self` in an exact count table (integer types only).
    fn slot(self) -> usize;
    /// [`fold_box`] with the register chunk width that suits the type, on
    /// AVX2 registers when `cpu` says the CPU has them.
    fn fold_box(
        cpu: Option<Avx2>,
        targets: BoxTargets<'_, Self>,
        rows: RowBox<'_, Self>,
        counts: Option<&mut ExactCounts>,
    );
}

/// Proof that the CPU runs AVX2: only [`Avx2::detect`] makes one, and only
/// where it does.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// The proof, if the CPU runs AVX2.
    pub fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Avx2(()));
        }
        None
    }
}

/// [`fold_box`] with chunks of `L` samples, on AVX2 registers when `cpu`
/// says the CPU has them (`L` samples are then 32 bytes).
#[inline(always)]
fn fold_box_on<T: ScanSample + FoldLanes, const L: usize>(
    cpu: Option<Avx2>,
    targets: BoxTargets<'_, T>,
    rows: RowBox<'_, T>,
    counts: Option<&mut ExactCounts>,
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        // SAFETY: `cpu` proves the CPU supports AVX2.
        return unsafe { avx2::fold_box::<T, L>(cpu, targets, rows, counts) };
    }
    let _ = cpu;
    fold_box::<T, L>(targets, rows, counts);
}

/// The AVX2 lane operations where there are any.
#[cfg(target_arch = "x86_64")]
use avx2::Lanes as FoldLanes;
/// Nothing extra elsewhere.
#[cfg(not(target_arch = "x86_64"))]
trait FoldLanes {}
#[cfg(not(target_arch = "x86_64"))]
impl<T> FoldLanes for T {}

macro_rules! int_scan {
    ($t:ty, $lanes:expr, $chunk:expr) => {
        impl ScanSample for $t {
            const TOP: Self = <$t>::MAX;
            const BOTTOM: Self = <$t>::MIN;
            const EXACT_VALUES: usize = 1 << <$t>::BITS;
            const COUNT_LANES: usize = $lanes;
            const TYPE_MIN: f64 = <$t>::MIN as f64;
            #[inline(always)]
            fn lower(acc: Self, v: Self) -> Self {
                acc.min(v)
            }
            #[inline(always)]
            fn upper(acc: Self, v: Self) -> Self {
                acc.max(v)
            }
            #[inline(always)]
            fn slot(self) -> usize {
                (self as i64 - <$t>::MIN as i64) as usize
            }
            #[inline(always)]
            fn fold_box(
                cpu: Option<Avx2>,
                targets: BoxTargets<'_, Self>,
                rows: RowBox<'_, Self>,
                counts: Option<&mut ExactCounts>,
            ) {
                fold_box_on::<$t, $chunk>(cpu, targets, rows, counts);
            }
        }
    };
}

// Chunks of 32 bytes: two SSE registers per bound.
int_scan!(u8, 8, 32);
int_scan!(u16, 1, 16);
int_scan!(i16, 1, 16);

impl ScanSample for f32 {
    const TOP: Self = f32::INFINITY;
    const BOTTOM: Self = f32::NEG_INFINITY;
    const EXACT_VALUES: usize = 0;
    const COUNT_LANES: usize = 0;
    const TYPE_MIN: f64 = f64::NEG_INFINITY;
    #[inline(always)]
    fn lower(acc: Self, v: Self) -> Self {
        // NaN compares false and is skipped.
        if v < acc {
            v
        } else {
            acc
        }
    }
    #[inline(always)]
    fn upper(acc: Self, v: Self) -> Self {
        if v > acc {
            v
        } else {
            acc
        }
    }
    #[inline(always)]
    fn slot(self) -> usize {
        0
    }
    #[inline(always)]
    fn fold_box(
        cpu: Option<Avx2>,
        targets: BoxTargets<'_, Self>,
        rows: RowBox<'_, Self>,
        counts: Option<&mut ExactCounts>,
    ) {
        fold_box_on::<f32, 8>(cpu, targets, rows, counts);
    }
}

/// Widen a native range to `f32`, mapping `−0.0` to `+0.0` so that the
/// stored bits never depend on which of two equal zeros a fold kept.
#[inline]
pub(crate) fn range_to_f32<T: ScanSample>(lo: T, hi: T) -> (f32, f32) {
    (lo.to_f32() + 0.0, hi.to_f32() + 0.0)
}

/// Element-wise lower and upper bounds of one accumulator row (or part of
/// one), of equal lengths.
pub(crate) struct Bounds<'a, T> {
    /// Element-wise minima.
    pub lo: &'a mut [T],
    /// Element-wise maxima.
    pub hi: &'a mut [T],
}

/// A box of sample rows in a cache-sized buffer: `slices` slices of `rows`
/// rows each, row `(z, r)` starting at `data[z·plane + r·stride]`, as wide
/// as the accumulator rows it is folded into.
#[derive(Clone, Copy)]
pub(crate) struct RowBox<'a, T> {
    /// The samples, from the first row of the first slice on.
    pub data: &'a [T],
    /// Distance between neighbouring rows of a slice.
    pub stride: usize,
    /// Distance between neighbouring slices.
    pub plane: usize,
    /// Rows per slice (at least one).
    pub rows: usize,
    /// Slices (at least one).
    pub slices: usize,
}

impl<T> RowBox<'_, T> {
    /// Offset of row `(z, r)` in `data`.
    #[inline(always)]
    pub fn at(&self, z: usize, r: usize) -> usize {
        z * self.plane + r * self.stride
    }
}

/// The accumulator rows a [`RowBox`] folds into: every sample goes into
/// `cell`; when the box's first row is also the far apron of the cell row
/// before, its first row goes into `row_apron`; likewise its first slice
/// into `slice_apron`, and the row that is both into `corner`.
pub(crate) struct BoxTargets<'a, T> {
    /// The cell row the box's samples belong to.
    pub cell: Bounds<'a, T>,
    /// The previous cell row's, when the first row is its apron.
    pub row_apron: Option<Bounds<'a, T>>,
    /// The previous cell layer's, when the first slice is its apron.
    pub slice_apron: Option<Bounds<'a, T>>,
    /// The previous cell layer's previous cell row's, when both are.
    pub corner: Option<Bounds<'a, T>>,
}

impl<T> BoxTargets<'_, T> {
    /// Columns of the targets.
    pub fn width(&self) -> usize {
        self.cell.lo.len().min(self.cell.hi.len())
    }
}

/// Fold a box of rows element-wise into its targets and count its samples
/// into `counts` if given.
///
/// Each `L`-column chunk goes down every row of every slice once with its
/// bounds in registers, kept apart for the first slice, the first row and
/// the rest, so that apron rows are not read twice and the accumulators
/// are loaded and stored once per box; a chunk column of one value (empty
/// space, mostly) is counted in one step. The AVX2 build of this loop is
/// `avx2::fold_box`; both end with [`fold_box_rest`].
#[inline(always)]
fn fold_box<T: ScanSample, const L: usize>(
    mut t: BoxTargets<'_, T>,
    b: RowBox<'_, T>,
    counts: Option<&mut ExactCounts>,
) {
    let w = t.width();
    let mut counts = counts.filter(|_| T::EXACT_VALUES > 0);
    let mut run = Run::<T, L>::new();
    let chunk = |z: usize, r: usize, x: usize| -> &[T] {
        let o = b.at(z, r) + x;
        &b.data[o..o + L]
    };
    let mut x = 0;
    while x + L <= w {
        // The first row of the first slice, the rest of the first slice,
        // the first rows of the other slices, and everything else.
        let (mut corner_lo, mut corner_hi) = ([T::TOP; L], [T::BOTTOM; L]);
        fold_regs(&mut corner_lo, &mut corner_hi, chunk(0, 0, x));
        let (mut slice_lo, mut slice_hi) = (corner_lo, corner_hi);
        for r in 1..b.rows {
            fold_regs(&mut slice_lo, &mut slice_hi, chunk(0, r, x));
        }
        let (mut row_lo, mut row_hi) = (corner_lo, corner_hi);
        let (mut lo, mut hi) = ([T::TOP; L], [T::BOTTOM; L]);
        for z in 1..b.slices {
            fold_regs(&mut row_lo, &mut row_hi, chunk(z, 0, x));
            for r in 1..b.rows {
                fold_regs(&mut lo, &mut hi, chunk(z, r, x));
            }
        }
        for i in 0..L {
            lo[i] = T::lower(T::lower(lo[i], slice_lo[i]), row_lo[i]);
            hi[i] = T::upper(T::upper(hi[i], slice_hi[i]), row_hi[i]);
        }
        let cols = x..x + L;
        fold_bounds::<T, L>(&mut t.cell, &cols, &lo, &hi);
        if let Some(a) = t.row_apron.as_mut() {
            fold_bounds::<T, L>(a, &cols, &row_lo, &row_hi);
        }
        if let Some(a) = t.slice_apron.as_mut() {
            fold_bounds::<T, L>(a, &cols, &slice_lo, &slice_hi);
        }
        if let Some(a) = t.corner.as_mut() {
            fold_bounds::<T, L>(a, &cols, &corner_lo, &corner_hi);
        }
        if let Some(c) = counts.as_deref_mut() {
            // One value throughout when every bound is the first minimum
            // (a branch-free fold, so the comparisons vectorise).
            let v = lo[0];
            let one = (0..L).fold(true, |u, i| u & (lo[i] == v) & (hi[i] == v));
            count_column(c, &mut run, b, x, one);
        }
        x += L;
    }
    fold_box_rest(t, b, x, counts, run);
}

/// Count the chunk column at `x` of a box: at once when it holds one
/// value throughout (`one`), else chunk by chunk.
#[inline(always)]
pub(crate) fn count_column<T: ScanSample, const L: usize>(
    counts: &mut ExactCounts,
    run: &mut Run<T, L>,
    b: RowBox<'_, T>,
    x: usize,
    one: bool,
) {
    if one {
        run.add_uniform(counts, b.data[x], (L * b.rows * b.slices) as u64);
        return;
    }
    for z in 0..b.slices {
        for r in 0..b.rows {
            let o = b.at(z, r) + x;
            run.add(counts, &b.data[o..o + L]);
        }
    }
}

/// Finish [`fold_box`] from column `x` on (fewer than a chunk), row by
/// row, and count the run left over.
#[inline(always)]
pub(crate) fn fold_box_rest<T: ScanSample, const L: usize>(
    mut t: BoxTargets<'_, T>,
    b: RowBox<'_, T>,
    x: usize,
    mut counts: Option<&mut ExactCounts>,
    mut run: Run<T, L>,
) {
    let w = t.width();
    if x < w {
        let cols = x..w;
        for z in 0..b.slices {
            for r in 0..b.rows {
                let o = b.at(z, r);
                let row = &b.data[o + x..o + w];
                fold_slice(&mut t.cell, &cols, row);
                let aprons = [
                    (r == 0, t.row_apron.as_mut()),
                    (z == 0, t.slice_apron.as_mut()),
                    (r == 0 && z == 0, t.corner.as_mut()),
                ];
                for (holds, apron) in aprons {
                    if let (true, Some(a)) = (holds, apron) {
                        fold_slice(a, &cols, row);
                    }
                }
                if let Some(c) = counts.as_deref_mut() {
                    run.add(c, row);
                }
            }
        }
    }
    if let Some(c) = counts {
        run.flush(c);
    }
}

/// Fold the `L` samples `s` into the register bounds `lo` and `hi`.
#[inline(always)]
fn fold_regs<T: ScanSample, const L: usize>(lo: &mut [T; L], hi: &mut [T; L], s: &[T]) {
    let s = &s[..L];
    for i in 0..L {
        lo[i] = T::lower(lo[i], s[i]);
        hi[i] = T::upper(hi[i], s[i]);
    }
}

/// Widen columns `cols` (`L` of them) of `acc` by `lo` and `hi`.
#[inline(always)]
fn fold_bounds<T: ScanSample, const L: usize>(
    acc: &mut Bounds<'_, T>,
    cols: &Range<usize>,
    lo: &[T; L],
    hi: &[T; L],
) {
    let (l, h) = (&mut acc.lo[cols.clone()], &mut acc.hi[cols.clone()]);
    let (l, h) = (&mut l[..L], &mut h[..L]);
    for i in 0..L {
        l[i] = T::lower(l[i], lo[i]);
        h[i] = T::upper(h[i], hi[i]);
    }
}

/// Fold the samples of `row` into columns `cols` of `acc`.
#[inline(always)]
fn fold_slice<T: ScanSample>(acc: &mut Bounds<'_, T>, cols: &Range<usize>, row: &[T]) {
    let (l, h) = (&mut acc.lo[cols.clone()], &mut acc.hi[cols.clone()]);
    for ((l, h), &v) in l.iter_mut().zip(h.iter_mut()).zip(row) {
        *l = T::lower(*l, v);
        *h = T::upper(*h, v);
    }
}

/// The run of one value being counted: chunks that continue it are counted
/// in a register, and the count table is touched only when the value
/// changes (an update per chunk would chain through memory).
pub(crate) struct Run<T, const L: usize> {
    /// The value, repeated across a whole chunk: a chunk continues the run
    /// when it equals this (compared as arrays, a few vector instructions;
    /// broadcasting the value per chunk would cost as many again).
    splat: [T; L],
    len: u64,
}

impl<T: ScanSample, const L: usize> Run<T, L> {
    /// No run yet.
    pub fn new() -> Self {
        Run {
            splat: [T::default(); L],
            len: 0,
        }
    }

    /// Whether every sample of `chunk` is the run's value.
    #[inline(always)]
    fn continues(&self, chunk: &[T]) -> bool {
        match <&[T; L]>::try_from(chunk) {
            Ok(whole) => *whole == self.splat,
            // A row's tail: branch-free, so the comparison vectorises.
            Err(_) => chunk
                .iter()
                .fold(true, |same, &x| same & (x == self.splat[0])),
        }
    }

    /// Count the samples of `chunk`.
    #[inline(always)]
    fn add(&mut self, counts: &mut ExactCounts, chunk: &[T]) {
        if self.continues(chunk) {
            self.len += chunk.len() as u64;
            return;
        }
        counts.add_run(self.splat[0], self.len);
        let Some(&first) = chunk.first() else { return };
        self.splat = [first; L];
        self.len = 0;
        if self.continues(chunk) {
            self.len = chunk.len() as u64;
        } else {
            counts.add_each(chunk);
        }
    }

    /// Count `n` samples of value `v`.
    #[inline(always)]
    fn add_uniform(&mut self, counts: &mut ExactCounts, v: T, n: u64) {
        if v == self.splat[0] {
            self.len += n;
        } else {
            counts.add_run(self.splat[0], self.len);
            self.splat = [v; L];
            self.len = n;
        }
    }

    /// Count the run so far.
    fn flush(self, counts: &mut ExactCounts) {
        counts.add_run(self.splat[0], self.len);
    }
}

/// Exact per-value sample counts of an integer type (empty for `f32`).
pub(crate) struct ExactCounts {
    lanes: usize,
    values: usize,
    counts: Vec<u64>,
}

impl ExactCounts {
    /// Zeroed counts for samples of type `T`.
    pub fn new<T: ScanSample>() -> Self {
        ExactCounts {
            lanes: T::COUNT_LANES,
            values: T::EXACT_VALUES,
            counts: vec![0; T::COUNT_LANES * T::EXACT_VALUES],
        }
    }

    /// Count `n` samples of value `v`.
    #[inline]
    pub fn add_run<T: ScanSample>(&mut self, v: T, n: u64) {
        if self.lanes > 0 {
            self.counts[v.slot() * self.lanes] += n;
        }
    }

    /// Count the samples of `part` one by one.
    #[inline]
    fn add_each<T: ScanSample>(&mut self, part: &[T]) {
        if self.lanes == 0 {
            return;
        }
        if self.lanes == 8 {
            // Lane k of value v at v·8 + k: neighbouring samples, often
            // equal, update different words.
            let counts = &mut self.counts[..self.values * 8];
            let mut eights = part.chunks_exact(8);
            for q in &mut eights {
                for (k, v) in q.iter().enumerate() {
                    counts[v.slot() * 8 + k] += 1;
                }
            }
            for (k, v) in eights.remainder().iter().enumerate() {
                counts[v.slot() * 8 + k] += 1;
            }
        } else {
            for v in part {
                self.counts[v.slot()] += 1;
            }
        }
    }

    /// The sum of two sets of counts (addition is exact in any order).
    pub fn merge(mut self, other: ExactCounts) -> ExactCounts {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self
    }

    /// The count of each value slot, lanes summed (empty for `f32`).
    pub fn per_value(&self) -> Vec<u64> {
        self.counts
            .chunks_exact(self.lanes.max(1))
            .map(|lanes| lanes.iter().sum())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds of one accumulator row `(lower, upper)`.
    fn bounds(b: &mut (Vec<u8>, Vec<u8>)) -> Bounds<'_, u8> {
        Bounds {
            lo: &mut b.0,
            hi: &mut b.1,
        }
    }

    /// Count `samples` chunk by chunk as the box folds do.
    fn count_chunks<T: ScanSample, const L: usize>(samples: &[T]) -> Vec<u64> {
        let mut counts = ExactCounts::new::<T>();
        let mut run = Run::<T, L>::new();
        for chunk in samples.chunks(L) {
            run.add(&mut counts, chunk);
        }
        run.flush(&mut counts);
        counts.per_value()
    }

    #[test]
    fn exact_counts_cover_every_value_once() {
        // Runs of one value (counted at once) between distinct values.
        let row: Vec<u8> = (0..=255u8)
            .chain([7; 70])
            .chain([1, 2])
            .chain([0; 40])
            .collect();
        let v = count_chunks::<u8, 32>(&row);
        assert_eq!((v[0], v[1], v[7]), (41, 2, 71));
        assert_eq!(v.iter().sum::<u64>(), row.len() as u64);
        assert_eq!(count_chunks::<u16, 16>(&[9; 100])[9], 100);
        let v = count_chunks::<i16, 16>(&[i16::MIN, -1, 0, i16::MAX]);
        assert_eq!((v[0], v[32767], v[32768], v[65535]), (1, 1, 1, 1));
    }

    /// Boxes of several shapes (widths with and without a partial chunk),
    /// rows of one value in runs of several values, rows that differ in one
    /// sample anywhere, with every set of apron targets: each target holds
    /// the bounds of its rows and the counts equal a brute-force pass, on
    /// the portable fold and on AVX2 where the CPU has it.
    #[test]
    fn box_folds_match_brute_force() {
        let shapes = [
            (1, 1, 1),
            (31, 2, 3),
            (32, 8, 8),
            (33, 9, 2),
            (129, 3, 5),
            (800, 8, 9),
        ];
        for (w, rows, slices) in shapes {
            let stride = w + 3;
            let plane = stride * rows + 5;
            let mut data = vec![0u8; plane * slices];
            for z in 0..slices {
                for r in 0..rows {
                    let row = &mut data[z * plane + r * stride..][..w];
                    row.fill([0, 0, 5, 5, 0, 9, 9, 0, 0][(z + r) % 9]);
                    if (z + 2 * r) % 3 == 1 {
                        row[(r * 37 + z * 11) % w] = 200;
                    }
                }
            }
            let at = |z: usize, r: usize, x: usize| data[z * plane + r * stride + x];
            let mut want_counts = vec![0u64; 256];
            for z in 0..slices {
                for r in 0..rows {
                    for x in 0..w {
                        want_counts[at(z, r, x) as usize] += 1;
                    }
                }
            }
            for (cpu, aprons) in [None, Avx2::detect()]
                .into_iter()
                .flat_map(|c| (0..4).map(move |a| (c, a)))
            {
                let what = format!("{w}x{rows}x{slices} {cpu:?} aprons {aprons}");
                let mut acc = [(); 4].map(|_| (vec![u8::MAX; w], vec![u8::MIN; w]));
                let mut counts = ExactCounts::new::<u8>();
                {
                    let [cell, row_apron, slice_apron, corner] = &mut acc;
                    let targets = BoxTargets {
                        cell: bounds(cell),
                        row_apron: (aprons & 1 == 1).then(|| bounds(row_apron)),
                        slice_apron: (aprons & 2 == 2).then(|| bounds(slice_apron)),
                        corner: (aprons == 3).then(|| bounds(corner)),
                    };
                    let rows = RowBox {
                        data: &data,
                        stride,
                        plane,
                        rows,
                        slices,
                    };
                    u8::fold_box(cpu, targets, rows, Some(&mut counts));
                }
                assert_eq!(counts.per_value(), want_counts, "{what}");
                let range = |zs: Range<usize>, rs: Range<usize>, x: usize| {
                    let v: Vec<u8> = zs
                        .flat_map(|z| rs.clone().map(move |r| (z, r)))
                        .map(|(z, r)| at(z, r, x))
                        .collect();
                    (
                        v.iter().copied().min().unwrap_or(u8::MAX),
                        v.iter().copied().max().unwrap_or(u8::MIN),
                    )
                };
                for x in 0..w {
                    let got = |k: usize| (acc[k].0[x], acc[k].1[x]);
                    assert_eq!(got(0), range(0..slices, 0..rows, x), "{what}: cell, x {x}");
                    let empty = (u8::MAX, u8::MIN);
                    let row_apron = if aprons & 1 == 1 {
                        range(0..slices, 0..1, x)
                    } else {
                        empty
                    };
                    assert_eq!(got(1), row_apron, "{what}: row apron, x {x}");
                    let slice_apron = if aprons & 2 == 2 {
                        range(0..1, 0..rows, x)
                    } else {
                        empty
                    };
                    assert_eq!(got(2), slice_apron, "{what}: slice apron, x {x}");
                    let corner = if aprons == 3 {
                        range(0..1, 0..1, x)
                    } else {
                        empty
                    };
                    assert_eq!(got(3), corner, "{what}: corner, x {x}");
                }
            }
        }
    }
}
