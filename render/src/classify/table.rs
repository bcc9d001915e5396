//! The 1D lookup table: a transfer function sampled per value bin, with
//! opacity corrected for the step.

use super::entry;
use super::{Classifier, GradientBound};
use crate::error::RenderError;
use crate::tf::TransferFunction;
use volindex::{MinMaxIndex, RangeMaxTable};

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
    /// Whether this CPU looks up eight values at once ([`TfTable::alpha8`]
    /// in AVX2 lanes).
    lanes: bool,
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
        TfTable {
            bins,
            entries,
            lanes: volcore::lanes::avx2_available(),
        }
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

    #[inline(always)]
    fn alpha8(&self, v: &[f32; 8]) -> [f32; 8] {
        #[cfg(target_arch = "x86_64")]
        if self.lanes && self.entries.len() < (1 << 28) {
            // SAFETY: `lanes` is set only where AVX2 was detected; every
            // index is a bin, below `entries.len()`.
            return unsafe { avx2::alpha8(&self.bins, &self.entries, v) };
        }
        v.map(|x| self.lookup(x)[3])
    }

    #[inline(always)]
    fn classify8(&self, v: &[f32; 8]) -> [[f32; 4]; 8] {
        #[cfg(target_arch = "x86_64")]
        if self.lanes && self.entries.len() < (1 << 28) {
            // SAFETY: as in `alpha8`.
            let (bins, nan) = unsafe { avx2::bins8(&self.bins, v) };
            let mut out = [[0.0; 4]; 8];
            for (i, (o, &b)) in out.iter_mut().zip(&bins).enumerate() {
                if nan >> i & 1 == 0 {
                    *o = self.entries[b as usize];
                }
            }
            return out;
        }
        v.map(|x| self.lookup(x))
    }

    fn variation(&self) -> Option<super::variation::Variation> {
        Some(super::variation::Variation::new(self.bins, &self.entries))
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
        index: &MinMaxIndex,
        _: &GradientBound,
    ) -> Result<Vec<Vec<bool>>, RenderError> {
        let bounds = self.opacity_bounds()?;
        Ok(index
            .levels()
            .iter()
            .map(|l| l.zero_cells(&bounds))
            .collect())
    }

    /// The bins' domain and corrected opacities: all the transparent
    /// cells depend on (a hash of their bits, a few microseconds for
    /// thousands of bins).
    fn cells_key(&self, _: &GradientBound) -> Option<u64> {
        use crate::sampler::mix;
        let (lo, hi) = self.domain();
        let mut h = mix(0x7472_616e_7370_6172 ^ self.entries.len() as u64);
        h = mix(h ^ (u64::from(lo.to_bits()) << 32 | u64::from(hi.to_bits())));
        for e in &self.entries {
            h = mix(h ^ u64::from(e[3].to_bits()));
        }
        Some(h)
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::Bins;
    use std::arch::x86_64::*;

    /// [`Bins::bin`] of eight values, the same operations per lane.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bin_lanes(bins: &Bins, v: __m256) -> __m256i {
        let i = _mm256_mul_ps(
            _mm256_sub_ps(v, _mm256_set1_ps(bins.lo)),
            _mm256_set1_ps(bins.scale),
        );
        let top = _mm256_set1_ps(bins.top);
        let above = _mm256_cmp_ps::<_CMP_GT_OQ>(i, _mm256_setzero_ps());
        let below = _mm256_cmp_ps::<_CMP_LT_OQ>(i, top);
        _mm256_cvttps_epi32(_mm256_and_ps(_mm256_blendv_ps(top, i, below), above))
    }

    /// [`Bins::bin`] of eight values, and a bit per NaN value.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn bins8(bins: &Bins, v: &[f32; 8]) -> ([u32; 8], u8) {
        let v = _mm256_loadu_ps(v.as_ptr());
        let mut out = [0u32; 8];
        _mm256_storeu_si256(out.as_mut_ptr().cast(), bin_lanes(bins, v));
        let nan = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_UNORD_Q>(v, v)) as u8;
        (out, nan)
    }

    /// [`super::TfTable::lookup`]'s opacity for eight values: the bin as
    /// [`Bins::bin`] computes it (the same operations per lane), then a
    /// gather; NaN values are transparent.
    ///
    /// # Safety
    /// The CPU must have AVX2, and `entries` hold `bins.count()` entries,
    /// fewer than 2^28.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn alpha8(bins: &Bins, entries: &[[f32; 4]], v: &[f32; 8]) -> [f32; 8] {
        let v = _mm256_loadu_ps(v.as_ptr());
        // Word offsets of each bin's alpha (bins < 2^28, so no overflow).
        let at = _mm256_add_epi32(
            _mm256_slli_epi32::<2>(bin_lanes(bins, v)),
            _mm256_set1_epi32(3),
        );
        let a = _mm256_i32gather_ps::<4>(entries.as_ptr().cast::<f32>(), at);
        let nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(v, v);
        let mut out = [0f32; 8];
        _mm256_storeu_ps(out.as_mut_ptr(), _mm256_andnot_ps(nan, a));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::correct_opacity;

    /// Eight lookups at once give each value's own opacity, bit for bit:
    /// values inside, at and beyond the domain's ends, at bin edges, NaN
    /// and infinities, over tables of one bin to thousands.
    #[test]
    fn eight_lookups_match_one_by_one() {
        let mut rng = fastrand::Rng::with_seed(4);
        for (lo, hi, bins) in [
            (0.0, 255.0, 1020),
            (-1024.0, 3071.0, 4096),
            (5.0, 5.0, 1),
            (0.0, 1.0, 7),
        ] {
            let mut table = TfTable::new(
                &crate::tf::TransferFunction::preset("grey", (lo, hi)).unwrap(),
                lo,
                hi,
                bins,
                0.7,
            );
            for (i, e) in table.entries.iter_mut().enumerate() {
                e[3] = i as f32 * 0.001 + 0.0005;
            }
            let span = hi - lo + 2.0;
            for round in 0..3000 {
                let v: [f32; 8] = std::array::from_fn(|k| match (round + k) % 11 {
                    0 => f32::NAN,
                    1 => f32::INFINITY,
                    2 => f32::NEG_INFINITY,
                    3 => lo,
                    4 => hi,
                    5 => lo + (rng.u32(0..bins as u32) as f32) / table.bins.scale,
                    _ => lo - 1.0 + rng.f32() * span,
                });
                let want = v.map(|x| table.lookup(x)[3]);
                let got = table.alpha8(&v);
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{v:?}");
                let got = table.classify8(&v).map(|e| e.map(f32::to_bits));
                let want = v.map(|x| table.lookup(x).map(f32::to_bits));
                assert_eq!(got, want, "{v:?}");
            }
        }
    }

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
