//! `--median R`: the exact median of the (2R+1)³ neighbourhood.
//!
//! - **Exact**: the output is one of the neighbourhood's samples, the
//!   middle one ((2R+1)³ is odd), so integer volumes stay integer and
//!   equal SimpleITK's `Median(img, [R, R, R])`.
//! - **Borders**: replicate (indices clamped), as ITK's MedianImageFilter,
//!   whose neighbourhood iterator uses ZeroFluxNeumann: so it equals
//!   SimpleITK at the borders too (checked with SimpleITK 2.5 on a
//!   random integer volume, R = 1 and 2, every voxel).
//! - **Order**: samples compare by [`f32::total_cmp`]: −NaN < −∞ < … <
//!   −0 < +0 < … < +∞ < +NaN. A NaN is a large (or, negative, a small)
//!   value, never a hole; −0 sorts below +0 (ITK leaves the order of NaN
//!   undefined and calls ±0 equal).
//! - **Speed**: R = 1 sorts each (z, y) column of 9 once per row and
//!   takes each median from three sorted columns through a comparator
//!   network on whole rows (vectorised min/max on integer keys); larger
//!   R selects with `select_nth_unstable` over the gathered keys.

use crate::grid::Grid;
use crate::stage::{Slab, Stage, SLAB_BUDGET};
use std::ops::Range;

/// The largest R: each voxel orders (2R+1)³ samples (R = 50: 1 030 301),
/// so past that a run would take days.
pub const MAX_RADIUS: u64 = 50;

/// Median filter over (2R+1)³ neighbourhoods, replicate borders; the
/// output grid is the input's.
pub struct Median {
    grid: Grid,
    r: u64,
    /// The R = 1 network's final selection: comparators over 16 wires.
    net: Vec<(usize, usize)>,
}

impl Median {
    /// A median of radius `r` over `input`. Refuses R = 0, R past
    /// [`MAX_RADIUS`], and a window of 2R+1 slices that does not fit half
    /// the slab budget.
    pub fn new(input: Grid, r: u64) -> Result<Median, String> {
        if r == 0 {
            return Err("--median 0: R must be at least 1 (R = 0 would copy the input)".into());
        }
        if r > MAX_RADIUS {
            return Err(format!(
                "--median {r}: R is at most {MAX_RADIUS} (each voxel orders (2R+1)^3 = {} samples)",
                (2 * r + 1).saturating_pow(3)
            ));
        }
        let window = (2 * r + 1).min(input.dims.z);
        let bytes = window.saturating_mul(input.dims.slice_len().saturating_mul(4));
        if bytes > SLAB_BUDGET / 2 {
            return Err(format!(
                "--median {r}: a window of {window} slices of {}x{} f32 ({} MB) does not fit the {} GiB slab budget",
                input.dims.x,
                input.dims.y,
                bytes / 1_000_000,
                SLAB_BUDGET >> 30
            ));
        }
        Ok(Median {
            grid: input,
            r,
            net: select_network(16, 6),
        })
    }

    /// R.
    pub fn radius(&self) -> u64 {
        self.r
    }

    /// Output slice `z` by the general path (gather and select), whatever
    /// R: the reference the R = 1 path is tested against.
    pub fn run_general(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) {
        let nx = self.grid.dims.x as usize;
        let ny = self.grid.dims.y as i64;
        let r = self.r as i64;
        let d = (2 * r + 1) as usize;
        let mid = d * d * d / 2;
        let xs: Vec<Vec<usize>> = (0..nx)
            .map(|x| {
                (-r..=r)
                    .map(|dx| (x as i64 + dx).clamp(0, nx as i64 - 1) as usize)
                    .collect()
            })
            .collect();
        let slices: Vec<&[f32]> = (-r..=r)
            .map(|dz| input.slice_clamped(z as i64 + dz))
            .collect();
        let mut keys: Vec<i32> = Vec::with_capacity(d * d * d);
        let mut rows: Vec<&[f32]> = Vec::with_capacity(d * d);
        for y in 0..ny {
            rows.clear();
            for s in &slices {
                for dy in -r..=r {
                    let j = (y + dy).clamp(0, ny - 1) as usize;
                    rows.push(&s[j * nx..(j + 1) * nx]);
                }
            }
            let o = &mut out[y as usize * nx..(y as usize + 1) * nx];
            for (x, v) in o.iter_mut().enumerate() {
                keys.clear();
                for row in &rows {
                    keys.extend(xs[x].iter().map(|&i| key(row[i])));
                }
                let (_, m, _) = keys.select_nth_unstable(mid);
                *v = unkey(*m);
            }
        }
    }

