//! Ambient occlusion: the share of ambient light that reaches a shaded
//! sample, the mean transmittance over directions around its normal up to
//! a radius `R`, through the classified volume's extinction (volumes
//! occlude by how much light they let through, not as opaque walls).
//!
//! Two ways, both reading the frame's [`OcclusionGrid`]:
//! - **rays** (`--ao N[:R]`): `N` directions per shaded sample,
//!   cosine-weighted over the hemisphere around the normal (the whole
//!   sphere where the gradient is too short for one): a [`Spiral`]
//!   rotated and offset by the hashed per-pixel sampler, so an image is
//!   the same for any thread count or tile size;
//! - **field** (`--ao-field K[:R]`): transmittance toward `K` fixed
//!   directions (a spherical Fibonacci set) precomputed at the points of a
//!   coarser grid ([`DEFAULT_AO_FIELD_CELL`] voxels apart unless
//!   `--ao-field-cell` says otherwise), after the visibility
//!   fields of Mortensen et al. Each point keeps the cosine-weighted
//!   occlusion as a function of the normal, projected on spherical
//!   harmonics up to order 2 (the `K` directions are the quadrature; the
//!   mean over them is kept exactly, so a uniform neighbourhood is exact):
//!   nine numbers per point whatever `K`, read trilinearly, so a lookup
//!   costs about as much as one occlusion-grid read.
//!
//! The ambient term of the lighting is multiplied by the occlusion; lights
//! are not (their shadows are the shadow methods' job).

use super::occlusion_grid::{Intervals, Lattice, OcclusionGrid, RayBatch, OCCLUSION_CELL};
use super::RayEffects;
use crate::error::RenderError;
use crate::lanes::Lanes3;
use crate::sampler::HashSampler;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;

/// Voxels between the points of a precomputed AO field, by default.
pub const DEFAULT_AO_FIELD_CELL: u32 = 8;

/// The most voxels between the points of a field (`--ao-field-cell`).
pub const MAX_AO_FIELD_CELL: u32 = 64;

/// The most directions per shaded sample (`--ao N`).
pub const MAX_AO_RAYS: u32 = 1024;

/// The most directions of a precomputed field (`--ao-field K`).
pub const MAX_AO_FIELD_DIRECTIONS: u32 = 256;

/// The `N` directions of one shaded sample: a golden-angle spiral on the
/// unit disk (point `i` at squared radius `(i + u)/N`, angle
/// `i·golden + φ`), lifted onto the hemisphere around the normal (Malley's
/// method: cosine-weighted), or its counterpart on the sphere (height
/// `1 − 2(i + u)/N`). The rotation `φ` and offset `u` come from the
/// pixel's hashed sampler, so every direction is distributed as the
/// method asks while the set stays stratified (less noise than
/// independent directions), and a sample costs one sine and cosine.
#[derive(Clone, Debug)]
pub struct Spiral {
    /// Directions.
    n: usize,
    /// Per run of eight directions: cos and sin of `i·golden` per lane
    /// (the last run padded with zeros).
    turns: Vec<([f32; 8], [f32; 8])>,
}

impl Spiral {
    /// The spiral of `n` directions.
    pub fn new(n: u32) -> Spiral {
        let golden = PI * (3.0 - 5f32.sqrt());
        let n = n as usize;
        Spiral {
            n,
            turns: (0..n.div_ceil(8))
                .map(|k| {
                    let mut run = ([0f32; 8], [0f32; 8]);
                    for l in 0..8.min(n - 8 * k) {
                        let (s, c) = (golden * (8 * k + l) as f32).sin_cos();
                        (run.0[l], run.1[l]) = (c, s);
                    }
                    run
                })
                .collect(),
        }
    }

    /// Directions per sample.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether it has none.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Call `f` with each unit direction for normal `n` (`None`: the
    /// sphere), rotated by `2π·u_rot` and offset by `u_off` (both in
    /// `[0, 1)`).
    #[inline]
    pub fn directions(&self, n: Option<Vec3>, u_rot: f32, u_off: f32, mut f: impl FnMut(Vec3)) {
        self.directions8(n, u_rot, u_off, |d, count| {
            (0..count).for_each(|i| f(Vec3::new(d[0][i], d[1][i], d[2][i])));
        });
    }

