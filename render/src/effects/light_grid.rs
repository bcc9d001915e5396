//! A light-transmittance grid for one directional light.
//!
//! Grid points sit every `divisor` voxels along each axis (the last one on
//! the volume's far face). The grid is swept in slabs along the axis the
//! light's voxel-space direction is longest in, starting from the slab
//! nearest the light (transmittance 1): each point looks one slab toward
//! the light, takes the transmittance there by bilinear interpolation, and
//! multiplies in the segment between, sampled about one shadow step apart.
//! A segment that leaves the volume through a side face ends there
//! (nothing outside blocks light). The segments do not depend on each
//! other, so they are all sampled first, on all threads; then the
//! upstream transmittance is blended in slab by slab (points within a slab
//! are independent, so each slab runs on all threads). The grid does not
//! depend on the thread count. At render time the grid is read
//! trilinearly.
//!
//! The grid is exact for light along an axis at divisor 1 up to the
//! segments' sampling; otherwise the bilinear reads blur the shadow by up
//! to a grid cell, which is the price of its speed.

use super::occluder::Occluder;
use crate::accel::ClearBoxes;
use crate::error::RenderError;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use volcore::VoxelSource;

/// Transmittance toward one light at every grid point.
#[derive(Clone, Debug)]
pub struct LightGrid {
    /// Volume axes in storage order: the sweep axis first.
    perm: [usize; 3],
    /// Grid points per volume axis.
    g: [usize; 3],
    /// The storage axes' point lookup, in storage order.
    axes: [GridAxis; 3],
    data: Vec<f32>,
    /// Whether eight points can be read at once
    /// ([`LightGrid::transmittance8`]): AVX2, every axis at least two
    /// points, every index an `i32`.
    lanes: bool,
    /// Seconds the build took.
    pub build_s: f64,
    /// Samples the build took.
    pub samples: u64,
}

/// Grid points along an axis of `n` voxels, one every `div`.
fn points(n: usize, div: usize) -> usize {
    n.saturating_sub(1).div_ceil(div) + 1
}

/// Voxel coordinate of grid point `i` along an axis.
#[inline(always)]
fn position(i: usize, n: usize, div: usize) -> f32 {
    (i * div).min(n.saturating_sub(1)) as f32
}

/// Continuous grid coordinate of voxel coordinate `p` along an axis of `n`
/// voxels and `g` points (clamped to the grid).
#[inline(always)]
fn grid_coord(p: f32, n: usize, g: usize, div: usize) -> f32 {
    if g < 2 {
        return 0.0;
    }
    let p = p.clamp(0.0, (n - 1) as f32);
    let last_uniform = ((g - 2) * div) as f32;
    if p <= last_uniform {
        p / div as f32
    } else {
        (g - 2) as f32 + (p - last_uniform) / ((n - 1) as f32 - last_uniform)
    }
}

/// Lower index and weight of `c` between points `i` and `i + 1`.
#[inline(always)]
fn split(c: f32, g: usize) -> (usize, f32) {
    if g < 2 {
        return (0, 0.0);
    }
    let i = (c as usize).min(g - 2);
    (i, c - i as f32)
}

impl LightGrid {
    /// Bytes a grid for `dims` at `divisor` takes, or `None` past `u64`.
    pub fn bytes_for(dims: [usize; 3], divisor: u32) -> Option<u64> {
        let d = divisor.max(1) as usize;
        dims.iter()
            .try_fold(4u64, |acc, &n| acc.checked_mul(points(n, d) as u64))
    }

    /// The grid's memory, bytes.
    pub fn bytes(&self) -> u64 {
        self.data.len() as u64 * 4
    }

    /// Build the grid of `src` through `occ` (with query `q`, depth per
    /// `step` world units; segments sampled about `spacing_of_samples`
    /// apart) for light arriving from unit world direction
    /// `towards`, at `divisor` voxels per cell, on all threads; segments
    /// inside boxes `clear` reports clear are not sampled. Refuses a grid
    /// past `budget` bytes.
    #[allow(clippy::too_many_arguments)]
    pub fn build<S: VoxelSource, O: Occluder>(
        src: &S,
        occ: &O,
        q: O::Query,
        towards: Vec3,
        spacing: [f32; 3],
        divisor: u32,
        step: f32,
        spacing_of_samples: f32,
        budget: u64,
        clear: Option<&ClearBoxes<'_>>,
    ) -> Result<LightGrid, RenderError> {
        let depths = OccluderSegmentDepths { src, occ, q };
        let options = GridOptions {
            towards,
            spacing,
            divisor,
            step,
            spacing_of_samples,
            budget,
            clear,
        };
        LightGrid::build_with(&depths, src.dims(), &options)
    }

