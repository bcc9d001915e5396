//! Transfer functions as users describe them: value (and gradient
//! magnitude) → colour and opacity.
//!
//! A [`TransferFunction`] is a list of piecewise-constant ranges (checked
//! first, the first match wins) over a piecewise-linear function through
//! control points. A [`TransferFunction2d`] adds rectangles and Gaussian
//! blobs in (value, gradient magnitude). Colours are sRGB components in
//! `[0, 1]` (converted to linear light for compositing); opacity is per
//! unit of world length at the reference step `s0`, so a step `Δs` sees
//! `1 − (1 − α)^(Δs/s0)`. Text format in [`parse`]; the per-frame lookup
//! tables built from them are in [`crate::classify`].

pub mod parse;
pub mod tf2d;

pub use tf2d::{Tf, TfBlob, TfRect, TransferFunction2d};

/// A colour and opacity at one value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfPoint {
    /// The sample value.
    pub value: f32,
    /// sRGB colour, components in `[0, 1]`.
    pub rgb: [f32; 3],
    /// Opacity per unit length at the reference step, in `[0, 1]`.
    pub alpha: f32,
}

/// Constant colour and opacity over `[lo, hi)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfRange {
    /// First value of the range.
    pub lo: f32,
    /// First value past the range.
    pub hi: f32,
    /// sRGB colour, components in `[0, 1]`.
    pub rgb: [f32; 3],
    /// Opacity per unit length at the reference step.
    pub alpha: f32,
}

/// A 1D transfer function (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// Control points, sorted by value.
    pub points: Vec<TfPoint>,
    /// Constant ranges, checked in order before the points.
    pub ranges: Vec<TfRange>,
    /// Value domain the lookup table covers (default: the volume's range).
    pub domain: Option<(f32, f32)>,
    /// The step at which opacities are given, in world units.
    pub reference_step: f32,
}

/// Names of the built-in presets (`boundary` is two-dimensional; see
/// [`Tf::preset`]; `auto` takes its window from the caller, see
/// [`TransferFunction::preset`]).
pub const PRESETS: [&str; 5] = ["grey", "auto", "ct", "shapes", "boundary"];

/// Default tail percentile of the `auto` preset's window (as
/// `vol-convert --window auto`): the window runs from the 0.5th to the
/// 99.5th percentile of the histogram.
pub const AUTO_TAIL_PERCENT: f64 = 0.5;

/// Values below which Hounsfield data must reach: CT has air (about
/// −1000 HU) or at least fat (about −100 HU) in it, and the `ct` preset
/// shows nothing below −300.
pub const HOUNSFIELD_MIN_BELOW: f32 = -200.0;

/// Whether a volume whose values span `range` looks like CT in
/// Hounsfield units (see [`HOUNSFIELD_MIN_BELOW`]); an unknown range
/// (NaN) does not count against it.
pub fn looks_like_hounsfield(range: (f32, f32)) -> bool {
    range.0.is_nan() || range.0 <= HOUNSFIELD_MIN_BELOW
}

impl TransferFunction {
    /// Colour and opacity at `v` (transparent black where nothing applies,
    /// and for NaN).
    pub fn eval(&self, v: f32) -> ([f32; 3], f32) {
        if v.is_nan() {
            return ([0.0; 3], 0.0);
        }
        if let Some(r) = self.ranges.iter().find(|r| v >= r.lo && v < r.hi) {
            return (r.rgb, r.alpha);
        }
        // The points are sorted: the first past `v` by bisection, so a
        // table's build stays bounded however many points a file gives.
        let p = &self.points;
        match p.partition_point(|q| q.value <= v) {
            i if i == p.len() => p.last().map_or(([0.0; 3], 0.0), |q| (q.rgb, q.alpha)),
            0 => (p[0].rgb, p[0].alpha),
            i => {
                let (a, b) = (&p[i - 1], &p[i]);
                let span = b.value - a.value;
                let t = if span > 0.0 {
                    (v - a.value) / span
                } else {
                    1.0
                };
                let mix = |x: f32, y: f32| x + (y - x) * t;
                (
                    [
                        mix(a.rgb[0], b.rgb[0]),
                        mix(a.rgb[1], b.rgb[1]),
                        mix(a.rgb[2], b.rgb[2]),
                    ],
                    mix(a.alpha, b.alpha),
                )
            }
        }
    }

