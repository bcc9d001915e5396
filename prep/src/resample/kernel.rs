//! The interpolation kernels: their names, their 1-D weights and the
//! cubic B-spline's prefilter.

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

/// The names `--kernel` accepts, in the order `--help` lists them.
pub const KERNEL_NAMES: [&str; 6] = [
    "nearest", "linear", "cubic", "bspline3", "lanczos3", "label",
];

/// How output samples are computed from the input's.
///
/// Every kernel but `label` is separable: a tensor product of one 1-D
/// kernel per axis. Input taps outside the volume take the nearest edge
/// sample (replicate, as ITK's ZeroFluxNeumann).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// The nearest input voxel; a tie rounds up (`floor(u + 0.5)`, as ITK).
    Nearest,
    /// Trilinear: the tent `max(0, 1 - |x|)`.
    Linear,
    /// Catmull-Rom cubic convolution (Keys, a = -0.5).
    Cubic,
    /// The interpolating cubic B-spline: the B-spline of degree 3 applied
    /// to coefficients from the exact inverse filter (pole √3 − 2),
    /// truncated to ±[`PREFILTER_HALF`] taps (relative error < 1e-6).
    BSpline3,
    /// Lanczos: `sinc(x)·sinc(x/3)` for `|x| < 3`, weights normalised to
    /// sum 1.
    Lanczos3,
    /// Label volumes: the nearest voxel along an axis that is upsampled;
    /// along an axis that is downsampled, the most frequent value among
    /// the input voxels the output voxel covers (ties to the smallest).
    Label,
}

/// Half-width of the truncated B-spline prefilter: taps `-11 ..= 11`.
/// The exact inverse of the sampled cubic B-spline `(z + 4 + 1/z)/6` has
/// the impulse response `√3 · z1^|k|`, `z1 = √3 − 2`; the dropped tail
/// sums to `2√3 |z1|^12 / (1 − |z1|) ≈ 6.5e-7` of a unit step (the
/// filter's absolute sum is 3, so < 1e-6 relative). The kept taps are
/// renormalised to sum 1, so constants and ramps stay exact.
pub const PREFILTER_HALF: usize = 11;

impl Kernel {
    /// Every kernel, in [`KERNEL_NAMES`] order.
    pub const ALL: [Kernel; 6] = [
        Kernel::Nearest,
        Kernel::Linear,
        Kernel::Cubic,
        Kernel::BSpline3,
        Kernel::Lanczos3,
        Kernel::Label,
    ];

    /// The name `--kernel` takes.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Nearest => KERNEL_NAMES[0],
            Kernel::Linear => KERNEL_NAMES[1],
            Kernel::Cubic => KERNEL_NAMES[2],
            Kernel::BSpline3 => KERNEL_NAMES[3],
            Kernel::Lanczos3 => KERNEL_NAMES[4],
            Kernel::Label => KERNEL_NAMES[5],
        }
    }

    /// Half-width of the support in input voxels at scale 1: the weight
    /// of a tap at distance `|x| >= radius` is zero. For `bspline3` this is
    /// the composite kernel (prefilter then B-spline).
    pub fn radius(self) -> f64 {
        match self {
            Kernel::Nearest | Kernel::Label => 0.5,
            Kernel::Linear => 1.0,
            Kernel::Cubic => 2.0,
            Kernel::BSpline3 => PREFILTER_HALF as f64 + 2.0,
            Kernel::Lanczos3 => 3.0,
        }
    }

    /// Whether downsampling widens this kernel (`nearest` and `label`
    /// pick samples; they are never widened).
    pub fn antialiases(self) -> bool {
        !matches!(self, Kernel::Nearest | Kernel::Label)
    }

    /// The continuous 1-D kernel at `x` (input voxels), unnormalised.
    /// `nearest` and `label` are not evaluated this way.
    pub(crate) fn eval(self, x: f64) -> f64 {
        let a = x.abs();
        match self {
            Kernel::Nearest | Kernel::Label => {
                if a < 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            Kernel::Linear => (1.0 - a).max(0.0),
            Kernel::Cubic => {
                // Keys with a = -0.5.
                if a < 1.0 {
                    (1.5 * a - 2.5) * a * a + 1.0
                } else if a < 2.0 {
                    ((-0.5 * a + 2.5) * a - 4.0) * a + 2.0
                } else {
                    0.0
                }
            }
            Kernel::BSpline3 => cardinal_bspline3(x),
            Kernel::Lanczos3 => {
                if a >= 3.0 {
                    0.0
                } else if a < 1e-12 {
                    1.0
                } else {
                    let p = std::f64::consts::PI * a;
                    3.0 * p.sin() * (p / 3.0).sin() / (p * p)
                }
            }
        }
    }
}

/// The cubic B-spline `β3(x)`.
fn bspline3(x: f64) -> f64 {
    let a = x.abs();
    if a < 1.0 {
        2.0 / 3.0 - a * a + 0.5 * a * a * a
    } else if a < 2.0 {
        let t = 2.0 - a;
        t * t * t / 6.0
    } else {
        0.0
    }
}

/// The truncated, renormalised prefilter taps `h[-11 ..= 11]` (index
/// `k + PREFILTER_HALF`).
pub(crate) fn prefilter() -> &'static [f64; 2 * PREFILTER_HALF + 1] {
    static H: OnceLock<[f64; 2 * PREFILTER_HALF + 1]> = OnceLock::new();
    H.get_or_init(|| {
        let z1 = 3f64.sqrt() - 2.0;
        let mut h = [0.0; 2 * PREFILTER_HALF + 1];
        for (i, v) in h.iter_mut().enumerate() {
            let k = i as i32 - PREFILTER_HALF as i32;
            *v = 3f64.sqrt() * z1.powi(k.abs());
        }
        let s: f64 = h.iter().sum();
        h.map(|v| v / s)
    })
}

