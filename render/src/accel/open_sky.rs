//! Where the way to a distant light becomes clear.
//!
//! A shadow ray toward a directional light marches on, skipping clear
//! cells one by one, until it leaves the volume. Past the last busy cell
//! on its way, nothing it could still sample adds optical depth: it may
//! stop there, with the same depth to the bit (every sample it leaves out
//! would have added exactly zero). This module finds that point for any
//! ray in one lookup, once its map is built (per frame and light).
//!
//! Method: project the volume along the light's direction onto the plane
//! across the direction's largest axis (a parallel projection, so a ray is
//! one point of the plane and climbs toward the light above it). A raster
//! of that plane holds, per pixel, the highest point (toward the light) of
//! any busy level-0 cell whose projected bounding rectangle touches the
//! pixel. A ray whose point falls in a pixel meets no busy cell above
//! that pixel's height. Rectangles cover the projected boxes and every
//! pixel they touch counts, so the map only errs high (a ray marches a
//! little longer than it needs, never shorter); rectangles and heights are
//! widened by a margin far above the rounding of sample positions, as the
//! skipping hierarchy's margins are.

use glam::Vec3;
use volindex::MinMaxIndex;

/// Most pixels a map may have (64 MiB of heights).
const MAX_PIXELS: usize = 1 << 24;

/// For one distant light, per column along its direction, the height
/// above which no busy cell lies (see the module notes).
pub struct OpenSky {
    proj: Projection,
    /// Lower corner of the raster in the plane.
    origin: [f64; 2],
    /// Pixel edge, voxels, and its reciprocal.
    pixel: f64,
    per_pixel: f64,
    /// Pixels along the two plane axes.
    n: [usize; 2],
    /// Per pixel, the highest busy point (with the margin), or −∞.
    top: Vec<f32>,
    /// `1 / |d_a|`: ray parameter per unit of height.
    t_per_height: f64,
}

/// A parallel projection along a direction: the two plane coordinates of
/// a point and its height toward the light.
#[derive(Clone, Copy, Debug)]
struct Projection {
    /// The direction's largest axis, and the other two.
    a: usize,
    b: usize,
    c: usize,
    /// The direction's `b` and `c` components over its `a` component.
    rb: f64,
    rc: f64,
    /// The sign of the `a` component (heights grow toward the light).
    s: f64,
}

/// A box's projected bounding rectangle and its height range.
struct Footprint {
    u: [f64; 2],
    v: [f64; 2],
    h: [f64; 2],
}

impl Projection {
    fn new(d: [f64; 3]) -> Option<Projection> {
        let a = (0..3).max_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()))?;
        if !(d[a].abs() > 0.0 && d.iter().all(|x| x.is_finite())) {
            return None;
        }
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        Some(Projection {
            a,
            b,
            c,
            rb: d[b] / d[a],
            rc: d[c] / d[a],
            s: d[a].signum(),
        })
    }

    /// A point's plane coordinates and height.
    fn point(&self, x: [f64; 3]) -> ([f64; 2], f64) {
        (
            [
                x[self.b] - self.rb * x[self.a],
                x[self.c] - self.rc * x[self.a],
            ],
            self.s * x[self.a],
        )
    }

    /// The footprint of the box `[lo, hi]`.
    fn footprint(&self, lo: [f64; 3], hi: [f64; 3]) -> Footprint {
        let along = |r: f64| {
            let (p, q) = (r * lo[self.a], r * hi[self.a]);
            (p.min(q), p.max(q))
        };
        let (bmin, bmax) = along(self.rb);
        let (cmin, cmax) = along(self.rc);
        let (h0, h1) = (self.s * lo[self.a], self.s * hi[self.a]);
        Footprint {
            u: [lo[self.b] - bmax, hi[self.b] - bmin],
            v: [lo[self.c] - cmax, hi[self.c] - cmin],
            h: [h0.min(h1), h0.max(h1)],
        }
    }
}

