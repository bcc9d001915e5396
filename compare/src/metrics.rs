//! The figures: running sums over compared pairs of values, and the
//! metrics derived from them.

/// Running sums over pairs `(a, b)` of compared values, in `f64`.
///
/// Two values are equal when they compare equal or are both NaN. A pair
/// whose difference is not finite (NaN in one input only, or infinities)
/// counts as differing and in [`Accumulator::nonfinite`], and is left out
/// of the squared-error sum and the maximum.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accumulator {
    /// Pairs compared.
    pub count: u64,
    /// Σ (a − b)² over pairs with a finite difference.
    pub sum_sq: f64,
    /// Largest |a − b| over pairs with a finite difference.
    pub max_abs: f64,
    /// Pairs that are not equal.
    pub differing: u64,
    /// Pairs whose difference is not finite.
    pub nonfinite: u64,
}

impl Accumulator {
    /// Add one pair; returns |a − b| (0 when equal, +∞ when not finite).
    #[inline]
    pub fn add(&mut self, a: f64, b: f64) -> f64 {
        self.count += 1;
        if a == b || (a.is_nan() && b.is_nan()) {
            return 0.0;
        }
        self.differing += 1;
        let d = a - b;
        if !d.is_finite() {
            self.nonfinite += 1;
            return f64::INFINITY;
        }
        self.sum_sq += d * d;
        let ad = d.abs();
        if ad > self.max_abs {
            self.max_abs = ad;
        }
        ad
    }

    /// Add another accumulator's pairs to this one.
    pub fn merge(&mut self, o: &Accumulator) {
        self.count += o.count;
        self.sum_sq += o.sum_sq;
        self.max_abs = self.max_abs.max(o.max_abs);
        self.differing += o.differing;
        self.nonfinite += o.nonfinite;
    }

    /// The metrics for a data range of `peak`.
    pub fn finish(&self, peak: f64) -> Metrics {
        let finite = self.count - self.nonfinite;
        let mse = if finite == 0 {
            0.0
        } else {
            self.sum_sq / finite as f64
        };
        Metrics {
            count: self.count,
            mse,
            psnr: psnr(mse, peak),
            peak,
            max_abs: self.max_abs,
            differing: self.differing,
            differing_fraction: if self.count == 0 {
                0.0
            } else {
                self.differing as f64 / self.count as f64
            },
            nonfinite: self.nonfinite,
        }
    }
}

/// PSNR in dB for a mean squared error and a peak (data range):
/// 10 · log10(peak² / mse), +∞ when `mse` is 0.
pub fn psnr(mse: f64, peak: f64) -> f64 {
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / mse).log10()
    }
}

/// How far apart two sets of values are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Values compared (pixels × channels, or voxels).
    pub count: u64,
    /// Mean squared error over the values with a finite difference.
    pub mse: f64,
    /// Peak signal-to-noise ratio in dB; +∞ when `mse` is 0.
    pub psnr: f64,
    /// The data range the PSNR is relative to.
    pub peak: f64,
    /// Largest absolute difference (over finite differences).
    pub max_abs: f64,
    /// Values that differ.
    pub differing: u64,
    /// `differing / count`.
    pub differing_fraction: f64,
    /// Values whose difference is not finite (NaN in one input only, or
    /// infinities), left out of `mse` and `max_abs`.
    pub nonfinite: u64,
}

impl Metrics {
    /// Whether every compared value is equal (NaN equals NaN).
    pub fn identical(&self) -> bool {
        self.differing == 0
    }

    /// The figures as one JSON object, as `vol-psnr --json` prints them:
    /// `psnr` is null when infinite (identical inputs).
    pub fn figures(&self) -> serde_json::Value {
        serde_json::json!({
            "psnr": self.psnr.is_finite().then_some(self.psnr),
            "identical": self.identical(),
            "mse": self.mse,
            "max_abs": self.max_abs,
            "differing": self.differing,
            "differing_fraction": self.differing_fraction,
            "count": self.count,
            "nonfinite": self.nonfinite,
            "peak": self.peak,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_nan_and_nonfinite_pairs() {
        let mut a = Accumulator::default();
        assert_eq!(a.add(1.0, 1.0), 0.0);
        assert_eq!(a.add(f64::NAN, f64::NAN), 0.0);
        assert_eq!(a.add(f64::INFINITY, f64::INFINITY), 0.0);
        assert_eq!(a.add(3.0, 1.0), 2.0);
        assert_eq!(a.add(f64::NAN, 1.0), f64::INFINITY);
        assert_eq!(a.count, 5);
        assert_eq!(a.differing, 2);
        assert_eq!(a.nonfinite, 1);
        let m = a.finish(1.0);
        // 4 is summed over the 4 pairs with a finite difference.
        assert_eq!(m.mse, 1.0);
        assert_eq!(m.max_abs, 2.0);
        assert_eq!(m.psnr, 0.0);
        assert!(!m.identical());
        assert_eq!(m.differing_fraction, 0.4);
    }

    #[test]
    fn zero_error_is_infinite_psnr() {
        assert_eq!(psnr(0.0, 255.0), f64::INFINITY);
        let mut a = Accumulator::default();
        a.add(7.0, 7.0);
        let m = a.finish(255.0);
        assert!(m.identical());
        assert_eq!(m.psnr, f64::INFINITY);
    }

    #[test]
    fn merge_is_the_sum_of_parts() {
        let mut whole = Accumulator::default();
        let mut left = Accumulator::default();
        let mut right = Accumulator::default();
        for i in 0..10 {
            let (a, b) = (i as f64, (i * i % 7) as f64);
            whole.add(a, b);
            if i < 4 {
                left.add(a, b);
            } else {
                right.add(a, b);
            }
        }
        left.merge(&right);
        assert_eq!(left, whole);
    }
}
