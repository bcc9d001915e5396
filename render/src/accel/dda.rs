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
    /// `1 / edge`, for guesses (exact where a cell is decided).
    inv_edge: f64,
    cell: [i64; 3],
    step: [i64; 3],
    /// Per axis, the ray parameter at which the ray leaves `cell` along it
    /// ([`Segments::exit_of`] of the cell; kept, since a step changes one
    /// axis's cell and so one exit).
    exits: [f64; 3],
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
        // A power-of-two edge divides exactly as its reciprocal multiplies.
        let exact_inverse = edge.is_power_of_two();
        let edge = edge as f64;
        let inv_edge = 1.0 / edge;
        let p = ray.at(t0);
        let cell = std::array::from_fn(|a| {
            let c = if p[a] > 0.0 { p[a].min(hi[a]) } else { 0.0 };
            let q = if exact_inverse {
                c as f64 * inv_edge
            } else {
                c as f64 / edge
            };
            // c is 0 or more (NaN fails the test): truncation is the floor.
            (q as i64).clamp(0, cells[a] as i64 - 1)
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
        let mut s = Segments {
            cells,
            ray: *ray,
            edge,
            inv_edge,
            cell,
            step,
            exits: [f64::INFINITY; 3],
            t: t0 as f64,
            t_end: t1 as f64,
            done: t0 > t1 || t0.is_nan() || t1.is_nan(),
        };
        s.exits = std::array::from_fn(|a| s.exit_of(a, s.cell[a]));
        s
    }

    /// Ray parameter at which the ray leaves cell `c` of axis `a` along
    /// that axis (infinite if it does not move along it).
    #[inline(always)]
    fn exit_of(&self, a: usize, c: i64) -> f64 {
        let face = match self.step[a] {
            1 => (c + 1) as f64 * self.edge,
            -1 => c as f64 * self.edge,
            _ => return f64::INFINITY,
        };
        (face - self.ray.o[a] as f64) * self.ray.inv_d[a]
    }

    /// The linear index of the cell the next segment is in (`None` once
    /// the walk is over).
    #[inline(always)]
    pub fn upcoming(&self) -> Option<usize> {
        if self.done {
            return None;
        }
        let [x, y, z] = self.cell.map(|c| c as u64);
        let n = self.cells;
        Some((x + n[0] * (y + n[1] * z)) as usize)
    }

    /// Pass over the `d × d × d` block of cells that starts at the
    /// upcoming cell and extends `d − 1` cells ahead along each axis the
    /// ray moves along (the block [`super::distance::ahead`] measures):
    /// the segments after it are the very ones [`Iterator::next`] would
    /// have given after the block's own, the same `t` and cells bit for
    /// bit, since the exit is taken from the same cell faces and the cells
    /// along the other axes are found by the same (time, axis) order in
    /// which the step-by-step walk crosses faces. The caller vouches that
    /// the block holds nothing it needs (its cells are empty).
    pub fn jump(&mut self, d: u64) {
        if self.done || d == 0 {
            return;
        }
        let k = (d - 1).min(i64::MAX as u64 / 2) as i64;
        // The block's exit: the first of its far faces the ray meets (the
        // lowest axis on a tie, as `next` picks).
        let mut axis = 0;
        let mut t_exit = f64::INFINITY;
        for a in 0..3 {
            let e = self.exit_of(a, self.cell[a] + k * self.step[a]);
            if e < t_exit {
                t_exit = e;
                axis = a;
            }
        }
        let next = self.cell[axis] + (k + 1) * self.step[axis];
        if t_exit >= self.t_end || next < 0 || next >= self.cells[axis] as i64 {
            // The rest of the range lies in the block (or past the grid).
            self.done = true;
            return;
        }
        for b in 0..3 {
            if b == axis || self.step[b] == 0 {
                continue;
            }
            // Faces of axis b inside the block that the walk crosses before
            // the block's exit (earlier, or at the same time on a lower
            // axis): a guess from the point, then the faces themselves.
            let (c, s) = (self.cell[b], self.step[b]);
            let crossed = |m: i64| {
                let f = self.exit_of(b, c + m * s);
                f < t_exit || (f == t_exit && b < axis)
            };
            let p = self.ray.o[b] as f64 + self.ray.d[b] as f64 * t_exit;
            // (Truncation: a guess, which the faces then correct.)
            let guess = ((p * self.inv_edge) as i64)
                .saturating_sub(c)
                .saturating_mul(s);
            let mut m = guess.clamp(0, k);
            while m < k && crossed(m) {
                m += 1;
            }
            while m > 0 && !crossed(m - 1) {
                m -= 1;
            }
            let cb = c + m * s;
            if cb < 0 || cb >= self.cells[b] as i64 {
                // The walk left the grid along b inside the block (a face
                // rounded a hair before the range's end): it ends there.
                self.done = true;
                return;
            }
            self.cell[b] = cb;
            self.exits[b] = self.exit_of(b, cb);
        }
        self.cell[axis] = next;
        self.exits[axis] = self.exit_of(axis, next);
        self.t = t_exit.max(self.t);
    }
}

