//! O(1) "largest transfer-function value over a value range" queries.
//!
//! A [`RangeMaxTable`] divides a value domain `[lo, hi]` into `n` equal bins
//! and keeps each bin's largest value of a function (opacity, extinction)
//! in a sparse table: level `k` holds the maximum of bins `i .. i + 2^k`, so
//! any run of bins is covered by two overlapping power-of-two runs.
//!
//! Lookups are conservative: a value range `[a, b]` includes every bin whose
//! closed interval it touches (a value on the edge between two bins includes
//! both), widened by a hair (1e-9 bin) against rounding. Values outside the
//! domain clamp to the end bins. Built once per transfer function, the table
//! is independent of the index; [`crate::Level::majorants`] applies it to
//! every cell of a level.

use crate::error::IndexError;

/// Largest number of bins a table accepts.
pub const MAX_TABLE_BINS: usize = 1 << 22;
/// Function samples taken per bin by [`RangeMaxTable::from_fn`], edges
/// included (adjacent bins share their edge sample).
pub const SAMPLES_PER_BIN: usize = 5;
/// Slack, in bins, added on both sides of every query.
const SLACK: f64 = 1e-9;

/// Range-maximum table over binned function values (see the module docs).
#[derive(Clone, Debug)]
pub struct RangeMaxTable {
    lo: f64,
    hi: f64,
    scale: f64,
    /// `levels[k][i]` = max of bins `i .. i + 2^k`.
    levels: Vec<Vec<f32>>,
    /// `positive[i]` = how many of bins `0 .. i` have a maximum above 0.
    positive: Vec<u32>,
}

