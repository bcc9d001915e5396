//! The skipping rules: which macrocells a ray may jump over without
//! changing its pixel. Each rule is its own type, so the march loop is
//! compiled for exactly one; their per-frame flags are private.

use super::distance::OctantDistances;
use super::{Accel, Hierarchy, Step, VoxelRay};
use glam::Vec3;
use std::sync::Arc;
use volindex::MinMaxIndex;

/// A flag per cell of every level, from a per-cell test of its range, in
/// the hierarchy's flat order (finest level first).
fn flags_of(index: &MinMaxIndex, f: impl Fn(f32, f32) -> u8) -> Vec<u8> {
    let levels = index.levels();
    let mut flags = Vec::with_capacity(levels.iter().map(|l| l.len()).sum());
    for l in levels {
        flags.extend(l.min().iter().zip(l.max()).map(|(&lo, &hi)| f(lo, hi)));
    }
    flags
}

/// Cells flagged once per frame by a rule that does not depend on the
/// ray: transparent under the transfer function (DVR: no sample in them
/// can add colour or opacity), or holding only zeros (X-ray: they add
/// nothing to the sum).
pub struct FixedCells<'a> {
    h: Hierarchy<'a>,
    /// The flags and their distances (shared with the index's memo when a
    /// later frame may use them again).
    cells: Arc<SkipFlags>,
    /// With adaptive steps: per level-0 cell, `log2` of the steps one
    /// sample there stands for ([`super::strides`]).
    strides: Option<Vec<u8>>,
}

/// What a fixed rule decides for one index: the flags and the distances
/// made from them, kept whole so that frames with the same rule can share
/// them ([`volindex::MinMaxIndex::memo`]).
pub struct SkipFlags {
    /// Per cell of every level (flat order): 1 when the cell may be
    /// skipped.
    flags: Vec<u8>,
    /// Per octant and level-0 cell: the chessboard distance, in cells, to
    /// the nearest level-0 cell ahead that may not be skipped (0 on those;
    /// see [`super::distance`]; each octant's table made on first use).
    distance: OctantDistances,
}

impl SkipFlags {
    /// The transparent-cell flags of `index` from per-level, per-cell
    /// flags (`true`: every sample the cell can produce has zero
    /// opacity), as a classifier computes them.
    pub fn transparent(index: &MinMaxIndex, transparent: Vec<Vec<bool>>) -> SkipFlags {
        // Level by level: a flattening iterator would go cell by cell.
        let mut flags = Vec::with_capacity(transparent.iter().map(Vec::len).sum());
        for level in &transparent {
            flags.extend(level.iter().map(|&t| u8::from(t)));
        }
        SkipFlags::new(index, flags)
    }

    /// Flags in flat order, with empty distance tables.
    fn new(index: &MinMaxIndex, flags: Vec<u8>) -> SkipFlags {
        let n = index.levels().first().map_or([0; 3], |l| l.cells());
        SkipFlags::finest(n, flags)
    }

    /// Flags of a grid of `cells` level-0 cells alone (x fastest; any
    /// flags past them are ignored), with empty distance tables: a
    /// majorant grid's empty cells, which path tracing jumps in blocks.
    pub fn finest(cells: [u64; 3], flags: Vec<u8>) -> SkipFlags {
        SkipFlags {
            flags,
            distance: OctantDistances::new(cells.map(|c| c as usize)),
        }
    }

    /// For a ray in octant `octant` ([`super::distance::octant`]), the
    /// edge of the block of skipped level-0 cells that starts at cell
    /// `cell` and extends ahead of it (0: the cell is kept).
    #[inline(always)]
    pub fn ahead(&self, octant: usize, cell: usize) -> u8 {
        self.distance.table(octant, &self.flags)[cell]
    }
}

impl<'a> FixedCells<'a> {
    /// The transparent-cell rule from per-level, per-cell flags (`true`:
    /// every sample the cell can produce has zero opacity), as a
    /// classifier computes them.
    pub fn transparent(index: &'a MinMaxIndex, transparent: Vec<Vec<bool>>) -> Self {
        Self::shared(index, Arc::new(SkipFlags::transparent(index, transparent)))
    }

    /// The rule over `index` from flags made for it (and perhaps already
    /// used by an earlier frame, with the distance tables it made).
    pub fn shared(index: &'a MinMaxIndex, cells: Arc<SkipFlags>) -> Self {
        FixedCells {
            h: Hierarchy::new(index),
            cells,
            strides: None,
        }
    }

