//! `waves`: a band-limited analytic volume for resampling and smoothing
//! studies. A sum of [`WAVE_COUNT`] plane waves (cosines) with fixed
//! wavelengths from [`WAVELENGTHS`] voxels (the longest 40, the shortest
//! 4) in directions and phases drawn from the seed (the shortest within
//! [`NEAR_AXIS_DEG`] of an axis):
//!
//! `f(x) = value · (1/2 + 1/2 · Σ aₙ cos(2π dₙ·x / λₙ + φₙ))`, Σ aₙ = 1,
//!
//! where `x` is the position in voxels of the generated grid (voxel
//! `(i, j, k)` is at `x = (i, j, k)`). Every wave's frequency along every
//! axis is at most `1/λₙ ≤ 1/4` cycles per voxel, half the grid's Nyquist
//! limit (1/2): the samples determine the function, and the function is
//! defined everywhere, so any other grid's exact values are known. The
//! values lie in `[0, value]`.
//!
//! The voxel values do not depend on the spacing: a volume written with
//! spacing `s` (vol-gen `--spacing`, identity directions, origin 0) holds
//! the physical function `f(p) = f_voxels(p / s)`, which
//! [`Waves::at_world`] evaluates at any world point, so a resampled
//! grid's exact values come from its own origin and spacing.
//! [`Waves::smoothed`] is the exact Gaussian convolution (each wave keeps
//! `exp(−2π²Σσₐ²kₐ²)` of its amplitude, `k` in cycles per world unit) and
//! [`Waves::lowpassed`] the ideal separable low-pass of another grid (the
//! waves above its Nyquist limit on any axis removed).

use super::{hash64, Scene};
use crate::dims::Dims;

/// How many plane waves the scene sums.
pub const WAVE_COUNT: usize = 5;

/// Each wave's wavelength along its direction, in voxels of the
/// generated grid (all at least 4: below half the Nyquist limit).
pub const WAVELENGTHS: [f64; WAVE_COUNT] = [40.0, 20.0, 10.0, 6.0, 4.0];

/// The shortest wave runs within this many degrees of a coordinate axis,
/// so that it has between 0.23 and 0.25 cycles per voxel on that axis:
/// above the Nyquist limit of a grid 3 times coarser (1/6), which must
/// then filter it out, and just below that of a grid 2 times coarser.
pub const NEAR_AXIS_DEG: f64 = 25.0;

/// Each wave's share of the amplitude (they sum to 1).
pub const AMPLITUDES: [f64; WAVE_COUNT] = [0.35, 0.25, 0.2, 0.12, 0.08];

/// One plane wave: `amplitude · cos(2π k·x + phase)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wave {
    /// Amplitude, in units of the scene's value.
    pub amplitude: f64,
    /// Wave vector, cycles per unit of `x` (voxels of the generated grid,
    /// or world units after [`Waves::in_world`]).
    pub k: [f64; 3],
    /// Phase, radians.
    pub phase: f64,
}

/// A sum of plane waves plus a constant: the `waves` scene's function.
#[derive(Clone, Debug, PartialEq)]
pub struct Waves {
    /// The constant term.
    pub offset: f64,
    /// The waves.
    pub waves: Vec<Wave>,
}

/// A uniform number in `[0, 1)` from a seed and an index.
fn uniform(seed: u64, index: u64) -> f64 {
    (hash64(seed, index) >> 11) as f64 / (1u64 << 53) as f64
}

