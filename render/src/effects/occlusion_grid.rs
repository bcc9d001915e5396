//! The medium ambient occlusion looks through: the classified volume's
//! extinction, box-filtered onto a coarse grid, and the march of one
//! occlusion ray through it.
//!
//! Ambient occlusion integrates extinction over long distances (a tenth of
//! the volume's diagonal by default) in many directions per shaded sample,
//! so it cannot afford the full-resolution volume: its rays read this grid,
//! one point every [`OCCLUSION_CELL`] voxels holding the mean extinction
//! (optical depth per world unit) of the 2×2×2 samples around it, with
//! intervals that grow with distance from the shaded point (near detail
//! matters more than far). Longer intervals read coarser levels of the
//! grid (each a tent-filtered half of the one below), as a cone's
//! footprint widens: a read then stands for its whole interval, and the
//! coarse levels are small enough to stay in cache. A homogeneous medium
//! stays homogeneous on every level, so its occlusion is exact:
//! `exp(−σ·R)`.

use super::occluder::Occluder;
use super::SHADOW_DEPTH_CUTOFF;
use crate::accel::ClearBoxes;
use crate::error::RenderError;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use volcore::VoxelSource;

/// Voxels between occlusion-grid points along each axis.
pub const OCCLUSION_CELL: usize = 4;

/// Growth of an occlusion ray's intervals from one to the next: each read
/// stands for twice the length of the last, as a cone's footprint doubles
/// (the levels' cells double too).
const INTERVAL_GROWTH: f32 = 2.0;

/// The most intervals one occlusion ray takes (a bound no setting can
/// push: intervals grow geometrically, so this covers any radius).
const MAX_INTERVALS: usize = 64;

/// Levels of the grid: cells of 4, 8 and 16 voxels.
pub const OCCLUSION_LEVELS: usize = 3;

/// A regular lattice of points every `cell` voxels (x fastest), and how
/// a world point falls between them: what the occlusion grid's levels and
/// the AO field share.
#[derive(Clone, Copy, Debug)]
pub struct Lattice {
    /// Points per axis.
    pub g: [usize; 3],
    /// Largest continuous grid coordinate per axis (`g − 1`).
    top: Vec3,
    /// World to grid coordinates, per axis.
    world_to_grid: Vec3,
}

impl Lattice {
    /// `g` points per axis (each at least 1), `cell` voxels of `spacing`
    /// apart.
    pub fn new(g: [usize; 3], spacing: [f32; 3], cell: f32) -> Lattice {
        Lattice {
            g,
            top: Vec3::new((g[0] - 1) as f32, (g[1] - 1) as f32, (g[2] - 1) as f32),
            world_to_grid: Vec3::new(
                1.0 / (spacing[0] * cell),
                1.0 / (spacing[1] * cell),
                1.0 / (spacing[2] * cell),
            ),
        }
    }

    /// The eight points around world point `p` (x fastest, then y, then
    /// z; points past the lattice read its nearest face) and the weights
    /// between them.
    #[inline(always)]
    pub fn corners(&self, p: Vec3) -> ([usize; 8], Vec3) {
        let c = (p * self.world_to_grid).clamp(Vec3::ZERO, self.top);
        let [gx, gy, gz] = self.g;
        // Clamped to be non-negative: truncation is the floor (and one
        // instruction, where `floor` is a libm call on baseline x86-64).
        let i = c.as_uvec3();
        let f = c - i.as_vec3();
        let (ix, iy, iz) = (i.x as usize, i.y as usize, i.z as usize);
        let sx = usize::from(ix + 1 < gx);
        let sy = if iy + 1 < gy { gx } else { 0 };
        let sz = if iz + 1 < gz { gx * gy } else { 0 };
        let b = (iz * gy + iy) * gx + ix;
        let at = [
            b,
            b + sx,
            b + sy,
            b + sy + sx,
            b + sz,
            b + sz + sx,
            b + sz + sy,
            b + sz + sy + sx,
        ];
        (at, f)
    }
}

/// The trilinear blend of corner values `v` (in [`Lattice::corners`]
/// order) at weights `f`, by lerps, so equal corners give their value
/// exactly.
#[inline(always)]
pub fn trilinear(v: [f32; 8], f: Vec3) -> f32 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let c00 = lerp(v[0], v[1], f.x);
    let c10 = lerp(v[2], v[3], f.x);
    let c01 = lerp(v[4], v[5], f.x);
    let c11 = lerp(v[6], v[7], f.x);
    lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z)
}