    /// The zero-cell rule: cells holding only zeros (or only NaN).
    pub fn zero(index: &'a MinMaxIndex) -> Self {
        Self::with_flags(
            index,
            flags_of(index, |lo, hi| ((lo == 0.0 && hi == 0.0) || lo > hi) as u8),
        )
    }

    /// The rule from its flags (flat order), with the level-0 distances
    /// computed from them.
    fn with_flags(index: &'a MinMaxIndex, flags: Vec<u8>) -> Self {
        Self::shared(index, Arc::new(SkipFlags::new(index, flags)))
    }

    /// The same rule with adaptive steps: `log2_strides` per level-0 cell
    /// (one per cell, from [`super::strides::stride_log2s`]).
    pub fn with_strides(mut self, log2_strides: Vec<u8>) -> Self {
        self.strides = Some(log2_strides);
        self
    }

    /// The rule that skips nothing, only walks `index`'s level-0 cells
    /// (for adaptive steps without skipping).
    pub fn none(index: &'a MinMaxIndex) -> Self {
        let n: usize = index.levels().iter().map(|l| l.len()).sum();
        Self::with_flags(index, vec![0; n])
    }

    /// The level-0 cells' strides (`log2`), when steps are adaptive.
    pub fn strides(&self) -> Option<&[u8]> {
        self.strides.as_deref()
    }

    /// Boxes made only of cells this rule skips.
    pub fn clear_boxes(&self) -> ClearBoxes<'_> {
        ClearBoxes::new(self.h.index(), &self.cells.flags, |f| f != 0)
    }

    /// The index the rule flags.
    pub fn index(&self) -> &'a MinMaxIndex {
        self.h.index()
    }

    /// Whether the rule may skip cell `cell` (linear index) of `level`.
    pub fn skippable(&self, level: usize, cell: usize) -> bool {
        let below: usize = self.h.index().levels()[..level]
            .iter()
            .map(|l| l.len())
            .sum();
        self.cells.flags[below + cell] != 0
    }

    /// Whether the rule may skip level-0 cell `cell` (linear index).
    #[inline]
    pub fn skippable_finest(&self, cell: usize) -> bool {
        self.cells.flags.get(cell).is_some_and(|&f| f != 0)
    }

    /// The fraction of level-0 cells that may be skipped.
    pub fn skippable_fraction(&self) -> f64 {
        let n = self.h.index().levels().first().map_or(0, |l| l.len());
        let f = &self.cells.flags[..n];
        f.iter().filter(|&&x| x != 0).count() as f64 / n.max(1) as f64
    }
}

impl Accel<()> for FixedCells<'_> {
    const ON: bool = true;
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, _: ()) -> Step {
        self.h
            .step_ahead(p, ray, |c| self.cells.ahead(ray.octant, c))
    }
    #[inline(always)]
    fn strided(&self) -> bool {
        self.strides.is_some()
    }
    #[inline(always)]
    fn stride_log2(&self, cell: usize) -> u32 {
        self.strides
            .as_ref()
            .and_then(|s| s.get(cell))
            .map_or(0, |&s| u32::from(s))
    }
}

/// Cells whose largest value cannot beat the ray's running maximum (MIP).
pub struct RunningMax<'a> {
    h: Hierarchy<'a>,
}

impl<'a> RunningMax<'a> {
    /// The rule for `index`.
    pub fn new(index: &'a MinMaxIndex) -> Self {
        RunningMax {
            h: Hierarchy::new(index),
        }
    }
}

impl Accel<f32> for RunningMax<'_> {
    const ON: bool = true;
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, best: f32) -> Step {
        let levels = self.h.index().levels();
        self.h.step(p, ray, |l, i, _| levels[l].max()[i] <= best)
    }
}

/// Cells whose smallest value cannot beat the ray's running minimum
/// (MinIP).
pub struct RunningMin<'a> {
    h: Hierarchy<'a>,
}

impl<'a> RunningMin<'a> {
    /// The rule for `index`.
    pub fn new(index: &'a MinMaxIndex) -> Self {
        RunningMin {
            h: Hierarchy::new(index),
        }
    }
}

impl Accel<f32> for RunningMin<'_> {
    const ON: bool = true;
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, best: f32) -> Step {
        let levels = self.h.index().levels();
        self.h.step(p, ray, |l, i, _| levels[l].min()[i] >= best)
    }
}

/// What a cell holds relative to an iso value: all samples below it.
pub const ISO_BELOW: u8 = 1;
/// See [`ISO_BELOW`]: all samples at or above it.
pub const ISO_ABOVE: u8 = 2;

