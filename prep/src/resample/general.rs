//! The general path (an output grid rotated against the input): each
//! output voxel's centre is mapped to a continuous input index, and the
//! kernel's tensor product is evaluated there.

use super::kernel::{AxisSampler, Kernel};
use super::{inside, Affine};
use crate::stage::Slab;

/// Per-voxel evaluation of a separable kernel through an affine map.
pub(crate) struct General {
    pub(crate) map: Affine,
    pub(crate) s: [AxisSampler; 3],
    pub(crate) kernel: Kernel,
    pub(crate) n_in: [u64; 3],
}

impl General {
    /// Output slice `z` (`nx` × `ny`) into `out`.
    pub(crate) fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32], nx: usize, bg: f32) {
        let nxi = self.n_in[0] as usize;
        let [tx, ty, tz] = self.s.map(|s| s.taps());
        let mut wx = vec![0.0f32; tx];
        let mut wy = vec![0.0f32; ty];
        let mut wz = vec![0.0f32; tz];
        let n = self.n_in;
        let nearest = self.kernel == Kernel::Nearest;
        // Plain trilinear (no widening on any axis): the 8 taps directly.
        let linear = self.kernel == Kernel::Linear && self.s.iter().all(|s| s.reach() == 1.0);
        for (j, o) in out.chunks_exact_mut(nx).enumerate() {
            let base = self.map.at([0.0, j as f64, z as f64]);
            let dx = self.map.column(0);
            for (i, v) in o.iter_mut().enumerate() {
                let fi = i as f64;
                let c: [f64; 3] = std::array::from_fn(|a| base[a] + fi * dx[a]);
                if !(inside(c[0], n[0]) && inside(c[1], n[1]) && inside(c[2], n[2])) {
                    *v = bg;
                    continue;
                }
                if nearest {
                    let k: [usize; 3] = std::array::from_fn(|a| {
                        ((c[a] + 0.5).floor() as i64).clamp(0, n[a] as i64 - 1) as usize
                    });
                    *v = input.slice(k[2] as u64)[k[1] * nxi + k[0]];
                    continue;
                }
                if linear {
                    *v = trilinear(input, c, n);
                    continue;
                }
                let fx = self.s[0].weights(c[0], &mut wx);
                let fy = self.s[1].weights(c[1], &mut wy);
                let fz = self.s[2].weights(c[2], &mut wz);
                let mut acc = 0.0f32;
                for (t, &a) in wz.iter().enumerate() {
                    if a == 0.0 {
                        continue;
                    }
                    let s = input.slice((fz + t) as u64);
                    let mut accy = 0.0f32;
                    for (u, &b) in wy.iter().enumerate() {
                        if b == 0.0 {
                            continue;
                        }
                        let row = &s[(fy + u) * nxi + fx..][..tx];
                        let accx: f32 = wx.iter().zip(row).map(|(p, q)| p * q).sum();
                        accy += b * accx;
                    }
                    acc += a * accy;
                }
                *v = acc;
            }
        }
    }
}

/// Trilinear interpolation at `c` (inside the box), taps clamped to the
/// volume: ITK's `LinearInterpolateImageFunction`.
#[inline]
fn trilinear(input: &Slab<'_>, c: [f64; 3], n: [u64; 3]) -> f32 {
    let mut i0 = [0usize; 3];
    let mut i1 = [0usize; 3];
    let mut f = [0.0f32; 3];
    for a in 0..3 {
        let b = c[a].floor();
        let last = n[a] as i64 - 1;
        f[a] = (c[a] - b) as f32;
        i0[a] = (b as i64).clamp(0, last) as usize;
        i1[a] = (b as i64 + 1).clamp(0, last) as usize;
    }
    let nx = n[0] as usize;
    let plane = |s: &[f32]| {
        let r0 = &s[i0[1] * nx..];
        let r1 = &s[i1[1] * nx..];
        let a = r0[i0[0]] + f[0] * (r0[i1[0]] - r0[i0[0]]);
        let b = r1[i0[0]] + f[0] * (r1[i1[0]] - r1[i0[0]]);
        a + f[1] * (b - a)
    };
    let p0 = plane(input.slice(i0[2] as u64));
    if f[2] == 0.0 {
        return p0;
    }
    let p1 = plane(input.slice(i1[2] as u64));
    p0 + f[2] * (p1 - p0)
}
