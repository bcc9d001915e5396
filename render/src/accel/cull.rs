//! Culling: the blocks of an image whose rays can meet no cell a
//! skipping rule keeps. Their rays could take no sample that adds
//! anything (every cell they cross is skipped), so their pixels are known
//! without tracing them: the image is the same, bit for bit; the rays,
//! skips and the odd sample a ray takes in a skipped cell within a
//! rounding margin of its face are not counted.
//!
//! Busy cells of one level of the index (the finest with at most
//! [`CELLS_PER_BLOCK`] cells per block of the image, at least
//! [`MIN_CELLS`] and at most [`MAX_CELLS`], so the cost per frame stays
//! bounded on dense volumes and small on small images) are projected onto
//! the image, slabs of cells in parallel; a block of [`BLOCK`]² pixels no
//! projection touches is culled. Blocks are fixed, not the render's
//! tiles, so what is traced does not depend on the tile size. The test is
//! conservative: each cell's box is widened by a voxel, its projection by
//! a pixel, and a busy cell that is not wholly in front of a perspective
//! camera culls nothing.

use crate::camera::Camera;
use glam::Vec3;
use rayon::prelude::*;
use volindex::MinMaxIndex;

/// Most cells projected per frame.
pub const MAX_CELLS: usize = 1 << 15;
/// Cells projected per block of the image, at most (a 16x16 preview
/// culls at a coarser level than a 512x512 frame: projecting 32768 cells
/// cost a 256³ volume's 16x16 frame 4 ms, the rays 0.1 ms).
pub const CELLS_PER_BLOCK: usize = 8;
/// The fewest cells a level needs to be projected, when the index has
/// that many.
pub const MIN_CELLS: usize = 1 << 12;

/// Edge of the square pixel blocks culled together.
pub const BLOCK: u32 = 8;

/// Which blocks of an image may see a busy cell.
#[derive(Clone, Debug)]
pub struct BlockMask {
    /// Blocks per row.
    across: u32,
    /// Per block, in row order: whether its rays may meet a busy cell.
    busy: Vec<bool>,
}

impl BlockMask {
    /// Whether the ray through pixel `(x, y)` may meet a busy cell.
    #[inline(always)]
    pub fn may_see(&self, x: u32, y: u32) -> bool {
        self.busy[((y / BLOCK) * self.across + x / BLOCK) as usize]
    }

    /// The number of blocks culled.
    pub fn culled(&self) -> usize {
        self.busy.iter().filter(|&&b| !b).count()
    }
}