    /// [`Spiral::directions`] in runs of eight: `f` receives each run's
    /// directions (per component, then per lane) and how many lanes of it
    /// are directions (eight but in the last run). Every lane does the same
    /// operations, so the loops run in vector registers.
    #[inline]
    pub fn directions8(
        &self,
        n: Option<Vec3>,
        u_rot: f32,
        u_off: f32,
        mut f: impl FnMut(&Lanes3, usize),
    ) {
        let (s0, c0) = (2.0 * PI * u_rot).sin_cos();
        let inv = 1.0 / self.n.max(1) as f32;
        let frame = n.map(|n| (n, n.any_orthonormal_pair()));
        for (k, (cos, sin)) in self.turns.iter().enumerate() {
            let mut c = [0f32; 8];
            let mut s = [0f32; 8];
            let mut q = [0f32; 8];
            for l in 0..8 {
                (c[l], s[l]) = (cos[l] * c0 - sin[l] * s0, sin[l] * c0 + cos[l] * s0);
                q[l] = (((8 * k + l) as f32 + u_off) * inv).min(1.0);
            }
            let mut d = [[0f32; 8]; 3];
            match frame {
                Some((n, (t, b))) => {
                    for l in 0..8 {
                        let r = q[l].sqrt();
                        let z = (1.0 - q[l]).max(0.0).sqrt();
                        let (rc, rs) = (r * c[l], r * s[l]);
                        for a in 0..3 {
                            d[a][l] = t[a] * rc + b[a] * rs + n[a] * z;
                        }
                    }
                }
                None => {
                    for l in 0..8 {
                        let z = 1.0 - 2.0 * q[l];
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        (d[0][l], d[1][l], d[2][l]) = (r * c[l], r * s[l], z);
                    }
                }
            }
            f(&d, 8.min(self.n - 8 * k));
        }
    }
}

/// `k` directions spread evenly over the sphere (spherical Fibonacci).
pub fn fibonacci_directions(k: u32) -> Vec<Vec3> {
    let golden = PI * (3.0 - 5f32.sqrt());
    (0..k)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as f32 / k as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (s, c) = (golden * i as f32).sin_cos();
            Vec3::new(r * c, r * s, z)
        })
        .collect()
}

/// Spherical-harmonic coefficients a field point keeps.
const SH: usize = 9;

/// The real spherical harmonics of orders 1 and 2 at unit `d`, without
/// their normalisation constants (folded into the stored coefficients).
#[inline(always)]
fn sh_shape(d: Vec3) -> [f32; SH - 1] {
    [
        d.y,
        d.z,
        d.x,
        d.x * d.y,
        d.y * d.z,
        3.0 * d.z * d.z - 1.0,
        d.x * d.z,
        d.x * d.x - d.y * d.y,
    ]
}

/// Normalisation constants of the harmonics in [`sh_shape`] order.
const SH_NORM: [f32; SH - 1] = [
    0.488_602_5,
    0.488_602_5,
    0.488_602_5,
    1.092_548_4,
    1.092_548_4,
    0.315_391_57,
    1.092_548_4,
    0.546_274_2,
];

/// A field point's first eight coefficients, 32-byte aligned.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Head([f32; SH - 1]);

/// The cosine-weighted occlusion around every normal, precomputed at the
/// points of a coarse grid from the transmittance toward `K` directions.
#[derive(Clone, Debug)]
pub struct AoField {
    k: u32,
    cell: usize,
    /// Where its points are.
    lattice: Lattice,
    /// Per point (x fastest): the mean transmittance, then the order-1
    /// and order-2 terms, scaled so that the occlusion for unit normal
    /// `n` is `c[0] + Σ c[i]·shape_i(n)`; the first eight here, each
    /// point's in one aligned half cache line (a lane lookup reads a
    /// corner in one load)...
    head: Vec<Head>,
    /// ... and the last one.
    tail: Vec<f32>,
    /// Whether lookups may run eight at a time in AVX2 lanes: this CPU
    /// has AVX2 and every point's index fits an `i32`.
    lanes: bool,
    /// Seconds the build took.
    pub build_s: f64,
    /// Grid reads the build took.
    pub samples: u64,
}

impl AoField {
    /// Bytes a field over `dims` with points `cell` voxels apart takes.
    pub fn bytes_for(dims: [usize; 3], cell: u32) -> Option<u64> {
        let cell = cell.max(1) as usize;
        dims.iter().try_fold((SH * 4) as u64, |acc, &n| {
            acc.checked_mul((n.saturating_sub(1).div_ceil(cell) + 1) as u64)
        })
    }