/// One level of the grid: extinction per world unit at its points.
#[derive(Clone, Debug)]
struct Level {
    /// Where its points are.
    lattice: Lattice,
    /// Extinction per world unit, x fastest, and one zero past the last
    /// point (so reading a point and the next as a pair stays in bounds).
    sigma: Vec<f32>,
}

impl Level {
    /// The level of `g` points per axis `cell` voxels of `spacing` apart,
    /// with extinctions `sigma` (x fastest; padded here).
    fn new(g: [usize; 3], spacing: [f32; 3], cell: f32, mut sigma: Vec<f32>) -> Level {
        sigma.push(0.0);
        Level {
            lattice: Lattice::new(g, spacing, cell),
            sigma,
        }
    }

    /// The next coarser level: every other point, each the tent-filtered
    /// mean (weights 1/4, 1/2, 1/4 per axis) of its neighbourhood.
    fn coarser(&self, spacing: [f32; 3], cell: f32) -> Level {
        let g = self.lattice.g.map(|n| n.div_ceil(2));
        let [fx, fy, fz] = self.lattice.g;
        let points = g[0] * g[1] * g[2];
        // Room for the padding `Level::new` adds.
        let mut sigma = Vec::with_capacity(points + 1);
        sigma.resize(points, 0.0f32);
        sigma
            .par_chunks_mut(g[0] * g[1])
            .enumerate()
            .for_each(|(z, slice)| {
                for (i, out) in slice.iter_mut().enumerate() {
                    let c = [2 * (i % g[0]), 2 * (i / g[0]), 2 * z];
                    let (mut sum, mut weight) = (0.0f32, 0.0f32);
                    for dz in -1i64..=1 {
                        let zz = c[2] as i64 + dz;
                        if zz < 0 || zz >= fz as i64 {
                            continue;
                        }
                        for dy in -1i64..=1 {
                            let yy = c[1] as i64 + dy;
                            if yy < 0 || yy >= fy as i64 {
                                continue;
                            }
                            for dx in -1i64..=1 {
                                let xx = c[0] as i64 + dx;
                                if xx < 0 || xx >= fx as i64 {
                                    continue;
                                }
                                let w = [dx, dy, dz]
                                    .iter()
                                    .map(|&d| if d == 0 { 0.5 } else { 0.25 })
                                    .product::<f32>();
                                let at = (zz as usize * fy + yy as usize) * fx + xx as usize;
                                sum += w * self.sigma[at];
                                weight += w;
                            }
                        }
                    }
                    *out = sum / weight;
                }
            });
        Level::new(g, spacing, cell, sigma)
    }

    /// Extinction at world point `p` (trilinear; points past the grid
    /// read its nearest face).
    #[inline(always)]
    fn sigma(&self, p: Vec3) -> f32 {
        let (at, f) = self.lattice.corners(p);
        trilinear(at.map(|i| self.sigma[i]), f)
    }
}

/// Mean extinction of the classified volume at every grid point, at
/// [`OCCLUSION_LEVELS`] resolutions.
#[derive(Clone, Debug)]
pub struct OcclusionGrid {
    /// Finest first.
    levels: Vec<Level>,
    /// Whether occlusion rays may march eight at a time in AVX2 lanes:
    /// this CPU has AVX2 and every level's points fit an `i32` index.
    lanes: bool,
    /// Seconds the build took.
    pub build_s: f64,
    /// Samples the build took.
    pub samples: u64,
}

impl OcclusionGrid {
    /// Bytes a grid over `dims` takes, or `None` past `u64`.
    pub fn bytes_for(dims: [usize; 3]) -> Option<u64> {
        dims.iter().try_fold(4u64, |acc, &n| {
            acc.checked_mul((n.saturating_sub(1).div_ceil(OCCLUSION_CELL) + 1) as u64)
        })
    }

    /// The grid's memory, bytes (all levels).
    pub fn bytes(&self) -> u64 {
        let points = |l: &Level| l.lattice.g.iter().product::<usize>() as u64;
        self.levels.iter().map(|l| points(l) * 4).sum()
    }

