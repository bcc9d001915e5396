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
use volindex::MinMaxIndex;

/// An index's levels, ready for point queries along rays.
pub struct Hierarchy<'a> {
    index: &'a MinMaxIndex,
    /// Finds the voxel the sampler reads first at a point.
    locator: Locator,
    margin: f32,
    /// Per level, what finding a cell needs, in one small array.
    levels: Vec<LevelGeom>,
    /// Whether every cell edge is a power of two (whenever the finest is),
    /// so finding a cell is a shift, not a 64-bit division.
    pow2: bool,
}

/// One level's cell geometry.
#[derive(Clone, Copy, Debug)]
struct LevelGeom {
    /// Cell edge, voxels.
    edge: u64,
    /// log2 of the edge (when it is a power of two).
    shift: u32,
    /// Cells along x, and in an xy slab.
    nx: u64,
    nxy: u64,
    /// Cells on all finer levels (where this level's cells start when the
    /// levels' cells are numbered in one sequence).
    offset: usize,
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
    pub fn new(index: &'a MinMaxIndex) -> Hierarchy<'a> {
        let dims = index.dims();
        let largest = dims.x.max(dims.y).max(dims.z) as f32;
        let mut offset = 0;
        let levels: Vec<LevelGeom> = index
            .levels()
            .iter()
            .map(|l| {
                let c = l.cells();
                let g = LevelGeom {
                    edge: l.edge(),
                    shift: l.edge().trailing_zeros(),
                    nx: c[0],
                    nxy: c[0] * c[1],
                    offset,
                };
                offset += l.len();
                g
            })
            .collect();
        let pow2 = levels.iter().all(|g| g.edge.is_power_of_two());
        Hierarchy {
            index,
            locator: Locator::new(dims),
            levels,
            pow2,
            // Well above the rounding of f32 positions at this size.
            margin: (largest * (1.0 / (1u32 << 20) as f32)).max(1e-3),
        }
    }

    /// The index behind the hierarchy.
    pub fn index(&self) -> &'a MinMaxIndex {
        self.index
    }

    /// The linear index of the level-0 cell holding voxel-space point `p`
    /// (the cell the sampler reads there).
    #[inline(always)]
    pub fn cell_at(&self, p: Vec3) -> usize {
        let v = self.locator.voxel(p.into());
        let g = &self.levels[0];
        g.linear(self.cell_of(g, v))
    }

    /// The voxel the sampler reads first at voxel-space point `p`, and the
    /// finest level's geometry with the cell holding that voxel (its
    /// coordinates and linear index); `None` when the index has no levels.
    #[inline(always)]
    fn finest_cell(&self, p: Vec3) -> Option<([u64; 3], &LevelGeom, [u64; 3], usize)> {
        let v = self.locator.voxel(p.into());
        let g0 = self.levels.first()?;
        let c0 = self.cell_of(g0, v);
        Some((v, g0, c0, g0.linear(c0)))
    }

    /// The cell of a level holding voxel `v`.
    #[inline(always)]
    fn cell_of(&self, g: &LevelGeom, v: [u64; 3]) -> [u64; 3] {
        if self.pow2 {
            v.map(|c| c >> g.shift)
        } else {
            v.map(|c| c / g.edge)
        }
    }

    /// What to do at voxel-space point `p` of `ray`: skip to the end of the
    /// largest cell around `p` qualifying under `qualifies(level, cell
    /// index in the level, flat index)` (the flat index numbers the cells
    /// of all levels in one sequence, finest first), or, when even the
    /// level-0 cell does not qualify, sample on until the ray leaves that
    /// cell.
    #[inline(always)]
    pub fn step(
        &self,
        p: Vec3,
        ray: &VoxelRay,
        qualifies: impl Fn(usize, usize, usize) -> bool,
    ) -> Step {
        let Some((v, g0, c0, cell)) = self.finest_cell(p) else {
            return NO_LEVELS;
        };
        if !qualifies(0, cell, cell) {
            return busy(g0, c0, cell, ray);
        }
        let mut best = (c0, g0.edge);
        for (li, g) in self.levels[1..].iter().enumerate() {
            let c = self.cell_of(g, v);
            let i = g.linear(c);
            if !qualifies(li + 1, i, g.offset + i) {
                break;
            }
            best = (c, g.edge);
        }
        // Stop the margin short of the faces (see the module notes).
        Step::Skip {
            until: exit(best.0, best.1, 0, self.margin, ray),
            cell,
        }
    }

    /// What to do at voxel-space point `p` of `ray` from per-level-0-cell
    /// chessboard distances to the nearest cell ahead of the ray that does
    /// not qualify (`distance(cell)`, see [`super::distance`]): skip to the
    /// exit of the block of cells from `p`'s cell onward that all qualify,
    /// or, at distance 0, sample on until the ray leaves the cell.
    #[inline(always)]
    pub fn step_ahead(&self, p: Vec3, ray: &VoxelRay, distance: impl Fn(usize) -> u8) -> Step {
        let Some((_, g0, c0, cell)) = self.finest_cell(p) else {
            return NO_LEVELS;
        };
        match distance(cell) {
            0 => busy(g0, c0, cell, ray),
            d => Step::Skip {
                until: exit(c0, g0.edge, d as u64 - 1, self.margin, ray),
                cell,
            },
        }
    }
}

/// What an index without levels answers everywhere: sample on.
const NO_LEVELS: Step = Step::Busy {
    exit: f32::INFINITY,
    cell: 0,
};

/// Sample on through level-0 cell `c` (geometry `g`, linear index `cell`)
/// until `ray` leaves it. Taking a sample is never wrong, so this exit
/// needs no margin.
#[inline(always)]
fn busy(g: &LevelGeom, c: [u64; 3], cell: usize, ray: &VoxelRay) -> Step {
    Step::Busy {
        exit: exit(c, g.edge, 0, 0.0, ray),
        cell,
    }
}

impl LevelGeom {
    /// The linear index of cell `c` in its level.
    #[inline(always)]
    fn linear(&self, c: [u64; 3]) -> usize {
        (c[0] + self.nx * c[1] + self.nxy * c[2]) as usize
    }
}

/// The ray parameter at which `ray` comes within `margin` of leaving the
/// block of cells of edge `e` that reaches from cell `c` to `r` cells
/// ahead of it along each axis the ray moves along (the cell itself when
/// `r` is 0); infinite if it moves along none. Multiplying by an f64
/// reciprocal rounds `t` as dividing in f32 would (once, to f32), without a
/// division's latency.
#[inline(always)]
fn exit(c: [u64; 3], e: u64, r: u64, margin: f32, ray: &VoxelRay) -> f32 {
    let mut until = f32::INFINITY;
    for (a, &ca) in c.iter().enumerate() {
        // Cell corners are far below 2^63: convert through i64, which is
        // one instruction (u64 to f32 is several). The block's far faces
        // may lie outside the volume: no sample is taken there.
        let face = if ray.d[a] > 0.0 {
            ((ca + 1 + r) * e) as i64 as f32 - margin
        } else if ray.d[a] < 0.0 {
            ((ca as i64 - r as i64) * e as i64) as f32 + margin
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