    /// The field's memory, bytes.
    pub fn bytes(&self) -> u64 {
        (self.head.len() * SH * 4) as u64
    }

    /// The number of directions it was built from.
    pub fn directions(&self) -> u32 {
        self.k
    }

    /// Voxels between its points.
    pub fn cell(&self) -> u32 {
        self.cell as u32
    }

    /// Build the field from `k` directions at points `cell` voxels apart
    /// over a volume of `dims` voxels at `spacing`, marching `grid` with
    /// `intervals` from each point, on all threads. Refuses a field past
    /// `budget` bytes.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        grid: &OcclusionGrid,
        intervals: &Intervals,
        dims: [usize; 3],
        spacing: [f32; 3],
        k: u32,
        cell: u32,
        budget: u64,
    ) -> Result<AoField, RenderError> {
        let start = Instant::now();
        let bytes = AoField::bytes_for(dims, cell).unwrap_or(u64::MAX);
        if bytes > budget {
            return Err(RenderError::Setting(format!(
                "an AO field with points every {cell} voxels would take {bytes} bytes, more than the budget of {budget}: use a larger --ao-field-cell, or --ao N"
            )));
        }
        let cell = cell.max(1) as usize;
        let g = dims.map(|n| n.saturating_sub(1).div_ceil(cell) + 1);
        let dirs = fibonacci_directions(k.max(1));
        let shapes: Vec<[f32; SH - 1]> = dirs.iter().map(|&d| sh_shape(d)).collect();
        let hi = Vec3::from(std::array::from_fn::<f32, 3, _>(|a| {
            dims[a].saturating_sub(1) as f32 * spacing[a]
        }));
        let points = g[0] * g[1] * g[2];
        let no_room =
            || RenderError::Setting(format!("cannot allocate an AO field of {bytes} bytes"));
        let mut head: Vec<Head> = Vec::new();
        head.try_reserve_exact(points).map_err(|_| no_room())?;
        head.resize(points, Head::default());
        let mut tail: Vec<f32> = Vec::new();
        tail.try_reserve_exact(points).map_err(|_| no_room())?;
        tail.resize(points, 0.0);
        // The projection's quadrature weight (4π/K) times the clamped
        // cosine's convolution factors over π (2/3 for order 1, 1/4 for
        // order 2) times each harmonic's constant twice (projection and
        // evaluation).
        let w = 4.0 * PI / dirs.len() as f32;
        let scale: [f32; SH - 1] = std::array::from_fn(|i| {
            let band = if i < 3 { 2.0 / 3.0 } else { 0.25 };
            w * band * SH_NORM[i] * SH_NORM[i]
        });
        let samples: u64 = head
            .par_chunks_mut(g[0] * g[1])
            .zip(tail.par_chunks_mut(g[0] * g[1]))
            .enumerate()
            .map(|(z, (heads, tails))| {
                let mut taken = 0u64;
                let mut t = vec![0.0f32; dirs.len()];
                for (i, (h, last)) in heads.iter_mut().zip(tails.iter_mut()).enumerate() {
                    let voxel = Vec3::new(
                        ((i % g[0]) * cell).min(dims[0].saturating_sub(1)) as f32,
                        ((i / g[0]) * cell).min(dims[1].saturating_sub(1)) as f32,
                        (z * cell).min(dims[2].saturating_sub(1)) as f32,
                    );
                    let p = voxel * Vec3::from(spacing);
                    let mut k = 0;
                    let mut put = |v: f32| {
                        t[k] = v;
                        k += 1;
                    };
                    let mut batch = RayBatch::new(intervals, grid, p, hi);
                    for &d in &dirs {
                        batch.push(d, &mut put);
                    }
                    batch.flush(&mut put);
                    taken += batch.taken;
                    let mean = t.iter().sum::<f32>() / t.len() as f32;
                    let mut c = [0.0f32; SH];
                    c[0] = mean;
                    for (tk, shape) in t.iter().zip(&shapes) {
                        let dev = tk - mean;
                        if dev != 0.0 {
                            for j in 0..SH - 1 {
                                c[j + 1] += dev * shape[j];
                            }
                        }
                    }
                    for j in 0..SH - 1 {
                        c[j + 1] *= scale[j];
                    }
                    h.0.copy_from_slice(&c[..SH - 1]);
                    *last = c[SH - 1];
                }
                taken
            })
            .sum();
        let lanes = volcore::lanes::avx2_available() && points <= i32::MAX as usize;
        Ok(AoField {
            k,
            cell,
            lattice: Lattice::new(g, spacing, cell as f32),
            head,
            tail,
            lanes,
            build_s: start.elapsed().as_secs_f64(),
            samples,
        })
    }

    /// The occlusion at world point `p` for unit normal `n` (`None`: the
    /// mean over all directions), from the coefficients read trilinearly;
    /// clamped to `[0, 1]` (a truncated expansion can ring past them).
    #[inline]
    pub fn occlusion(&self, p: Vec3, n: Option<Vec3>) -> f32 {
        let (at, f) = self.lattice.corners(p);
        let v = at.map(|i| -> [f32; SH] {
            let h = &self.head[i].0;
            std::array::from_fn(|j| if j < SH - 1 { h[j] } else { self.tail[i] })
        });
        // `trilinear` of every coefficient at once: the same lerps, row
        // by row.
        let lerp = |a: &[f32; SH], b: &[f32; SH], t: f32| -> [f32; SH] {
            std::array::from_fn(|j| a[j] + (b[j] - a[j]) * t)
        };
        let c00 = lerp(&v[0], &v[1], f.x);
        let c10 = lerp(&v[2], &v[3], f.x);
        let c01 = lerp(&v[4], &v[5], f.x);
        let c11 = lerp(&v[6], &v[7], f.x);
        let c = lerp(&lerp(&c00, &c10, f.y), &lerp(&c01, &c11, f.y), f.z);
        let mut ao = c[0];
        if let Some(n) = n {
            let shape = sh_shape(n);
            for (j, s) in shape.iter().enumerate() {
                ao += c[j + 1] * s;
            }
        }
        ao.clamp(0.0, 1.0)
    }

    /// [`AoField::occlusion`] at eight world points `p` (per component,
    /// then per lane) with unit normals `n` in the lanes set in `lit` (the
    /// mean over all directions in the others), read in AVX2 lanes, bit
    /// for bit, in the lanes set in `want` (the others' values mean
    /// nothing); lit lanes' points are first moved `offset` along their
    /// normals (`p + n * offset`, as [`AoSource::occlusion`] moves them).
    /// `None` where the field cannot be read in lanes.
    #[inline]
    pub fn occlusion8(
        &self,
        p: &Lanes3,
        n: &Lanes3,
        offset: f32,
        lit: u8,
        want: u8,
    ) -> Option<[f32; 8]> {
        if !self.lanes {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `lanes` is set only where AVX2 was found and every
            // point's index fits an i32.
            Some(unsafe { avx2::occlusion8(self, p, n, offset, lit, want) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (p, n, offset, lit, want);
            None
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::super::occlusion_grid::avx2::{corners8, trilinear8};
    use super::{AoField, Lanes3, SH};
    use std::arch::x86_64::*;

    /// Rows `r` (eight values each) as columns: lane `i` of the result's
    /// `j` is lane `j` of `r[i]`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpackhi_ps(r[0], r[1]);
        let t2 = _mm256_unpacklo_ps(r[2], r[3]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        let t4 = _mm256_unpacklo_ps(r[4], r[5]);
        let t5 = _mm256_unpackhi_ps(r[4], r[5]);
        let t6 = _mm256_unpacklo_ps(r[6], r[7]);
        let t7 = _mm256_unpackhi_ps(r[6], r[7]);
        let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
        let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
        let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
        let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
        let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
        let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
        let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
        let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
        [
            _mm256_permute2f128_ps::<0x20>(u0, u4),
            _mm256_permute2f128_ps::<0x20>(u1, u5),
            _mm256_permute2f128_ps::<0x20>(u2, u6),
            _mm256_permute2f128_ps::<0x20>(u3, u7),
            _mm256_permute2f128_ps::<0x31>(u0, u4),
            _mm256_permute2f128_ps::<0x31>(u1, u5),
            _mm256_permute2f128_ps::<0x31>(u2, u6),
            _mm256_permute2f128_ps::<0x31>(u3, u7),
        ]
    }

    /// See [`AoField::occlusion8`].
    ///
    /// Each wanted lane reads its eight corners' first eight coefficients
    /// with one aligned load apiece and blends them across the vector (the
    /// scalar lookup's lerps, coefficient by coefficient); the blends are
    /// turned back into lanes for the harmonics' sum, and the ninth
    /// coefficient is gathered. Eight gathers a lookup where gathering
    /// every coefficient took 72.
    ///
    /// # Safety
    /// AVX2; every point's index fits an i32.
    #[target_feature(enable = "avx2")]
    pub unsafe fn occlusion8(
        f: &AoField,
        p: &Lanes3,
        n: &Lanes3,
        offset: f32,
        lit: u8,
        want: u8,
    ) -> [f32; 8] {
        let load = |c: &[f32; 8]| _mm256_loadu_ps(c.as_ptr());
        let lanes = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let lit = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(lit as i32), lanes),
            lanes,
        ));
        let [x, y, z] = n.each_ref().map(load);
        // `p + n * offset` in lit lanes, as one by one.
        let by = _mm256_set1_ps(offset);
        let origin = [(0, x), (1, y), (2, z)].map(|(a, n)| {
            let p = load(&p[a]);
            _mm256_blendv_ps(p, _mm256_add_ps(p, _mm256_mul_ps(n, by)), lit)
        });
        let (at, w) = corners8(&f.lattice, &origin);
        let mut corner = [[0i32; 8]; 8];
        for (c, i) in corner.iter_mut().zip(&at) {
            _mm256_storeu_si256(c.as_mut_ptr().cast(), *i);
        }
        let mut weight = [[0f32; 8]; 3];
        for (c, v) in weight.iter_mut().zip(&w) {
            _mm256_storeu_ps(c.as_mut_ptr(), *v);
        }
        let head = f.head.as_ptr().cast::<f32>();
        let mut rows = [_mm256_setzero_ps(); 8];
        for (lane, row) in rows.iter_mut().enumerate() {
            if want >> lane & 1 == 0 {
                continue;
            }
            // The corners' indices are in bounds (`corners8`); each point's
            // head is 32-byte aligned.
            let v = corner.map(|c| _mm256_load_ps(head.add(c[lane] as usize * (SH - 1))));
            *row = trilinear8(v, weight.map(|w| _mm256_set1_ps(w[lane])));
        }
        let c = transpose8(rows);
        let last = trilinear8(at.map(|i| _mm256_i32gather_ps::<4>(f.tail.as_ptr(), i)), w);
        let mean = c[0];
        // `sh_shape`, the same operations.
        let mul = |a, b| _mm256_mul_ps(a, b);
        let shape = [
            y,
            z,
            x,
            mul(x, y),
            mul(y, z),
            _mm256_sub_ps(mul(mul(_mm256_set1_ps(3.0), z), z), _mm256_set1_ps(1.0)),
            mul(x, z),
            _mm256_sub_ps(mul(x, x), mul(y, y)),
        ];
        let mut ao = mean;
        for (j, s) in shape.into_iter().enumerate() {
            let cj = if j + 1 < SH - 1 { c[j + 1] } else { last };
            ao = _mm256_add_ps(ao, mul(cj, s));
        }
        let ao = _mm256_blendv_ps(mean, ao, lit);
        // `clamp(0, 1)`: NaN stays NaN.
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let ao = _mm256_blendv_ps(ao, zero, _mm256_cmp_ps::<_CMP_LT_OQ>(ao, zero));
        let ao = _mm256_blendv_ps(ao, one, _mm256_cmp_ps::<_CMP_GT_OQ>(ao, one));
        let mut out = [0f32; 8];
        _mm256_storeu_ps(out.as_mut_ptr(), ao);
        out
    }
}

