//! The Henyey-Greenstein phase function: evaluation for next-event
//! estimation and exact sampling for path continuation.
//!
//! Directions are the directions light travels. For a path traced from
//! the camera along `d`, light leaves the scattering point along `−d`; a
//! light whose photons arrive travelling along `s` scatters into it with
//! cosine `μ = s·(−d)`. Sampling a continuation around the current ray
//! direction `d` with the same `μ` distribution is the same thing seen
//! backwards. `g > 0` scatters forward.

use glam::Vec3;

/// Largest |g| used: `g = ±1` is a delta distribution (a forward or
/// backward ray that never turns), so `g` is clamped into
/// `[−0.9999, 0.9999]`, where the densities stay finite in f32.
pub const MAX_G: f32 = 0.9999;

/// A Henyey-Greenstein phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    g: f32,
}

impl HenyeyGreenstein {
    /// The phase function with asymmetry `g` (clamped to ±[`MAX_G`]; NaN
    /// is taken as 0, isotropic).
    pub fn new(g: f32) -> HenyeyGreenstein {
        let g = if g.is_nan() {
            0.0
        } else {
            g.clamp(-MAX_G, MAX_G)
        };
        HenyeyGreenstein { g }
    }

    /// The asymmetry parameter.
    pub fn g(&self) -> f32 {
        self.g
    }

    /// The density per steradian for scattering cosine `mu`. In f64,
    /// with `1 + g² − 2gμ` written around the peak (`(1 − g)² + 2g(1 − μ)`
    /// for g ≥ 0), so strongly peaked lobes keep their precision.
    #[inline]
    pub fn eval(&self, mu: f32) -> f32 {
        let g = self.g as f64;
        let mu = (mu as f64).clamp(-1.0, 1.0);
        let denom = if g >= 0.0 {
            (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - mu)
        } else {
            (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + mu)
        };
        let denom = denom.max(1e-30);
        ((1.0 - g) * (1.0 + g) / (4.0 * std::f64::consts::PI * denom * denom.sqrt())) as f32
    }

    /// A scattering cosine drawn from the phase function with `u` in
    /// `[0, 1)` (the inverse of the cosine's distribution, in f64).
    #[inline]
    pub fn sample_mu(&self, u: f32) -> f32 {
        let g = self.g as f64;
        let u = u as f64;
        let mu = if g.abs() < 1e-3 {
            1.0 - 2.0 * u
        } else {
            let s = (1.0 - g) * (1.0 + g) / (1.0 - g + 2.0 * g * u);
            (1.0 + g * g - s * s) / (2.0 * g)
        };
        mu.clamp(-1.0, 1.0) as f32
    }

    /// A new unit direction around unit `d`, at a cosine drawn from the
    /// phase function and a uniform azimuth (`u`, `v` in `[0, 1)`). Its
    /// weight (density over pdf) is exactly 1.
    #[inline]
    pub fn sample(&self, d: Vec3, u: f32, v: f32) -> Vec3 {
        let mu = self.sample_mu(u);
        let sin = (1.0 - mu * mu).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * v;
        let (b1, b2) = basis(d);
        let w = b1 * (sin * phi.cos()) + b2 * (sin * phi.sin()) + d * mu;
        // Unit up to rounding; renormalised so rounding does not build up
        // over many bounces.
        w.normalize_or(d)
    }
}

/// Two unit vectors that complete unit `n` to an orthonormal basis
/// (Duff et al. 2017: no division by a small number, no branch on a
/// threshold).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The density integrates to 1 over the sphere and its mean cosine is
    /// g, for g across its range, the extremes included (the lobe of
    /// g = 0.999 is 1e-6 wide in cosine: the quadrature runs on a
    /// logarithmic grid of distances from the peak).
    #[test]
    fn density_is_normalised_with_mean_cosine_g() {
        for g in [-0.999f32, -0.7, 0.0, 0.3, 0.9, 0.999] {
            let p = HenyeyGreenstein::new(g);
            // Distance w from the peak cosine (1 for g >= 0, −1 below).
            let peak = if g >= 0.0 { 1.0 } else { -1.0 };
            let n = 200_000;
            let w_at = |i: usize| 2.0 * 1e-14f64.powf(1.0 - i as f64 / n as f64);
            // Trapezoids between nodes at f32 cosines (the density's
            // argument), their distances recomputed exactly.
            let (mut total, mut mean) = (0.0f64, 0.0f64);
            let (mut w0, mut f0) = (0.0f64, p.eval(peak as f32) as f64);
            for i in 0..=n {
                let mu = (peak - peak * w_at(i)) as f32;
                let w = (peak - mu as f64) * peak;
                if w <= w0 {
                    continue;
                }
                let f = p.eval(mu) as f64;
                let d = 0.5 * (f0 + f) * (w - w0) * 2.0 * std::f64::consts::PI;
                total += d;
                mean += (peak - peak * 0.5 * (w0 + w)) * d;
                (w0, f0) = (w, f);
            }
            assert!((total - 1.0).abs() < 2e-3, "g {g}: integral {total}");
            assert!((mean - g as f64).abs() < 3e-3, "g {g}: mean cosine {mean}");
        }
    }

    /// Sampled cosines follow the density: their mean is g and the
    /// fraction below 0 matches the integral of the density.
    #[test]
    fn samples_follow_the_density() {
        for g in [-0.999f32, -0.5, 0.0, 0.8, 0.999] {
            let p = HenyeyGreenstein::new(g);
            let n = 400_000;
            let mut rng = fastrand::Rng::with_seed(3);
            let (mut mean, mut back) = (0.0f64, 0usize);
            let d = Vec3::new(0.3, -0.4, 0.866).normalize();
            for _ in 0..n {
                let w = p.sample(d, rng.f32(), rng.f32());
                assert!((w.length() - 1.0).abs() < 1e-5);
                let mu = w.dot(d);
                mean += mu as f64;
                back += usize::from(mu < 0.0);
            }
            mean /= n as f64;
            assert!((mean - g as f64).abs() < 0.01, "g {g}: mean {mean}");
            // P(μ < 0) from the closed-form distribution of the cosine,
            // (1 − g²)/(2g) · (1/sqrt(1 + g² − 2gμ) − 1/(1 + g)), at μ = 0.
            let gd = g as f64;
            let expect = if gd == 0.0 {
                0.5
            } else {
                (1.0 - gd * gd) / (2.0 * gd) * (1.0 / (1.0 + gd * gd).sqrt() - 1.0 / (1.0 + gd))
            };
            let got = back as f64 / n as f64;
            assert!((got - expect).abs() < 0.005, "g {g}: {got} vs {expect}");
        }
    }

    #[test]
    fn basis_is_orthonormal_for_every_direction() {
        let mut rng = fastrand::Rng::with_seed(1);
        let mut dirs = vec![Vec3::X, Vec3::NEG_Z, Vec3::Z, Vec3::new(0.0, 0.0, -1.0)];
        dirs.extend(
            (0..1000)
                .map(|_| Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5).normalize()),
        );
        for n in dirs {
            let (a, b) = basis(n);
            for (x, y) in [(a, b), (a, n), (b, n)] {
                assert!(x.dot(y).abs() < 1e-5, "{n}");
            }
            assert!((a.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
        }
        assert_eq!(HenyeyGreenstein::new(f32::NAN).g(), 0.0);
        assert_eq!(HenyeyGreenstein::new(2.0).g(), MAX_G);
    }
}
