//! Pre-integrated classification: a table over (front, back) value pairs
//! giving the colour and opacity of a whole ray segment between two
//! samples, on the assumption that the value varies linearly between
//! them (Engel, Kraus and Ertl's pre-integration, built exactly rather
//! than with their no-self-attenuation shortcut).
//!
//! With post-classification a sample stands for the step around it, so
//! a layer thinner than the step shows only when a sample lands in it.
//! A segment's entry instead composites, front to back, every value bin
//! the segment's values pass through, each for the share of the step the
//! linear ramp spends in it. Within a bin, colour and extinction are the
//! transfer function's at the bin's centre, as in the 1D table: the
//! table is exact for the binned transfer function.
//!
//! Equal front and back bins give the 1D table's entry for the step, bit
//! for bit, so a pair table and a 1D table of the same bins agree
//! wherever the volume is locally constant.

use super::table::{Bins, MAX_BINS};
use super::{correct_opacity, entry, Classifier, GradientBound, TfTable};
use crate::error::RenderError;
use crate::tf::TransferFunction;
use rayon::prelude::*;
use volindex::MinMaxIndex;

/// Most bins a pair table has: its entries grow as the square and its
/// build as the cube of the bins (1024: 16 MiB, about 0.4 s on one core).
pub const MAX_PAIR_BINS: usize = 1024;

/// Bins of a pair table by default: at most this many.
pub const DEFAULT_PAIR_BINS: usize = 512;

/// The pre-integrated table of a 1D transfer function for one step (see
/// the module docs).
#[derive(Clone, Debug)]
pub struct PairTable {
    /// The 1D table of the same bins at the same step: the classification
    /// of single samples (shadow rays) and the bins' transparency for
    /// skipping.
    single: TfTable,
    /// The same at half the step: a ray's ends.
    half: TfTable,
    /// `[r, g, b, alpha]` per (front bin, back bin), front-major: colour
    /// is the segment's emitted light divided by its opacity, so
    /// compositing `colour · alpha` adds the segment's light.
    pairs: Vec<[f32; 4]>,
    /// Bins per side.
    n: usize,
}

impl PairTable {
    /// Bins for a domain: a whole number of bins per unit of value when
    /// the span is a whole number no larger than `most` (so integer values
    /// fall on bin edges), else `most`.
    pub fn default_bins(lo: f32, hi: f32, most: usize) -> usize {
        let most = most.clamp(1, MAX_PAIR_BINS);
        let span = (hi - lo) as f64;
        if span >= 1.0 && span <= most as f64 && span.fract() == 0.0 {
            let span = span as usize;
            span * (most / span)
        } else {
            most
        }
    }