impl Iterator for Segments {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        if self.done {
            return None;
        }
        let exits = self.exits;
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
        self.exits[axis] = self.exit_of(axis, next);
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

    /// The index of a `vol-gen shapes`-like volume: `count` shapes of
    /// size `size`, from `seed`.
    fn shapes_index(dims: Dims, seed: u64, count: usize, size: u64) -> MinMaxIndex {
        let scene = ShapesScene::new(dims, seed, count, size, 100.0);
        let v = volcore::Volume::from_samples(dims, pack_sliced(&SceneSource::<u8>::new(&scene)))
            .unwrap();
        MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap()
    }

    /// Segments tile the ray's range in order, and every point inside a
    /// segment (away from its ends by more than rounding) is in the
    /// segment's cell as the sampler finds cells.
    #[test]
    fn segments_tile_the_ray_and_name_the_sampler_cell() {
        let dims = Dims::new(61, 40, 33).unwrap();
        let ix = shapes_index(dims, 1, 5, 10);
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

    /// Jumping across the blocks the octant distances measure leaves
    /// every kept cell's segment as the cell-by-cell walk gives it, bit for
    /// bit and in order: random rays from near and far, axis-parallel rays
    /// on cell planes, and diagonals through cell corners (ties on two and
    /// three axes), on a grid whose last cells are partial.
    #[test]
    fn jumps_keep_every_kept_cells_segment_bit_for_bit() {
        let dims = Dims::new(83, 70, 61).unwrap();
        let ix = shapes_index(dims, 3, 10, 12);
        let level = ix.level(0);
        let cells = level.cells().map(|n| n as usize);
        let clear: Vec<u8> = level.max().iter().map(|&m| u8::from(m <= 0.0)).collect();
        assert!(clear.iter().filter(|&&c| c == 1).count() * 2 > clear.len());
        let tables: Vec<Vec<u8>> = (0..8)
            .map(|o| crate::accel::distance::ahead(cells, &clear, o))
            .collect();
        let hi = [82.0, 69.0, 60.0];
        let mut rng = fastrand::Rng::with_seed(3);
        let (mut jumps, mut kept) = (0u64, 0u64);
        for n in 0..6000 {
            let radius = [120.0, 3000.0][n % 2];
            let around = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let mut origin = Vec3::from(hi) * 0.5 + around.normalize_or_zero() * radius;
            let target = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * Vec3::from(hi);
            let mut dir = (target - origin).normalize();
            match n % 7 {
                0 => {
                    let a = n % 3;
                    dir = Vec3::ZERO;
                    dir[a] = if n % 2 == 0 { 1.0 } else { -1.0 };
                    origin = (target / 8.0).floor() * 8.0 - dir * 50.0;
                }
                1 => {
                    // Through cell corners: every axis crosses a face at once.
                    let s = |b: bool| if b { 1.0 } else { -1.0 };
                    dir = Vec3::new(s(n % 2 == 0), s(n % 3 == 0), s(n % 5 == 0)).normalize();
                    origin = Vec3::new(8.0, 16.0, 24.0) * (n % 4) as f32 - dir * 40.0;
                }
                2 => {
                    // Two axes tie, the third moves slowly.
                    dir = Vec3::new(1.0, -1.0, 0.05 * (rng.f32() - 0.5)).normalize();
                    origin = Vec3::new(16.0, 64.0, 8.0 * (n % 7) as f32) - dir * 30.0;
                }
                _ => {}
            }
            let ray = Ray { origin, dir };
            let Some((t0, t1)) = intersect_box(&ray, Vec3::ZERO, Vec3::from(hi)) else {
                continue;
            };
            let vr = VoxelRay::new(ray.origin, ray.dir);
            let busy = |s: &Segment| clear[s.index] == 0;
            let plain: Vec<Segment> = segments(level, hi, &vr, t0, t1).filter(busy).collect();
            let table = &tables[vr.octant];
            let mut segs = segments(level, hi, &vr, t0, t1);
            let mut jumped = Vec::new();
            loop {
                if let Some(i) = segs.upcoming() {
                    if table[i] > 1 {
                        segs.jump(u64::from(table[i]));
                        jumps += 1;
                        continue;
                    }
                }
                let Some(s) = segs.next() else { break };
                if busy(&s) {
                    jumped.push(s);
                }
            }
            assert_eq!(plain, jumped, "ray {n}: {origin} along {dir}");
            kept += plain.len() as u64;
        }
        assert!(
            jumps > 10_000 && kept > 10_000,
            "{jumps} jumps, {kept} kept"
        );
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
