//! `spheres`: soft ellipsoids with smooth density falloff and varying peaks.
//!
//! `count` ellipsoids with random centres inside the volume, semi-axes drawn
//! from `[size/2, size]` per axis and peaks from `[0.25, 1] · value`. The
//! density of one is `peak · (1 − r²)²` for normalised radius `r < 1`
//! (smooth to its first derivative at the rim); overlapping ones combine by
//! maximum, so the result stays within `[0, value]`.

use super::{clip, Scene};
use crate::dims::Dims;

struct Blob {
    centre: [f64; 3],
    semi: [f64; 3],
    peak: f64,
}

/// Soft ellipsoids (see the module docs).
pub struct SpheresScene {
    dims: Dims,
    blobs: Vec<Blob>,
}

impl SpheresScene {
    /// `count` blobs of nominal semi-axis `size`, peaks up to `value`.
    pub fn new(dims: Dims, seed: u64, count: usize, size: u64, value: f32) -> Self {
        let mut rng = fastrand::Rng::with_seed(seed);
        let d = dims.as_array();
        let size = size.max(1) as f64;
        let blobs = (0..count)
            .map(|_| Blob {
                centre: std::array::from_fn(|a| rng.f64() * (d[a] - 1) as f64),
                semi: std::array::from_fn(|_| size * (0.5 + 0.5 * rng.f64())),
                peak: value as f64 * (0.25 + 0.75 * rng.f64()),
            })
            .collect();
        SpheresScene { dims, blobs }
    }
}

impl Scene for SpheresScene {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        out.fill(0.0);
        let mut any = false;
        for b in &self.blobs {
            let dy = (y as f64 - b.centre[1]) / b.semi[1];
            let dz = (z as f64 - b.centre[2]) / b.semi[2];
            let q = 1.0 - dy * dy - dz * dz;
            if q <= 0.0 {
                continue;
            }
            let half = b.semi[0] * q.sqrt();
            let a = (b.centre[0] - half).floor() as i64;
            let e = (b.centre[0] + half).ceil() as i64 + 1;
            let Some((a, e)) = clip(a, e, x0, out.len()) else {
                continue;
            };
            any = true;
            for (i, o) in out[a..e].iter_mut().enumerate() {
                let dx = ((x0 + (a + i) as u64) as f64 - b.centre[0]) / b.semi[0];
                let r2 = dx * dx + dy * dy + dz * dz;
                if r2 < 1.0 {
                    let w = 1.0 - r2;
                    let v = (b.peak * w * w) as f32;
                    if v > *o {
                        *o = v;
                    }
                }
            }
        }
        any
    }
}
