//! Exact percentiles: the order statistics they need found by radix
//! selection on the samples' keys (16 bits a pass, [`super::sample`]),
//! then interpolated as numpy's default ('linear') method does.

/// The percentiles reported, in percent.
pub const PERCENTILES: [u32; 7] = [1, 5, 25, 50, 75, 95, 99];

/// Where percentile `p` (in percent) of `n` sorted values lies, as numpy's
/// 'linear' method puts it: between the values of 0-based ranks `lo` and
/// `hi`, at `gamma` from `lo` (virtual index `(n − 1)·p/100`). `n` must
/// not be 0.
pub(crate) fn position(n: u64, p: u32) -> (u64, u64, f64) {
    let q = p as f64 / 100.0;
    let h = (n - 1) as f64 * q;
    let lo = (h.floor() as u64).min(n - 1);
    let hi = (lo + 1).min(n - 1);
    (lo, hi, h - lo as f64)
}

/// numpy's `_lerp`: `a + (b − a)·t`, or `b − (b − a)·(1 − t)` from
/// `t = 0.5` on (so `t = 1` gives `b` exactly).
pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    let d = b - a;
    if t >= 0.5 {
        b - d * (1.0 - t)
    } else {
        a + d * t
    }
}

/// One order statistic being found: its rank among the values whose key
/// starts with the `digits` 16-bit digits of `prefix`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rank {
    rank: u64,
    prefix: u64,
    digits: u32,
}

impl Rank {
    /// The value of 0-based rank `rank` among all values.
    pub(crate) fn new(rank: u64) -> Rank {
        Rank {
            rank,
            prefix: 0,
            digits: 0,
        }
    }

    /// The digits known so far and their number.
    pub(crate) fn prefix(&self) -> (u64, u32) {
        (self.prefix, self.digits)
    }

    /// Take the next digit from `hist`, the counts of the next digit among
    /// the values that share this prefix.
    pub(crate) fn descend(&mut self, hist: &[u64]) {
        let mut seen = 0u64;
        let mut last = 0usize;
        for (d, &c) in hist.iter().enumerate() {
            if c == 0 {
                continue;
            }
            last = d;
            if self.rank < seen + c {
                break;
            }
            seen += c;
        }
        // Counts always cover the rank; were they short, the largest
        // digit seen stands (never a panic).
        self.rank = self.rank.saturating_sub(seen);
        self.prefix = self.prefix << 16 | last as u64;
        self.digits += 1;
    }

    /// The left-aligned key found (all digits known) or its start.
    pub(crate) fn key(&self) -> u64 {
        match self.digits {
            0 => 0,
            d => self.prefix << (64 - 16 * d),
        }
    }
}

/// Whether left-aligned `key` starts with `digits` digits `prefix`.
#[cfg(test)]
fn has_prefix(key: u64, prefix: u64, digits: u32) -> bool {
    digits == 0 || key >> (64 - 16 * digits) == prefix
}

/// Digit `digits` (0-based) of left-aligned `key`.
#[inline]
pub(crate) fn digit(key: u64, digits: u32) -> usize {
    ((key >> (48 - 16 * digits)) & 0xffff) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy.percentile(sorted, p) by its definition.
    fn numpy_percentile(sorted: &[f64], p: u32) -> f64 {
        let (lo, hi, g) = position(sorted.len() as u64, p);
        lerp(sorted[lo as usize], sorted[hi as usize], g)
    }

    #[test]
    fn positions_follow_numpy_linear() {
        assert_eq!(position(1, 50), (0, 0, 0.0));
        assert_eq!(position(5, 50), (2, 3, 0.0));
        assert_eq!(position(4, 50), (1, 2, 0.5));
        assert_eq!(position(101, 1), (1, 2, 0.0));
        let (lo, hi, g) = position(10, 25);
        assert_eq!((lo, hi), (2, 3));
        assert!((g - 0.25).abs() < 1e-15);
        assert_eq!(position(10, 100).0, 9);
        // Values checked by hand against numpy 2.x:
        // np.percentile([1, 2, 3, 4], 25) == 1.75
        assert_eq!(numpy_percentile(&[1.0, 2.0, 3.0, 4.0], 25), 1.75);
        // np.percentile([0, 10], 99) == 9.9
        assert_eq!(
            numpy_percentile(&[0.0, 10.0], 99),
            10.0 - 10.0 * (1.0 - 0.99)
        );
    }

    #[test]
    fn radix_descent_finds_the_rank() {
        // Keys with two digits: values (hi << 16 | lo) left-aligned.
        let vals: Vec<u64> = vec![5 << 16 | 9, 5 << 16 | 2, 1 << 16 | 7, 9 << 16];
        let keys: Vec<u64> = vals.iter().map(|v| v << 32).collect();
        let mut sorted = keys.clone();
        sorted.sort();
        for (r, want) in sorted.iter().enumerate() {
            let mut rank = Rank::new(r as u64);
            for _ in 0..2 {
                let (p, d) = rank.prefix();
                let mut h = vec![0u64; 65536];
                for &k in keys.iter().filter(|&&k| has_prefix(k, p, d)) {
                    h[digit(k, d)] += 1;
                }
                rank.descend(&h);
            }
            assert_eq!(rank.key(), *want, "rank {r}");
        }
    }
}