/// Which [`BLOCK`]-pixel blocks of `camera`'s image may see a cell of
/// `index` that `busy(level, cell)` keeps; `None` when every block may
/// (nothing can be culled). `spacing` is the voxel spacing. With
/// `within`, a world box (lower and upper corners), only the cells that
/// reach into it count: the rays of a share that takes only the samples
/// inside that box ([`crate::distributed::ShareBox`]).
pub fn busy_blocks(
    camera: &Camera,
    index: &MinMaxIndex,
    spacing: Vec3,
    within: Option<(Vec3, Vec3)>,
    busy: impl Fn(usize, usize) -> bool + Sync,
) -> Option<BlockMask> {
    let (w, h) = (camera.width(), camera.height());
    let (tx, ty) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    let blocks = tx as usize * ty as usize;
    let most = blocks
        .saturating_mul(CELLS_PER_BLOCK)
        .clamp(MIN_CELLS, MAX_CELLS);
    let levels = index.levels();
    let level = levels.iter().position(|l| l.len() <= most)?;
    let l = &levels[level];
    let [nx, ny, nz] = l.cells();
    let d = index.dims().as_array();
    let edge = l.edge();
    // Each slab of cells marks its own mask; the masks are OR-ed. A cell
    // not wholly in front of a perspective eye culls nothing (`None`).
    let slab = |cz: u64| -> Option<Vec<bool>> {
        let mut mask = vec![false; blocks];
        for cy in 0..ny {
            for cx in 0..nx {
                if !busy(level, l.index(cx, cy, cz)) {
                    continue;
                }
                // The voxels the cell's samples read (the next voxel too,
                // for interpolation), widened by a voxel.
                let c = [cx, cy, cz];
                let lo: [f32; 3] = std::array::from_fn(|a| (c[a] * edge) as f32 - 1.0);
                let hi: [f32; 3] =
                    std::array::from_fn(|a| (((c[a] + 1) * edge).min(d[a] - 1)) as f32 + 1.0);
                let (lo, hi) = (Vec3::from(lo) * spacing, Vec3::from(hi) * spacing);
                if within.is_some_and(|(a, b)| lo.cmpgt(b).any() || hi.cmplt(a).any()) {
                    continue; // none of the share's samples read it
                }
                let [x, y] = camera.project_box(lo, hi)?;
                // Pixels whose centres may lie in the projection, plus one.
                let first = |v: f32| (v - 1.0).ceil().max(0.0);
                let last = |v: f32, n: u32| (v + 1.0).floor().min(n as f32 - 1.0);
                let (x0, x1) = (first(x.0), last(x.1, w));
                let (y0, y1) = (first(y.0), last(y.1, h));
                if x0 > x1 || y0 > y1 {
                    continue;
                }
                let (b0, b1) = (x0 as u32 / BLOCK, x1 as u32 / BLOCK);
                for by in y0 as u32 / BLOCK..=y1 as u32 / BLOCK {
                    for bx in b0..=b1 {
                        mask[(by * tx + bx) as usize] = true;
                    }
                }
            }
        }
        Some(mask)
    };
    let busy = (0..nz).into_par_iter().map(slab).try_reduce(
        || vec![false; blocks],
        |mut a, b| {
            a.iter_mut().zip(&b).for_each(|(x, &y)| *x |= y);
            Some(a)
        },
    )?;
    Some(BlockMask { across: tx, busy })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::ray::intersect_box;
    use volcore::{Dims, Volume};
    use volindex::BuildOptions;

    /// A 64³ volume, zero but for a block of voxels `lo ..= hi`.
    fn block(lo: [u64; 3], hi: [u64; 3]) -> Volume {
        let d = Dims::new(64, 64, 64).unwrap();
        let inside = |v: u64, a: usize| v >= lo[a] && v <= hi[a];
        let samples = (0..d.count())
            .map(|n| {
                let (x, y, z) = (n % 64, (n / 64) % 64, n / 4096);
                u8::from(inside(x, 0) && inside(y, 1) && inside(z, 2)) * 200
            })
            .collect();
        Volume::from_samples(d, samples).unwrap()
    }

    /// Every pixel whose ray passes within a voxel of a non-zero voxel
    /// lies in a busy block, and most blocks elsewhere are culled; a busy
    /// cell behind the eye culls nothing.
    #[test]
    fn culling_keeps_every_block_that_can_see_a_busy_cell() {
        let vol = block([40, 8, 20], [47, 15, 23]);
        let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
        let busy = |l: usize, c: usize| ix.level(l).max()[c] > 0.0;
        let (lo, hi) = (Vec3::new(39.0, 7.0, 19.0), Vec3::new(49.0, 17.0, 25.0));
        for (eye, proj) in [
            (Vec3::new(150.0, 90.0, 170.0), Projection::Perspective(40.0)),
            (Vec3::new(-60.0, 30.0, 32.0), Projection::Perspective(70.0)),
            (Vec3::new(32.0, 32.0, 200.0), Projection::Orthographic(90.0)),
        ] {
            let cam = Camera::look_at(eye, Vec3::splat(32.0), Vec3::Y, proj, 90, 70).unwrap();
            let mask = busy_blocks(&cam, &ix, Vec3::ONE, None, busy).unwrap();
            let mut seen = 0;
            for y in 0..70 {
                for x in 0..90 {
                    if intersect_box(&cam.ray(x, y).rounded(), lo, hi).is_some() {
                        seen += 1;
                        assert!(mask.may_see(x, y), "{proj:?}: pixel {x},{y}");
                    }
                }
            }
            assert!(seen > 0, "{proj:?}: the block is in view");
            let blocks = 90usize.div_ceil(8) * 70usize.div_ceil(8);
            assert!(
                mask.culled() * 2 > blocks,
                "{proj:?}: {} culled",
                mask.culled()
            );
        }
        // A share's box: only the cells that reach into it count. A box
        // around the busy voxels keeps every pixel that sees them; a box
        // well away from them culls every block.
        let cam = Camera::look_at(
            Vec3::new(150.0, 90.0, 170.0),
            Vec3::splat(32.0),
            Vec3::Y,
            Projection::Perspective(40.0),
            90,
            70,
        )
        .unwrap();
        let around = Some((Vec3::new(32.0, 0.0, 0.0), Vec3::splat(64.0)));
        let mask = busy_blocks(&cam, &ix, Vec3::ONE, around, busy).unwrap();
        for y in 0..70 {
            for x in 0..90 {
                if intersect_box(&cam.ray(x, y).rounded(), lo, hi).is_some() {
                    assert!(mask.may_see(x, y), "pixel {x},{y}");
                }
            }
        }
        let away = Some((Vec3::ZERO, Vec3::new(24.0, 64.0, 64.0)));
        let mask = busy_blocks(&cam, &ix, Vec3::ONE, away, busy).unwrap();
        assert_eq!(mask.culled(), 90usize.div_ceil(8) * 70usize.div_ceil(8));
        // The eye inside the volume, the block behind it: nothing culled.
        let cam = Camera::look_at(
            Vec3::new(44.0, 12.0, 40.0),
            Vec3::new(44.0, 12.0, 63.0),
            Vec3::Y,
            Projection::Perspective(60.0),
            32,
            32,
        )
        .unwrap();
        assert!(busy_blocks(&cam, &ix, Vec3::ONE, None, busy).is_none());
    }
}