    /// Output slice `z` for R = 1: per row, the 9 samples of each (z, y)
    /// column sorted once; each voxel's median from the three sorted
    /// columns around it.
    ///
    /// With columns A, B, C sorted and each rank's triple (A_i, B_i, C_i)
    /// sorted into (lo_i, mid_i, hi_i), the 9×3 table is sorted along both
    /// ways, so element (i, j) has at least (i+1)(j+1) samples at or below
    /// it and (9−i)(3−j) at or above. Seven (lo_0..4, mid_0..1) are below
    /// the median for sure and seven above (mid_7..8, hi_4..8); the
    /// median of 27 is the median of the other 13, selected by a
    /// comparator network.
    fn run_r1(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) {
        let nx = self.grid.dims.x as usize;
        let ny = self.grid.dims.y as i64;
        let w = nx + 2;
        let slices: Vec<&[f32]> = (-1..=1)
            .map(|dz| input.slice_clamped(z as i64 + dz))
            .collect();
        // cols[k * w + x + 1]: sample k of the column at x (x padded by
        // one on each side, replicated).
        let mut cols = vec![0i32; 9 * w];
        // cand[c * nx + x]: candidate c of voxel x; 13..16 stay i32::MAX.
        let mut cand = vec![i32::MAX; 16 * nx];
        for y in 0..ny {
            for (si, s) in slices.iter().enumerate() {
                for dy in -1..=1i64 {
                    let j = (y + dy).clamp(0, ny - 1) as usize;
                    let row = &s[j * nx..(j + 1) * nx];
                    let k = si * 3 + (dy + 1) as usize;
                    let c = &mut cols[k * w..(k + 1) * w];
                    for (o, &v) in c[1..=nx].iter_mut().zip(row) {
                        *o = key(v);
                    }
                    c[0] = c[1];
                    c[nx + 1] = c[nx];
                }
            }
            for &(a, b) in SORT9.iter() {
                compare_exchange(&mut cols, w, a, b);
            }
            // Row sorts of each rank, keeping the 13 candidates.
            for i in 0..9 {
                let c = &cols[i * w..(i + 1) * w];
                let (a, rest) = (&c[..nx], &c[1..]);
                let (b, cc) = (&rest[..nx], &rest[1..=nx]);
                let lo_slot = (5..=8).contains(&i).then(|| i - 5);
                let mid_slot = (2..=6).contains(&i).then(|| 4 + i - 2);
                let hi_slot = (0..=3).contains(&i).then(|| 9 + i);
                if let Some(t) = lo_slot {
                    let dst = &mut cand[t * nx..(t + 1) * nx];
                    for x in 0..nx {
                        dst[x] = a[x].min(b[x]).min(cc[x]);
                    }
                }
                if let Some(t) = mid_slot {
                    let dst = &mut cand[t * nx..(t + 1) * nx];
                    for x in 0..nx {
                        let (p, q) = (a[x].min(b[x]), a[x].max(b[x]));
                        dst[x] = p.max(q.min(cc[x]));
                    }
                }
                if let Some(t) = hi_slot {
                    let dst = &mut cand[t * nx..(t + 1) * nx];
                    for x in 0..nx {
                        dst[x] = a[x].max(b[x]).max(cc[x]);
                    }
                }
            }
            for &(a, b) in &self.net {
                compare_exchange(&mut cand, nx, a, b);
            }
            let o = &mut out[y as usize * nx..(y as usize + 1) * nx];
            for (v, &k) in o.iter_mut().zip(&cand[6 * nx..7 * nx]) {
                *v = unkey(k);
            }
        }
    }
}

/// The sample's place in [`f32::total_cmp`]'s order as an `i32` (so min
/// and max vectorise): negative values have their magnitude bits flipped.
#[inline]
fn key(v: f32) -> i32 {
    let b = v.to_bits() as i32;
    b ^ (((b >> 31) as u32) >> 1) as i32
}

/// The sample of a [`key`] (the map is its own inverse).
#[inline]
fn unkey(k: i32) -> f32 {
    f32::from_bits((k ^ (((k >> 31) as u32) >> 1) as i32) as u32)
}