    /// [`LightGrid::build`] with its samples taken by `depths` in a volume
    /// of `dims`: everything but the segments' samples is compiled once,
    /// whatever the occluder and the volume's layout.
    fn build_with(
        depths: &dyn SegmentDepths,
        d: volcore::Dims,
        options: &GridOptions<'_>,
    ) -> Result<LightGrid, RenderError> {
        let GridOptions {
            towards,
            spacing,
            divisor,
            step,
            spacing_of_samples,
            budget,
            clear,
        } = *options;
        let start = Instant::now();
        let div = divisor.max(1) as usize;
        let n = [d.x as usize, d.y as usize, d.z as usize];
        let g = n.map(|n| points(n, div));
        let bytes = LightGrid::bytes_for(n, divisor).unwrap_or(u64::MAX);
        if bytes > budget {
            return Err(RenderError::Setting(format!(
                "a shadow grid at divisor {divisor} would take {bytes} bytes, more than the \
                 budget of {budget}: use a larger divisor or --shadows ray"
            )));
        }
        // The light's direction in voxels per world unit.
        let lv = Vec3::new(
            towards.x / spacing[0],
            towards.y / spacing[1],
            towards.z / spacing[2],
        );
        let a = (0..3)
            .max_by(|&i, &j| lv[i].abs().total_cmp(&lv[j].abs()))
            .unwrap_or(2);
        let usable = lv[a].abs() > 0.0 && lv.is_finite() && step > 0.0 && spacing_of_samples > 0.0;
        if !usable {
            return Err(RenderError::Setting(
                "the light's direction in voxel units is degenerate for a shadow grid".into(),
            ));
        }
        let (b, c) = match a {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let perm = [a, b, c];
        let slice_len = g[b] * g[c];
        let total = g[a] * slice_len;
        let mut data: Vec<f32> = Vec::new();
        data.try_reserve_exact(total).map_err(|_| {
            RenderError::Setting(format!("cannot allocate a shadow grid of {bytes} bytes"))
        })?;
        data.resize(total, 1.0);
        let towards_plus = lv[a] > 0.0;
        let sweep = Sweep {
            lv,
            perm,
            g,
            n,
            div,
            step,
            spacing: spacing_of_samples,
            clear,
        };
        // Two passes. The first writes every point's own segment
        // transmittance (1 where the segment lies in clear cells, as most
        // do, and in the slab nearest the light): segments do not depend
        // on each other, so all slabs run at once on all threads. The
        // second multiplies in the transmittance arriving from upstream,
        // slab by slab away from the light. (One pass per slab doing both
        // waited on the slowest rows of each slab, and scaled 1.3x from
        // one thread to two.)
        let nearest = if towards_plus { g[a] - 1 } else { 0 };
        let slabs: Vec<(u64, Option<Upstream>)> = data
            .par_chunks_mut(slice_len)
            .enumerate()
            .map_init(Vec::new, |clear, (i, slab_data)| {
                if i == nearest {
                    return (0, None);
                }
                let prev = if towards_plus { i + 1 } else { i - 1 };
                let slab = sweep.slab(i, prev);
                let samples = depths.slab(&sweep, &slab, slab_data, clear);
                (samples, Some(Upstream::of(&slab)))
            })
            .collect();
        let samples = slabs.iter().map(|(s, _)| s).sum();
        // The upstream pass runs as one job on the pool: each slab's rows
        // are split from a worker, not handed over from this thread and
        // waited for, a round trip per slab.
        rayon::scope(|_| {
            for s in 1..g[a] {
                let (i, prev) = if towards_plus {
                    (g[a] - 1 - s, g[a] - s)
                } else {
                    (s, s - 1)
                };
                let Some(up) = slabs[i].1.as_ref() else {
                    continue;
                };
                let (cur_slab, prev_slab) = if towards_plus {
                    let (head, tail) = data.split_at_mut(prev * slice_len);
                    (&mut head[i * slice_len..], &tail[..slice_len])
                } else {
                    let (head, tail) = data.split_at_mut(i * slice_len);
                    (&mut tail[..slice_len], &head[prev * slice_len..])
                };
                let prev_slab: &[f32] = prev_slab;
                cur_slab
                    .par_chunks_mut(g[c])
                    .enumerate()
                    .for_each(|(j, row)| sweep.upstream(up, j, row, prev_slab));
            }
        });
        Ok(LightGrid {
            perm,
            g,
            axes: perm.map(|ax| GridAxis::new(n[ax], g[ax], div)),
            lanes: volcore::lanes::avx2_available()
                && g.iter().all(|&g| (2..1 << 24).contains(&g))
                && data.len() < i32::MAX as usize,
            data,
            build_s: start.elapsed().as_secs_f64(),
            samples,
        })
    }

    /// Transmittance at voxel-space point `p` (trilinear; points outside
    /// the volume read its nearest face).
    #[inline]
    pub fn transmittance(&self, p: Vec3) -> f32 {
        let [a, b, c] = self.perm;
        let (ia, fa) = self.axes[0].locate(p[a]);
        let (ib, fb) = self.axes[1].locate(p[b]);
        let (ic, fc) = self.axes[2].locate(p[c]);
        let (gb, gc) = (self.g[b], self.g[c]);
        let step_a = if self.g[a] > 1 { gb * gc } else { 0 };
        let step_b = if gb > 1 { gc } else { 0 };
        let step_c = usize::from(gc > 1);
        let base = (ia * gb + ib) * gc + ic;
        let at = |o: usize| self.data[base + o];
        let lerp = |x: f32, y: f32, f: f32| x + (y - x) * f;
        let c00 = lerp(at(0), at(step_c), fc);
        let c01 = lerp(at(step_b), at(step_b + step_c), fc);
        let c10 = lerp(at(step_a), at(step_a + step_c), fc);
        let c11 = lerp(at(step_a + step_b), at(step_a + step_b + step_c), fc);
        lerp(lerp(c00, c01, fb), lerp(c10, c11, fb), fa).clamp(0.0, 1.0)
    }
}

impl LightGrid {
    /// [`LightGrid::transmittance`] at eight voxel-space points (per axis,
    /// then per lane), bit for bit, read in AVX2 lanes; `None` where the
    /// CPU or the grid does not allow it.
    #[inline]
    pub fn transmittance8(&self, p: &[[f32; 8]; 3]) -> Option<[f32; 8]> {
        if !self.lanes {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `lanes` is set only where AVX2 was found, every axis
            // has two points or more and every index fits an i32.
            Some(unsafe { avx2::transmittance8(self, p) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = p;
            None
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{GridAxis, LightGrid, Lines, UpstreamRows};
    use std::arch::x86_64::*;
    use volcore::lanes::lerp8 as lerp;

    /// [`GridAxis::locate`] of eight coordinates: lower points and
    /// weights, the same operations.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn locate(ax: &GridAxis, p: __m256) -> (__m256i, __m256) {
        // `if p > 0 { p.min(hi) } else { 0 }` (NaN to 0).
        let positive = _mm256_cmp_ps::<_CMP_GT_OQ>(p, _mm256_setzero_ps());
        let p = _mm256_and_ps(_mm256_min_ps(p, _mm256_set1_ps(ax.hi)), positive);
        let lu = _mm256_set1_ps(ax.last_uniform);
        let uniform = _mm256_mul_ps(p, _mm256_set1_ps(ax.inv_div));
        let last = _mm256_add_ps(
            _mm256_set1_ps((ax.g - 2) as f32),
            _mm256_mul_ps(_mm256_sub_ps(p, lu), _mm256_set1_ps(ax.inv_last)),
        );
        let c = _mm256_blendv_ps(last, uniform, _mm256_cmp_ps::<_CMP_LE_OQ>(p, lu));
        // `split`: (c as usize).min(g − 2) and the rest (c >= 0).
        let i = _mm256_min_epi32(_mm256_cvttps_epi32(c), _mm256_set1_epi32((ax.g - 2) as i32));
        (i, _mm256_sub_ps(c, _mm256_cvtepi32_ps(i)))
    }

    /// The upstream pass over one row (see `Sweep::upstream`): where the
    /// upstream points of eight neighbouring grid lines are eight
    /// neighbours, their rows are read with plain loads, blended in lanes
    /// (the scalar lerps in the same order) and multiplied into the
    /// points whose segments reach upstream; other points go to `one`,
    /// the scalar code. `reach`: the row's exit distance and the full
    /// segment's length.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn upstream_row(
        up: &UpstreamRows<'_>,
        reach: (f32, f32),
        lines: &Lines,
        row: &mut [f32],
        mut one: impl FnMut(usize, &mut f32),
    ) {
        let n = row
            .len()
            .min(lines.index.len())
            .min(lines.weight.len())
            .min(lines.u_exit.len());
        let steps = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let (exit_b, u_full) = (_mm256_set1_ps(reach.0), _mm256_set1_ps(reach.1));
        let fb = _mm256_set1_ps(up.fb);
        let rows_len = up.up0.len().min(up.up1.len());
        let mut k = 0;
        while k + 8 <= n {
            let index = _mm256_loadu_si256(lines.index.as_ptr().add(k).cast());
            let i0 = lines.index[k] as usize;
            let neighbours =
                _mm256_cmpeq_epi32(index, _mm256_add_epi32(_mm256_set1_epi32(i0 as i32), steps));
            if _mm256_movemask_epi8(neighbours) == -1 && i0 + 8 + up.sc <= rows_len {
                let at = |r: &[f32], o: usize| _mm256_loadu_ps(r.as_ptr().add(o));
                let fc = _mm256_loadu_ps(lines.weight.as_ptr().add(k));
                let blend = lerp(
                    lerp(at(up.up0, i0), at(up.up0, i0 + up.sc), fc),
                    lerp(at(up.up1, i0), at(up.up1, i0 + up.sc), fc),
                    fb,
                );
                // `lb.u_exit.min(lc.u_exit) >= u_full` (exits are never
                // NaN).
                let exit = _mm256_min_ps(exit_b, _mm256_loadu_ps(lines.u_exit.as_ptr().add(k)));
                let reaches = _mm256_cmp_ps::<_CMP_GE_OQ>(exit, u_full);
                let own = _mm256_loadu_ps(row.as_ptr().add(k));
                let out = _mm256_blendv_ps(own, _mm256_mul_ps(blend, own), reaches);
                _mm256_storeu_ps(row.as_mut_ptr().add(k), out);
            } else {
                for (kk, out) in row[k..k + 8].iter_mut().enumerate() {
                    one(k + kk, out);
                }
            }
            k += 8;
        }
        for (kk, out) in row[k..].iter_mut().enumerate() {
            one(k + kk, out);
        }
    }

    /// See [`LightGrid::transmittance8`].
    ///
    /// # Safety
    /// The CPU must have AVX2; the grid must have at least two points per
    /// axis and fewer than 2^31 in all.
    #[target_feature(enable = "avx2")]
    pub unsafe fn transmittance8(grid: &LightGrid, p: &[[f32; 8]; 3]) -> [f32; 8] {
        let [a, b, c] = grid.perm;
        let read = |axis: usize| _mm256_loadu_ps(p[axis].as_ptr());
        let (ia, fa) = locate(&grid.axes[0], read(a));
        let (ib, fb) = locate(&grid.axes[1], read(b));
        let (ic, fc) = locate(&grid.axes[2], read(c));
        let (gb, gc) = (grid.g[b] as i32, grid.g[c] as i32);
        let (sa, sb) = (gb * gc, gc);
        let base = _mm256_add_epi32(
            _mm256_mullo_epi32(
                _mm256_add_epi32(_mm256_mullo_epi32(ia, _mm256_set1_epi32(gb)), ib),
                _mm256_set1_epi32(gc),
            ),
            ic,
        );
        // Every index is at most the last point's: each lower point is at
        // most g − 2 on its axis.
        let data = grid.data.as_ptr();
        let at =
            |o: i32| _mm256_i32gather_ps::<4>(data, _mm256_add_epi32(base, _mm256_set1_epi32(o)));
        let c00 = lerp(at(0), at(1), fc);
        let c01 = lerp(at(sb), at(sb + 1), fc);
        let c10 = lerp(at(sa), at(sa + 1), fc);
        let c11 = lerp(at(sa + sb), at(sa + sb + 1), fc);
        let v = lerp(lerp(c00, c01, fb), lerp(c10, c11, fb), fa);
        // `clamp(0, 1)`: NaN stays NaN.
        let v = _mm256_blendv_ps(
            v,
            _mm256_setzero_ps(),
            _mm256_cmp_ps::<_CMP_LT_OQ>(v, _mm256_setzero_ps()),
        );
        let one = _mm256_set1_ps(1.0);
        let v = _mm256_blendv_ps(v, one, _mm256_cmp_ps::<_CMP_GT_OQ>(v, one));
        let mut out = [0f32; 8];
        _mm256_storeu_ps(out.as_mut_ptr(), v);
        out
    }
}

/// One storage axis of a grid, for finding where a voxel coordinate falls
/// between grid points (the same mapping as `grid_coord`, with the
/// divisions turned into multiplications).
#[derive(Clone, Copy, Debug)]
struct GridAxis {
    /// Grid points.
    g: usize,
    /// Largest voxel coordinate.
    hi: f32,
    /// Voxel coordinate of the last uniformly spaced point.
    last_uniform: f32,
    inv_div: f32,
    /// `1 / (hi − last_uniform)`.
    inv_last: f32,
}

impl GridAxis {
    fn new(n: usize, g: usize, div: usize) -> GridAxis {
        let hi = n.saturating_sub(1) as f32;
        let last_uniform = (g.saturating_sub(2) * div) as f32;
        GridAxis {
            g,
            hi,
            last_uniform,
            inv_div: 1.0 / div as f32,
            inv_last: if hi > last_uniform {
                1.0 / (hi - last_uniform)
            } else {
                0.0
            },
        }
    }

    /// Lower point and weight of voxel coordinate `p`.
    #[inline(always)]
    fn locate(&self, p: f32) -> (usize, f32) {
        if self.g < 2 {
            return (0, 0.0);
        }
        let p = if p > 0.0 { p.min(self.hi) } else { 0.0 };
        let c = if p <= self.last_uniform {
            p * self.inv_div
        } else {
            (self.g - 2) as f32 + (p - self.last_uniform) * self.inv_last
        };
        split(c, self.g)
    }
}

/// What a light grid's build reads from the volume: the optical depth
/// of the samples along a slab's segments. The one part of the build
/// specialised per occluder and per volume layout (one cursor per slab).
trait SegmentDepths: Sync {
    /// The first pass over `slab` (see [`Sweep::segments`]), row by row
    /// into `data`; returns the samples taken.
    fn slab(&self, sweep: &Sweep<'_>, slab: &Slab, data: &mut [f32], clear: &mut Vec<bool>) -> u64;
}

/// The optical depths of occluder `occ` (query `q`) over `src`, along a
/// light grid slab's segments.
struct OccluderSegmentDepths<'a, S, O: Occluder> {
    src: &'a S,
    occ: &'a O,
    q: O::Query,
}

impl<S: VoxelSource, O: Occluder> SegmentDepths for OccluderSegmentDepths<'_, S, O> {
    fn slab(&self, sweep: &Sweep<'_>, slab: &Slab, data: &mut [f32], clear: &mut Vec<bool>) -> u64 {
        let mut cur = self.src.cursor();
        let mut depth = |p: Vec3| self.occ.depth(&mut cur, p, self.q);
        let row_len = sweep.g[sweep.perm[2]];
        data.chunks_mut(row_len)
            .enumerate()
            .map(|(j, row)| sweep.segments(&mut depth, clear, slab, j, row))
            .sum()
    }
}

/// A light grid's settings besides its volume (see [`LightGrid::build`]).
#[derive(Clone, Copy)]
struct GridOptions<'a> {
    towards: Vec3,
    spacing: [f32; 3],
    divisor: u32,
    step: f32,
    spacing_of_samples: f32,
    budget: u64,
    clear: Option<&'a ClearBoxes<'a>>,
}

/// What every point of a sweep needs.
struct Sweep<'o> {
    /// The light's direction, voxels per world unit.
    lv: Vec3,
    perm: [usize; 3],
    g: [usize; 3],
    n: [usize; 3],
    div: usize,
    /// The step the occluder's depths are for.
    step: f32,
    /// Distance between samples along a segment (about).
    spacing: f32,
    clear: Option<&'o ClearBoxes<'o>>,
}