    /// The pair table of `tf` over `bins` bins (1 ..= [`MAX_PAIR_BINS`],
    /// clamped) of `[lo, hi]`, for segments `step` world units long;
    /// built in parallel, one task per distance between the bins.
    pub fn new(tf: &TransferFunction, lo: f32, hi: f32, bins: usize, step: f32) -> PairTable {
        let n = bins.clamp(1, MAX_PAIR_BINS.min(MAX_BINS));
        let single = TfTable::new(tf, lo, hi, n, step);
        let half = TfTable::new(tf, lo, hi, n, step * 0.5);
        let grid = Bins::new(lo, hi, n);
        // Each bin's linear colour and opacity at the reference step.
        let bin: Vec<([f32; 3], f32)> = (0..n)
            .map(|i| {
                let (rgb, alpha) = tf.eval(grid.centre(i));
                let lin = entry(rgb, 0.0, 1.0);
                ([lin[0], lin[1], lin[2]], alpha)
            })
            .collect();
        let ratio = step as f64 / tf.reference_step as f64;
        // ln(1 − α) per bin: a share `r` of the reference step has opacity
        // −expm1(r · ln(1 − α)), as `correct_opacity` computes it.
        let log_clear: Vec<f64> = bin
            .iter()
            .map(|b| match b.1 {
                a if a.is_nan() || a <= 0.0 => 0.0,
                a if a >= 1.0 => f64::NEG_INFINITY,
                a => (-(a as f64)).ln_1p(),
            })
            .collect();
        // Rows of pairs `distance` bins apart: (i, i ± distance), each a
        // task. A ramp across `distance` bins spends half as long in its
        // end bins as in each bin between; the bins between are
        // composited by sliding windows, so a row costs O(bins).
        let rows: Vec<Vec<(usize, [f32; 4])>> = (1..n)
            .into_par_iter()
            .map(|distance| {
                // An end bin's opacity `a` for half the share of a bin
                // between: that one's is `1 − (1 − a)² = a·(2 − a)`.
                let share = ratio / (2 * distance) as f64;
                let (end, middle): (Vec<Over>, Vec<Over>) = bin
                    .iter()
                    .zip(&log_clear)
                    .map(|(b, &l)| {
                        let a = -(l * share).exp_m1();
                        (Over::piece(b.0, a), Over::piece(b.0, a * (2.0 - a)))
                    })
                    .unzip();
                let width = distance - 1;
                let ahead = windows(&middle, width, |a, b| a.then(b));
                let back = windows(&middle, width, |a, b| b.then(a));
                let mut row = Vec::with_capacity(2 * (n - distance));
                for i in 0..n - distance {
                    let j = i + distance;
                    let up = end[i].then(ahead[i + 1]).then(end[j]);
                    row.push((i * n + j, up.entry()));
                    let down = end[j].then(back[i + 1]).then(end[i]);
                    row.push((j * n + i, down.entry()));
                }
                row
            })
            .collect();
        let mut pairs = vec![[0f32; 4]; n * n];
        for (i, b) in bin.iter().enumerate() {
            pairs[i * n + i] = entry_of_linear(b.0, correct_opacity(b.1, ratio));
        }
        for (at, e) in rows.into_iter().flatten() {
            pairs[at] = e;
        }
        PairTable {
            single,
            half,
            pairs,
            n,
        }
    }

    /// Bins per side.
    pub fn bins(&self) -> usize {
        self.n
    }

    /// The 1D table of the same bins and step.
    pub fn single(&self) -> &TfTable {
        &self.single
    }

    /// `[r, g, b, alpha]` of the segment from a sample of value `front` to
    /// the next, of value `back`; transparent when either is NaN.
    #[inline(always)]
    pub fn segment(&self, front: f32, back: f32) -> [f32; 4] {
        if front.is_nan() || back.is_nan() {
            return [0.0; 4];
        }
        let (i, j) = (self.single.bin(front), self.single.bin(back));
        self.pairs[i * self.n + j]
    }
}

/// Light and transmittance of a stretch of a segment, in f64: stretches
/// compose front to back with [`Over::then`] (associative, not
/// commutative).
#[derive(Clone, Copy, Debug)]
struct Over {
    /// Linear light it emits toward the front, per channel.
    light: [f64; 3],
    /// The fraction of light from behind that passes it.
    through: f64,
}

impl Over {
    /// Nothing: light passes unchanged.
    const CLEAR: Over = Over {
        light: [0.0; 3],
        through: 1.0,
    };

    /// A bin of linear colour `rgb` over a stretch of opacity `alpha`.
    fn piece(rgb: [f32; 3], alpha: f64) -> Over {
        let a = alpha.clamp(0.0, 1.0);
        Over {
            light: rgb.map(|c| c as f64 * a),
            through: 1.0 - a,
        }
    }

    /// This stretch in front of `back`.
    fn then(self, back: Over) -> Over {
        Over {
            light: std::array::from_fn(|c| self.light[c] + self.through * back.light[c]),
            through: self.through * back.through,
        }
    }

    /// As a table entry: colour is the light divided by the opacity.
    fn entry(self) -> [f32; 4] {
        let alpha = 1.0 - self.through;
        if alpha <= 0.0 {
            return [0.0; 4];
        }
        let c = self.light.map(|l| (l / alpha) as f32);
        [c[0], c[1], c[2], alpha as f32]
    }
}

