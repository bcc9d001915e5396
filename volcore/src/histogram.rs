//! A sample histogram and its binning rule: the histogram `vol-index`
//! stores in a `.vidx` and `vol-info --stats` prints, so `--bins N` means
//! the same in both tools.
//!
//! A histogram has `n` equal bins over `[lo, hi]`: bin `i` covers
//! `[lo + i·w, lo + (i+1)·w)` with `w = (hi − lo) / n`, the last bin also
//! holds `hi`. A value `v` goes to bin `floor((v − lo)·n / (hi − lo))`
//! (computed in `f64`), clamped to `0 ..= n − 1`; when `hi == lo` every
//! value goes to bin 0. NaN samples are not binned but counted apart.
//!
//! The layout depends on the sample type (with `B` requested bins,
//! default 256):
//! - Integer types whose every value fits in `B` bins (`u8` with the
//!   default): one bin per possible value, `lo` = the type's minimum,
//!   width 1. For `u8` that is exactly bins `0 ..= 255`.
//! - Other integer types (`u16`, `i16`): bins of integer width
//!   `w = ceil(span / B)` starting at the data minimum, `span = max − min + 1`
//!   values, `n = ceil(span / w) <= B` bins, `hi = lo + n·w`. Each bin holds
//!   exactly `w` integer values, so no bin is favoured by rounding. Samples
//!   are counted exactly per value during the build pass and rebinned.
//! - `f32`: `B` bins over the range of the finite samples (infinities land
//!   in the end bins). This needs the range first, so `f32` volumes are read
//!   a second time for the histogram.

/// Sample counts in equal bins over a value range (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    lo: f64,
    hi: f64,
    counts: Vec<u64>,
    nan_count: u64,
}

/// Default number of histogram bins.
pub const DEFAULT_BINS: u32 = 256;
/// Largest number of histogram bins accepted (when building and reading).
pub const MAX_BINS: u32 = 1 << 16;

impl Histogram {
    /// A histogram from its parts; `counts` must not be empty.
    pub fn from_parts(lo: f64, hi: f64, counts: Vec<u64>, nan_count: u64) -> Histogram {
        Histogram {
            lo,
            hi,
            counts,
            nan_count,
        }
    }

    /// Rebin exact per-value counts of an integer type whose smallest value
    /// is `type_min` (slot `s` holds value `type_min + s`) into at most
    /// `bins` bins, following the module rule.
    pub fn from_exact(type_min: f64, per_value: &[u64], bins: u32) -> Histogram {
        let bins = bins.max(1) as u64;
        let values = per_value.len() as u64;
        let (first, last) = if values <= bins {
            (0, values.saturating_sub(1))
        } else {
            let first = per_value.iter().position(|&c| c > 0).unwrap_or(0) as u64;
            let last = per_value.iter().rposition(|&c| c > 0).unwrap_or(0) as u64;
            (first, last.max(first))
        };
        let span = last - first + 1;
        let width = span.div_ceil(bins);
        let n = span.div_ceil(width);
        let mut counts = vec![0u64; n as usize];
        for (s, &c) in per_value.iter().enumerate() {
            let s = s as u64;
            if c > 0 && (first..=last).contains(&s) {
                counts[((s - first) / width) as usize] += c;
            }
        }
        let lo = type_min + first as f64;
        Histogram::from_parts(lo, lo + (n * width) as f64, counts, 0)
    }

    /// Lower edge of the first bin.
    pub fn lo(&self) -> f64 {
        self.lo
    }

    /// Upper edge of the last bin.
    pub fn hi(&self) -> f64 {
        self.hi
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.counts.len()
    }

    /// Samples per bin.
    pub fn counts(&self) -> &[u64] {
        &self.counts
    }

    /// NaN samples (not in any bin).
    pub fn nan_count(&self) -> u64 {
        self.nan_count
    }

    /// Binned (non-NaN) samples.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// The bin value `v` falls in (`v` must not be NaN).
    #[inline]
    pub fn bin_of(&self, v: f64) -> usize {
        bin_of(v, self.lo, self.hi, self.counts.len())
    }

    /// The value interval `[start, end)` of bin `i`.
    pub fn bin_edges(&self, i: usize) -> (f64, f64) {
        let n = self.counts.len() as f64;
        let w = (self.hi - self.lo) / n;
        (self.lo + i as f64 * w, self.lo + (i + 1) as f64 * w)
    }

