//! The participating medium a path tracer sees in a volume: extinction
//! `σt` per world unit and single-scattering albedo, both functions of the
//! trilinear sample value, and the per-macrocell majorants that bound
//! `σt` for delta and ratio tracking.
//!
//! Two media, as the user chooses:
//! - [`DensityMedium`]: `σt = S × normalised value`, constant albedo (what
//!   pbrt, Mitsuba and VPT use by default).
//! - [`TableMedium`]: from a 1D transfer function, `σt = −ln(1 − α)` with
//!   `α` the opacity per unit world length, albedo the TF colour in linear
//!   light.
//!
//! NaN samples have extinction 0 (they are empty space, never propagated).

use crate::accel::majorant::{MajorantGrid, MAX_SIGMA_T};
use crate::classify::{optical_depth, Bins, TfTable};
use crate::error::RenderError;
use crate::tf::TransferFunction;
use glam::Vec3;
use volcore::SampleType;
use volindex::{MinMaxIndex, RangeMaxTable};

/// Extinction and albedo as functions of a sample's value.
pub trait Medium: Sync {
    /// Whether the albedo is the same everywhere (then [`Medium::albedo`]
    /// is not looked up per collision).
    const CONSTANT_ALBEDO: bool;
    /// Extinction per world unit of value `v`, in `[0, MAX_SIGMA_T]`; 0 for
    /// NaN.
    fn sigma_t(&self, v: f32) -> f32;
    /// Single-scattering albedo (linear RGB in `[0, 1]`) of value `v`.
    fn albedo(&self, v: f32) -> Vec3;
    /// The largest albedo component anywhere (0: the medium only absorbs).
    fn max_albedo(&self) -> f32;
    /// An upper bound of the extinction of every value in `[lo, hi]`
    /// (either end may be infinite), in `[0, MAX_SIGMA_T]`: the bound the
    /// majorant grid's cells take from their value ranges, and tracking
    /// from a voxel cell's eight values inside a cell at the cap.
    fn majorant_over(&self, lo: f32, hi: f32) -> f32;
    /// A control extinction for values in `[lo, hi]`, for residual ratio
    /// tracking: at most the smallest extinction of any value in the range
    /// (any value keeps the estimate unbiased; one that bounds from below
    /// keeps every factor in `[0, 1]`). The default, 0, is plain ratio
    /// tracking.
    fn control_over(&self, _lo: f32, _hi: f32) -> f32 {
        0.0
    }
    /// Majorants of `index`'s level `level`.
    fn majorants(&self, index: &MinMaxIndex, level: usize) -> Result<MajorantGrid, RenderError> {
        Ok(MajorantGrid::from_ranges(index, level, |lo, hi| {
            self.majorant_over(lo, hi)
        }))
    }
}

/// `σt = scale × normalised value` with a constant albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityMedium {
    /// Extinction per world unit at normalised value 1.
    pub scale: f32,
    /// Multiplier from a sample value to the normalised value.
    pub norm: f32,
    /// Albedo, linear RGB.
    pub albedo: Vec3,
}

/// What a sample value counts as in `--density-scale` mode: value / 255
/// for u8, / 65535 for u16, / 32767 for i16 (negative values count as 0),
/// and the value itself for floats (negative values count as 0).
pub fn density_norm(t: SampleType) -> f32 {
    match t {
        SampleType::U8 => 1.0 / 255.0,
        SampleType::U16 => 1.0 / 65535.0,
        SampleType::I16 => 1.0 / 32767.0,
        SampleType::F32 | SampleType::F64 => 1.0,
    }
}

impl DensityMedium {
    /// A medium of `scale` per unit at normalised value 1, for samples of
    /// type `t`, with `albedo`; checked: finite, scale not negative,
    /// albedo in `[0, 1]`.
    pub fn new(scale: f32, t: SampleType, albedo: Vec3) -> Result<DensityMedium, RenderError> {
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(RenderError::Setting(format!(
                "density scale {scale} must be a finite number, not negative"
            )));
        }
        if !(albedo.is_finite() && albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0) {
            return Err(RenderError::Setting(format!(
                "albedo {},{},{} must be in [0, 1]",
                albedo.x, albedo.y, albedo.z
            )));
        }
        Ok(DensityMedium {
            scale,
            norm: density_norm(t),
            albedo,
        })
    }
}

impl Medium for DensityMedium {
    const CONSTANT_ALBEDO: bool = true;

    #[inline(always)]
    fn sigma_t(&self, v: f32) -> f32 {
        // NaN and negative values fail the comparison: 0.
        let s = if v > 0.0 {
            v * self.norm * self.scale
        } else {
            0.0
        };
        s.min(MAX_SIGMA_T)
    }

    #[inline(always)]
    fn albedo(&self, _: f32) -> Vec3 {
        self.albedo
    }

    fn max_albedo(&self) -> f32 {
        self.albedo.max_element()
    }

    fn majorant_over(&self, _: f32, hi: f32) -> f32 {
        // σt rises with the value: the largest value bounds it. Rounding:
        // the bound is computed as the samples are, and widened by a hair.
        let m = self.sigma_t(hi);
        if m > 0.0 {
            (m * (1.0 + 4.0 * f32::EPSILON)).min(MAX_SIGMA_T)
        } else {
            0.0
        }
    }

    fn control_over(&self, lo: f32, _: f32) -> f32 {
        // σt rises with the value: the smallest value's, narrowed by a hair.
        self.sigma_t(lo) * (1.0 - 4.0 * f32::EPSILON)
    }
}