/// Where a frame's occlusion comes from.
#[derive(Clone, Copy, Debug)]
pub enum AoLookup<'a> {
    /// `n` sampled directions per shaded sample, marched with `intervals`.
    Rays {
        /// The directions per shaded sample.
        spiral: &'a Spiral,
        /// The march.
        intervals: &'a Intervals,
        /// The directions' sampler.
        sampler: HashSampler,
    },
    /// The precomputed field.
    Field(&'a AoField),
}

/// Ambient occlusion of a frame: the grid, the lookup, and where rays
/// start (moved off the shaded sample along the normal, so a surface does
/// not occlude itself through the grid's blur).
#[derive(Clone, Copy, Debug)]
pub struct AoSource<'a> {
    grid: &'a OcclusionGrid,
    lookup: AoLookup<'a>,
    /// The far corner of the volume's box, world units.
    hi: Vec3,
    /// World distance along the normal at which occlusion is looked up.
    offset: f32,
}

impl<'a> AoSource<'a> {
    /// Occlusion through `grid` by `lookup` in the box `[0, hi]`, looked
    /// up `offset` world units off the shaded sample along its normal.
    pub fn new(grid: &'a OcclusionGrid, lookup: AoLookup<'a>, hi: Vec3, offset: f32) -> Self {
        AoSource {
            grid,
            lookup,
            hi,
            offset,
        }
    }