impl Waves {
    /// The scene's function in voxel coordinates of the generated grid,
    /// with values in `[0, value]`; the same seed gives the same waves.
    pub fn new(seed: u64, value: f64) -> Waves {
        let waves = (0..WAVE_COUNT)
            .map(|n| {
                let r = |j: u64| uniform(seed, 4 * n as u64 + j);
                let t = 2.0 * std::f64::consts::PI * r(1);
                let d = if n + 1 == WAVE_COUNT {
                    // The shortest wave within NEAR_AXIS_DEG of an axis
                    // (picked by the seed), either way along it.
                    let lo = NEAR_AXIS_DEG.to_radians().cos();
                    let c = lo + (1.0 - lo) * r(0);
                    let c = if r(3) < 0.5 { -c } else { c };
                    let sn = (1.0 - c * c).max(0.0).sqrt();
                    let axis = (hash64(seed, u64::MAX) % 3) as usize;
                    let mut d = [0.0; 3];
                    d[axis] = c;
                    d[(axis + 1) % 3] = sn * t.cos();
                    d[(axis + 2) % 3] = sn * t.sin();
                    d
                } else {
                    // A direction uniform on the sphere.
                    let cz = 2.0 * r(0) - 1.0;
                    let sz = (1.0 - cz * cz).max(0.0).sqrt();
                    [sz * t.cos(), sz * t.sin(), cz]
                };
                Wave {
                    amplitude: 0.5 * value * AMPLITUDES[n],
                    k: d.map(|c| c / WAVELENGTHS[n]),
                    phase: 2.0 * std::f64::consts::PI * r(2),
                }
            })
            .collect();
        Waves {
            offset: 0.5 * value,
            waves,
        }
    }

    /// The value at `x`.
    pub fn at(&self, x: [f64; 3]) -> f64 {
        let tau = 2.0 * std::f64::consts::PI;
        self.offset
            + self
                .waves
                .iter()
                .map(|w| {
                    let kx = w.k[0] * x[0] + w.k[1] * x[1] + w.k[2] * x[2];
                    w.amplitude * (tau * kx + w.phase).cos()
                })
                .sum::<f64>()
    }

    /// The same function in world coordinates of a volume generated with
    /// `spacing` (origin 0, identity directions: `p = x · spacing`).
    pub fn in_world(&self, spacing: [f64; 3]) -> Waves {
        Waves {
            offset: self.offset,
            waves: self
                .waves
                .iter()
                .map(|w| Wave {
                    k: [0, 1, 2].map(|a| {
                        if spacing[a] > 0.0 {
                            w.k[a] / spacing[a]
                        } else {
                            0.0
                        }
                    }),
                    ..*w
                })
                .collect(),
        }
    }

    /// The value at world point `p` of a volume generated with `spacing`
    /// (see [`Waves::in_world`]); for many points, convert once.
    pub fn at_world(&self, p: [f64; 3], spacing: [f64; 3]) -> f64 {
        self.in_world(spacing).at(p)
    }

    /// The exact convolution with a Gaussian of standard deviations
    /// `sigma` (per axis, in the units of `x`): each wave keeps
    /// `exp(−2π² Σₐ σₐ² kₐ²)` of its amplitude.
    pub fn smoothed(&self, sigma: [f64; 3]) -> Waves {
        let pi2 = std::f64::consts::PI * std::f64::consts::PI;
        Waves {
            offset: self.offset,
            waves: self
                .waves
                .iter()
                .map(|w| {
                    let e: f64 = (0..3).map(|a| sigma[a] * sigma[a] * w.k[a] * w.k[a]).sum();
                    Wave {
                        amplitude: w.amplitude * (-2.0 * pi2 * e).exp(),
                        ..*w
                    }
                })
                .collect(),
        }
    }

    /// The ideal separable low-pass of a grid of `spacing` (in the units
    /// of `x`): the waves whose frequency on some axis reaches that
    /// axis's Nyquist limit `1 / (2 spacing)` are removed.
    pub fn lowpassed(&self, spacing: [f64; 3]) -> Waves {
        Waves {
            offset: self.offset,
            waves: self
                .waves
                .iter()
                .filter(|w| (0..3).all(|a| w.k[a].abs() * 2.0 * spacing[a] < 1.0))
                .copied()
                .collect(),
        }
    }
}

/// The `waves` scene: [`Waves`] sampled at the voxel centres.
pub struct WavesScene {
    dims: Dims,
    waves: Waves,
}

