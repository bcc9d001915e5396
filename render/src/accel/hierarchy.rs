//! Empty-space skipping over the index's macrocell hierarchy.
//!
//! At a sample position the integrator asks [`SkipGrid::skip_until`] for
//! the largest cell containing it (climbing the levels while the parent
//! qualifies) that cannot change the pixel, and jumps to the last `t` at
//! which the ray is still safely inside that cell. Repeating this at every
//! landing point walks the hierarchy cell by cell along the ray, as a 3D
//! DDA would, taking the coarsest step the index allows.
//!
//! Exactness: a skipped sample must be one that would have changed nothing.
//! The cell of a position is computed exactly as the sampler computes the
//! cell it reads (clamp to the volume, then floor), and a cell's stored
//! range covers every voxel that cell's samples read (the index's apron), so
//! every trilinear or nearest value of a sample in a qualifying cell lies in
//! the cell's range. The jump stops a margin before the cell's faces, per
//! axis, larger than the rounding of sample positions, so every skipped
//! sample's computed position is in the cell. Tests check images with and
//! without skipping are bit-identical.

use glam::Vec3;
use volcore::grid::Locator;
use volindex::MajorantIndex;

/// Per-frame skipping data: for each level, one flag per cell.
pub struct SkipGrid<'a> {
    index: &'a MajorantIndex,
    /// Finds the voxel the sampler reads first at a point.
    locator: Locator,
    /// `flags[level][cell]`: the cell qualifies for skipping (for modes with
    /// a per-frame rule); empty for modes whose rule depends on the pixel.
    flags: Vec<Vec<u8>>,
    margin: f32,
    /// log2 of each level's cell edge (edges are powers of two whenever the
    /// finest is), so finding a cell is a shift, not a 64-bit division.
    shifts: Option<Vec<u32>>,
}

/// What a uniform iso cell holds: all samples below, or all at or above.
pub const ISO_BELOW: u8 = 1;
/// See [`ISO_BELOW`].
pub const ISO_ABOVE: u8 = 2;