    /// A built-in transfer function by name, for a volume whose values span
    /// `range`: `grey` (a greyscale ramp over the range), `auto` (the same
    /// ramp; the caller passes the window it took from the histogram's
    /// percentiles as `range`, and values past it clamp to its ends), `ct`
    /// (soft tissue and bone, in Hounsfield units), `shapes` (the thesis
    /// test scene's).
    pub fn preset(name: &str, range: (f32, f32)) -> Option<TransferFunction> {
        let pt = |value: f32, rgb: [f32; 3], alpha: f32| TfPoint { value, rgb, alpha };
        let rg = |lo: f32, hi: f32, rgb: [u8; 3], alpha: f32| TfRange {
            lo,
            hi,
            rgb: rgb.map(|c| c as f32 / 255.0),
            alpha,
        };
        let (lo, hi) = if range.0.is_finite() && range.1.is_finite() && range.0 < range.1 {
            range
        } else {
            (0.0, 1.0)
        };
        let tf = match name {
            "grey" | "gray" | "greyscale" | "auto" => TransferFunction {
                points: vec![pt(lo, [0.0; 3], 0.0), pt(hi, [1.0; 3], 0.1)],
                ranges: vec![],
                domain: Some((lo, hi)),
                reference_step: 1.0,
            },
            "ct" => TransferFunction {
                points: vec![
                    pt(-1000.0, [0.0; 3], 0.0),
                    pt(-300.0, [0.0; 3], 0.0),
                    pt(-100.0, [0.75, 0.35, 0.25], 0.004),
                    pt(150.0, [0.9, 0.55, 0.45], 0.015),
                    pt(300.0, [0.95, 0.9, 0.8], 0.08),
                    pt(1500.0, [1.0, 1.0, 0.98], 0.6),
                ],
                ranges: vec![],
                domain: Some((-1024.0, 3071.0)),
                reference_step: 1.0,
            },
            "shapes" => TransferFunction {
                points: vec![],
                ranges: vec![
                    rg(85.0, 95.0, [255, 0, 0], 0.02),
                    rg(95.0, 100.0, [0, 0, 255], 0.3),
                    rg(100.0, 115.0, [0, 255, 0], 0.6),
                ],
                domain: Some((0.0, 255.0)),
                reference_step: 1.0,
            },
            _ => return None,
        };
        Some(tf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_preset_matches_the_thesis() {
        let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
        assert_eq!(tf.eval(84.9).1, 0.0);
        assert_eq!(tf.eval(85.0), ([1.0, 0.0, 0.0], 0.02));
        assert_eq!(tf.eval(97.0), ([0.0, 0.0, 1.0], 0.3));
        assert_eq!(tf.eval(100.0), ([0.0, 1.0, 0.0], 0.6));
        assert_eq!(tf.eval(115.0).1, 0.0);
        assert_eq!(tf.eval(f32::NAN).1, 0.0);
    }

    #[test]
    fn auto_is_a_grey_ramp_over_the_given_window() {
        let tf = TransferFunction::preset("auto", (20.0, 120.0)).unwrap();
        assert_eq!(tf.domain, Some((20.0, 120.0)));
        assert_eq!(tf.eval(19.0), ([0.0; 3], 0.0));
        assert_eq!(tf.eval(70.0), ([0.5; 3], 0.05));
        assert_eq!(tf.eval(400.0), ([1.0; 3], 0.1));
        assert!(PRESETS.contains(&"auto"));
    }

    #[test]
    fn hounsfield_data_reaches_below_fat() {
        assert!(looks_like_hounsfield((-1024.0, 3071.0)));
        assert!(looks_like_hounsfield((-200.0, 80.0)));
        assert!(!looks_like_hounsfield((0.0, 255.0)));
        assert!(!looks_like_hounsfield((0.0, 4095.0)));
        assert!(!looks_like_hounsfield((-1.0, 1.0)));
        assert!(looks_like_hounsfield((f32::NAN, f32::NAN)));
    }

    #[test]
    fn points_interpolate_and_clamp() {
        let tf = TransferFunction::preset("grey", (0.0, 100.0)).unwrap();
        assert_eq!(tf.eval(50.0).1, 0.05);
        assert_eq!(tf.eval(-5.0).1, 0.0);
        assert_eq!(tf.eval(500.0).1, 0.1);
    }
}
