//! Two-dimensional transfer functions over (value, gradient magnitude),
//! and [`Tf`], either kind.
//!
//! A [`TransferFunction2d`] has three kinds of parts: a 1D layer (the
//! points and ranges of a [`TransferFunction`], the same at every gradient
//! magnitude), rectangles `[lo, hi) × [glo, ghi)` of constant colour and
//! opacity, and Gaussian blobs (opacity `α·exp(−(dv²/σv² + dg²/σg²)/2)`
//! within three standard deviations, zero beyond). At a point every part
//! offers a colour and an opacity; the one with the largest opacity wins
//! (the earliest in the file on a tie, the 1D layer first). Gradient
//! magnitudes are per unit of world length, from the frame's gradient
//! method (central differences or the analytic trilinear gradient).

use super::TransferFunction;

/// A rectangle of constant colour and opacity in (value, gradient).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfRect {
    /// First value inside.
    pub lo: f32,
    /// First value past it.
    pub hi: f32,
    /// First gradient magnitude inside.
    pub glo: f32,
    /// First gradient magnitude past it.
    pub ghi: f32,
    /// sRGB colour, components in `[0, 1]`.
    pub rgb: [f32; 3],
    /// Opacity per unit length at the reference step.
    pub alpha: f32,
}

/// A Gaussian blob in (value, gradient), cut off at three standard
/// deviations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfBlob {
    /// Centre value.
    pub value: f32,
    /// Centre gradient magnitude.
    pub gradient: f32,
    /// Standard deviation along the value axis (> 0).
    pub value_sd: f32,
    /// Standard deviation along the gradient axis (> 0).
    pub gradient_sd: f32,
    /// sRGB colour, components in `[0, 1]`.
    pub rgb: [f32; 3],
    /// Peak opacity per unit length at the reference step.
    pub alpha: f32,
}

/// A transfer function over value and gradient magnitude (see the module
/// docs).
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction2d {
    /// The 1D layer, with the value domain and the reference step.
    pub base: TransferFunction,
    /// Rectangles, in file order.
    pub rects: Vec<TfRect>,
    /// Blobs, in file order.
    pub blobs: Vec<TfBlob>,
    /// Gradient magnitudes the table covers (default: zero to the value
    /// span per smallest voxel spacing, the steepest a one-voxel jump can
    /// be along an axis).
    pub gradient_domain: Option<(f32, f32)>,
}

/// Blobs end at this many standard deviations (squared).
const BLOB_CUTOFF2: f32 = 9.0;

impl TfBlob {
    /// The blob's opacity at `(v, g)`.
    fn opacity(&self, v: f32, g: f32) -> f32 {
        let dv = (v - self.value) / self.value_sd;
        let dg = (g - self.gradient) / self.gradient_sd;
        let r2 = dv * dv + dg * dg;
        if r2 <= BLOB_CUTOFF2 {
            self.alpha * (-0.5 * r2).exp()
        } else {
            0.0
        }
    }
}

impl TransferFunction2d {
    /// Colour and opacity at value `v` and gradient magnitude `g`
    /// (transparent black for a NaN value; a NaN gradient counts as 0).
    pub fn eval(&self, v: f32, g: f32) -> ([f32; 3], f32) {
        if v.is_nan() {
            return ([0.0; 3], 0.0);
        }
        let g = if g.is_nan() { 0.0 } else { g };
        let mut best = self.base.eval(v);
        for r in &self.rects {
            if v >= r.lo && v < r.hi && g >= r.glo && g < r.ghi && r.alpha > best.1 {
                best = (r.rgb, r.alpha);
            }
        }
        for b in &self.blobs {
            let a = b.opacity(v, g);
            if a > best.1 {
                best = (b.rgb, a);
            }
        }
        best
    }

    /// The `boundary` preset for values spanning `range` and gradients up
    /// to `max_gradient`: after Kniss et al.'s boundary emphasis, opacity
    /// rises with the gradient magnitude (16 steps from 0.05 at 2% of the
    /// gradient domain to 0.8 at its top) whatever the value, and regions
    /// of nearly constant value are transparent, so the boundaries
    /// between materials stand out.
    pub fn boundary(range: (f32, f32), max_gradient: f32) -> TransferFunction2d {
        let (lo, hi) = if range.0.is_finite() && range.1.is_finite() && range.0 < range.1 {
            range
        } else {
            (0.0, 1.0)
        };
        let gmax = if max_gradient.is_finite() && max_gradient > 0.0 {
            max_gradient
        } else {
            1.0
        };
        const BANDS: usize = 16;
        let g0 = 0.02 * gmax;
        let band = (gmax - g0) / BANDS as f32;
        let rects = (0..BANDS)
            .map(|i| {
                let f = i as f32 / (BANDS - 1) as f32;
                TfRect {
                    // Past the top of the value domain too: the table
                    // clamps values there to its last bin.
                    lo,
                    hi: hi + (hi - lo),
                    glo: g0 + band * i as f32,
                    ghi: if i + 1 == BANDS {
                        f32::MAX
                    } else {
                        g0 + band * (i + 1) as f32
                    },
                    rgb: [1.0, 0.9 - 0.25 * f, 0.75 - 0.5 * f],
                    alpha: 0.05 + 0.75 * f,
                }
            })
            .collect();
        TransferFunction2d {
            base: TransferFunction {
                points: vec![],
                ranges: vec![],
                domain: Some((lo, hi)),
                reference_step: 1.0,
            },
            rects,
            blobs: vec![],
            gradient_domain: Some((0.0, gmax)),
        }
    }

