//! Brick geometry: which voxels a brick owns and which it stores.
//!
//! A brick of edge `B` *owns* the voxels `[b·B, b·B + B)` along each axis and
//! *stores* one more voxel before them and two after (`apron_lo = 1`,
//! `apron_hi = 2`), so its stored cube has edge `B + 3`. That is exactly what
//! trilinear interpolation (voxels `i, i+1`) and central differences of the
//! interpolant (voxels `i-1 .. i+2`) need for any point whose integer part
//! `i` the brick owns. Stored voxels outside the volume repeat the nearest
//! voxel inside it (clamp to edge), the same rule the sliced sampler applies,
//! so both layouts interpolate to identical values everywhere.
//!
//! Bricks are numbered x fastest: index = bx + nx·(by + ny·bz). Inside a
//! brick, stored voxels are x fastest too.

use crate::dims::Dims;
use crate::error::{Error, Result};

/// Voxels stored before the owned range on each axis.
pub const APRON_LO: u32 = 1;
/// Voxels stored after the owned range on each axis.
pub const APRON_HI: u32 = 2;
/// Smallest allowed brick edge.
pub const MIN_BRICK: u32 = 2;
/// Largest allowed brick edge.
pub const MAX_BRICK: u32 = 1024;

/// The brick decomposition of a volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrickGeometry {
    dims: Dims,
    brick: u32,
    counts: [u64; 3],
}

impl BrickGeometry {
    /// Geometry for bricks of edge `brick` over `dims`.
    pub fn new(dims: Dims, brick: u32) -> Result<BrickGeometry> {
        if !(MIN_BRICK..=MAX_BRICK).contains(&brick) {
            return Err(Error::Layout(format!(
                "brick edge {brick} is outside {MIN_BRICK}..={MAX_BRICK}"
            )));
        }
        let b = brick as u64;
        let counts = [dims.x.div_ceil(b), dims.y.div_ceil(b), dims.z.div_ceil(b)];
        let g = BrickGeometry {
            dims,
            brick,
            counts,
        };
        g.brick_count()
            .checked_mul(g.stored_len() as u64)
            .ok_or_else(|| Error::Layout("brick storage size overflows 64 bits".into()))?;
        Ok(g)
    }

    /// The volume's dimensions.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Owned edge `B`.
    pub fn brick(&self) -> u32 {
        self.brick
    }

    /// Stored edge `B + apron_lo + apron_hi`.
    #[inline(always)]
    pub fn stored_edge(&self) -> u32 {
        self.brick + APRON_LO + APRON_HI
    }

    /// Samples stored per brick.
    #[inline(always)]
    pub fn stored_len(&self) -> usize {
        let e = self.stored_edge() as usize;
        e * e * e
    }

    /// Bricks along x, y, z.
    pub fn counts(&self) -> [u64; 3] {
        self.counts
    }

    /// Total number of bricks.
    pub fn brick_count(&self) -> u64 {
        self.counts[0] * self.counts[1] * self.counts[2]
    }

    /// Linear brick index of brick coordinates.
    #[inline(always)]
    pub fn brick_index(&self, bx: u64, by: u64, bz: u64) -> u64 {
        bx + self.counts[0] * (by + self.counts[1] * bz)
    }

    /// Brick coordinates of a linear brick index.
    pub fn brick_coords(&self, index: u64) -> [u64; 3] {
        let bx = index % self.counts[0];
        let rest = index / self.counts[0];
        [bx, rest % self.counts[1], rest / self.counts[1]]
    }

    /// Volume coordinate (may be negative or past the far face) of the
    /// brick's first stored voxel along each axis.
    pub fn stored_origin(&self, brick: [u64; 3]) -> [i64; 3] {
        let b = self.brick as i64;
        brick.map(|c| c as i64 * b - APRON_LO as i64)
    }

    /// For a brick, the volume coordinates its stored voxels read, per axis:
    /// the stored range clamped to the volume (clamp-to-edge padding).
    pub fn stored_coords(&self, brick: [u64; 3]) -> [Vec<u64>; 3] {
        let origin = self.stored_origin(brick);
        let e = self.stored_edge() as i64;
        let d = self.dims.as_array();
        std::array::from_fn(|a| {
            (0..e)
                .map(|s| (origin[a] + s).clamp(0, d[a] as i64 - 1) as u64)
                .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_cover_the_volume() {
        let g = BrickGeometry::new(Dims::new(33, 32, 1).unwrap(), 16).unwrap();
        assert_eq!(g.counts(), [3, 2, 1]);
        assert_eq!(g.stored_edge(), 19);
        assert_eq!(g.brick_coords(g.brick_index(2, 1, 0)), [2, 1, 0]);
        assert!(BrickGeometry::new(Dims::new(4, 4, 4).unwrap(), 1).is_err());
    }

    #[test]
    fn stored_coords_clamp_to_edge() {
        let g = BrickGeometry::new(Dims::new(5, 5, 5).unwrap(), 4).unwrap();
        let c = g.stored_coords([1, 0, 0]);
        // Brick 1 owns x = 4 only; stores 3 (apron), 4, and two clamped past the face.
        assert_eq!(&c[0][..4], &[3, 4, 4, 4]);
        assert_eq!(c[1][0], 0); // -1 clamped
    }
}