    /// Build the grid of `src` through `occ` (query `q`, optical depth per
    /// `step` world units) for voxel `spacing`, on all threads; samples in
    /// cells `clear` reports clear count as clear without being taken.
    /// Refuses a grid past `budget` bytes.
    pub fn build<S: VoxelSource, O: Occluder>(
        src: &S,
        occ: &O,
        q: O::Query,
        spacing: [f32; 3],
        step: f32,
        budget: u64,
        clear: Option<&ClearBoxes<'_>>,
    ) -> Result<OcclusionGrid, RenderError> {
        let depths = OccluderPointExtinction { src, occ, q };
        OcclusionGrid::build_with(&depths, src.dims(), spacing, step, budget, clear)
    }

    /// [`OcclusionGrid::build`] with its samples taken by `depths` in a
    /// volume of `dims`: everything but the samples is compiled once,
    /// whatever the occluder and the volume's layout.
    fn build_with(
        depths: &dyn PointDepths,
        d: volcore::Dims,
        spacing: [f32; 3],
        step: f32,
        budget: u64,
        clear: Option<&ClearBoxes<'_>>,
    ) -> Result<OcclusionGrid, RenderError> {
        let start = Instant::now();
        let n = [d.x as usize, d.y as usize, d.z as usize];
        let bytes = OcclusionGrid::bytes_for(n).unwrap_or(u64::MAX);
        if bytes > budget {
            return Err(RenderError::Setting(format!(
                "an occlusion grid for {} would take {bytes} bytes, more than the budget of {budget}",
                d
            )));
        }
        let g = n.map(|n| n.saturating_sub(1).div_ceil(OCCLUSION_CELL) + 1);
        let mut sigma: Vec<f32> = Vec::new();
        // With room for the padding `Level::new` adds.
        sigma
            .try_reserve_exact(g[0] * g[1] * g[2] + 1)
            .map_err(|_| {
                RenderError::Setting(format!(
                    "cannot allocate an occlusion grid of {bytes} bytes"
                ))
            })?;
        sigma.resize(g[0] * g[1] * g[2], 0.0);
        let min_spacing = spacing.iter().copied().fold(f32::INFINITY, f32::min);
        // One voxel of the densest material blocks light down to the
        // shadow cutoff; denser samples (and the opaque inside of an
        // iso-surface, whose depth is infinite) are clamped to that, so
        // the grid stays finite and interpolates without NaN.
        let sigma_max = SHADOW_DEPTH_CUTOFF / min_spacing;
        let cell = OCCLUSION_CELL as f32;
        let hi = n.map(|n| n.saturating_sub(1) as f32);
        let per_slice = g[0] * g[1];
        let ranges = clear.map(|c| ClearRanges::new(c, g, 0.25 * cell, hi));
        let slices = Slices {
            g,
            hi,
            step,
            sigma_max,
            ranges: ranges.as_ref(),
        };
        let samples: u64 = sigma
            .par_chunks_mut(per_slice)
            .enumerate()
            .map_init(Vec::new, |row, (z, slice)| {
                depths.slice(&slices, z, slice, row)
            })
            .sum();
        let mut levels = vec![Level::new(g, spacing, cell, sigma)];
        for l in 1..OCCLUSION_LEVELS {
            let next = levels[l - 1].coarser(spacing, cell * (1 << l) as f32);
            levels.push(next);
        }
        let lanes = volcore::lanes::avx2_available()
            && levels.iter().all(|l| l.sigma.len() <= i32::MAX as usize);
        Ok(OcclusionGrid {
            levels,
            lanes,
            build_s: start.elapsed().as_secs_f64(),
            samples,
        })
    }

    /// Extinction per world unit at world point `p` on level `level`
    /// (0 finest; trilinear; points past the grid read its nearest face).
    #[inline]
    pub fn sigma(&self, level: usize, p: Vec3) -> f32 {
        self.levels[level.min(self.levels.len() - 1)].sigma(p)
    }
}

/// Which index cells the samples around each grid point touch, per axis
/// (the points lie on a lattice, so each axis's ranges are worked out once).
struct ClearRanges<'a> {
    clear: &'a ClearBoxes<'a>,
    /// Per axis, per grid index: the first and last index cell.
    ranges: [Vec<(u64, u64)>; 3],
}