/// For every start `a` with `a + width <= items.len()`, `items[a]` to
/// `items[a + width - 1]` combined in index order by the associative
/// `op` ([`Over::CLEAR`] when `width` is 0); one more entry (at
/// `items.len() - width + 1`) is [`Over::CLEAR`] so a window one past the
/// end can be asked for an empty range. O(items): the items are cut into
/// blocks of `width`, each position keeps the combination from itself to
/// its block's end and from its block's start to itself, and a window is
/// one of the first joined with one of the second.
fn windows(items: &[Over], width: usize, op: impl Fn(Over, Over) -> Over) -> Vec<Over> {
    let n = items.len();
    if width == 0 {
        return vec![Over::CLEAR; n + 1];
    }
    let mut to_end = items.to_vec();
    let mut from_start = items.to_vec();
    for block in (0..n).step_by(width) {
        let last = (block + width).min(n) - 1;
        for p in (block..last).rev() {
            to_end[p] = op(items[p], to_end[p + 1]);
        }
        for p in block + 1..=last {
            from_start[p] = op(from_start[p - 1], items[p]);
        }
    }
    let mut out: Vec<Over> = (0..=n.saturating_sub(width))
        .map(|a| {
            if a % width == 0 {
                to_end[a]
            } else {
                op(to_end[a], from_start[a + width - 1])
            }
        })
        .collect();
    out.push(Over::CLEAR);
    out
}

/// An entry of linear colour `rgb` and opacity `alpha`.
fn entry_of_linear(rgb: [f32; 3], alpha: f32) -> [f32; 4] {
    [rgb[0], rgb[1], rgb[2], alpha]
}

impl Classifier for PairTable {
    const NEEDS_GRADIENT: bool = false;
    const SEGMENTS: bool = true;

    #[inline(always)]
    fn classify(&self, v: f32, _gradient: f32) -> [f32; 4] {
        self.single.lookup(v)
    }

    #[inline(always)]
    fn classify_segment(&self, front: f32, back: f32) -> [f32; 4] {
        self.segment(front, back)
    }

    #[inline(always)]
    fn classify_half(&self, v: f32) -> [f32; 4] {
        self.half.lookup(v)
    }

    fn to_optical_depth(&self) -> Self {
        PairTable {
            single: self.single.to_optical_depth(),
            half: self.half.to_optical_depth(),
            ..self.clone()
        }
    }

