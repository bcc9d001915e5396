//! How much a 1D table's classification can change over a value range:
//! the total variation, over the bins the range covers, of each bin's
//! optical depth per step and of the light it emits per step (per colour
//! channel). Adaptive steps ([`crate::accel::strides`]) bound the error of
//! a longer step in a macrocell by it.
//!
//! Prefix sums of the bins' absolute differences make a range's variation
//! two lookups, so a frame's cells cost O(cells + bins).

use super::table::Bins;

/// Optical depth a bin of opacity 1 counts as: an opacity this close to 1
/// (1 − e⁻⁴⁰ rounds to 1 in f32) is opaque for every step, and a finite
/// depth keeps the sums finite.
const OPAQUE_DEPTH: f64 = 40.0;

/// Per-bin total variation of a 1D table (see the module docs).
#[derive(Clone, Debug)]
pub struct Variation {
    bins: Bins,
    /// `prefix[i]` = Σ over bins `1 ..= i` of `|x(i) − x(i − 1)|`, for
    /// `x` = optical depth, then the light per step in red, green, blue.
    prefix: Vec<[f64; 4]>,
}

impl Variation {
    /// The variation of the table whose bins are `bins` and whose entries
    /// (`[r, g, b, alpha]`, colour linear, opacity corrected for the
    /// frame's step) are `entries`, one per bin.
    pub fn new(bins: Bins, entries: &[[f32; 4]]) -> Variation {
        let per_step = |e: &[f32; 4]| {
            let a = f64::from(e[3]);
            let depth = if a.is_nan() || a <= 0.0 {
                0.0
            } else if a >= 1.0 {
                OPAQUE_DEPTH
            } else {
                (-(-a).ln_1p()).min(OPAQUE_DEPTH)
            };
            let light = |c: f32| f64::from(c).clamp(0.0, 1.0) * depth;
            [depth, light(e[0]), light(e[1]), light(e[2])]
        };
        let mut prefix = Vec::with_capacity(entries.len());
        let mut sum = [0f64; 4];
        let mut prev: Option<[f64; 4]> = None;
        for e in entries {
            let x = per_step(e);
            if let Some(p) = prev {
                for c in 0..4 {
                    sum[c] += (x[c] - p[c]).abs();
                }
            }
            prefix.push(sum);
            prev = Some(x);
        }
        Variation { bins, prefix }
    }

    /// The largest total variation, of optical depth or of any channel's
    /// light per step, over the bins that values in `[lo, hi]` fall in.
    /// Infinite for a range with NaN ends (no bound).
    pub fn over(&self, lo: f32, hi: f32) -> f64 {
        if lo.is_nan() || hi.is_nan() {
            return f64::INFINITY;
        }
        let (a, b) = (self.bins.bin(lo.min(hi)), self.bins.bin(lo.max(hi)));
        let (pa, pb) = (self.prefix[a], self.prefix[b]);
        (0..4).map(|c| pb[c] - pa[c]).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp of opacity over four bins, then a constant plateau: the
    /// plateau varies by nothing, the ramp by its rise in depth, and a
    /// range reaching across both by the ramp's part it covers.
    #[test]
    fn variation_is_the_rise_over_the_range() {
        let bins = Bins::new(0.0, 8.0, 8);
        let a = [0.0, 0.1, 0.2, 0.3, 0.5, 0.5, 0.5, 0.5];
        let entries: Vec<[f32; 4]> = a.iter().map(|&a| [1.0, 0.5, 0.0, a]).collect();
        let v = Variation::new(bins, &entries);
        let depth = |a: f64| -(1.0 - a).ln();
        assert_eq!(v.over(4.2, 7.9), 0.0);
        let ramp = v.over(0.5, 4.5);
        assert!((ramp - depth(0.5)).abs() < 1e-6, "{ramp}");
        // Red is 1: its light per step is the depth itself; green half.
        assert!((v.over(1.5, 2.5) - (depth(0.2) - depth(0.1))).abs() < 1e-6);
        // One value: one bin, no variation.
        assert_eq!(v.over(3.3, 3.3), 0.0);
        // Reversed ends read the same range; NaN gives no bound.
        assert_eq!(v.over(4.5, 0.5), ramp);
        assert_eq!(v.over(f32::NAN, 1.0), f64::INFINITY);
    }

    /// Opacity 1 counts as a finite depth: ranges stay finite, and a run
    /// of opaque bins varies by nothing.
    #[test]
    fn opaque_bins_stay_finite() {
        let bins = Bins::new(0.0, 4.0, 4);
        let entries = [
            [1.0, 1.0, 1.0, 0.0],
            [1.0, 1.0, 1.0, 1.0],
            [1.0, 1.0, 1.0, 1.0],
            [1.0, 1.0, 1.0, f32::NAN],
        ];
        let v = Variation::new(bins, &entries);
        assert_eq!(v.over(1.2, 2.8), 0.0);
        assert_eq!(v.over(0.2, 1.8), OPAQUE_DEPTH);
        assert_eq!(v.over(0.0, 4.0), 2.0 * OPAQUE_DEPTH);
    }
}