impl WavesScene {
    /// The waves of `seed`, values in `[0, value]`.
    pub fn new(dims: Dims, seed: u64, value: f32) -> Self {
        WavesScene {
            dims,
            waves: Waves::new(seed, value as f64),
        }
    }
}

impl Scene for WavesScene {
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        // Directly, one cosine per wave and voxel, in f64: a rotation
        // recurrence along the row would drift with the row's length.
        let (y, z) = (y as f64, z as f64);
        let mut any = false;
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.waves.at([(x0 + i as u64) as f64, y, z]) as f32;
            any |= *o != 0.0;
        }
        any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene's voxels are the function at integer points, the same
    /// seed gives the same waves and another seed others.
    #[test]
    fn voxels_are_the_function_and_the_seed_decides() {
        let d = Dims::new(9, 4, 3).unwrap();
        let s = WavesScene::new(d, 7, 255.0);
        let w = Waves::new(7, 255.0);
        let mut row = vec![0f32; 9];
        s.fill_row(0, 2, 1, &mut row);
        for (i, v) in row.iter().enumerate() {
            let f = w.at([i as f64, 2.0, 1.0]);
            assert!((*v as f64 - f).abs() < 1e-3, "{v} {f}");
            assert!((0.0..=255.0).contains(v));
        }
        assert_eq!(Waves::new(7, 255.0), w);
        assert_ne!(Waves::new(8, 255.0), w);
    }

    /// Band-limited: every wave is below half the Nyquist limit on every
    /// axis, and the world form at spacing s agrees with the voxel form.
    #[test]
    fn waves_are_band_limited_and_scale_with_spacing() {
        for seed in 0..50 {
            let w = Waves::new(seed, 1.0);
            assert_eq!(w.waves.len(), WAVE_COUNT);
            for wave in &w.waves {
                assert!(wave.k.iter().all(|k| k.abs() <= 0.25 + 1e-12));
            }
            // Nothing is removed by the generated grid's own low-pass.
            assert_eq!(w.lowpassed([1.0; 3]).waves.len(), WAVE_COUNT);
            let s = [0.5, 0.5, 2.0];
            let x = [3.25, -1.5, 7.0];
            let p = [x[0] * s[0], x[1] * s[1], x[2] * s[2]];
            assert!((w.at(x) - w.at_world(p, s)).abs() < 1e-12);
        }
    }

    /// The Gaussian's effect on one wave: exp(−2π²σ²/λ²) along its
    /// direction, and nothing for σ = 0.
    #[test]
    fn smoothing_attenuates_each_wave_by_its_frequency() {
        let w = Waves::new(3, 2.0);
        assert_eq!(w.smoothed([0.0; 3]), w);
        let s = w.smoothed([1.5; 3]);
        for (n, (a, b)) in w.waves.iter().zip(&s.waves).enumerate() {
            let lambda = WAVELENGTHS[n];
            let want = (-2.0 * std::f64::consts::PI.powi(2) * 2.25 / (lambda * lambda)).exp();
            assert!((b.amplitude / a.amplitude - want).abs() < 1e-12);
        }
    }

    /// Down by 3 on every axis removes exactly the waves at or above the
    /// coarse grid's Nyquist limit, the shortest among them.
    #[test]
    fn lowpass_keeps_what_a_coarse_grid_can_hold() {
        for seed in 0..50 {
            let w = Waves::new(seed, 1.0);
            let kept = w.lowpassed([3.0; 3]);
            for wave in &w.waves {
                let fits = wave.k.iter().all(|k| k.abs() < 1.0 / 6.0);
                assert_eq!(kept.waves.contains(wave), fits);
            }
            // The 40-voxel wave always fits a grid 3 times coarser, the
            // 4-voxel one never does; a grid 2 times coarser holds all.
            assert!(kept.waves.contains(&w.waves[0]));
            assert!(!kept.waves.contains(&w.waves[WAVE_COUNT - 1]));
            assert_eq!(w.lowpassed([2.0; 3]).waves.len(), WAVE_COUNT);
        }
    }
}