    fn transparent_cells(
        &self,
        index: &MinMaxIndex,
        gradients: &GradientBound,
    ) -> Result<Vec<Vec<bool>>, RenderError> {
        // A segment is transparent when every bin between its ends is:
        // the single table's bins are the pairs' bins.
        self.single.transparent_cells(index, gradients)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf::{TfPoint, TfRange};

    fn ramp() -> TransferFunction {
        TransferFunction {
            points: vec![
                TfPoint {
                    value: 0.0,
                    rgb: [0.0, 0.2, 1.0],
                    alpha: 0.0,
                },
                TfPoint {
                    value: 255.0,
                    rgb: [1.0, 0.8, 0.0],
                    alpha: 0.6,
                },
            ],
            ranges: vec![TfRange {
                lo: 100.0,
                hi: 101.0,
                rgb: [1.0, 1.0, 1.0],
                alpha: 1.0,
            }],
            domain: None,
            reference_step: 1.0,
        }
    }

    #[test]
    fn equal_ends_are_the_single_table_bit_for_bit() {
        let tf = ramp();
        for step in [0.01, 0.5, 1.0, 3.7] {
            let p = PairTable::new(&tf, 0.0, 255.0, 255, step);
            let t = TfTable::new(&tf, 0.0, 255.0, 255, step);
            for v in [0.2, 17.5, 99.9, 100.5, 200.0, 254.9] {
                assert_eq!(
                    p.segment(v, v).map(f32::to_bits),
                    t.lookup(v).map(f32::to_bits),
                    "{v} at step {step}"
                );
            }
        }
    }

    /// A thin opaque layer between two samples shows, whichever way the
    /// ramp crosses it, where the single table sees nothing.
    #[test]
    fn a_layer_between_samples_is_seen_both_ways() {
        let mut tf = ramp();
        tf.points[1].alpha = 0.0;
        let p = PairTable::new(&tf, 0.0, 255.0, 255, 2.0);
        assert_eq!(p.single().lookup(90.5)[3], 0.0);
        assert_eq!(p.single().lookup(110.5)[3], 0.0);
        for e in [p.segment(90.5, 110.5), p.segment(110.5, 90.5)] {
            assert_eq!(e[3], 1.0, "{e:?}");
            assert!(e[..3].iter().all(|&c| (c - 1.0).abs() < 1e-6), "{e:?}");
        }
        // Ends on the layer's near side only: the layer is not reached.
        assert_eq!(p.segment(90.5, 99.5)[3], 0.0);
    }

    /// Against a fine Riemann sum of the emission-absorption integral
    /// over the binned transfer function.
    #[test]
    fn segments_match_a_fine_integration() {
        let mut tf = ramp();
        tf.ranges.clear();
        let (n, step) = (64usize, 0.8f32);
        let p = PairTable::new(&tf, 0.0, 64.0, n, step);
        for (i, j) in [(3usize, 40usize), (50, 10), (0, 63), (20, 21)] {
            let (a, b) = (i as f64 + 0.5, j as f64 + 0.5);
            let parts = 200_000;
            let dx = step as f64 / parts as f64;
            let (mut light, mut through) = ([0f64; 3], 1f64);
            for k in 0..parts {
                let v = a + (b - a) * (k as f64 + 0.5) / parts as f64;
                let centre = v.floor() + 0.5;
                let (rgb, alpha) = tf.eval(centre as f32);
                let lin = entry(rgb, 0.0, 1.0);
                let tau = -(-(alpha as f64)).ln_1p();
                let da = -(-tau * dx).exp_m1();
                for c in 0..3 {
                    light[c] += through * da * lin[c] as f64;
                }
                through *= 1.0 - da;
            }
            let e = p.segment(i as f32 + 0.5, j as f32 + 0.5);
            let alpha = 1.0 - through;
            assert!(
                (e[3] as f64 - alpha).abs() < 1e-4,
                "{i}->{j}: {e:?} vs {alpha}"
            );
            for c in 0..3 {
                let want = light[c];
                let got = e[c] as f64 * e[3] as f64;
                assert!(
                    (got - want).abs() < 1e-4,
                    "{i}->{j} channel {c}: {got} vs {want}"
                );
            }
        }
    }

    /// Sliding windows equal each window combined one by one, in both
    /// orders, for every width.
    #[test]
    fn windows_equal_combining_each_window() {
        let items: Vec<Over> = (0..23)
            .map(|i| {
                Over::piece(
                    [i as f32 / 23.0, 0.5, 1.0 - i as f32 / 46.0],
                    (i % 7) as f64 / 9.0,
                )
            })
            .collect();
        for width in 0..items.len() {
            for ahead in [true, false] {
                let op = |a: Over, b: Over| if ahead { a.then(b) } else { b.then(a) };
                let got = windows(&items, width, op);
                for a in 0..=items.len() - width {
                    let want = items[a..a + width]
                        .iter()
                        .fold(Over::CLEAR, |acc, &x| op(acc, x));
                    let (g, w) = (got[a], want);
                    assert!((g.through - w.through).abs() < 1e-12, "{width} {a}");
                    for c in 0..3 {
                        assert!((g.light[c] - w.light[c]).abs() < 1e-12, "{width} {a}");
                    }
                }
            }
        }
    }

    #[test]
    fn nan_ends_are_transparent_and_opaque_bins_stay_finite() {
        let mut tf = ramp();
        tf.points[1].alpha = 1.0;
        let p = PairTable::new(&tf, 0.0, 255.0, 510, 0.001);
        assert_eq!(p.segment(f32::NAN, 3.0), [0.0; 4]);
        assert_eq!(p.segment(3.0, f32::NAN), [0.0; 4]);
        for e in &p.pairs {
            assert!(e.iter().all(|x| x.is_finite()), "{e:?}");
            assert!((0.0..=1.0).contains(&e[3]));
        }
        assert_eq!(p.segment(0.0, 255.0)[3], 1.0);
    }

    #[test]
    fn bins_keep_integer_values_on_edges() {
        assert_eq!(PairTable::default_bins(0.0, 255.0, 512), 510);
        assert_eq!(PairTable::default_bins(-1024.0, 3071.0, 512), 512);
        assert_eq!(PairTable::default_bins(0.0, 1.0, 512), 512);
        assert_eq!(PairTable::default_bins(0.0, 0.5, 512), 512);
        assert_eq!(PairTable::default_bins(0.0, 255.0, 1 << 30), 1020);
    }
}