impl Sweep<'_> {
    /// What every row of slab `i` (looking toward slab `prev`) shares:
    /// per grid line along each of the two other axes, the point's
    /// coordinate, where a segment from it leaves the volume, the upstream
    /// point's bilinear position, and the index cells the segment's box
    /// spans; and which columns of index cells are clear over the slab's
    /// depth.
    fn slab(&self, i: usize, prev: usize) -> Slab {
        let [a, b, c] = self.perm;
        let (n, g, div, lv) = (self.n, self.g, self.div, self.lv);
        let xa = position(i, n[a], div);
        let delta = position(prev, n[a], div) - xa;
        // World distance to the previous slab along the light.
        let u_full = delta / lv[a];
        let along = |ax: usize| {
            let off = lv[ax] * u_full;
            let hi = (n[ax] - 1) as f32;
            (0..g[ax])
                .map(|j| {
                    let x = position(j, n[ax], div);
                    let u_exit = if lv[ax] > 0.0 {
                        (hi - x) / lv[ax]
                    } else if lv[ax] < 0.0 {
                        -x / lv[ax]
                    } else {
                        f32::INFINITY
                    };
                    let (lo_p, hi_p) = (x.min(x + off), x.max(x + off));
                    let cells = self.clear.map_or((0, 0), |cb| {
                        (cb.cell_along(ax, lo_p), cb.cell_along(ax, hi_p))
                    });
                    Line {
                        x,
                        u_exit,
                        upstream: split(grid_coord(x + off, n[ax], g[ax], div), g[ax]),
                        cells,
                    }
                })
                .collect::<Vec<_>>()
        };
        let (lines_b, lines_c) = (along(b), along(c));
        // Per (cell along b, cell along c): clear over every cell along a
        // that the slab's segments reach.
        let (clear_columns, cells_c) = match self.clear {
            None => (Vec::new(), 0),
            Some(cb) => {
                let (a0, a1) = (
                    cb.cell_along(a, xa.min(xa + delta)),
                    cb.cell_along(a, xa.max(xa + delta)),
                );
                (cb.clear_columns(self.perm, a0, a1), cb.cells()[c] as usize)
            }
        };
        Slab {
            xa,
            u_full,
            lines_b,
            lines_c,
            clear_columns,
            cells_c,
        }
    }

    /// Where a segment from a point on lines `lb` and `lc` of `slab`
    /// stops: whether it reaches the upstream slab, and its world length
    /// to where it leaves the volume.
    #[inline(always)]
    fn reach(slab: &Slab, lb: &Line, lc: &Line) -> (bool, f32) {
        let u_exit = lb.u_exit.min(lc.u_exit);
        (u_exit >= slab.u_full, u_exit)
    }

    /// First pass over row `j` of a slab (`clear`: scratch space): the
    /// transmittance of each point's own segment, but those whose box lies
    /// in clear cells (only whole segments: a clipped one is shorter, so
    /// inside), which keep 1; returns the samples taken.
    fn segments(
        &self,
        depth: &mut impl FnMut(Vec3) -> f32,
        clear: &mut Vec<bool>,
        slab: &Slab,
        j: usize,
        row: &mut [f32],
    ) -> u64 {
        let [a, b, c] = self.perm;
        let lb = &slab.lines_b[j];
        // Per index cell along c: clear through the slab over every cell
        // along b this row's segments span (none without skipping).
        clear.clear();
        if !slab.clear_columns.is_empty() {
            let (b0, b1) = (lb.cells.0 as usize, lb.cells.1 as usize);
            let nc = slab.cells_c;
            let column_row = |cb_i: usize| &slab.clear_columns[cb_i * nc..(cb_i + 1) * nc];
            clear.extend_from_slice(column_row(b0));
            for cb_i in b0 + 1..=b1 {
                clear
                    .iter_mut()
                    .zip(column_row(cb_i))
                    .for_each(|(x, &y)| *x &= y);
            }
            // Most rows have no segment left.
            if clear.iter().all(|&c| c) {
                return 0;
            }
        }
        let mut samples = 0;
        for (out, lc) in row.iter_mut().zip(&slab.lines_c) {
            let clear = !clear.is_empty()
                && (lc.cells.0 as usize..=lc.cells.1 as usize).all(|cc_i| clear[cc_i]);
            if !clear {
                let (full, u_exit) = Self::reach(slab, lb, lc);
                let u = if full { slab.u_full } else { u_exit };
                let mut x = Vec3::ZERO;
                x[a] = slab.xa;
                x[b] = lb.x;
                x[c] = lc.x;
                let (t, s) = self.segment(depth, x, u);
                samples += s;
                *out = t;
            }
        }
        samples
    }

    /// Second pass over row `j` of a slab: each point whose segment
    /// reaches the upstream slab takes the transmittance arriving there
    /// (blended from the two upstream rows it lies between, the same one
    /// twice on a one-point axis, along c, then b) times its own.
    fn upstream(&self, up: &Upstream, j: usize, row: &mut [f32], prev_slab: &[f32]) {
        let [_, b, c] = self.perm;
        let (gb, gc) = (self.g[b], self.g[c]);
        let (ib, fb) = (up.b.index[j] as usize, up.b.weight[j]);
        let exit_b = up.b.u_exit[j];
        let up0 = &prev_slab[ib * gc..(ib + 1) * gc];
        let up1 = if gb > 1 {
            &prev_slab[(ib + 1) * gc..(ib + 2) * gc]
        } else {
            up0
        };
        let sc = usize::from(gc > 1);
        let lerp = |x: f32, y: f32, f: f32| x + (y - x) * f;
        let lines = &up.c;
        let one = |k: usize, out: &mut f32| {
            if exit_b.min(lines.u_exit[k]) >= up.u_full {
                let (ic, fc) = (lines.index[k] as usize, lines.weight[k]);
                let arriving = lerp(
                    lerp(up0[ic], up0[ic + sc], fc),
                    lerp(up1[ic], up1[ic + sc], fc),
                    fb,
                );
                *out *= arriving;
            }
        };
        #[cfg(target_arch = "x86_64")]
        if volcore::lanes::avx2_available() {
            let rows = UpstreamRows { up0, up1, sc, fb };
            // SAFETY: AVX2 was found.
            unsafe { avx2::upstream_row(&rows, (exit_b, up.u_full), lines, row, one) };
            return;
        }
        row.iter_mut().enumerate().for_each(|(k, out)| one(k, out));
    }

    /// Transmittance over world length `u` from voxel point `x` toward the
    /// light, and the samples taken (about one per step, at midpoints).
    fn segment(&self, depth_at: &mut impl FnMut(Vec3) -> f32, x: Vec3, u: f32) -> (f32, u64) {
        if u.is_nan() || u <= 0.0 {
            return (1.0, 0);
        }
        let count = ((u / self.spacing) as f64).ceil().clamp(1.0, 1e6) as u32;
        let h = u / count as f32;
        let mut depth = 0.0f32;
        for s in 0..count {
            let p = x + self.lv * (h * (s as f32 + 0.5));
            depth += depth_at(p);
        }
        let depth = depth * (h / self.step);
        ((-depth).exp(), count as u64)
    }
}