impl RangeMaxTable {
    /// A table over `[lo, hi]` whose bin `i` has maximum `maxima[i]`.
    /// Use this when the per-bin maxima are known exactly (e.g. from a
    /// piecewise-linear transfer function evaluated at its knots).
    pub fn from_bin_maxima(lo: f32, hi: f32, maxima: Vec<f32>) -> Result<Self, IndexError> {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(IndexError::Table(format!(
                "domain [{lo}, {hi}] must be finite and ordered"
            )));
        }
        if maxima.is_empty() || maxima.len() > MAX_TABLE_BINS {
            return Err(IndexError::Table(format!(
                "{} bins is outside 1..={MAX_TABLE_BINS}",
                maxima.len()
            )));
        }
        if let Some(i) = maxima.iter().position(|v| v.is_nan()) {
            return Err(IndexError::Table(format!("bin {i} has a NaN maximum")));
        }
        let n = maxima.len();
        let mut levels = vec![maxima];
        let mut span = 1;
        while 2 * span <= n {
            let prev = &levels[levels.len() - 1];
            let next: Vec<f32> = (0..=n - 2 * span)
                .map(|i| prev[i].max(prev[i + span]))
                .collect();
            levels.push(next);
            span *= 2;
        }
        let (lo, hi) = (f64::from(lo), f64::from(hi));
        let scale = if hi > lo { n as f64 / (hi - lo) } else { 0.0 };
        let positive = std::iter::once(0)
            .chain(levels[0].iter().scan(0u32, |c, &m| {
                *c += u32::from(m > 0.0);
                Some(*c)
            }))
            .collect();
        Ok(RangeMaxTable {
            lo,
            hi,
            scale,
            levels,
            positive,
        })
    }

    /// A table of `bins` bins over `[lo, hi]` (typically the volume's value
    /// range) from a function of the sample value. Each bin's maximum is
    /// taken over [`SAMPLES_PER_BIN`] evenly spaced samples of `f` across the
    /// bin, both edges included: exact for functions that are linear between
    /// those points, an estimate for anything wigglier.
    pub fn from_fn(
        lo: f32,
        hi: f32,
        bins: usize,
        f: impl Fn(f32) -> f32,
    ) -> Result<Self, IndexError> {
        if bins == 0 || bins > MAX_TABLE_BINS {
            return Err(IndexError::Table(format!(
                "{bins} bins is outside 1..={MAX_TABLE_BINS}"
            )));
        }
        let steps = (SAMPLES_PER_BIN - 1) as f64;
        let total = bins as f64 * steps;
        let (l, h) = (f64::from(lo), f64::from(hi));
        let at = |s: usize| f((l + (h - l) * (s as f64 / total)) as f32);
        let maxima = (0..bins)
            .map(|i| {
                let first = i * (SAMPLES_PER_BIN - 1);
                (first..first + SAMPLES_PER_BIN)
                    .map(at)
                    // Keep a NaN sample visible so the table rejects it.
                    .fold(
                        f32::NEG_INFINITY,
                        |m, v| if v.is_nan() { v } else { m.max(v) },
                    )
            })
            .collect();
        Self::from_bin_maxima(lo, hi, maxima)
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.levels[0].len()
    }

    /// The value domain `[lo, hi]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    /// The per-bin maxima.
    pub fn bin_maxima(&self) -> &[f32] {
        &self.levels[0]
    }

    /// The bins touched by `[a, b]` (`a <= b`, neither NaN), clamped.
    #[inline]
    fn bin_span(&self, a: f32, b: f32) -> (usize, usize) {
        let last = self.bins() - 1;
        if self.scale == 0.0 {
            return (0, last);
        }
        let t0 = (f64::from(a) - self.lo) * self.scale;
        let t1 = (f64::from(b) - self.lo) * self.scale;
        // i = ceil(t0 − slack) − 1 and j = floor(t1 + slack), each clamped
        // to 0 ..= last. Clamping first keeps the values where truncation
        // is exact and lets it stand in for floor and ceil (libm calls on
        // baseline x86-64, a third of the time of a pass over every cell).
        // Through i64: in range, and one instruction where `as usize`
        // takes several.
        let top = (last + 1) as f64;
        let x = (t0 - SLACK).clamp(0.0, top);
        let c = x as i64;
        let ceil = c + i64::from((c as f64) < x);
        let i = (ceil - 1).max(0) as usize;
        let j = (t1 + SLACK).clamp(0.0, top) as i64 as usize;
        (i.min(last), j.min(last))
    }

    /// Whether the function is at most 0 over all of `[a, b]`: exactly
    /// `max_over(a, b) <= 0.0`, from a prefix count of positive bins (two
    /// loads, no sparse-table levels).
    #[inline]
    pub fn zero_over(&self, a: f32, b: f32) -> bool {
        let (i, j) = if a.is_nan() || b.is_nan() {
            (0, self.bins() - 1)
        } else if a > b {
            return true;
        } else {
            self.bin_span(a, b)
        };
        self.positive[j + 1] == self.positive[i]
    }

    /// The largest function value over value range `[a, b]`, in O(1).
    /// An empty range (`a > b`, as in an empty cell) gives 0; a NaN bound
    /// gives the maximum over all bins.
    #[inline]
    pub fn max_over(&self, a: f32, b: f32) -> f32 {
        if a.is_nan() || b.is_nan() {
            return self.max_bins(0, self.bins() - 1);
        }
        if a > b {
            return 0.0;
        }
        let (i, j) = self.bin_span(a, b);
        self.max_bins(i, j)
    }

    /// The largest maximum of bins `i ..= j` (`i <= j < bins`).
    #[inline]
    fn max_bins(&self, i: usize, j: usize) -> f32 {
        let k = (usize::BITS - 1 - (j - i + 1).leading_zeros()) as usize;
        let level = &self.levels[k];
        level[i].max(level[j + 1 - (1 << k)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the largest maximum over bins whose closed interval
    /// meets `[a, b]` clamped to the domain.
    fn brute(lo: f32, hi: f32, maxima: &[f32], a: f32, b: f32) -> f32 {
        if a > b {
            return 0.0;
        }
        let (lo, hi) = (lo as f64, hi as f64);
        let (a, b) = ((a as f64).clamp(lo, hi), (b as f64).clamp(lo, hi));
        let w = (hi - lo) / maxima.len() as f64;
        let mut m = f32::NEG_INFINITY;
        for (i, &v) in maxima.iter().enumerate() {
            let (s, e) = (lo + i as f64 * w, lo + (i + 1) as f64 * w);
            if s <= b && e >= a {
                m = m.max(v);
            }
        }
        m
    }

    #[test]
    fn random_queries_match_brute_force() {
        let mut rng = fastrand::Rng::with_seed(11);
        for bins in [1, 2, 3, 7, 64, 255, 256, 1000] {
            let (lo, hi) = (-37.5f32, 212.25f32);
            let maxima: Vec<f32> = (0..bins).map(|_| rng.f32() * 10.0 - 2.0).collect();
            let t = RangeMaxTable::from_bin_maxima(lo, hi, maxima.clone()).unwrap();
            for _ in 0..2000 {
                let mut a = lo - 20.0 + rng.f32() * (hi - lo + 40.0);
                let mut b = if rng.u8(..4) == 0 {
                    a
                } else {
                    lo - 20.0 + rng.f32() * (hi - lo + 40.0)
                };
                if a > b && rng.bool() {
                    std::mem::swap(&mut a, &mut b);
                }
                assert_eq!(
                    t.max_over(a, b),
                    brute(lo, hi, &maxima, a, b),
                    "bins {bins} query [{a}, {b}]"
                );
            }
        }
    }

    /// The prefix-count test agrees with the range maximum, on tables with
    /// runs of zero and negative bins, at bin edges, outside the domain and
    /// for NaN and empty ranges.
    #[test]
    fn zero_over_is_max_over_at_most_zero() {
        let mut rng = fastrand::Rng::with_seed(12);
        for bins in [1, 2, 5, 64, 256, 1000] {
            let (lo, hi) = (0.0f32, 255.0f32);
            let maxima: Vec<f32> = (0..bins)
                .map(|_| match rng.u8(..4) {
                    0 => 0.5,
                    1 => -1.0,
                    _ => 0.0,
                })
                .collect();
            let t = RangeMaxTable::from_bin_maxima(lo, hi, maxima).unwrap();
            let edge = |r: &mut fastrand::Rng| r.usize(0..=bins) as f32 * (hi - lo) / bins as f32;
            for _ in 0..3000 {
                let (a, b) = match rng.u8(..3) {
                    0 => (edge(&mut rng), edge(&mut rng)),
                    1 => (rng.f32() * 300.0 - 20.0, rng.f32() * 300.0 - 20.0),
                    _ => {
                        let a = rng.f32() * 255.0;
                        (a, a + rng.f32() * 3.0)
                    }
                };
                assert_eq!(
                    t.zero_over(a, b),
                    t.max_over(a, b) <= 0.0,
                    "{bins}: [{a}, {b}]"
                );
            }
            for (a, b) in [
                (f32::NAN, 1.0),
                (2.0, 1.0),
                (f32::NEG_INFINITY, f32::INFINITY),
            ] {
                assert_eq!(t.zero_over(a, b), t.max_over(a, b) <= 0.0, "[{a}, {b}]");
            }
        }
    }

    #[test]
    fn touching_a_bin_edge_includes_both_bins() {
        let mut maxima = vec![0.0f32; 256];
        maxima[9] = 1.0;
        maxima[10] = 2.0;
        let t = RangeMaxTable::from_bin_maxima(0.0, 256.0, maxima).unwrap();
        assert_eq!(t.max_over(10.0, 10.0), 2.0);
        assert_eq!(t.max_over(5.0, 9.0), 1.0); // 9.0 touches bin 9's lower edge
        assert_eq!(t.max_over(10.5, 10.7), 2.0);
        assert_eq!(t.max_over(11.0, 30.0), 2.0); // 11.0 touches bin 10's upper edge
        assert_eq!(t.max_over(11.5, 30.0), 0.0);
        assert_eq!(t.max_over(f32::INFINITY, f32::NEG_INFINITY), 0.0);
        assert_eq!(t.max_over(f32::NAN, 3.0), 2.0);
        assert_eq!(t.max_over(-1e9, 1e9), 2.0);
    }

    #[test]
    fn from_fn_bounds_a_piecewise_linear_function() {
        // A tent peaking at 100 between sample points of bin 12 of 50.
        let f = |v: f32| (1.0 - (v - 100.0).abs() / 30.0).max(0.0);
        let t = RangeMaxTable::from_fn(0.0, 400.0, 50, f).unwrap();
        let mut rng = fastrand::Rng::with_seed(5);
        for _ in 0..1000 {
            let a = rng.f32() * 400.0;
            let b = (a + rng.f32() * 40.0).min(400.0);
            let truth = (0..=200)
                .map(|s| f(a + (b - a) * s as f32 / 200.0))
                .fold(0.0f32, f32::max);
            assert!(t.max_over(a, b) >= truth - 1e-6, "[{a}, {b}]");
        }
        assert!(RangeMaxTable::from_fn(0.0, 1.0, 0, f).is_err());
        assert!(RangeMaxTable::from_fn(1.0, 0.0, 4, f).is_err());
        assert!(RangeMaxTable::from_fn(0.0, 1.0, 4, |_| f32::NAN).is_err());
    }

    #[test]
    fn degenerate_domain_answers_with_every_bin() {
        let t = RangeMaxTable::from_bin_maxima(3.0, 3.0, vec![0.5, 0.25]).unwrap();
        assert_eq!(t.max_over(3.0, 3.0), 0.5);
    }
}