impl OpenSky {
    /// The map of `index`'s finest level for a light in voxel-space
    /// direction `toward` (the direction shadow rays travel, in voxels per
    /// unit of the ray parameter), where `busy(cell)` tells the level-0
    /// cells (linear index) the skipping rule keeps. `None` when the
    /// direction has none.
    pub fn build(
        index: &MinMaxIndex,
        busy: impl Fn(usize) -> bool,
        toward: Vec3,
    ) -> Option<OpenSky> {
        let level = index.levels().first()?;
        let d = toward.to_array().map(f64::from);
        let proj = Projection::new(d)?;
        let cells = level.cells();
        let edge = level.edge() as f64;
        let dims = index.dims().as_array();
        // Sample points are clamped to [0, dims − 1].
        let top = dims.map(|d| d.saturating_sub(1) as f64);
        let largest = top.iter().fold(1.0f64, |m, &t| m.max(t));
        // Ten times the hierarchy's margin: far above the rounding of a
        // sample's position (and of its clamp) at this size.
        let margin = (largest * 10.0 / (1u64 << 20) as f64).max(1e-2);
        let whole = proj.footprint([0.0; 3], top);
        let origin = [whole.u[0] - 2.0 * margin, whole.v[0] - 2.0 * margin];
        // A quarter of a cell, coarser if the raster would grow too big.
        let mut pixel = (edge / 4.0).max(1.0);
        let span =
            |iv: [f64; 2], pixel: f64| ((iv[1] - iv[0] + 4.0 * margin) / pixel).ceil() as usize + 1;
        let mut n = [span(whole.u, pixel), span(whole.v, pixel)];
        while n[0].saturating_mul(n[1]) > MAX_PIXELS {
            pixel *= 2.0;
            n = [span(whole.u, pixel), span(whole.v, pixel)];
        }
        let mut map = OpenSky {
            proj,
            origin,
            pixel,
            per_pixel: 1.0 / pixel,
            n,
            top: vec![f32::NEG_INFINITY; n[0] * n[1]],
            t_per_height: 1.0 / d[proj.a].abs(),
        };
        let (nx, ny) = (cells[0], cells[1]);
        for cell in (0..level.len()).filter(|&i| busy(i)) {
            let i = cell as u64;
            let c = [i % nx, (i / nx) % ny, i / (nx * ny)];
            let lo = std::array::from_fn(|x| (c[x] as f64 * edge).min(top[x]));
            let hi = std::array::from_fn(|x| ((c[x] + 1) as f64 * edge).min(top[x]));
            let f = proj.footprint(lo, hi);
            // Rounded up to f32: the map may only err high.
            let h = next_up(f.h[1] + margin);
            let [u0, u1] = map.pixels(0, f.u[0] - margin, f.u[1] + margin);
            let [v0, v1] = map.pixels(1, f.v[0] - margin, f.v[1] + margin);
            for v in v0..=v1 {
                for t in &mut map.top[v * n[0] + u0..=v * n[0] + u1] {
                    *t = t.max(h);
                }
            }
        }
        Some(map)
    }

    /// The pixels along plane axis `axis` that `[lo, hi]` touches,
    /// clamped to the raster.
    fn pixels(&self, axis: usize, lo: f64, hi: f64) -> [usize; 2] {
        let n = self.n[axis];
        let i = |x: f64| {
            let p = ((x - self.origin[axis]) / self.pixel).floor();
            (p.max(0.0) as usize).min(n - 1)
        };
        [i(lo), i(hi)]
    }

    /// The ray parameter past which the ray from voxel-space point `o`
    /// along the map's direction meets no busy cell: every sample it
    /// takes later adds nothing. Infinite where the map cannot tell
    /// (outside its raster or for a non-finite point).
    #[inline]
    pub fn clear_after(&self, o: Vec3) -> f32 {
        let (uv, h) = self.proj.point(o.to_array().map(f64::from));
        let mut at = 0;
        for (axis, &x) in uv.iter().enumerate() {
            let p = (x - self.origin[axis]) * self.per_pixel;
            if !(p >= 0.0 && p < self.n[axis] as f64) {
                return f32::INFINITY;
            }
            at += (p as usize) * if axis == 0 { 1 } else { self.n[0] };
        }
        let above = f64::from(self.top[at]) - h;
        if above == f64::NEG_INFINITY {
            return 0.0;
        }
        // Rounded up, so no sample before the point is cut.
        next_up(above.max(0.0) * self.t_per_height)
    }

    /// Bytes the map takes.
    pub fn bytes(&self) -> u64 {
        (self.top.len() * std::mem::size_of::<f32>()) as u64
    }
}

