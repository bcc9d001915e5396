//! Classification: what colour and opacity a sample has.
//!
//! A [`Classifier`] maps a sample's value (and, when it asks for it, its
//! gradient magnitude) to linear colour and step-corrected opacity, and
//! tells the skipping which macrocells can hold nothing but transparent
//! samples. The 1D table ([`TfTable`]), the 2D table over value and
//! gradient magnitude ([`TfTable2d`]) and the pre-integrated table over
//! pairs of values ([`PairTable`]) are its implementations; each is built
//! once per frame from a transfer function ([`crate::tf`]).

pub mod pairs;
pub mod table;
pub mod table2d;
pub mod variation;

pub use pairs::PairTable;
pub use table::{Bins, TfTable, MAX_BINS};
pub use table2d::TfTable2d;

use crate::error::RenderError;
use crate::settings::GradientMethod;
use glam::Vec3;
use volindex::MinMaxIndex;

/// How gradients are computed in the frame, for bounding their length
/// over a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientBound {
    /// The gradient method the frame uses.
    pub method: GradientMethod,
    /// `1 / spacing` per axis (gradients are per world unit).
    pub inv_spacing: Vec3,
}

/// Maps samples to colour and opacity (see the module docs).
pub trait Classifier: Sync {
    /// Whether classification reads the gradient magnitude (then each
    /// sample's gradient is computed before it is classified, and shared
    /// with shading).
    const NEEDS_GRADIENT: bool;

    /// `[r, g, b, alpha]`: linear colour and opacity corrected for the
    /// frame's step, for a sample of value `v` whose world-space gradient
    /// has length `gradient` (ignored unless [`Self::NEEDS_GRADIENT`]).
    /// NaN values are transparent.
    fn classify(&self, v: f32, gradient: f32) -> [f32; 4];

    /// Whether samples are classified in pairs: each sample stands for
    /// the segment from the sample before it ([`Self::classify_segment`]),
    /// not for the step around it.
    const SEGMENTS: bool = false;

    /// `[r, g, b, alpha]` of the segment between consecutive samples of
    /// values `front` and `back` (for classifiers with [`Self::SEGMENTS`];
    /// others classify the back sample alone).
    #[inline(always)]
    fn classify_segment(&self, front: f32, back: f32) -> [f32; 4] {
        let _ = front;
        self.classify(back, 0.0)
    }

    /// `[r, g, b, alpha]` of half a step of constant value `v`: what a
    /// classifier of segments adds before a ray's first sample and after
    /// its last, so its samples cover what a classifier of single samples
    /// covers (half a step around each).
    #[inline(always)]
    fn classify_half(&self, v: f32) -> [f32; 4] {
        self.classify(v, 0.0)
    }

    /// `classify(v[i], 0.0)` of eight samples of values `v`, bit for bit
    /// (for classifiers that do not read the gradient); tables override it
    /// to find the bins in lanes.
    #[inline(always)]
    fn classify8(&self, v: &[f32; 8]) -> [[f32; 4]; 8] {
        v.map(|x| self.classify(x, 0.0))
    }

    /// The opacities of eight samples of values `v`, each
    /// `classify(v[i], 0.0)[3]` bit for bit (for classifiers that do not
    /// read the gradient); tables override it to look up in lanes.
    #[inline(always)]
    fn alpha8(&self, v: &[f32; 8]) -> [f32; 8] {
        v.map(|x| self.classify(x, 0.0)[3])
    }

    /// How much classification can change over value ranges, for
    /// adaptive steps ([`variation::Variation`]); `None` for classifiers
    /// that do not bound it (2D and pre-integrated tables).
    fn variation(&self) -> Option<variation::Variation> {
        None
    }

    /// The same table with each opacity `α` replaced by its optical depth
    /// `−ln(1 − α)` (infinite at α = 1), for shadow rays that add depths.
    fn to_optical_depth(&self) -> Self
    where
        Self: Sized;

    /// For every level of `index` and every cell: `true` when no sample
    /// the cell can produce (any value in its range, any gradient the
    /// frame's gradient method can give there) has nonzero opacity.
    fn transparent_cells(
        &self,
        index: &MinMaxIndex,
        gradients: &GradientBound,
    ) -> Result<Vec<Vec<bool>>, RenderError>;

    /// A key naming everything besides the index that
    /// [`Classifier::transparent_cells`] depends on, so that frames with
    /// the same key share its result (and the skipping distances made
    /// from it) through the index's memo; `None`, the default: every frame
    /// classifies afresh.
    fn cells_key(&self, _gradients: &GradientBound) -> Option<u64> {
        None
    }
}

/// Step-corrected opacity `1 − (1 − α)^ratio`, computed as
/// `−expm1(ratio · ln(1 − α))`, which stays accurate for small α and
/// small ratios; exact at α = 0 (gives 0) and α = 1 (gives 1).
pub fn correct_opacity(alpha: f32, ratio: f64) -> f32 {
    if alpha <= 0.0 || alpha.is_nan() {
        return 0.0;
    }
    if alpha >= 1.0 {
        return 1.0;
    }
    let a = -((ratio * (-(alpha as f64)).ln_1p()).exp_m1());
    a.clamp(0.0, 1.0) as f32
}

/// Optical depth `−ln(1 − α)` of an opacity: 0 at α ≤ 0 (and NaN),
/// infinite at α ≥ 1, accurate for small α.
pub fn optical_depth(alpha: f32) -> f32 {
    if alpha.is_nan() || alpha <= 0.0 {
        return 0.0;
    }
    if alpha >= 1.0 {
        return f32::INFINITY;
    }
    (-(-(alpha as f64)).ln_1p()) as f32
}

/// Entry `front` composited over entry `back` (each `[r, g, b, alpha]`,
/// colour not premultiplied): one entry for both, in the same form.
#[inline]
pub fn over(front: [f32; 4], back: [f32; 4]) -> [f32; 4] {
    let wb = (1.0 - front[3]) * back[3];
    let alpha = front[3] + wb;
    if alpha <= 0.0 {
        return [0.0; 4];
    }
    let c = |i: usize| (front[i] * front[3] + back[i] * wb) / alpha;
    [c(0), c(1), c(2), alpha]
}

/// sRGB transfer curve to linear light.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A table entry: sRGB colour to linear light, opacity corrected for a
/// step `ratio` times the reference step.
pub(crate) fn entry(rgb: [f32; 3], alpha: f32, ratio: f64) -> [f32; 4] {
    let lin = rgb.map(srgb_to_linear);
    [lin[0], lin[1], lin[2], correct_opacity(alpha, ratio)]
}
