//! A frame's data-parallel split: the volume's block grid, its split among
//! ranks weighted by the cells the frame can see, each rank's box in world
//! and voxel coordinates, the composite rule and order for the camera.

use super::composite::Composite;
use super::{KdTree, ShareBox, Viewer};
use crate::camera::{Camera, Projection};
use crate::settings::Mode;
use std::ops::Range;
use volcore::Dims;

/// The split of one volume among ranks (see the module docs).
#[derive(Clone, Debug)]
pub struct Split {
    tree: KdTree,
    dims: [u64; 3],
    block: u64,
    shape: [u64; 3],
    spacing: [f32; 3],
}

impl Split {
    /// Split a volume of `dims` and voxel `spacing` into blocks of `block`
    /// voxels a side among `ranks` ranks. `busy` flags the cells of edge
    /// `cell` (x fastest, as [`crate::frame::busy_cells`] gives them): a
    /// block weighs the number of busy cells whose first voxel is in it;
    /// without flags every block weighs one. With a `camera`, a block's
    /// weight is scaled by the density of the camera's rays there (for a
    /// perspective camera the inverse square of the distance to the eye:
    /// a block near the eye is crossed by more rays, so its samples are
    /// more), and blocks off the image weigh nothing: the weights then
    /// estimate each box's samples, which is what balances the ranks.
    pub fn new(
        dims: Dims,
        spacing: [f32; 3],
        block: u64,
        busy: Option<(&[bool], u64)>,
        ranks: usize,
        camera: Option<&Camera>,
    ) -> Split {
        let block = block.max(1);
        let dims = dims.as_array();
        let shape = dims.map(|n| n.div_ceil(block));
        let blocks = shape.iter().product::<u64>() as usize;
        let mut weights = match busy {
            None => vec![1u64; blocks],
            Some((flags, cell)) => {
                let cell = cell.max(1);
                let cells = dims.map(|n| n.div_ceil(cell));
                let mut w = vec![0u64; blocks];
                for (i, _) in flags.iter().enumerate().filter(|(_, &b)| b) {
                    let i = i as u64;
                    let c = [
                        i % cells[0],
                        (i / cells[0]) % cells[1],
                        i / (cells[0] * cells[1]),
                    ];
                    let b = c.map(|c| c * cell / block);
                    if b[2] < shape[2] {
                        w[((b[2] * shape[1] + b[1]) * shape[0] + b[0]) as usize] += 1;
                    }
                }
                w
            }
        };
        if let Some(cam) = camera {
            let mut i = 0;
            for z in 0..shape[2] {
                for y in 0..shape[1] {
                    for x in 0..shape[0] {
                        let lo = [x, y, z];
                        let w = &mut weights[i];
                        i += 1;
                        if *w == 0 {
                            continue;
                        }
                        let corner = |k: usize, a: usize| {
                            let v = (lo[a] + ((k >> a) & 1) as u64) * block;
                            v.min(dims[a]) as f32 * spacing[a]
                        };
                        *w = ray_density(cam, corner, *w);
                    }
                }
            }
        }
        Split {
            tree: KdTree::split(&weights, shape, ranks.max(1)),
            dims,
            block,
            shape,
            spacing,
        }
    }

    /// The k-d split.
    pub fn tree(&self) -> &KdTree {
        &self.tree
    }

    /// How many ranks share the volume.
    pub fn ranks(&self) -> usize {
        self.tree.leaves().len()
    }

    /// Rank `rank`'s box as a share of every ray, or `None` when the rank
    /// got no block (more ranks than blocks with work).
    pub fn share(&self, rank: usize) -> Option<ShareBox> {
        let leaf = self.tree.leaves().get(rank)?;
        if leaf.is_empty() {
            return None;
        }
        let b = &leaf.blocks;
        let world = |a: usize, at: u64| (at * self.block) as f32 * self.spacing[a];
        Some(ShareBox {
            lo: std::array::from_fn(|a| (b[a].start > 0).then(|| world(a, b[a].start))),
            hi: std::array::from_fn(|a| (b[a].end < self.shape[a]).then(|| world(a, b[a].end))),
        })
    }