    /// The offset for a frame: `cells` occlusion-grid cells at the
    /// smallest voxel spacing.
    pub fn offset_for(cells: f32, min_spacing: f32) -> f32 {
        cells * OCCLUSION_CELL as f32 * min_spacing
    }

    /// The occlusion at world point `p` with unit normal `n` (`None`: no
    /// normal, the whole sphere counts), for shaded sample `index` of pixel
    /// `pixel`; counts rays and samples into `fx`. In `[0, 1]`.
    #[inline]
    pub fn occlusion(
        &self,
        p: Vec3,
        n: Option<Vec3>,
        pixel: [u32; 2],
        index: u64,
        fx: &mut RayEffects,
    ) -> f32 {
        let origin = match n {
            Some(n) => p + n * self.offset,
            None => p,
        };
        match self.lookup {
            AoLookup::Field(field) => field.occlusion(origin, n),
            AoLookup::Rays {
                spiral,
                intervals,
                sampler,
            } => {
                let (u_rot, u_off) = sampler.pixel(pixel[0], pixel[1], index).next_2d();
                let mut sum = 0.0f32;
                let mut add = |t: f32| sum += t;
                let mut batch = RayBatch::new(intervals, self.grid, origin, self.hi);
                spiral.directions8(n, u_rot, u_off, |d, count| batch.push8(d, count, &mut add));
                batch.flush(&mut add);
                fx.ao_samples += batch.taken;
                fx.ao_rays += spiral.len() as u32;
                sum / spiral.len().max(1) as f32
            }
        }
    }