    /// A 2D function equal to `tf` at every gradient magnitude.
    pub fn from_1d(tf: TransferFunction, gradient_domain: Option<(f32, f32)>) -> Self {
        TransferFunction2d {
            base: tf,
            rects: vec![],
            blobs: vec![],
            gradient_domain,
        }
    }
}

/// A transfer function of either kind.
#[derive(Clone, Debug, PartialEq)]
pub enum Tf {
    /// Over the value alone.
    OneD(TransferFunction),
    /// Over value and gradient magnitude.
    TwoD(TransferFunction2d),
}

impl Tf {
    /// A built-in transfer function by name (see
    /// [`TransferFunction::preset`]; `boundary` is
    /// [`TransferFunction2d::boundary`]) for a volume whose values span
    /// `range` and whose steepest gradient is about `max_gradient`.
    pub fn preset(name: &str, range: (f32, f32), max_gradient: f32) -> Option<Tf> {
        match name {
            "boundary" => Some(Tf::TwoD(TransferFunction2d::boundary(range, max_gradient))),
            _ => TransferFunction::preset(name, range).map(Tf::OneD),
        }
    }

    /// The value domain the function asks for, if any.
    pub fn domain(&self) -> Option<(f32, f32)> {
        match self {
            Tf::OneD(t) => t.domain,
            Tf::TwoD(t) => t.base.domain,
        }
    }

    /// The reference step of its opacities.
    pub fn reference_step(&self) -> f32 {
        match self {
            Tf::OneD(t) => t.reference_step,
            Tf::TwoD(t) => t.base.reference_step,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_opacity_wins_and_blobs_end_at_three_sd() {
        let mut tf = TransferFunction2d::from_1d(
            TransferFunction::preset("grey", (0.0, 100.0)).unwrap(),
            Some((0.0, 50.0)),
        );
        // The 1D layer alone: the same at every gradient.
        assert_eq!(tf.eval(50.0, 0.0), tf.eval(50.0, 40.0));
        assert_eq!(tf.eval(50.0, 7.0).1, 0.05);
        tf.rects.push(TfRect {
            lo: 40.0,
            hi: 60.0,
            glo: 10.0,
            ghi: 20.0,
            rgb: [1.0, 0.0, 0.0],
            alpha: 0.5,
        });
        tf.blobs.push(TfBlob {
            value: 80.0,
            gradient: 30.0,
            value_sd: 2.0,
            gradient_sd: 5.0,
            rgb: [0.0, 0.0, 1.0],
            alpha: 0.9,
        });
        assert_eq!(tf.eval(50.0, 15.0), ([1.0, 0.0, 0.0], 0.5));
        assert_eq!(tf.eval(50.0, 20.0).1, 0.05);
        assert_eq!(tf.eval(80.0, 30.0), ([0.0, 0.0, 1.0], 0.9));
        let (_, a) = tf.eval(82.0, 30.0);
        assert!((a - 0.9 * (-0.5f32).exp()).abs() < 1e-6);
        // Past three standard deviations the 1D layer shows again.
        assert_eq!(tf.eval(80.0, 46.0).1, tf.eval(80.0, 0.0).1);
        assert_eq!(tf.eval(f32::NAN, 30.0).1, 0.0);
        assert_eq!(tf.eval(50.0, f32::NAN), tf.eval(50.0, 0.0));
    }

    #[test]
    fn boundary_preset_is_transparent_where_the_value_is_flat() {
        let b = TransferFunction2d::boundary((0.0, 255.0), 255.0);
        for v in [0.0, 100.0, 255.0, 300.0] {
            assert_eq!(b.eval(v, 0.0).1, 0.0);
            assert_eq!(b.eval(v, 5.0).1, 0.0);
            assert!(b.eval(v, 10.0).1 > 0.0);
            assert!(b.eval(v, 200.0).1 > b.eval(v, 20.0).1);
            assert_eq!(b.eval(v, 1e30).1, 0.8);
        }
    }
}