impl<'a> ClearRanges<'a> {
    /// The ranges of boxes of half-width `r` voxels around the points of
    /// a grid of `g` points per axis, clamped to `[0, hi]`.
    fn new(clear: &'a ClearBoxes<'a>, g: [usize; 3], r: f32, hi: [f32; 3]) -> Self {
        let ranges = std::array::from_fn(|a| {
            (0..g[a])
                .map(|i| {
                    let c = (i * OCCLUSION_CELL) as f32;
                    (
                        clear.cell_along(a, (c - r).clamp(0.0, hi[a])),
                        clear.cell_along(a, (c + r).clamp(0.0, hi[a])),
                    )
                })
                .collect()
        });
        ClearRanges { clear, ranges }
    }

    /// Per index cell along x: whether every cell the boxes around the
    /// points of row `(y, z)` touch across y and z is clear (into `out`).
    fn row(&self, y: usize, z: usize, out: &mut Vec<bool>) {
        let (ry, rz) = (self.ranges[1][y], self.ranges[2][z]);
        out.clear();
        out.extend((0..self.clear.cells()[0]).map(|cx| {
            (rz.0..=rz.1).all(|cz| (ry.0..=ry.1).all(|cy| self.clear.is_clear([cx, cy, cz])))
        }));
    }

    /// Whether every index cell the box around point `x` of a row touches
    /// is clear, from the row's [`ClearRanges::row`].
    #[inline]
    fn clear_in_row(&self, x: usize, row: &[bool]) -> bool {
        let rx = self.ranges[0][x];
        (rx.0..=rx.1).all(|cx| row.get(cx as usize).copied().unwrap_or(false))
    }
}

/// Where an occlusion ray samples: intervals that partition `[0, R]`,
/// the first half a grid cell long, each the last times
/// [`INTERVAL_GROWTH`] (the last clipped to end at `R`), each read at its
/// midpoint on the level whose cell is no longer than the interval. The
/// same for every ray of a frame.
#[derive(Clone, Debug)]
pub struct Intervals {
    /// (midpoint, length, level) per interval, world units.
    parts: Vec<(f32, f32, usize)>,
}

impl Intervals {
    /// The intervals up to `radius`, starting at `first` world units (both
    /// finite, `first > 0`; a radius of 0 has none), for a finest grid
    /// cell of `cell` world units.
    pub fn new(radius: f32, first: f32, cell: f32) -> Intervals {
        let mut parts = Vec::new();
        let (mut t, mut len) = (0.0f32, first.max(f32::MIN_POSITIVE));
        while t < radius && parts.len() < MAX_INTERVALS {
            let last = parts.len() + 1 == MAX_INTERVALS;
            let l = if last || t + len * INTERVAL_GROWTH > radius {
                radius - t
            } else {
                len
            };
            let cells = l / cell.max(f32::MIN_POSITIVE);
            let level = if cells >= 4.0 {
                2
            } else if cells >= 2.0 {
                1
            } else {
                0
            };
            parts.push((t + 0.5 * l, l, level.min(OCCLUSION_LEVELS - 1)));
            if l != len {
                break;
            }
            t += l;
            len *= INTERVAL_GROWTH;
        }
        Intervals { parts }
    }

    /// Samples per ray.
    pub fn len(&self) -> usize {
        self.parts.len()
    }

    /// Whether there are none (radius 0).
    pub fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// Transmittance from world point `origin` along unit world direction
    /// `dir` through `grid`, inside the box `[0, hi]` (the medium is empty
    /// outside it); and the samples taken. In `[0, 1]`, never NaN: 0 once
    /// the optical depth passes the shadow cutoff.
    #[inline]
    pub fn transmittance(
        &self,
        grid: &OcclusionGrid,
        origin: Vec3,
        dir: Vec3,
        hi: Vec3,
    ) -> (f32, u32) {
        let mut depth = 0.0f32;
        let mut taken = 0;
        for &(mid, len, level) in &self.parts {
            let p = origin + dir * mid;
            if p.cmplt(Vec3::ZERO).any() || p.cmpgt(hi).any() {
                // A ray that leaves a convex box never comes back.
                break;
            }
            taken += 1;
            depth += grid.sigma(level, p) * len;
            if depth > SHADOW_DEPTH_CUTOFF {
                return (0.0, taken);
            }
        }
        ((-depth).exp(), taken)
    }

