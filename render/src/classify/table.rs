//! The 1D lookup table: a transfer function sampled per value bin, with
//! opacity corrected for the step.

use super::entry;
use super::{Classifier, GradientBound};
use crate::error::RenderError;
use crate::tf::TransferFunction;
use volindex::{MajorantIndex, RangeMaxTable};

/// Equal bins over a domain `[lo, hi]`, and the bin of a value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bins {
    lo: f32,
    scale: f32,
    width: f32,
    /// The last bin's index, as f32 (exact: at most [`MAX_BINS`] bins).
    top: f32,
    count: usize,
}

impl Bins {
    /// `count` bins (1 ..= [`MAX_BINS`], clamped) over `[lo, hi]`.
    pub fn new(lo: f32, hi: f32, count: usize) -> Bins {
        let count = count.clamp(1, MAX_BINS);
        let width = ((hi - lo) / count as f32).max(f32::MIN_POSITIVE);
        Bins {
            lo,
            scale: 1.0 / width,
            width,
            top: (count - 1) as f32,
            count,
        }
    }

    /// Number of bins.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The value at the centre of bin `i`.
    pub fn centre(&self, i: usize) -> f32 {
        self.lo + (i as f32 + 0.5) * self.width
    }

    /// The domain the bins cover.
    pub fn domain(&self) -> (f32, f32) {
        (self.lo, self.lo + self.count as f32 / self.scale)
    }

    /// The bin of value `v` (values outside the domain clamp to the end
    /// bins; NaN to the first).
    #[inline(always)]
    pub fn bin(&self, v: f32) -> usize {
        let i = (v - self.lo) * self.scale;
        // Clamp in floats (negative or NaN → 0, huge → the last bin), then
        // a plain truncation: cheaper than a saturating cast and an integer
        // clamp.
        let top = self.top;
        let i = if i > 0.0 {
            if i < top {
                i
            } else {
                top
            }
        } else {
            0.0
        };
        volcore::grid::trunc_in_range(i) as usize
    }
}

/// A transfer function sampled into bins over a value domain, with each
/// bin's opacity already corrected for the frame's step, so the inner loop
/// does one lookup and no `powf`. Colours are linear light.
#[derive(Clone, Debug)]
pub struct TfTable {
    bins: Bins,
    /// `[r, g, b, alpha]` per bin.
    entries: Vec<[f32; 4]>,
}

/// Most bins a table has: far below 2^24, so bin indices are exact in f32.
pub const MAX_BINS: usize = 1 << 20;

impl TfTable {
    /// Bins for a domain: four per unit of value when that gives at most
    /// 4096 (so integer-valued range edges fall on bin edges), else 4096.
    pub fn default_bins(lo: f32, hi: f32) -> usize {
        let span = (hi - lo) as f64;
        if span > 0.0 && span * 4.0 <= 4096.0 && span.fract() == 0.0 {
            (span * 4.0) as usize
        } else {
            4096
        }
    }

    /// Sample `tf` at the centres of `bins` bins (1 ..= [`MAX_BINS`]) over
    /// `[lo, hi]` and correct opacities for a step of `step` world units.
    pub fn new(tf: &TransferFunction, lo: f32, hi: f32, bins: usize, step: f32) -> TfTable {
        let bins = Bins::new(lo, hi, bins);
        let ratio = step as f64 / tf.reference_step as f64;
        let entries: Vec<[f32; 4]> = (0..bins.count())
            .map(|i| {
                let (rgb, alpha) = tf.eval(bins.centre(i));
                entry(rgb, alpha, ratio)
            })
            .collect();
        TfTable { bins, entries }
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.entries.len()
    }

    /// The value domain.
    pub fn domain(&self) -> (f32, f32) {
        self.bins.domain()
    }

    /// The bin of value `v` (values outside the domain clamp to the end
    /// bins). NaN must be handled by the caller.
    #[inline(always)]
    pub fn bin(&self, v: f32) -> usize {
        self.bins.bin(v)
    }

    /// `[r, g, b, alpha]` for value `v`; NaN is transparent.
    #[inline(always)]
    pub fn lookup(&self, v: f32) -> [f32; 4] {
        if v.is_nan() {
            return [0.0; 4];
        }
        self.entries[self.bins.bin(v)]
    }

    /// Corrected opacity per bin, for building skipping tables.
    pub fn alphas(&self) -> Vec<f32> {
        self.entries.iter().map(|e| e[3]).collect()
    }

    /// The largest corrected opacity per value range, as a range-maximum
    /// table over the bins.
    pub fn opacity_bounds(&self) -> Result<RangeMaxTable, RenderError> {
        let (lo, hi) = self.domain();
        RangeMaxTable::from_bin_maxima(lo, hi, self.alphas())
            .map_err(|e| RenderError::Index(e.to_string()))
    }
}

impl Classifier for TfTable {
    const NEEDS_GRADIENT: bool = false;

    #[inline(always)]
    fn classify(&self, v: f32, _gradient: f32) -> [f32; 4] {
        self.lookup(v)
    }

    fn to_optical_depth(&self) -> Self {
        let mut t = self.clone();
        for e in &mut t.entries {
            e[3] = super::optical_depth(e[3]);
        }
        t
    }

    fn transparent_cells(
        &self,
        index: &MajorantIndex,
        _: &GradientBound,
    ) -> Result<Vec<Vec<bool>>, RenderError> {
        let bounds = self.opacity_bounds()?;
        Ok(index
            .levels()
            .iter()
            .map(|l| l.zero_cells(&bounds))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::correct_opacity;

    #[test]
    fn opacity_correction_is_stable_at_the_edges() {
        assert_eq!(correct_opacity(0.0, 0.2), 0.0);
        assert_eq!(correct_opacity(1.0, 0.2), 1.0);
        assert_eq!(correct_opacity(1.0, 1e-9), 1.0);
        assert_eq!(correct_opacity(f32::NAN, 1.0), 0.0);
        assert!((correct_opacity(0.6, 1.0) - 0.6).abs() < 1e-7);
        // 1 - (1 - 0.6)^0.2, and two half steps compose to one step.
        assert!((correct_opacity(0.6, 0.2) - (1.0 - 0.4f64.powf(0.2)) as f32).abs() < 1e-7);
        let half = correct_opacity(0.3, 0.5) as f64;
        assert!((1.0 - (1.0 - half) * (1.0 - half) - 0.3).abs() < 1e-6);
        // Tiny opacity and tiny ratio keep their precision.
        let tiny = correct_opacity(1e-6, 1e-3);
        assert!((tiny as f64 - 1e-9).abs() < 1e-14, "{tiny}");
        // Alpha near one: no overflow, stays below one for a short step.
        let near = correct_opacity(0.999_999_9, 0.01);
        assert!(near > 0.1 && near < 1.0);
    }

    #[test]
    fn bins_align_with_integer_values_for_u8() {
        let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
        let t = TfTable::new(&tf, 0.0, 255.0, TfTable::default_bins(0.0, 255.0), 1.0);
        assert_eq!(t.bins(), 1020);
        assert_eq!(t.lookup(84.99)[3], 0.0);
        assert!(t.lookup(85.0)[3] > 0.0);
        assert_eq!(t.lookup(-3.0)[3], 0.0);
        assert_eq!(t.lookup(1e30)[3], 0.0);
        assert_eq!(t.lookup(f32::NAN), [0.0; 4]);
    }
}
