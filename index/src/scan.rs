//! Per-sample-type kernels of the build pass: element-wise min/max of rows
//! and per-cell folds in the native sample type (no `f32` conversion per
//! voxel), and exact per-value counting for integer types.

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
}

macro_rules! int_scan {
    ($t:ty, $lanes:expr) => {
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
        }
    };
}

int_scan!(u8, 4);
int_scan!(u16, 1);
int_scan!(i16, 1);

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
}

/// Widen a native range to `f32`, mapping `−0.0` to `+0.0` so that the
/// stored bits never depend on which of two equal zeros a fold kept.
#[inline]
pub(crate) fn range_to_f32<T: ScanSample>(lo: T, hi: T) -> (f32, f32) {
    (lo.to_f32() + 0.0, hi.to_f32() + 0.0)
}

/// Element-wise running minimum and maximum of rows of one length.
pub(crate) struct RowRange<T> {
    lo: Vec<T>,
    hi: Vec<T>,
}

impl<T: ScanSample> RowRange<T> {
    /// An empty accumulator for rows of `len` samples.
    pub fn new(len: usize) -> Self {
        RowRange {
            lo: vec![T::TOP; len],
            hi: vec![T::BOTTOM; len],
        }
    }

    /// Forget every row added so far.
    pub fn reset(&mut self) {
        self.lo.fill(T::TOP);
        self.hi.fill(T::BOTTOM);
    }

    /// Fold `row` in, element by element.
    #[inline]
    pub fn add(&mut self, row: &[T]) {
        for ((lo, hi), &v) in self.lo.iter_mut().zip(self.hi.iter_mut()).zip(row) {
            *lo = T::lower(*lo, v);
            *hi = T::upper(*hi, v);
        }
    }

    /// The range of elements `a ..= b`, widened to `f32`.
    #[inline]
    pub fn span(&self, a: usize, b: usize) -> (f32, f32) {
        let lo = self.lo[a..=b].iter().fold(T::TOP, |m, &v| T::lower(m, v));
        let hi = self.hi[a..=b]
            .iter()
            .fold(T::BOTTOM, |m, &v| T::upper(m, v));
        range_to_f32(lo, hi)
    }
}

/// Samples checked at once for a run of one value while counting.
const RUN: usize = 32;

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

    /// Count every sample of `row`. Runs of [`RUN`] equal samples (empty
    /// space, mostly) are counted in one step.
    #[inline]
    pub fn add<T: ScanSample>(&mut self, row: &[T]) {
        if self.lanes == 0 {
            return;
        }
        let mut runs = row.chunks_exact(RUN);
        for chunk in &mut runs {
            let v = chunk[0];
            // A branch-free fold, so the comparison vectorises.
            if chunk.iter().fold(true, |same, &x| same & (x == v)) {
                self.counts[v.slot()] += RUN as u64;
            } else {
                self.add_each(chunk);
            }
        }
        self.add_each(runs.remainder());
    }

    /// Count the samples of `part` one by one.
    #[inline]
    fn add_each<T: ScanSample>(&mut self, part: &[T]) {
        if self.lanes == 4 {
            let (t0, rest) = self.counts.split_at_mut(self.values);
            let (t1, rest) = rest.split_at_mut(self.values);
            let (t2, t3) = rest.split_at_mut(self.values);
            let mut quads = part.chunks_exact(4);
            for q in &mut quads {
                t0[q[0].slot()] += 1;
                t1[q[1].slot()] += 1;
                t2[q[2].slot()] += 1;
                t3[q[3].slot()] += 1;
            }
            for v in quads.remainder() {
                t0[v.slot()] += 1;
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
        let mut out = vec![0u64; self.values];
        for lane in self.counts.chunks_exact(self.values.max(1)) {
            for (o, &c) in out.iter_mut().zip(lane) {
                *o += c;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_folds_skip_nan_and_canonicalise_zero() {
        let mut r = RowRange::<f32>::new(3);
        r.add(&[f32::NAN, -0.0, 2.0]);
        r.add(&[f32::NAN, 1.0, f32::NAN]);
        let (lo, hi) = r.span(0, 0);
        assert!(lo > hi, "only NaNs must give the empty range");
        let (lo, hi) = r.span(1, 2);
        assert_eq!(
            (lo.to_bits(), hi.to_bits()),
            (0f32.to_bits(), 2f32.to_bits())
        );
    }

    #[test]
    fn exact_counts_cover_every_value_once() {
        // Runs of one value (counted at once) between distinct values.
        let row: Vec<u8> = (0..=255u8)
            .chain([7; 70])
            .chain([1, 2])
            .chain([0; 40])
            .collect();
        let mut c = ExactCounts::new::<u8>();
        c.add(&row);
        let v = c.per_value();
        assert_eq!((v[0], v[1], v[7]), (41, 2, 71));
        assert_eq!(v.iter().sum::<u64>(), row.len() as u64);
        let mut c = ExactCounts::new::<u16>();
        c.add(&[9u16; 100]);
        assert_eq!(c.per_value()[9], 100);
        let mut c = ExactCounts::new::<i16>();
        c.add(&[i16::MIN, -1, 0, i16::MAX]);
        let v = c.per_value();
        assert_eq!((v[0], v[32767], v[32768], v[65535]), (1, 1, 1, 1));
    }
}