/// One grid line of a slab along one of the other two axes.
struct Line {
    /// Voxel coordinate.
    x: f32,
    /// World distance along the light at which a segment leaves the volume
    /// through a face across this axis.
    u_exit: f32,
    /// The upstream point's lower grid index and weight on this axis.
    upstream: (usize, f32),
    /// First and last index cell the segment's box spans on this axis.
    cells: (u64, u64),
}

/// What the rows of one slab share (see `Sweep::slab`).
struct Slab {
    xa: f32,
    u_full: f32,
    lines_b: Vec<Line>,
    lines_c: Vec<Line>,
    /// Per (cell along b, cell along c), row-major: clear through the
    /// slab's depth (empty without skipping).
    clear_columns: Vec<bool>,
    cells_c: usize,
}

/// What the upstream pass needs of a slab: the full segment's length and,
/// per grid line along b and along c, the upstream point and where a
/// segment leaves the volume (a third of a slab's lines in size, kept for
/// every slab between the passes).
struct Upstream {
    u_full: f32,
    b: Lines,
    c: Lines,
}

impl Upstream {
    fn of(slab: &Slab) -> Upstream {
        Upstream {
            u_full: slab.u_full,
            b: Lines::of(&slab.lines_b),
            c: Lines::of(&slab.lines_c),
        }
    }
}