/// Rows `a < b` (each `w` long) of `v` become their element-wise min and
/// max.
#[inline]
fn compare_exchange(v: &mut [i32], w: usize, a: usize, b: usize) {
    let (lo, hi) = v.split_at_mut(b * w);
    let ra = &mut lo[a * w..(a + 1) * w];
    let rb = &mut hi[..w];
    for (p, q) in ra.iter_mut().zip(rb.iter_mut()) {
        let (m, n) = ((*p).min(*q), (*p).max(*q));
        *p = m;
        *q = n;
    }
}

/// A sorting network for 9 (25 comparators): sort the three triples, then
/// the three "columns", then fix the middle.
const SORT9: [(usize, usize); 25] = [
    (0, 1),
    (3, 4),
    (6, 7),
    (1, 2),
    (4, 5),
    (7, 8),
    (0, 1),
    (3, 4),
    (6, 7),
    (0, 3),
    (3, 6),
    (0, 3),
    (1, 4),
    (4, 7),
    (1, 4),
    (2, 5),
    (5, 8),
    (2, 5),
    (1, 3),
    (5, 7),
    (2, 6),
    (4, 6),
    (2, 4),
    (2, 3),
    (5, 6),
];

/// Batcher's odd-even merge sort for `n` (a power of two) wires, keeping
/// only the comparators that wire `out` depends on: a network whose wire
/// `out` ends as the input's element of rank `out`.
fn select_network(n: usize, out: usize) -> Vec<(usize, usize)> {
    let mut all = Vec::new();
    let mut p = 1;
    while p < n {
        let mut k = p;
        while k >= 1 {
            for j in (k % p..n - k).step_by(2 * k) {
                for i in 0..k.min(n - j - k) {
                    if (i + j) / (2 * p) == (i + j + k) / (2 * p) {
                        all.push((i + j, i + j + k));
                    }
                }
            }
            k /= 2;
        }
        p *= 2;
    }
    let mut live = vec![false; n];
    live[out] = true;
    let mut kept = Vec::new();
    for &(a, b) in all.iter().rev() {
        if live[a] || live[b] {
            live[a] = true;
            live[b] = true;
            kept.push((a, b));
        }
    }
    kept.reverse();
    kept
}

impl Stage for Median {
    fn name(&self) -> &str {
        "median"
    }