/// `x` as an f32 no smaller than `x`.
fn next_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) >= x {
        f
    } else {
        f.next_up()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::grid::Locator;
    use volcore::Dims;
    use volindex::BuildOptions;

    fn index(dims: [u64; 3], busy_voxels: &[[u64; 3]]) -> MinMaxIndex {
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let mut v = vec![0u8; n];
        for b in busy_voxels {
            v[(b[0] + dims[0] * (b[1] + dims[1] * b[2])) as usize] = 200;
        }
        let dims = Dims::new(dims[0], dims[1], dims[2]).unwrap();
        let vol = volcore::Volume::from_samples(dims, v).unwrap();
        let opts = BuildOptions {
            cell_edge: 8,
            ..BuildOptions::default()
        };
        MinMaxIndex::build_volume(&vol, &opts, 0).unwrap()
    }

    /// The level-0 cell the sampler reads at `p`.
    fn cell_at(ix: &MinMaxIndex, loc: &Locator, p: Vec3) -> usize {
        let l0 = &ix.levels()[0];
        let (c, e) = (l0.cells(), l0.edge());
        let v = loc.voxel(p.to_array());
        (v[0] / e + c[0] * (v[1] / e + c[1] * (v[2] / e))) as usize
    }

    /// Rays from many points (inside and on the faces of the volume)
    /// toward the light, sampled finely as f32 rays are: every sample past
    /// the map's point lies in a clear cell; and the map does not stop
    /// rays far later than the last busy sample.
    #[test]
    fn past_the_point_every_sample_is_in_a_clear_cell() {
        let dims = [80, 72, 64];
        let ix = index(
            dims,
            &[[20, 20, 20], [50, 10, 30], [5, 60, 8], [79, 71, 63]],
        );
        let flags: Vec<bool> = ix.levels()[0].max().iter().map(|&m| m > 0.0).collect();
        let busy = |i: usize| flags[i];
        let loc = Locator::new(Dims::new(dims[0], dims[1], dims[2]).unwrap());
        let top = dims.map(|x| (x - 1) as f32);
        let mut rng = fastrand::Rng::with_seed(3);
        let mut cut = 0;
        let mut late_rays = 0;
        for d in [
            Vec3::new(1.0, 2.0, 0.5),
            Vec3::new(-1.0, 0.3, -0.2),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.7, 0.7, 0.7),
            Vec3::new(-0.2, -0.1, 1.0) * 3.0,
        ] {
            let sky = OpenSky::build(&ix, busy, d).unwrap();
            let step = 0.2 / d.abs().max_element();
            for _ in 0..3000 {
                let o = Vec3::from(std::array::from_fn(|a| rng.f32() * top[a]));
                let t_clear = sky.clear_after(o);
                assert!(t_clear >= 0.0 && t_clear.is_finite());
                let mut last_busy = -1.0f32;
                let mut t = 0.0f32;
                while (0..3).all(|a| (o + d * t)[a] >= 0.0 && (o + d * t)[a] <= top[a]) {
                    if busy(cell_at(&ix, &loc, o + d * t)) {
                        assert!(t <= t_clear, "{d} from {o}: busy at {t} > {t_clear}");
                        last_busy = t;
                    }
                    t += step;
                }
                if last_busy < 0.0 && t_clear == 0.0 {
                    cut += 1;
                }
                // Rays the map stops more than two cells of height after
                // their last busy sample (before they leave the volume).
                let late = (t_clear - last_busy.max(0.0)) * d.abs().max_element();
                if late > 16.0 && t > t_clear {
                    late_rays += 1;
                }
            }
        }
        // Most rays in this nearly empty volume are cut at their start.
        assert!(cut > 6 * 3000 / 2, "{cut}");
        // The rectangles and pixels keep some rays going longer than they
        // need, but few.
        assert!(late_rays < 6 * 3000 / 20, "{late_rays} {cut}");
    }

    #[test]
    fn a_ray_under_a_busy_cell_marches_past_it_and_one_beside_it_does_not() {
        // One busy voxel in cell (2, 2, 2); light straight up +z.
        let ix = index([40, 40, 40], &[[20, 20, 20]]);
        let flags: Vec<bool> = ix.levels()[0].max().iter().map(|&m| m > 0.0).collect();
        let sky = OpenSky::build(&ix, |i| flags[i], Vec3::Z).unwrap();
        // From z = 2 under the cell: past its top (z = 24), not much more.
        let t = sky.clear_after(Vec3::new(20.0, 20.0, 2.0));
        assert!((22.0..23.0).contains(&t), "{t}");
        // Above it, or beside it: nothing to march.
        assert_eq!(sky.clear_after(Vec3::new(20.0, 20.0, 30.0)), 0.0);
        assert_eq!(sky.clear_after(Vec3::new(4.0, 4.0, 2.0)), 0.0);
        // Outside the raster: unknown.
        assert_eq!(sky.clear_after(Vec3::new(-500.0, 4.0, 2.0)), f32::INFINITY);
    }

    #[test]
    fn no_direction_gives_none() {
        let ix = index([16, 16, 16], &[]);
        assert!(OpenSky::build(&ix, |_| false, Vec3::ZERO).is_none());
        assert!(OpenSky::build(&ix, |_| false, Vec3::new(f32::NAN, 1.0, 0.0)).is_none());
    }
}