/// Cells entirely on one side of an iso value: a ray on that side may jump
/// through them (the crossing cannot be inside).
pub struct IsoSides<'a> {
    h: Hierarchy<'a>,
    /// [`ISO_BELOW`], [`ISO_ABOVE`] or 0 (mixed) per cell of every level
    /// (flat order).
    flags: Vec<u8>,
}

impl<'a> IsoSides<'a> {
    /// The rule for iso value `iso`: [`ISO_BELOW`] when every value is
    /// below it, [`ISO_ABOVE`] when every value is at or above it (only
    /// when the volume holds no NaN, which counts as below), else 0.
    pub fn new(index: &'a MinMaxIndex, iso: f32) -> Self {
        let nan_free = index.stats().nan_count == 0;
        IsoSides {
            h: Hierarchy::new(index),
            flags: flags_of(index, |lo, hi| {
                if hi < iso || lo > hi {
                    ISO_BELOW
                } else if lo >= iso && nan_free {
                    ISO_ABOVE
                } else {
                    0
                }
            }),
        }
    }
}

impl IsoSides<'_> {
    /// Boxes made only of cells entirely below the iso value.
    pub fn clear_boxes_below(&self) -> ClearBoxes<'_> {
        ClearBoxes::new(self.h.index(), &self.flags, |f| f == ISO_BELOW)
    }
}

/// Which level-0 cells hold nothing a sample could see, by cell
/// coordinates (for light grids, which skip segments inside such cells).
pub struct ClearBoxes<'a> {
    level: &'a volindex::Level,
    dims: volcore::Dims,
    /// `log2` of the cell edge when it is a power of two (then finding a
    /// cell is a shift).
    shift: Option<u32>,
    /// Per level-0 cell: clear or not.
    clear: Vec<bool>,
}

impl<'a> ClearBoxes<'a> {
    fn new(index: &'a MinMaxIndex, flags: &[u8], clear: impl Fn(u8) -> bool) -> Self {
        let level = index.level(0);
        let edge = level.edge();
        ClearBoxes {
            level,
            dims: index.dims(),
            shift: edge.is_power_of_two().then(|| edge.trailing_zeros()),
            clear: flags[..level.len()].iter().map(|&f| clear(f)).collect(),
        }
    }

    /// The level-0 cell of voxel point `p`, as the index finds it (clamp
    /// to the volume, floor, divide by the edge).
    #[inline(always)]
    fn cell_of(&self, p: Vec3) -> [u64; 3] {
        match self.shift {
            Some(sh) => {
                let d = self.dims.as_array();
                let cells = self.level.cells();
                std::array::from_fn(|a| {
                    let base = volcore::grid::clamp_axis(p[a], d[a]) as u64;
                    (base >> sh).min(cells[a] - 1)
                })
            }
            None => self.level.cell_of(p.to_array(), self.dims),
        }
    }

    /// Level-0 cells along each axis.
    pub fn cells(&self) -> [u64; 3] {
        self.level.cells()
    }

    /// The level-0 cell coordinate along `axis` of voxel coordinate `p`
    /// (as the index finds it).
    #[inline]
    pub fn cell_along(&self, axis: usize, p: f32) -> u64 {
        let mut v = Vec3::ZERO;
        v[axis] = p;
        self.cell_of(v)[axis]
    }

    /// Whether cell `c` (cell coordinates) is clear.
    #[inline]
    pub fn is_clear(&self, c: [u64; 3]) -> bool {
        self.clear[self.level.index(c[0], c[1], c[2])]
    }

    /// Per cell of the plane across axes `b` (rows) and `c` (columns),
    /// row-major: whether every cell from `a0` to `a1` (inclusive) along
    /// axis `a` is clear, for `[a, b, c]` a permutation of the axes and
    /// `a0 ≤ a1` cells along `a`.
    pub fn clear_columns(&self, [a, b, c]: [usize; 3], a0: u64, a1: u64) -> Vec<bool> {
        let cells = self.cells().map(|n| n as usize);
        let stride = [1, cells[0], cells[0] * cells[1]];
        let (nb, nc) = (cells[b], cells[c]);
        let mut cols = vec![true; nb * nc];
        for ca in a0 as usize..=(a1 as usize).min(cells[a].saturating_sub(1)) {
            for (cb, row) in cols.chunks_exact_mut(nc.max(1)).enumerate() {
                let at = ca * stride[a] + cb * stride[b];
                for (cc, col) in row.iter_mut().enumerate() {
                    *col &= self.clear[at + cc * stride[c]];
                }
            }
        }
        cols
    }
}