impl<'a> SkipGrid<'a> {
    fn with_flags(index: &'a MajorantIndex, flags: Vec<Vec<u8>>) -> SkipGrid<'a> {
        let dims = index.dims();
        let largest = dims.x.max(dims.y).max(dims.z) as f32;
        let shifts = index
            .levels()
            .iter()
            .map(|l| {
                l.edge()
                    .is_power_of_two()
                    .then(|| l.edge().trailing_zeros())
            })
            .collect();
        SkipGrid {
            index,
            locator: Locator::new(dims),
            flags,
            shifts,
            // Well above the rounding of f32 positions at this size.
            margin: (largest * (1.0 / (1u32 << 20) as f32)).max(1e-3),
        }
    }

    /// Cells whose largest opacity under the frame's table is zero.
    pub fn transparent(index: &'a MajorantIndex, table: &volindex::RangeMaxTable) -> Self {
        let flags = index
            .levels()
            .iter()
            .map(|l| {
                l.majorants(table)
                    .iter()
                    .map(|&m| (m <= 0.0) as u8)
                    .collect()
            })
            .collect();
        SkipGrid::with_flags(index, flags)
    }

    /// Cells holding only zeros (or only NaN): they add nothing to a sum.
    pub fn zero(index: &'a MajorantIndex) -> Self {
        let flags = index
            .levels()
            .iter()
            .map(|l| {
                l.min()
                    .iter()
                    .zip(l.max())
                    .map(|(&lo, &hi)| ((lo == 0.0 && hi == 0.0) || lo > hi) as u8)
                    .collect()
            })
            .collect();
        SkipGrid::with_flags(index, flags)
    }

    /// Cells on one side of `iso`: [`ISO_BELOW`] when every value is below
    /// it, [`ISO_ABOVE`] when every value is at or above it (only when the
    /// volume holds no NaN, which counts as below), else 0.
    pub fn iso(index: &'a MajorantIndex, iso: f32) -> Self {
        let nan_free = index.stats().nan_count == 0;
        let flags = index
            .levels()
            .iter()
            .map(|l| {
                l.min()
                    .iter()
                    .zip(l.max())
                    .map(|(&lo, &hi)| {
                        if hi < iso || lo > hi {
                            ISO_BELOW
                        } else if lo >= iso && nan_free {
                            ISO_ABOVE
                        } else {
                            0
                        }
                    })
                    .collect()
            })
            .collect();
        SkipGrid::with_flags(index, flags)
    }

    /// No per-frame flags: for MIP and MinIP, whose rule compares the
    /// cell's range with the pixel's running value.
    pub fn ranges(index: &'a MajorantIndex) -> Self {
        SkipGrid::with_flags(index, Vec::new())
    }

    /// The flag of the level-0 cell holding voxel-space point `p`.
    #[inline(always)]
    pub fn flag_at(&self, p: Vec3) -> u8 {
        self.flags[0][self.cell_at(p)]
    }

    /// The linear index of the level-0 cell holding voxel-space point `p`
    /// (the cell the sampler reads there).
    #[inline(always)]
    pub fn cell_at(&self, p: Vec3) -> usize {
        let v = self.voxel_of(p);
        let c = self.cell_of(0, v);
        self.index.level(0).index(c[0], c[1], c[2])
    }

    /// The cell of level `l` holding voxel `v`.
    #[inline(always)]
    fn cell_of(&self, l: usize, v: [u64; 3]) -> [u64; 3] {
        match &self.shifts {
            Some(s) => v.map(|c| c >> s[l]),
            None => {
                let e = self.index.level(l).edge();
                v.map(|c| c / e)
            }
        }
    }

    /// The integer voxel the sampler reads first for point `p`.
    #[inline(always)]
    fn voxel_of(&self, p: Vec3) -> [u64; 3] {
        self.locator.voxel(p.into())
    }

    /// If the cell holding voxel-space point `p` qualifies (`pred(level,
    /// cell index, flag)`), the ray parameter up to which every sample is
    /// still inside the largest qualifying cell around `p`, for a ray with
    /// voxel-space origin `o` and direction `d` (`inv_d` its element-wise
    /// reciprocal, in f64). `None` when it does not.
    #[inline]
    pub fn skip_until(
        &self,
        p: Vec3,
        o: Vec3,
        d: Vec3,
        inv_d: [f64; 3],
        pred: impl Fn(usize, usize, u8) -> bool,
    ) -> Option<f32> {
        match self.step(p, o, d, inv_d, pred) {
            Step::Skip(u) => Some(u),
            Step::Busy(_) => None,
        }
    }

    /// What to do at voxel-space point `p` of a ray with origin `o`,
    /// direction `d` and element-wise reciprocal direction `inv_d` (f64):
    /// skip to the end of the largest cell around `p` qualifying under
    /// `pred(level, cell index, flag)`, or, when even the level-0 cell does
    /// not qualify, sample on until the ray leaves that cell.
    #[inline]
    pub fn step(
        &self,
        p: Vec3,
        o: Vec3,
        d: Vec3,
        inv_d: [f64; 3],
        pred: impl Fn(usize, usize, u8) -> bool,
    ) -> Step {
        let v = self.voxel_of(p);
        let levels = self.index.levels();
        let flag = |l: usize, i: usize| self.flags.get(l).map_or(0, |f| f[i]);
        let mut best = None;
        for (li, level) in levels.iter().enumerate() {
            let c = self.cell_of(li, v);
            let i = level.index(c[0], c[1], c[2]);
            if !pred(li, i, flag(li, i)) {
                break;
            }
            best = Some((c, level.edge()));
        }
        match best {
            // Stop the margin short of the faces (see the module notes).
            Some((c, e)) => Step::Skip(exit(c, e, self.margin, o, d, inv_d)),
            // Taking a sample is never wrong, so this needs no margin.
            None => Step::Busy(exit(self.cell_of(0, v), levels[0].edge(), 0.0, o, d, inv_d)),
        }
    }

    /// The index behind this grid.
    pub fn index(&self) -> &MajorantIndex {
        self.index
    }
}

/// What a ray does next at a point (see [`SkipGrid::step`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Every sample up to this ray parameter can be skipped.
    Skip(f32),
    /// The point's cell cannot be skipped; the ray leaves it at this
    /// parameter.
    Busy(f32),
}