/// The interpolating cubic B-spline as one kernel on the samples:
/// `Σ_m h[m] β3(x − m)` (the prefilter folded into the B-spline), which
/// is 1 at 0 and ~0 at the other integers.
fn cardinal_bspline3(x: f64) -> f64 {
    let h = prefilter();
    let k = PREFILTER_HALF as i64;
    let lo = ((x - 2.0).floor() as i64 + 1).max(-k);
    let hi = ((x + 2.0).ceil() as i64 - 1).min(k);
    (lo..=hi)
        .map(|m| h[(m + k) as usize] * bspline3(x - m as f64))
        .sum()
}

impl fmt::Display for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kernel {
    type Err = String;

    fn from_str(s: &str) -> Result<Kernel, String> {
        Kernel::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown kernel '{s}': the kernels are {}",
                    KERNEL_NAMES.join(", ")
                )
            })
    }
}

/// One axis's 1-D sampler: for a continuous input index, the first input
/// index and the weights of `taps()` consecutive input voxels, with the
/// taps that fall outside `0 .. n` folded onto the edge voxels (replicate).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AxisSampler {
    n: i64,
    kernel: Kernel,
    /// Widening factor (1, or the downsampling scale with antialiasing).
    sigma: f64,
    /// Raw taps before folding: `ceil(2 · radius · sigma)`.
    raw: usize,
    /// Taps after folding: `min(raw, n)`.
    taps: usize,
}

impl AxisSampler {
    /// A sampler over `n` voxels; `sigma >= 1` widens the kernel.
    pub(crate) fn new(n: u64, kernel: Kernel, sigma: f64) -> AxisSampler {
        let sigma = if kernel.antialiases() && sigma.is_finite() {
            sigma.max(1.0)
        } else {
            1.0
        };
        let raw = if kernel.antialiases() {
            ((2.0 * kernel.radius() * sigma).ceil() as usize).max(1)
        } else {
            1
        };
        AxisSampler {
            n: n as i64,
            kernel,
            sigma,
            raw,
            taps: raw.min(n as usize).max(1),
        }
    }

    /// Weights per call (the stride of weight tables).
    pub(crate) fn taps(&self) -> usize {
        self.taps
    }

    /// How far from `c` (in input voxels) a tap with a non-zero weight can
    /// lie, at most.
    pub(crate) fn reach(&self) -> f64 {
        if self.kernel.antialiases() {
            self.kernel.radius() * self.sigma
        } else {
            0.5
        }
    }

    /// Fills `w[..taps()]` with the weights for continuous index `c` and
    /// returns the input index of `w[0]`.
    #[inline]
    pub(crate) fn weights(&self, c: f64, w: &mut [f32]) -> usize {
        let w = &mut w[..self.taps];
        w.fill(0.0);
        let last = self.n - 1;
        if !self.kernel.antialiases() {
            // floor(c + 0.5): ITK's round-half-up.
            let j = ((c + 0.5).floor() as i64).clamp(0, last);
            w[0] = 1.0;
            return j as usize;
        }
        let r = self.kernel.radius() * self.sigma;
        let j0 = (c - r).floor() as i64 + 1;
        let first = j0.clamp(0, (self.n - self.taps as i64).max(0));
        let inv = 1.0 / self.sigma;
        let mut sum = 0.0f64;
        for t in 0..self.raw as i64 {
            let j = j0 + t;
            let v = self.kernel.eval((c - j as f64) * inv);
            if v != 0.0 {
                sum += v;
                w[(j.clamp(0, last) - first) as usize] += v as f32;
            }
        }
        if sum.abs() < 1e-12 || !sum.is_finite() {
            w.fill(0.0);
            let j = ((c + 0.5).floor() as i64).clamp(0, last);
            w[(j - first) as usize] = 1.0;
        } else if sum != 1.0 {
            let k = (1.0 / sum) as f32;
            for v in w.iter_mut() {
                *v *= k;
            }
        }
        first as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_lists_all() {
        for k in Kernel::ALL {
            assert_eq!(k.to_string().parse::<Kernel>(), Ok(k));
        }
        let e = "sinc".parse::<Kernel>().unwrap_err();
        for n in KERNEL_NAMES {
            assert!(e.contains(n), "{e}");
        }
        assert!(!e.contains('\n'));
    }

    #[test]
    fn prefilter_inverts_the_sampled_bspline() {
        // The composite kernel interpolates: 1 at 0, ~0 at other integers.
        assert!((cardinal_bspline3(0.0) - 1.0).abs() < 1e-6);
        for m in 1..14 {
            assert!(cardinal_bspline3(m as f64).abs() < 1e-6, "{m}");
            assert!(cardinal_bspline3(-(m as f64)).abs() < 1e-6, "{m}");
        }
        assert_eq!(cardinal_bspline3(13.0), 0.0);
    }

    #[test]
    fn folded_weights_sum_to_one_at_the_edges() {
        for k in [
            Kernel::Linear,
            Kernel::Cubic,
            Kernel::BSpline3,
            Kernel::Lanczos3,
        ] {
            for sigma in [1.0, 1.7, 3.0] {
                for n in [1u64, 3, 40] {
                    let s = AxisSampler::new(n, k, sigma);
                    let mut w = vec![0.0; s.taps()];
                    for c in [-0.5, -0.2, 0.0, 0.3, n as f64 / 2.0, n as f64 - 0.6] {
                        let f = s.weights(c, &mut w);
                        assert!(f + s.taps() <= n as usize);
                        let sum: f32 = w.iter().sum();
                        assert!((sum - 1.0).abs() < 1e-5, "{k} {sigma} {n} {c}: {sum}");
                    }
                }
            }
        }
    }
}