impl Accel<bool> for IsoSides<'_> {
    const ON: bool = true;
    /// `above`: the side the ray is on.
    #[inline(always)]
    fn step(&self, p: Vec3, ray: &VoxelRay, above: bool) -> Step {
        let side = if above { ISO_ABOVE } else { ISO_BELOW };
        self.h.step(p, ray, |_, _, f| self.flags[f] == side)
    }
    #[inline(always)]
    fn flag(&self, cell: usize) -> u8 {
        self.flags[cell]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::{intersect_box, Ray};
    use crate::trace::march::RaySteps;
    use volcore::grid::Locator;
    use volcore::region::pack_sliced;
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::{Cursor, Dims, VoxelSource};
    use volindex::BuildOptions;

    /// The invariant skipping rests on, checked directly: every sample a
    /// skip passes over lies in a qualifying cell and reads exactly zero
    /// (here, with the zero-cell rule), for rays from near and very far
    /// (where ray parameters, and their rounding, are large) and for fine
    /// and coarse steps.
    #[test]
    fn every_skipped_sample_reads_zero() {
        let dims = Dims::new(96, 80, 72).unwrap();
        let scene = ShapesScene::new(dims, 2, 25, 24, 100.0);
        let samples = pack_sliced(&SceneSource::<u8>::new(&scene));
        let vol = volcore::Volume::from_samples(dims, samples.clone()).unwrap();
        let grid = volcore::SlicedGrid::new(dims, volcore::Data::Owned(samples)).unwrap();
        let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
        let zero = FixedCells::zero(&ix);
        let loc = Locator::new(dims);
        let mut cur = grid.cursor();
        let hi = Vec3::new(95.0, 79.0, 71.0);
        let mut rng = fastrand::Rng::with_seed(11);
        let (mut skipped, mut skips) = (0u64, 0u64);
        for n in 0..6000 {
            let radius = [150.0, 4000.0, 30000.0][(n / 3) % 3];
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
            let w = RaySteps::voxel_space(ray.origin, ray.dir, t0, t1, step, loc);
            let mut k = w.k0;
            while k <= w.k1 {
                let p = w.at(w.t(k));
                // Rays of one kind in three skip one level-0 cell at a
                // time (many more skips end near a face), and one in three
                // jumps whole clear blocks by the chessboard distances ahead.
                let finest = n % 3 == 1;
                let qualifies =
                    |l: usize, _: usize, f: usize| zero.cells.flags[f] != 0 && (l == 0 || !finest);
                let step = if n % 3 == 2 {
                    let table = zero.cells.distance.table(w.ray.octant, &zero.cells.flags);
                    zero.h.step_ahead(p, &w.ray, |c| table[c])
                } else {
                    zero.h.step(p, &w.ray, qualifies)
                };
                let next = match step {
                    Step::Skip { until, .. } => w.after_skip(k, until),
                    Step::Busy { .. } => None,
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
                            assert_ne!(
                                zero.cells.flags[zero.h.cell_at(q)],
                                0,
                                "ray {n}: sample {j} at {q}"
                            );
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

    /// The clear columns of a plane are, cell by cell, whether every cell
    /// of the column's range is clear: every axis order and range.
    #[test]
    fn clear_columns_are_the_columns_cells() {
        let dims = Dims::new(70, 50, 40).unwrap();
        let scene = ShapesScene::new(dims, 4, 12, 20, 100.0);
        let vol = volcore::Volume::from_samples(dims, pack_sliced(&SceneSource::<u8>::new(&scene)))
            .unwrap();
        let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
        let zero = FixedCells::zero(&ix);
        let boxes = zero.clear_boxes();
        let cells = boxes.cells();
        let mut some = [0usize; 2];
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            let [a, b, c] = perm;
            for (a0, a1) in [
                (0, 0),
                (1, 2),
                (0, cells[a] - 1),
                (cells[a] - 1, cells[a] - 1),
            ] {
                let got = boxes.clear_columns(perm, a0, a1);
                assert_eq!(got.len() as u64, cells[b] * cells[c]);
                for cb in 0..cells[b] {
                    for cc in 0..cells[c] {
                        let want = (a0..=a1).all(|ca| {
                            let mut cell = [0; 3];
                            (cell[a], cell[b], cell[c]) = (ca, cb, cc);
                            boxes.is_clear(cell)
                        });
                        let got = got[(cb * cells[c] + cc) as usize];
                        assert_eq!(got, want, "{perm:?} {a0}..={a1}: {cb}, {cc}");
                        some[usize::from(got)] += 1;
                    }
                }
            }
        }
        assert!(some[0] > 100 && some[1] > 100, "{some:?}");
    }
}