    /// The lower edge of the bin holding quantile `q` (0..=1) of the binned
    /// samples: exact for integer bins of width 1, such as every u8
    /// histogram; `None` when no sample is binned or `q` is not a number.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        let total = self.total();
        if total == 0 || q.is_nan() {
            return None;
        }
        let want = ((q.clamp(0.0, 1.0) * total as f64).ceil() as u64).clamp(1, total);
        let mut seen = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= want {
                return Some(self.bin_edges(i).0);
            }
        }
        None
    }

    /// The `n` fullest non-empty bins, fullest first (ties: lower bin
    /// first).
    pub fn busiest(&self, n: usize) -> Vec<usize> {
        let c = &self.counts;
        let mut bins: Vec<usize> = (0..c.len()).filter(|&i| c[i] > 0).collect();
        bins.sort_by(|&a, &b| c[b].cmp(&c[a]).then(a.cmp(&b)));
        bins.truncate(n);
        bins
    }

    /// Whether every bin holds a single integer value.
    pub fn unit_bins(&self) -> bool {
        let w = (self.hi - self.lo) / self.bins() as f64;
        w == 1.0 && self.lo.fract() == 0.0
    }

    /// Bin `i` as text: its value for unit bins, else its interval.
    pub fn bin_label(&self, i: usize) -> String {
        let (a, b) = self.bin_edges(i);
        if self.unit_bins() {
            format!("{a}")
        } else {
            format!("[{}, {})", a as f32, b as f32)
        }
    }

    /// Set the number of NaN samples (counted apart from the bins).
    pub fn set_nan_count(&mut self, n: u64) {
        self.nan_count = n;
    }
}

/// The bin of `v` among `n` bins over `[lo, hi]` (module rule).
#[inline]
pub fn bin_of(v: f64, lo: f64, hi: f64, n: usize) -> usize {
    if lo.is_nan() || hi.is_nan() || hi <= lo {
        return if v > hi { n - 1 } else { 0 };
    }
    let t = ((v - lo) * n as f64 / (hi - lo)).floor();
    // Saturating cast: below 0 (and -inf) gives 0, above n gives n − 1.
    (t.max(0.0) as usize).min(n - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_lower_bin_edges() {
        // 100 samples: value v (0..=99) once each, in u8's unit bins.
        let mut per = vec![0u64; 256];
        per[..100].fill(1);
        let h = Histogram::from_exact(0.0, &per, 256);
        assert_eq!(h.quantile(0.0), Some(0.0));
        assert_eq!(h.quantile(0.01), Some(0.0));
        assert_eq!(h.quantile(0.015), Some(1.0));
        assert_eq!(h.quantile(0.5), Some(49.0));
        assert_eq!(h.quantile(0.99), Some(98.0));
        assert_eq!(h.quantile(1.0), Some(99.0));
        assert_eq!(h.quantile(f64::NAN), None);
        let empty = Histogram::from_exact(0.0, &[0u64; 256], 256);
        assert_eq!(empty.quantile(0.5), None);
    }

    #[test]
    fn u8_layout_is_one_bin_per_value() {
        let mut per = vec![0u64; 256];
        per[3] = 5;
        per[255] = 1;
        let h = Histogram::from_exact(0.0, &per, 256);
        assert_eq!((h.lo(), h.hi(), h.bins()), (0.0, 256.0, 256));
        assert_eq!((h.counts()[3], h.counts()[255]), (5, 1));
        for v in 0..256 {
            assert_eq!(h.bin_of(v as f64), v);
        }
    }

    #[test]
    fn wide_integer_layout_uses_integer_widths_from_the_data_min() {
        // i16 data in -1024 ..= 3071: 4096 values, width 16, 256 bins.
        let mut per = vec![0u64; 65536];
        let slot = |v: i64| (v + 32768) as usize;
        per[slot(-1024)] = 1;
        per[slot(-1009)] = 2; // still bin 0 (16 values per bin)
        per[slot(-1008)] = 4; // bin 1
        per[slot(3071)] = 8;
        let h = Histogram::from_exact(-32768.0, &per, 256);
        assert_eq!((h.lo(), h.hi(), h.bins()), (-1024.0, 3072.0, 256));
        assert_eq!(&h.counts()[..2], &[3, 4]);
        assert_eq!(h.counts()[255], 8);
        assert_eq!(h.bin_of(-1009.0), 0);
        assert_eq!(h.bin_of(-1008.0), 1);
        // A span that does not divide evenly: 1000 values, width 4, 250 bins.
        let mut per = vec![0u64; 65536];
        per[10] = 1;
        per[1009] = 1;
        let h = Histogram::from_exact(0.0, &per, 256);
        assert_eq!((h.lo(), h.hi(), h.bins()), (10.0, 1010.0, 250));
        assert_eq!((h.counts()[0], h.counts()[249]), (1, 1));
    }

    #[test]
    fn float_binning_clamps_and_handles_degenerate_ranges() {
        assert_eq!(bin_of(1.0, 0.0, 1.0, 4), 3);
        assert_eq!(bin_of(0.25, 0.0, 1.0, 4), 1);
        assert_eq!(bin_of(f64::NEG_INFINITY, 0.0, 1.0, 4), 0);
        assert_eq!(bin_of(f64::INFINITY, 0.0, 1.0, 4), 3);
        assert_eq!(bin_of(5.0, 5.0, 5.0, 4), 0);
    }
}