    /// Rank `rank`'s box in voxels, `x, y, z`, half-open and inside the
    /// volume (empty ranges for a rank without blocks). Samples in the box
    /// read voxels up to one past its upper faces (trilinear
    /// interpolation's apron) and, with gradients, one more on each side.
    pub fn voxels(&self, rank: usize) -> [Range<u64>; 3] {
        match self.tree.leaves().get(rank) {
            Some(leaf) if !leaf.is_empty() => std::array::from_fn(|a| {
                let r = &leaf.blocks[a];
                (r.start * self.block).min(self.dims[a])..(r.end * self.block).min(self.dims[a])
            }),
            _ => [0..0, 0..0, 0..0],
        }
    }

    /// The ranks front to back as `camera` sees them.
    pub fn front_to_back(&self, camera: &Camera) -> Vec<usize> {
        let viewer = match camera.projection() {
            Projection::Perspective(_) => {
                let e = camera.eye();
                Viewer::Point(std::array::from_fn(|a| {
                    f64::from(e[a]) / (self.block as f64 * f64::from(self.spacing[a]))
                }))
            }
            Projection::Orthographic(_) => {
                Viewer::Direction(camera.forward().to_array().map(f64::from))
            }
        };
        self.tree.front_to_back(viewer)
    }
}

/// Weight `w` of a box with world corners `corner(k, axis)` (`k` in
/// 0..8) scaled by how densely `camera`'s rays cross it: 0 when every
/// corner lands beyond one edge of the image; for a perspective camera
/// the inverse square of the distance from the eye to the box's centre
/// (at least half the box's diagonal), relative to the box's own size,
/// in fixed point. Orthographic rays are equally dense everywhere.
fn ray_density(camera: &Camera, corner: impl Fn(usize, usize) -> f32, w: u64) -> u64 {
    let (cw, ch) = (camera.width() as f32, camera.height() as f32);
    let mut off = [true; 4];
    let mut seen = true;
    for k in 0..8 {
        let p = glam::Vec3::new(corner(k, 0), corner(k, 1), corner(k, 2));
        match camera.project(p) {
            Some([x, y]) => {
                off[0] &= x < -1.0;
                off[1] &= x > cw;
                off[2] &= y < -1.0;
                off[3] &= y > ch;
            }
            None => seen = false,
        }
    }
    if seen && off.iter().any(|&o| o) {
        return 0;
    }
    match camera.projection() {
        Projection::Orthographic(_) => w,
        Projection::Perspective(_) => {
            let lo = glam::Vec3::new(corner(0, 0), corner(0, 1), corner(0, 2));
            let hi = glam::Vec3::new(corner(7, 0), corner(7, 1), corner(7, 2));
            let size = (hi - lo).length().max(f32::MIN_POSITIVE);
            let d = ((lo + hi) * 0.5 - camera.eye()).length().max(size * 0.5);
            let scale = f64::from(size / d).powi(2);
            // 2^16 per unit: a block's own size away weighs w·2^16.
            ((w as f64) * scale * 65536.0)
                .ceil()
                .min(u64::MAX as f64 / 2.0) as u64
        }
    }
}

/// How the shares of a ray combine in `mode`, or `None` for a mode whose
/// shares cannot be combined from their films (the X-ray mean divides by
/// each share's own sample count, which the film does not keep).
pub fn composite_for(mode: Mode) -> Option<Composite> {
    match mode {
        Mode::Dvr => Some(Composite::Over),
        Mode::Iso(_) => Some(Composite::FirstHit),
        Mode::Mip => Some(Composite::Max),
        Mode::Minip => Some(Composite::Min),
        Mode::XraySum => Some(Composite::Sum),
        Mode::XrayMean => None,
    }
}