    /// [`Intervals::transmittance`] along the first `count` (at most 8) of
    /// the unit directions `dirs` (per component, then per lane) from one
    /// `origin`, the rays marched side by side in AVX2 lanes, bit for bit:
    /// each lane's transmittance (lanes from `count` on hold 1), and the
    /// samples the `count` rays took in all. `None` where the grid cannot
    /// be read in lanes (then march them one by one).
    #[inline]
    pub fn transmittance8(
        &self,
        grid: &OcclusionGrid,
        origin: Vec3,
        dirs: &[[f32; 8]; 3],
        count: usize,
        hi: Vec3,
    ) -> Option<([f32; 8], u64)> {
        if !grid.lanes {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `lanes` is set only where AVX2 was found and every
            // level's points fit an i32 index.
            Some(unsafe { avx2::transmittance8(self, grid, origin, dirs, count.min(8), hi) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (origin, dirs, count, hi);
            None
        }
    }
}

/// Occlusion rays from one origin, marched eight at a time in lanes where
/// the grid allows (one by one elsewhere), their transmittances handed on
/// in the order their directions came: the same numbers either way.
pub struct RayBatch<'a> {
    intervals: &'a Intervals,
    grid: &'a OcclusionGrid,
    origin: Vec3,
    hi: Vec3,
    /// Directions waiting, per component, then per lane.
    dirs: [[f32; 8]; 3],
    /// How many are waiting.
    count: usize,
    /// Samples the rays marched so far took.
    pub taken: u64,
}

impl<'a> RayBatch<'a> {
    /// Rays from `origin` through `grid` with `intervals`, in the box
    /// `[0, hi]`.
    #[inline]
    pub fn new(intervals: &'a Intervals, grid: &'a OcclusionGrid, origin: Vec3, hi: Vec3) -> Self {
        RayBatch {
            intervals,
            grid,
            origin,
            hi,
            dirs: [[0.0; 8]; 3],
            count: 0,
            taken: 0,
        }
    }

    /// Add the ray along unit direction `d`; `out` receives the
    /// transmittances of the rays marched (eight once eight wait).
    #[inline]
    pub fn push(&mut self, d: Vec3, out: &mut impl FnMut(f32)) {
        if !self.grid.lanes {
            let (t, s) = self
                .intervals
                .transmittance(self.grid, self.origin, d, self.hi);
            self.taken += s as u64;
            out(t);
            return;
        }
        for (a, v) in d.to_array().into_iter().enumerate() {
            self.dirs[a][self.count] = v;
        }
        self.count += 1;
        if self.count == 8 {
            self.flush(out);
        }
    }

    /// [`RayBatch::push`] of the first `count` (at most 8) of the unit
    /// directions `dirs` (per component, then per lane), in lane order;
    /// eight with none waiting are marched at once.
    #[inline]
    pub fn push8(&mut self, dirs: &[[f32; 8]; 3], count: usize, out: &mut impl FnMut(f32)) {
        if self.grid.lanes && self.count == 0 {
            self.dirs = *dirs;
            self.count = count.min(8);
            if self.count == 8 {
                self.flush(out);
            }
            return;
        }
        (0..count.min(8))
            .for_each(|i| self.push(Vec3::new(dirs[0][i], dirs[1][i], dirs[2][i]), out));
    }

    /// March the rays still waiting; `out` receives their transmittances.
    #[inline]
    pub fn flush(&mut self, out: &mut impl FnMut(f32)) {
        if self.count == 0 {
            return;
        }
        let count = std::mem::take(&mut self.count);
        match self
            .intervals
            .transmittance8(self.grid, self.origin, &self.dirs, count, self.hi)
        {
            Some((t, s)) => {
                self.taken += s;
                t[..count].iter().for_each(|&t| out(t));
            }
            None => {
                for i in 0..count {
                    let d = Vec3::new(self.dirs[0][i], self.dirs[1][i], self.dirs[2][i]);
                    let (t, s) = self
                        .intervals
                        .transmittance(self.grid, self.origin, d, self.hi);
                    self.taken += s as u64;
                    out(t);
                }
            }
        }
    }
}

/// Reads of the grid's levels (and of lattices like them) in AVX2 lanes.
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use super::{Intervals, Lattice, Level, OcclusionGrid, SHADOW_DEPTH_CUTOFF};
    use glam::Vec3;
    use std::arch::x86_64::*;
    use volcore::lanes::lerp8 as lerp;