/// A transfer function as a medium: per value bin, extinction and albedo.
#[derive(Clone, Debug)]
pub struct TableMedium {
    bins: Bins,
    /// `[r, g, b, σt]` per bin.
    entries: Vec<[f32; 4]>,
    /// The largest σt over any range of bins (an error when the bins'
    /// domain makes no table: then [`Medium::majorants`] reports it).
    range_max: Result<RangeMaxTable, String>,
    /// The largest −σt over any range of bins (the smallest σt, negated),
    /// for the controls of residual ratio tracking.
    range_min: Option<RangeMaxTable>,
    max_albedo: f32,
}

impl TableMedium {
    /// `tf` sampled into its frame table's bins over `[lo, hi]`: opacity
    /// for one world unit, turned into extinction.
    pub fn new(tf: &TransferFunction, lo: f32, hi: f32) -> TableMedium {
        let hi = if hi > lo { hi } else { lo + 1.0 };
        let count = TfTable::default_bins(lo, hi);
        let table = TfTable::new(tf, lo, hi, count, 1.0);
        let bins = Bins::new(lo, hi, count);
        let entries: Vec<[f32; 4]> = (0..bins.count())
            .map(|i| {
                let [r, g, b, a] = table.lookup(bins.centre(i));
                let sigma = optical_depth(a).min(MAX_SIGMA_T);
                [r, g, b, sigma]
            })
            .collect();
        let max_albedo = entries
            .iter()
            .filter(|e| e[3] > 0.0)
            .map(|e| e[0].max(e[1]).max(e[2]))
            .fold(0.0, f32::max);
        let (lo, hi) = bins.domain();
        let maxima = entries.iter().map(|e| e[3]).collect();
        let range_max = RangeMaxTable::from_bin_maxima(lo, hi, maxima).map_err(|e| e.to_string());
        let negated = entries.iter().map(|e| -e[3]).collect();
        let range_min = RangeMaxTable::from_bin_maxima(lo, hi, negated).ok();
        TableMedium {
            bins,
            entries,
            range_max,
            range_min,
            max_albedo,
        }
    }
}

impl Medium for TableMedium {
    const CONSTANT_ALBEDO: bool = false;

    #[inline(always)]
    fn sigma_t(&self, v: f32) -> f32 {
        if v.is_nan() {
            return 0.0;
        }
        self.entries[self.bins.bin(v)][3]
    }

    #[inline(always)]
    fn albedo(&self, v: f32) -> Vec3 {
        if v.is_nan() {
            return Vec3::ZERO;
        }
        let e = self.entries[self.bins.bin(v)];
        Vec3::new(e[0], e[1], e[2])
    }

    fn max_albedo(&self) -> f32 {
        self.max_albedo
    }

    fn majorant_over(&self, lo: f32, hi: f32) -> f32 {
        match &self.range_max {
            Ok(t) => t.max_over(lo, hi),
            // No frame gets this far (majorants() refused it); a bound
            // all the same.
            Err(_) => self.entries.iter().map(|e| e[3]).fold(0.0, f32::max),
        }
    }

    fn control_over(&self, lo: f32, hi: f32) -> f32 {
        // A NaN or negative bound is taken as 0 by the grid.
        self.range_min.as_ref().map_or(0.0, |t| -t.max_over(lo, hi))
    }

    fn majorants(&self, index: &MinMaxIndex, level: usize) -> Result<MajorantGrid, RenderError> {
        match &self.range_max {
            Ok(t) => Ok(MajorantGrid::from_table(index, level, t)),
            Err(e) => Err(RenderError::Index(e.clone())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_maps_values_and_guards_edges() {
        let m = DensityMedium::new(0.1, SampleType::U8, Vec3::splat(0.8)).unwrap();
        assert!((m.sigma_t(255.0) - 0.1).abs() < 1e-7);
        assert_eq!(m.sigma_t(0.0), 0.0);
        assert_eq!(m.sigma_t(f32::NAN), 0.0);
        assert_eq!(m.sigma_t(-5.0), 0.0);
        assert_eq!(m.sigma_t(f32::INFINITY), MAX_SIGMA_T);
        let huge = DensityMedium::new(1e30, SampleType::F32, Vec3::ONE).unwrap();
        assert_eq!(huge.sigma_t(1.0), MAX_SIGMA_T);
        assert!(DensityMedium::new(f32::NAN, SampleType::U8, Vec3::ONE).is_err());
        assert!(DensityMedium::new(-1.0, SampleType::U8, Vec3::ONE).is_err());
        assert!(DensityMedium::new(1.0, SampleType::U8, Vec3::splat(1.5)).is_err());
    }

    #[test]
    fn a_table_medium_turns_opacity_per_unit_into_extinction() {
        let tf =
            crate::tf::parse::parse("domain 0 255\nstep 1\nrange 100 200 255 0 0 0.5\n").unwrap();
        let m = TableMedium::new(&tf, 0.0, 255.0);
        assert_eq!(m.sigma_t(50.0), 0.0);
        // −ln(1 − 0.5) per unit.
        assert!((m.sigma_t(150.0) - std::f32::consts::LN_2).abs() < 1e-6);
        assert_eq!(m.albedo(150.0), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.sigma_t(f32::NAN), 0.0);
        assert_eq!(m.max_albedo(), 1.0);
        let opaque =
            crate::tf::parse::parse("domain 0 255\nstep 1\nrange 0 256 255 255 255 1\n").unwrap();
        assert_eq!(
            TableMedium::new(&opaque, 0.0, 255.0).sigma_t(3.0),
            MAX_SIGMA_T
        );
    }
}
