//! The `label` kernel: nearest along upsampled axes, and along
//! downsampled axes the most frequent value of the input voxels the
//! output voxel covers. Not separable (a majority of a box is not a
//! product of per-axis majorities), so it runs per voxel over the box.

use super::{inside, Affine};
use crate::stage::Slab;

/// Majority over the covered box, through an affine map.
pub(crate) struct Label {
    pub(crate) map: Affine,
    /// The output voxel's size along each input axis, in input voxels
    /// (see [`super::Resample`]); at most 1 means nearest on that axis.
    pub(crate) sigma: [f64; 3],
    pub(crate) n_in: [u64; 3],
}

/// Whether an axis with this scale is downsampled (a covered box wider
/// than one voxel).
pub(crate) fn downsampled(sigma: f64) -> bool {
    sigma > 1.0 + 1e-9
}

/// The input indices (inclusive) an output voxel centred at `c` covers
/// along one axis of `n` voxels: the voxels whose centres lie in
/// `[c − σ/2, c + σ/2)`, or the nearest one (`floor(c + 0.5)`) when the
/// axis is not downsampled or no centre lies there. Clamped to `0 .. n`.
#[inline]
pub(crate) fn covered(c: f64, sigma: f64, n: u64) -> (usize, usize) {
    let last = n as i64 - 1;
    let near = ((c + 0.5).floor() as i64).clamp(0, last) as usize;
    if !downsampled(sigma) {
        return (near, near);
    }
    let lo = ((c - sigma / 2.0).ceil() as i64).clamp(0, last);
    let hi = ((c + sigma / 2.0).ceil() as i64 - 1).clamp(0, last);
    if hi < lo {
        (near, near)
    } else {
        (lo as usize, hi as usize)
    }
}

/// The most frequent value of `v` (ties to the smallest); sorts `v`.
pub(crate) fn majority(v: &mut [f32]) -> f32 {
    v.sort_unstable_by(|a, b| a.total_cmp(b));
    let mut best = v[0];
    let mut best_n = 0usize;
    let mut i = 0;
    while i < v.len() {
        let mut j = i + 1;
        while j < v.len() && v[j].to_bits() == v[i].to_bits() {
            j += 1;
        }
        if j - i > best_n {
            best_n = j - i;
            best = v[i];
        }
        i = j;
    }
    best
}

impl Label {
    /// Output slice `z` (`nx` × `ny`) into `out`.
    pub(crate) fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32], nx: usize, bg: f32) {
        let n = self.n_in;
        let nxi = n[0] as usize;
        let mut vals: Vec<f32> = Vec::new();
        let dx = self.map.column(0);
        for (j, o) in out.chunks_exact_mut(nx).enumerate() {
            let base = self.map.at([0.0, j as f64, z as f64]);
            for (i, v) in o.iter_mut().enumerate() {
                let fi = i as f64;
                let c: [f64; 3] = std::array::from_fn(|a| base[a] + fi * dx[a]);
                if !(inside(c[0], n[0]) && inside(c[1], n[1]) && inside(c[2], n[2])) {
                    *v = bg;
                    continue;
                }
                let r: [(usize, usize); 3] =
                    std::array::from_fn(|a| covered(c[a], self.sigma[a], n[a]));
                if r.iter().all(|(lo, hi)| lo == hi) {
                    *v = input.slice(r[2].0 as u64)[r[1].0 * nxi + r[0].0];
                    continue;
                }
                vals.clear();
                for k in r[2].0..=r[2].1 {
                    let s = input.slice(k as u64);
                    for y in r[1].0..=r[1].1 {
                        vals.extend_from_slice(&s[y * nxi + r[0].0..=y * nxi + r[0].1]);
                    }
                }
                *v = majority(&mut vals);
            }
        }
    }
}