    /// One axis of [`super::Lattice::corners`] for eight world
    /// coordinates: the lower points and the weights, the same
    /// operations (the clamp's `max` first, so NaN reads point 0).
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn locate(p: __m256, world_to_grid: f32, top: f32) -> (__m256i, __m256) {
        let c = _mm256_mul_ps(p, _mm256_set1_ps(world_to_grid));
        let c = _mm256_min_ps(_mm256_max_ps(c, _mm256_setzero_ps()), _mm256_set1_ps(top));
        let i = _mm256_cvttps_epi32(c);
        (i, _mm256_sub_ps(c, _mm256_cvtepi32_ps(i)))
    }

    /// `step` where the lower point `i` has a next point on an axis of
    /// `g` points, else 0 (the lattice's last face reads itself).
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn stride(i: __m256i, g: usize, step: i32) -> __m256i {
        let has_next = _mm256_cmpgt_epi32(
            _mm256_set1_epi32(g as i32),
            _mm256_add_epi32(i, _mm256_set1_epi32(1)),
        );
        _mm256_and_si256(has_next, _mm256_set1_epi32(step))
    }

    /// [`super::Lattice::corners`] of eight world points `p`: the eight
    /// corners' indices (in its order) and the weights per axis, the same
    /// operations.
    ///
    /// # Safety
    /// AVX2; the lattice's points fit an i32 index.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn corners8(l: &Lattice, p: &[__m256; 3]) -> ([__m256i; 8], [__m256; 3]) {
        let [gx, gy, gz] = l.g;
        let (ix, fx) = locate(p[0], l.world_to_grid.x, l.top.x);
        let (iy, fy) = locate(p[1], l.world_to_grid.y, l.top.y);
        let (iz, fz) = locate(p[2], l.world_to_grid.z, l.top.z);
        let sx = stride(ix, gx, 1);
        let sy = stride(iy, gy, gx as i32);
        let sz = stride(iz, gz, (gx * gy) as i32);
        let b = _mm256_add_epi32(
            _mm256_mullo_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(iz, _mm256_set1_epi32(gy as i32)), iy),
                _mm256_set1_epi32(gx as i32),
            ),
            ix,
        );
        // Every lower point is clamped into the lattice and every stride
        // stays inside it, so every index is in bounds.
        let by = _mm256_add_epi32(b, sy);
        let bz = _mm256_add_epi32(b, sz);
        let bzy = _mm256_add_epi32(bz, sy);
        let plus = |i: __m256i| _mm256_add_epi32(i, sx);
        (
            [b, plus(b), by, plus(by), bz, plus(bz), bzy, plus(bzy)],
            [fx, fy, fz],
        )
    }

    /// [`super::trilinear`] of corner values `v` at weights `f`, per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn trilinear8(v: [__m256; 8], f: [__m256; 3]) -> __m256 {
        let c00 = lerp(v[0], v[1], f[0]);
        let c10 = lerp(v[2], v[3], f[0]);
        let c01 = lerp(v[4], v[5], f[0]);
        let c11 = lerp(v[6], v[7], f[0]);
        lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2])
    }

    /// [`Level::sigma`] at eight world points.
    ///
    /// # Safety
    /// AVX2; the level's points fit an i32 index.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn sigma8(level: &Level, p: &[__m256; 3]) -> __m256 {
        let (at, f) = corners8(&level.lattice, p);
        let data = level.sigma.as_ptr();
        // Lanes at the lattice's last x, whose two x corners are one point.
        let same = _mm256_castsi256_ps(_mm256_cmpeq_epi32(at[0], at[1]));
        let mut v = [_mm256_setzero_ps(); 8];
        for k in 0..4 {
            // In bounds: the level is padded by one.
            let (first, next) = pairs8(data, at[2 * k]);
            v[2 * k] = first;
            v[2 * k + 1] = _mm256_blendv_ps(next, first, same);
        }
        trilinear8(v, f)
    }

    /// `data[at]` and `data[at + 1]` per lane, each pair read as one
    /// 8-byte element, four lanes a gather: half the elements of gathering
    /// the two apart.
    ///
    /// # Safety
    /// AVX2; `at` and `at + 1` are in bounds of `data`'s allocation.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn pairs8(data: *const f32, at: __m256i) -> (__m256, __m256) {
        let pairs = data.cast::<f64>();
        let lo = _mm256_i32gather_pd::<4>(pairs, _mm256_castsi256_si128(at));
        let hi = _mm256_i32gather_pd::<4>(pairs, _mm256_extracti128_si256::<1>(at));
        let (lo, hi) = (_mm256_castpd_ps(lo), _mm256_castpd_ps(hi));
        // Firsts and seconds come in lane order 0 1 4 5 | 2 3 6 7.
        let order =
            |v: __m256| _mm256_castpd_ps(_mm256_permute4x64_pd::<0xD8>(_mm256_castps_pd(v)));
        (
            order(_mm256_shuffle_ps::<0x88>(lo, hi)),
            order(_mm256_shuffle_ps::<0xDD>(lo, hi)),
        )
    }

    /// See [`Intervals::transmittance8`].
    ///
    /// # Safety
    /// AVX2; every level's points fit an i32 index; `count <= 8`.
    #[target_feature(enable = "avx2")]
    pub unsafe fn transmittance8(
        iv: &Intervals,
        grid: &OcclusionGrid,
        origin: Vec3,
        dirs: &[[f32; 8]; 3],
        count: usize,
        hi: Vec3,
    ) -> ([f32; 8], u64) {
        let zero = _mm256_setzero_ps();
        let d = dirs.map(|c| _mm256_loadu_ps(c.as_ptr()));
        let o = [origin.x, origin.y, origin.z].map(|v| _mm256_set1_ps(v));
        let h = [hi.x, hi.y, hi.z].map(|v| _mm256_set1_ps(v));
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        // Lanes still marching; those cut off (optical depth past the
        // cutoff: transmittance 0).
        let mut alive =
            _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(count as i32), lane));
        let mut cut = zero;
        let mut depth = zero;
        let mut taken = _mm256_setzero_si256();
        let cutoff = _mm256_set1_ps(SHADOW_DEPTH_CUTOFF);
        for &(mid, len, level) in &iv.parts {
            let m = _mm256_set1_ps(mid);
            let mut p = [zero; 3];
            let mut outside = zero;
            for a in 0..3 {
                p[a] = _mm256_add_ps(o[a], _mm256_mul_ps(d[a], m));
                outside = _mm256_or_ps(
                    outside,
                    _mm256_or_ps(
                        _mm256_cmp_ps::<_CMP_LT_OQ>(p[a], zero),
                        _mm256_cmp_ps::<_CMP_GT_OQ>(p[a], h[a]),
                    ),
                );
            }
            // A ray that leaves a convex box never comes back.
            alive = _mm256_andnot_ps(outside, alive);
            if _mm256_movemask_ps(alive) == 0 {
                break;
            }
            // Alive lanes are all ones: −1 each.
            taken = _mm256_sub_epi32(taken, _mm256_castps_si256(alive));
            let s = sigma8(&grid.levels[level.min(grid.levels.len() - 1)], &p);
            let next = _mm256_add_ps(depth, _mm256_mul_ps(s, _mm256_set1_ps(len)));
            depth = _mm256_blendv_ps(depth, next, alive);
            let over = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(depth, cutoff), alive);
            cut = _mm256_or_ps(cut, over);
            alive = _mm256_andnot_ps(over, alive);
        }
        let mut dep = [0f32; 8];
        _mm256_storeu_ps(dep.as_mut_ptr(), depth);
        let mut n = [0i32; 8];
        _mm256_storeu_si256(n.as_mut_ptr().cast(), taken);
        let cut = _mm256_movemask_ps(cut);
        let mut out = [1f32; 8];
        for i in 0..count {
            out[i] = if cut >> i & 1 == 1 {
                0.0
            } else {
                (-dep[i]).exp()
            };
        }
        (out, n.iter().map(|&k| k as u64).sum())
    }
}