    /// [`AoSource::occlusion`] at eight world points `p` (per component,
    /// then per lane) with unit normals `n` in the lanes set in `lit` (no
    /// normal in the others), looked up in the field in lanes, bit for
    /// bit, in the lanes set in `want` (the others' values mean nothing);
    /// `None` for sampled directions, or where the field cannot be read in
    /// lanes.
    #[inline]
    pub fn field8(&self, p: &Lanes3, n: &Lanes3, lit: u8, want: u8) -> Option<[f32; 8]> {
        let AoLookup::Field(field) = self.lookup else {
            return None;
        };
        field.occlusion8(p, n, self.offset, lit, want)
    }
}

/// The outward unit normal for ambient occlusion from world gradient
/// `grad` (toward falling values), scaled by its largest component first
/// so tiny and huge gradients normalise alike; `None` when it has no
/// direction.
#[inline]
pub fn outward_normal(grad: Vec3) -> Option<Vec3> {
    let m = grad.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let n = -(grad / m).normalize_or_zero();
    (n != Vec3::ZERO).then_some(n)
}

/// [`outward_normal`] of eight gradients (per component, then per lane):
/// the normals (zero where there is none) and the lanes that have one, bit
/// for bit.
#[inline]
pub fn outward_normals8(grad: &Lanes3) -> (Lanes3, u8) {
    #[cfg(target_arch = "x86_64")]
    if volcore::lanes::avx2_available() {
        // SAFETY: AVX2 was found.
        return unsafe { normals_avx2::outward_normals8(grad) };
    }
    let mut out = [[0.0; 8]; 3];
    let mut has = 0u8;
    for i in 0..8 {
        if let Some(n) = outward_normal(Vec3::new(grad[0][i], grad[1][i], grad[2][i])) {
            has |= 1 << i;
            for (a, o) in out.iter_mut().enumerate() {
                o[i] = n[a];
            }
        }
    }
    (out, has)
}

#[cfg(target_arch = "x86_64")]
mod normals_avx2 {
    use crate::lanes::Lanes3;
    use std::arch::x86_64::*;

