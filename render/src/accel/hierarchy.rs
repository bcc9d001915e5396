//! The index's macrocell levels as a hierarchy a ray can query at a point.
//!
//! At a sample position, [`Hierarchy::step`] finds the largest cell
//! containing it (climbing the levels while a rule lets the parent
//! qualify) and the last ray parameter at which the ray is still safely
//! inside that cell. Repeating this at every landing point walks the
//! hierarchy cell by cell along the ray, as a 3D DDA would, taking the
//! coarsest step the index allows. The rules that decide which cells
//! qualify live in [`super::skip`].
//!
//! Exactness: a skipped sample must be one that would have changed
//! nothing. The cell of a position is computed exactly as the sampler
//! computes the cell it reads (clamp to the volume, then floor), and a
//! cell's stored range covers every voxel that cell's samples read (the
//! index's apron), so every trilinear or nearest value of a sample in a
//! qualifying cell lies in the cell's range. The jump stops a margin
//! before the cell's faces, per axis, larger than the rounding of sample
//! positions, so every skipped sample's computed position is in the cell.

use super::VoxelRay;
use glam::Vec3;
use volcore::grid::Locator;
use volindex::MajorantIndex;

/// An index's levels, ready for point queries along rays.
pub struct Hierarchy<'a> {
    index: &'a MajorantIndex,
    /// Finds the voxel the sampler reads first at a point.
    locator: Locator,
    margin: f32,
    /// log2 of each level's cell edge (edges are powers of two whenever the
    /// finest is), so finding a cell is a shift, not a 64-bit division.
    shifts: Option<Vec<u32>>,
}

/// What a ray does next at a point (see [`Hierarchy::step`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Every sample up to this ray parameter can be skipped; `cell` is the
    /// level-0 cell holding the point.
    Skip {
        /// Last ray parameter safely inside the qualifying cell.
        until: f32,
        /// Linear index of the point's level-0 cell.
        cell: usize,
    },
    /// The point's level-0 cell does not qualify; the ray leaves it at
    /// `exit`.
    Busy {
        /// Ray parameter at which the ray leaves the cell.
        exit: f32,
        /// Linear index of the point's level-0 cell.
        cell: usize,
    },
}

impl<'a> Hierarchy<'a> {
    /// The hierarchy of `index`'s levels.
    pub fn new(index: &'a MajorantIndex) -> Hierarchy<'a> {
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
        Hierarchy {
            index,
            locator: Locator::new(dims),
            shifts,
            // Well above the rounding of f32 positions at this size.
            margin: (largest * (1.0 / (1u32 << 20) as f32)).max(1e-3),
        }
    }

    /// The index behind the hierarchy.
    pub fn index(&self) -> &'a MajorantIndex {
        self.index
    }

    /// The linear index of the level-0 cell holding voxel-space point `p`
    /// (the cell the sampler reads there).
    #[inline(always)]
    pub fn cell_at(&self, p: Vec3) -> usize {
        let v = self.locator.voxel(p.into());
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

    /// What to do at voxel-space point `p` of `ray`: skip to the end of the
    /// largest cell around `p` qualifying under `qualifies(level, cell
    /// index)`, or, when even the level-0 cell does not qualify, sample on
    /// until the ray leaves that cell.
    #[inline]
    pub fn step(&self, p: Vec3, ray: &VoxelRay, qualifies: impl Fn(usize, usize) -> bool) -> Step {
        let v = self.locator.voxel(p.into());
        let levels = self.index.levels();
        let c0 = self.cell_of(0, v);
        let cell = levels[0].index(c0[0], c0[1], c0[2]);
        if !qualifies(0, cell) {
            // Taking a sample is never wrong, so this needs no margin.
            return Step::Busy {
                exit: exit(c0, levels[0].edge(), 0.0, ray),
                cell,
            };
        }
        let mut best = (c0, levels[0].edge());
        for (li, level) in levels.iter().enumerate().skip(1) {
            let c = self.cell_of(li, v);
            if !qualifies(li, level.index(c[0], c[1], c[2])) {
                break;
            }
            best = (c, level.edge());
        }
        // Stop the margin short of the faces (see the module notes).
        Step::Skip {
            until: exit(best.0, best.1, self.margin, ray),
            cell,
        }
    }
}

/// The ray parameter at which `ray` comes within `margin` of leaving the
/// cell `c` of edge `e`, per axis it moves along; infinite if it moves
/// along none. Multiplying by an f64 reciprocal rounds `t` as dividing in
/// f32 would (once, to f32), without a division's latency.
#[inline(always)]
fn exit(c: [u64; 3], e: u64, margin: f32, ray: &VoxelRay) -> f32 {
    let mut until = f32::INFINITY;
    for (a, &ca) in c.iter().enumerate() {
        // Cell corners are far below 2^63: convert through i64, which is
        // one instruction (u64 to f32 is several).
        let face = if ray.d[a] > 0.0 {
            ((ca + 1) * e) as i64 as f32 - margin
        } else if ray.d[a] < 0.0 {
            (ca * e) as i64 as f32 + margin
        } else {
            continue;
        };
        let t = ((face - ray.o[a]) as f64 * ray.inv_d[a]) as f32;
        if t < until {
            until = t;
        }
    }
    until
}
