//! The macrocells a ray crosses, in order along it: a 3D DDA over one
//! level of the index, yielding segments `(t_enter, t_exit, cell)` (the
//! shape of pbrt's majorant iterator). Shadow rays and delta tracking walk
//! these segments with each cell's majorant ([`super::majorant`]).
//!
//! A cell of edge `E` covers the voxel-space points whose sampler cell
//! (clamp to the volume, then floor) falls in `[c·E, (c + 1)·E)` per axis;
//! segment boundaries are where the ray crosses those planes, computed in
//! f64 from the cell itself (no accumulated increments), so the segments
//! tile `[t0, t1]` exactly and in order.

use super::VoxelRay;
use volcore::Dims;
use volindex::Level;

/// One cell's stretch of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Ray parameter where the ray enters the cell (or the range starts).
    pub t0: f32,
    /// Ray parameter where it leaves (or the range ends).
    pub t1: f32,
    /// The cell's coordinates in its level.
    pub cell: [u64; 3],
    /// The cell's linear index in its level.
    pub index: usize,
}

/// Iterator over the cells of one grid along a ray (see [`segments`] and
/// [`voxel_segments`]).
pub struct Segments {
    cells: [u64; 3],
    ray: VoxelRay,
    edge: f64,
    cell: [i64; 3],
    step: [i64; 3],
    t: f64,
    t_end: f64,
    done: bool,
}

/// The segments of `ray` over `[t0, t1]` (a range inside the volume's box,
/// as the ray–box test gives it) through the cells of `level`, for a
/// volume whose voxel box is `[0, hi]` per axis (`hi = dims − 1`).
pub fn segments(level: &Level, hi: [f32; 3], ray: &VoxelRay, t0: f32, t1: f32) -> Segments {
    Segments::new(level.cells(), level.edge(), hi, ray, t0, t1)
}

/// The segments of `ray` over `[t0, t1]` through the voxel cells of a
/// volume of `dims` (`hi = dims − 1`): cell `c` is where the sampler reads
/// the eight voxels from `c` on (`Cursor::cell`), so a cell's segment sees
/// only blends of those eight values. The last cell per axis holds the
/// points on the volume's far face.
pub fn voxel_segments(dims: Dims, hi: [f32; 3], ray: &VoxelRay, t0: f32, t1: f32) -> Segments {
    Segments::new(dims.as_array(), 1, hi, ray, t0, t1)
}

impl Segments {
    fn new(cells: [u64; 3], edge: u64, hi: [f32; 3], ray: &VoxelRay, t0: f32, t1: f32) -> Segments {
        let edge = edge as f64;
        let p = ray.at(t0);
        let cell = std::array::from_fn(|a| {
            let c = if p[a] > 0.0 { p[a].min(hi[a]) } else { 0.0 };
            ((c as f64 / edge).floor() as i64).clamp(0, cells[a] as i64 - 1)
        });
        let step = std::array::from_fn(|a| {
            if ray.d[a] > 0.0 {
                1
            } else if ray.d[a] < 0.0 {
                -1
            } else {
                0
            }
        });
        Segments {
            cells,
            ray: *ray,
            edge,
            cell,
            step,
            t: t0 as f64,
            t_end: t1 as f64,
            done: t0 > t1 || t0.is_nan() || t1.is_nan(),
        }
    }

    /// Ray parameter at which the ray leaves the current cell along axis
    /// `a` (infinite if it does not move along it).
    fn exit(&self, a: usize) -> f64 {
        let face = match self.step[a] {
            1 => (self.cell[a] + 1) as f64 * self.edge,
            -1 => self.cell[a] as f64 * self.edge,
            _ => return f64::INFINITY,
        };
        (face - self.ray.o[a] as f64) * self.ray.inv_d[a]
    }
}

