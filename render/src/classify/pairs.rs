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
        // Rows of pairs `distance` bins apart: (i, i ± distance).
        let rows: Vec<Vec<(usize, [f32; 4])>> = (1..n)
            .into_par_iter()
            .map(|distance| {
                // A ramp across `distance` bins spends half as long in its
                // end bins as in each bin between.
                let middle: Vec<f32> = bin
                    .iter()
                    .map(|b| correct_opacity(b.1, ratio / distance as f64))
                    .collect();
                let end: Vec<f32> = bin
                    .iter()
                    .map(|b| correct_opacity(b.1, ratio / (2 * distance) as f64))
                    .collect();
                let mut row = Vec::with_capacity(2 * (n - distance));
                for i in 0..n - distance {
                    let j = i + distance;
                    let up = (i..=j).map(|b| piece(b, i, j, &middle, &end, &bin));
                    row.push((i * n + j, composite(up)));
                    let down = (i..=j).rev().map(|b| piece(b, j, i, &middle, &end, &bin));
                    row.push((j * n + i, composite(down)));
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

/// Bin `b`'s colour and its opacity over its share of a ramp from bin
/// `from` to bin `to`.
#[inline]
fn piece(
    b: usize,
    from: usize,
    to: usize,
    middle: &[f32],
    end: &[f32],
    bin: &[([f32; 3], f32)],
) -> ([f32; 3], f32) {
    let a = if b == from || b == to {
        end[b]
    } else {
        middle[b]
    };
    (bin[b].0, a)
}

/// Composite pieces (linear colour, opacity) front to back into one
/// entry, in f64.
fn composite(pieces: impl Iterator<Item = ([f32; 3], f32)>) -> [f32; 4] {
    let mut light = [0f64; 3];
    let mut through = 1f64;
    for (rgb, a) in pieces {
        let w = through * a as f64;
        for (l, c) in light.iter_mut().zip(rgb) {
            *l += w * c as f64;
        }
        through *= 1.0 - a as f64;
    }
    let alpha = 1.0 - through;
    if alpha <= 0.0 {
        return [0.0; 4];
    }
    let c = light.map(|l| (l / alpha) as f32);
    [c[0], c[1], c[2], alpha as f32]
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