/// The points of one z slice of an occlusion grid and how they are
/// sampled: everything [`PointDepths::slice`] needs but the volume.
struct Slices<'a> {
    /// Grid points per axis.
    g: [usize; 3],
    /// The volume's far corner, voxels.
    hi: [f32; 3],
    /// The step the occluder's depths are for.
    step: f32,
    /// The largest extinction a sample counts with.
    sigma_max: f32,
    /// The index cells clear along rows, when skipping.
    ranges: Option<&'a ClearRanges<'a>>,
}

/// What an occlusion grid's build reads from the volume: the mean
/// extinction at the points of one slice. The one part of the build
/// specialised per occluder and per volume layout (one cursor per slice).
trait PointDepths: Sync {
    /// Fill `slice` (slice `z` of the grid, x fastest) with each point's
    /// mean extinction over its eight samples (`row`: scratch space);
    /// returns the samples taken.
    fn slice(&self, s: &Slices<'_>, z: usize, slice: &mut [f32], row: &mut Vec<bool>) -> u64;
}

/// The mean extinction of occluder `occ` (query `q`) over `src`, at the
/// points of an occlusion grid slice.
struct OccluderPointExtinction<'a, S, O: Occluder> {
    src: &'a S,
    occ: &'a O,
    q: O::Query,
}