/// The ray parameter at which a ray (voxel-space origin `o`, direction
/// `d`, f64 reciprocal `inv_d`) comes within `margin` of leaving the cell `c`
/// of edge `e`, per axis it moves along; infinite if it moves along none.
/// Multiplying by an f64 reciprocal rounds `t` as dividing in f32 would
/// (once, to f32), without a division's latency.
#[inline(always)]
fn exit(c: [u64; 3], e: u64, margin: f32, o: Vec3, d: Vec3, inv_d: [f64; 3]) -> f32 {
    let mut until = f32::INFINITY;
    for a in 0..3 {
        // Cell corners are far below 2^63: convert through i64, which is
        // one instruction (u64 to f32 is several).
        let face = if d[a] > 0.0 {
            ((c[a] + 1) * e) as i64 as f32 - margin
        } else if d[a] < 0.0 {
            (c[a] * e) as i64 as f32 + margin
        } else {
            continue;
        };
        let t = ((face - o[a]) as f64 * inv_d[a]) as f32;
        if t < until {
            until = t;
        }
    }
    until
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::Walk;
    use crate::ray::{intersect_box, Ray};
    use volcore::region::pack_sliced;
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::{Cursor, Dims, VoxelSource};
    use volindex::BuildOptions;

    /// The invariant skipping rests on, checked directly: every sample a
    /// skip passes over lies in a qualifying cell and reads exactly zero
    /// (here, with the zero-cell rule),
    /// for rays from near and very far (where ray parameters, and their
    /// rounding, are large) and for fine and coarse steps.
    #[test]
    fn every_skipped_sample_reads_zero() {
        let dims = Dims::new(96, 80, 72).unwrap();
        let scene = ShapesScene::new(dims, 2, 25, 24, 100.0);
        let samples = pack_sliced(&SceneSource::<u8>::new(&scene));
        let vol = volcore::Volume::from_samples(dims, samples.clone()).unwrap();
        let grid = volcore::SlicedGrid::new(dims, volcore::Data::Owned(samples)).unwrap();
        let ix = MajorantIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
        let skip = SkipGrid::zero(&ix);
        let loc = Locator::new(dims);
        let mut cur = grid.cursor();
        let hi = Vec3::new(95.0, 79.0, 71.0);
        let mut rng = fastrand::Rng::with_seed(11);
        let (mut skipped, mut skips) = (0u64, 0u64);
        for n in 0..6000 {
            let radius = [150.0, 4000.0, 30000.0][n % 3];
            let step: f64 = [0.05, 0.1, 0.37, 1.0][n % 4];
            let around = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let origin = hi * 0.5 + around.normalize_or_zero() * radius;
            let target = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * hi;
            let ray = Ray {
                origin,
                dir: (target - origin).normalize(),
            };
            let Some((t0, t1)) = intersect_box(&ray, Vec3::ZERO, hi) else {
                continue;
            };
            // Unit spacing: world and voxel coordinates coincide.
            let w = Walk::voxel_space(ray.origin, ray.dir, t0, t1, step, loc);
            let mut k = w.k0;
            while k <= w.k1 {
                let p = w.at(w.t(k));
                // Odd rays skip one level-0 cell at a time: many more skips
                // end near a face.
                let finest = n % 2 == 1;
                let pred = |l: usize, _: usize, f: u8| f != 0 && (l == 0 || !finest);
                let next = match skip.step(p, w.o, w.d, w.inv_d, pred) {
                    Step::Skip(u) => w.after_skip(k, u),
                    Step::Busy(_) => None,
                };
                match next {
                    Some(kn) => {
                        skips += 1;
                        for j in k..kn.min(w.k1 + 1) {
                            let q = w.at(w.t(j));
                            let (b, t) = loc.locate(q.into());
                            let v = volcore::grid::blend(&cur.cell(b[0], b[1], b[2]), t);
                            assert_eq!(v, 0.0, "ray {n}: skipped sample {j} at {q} reads {v}");
                            // Stronger, and independent of the data near the
                            // faces: the sample's own cell qualifies.
                            assert_ne!(skip.flag_at(q), 0, "ray {n}: sample {j} at {q}");
                            skipped += 1;
                        }
                        k = kn;
                    }
                    None => k += 1,
                }
            }
        }
        assert!(
            skips > 10_000 && skipped > 500_000,
            "{skips} skips, {skipped} samples"
        );
    }
}
