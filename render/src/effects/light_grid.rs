//! A light-transmittance grid for one directional light.
//!
//! Grid points sit every `divisor` voxels along each axis (the last one on
//! the volume's far face). The grid is swept in slabs along the axis the
//! light's voxel-space direction is longest in, starting from the slab
//! nearest the light (transmittance 1): each point looks one slab toward
//! the light, takes the transmittance there by bilinear interpolation, and
//! multiplies in the segment between, sampled about one shadow step apart.
//! A segment that leaves the volume through a side face ends there
//! (nothing outside blocks light). Points within a slab are independent,
//! so each slab is computed on all threads and the grid does not depend on
//! the thread count. At render time the grid is read trilinearly.
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
use volcore::{Cursor, VoxelSource};

/// Transmittance toward one light at every grid point.
#[derive(Clone, Debug)]
pub struct LightGrid {
    /// Volume axes in storage order: the sweep axis first.
    perm: [usize; 3],
    /// Grid points per volume axis.
    g: [usize; 3],
    /// Volume dims per axis.
    n: [usize; 3],
    div: usize,
    data: Vec<f32>,
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
        let start = Instant::now();
        let div = divisor.max(1) as usize;
        let d = src.cursor().dims();
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
            occ,
            q,
            lv,
            perm,
            g,
            n,
            div,
            step,
            spacing: spacing_of_samples,
            clear,
        };
        let mut samples = 0u64;
        // The first slab (nearest the light) keeps transmittance 1.
        for s in 1..g[a] {
            let (i, prev) = if towards_plus {
                (g[a] - 1 - s, g[a] - s)
            } else {
                (s, s - 1)
            };
            let (cur_slab, prev_slab) = if towards_plus {
                let (head, tail) = data.split_at_mut(prev * slice_len);
                (&mut head[i * slice_len..], &tail[..slice_len])
            } else {
                let (head, tail) = data.split_at_mut(i * slice_len);
                (&mut tail[..slice_len], &head[prev * slice_len..])
            };
            let prev_slab: &[f32] = prev_slab;
            samples += cur_slab
                .par_chunks_mut(g[c])
                .enumerate()
                .map_init(
                    || src.cursor(),
                    |cur, (j, row)| sweep.row(cur, i, prev, j, row, prev_slab),
                )
                .sum::<u64>();
        }
        Ok(LightGrid {
            perm,
            g,
            n,
            div,
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
        let coord = |ax: usize| {
            let cc = grid_coord(p[ax], self.n[ax], self.g[ax], self.div);
            split(cc, self.g[ax])
        };
        let ((ia, fa), (ib, fb), (ic, fc)) = (coord(a), coord(b), coord(c));
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

/// What every point of a sweep needs.
struct Sweep<'o, O: Occluder> {
    occ: &'o O,
    q: O::Query,
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

impl<O: Occluder> Sweep<'_, O> {
    /// Row `j` of slab `i`, looking toward slab `prev`; returns the samples
    /// taken.
    fn row<C: Cursor>(
        &self,
        cur: &mut C,
        i: usize,
        prev: usize,
        j: usize,
        row: &mut [f32],
        prev_slab: &[f32],
    ) -> u64 {
        let [a, b, c] = self.perm;
        let (n, g, div) = (self.n, self.g, self.div);
        let lv = self.lv;
        let delta = position(prev, n[a], div) - position(i, n[a], div);
        // World distance to the previous slab along the light.
        let u_full = delta / lv[a];
        let mut samples = 0;
        for (k, out) in row.iter_mut().enumerate() {
            let mut x = Vec3::ZERO;
            x[a] = position(i, n[a], div);
            x[b] = position(j, n[b], div);
            x[c] = position(k, n[c], div);
            // Where the segment leaves the volume through a side face.
            let mut u_exit = f32::INFINITY;
            for ax in [b, c] {
                let hi = (n[ax] - 1) as f32;
                let u = if lv[ax] > 0.0 {
                    (hi - x[ax]) / lv[ax]
                } else if lv[ax] < 0.0 {
                    -x[ax] / lv[ax]
                } else {
                    f32::INFINITY
                };
                u_exit = u_exit.min(u);
            }
            let (u, upstream) = if u_exit >= u_full {
                let y = x + lv * u_full;
                let yb = grid_coord(y[b], n[b], g[b], div);
                let yc = grid_coord(y[c], n[c], g[c], div);
                (u_full, bilinear(prev_slab, g[b], g[c], yb, yc))
            } else {
                (u_exit, 1.0)
            };
            let (t, s) = self.segment(cur, x, u);
            samples += s;
            *out = upstream * t;
        }
        samples
    }

    /// Transmittance over world length `u` from voxel point `x` toward the
    /// light, and the samples taken (about one per step, at midpoints).
    fn segment<C: Cursor>(&self, cur: &mut C, x: Vec3, u: f32) -> (f32, u64) {
        if u.is_nan() || u <= 0.0 {
            return (1.0, 0);
        }
        if let Some(c) = self.clear {
            let y = x + self.lv * u;
            if c.clear(x.min(y), x.max(y)) {
                return (1.0, 0);
            }
        }
        let count = ((u / self.spacing) as f64).ceil().clamp(1.0, 1e6) as u32;
        let h = u / count as f32;
        let mut depth = 0.0f32;
        for s in 0..count {
            let p = x + self.lv * (h * (s as f32 + 0.5));
            depth += self.occ.depth(cur, p, self.q);
        }
        let depth = depth * (h / self.step);
        ((-depth).exp(), count as u64)
    }
}

/// Bilinear read of a `gb × gc` slab at grid coordinates `(yb, yc)`.
fn bilinear(slab: &[f32], gb: usize, gc: usize, yb: f32, yc: f32) -> f32 {
    let (ib, fb) = split(yb, gb);
    let (ic, fc) = split(yc, gc);
    let sb = if gb > 1 { gc } else { 0 };
    let sc = usize::from(gc > 1);
    let base = ib * gc + ic;
    let lerp = |x: f32, y: f32, f: f32| x + (y - x) * f;
    lerp(
        lerp(slab[base], slab[base + sc], fc),
        lerp(slab[base + sb], slab[base + sb + sc], fc),
        fb,
    )
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

    #[test]
    fn grid_bytes_are_checked() {
        assert_eq!(LightGrid::bytes_for([9, 9, 9], 4), Some(27 * 4));
        assert_eq!(LightGrid::bytes_for([usize::MAX; 3], 1), None);
    }
}