    /// See [`super::outward_normals8`]: `outward_normal`'s operations in
    /// lanes (MAXPS picks as `max_element` does, NaN included).
    ///
    /// # Safety
    /// AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn outward_normals8(grad: &Lanes3) -> (Lanes3, u8) {
        let [x, y, z] = grad.each_ref().map(|c| _mm256_loadu_ps(c.as_ptr()));
        let sign = _mm256_set1_ps(-0.0);
        let abs = |v| _mm256_andnot_ps(sign, v);
        let zero = _mm256_setzero_ps();
        let inf = _mm256_set1_ps(f32::INFINITY);
        let m = _mm256_max_ps(abs(x), _mm256_max_ps(abs(y), abs(z)));
        // `m > 0 && m.is_finite()`.
        let scaled = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(m, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(m, inf),
        );
        let q = [x, y, z].map(|c| _mm256_div_ps(c, m));
        let mul = |a, b| _mm256_mul_ps(a, b);
        let dot = _mm256_add_ps(
            _mm256_add_ps(mul(q[0], q[0]), mul(q[1], q[1])),
            mul(q[2], q[2]),
        );
        let rcp = _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(dot));
        // `normalize_or_zero`: `rcp.is_finite() && rcp > 0`.
        let unit = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(rcp, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(rcp, inf),
        );
        let ok = _mm256_and_ps(scaled, unit);
        let n = q.map(|c| _mm256_and_ps(_mm256_xor_ps(mul(c, rcp), sign), ok));
        // `n != ZERO` (NaN counts as not zero).
        let nonzero = n.iter().fold(zero, |acc, &c| {
            _mm256_or_ps(acc, _mm256_cmp_ps::<_CMP_NEQ_UQ>(c, zero))
        });
        let has = _mm256_movemask_ps(_mm256_and_ps(ok, nonzero)) as u8;
        let mut out = [[0f32; 8]; 3];
        for (o, c) in out.iter_mut().zip(n) {
            _mm256_storeu_ps(o.as_mut_ptr(), c);
        }
        (out, has)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spiral_directions_are_unit_in_their_hemisphere_and_cosine_weighted() {
        let s = HashSampler::new(7);
        for count in [1, 8, 32] {
            let spiral = Spiral::new(count);
            for (i, n) in [Vec3::Z, Vec3::NEG_Z, Vec3::new(0.6, 0.0, -0.8), Vec3::X]
                .into_iter()
                .enumerate()
            {
                let (mut mean_cos, mut mean_dir, mut total) = (0.0f64, Vec3::ZERO, 0.0f64);
                for k in 0..4000 / count as u64 {
                    let (u1, u2) = s.pixel(i as u32, 0, k).next_2d();
                    spiral.directions(Some(n), u1, u2, |d| {
                        assert!((d.length() - 1.0).abs() < 1e-5);
                        assert!(d.dot(n) >= -1e-6);
                        mean_cos += d.dot(n) as f64;
                        total += 1.0;
                    });
                    spiral.directions(None, u1, u2, |d| {
                        assert!((d.length() - 1.0).abs() < 1e-5);
                        mean_dir += d;
                    });
                }
                // Cosine-weighted: the mean cosine is 2/3; the sphere's
                // directions average to nothing.
                assert!(
                    (mean_cos / total - 2.0 / 3.0).abs() < 0.02,
                    "{count}: {mean_cos}"
                );
                assert!(
                    (mean_dir / total as f32).length() < 0.05,
                    "{count}: {mean_dir}"
                );
            }
            // The corners of the unit square stay finite.
            for (u1, u2) in [(0.0, 0.0), (0.99999994, 0.99999994)] {
                spiral.directions(Some(Vec3::Y), u1, u2, |d| assert!(d.is_finite()));
                spiral.directions(None, u1, u2, |d| assert!(d.is_finite()));
            }
        }
    }

    #[test]
    fn fibonacci_directions_cover_the_sphere_evenly() {
        for k in [1, 2, 16, 64] {
            let d = fibonacci_directions(k);
            assert_eq!(d.len(), k as usize);
            assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
            if k >= 16 {
                let mean = d.iter().copied().sum::<Vec3>() / k as f32;
                assert!(mean.length() < 0.05, "{k}: {mean}");
            }
        }
    }
}