impl<S: VoxelSource, O: Occluder> PointDepths for OccluderPointExtinction<'_, S, O> {
    fn slice(&self, s: &Slices<'_>, z: usize, slice: &mut [f32], row: &mut Vec<bool>) -> u64 {
        let Slices {
            g,
            hi,
            step,
            sigma_max,
            ranges,
        } = *s;
        let cell = OCCLUSION_CELL as f32;
        let mut cur = self.src.cursor();
        let mut taken = 0u64;
        for (y, line) in slice.chunks_mut(g[0]).enumerate() {
            // Which index cells along x are clear across the
            // row's y and z: found once a row.
            if let Some(r) = &ranges {
                r.row(y, z, row);
            }
            for (x, out) in line.iter_mut().enumerate() {
                // The samples lie within a quarter cell of the
                // point: when every index cell that box
                // touches is clear, so are they.
                if ranges.as_ref().is_some_and(|r| r.clear_in_row(x, row)) {
                    *out = 0.0;
                    continue;
                }
                let centre = Vec3::new(
                    (x * OCCLUSION_CELL) as f32,
                    (y * OCCLUSION_CELL) as f32,
                    (z * OCCLUSION_CELL) as f32,
                );
                let mut sum = 0.0f32;
                for corner in 0..8 {
                    let off = Vec3::new(
                        if corner & 1 == 0 { -0.25 } else { 0.25 },
                        if corner & 2 == 0 { -0.25 } else { 0.25 },
                        if corner & 4 == 0 { -0.25 } else { 0.25 },
                    ) * cell;
                    let p = (centre + off).clamp(Vec3::ZERO, Vec3::new(hi[0], hi[1], hi[2]));
                    taken += 1;
                    let s = self.occ.depth(&mut cur, p, self.q) / step;
                    sum += if s.is_nan() { 0.0 } else { s.min(sigma_max) };
                }
                *out = sum * 0.125;
            }
        }
        taken
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_partition_the_radius() {
        for (r, first) in [(139.0, 2.0), (1.0, 2.0), (10.0, 0.5), (1e6, 1e-3)] {
            let iv = Intervals::new(r, first, 4.0);
            let sum: f32 = iv.parts.iter().map(|p| p.1).sum();
            assert!((sum - r).abs() <= r * 1e-5, "{r} {first}: {sum}");
            assert!(iv.len() <= MAX_INTERVALS);
            assert!(iv.parts.iter().all(|p| p.1 > 0.0));
        }
        assert!(Intervals::new(0.0, 2.0, 4.0).is_empty());
        // The default radius on the thesis scene: a handful of reads, the
        // far ones on coarse levels.
        let iv = Intervals::new(139.0, 2.0, 4.0);
        assert!(iv.len() <= 8);
        assert_eq!(iv.parts[0].2, 0);
        assert_eq!(iv.parts[iv.len() - 1].2, 2);
        assert!(iv.parts.windows(2).all(|w| w[0].2 <= w[1].2));
    }
}
