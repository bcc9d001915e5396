//! `noise`: fractal (fBm) value or gradient noise.
//!
//! Octave `o` samples a lattice of period `period / 2^o` voxels with
//! amplitude `0.5^o`; lattice values (value noise) or gradients (gradient
//! noise, Perlin's twelve cube-edge directions) are hashed from the seed,
//! the octave and the lattice point, and blended with the quintic fade
//! `6t⁵ − 15t⁴ + 10t³`. The sum, normalised to `[−1, 1]`, is mapped
//! to `[0, value]`. Each row computes lattice data once per cell it crosses.

use super::{hash64, Scene};
use crate::dims::Dims;

/// Which lattice noise to sum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    /// Interpolated random values at lattice points.
    Value,
    /// Perlin-style gradient noise.
    Gradient,
}

/// Fractal noise (see the module docs).
pub struct NoiseScene {
    dims: Dims,
    seed: u64,
    kind: NoiseKind,
    period: f64,
    octaves: u32,
    value: f32,
}

const GRADIENTS: [[f64; 3]; 12] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
];

#[inline(always)]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline(always)]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

impl NoiseScene {
    /// Noise with lattice `period` (voxels, at least 1) and `octaves`
    /// (1 to 16), peak `value`.
    pub fn new(
        dims: Dims,
        seed: u64,
        kind: NoiseKind,
        period: f64,
        octaves: u32,
        value: f32,
    ) -> Self {
        NoiseScene {
            dims,
            seed,
            kind,
            period: if period.is_finite() {
                period.max(1.0)
            } else {
                1.0
            },
            octaves: octaves.clamp(1, 16),
            value,
        }
    }

    fn lattice_hash(seed: u64, p: [i64; 3]) -> u64 {
        hash64(hash64(hash64(seed, p[0] as u64), p[1] as u64), p[2] as u64)
    }

    /// Add one octave of `amp`-weighted noise to `acc`.
    fn octave(&self, o: u32, amp: f64, x0: u64, y: u64, z: u64, acc: &mut [f64]) {
        let seed = hash64(self.seed, o as u64 + 1);
        let freq = (1u64 << o) as f64 / self.period;
        let py = y as f64 * freq;
        let pz = z as f64 * freq;
        let (iy, iz) = (py.floor() as i64, pz.floor() as i64);
        let (fy, fz) = (py - iy as f64, pz - iz as f64);
        let (uy, uz) = (fade(fy), fade(fz));
        let mut cell = i64::MIN;
        // Corner data for the current cell: value, or gradient, per corner
        // ordered dx + 2·dy + 4·dz.
        let mut corner = [[0f64; 3]; 8];
        for (i, a) in acc.iter_mut().enumerate() {
            let px = (x0 + i as u64) as f64 * freq;
            let ix = px.floor() as i64;
            if ix != cell {
                cell = ix;
                for (c, slot) in corner.iter_mut().enumerate() {
                    let p = [
                        ix + (c & 1) as i64,
                        iy + ((c >> 1) & 1) as i64,
                        iz + ((c >> 2) & 1) as i64,
                    ];
                    let h = Self::lattice_hash(seed, p);
                    *slot = match self.kind {
                        NoiseKind::Gradient => GRADIENTS[(h % 12) as usize],
                        NoiseKind::Value => {
                            [(h >> 11) as f64 / (1u64 << 52) as f64 - 1.0, 0.0, 0.0]
                        }
                    };
                }
            }
            let fx = px - ix as f64;
            let mut v = [0f64; 8];
            for (c, val) in v.iter_mut().enumerate() {
                let g = corner[c];
                *val = match self.kind {
                    NoiseKind::Value => g[0],
                    NoiseKind::Gradient => {
                        let dx = fx - (c & 1) as f64;
                        let dy = fy - ((c >> 1) & 1) as f64;
                        let dz = fz - ((c >> 2) & 1) as f64;
                        g[0] * dx + g[1] * dy + g[2] * dz
                    }
                };
            }
            let ux = fade(fx);
            let x00 = lerp(v[0], v[1], ux);
            let x10 = lerp(v[2], v[3], ux);
            let x01 = lerp(v[4], v[5], ux);
            let x11 = lerp(v[6], v[7], ux);
            *a += amp * lerp(lerp(x00, x10, uy), lerp(x01, x11, uy), uz);
        }
    }
}

impl Scene for NoiseScene {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        let mut acc = vec![0f64; out.len()];
        let mut amp = 1.0;
        let mut norm = 0.0;
        for o in 0..self.octaves {
            self.octave(o, amp, x0, y, z, &mut acc);
            norm += amp;
            amp *= 0.5;
        }
        for (o, a) in out.iter_mut().zip(acc) {
            let n = (0.5 + 0.5 * a / norm).clamp(0.0, 1.0);
            *o = (n * self.value as f64) as f32;
        }
        true
    }
}