/// Rows `j`-th of `parts` near-equal strips of an image `height` rows
/// high: the strip rank `j` composites when the ranks split the image
/// (direct send).
pub fn strip_rows(height: u32, parts: usize, j: usize) -> Range<u32> {
    let parts = parts.max(1) as u64;
    let at = |j: u64| (u64::from(height) * j.min(parts) / parts) as u32;
    at(j as u64)..at(j as u64 + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_follow_the_busy_cells() {
        // 64^3 voxels, cells of 8, blocks of 16: only cells with x < 16
        // are busy, so two ranks split the busy x-slab, not the volume.
        let dims = Dims::new(64, 64, 64).unwrap();
        let cells = 8u64 * 8 * 8;
        let flags: Vec<bool> = (0..cells).map(|i| i % 8 < 2).collect();
        let l = Split::new(dims, [1.0; 3], 16, Some((&flags, 8)), 2, None);
        let w: Vec<u64> = l.tree().leaves().iter().map(|f| f.weight).collect();
        assert_eq!(
            w.iter().sum::<u64>(),
            flags.iter().filter(|&&b| b).count() as u64
        );
        assert_eq!(w[0], w[1], "balanced: {w:?}");
        // Without flags: every block weighs one.
        let u = Split::new(dims, [1.0; 3], 16, None, 3, None);
        assert_eq!(u.tree().leaves().iter().map(|f| f.weight).sum::<u64>(), 64);
    }

    #[test]
    fn near_blocks_weigh_more_and_blocks_off_the_image_nothing() {
        let dims = Dims::new(64, 64, 64).unwrap();
        let cam = |p| {
            Camera::look_at(
                glam::Vec3::new(200.0, 32.0, 32.0),
                glam::Vec3::new(32.0, 32.0, 32.0),
                glam::Vec3::Y,
                p,
                40,
                40,
            )
            .unwrap()
        };
        // Looking down -x from x = 200: the near half (x >= 32) is
        // closer, so a split by ray density gives it fewer blocks.
        let near = Split::new(
            dims,
            [1.0; 3],
            16,
            None,
            2,
            Some(&cam(Projection::Perspective(30.0))),
        );
        let v = |l: &Split, r| l.voxels(r)[0].clone();
        let (a, b) = (v(&near, 0), v(&near, 1));
        let far_x = if a.start == 0 { &a } else { &b };
        assert!(far_x.end > 32, "{a:?} {b:?}");
        // Orthographic: every block alike, the even split.
        let flat = Split::new(
            dims,
            [1.0; 3],
            16,
            None,
            2,
            Some(&cam(Projection::Orthographic(80.0))),
        );
        let w: Vec<u64> = flat.tree().leaves().iter().map(|f| f.weight).collect();
        assert_eq!(w, vec![32, 32]);
        // A narrow view of the middle: the corner blocks are off the image.
        let narrow = Split::new(
            dims,
            [1.0; 3],
            16,
            None,
            1,
            Some(&cam(Projection::Perspective(5.0))),
        );
        let all = Split::new(
            dims,
            [1.0; 3],
            16,
            None,
            1,
            Some(&cam(Projection::Perspective(60.0))),
        );
        assert!(narrow.tree().leaves()[0].weight < all.tree().leaves()[0].weight);
    }

    #[test]
    fn boxes_cover_the_volume_once_and_empty_ranks_get_no_share() {
        let dims = Dims::new(40, 33, 17).unwrap();
        let l = Split::new(dims, [0.5, 1.0, 2.0], 16, None, 20, None);
        let mut voxels = 0u64;
        let mut empty = 0;
        for r in 0..l.ranks() {
            let v = l.voxels(r);
            voxels += v.iter().map(|a| a.end - a.start).product::<u64>();
            if l.share(r).is_none() {
                empty += 1;
                assert!(v.iter().any(|a| a.is_empty()));
            }
        }
        assert_eq!(voxels, 40 * 33 * 17);
        // 3 x 3 x 2 = 18 blocks for 20 ranks: at least 2 go without.
        assert!((2..20).contains(&empty), "{empty} empty ranks");
        assert_eq!(composite_for(Mode::XrayMean), None);
        for (h, n) in [(700, 3), (2, 5), (0, 2), (1, 1)] {
            let rows: Vec<_> = (0..n).map(|j| strip_rows(h, n, j)).collect();
            assert_eq!(rows[0].start, 0);
            assert_eq!(rows[n - 1].end, h);
            assert!(rows.windows(2).all(|p| p[0].end == p[1].start));
        }
        assert_eq!(composite_for(Mode::Iso(1.0)), Some(Composite::FirstHit));
    }
}