/// Per grid line, the upstream point's lower index and weight and where a
/// segment leaves the volume, each in its own array (lanes read eight of
/// each at once).
struct Lines {
    index: Vec<u32>,
    weight: Vec<f32>,
    u_exit: Vec<f32>,
}

impl Lines {
    fn of(lines: &[Line]) -> Lines {
        Lines {
            // Grid indices fit a u32: a grid past 2^32 points per axis
            // is past any budget.
            index: lines.iter().map(|l| l.upstream.0 as u32).collect(),
            weight: lines.iter().map(|l| l.upstream.1).collect(),
            u_exit: lines.iter().map(|l| l.u_exit).collect(),
        }
    }
}

/// The two upstream rows a row of the upstream pass blends, their step
/// along c (0 on a one-point axis) and the weight between them.
#[cfg(target_arch = "x86_64")]
struct UpstreamRows<'a> {
    up0: &'a [f32],
    up1: &'a [f32],
    sc: usize,
    fb: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_coordinates_cover_uneven_last_cells() {
        // 10 voxels, divisor 4: points at 0, 4, 8, 9.
        assert_eq!(points(10, 4), 4);
        assert_eq!(position(3, 10, 4), 9.0);
        assert_eq!(grid_coord(0.0, 10, 4, 4), 0.0);
        assert_eq!(grid_coord(4.0, 10, 4, 4), 1.0);
        assert_eq!(grid_coord(8.0, 10, 4, 4), 2.0);
        assert_eq!(grid_coord(8.5, 10, 4, 4), 2.5);
        assert_eq!(grid_coord(9.0, 10, 4, 4), 3.0);
        assert_eq!(grid_coord(99.0, 10, 4, 4), 3.0);
        assert_eq!(points(1, 2), 1);
        assert_eq!(grid_coord(0.0, 1, 1, 2), 0.0);
        assert_eq!(split(3.0, 4), (2, 1.0));
    }

    /// Eight points read in lanes give each point's one-by-one
    /// transmittance bit for bit: random grids of uneven last cells in
    /// every storage order, points inside, outside, on grid points, on
    /// the last cell, NaN, -0 and infinite.
    #[test]
    fn eight_reads_at_once_match_one_by_one() {
        let mut rng = fastrand::Rng::with_seed(3);
        let mut checked = 0;
        for (n, div, perm) in [
            ([10, 9, 17], 4, [2, 0, 1]),
            ([33, 2, 8], 1, [0, 1, 2]),
            ([40, 41, 42], 2, [1, 2, 0]),
            ([7, 300, 5], 4, [1, 0, 2]),
        ] {
            let g = n.map(|n| points(n, div));
            let total: usize = g.iter().product();
            let grid = LightGrid {
                perm,
                g,
                axes: perm.map(|ax| GridAxis::new(n[ax], g[ax], div)),
                data: (0..total)
                    .map(|i| match i % 13 {
                        0 => 0.0,
                        1 => 1.0,
                        _ => rng.f32() * 1.2 - 0.1,
                    })
                    .collect(),
                lanes: volcore::lanes::avx2_available(),
                build_s: 0.0,
                samples: 0,
            };
            for _ in 0..2000 {
                let mut p = [[0f32; 8]; 3];
                for (a, axis) in p.iter_mut().enumerate() {
                    let hi = (n[a] - 1) as f32;
                    for x in axis.iter_mut() {
                        *x = match rng.usize(0..12) {
                            0 => f32::NAN,
                            1 => -0.0,
                            2 => f32::INFINITY,
                            3 => -3.5,
                            4 => hi,
                            5 => (rng.usize(0..n[a]) / div * div) as f32,
                            6 => hi - rng.f32() * div as f32,
                            _ => rng.f32() * (hi + 4.0) - 2.0,
                        };
                    }
                }
                let Some(got) = grid.transmittance8(&p) else {
                    assert!(!volcore::lanes::avx2_available());
                    return;
                };
                for (i, got) in got.iter().enumerate() {
                    let want = grid.transmittance(Vec3::new(p[0][i], p[1][i], p[2][i]));
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "{n:?} / {div}: lane {i} of {p:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 4 * 2000 * 8);
    }

    /// The upstream pass's rows blended in lanes give the scalar pass's
    /// bits, over rows whose upstream points are neighbours and rows
    /// where some are not, exits on both sides of the full segment, and
    /// rows shorter than eight.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn upstream_rows_in_lanes_match_one_by_one() {
        if !volcore::lanes::avx2_available() {
            return;
        }
        let mut rng = fastrand::Rng::with_seed(5);
        let (mut in_lanes, mut alone) = (0, 0);
        for round in 0..400 {
            let gc = rng.usize(1..50);
            let sc = usize::from(gc > 1);
            let value = |rng: &mut fastrand::Rng| match rng.usize(0..10) {
                0 => 0.0,
                1 => 1.0,
                _ => rng.f32(),
            };
            let up0: Vec<f32> = (0..gc).map(|_| value(&mut rng)).collect();
            let up1: Vec<f32> = (0..gc).map(|_| value(&mut rng)).collect();
            let shift = rng.usize(0..2);
            let index: Vec<u32> = (0..gc)
                .map(|k| {
                    let i = if round % 3 == 0 && rng.usize(0..6) == 0 {
                        rng.usize(0..gc)
                    } else {
                        k + shift
                    };
                    i.min(gc.saturating_sub(2)) as u32
                })
                .collect();
            let u_full = 4.0;
            let exit = |rng: &mut fastrand::Rng| match rng.usize(0..6) {
                0 => u_full,
                1 => f32::INFINITY,
                2 => 0.0,
                _ => rng.f32() * 8.0,
            };
            let lines = Lines {
                index,
                weight: (0..gc).map(|_| rng.f32()).collect(),
                u_exit: (0..gc).map(|_| exit(&mut rng)).collect(),
            };
            let (exit_b, fb) = (exit(&mut rng), rng.f32());
            let lerp = |x: f32, y: f32, f: f32| x + (y - x) * f;
            let own: Vec<f32> = (0..gc).map(|_| value(&mut rng)).collect();
            let scalar = |k: usize| {
                if exit_b.min(lines.u_exit[k]) >= u_full {
                    let (ic, fc) = (lines.index[k] as usize, lines.weight[k]);
                    lerp(
                        lerp(up0[ic], up0[ic + sc], fc),
                        lerp(up1[ic], up1[ic + sc], fc),
                        fb,
                    ) * own[k]
                } else {
                    own[k]
                }
            };
            let mut row = own.clone();
            let mut by_one = vec![false; gc];
            let up = UpstreamRows {
                up0: &up0,
                up1: &up1,
                sc,
                fb,
            };
            // SAFETY: AVX2 was found above.
            unsafe {
                avx2::upstream_row(&up, (exit_b, u_full), &lines, &mut row, |k, out| {
                    by_one[k] = true;
                    *out = scalar(k);
                });
            }
            for (k, got) in row.iter().enumerate() {
                assert_eq!(
                    got.to_bits(),
                    scalar(k).to_bits(),
                    "round {round}, point {k}"
                );
                if by_one[k] {
                    alone += 1;
                } else {
                    in_lanes += 1;
                }
            }
        }
        // Both ways were taken.
        assert!(in_lanes > 1000 && alone > 1000, "{in_lanes} / {alone}");
    }

    #[test]
    fn grid_bytes_are_checked() {
        assert_eq!(LightGrid::bytes_for([9, 9, 9], 4), Some(27 * 4));
        assert_eq!(LightGrid::bytes_for([usize::MAX; 3], 1), None);
    }
}