    fn output(&self) -> Grid {
        self.grid
    }

    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        let nz = self.grid.dims.z;
        let lo = zs.start.saturating_sub(self.r).min(nz);
        let hi = zs.end.saturating_add(self.r).min(nz).max(lo);
        lo..hi
    }

    fn window(&self) -> u64 {
        (2 * self.r + 1).min(self.grid.dims.z)
    }

    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        if self.r == 1 {
            self.run_r1(z, input, out);
        } else {
            self.run_general(z, input, out);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::{Dims, Geometry};

    fn grid(d: [u64; 3]) -> Grid {
        Grid {
            dims: Dims::new(d[0], d[1], d[2]).unwrap(),
            spacing: [0.5, 0.7, 2.0],
            geometry: Geometry::IDENTITY,
        }
    }

    /// Sorts every 0/1 input (the 0-1 principle).
    fn sorts_all_01(net: &[(usize, usize)], n: usize, check: impl Fn(&[u8]) -> bool) -> bool {
        (0u32..1 << n).all(|bits| {
            let mut v: Vec<u8> = (0..n).map(|i| ((bits >> i) & 1) as u8).collect();
            for &(a, b) in net {
                if v[a] > v[b] {
                    v.swap(a, b);
                }
            }
            check(&v)
        })
    }

    #[test]
    fn the_networks_sort_and_select() {
        assert!(sorts_all_01(&SORT9, 9, |v| v
            .windows(2)
            .all(|w| w[0] <= w[1])));
        // Wire 6 of 16 is the rank-6 element; with wires 13..16 fixed at
        // the top (1), it is the median of 13.
        let net = select_network(16, 6);
        assert!((0u32..1 << 16).all(|bits| {
            let mut v: Vec<u8> = (0..16).map(|i| ((bits >> i) & 1) as u8).collect();
            let mut s = v.clone();
            s.sort();
            for &(a, b) in &net {
                if v[a] > v[b] {
                    v.swap(a, b);
                }
            }
            v[6] == s[6]
        }));
    }

    #[test]
    fn keys_order_as_total_cmp() {
        let vals = [
            f32::NEG_INFINITY,
            -1e30,
            -1.0,
            -0.0,
            0.0,
            1e-40,
            1.0,
            f32::INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        for &a in &vals {
            assert_eq!(unkey(key(a)).to_bits(), a.to_bits());
            for &b in &vals {
                assert_eq!(key(a).cmp(&key(b)), a.total_cmp(&b), "{a} {b}");
            }
        }
    }

    /// Brute force: sort the (2R+1)³ clamped neighbours.
    fn brute(v: &[f32], d: [u64; 3], r: i64, x: i64, y: i64, z: i64) -> f32 {
        let c = |p: i64, n: u64| p.clamp(0, n as i64 - 1) as u64;
        let mut n = Vec::new();
        for dz in -r..=r {
            for dy in -r..=r {
                for dx in -r..=r {
                    let (i, j, k) = (c(x + dx, d[0]), c(y + dy, d[1]), c(z + dz, d[2]));
                    n.push(v[(i + d[0] * (j + d[1] * k)) as usize]);
                }
            }
        }
        n.sort_by(|a, b| a.total_cmp(b));
        n[n.len() / 2]
    }

    fn volume(d: [u64; 3], seed: u64, range: i32) -> Vec<f32> {
        let mut rng = fastrand::Rng::with_seed(seed);
        (0..d[0] * d[1] * d[2])
            .map(|_| rng.i32(-range..=range) as f32)
            .collect()
    }

    fn slab<'a>(v: &'a [f32], d: [u64; 3]) -> Slab<'a> {
        let n = (d[0] * d[1]) as usize;
        Slab::new(
            0,
            Dims::new(d[0], d[1], d[2]).unwrap(),
            v.chunks(n).collect(),
        )
    }

    #[test]
    fn equals_brute_force_including_borders() {
        for (r, d, range) in [
            (1, [9u64, 7, 6], 5),
            (1, [1, 1, 1], 5),
            (1, [2, 1, 3], 5),
            (1, [17, 5, 4], 1000),
            (2, [8, 7, 6], 5),
            (2, [11, 3, 2], 1000),
        ] {
            let v = volume(d, 7 + r, range);
            let m = Median::new(grid(d), r).unwrap();
            let s = slab(&v, d);
            let n = (d[0] * d[1]) as usize;
            for z in 0..d[2] {
                let mut out = vec![0.0; n];
                m.run(z, &s, &mut out).unwrap();
                for y in 0..d[1] {
                    for x in 0..d[0] {
                        let want = brute(&v, d, r as i64, x as i64, y as i64, z as i64);
                        let got = out[(x + d[0] * y) as usize];
                        assert_eq!(got.to_bits(), want.to_bits(), "r {r} {d:?} at {x},{y},{z}");
                    }
                }
            }
        }
    }

    #[test]
    fn r1_fast_path_equals_the_general_path_with_ties_nan_and_zeros() {
        let d = [37u64, 11, 7];
        let mut v = volume(d, 3, 3);
        let mut rng = fastrand::Rng::with_seed(11);
        for x in v.iter_mut() {
            match rng.u8(0..20) {
                0 => *x = f32::NAN,
                1 => *x = -0.0,
                2 => *x = f32::NEG_INFINITY,
                3 => *x = -f32::NAN,
                _ => {}
            }
        }
        let m = Median::new(grid(d), 1).unwrap();
        let s = slab(&v, d);
        let n = (d[0] * d[1]) as usize;
        for z in 0..d[2] {
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            m.run(z, &s, &mut a).unwrap();
            m.run_general(z, &s, &mut b);
            let a: Vec<u32> = a.iter().map(|v| v.to_bits()).collect();
            let b: Vec<u32> = b.iter().map(|v| v.to_bits()).collect();
            assert_eq!(a, b, "slice {z}");
        }
    }

    #[test]
    fn refuses_zero_huge_and_over_budget() {
        let e = Median::new(grid([4, 4, 4]), 0).err().unwrap();
        assert!(e.contains("at least 1"), "{e}");
        let e = Median::new(grid([4, 4, 4]), 51).err().unwrap();
        assert!(e.contains("at most 50"), "{e}");
        let e = Median::new(grid([16384, 16384, 400]), 2).err().unwrap();
        assert!(
            e.starts_with("--median 2: a window of 5 slices of 16384x16384 f32")
                && e.contains("1 GiB slab budget"),
            "{e}"
        );
        let m = Median::new(grid([4, 4, 10]), 2).unwrap();
        assert_eq!(m.needs(0..1), 0..3);
        assert_eq!(m.needs(4..6), 2..8);
        assert_eq!(m.needs(9..10), 7..10);
        assert_eq!(m.window(), 5);
    }
}