impl Iterator for Segments {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        if self.done {
            return None;
        }
        let exits = [self.exit(0), self.exit(1), self.exit(2)];
        let mut axis = 0;
        for a in 1..3 {
            if exits[a] < exits[axis] {
                axis = a;
            }
        }
        let cells = self.cells;
        let next = self.cell[axis] + self.step[axis];
        // The last cell ends where the range does (the box face and the
        // grid's outer plane round differently, or lie apart).
        let last = self.step[axis] == 0 || next < 0 || next >= cells[axis] as i64;
        let end = if last {
            self.t_end
        } else {
            exits[axis].min(self.t_end).max(self.t)
        };
        let c = self.cell.map(|c| c as u64);
        let seg = Segment {
            t0: self.t as f32,
            t1: end as f32,
            cell: c,
            index: (c[0] + cells[0] * (c[1] + cells[1] * c[2])) as usize,
        };
        self.cell[axis] = next;
        self.t = end;
        if last || end >= self.t_end {
            self.done = true;
        }
        Some(seg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::{intersect_box, Ray};
    use glam::Vec3;
    use volcore::grid::Locator;
    use volcore::region::pack_sliced;
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::Dims;
    use volindex::{BuildOptions, MinMaxIndex};

    /// Segments tile the ray's range in order, and every point inside a
    /// segment (away from its ends by more than rounding) is in the
    /// segment's cell as the sampler finds cells.
    #[test]
    fn segments_tile_the_ray_and_name_the_sampler_cell() {
        let dims = Dims::new(61, 40, 33).unwrap();
        let v = volcore::Volume::from_samples(
            dims,
            pack_sliced(&SceneSource::<u8>::new(&ShapesScene::new(
                dims, 1, 5, 10, 100.0,
            ))),
        )
        .unwrap();
        let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
        let loc = Locator::new(dims);
        let hi = [60.0, 39.0, 32.0];
        let mut rng = fastrand::Rng::with_seed(7);
        let mut checked = 0;
        for n in 0..3000 {
            let level = ix.level(n % ix.level_count());
            let e = level.edge();
            let around = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let mut origin = Vec3::from(hi) * 0.5 + around.normalize_or_zero() * 90.0;
            let target = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * Vec3::from(hi);
            let mut dir = (target - origin).normalize();
            if n % 5 == 0 {
                // Axis-parallel rays, on cell planes now and then.
                let a = n % 3;
                dir = Vec3::ZERO;
                dir[a] = if n % 2 == 0 { 1.0 } else { -1.0 };
                origin = target - dir * 100.0;
                if n % 10 == 0 {
                    origin[(a + 1) % 3] = (e as f32 * 2.0).min(hi[(a + 1) % 3]);
                }
            }
            let ray = Ray { origin, dir };
            let Some((t0, t1)) = intersect_box(&ray, Vec3::ZERO, Vec3::from(hi)) else {
                continue;
            };
            let vr = VoxelRay::new(ray.origin, ray.dir);
            let segs: Vec<Segment> = segments(level, hi, &vr, t0, t1).collect();
            assert!(!segs.is_empty());
            assert_eq!(segs[0].t0, t0, "ray {n}");
            assert_eq!(segs.last().unwrap().t1, t1, "ray {n}");
            for w in segs.windows(2) {
                assert_eq!(w[0].t1, w[1].t0, "ray {n}: gap");
                assert!(w[0].t0 <= w[0].t1);
            }
            for s in &segs {
                let len = s.t1 - s.t0;
                if len < 1e-3 {
                    continue;
                }
                for f in [0.01f32, 0.5, 0.99] {
                    let p = vr.at(s.t0 + len * f);
                    let vox = loc.voxel(p.into());
                    let cell = vox.map(|c| c / e);
                    assert_eq!(cell, s.cell, "ray {n} level edge {e}: point {p}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 20_000, "{checked}");
    }

    #[test]
    fn an_empty_range_gives_no_segment_and_a_point_gives_one() {
        let dims = Dims::new(16, 16, 16).unwrap();
        let v = volcore::Volume::from_samples(dims, vec![0u8; 16 * 16 * 16]).unwrap();
        let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
        let vr = VoxelRay::new(Vec3::new(-1.0, 3.0, 3.0), Vec3::X);
        let hi = [15.0; 3];
        assert_eq!(segments(ix.level(0), hi, &vr, 5.0, 4.0).count(), 0);
        let one: Vec<_> = segments(ix.level(0), hi, &vr, 5.0, 5.0).collect();
        assert_eq!(one.len(), 1);
        assert_eq!((one[0].t0, one[0].t1, one[0].cell), (5.0, 5.0, [0, 0, 0]));
        let all: Vec<_> = segments(ix.level(0), hi, &vr, 1.0, 16.0).collect();
        assert_eq!(all.len(), 2);
        assert_eq!((all[0].t1, all[1].cell), (9.0, [1, 0, 0]));
    }
}
