//! Where a volume's samples lie.

use volcore::{Dims, Geometry};

/// A voxel grid: how many voxels, how far apart, and where in the world.
/// Voxel `(i, j, k)` is at `geometry.origin + D · (i·sx, j·sy, k·sz)`
/// (see [`Geometry`]); spacing is in the geometry's unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Voxels per axis.
    pub dims: Dims,
    /// Distance between voxel centres along each index axis.
    pub spacing: [f64; 3],
    /// Origin, axis directions and unit.
    pub geometry: Geometry,
}

impl Grid {
    /// A grid from the f32 spacing volumes store.
    pub fn new(dims: Dims, spacing: [f32; 3], geometry: Geometry) -> Grid {
        Grid {
            dims,
            spacing: spacing.map(f64::from),
            geometry,
        }
    }

    /// The spacing as volumes store it.
    pub fn spacing_f32(&self) -> [f32; 3] {
        self.spacing.map(|s| s as f32)
    }

    /// Samples in one z slice.
    pub fn slice_len(&self) -> usize {
        (self.dims.x * self.dims.y) as usize
    }

    /// World position of continuous index `ijk`.
    pub fn world(&self, ijk: [f64; 3]) -> [f64; 3] {
        let d = &self.geometry.direction;
        let s = [
            ijk[0] * self.spacing[0],
            ijk[1] * self.spacing[1],
            ijk[2] * self.spacing[2],
        ];
        std::array::from_fn(|r| {
            self.geometry.origin[r] + d[r][0] * s[0] + d[r][1] * s[1] + d[r][2] * s[2]
        })
    }

    /// Continuous index of world position `p` (the direction matrix is
    /// orthonormal in every grid volkit reads, so its inverse is its
    /// transpose; a general matrix is inverted).
    pub fn index(&self, p: [f64; 3]) -> [f64; 3] {
        let inv = invert3(&self.geometry.direction);
        let q = [
            p[0] - self.geometry.origin[0],
            p[1] - self.geometry.origin[1],
            p[2] - self.geometry.origin[2],
        ];
        std::array::from_fn(|a| {
            (inv[a][0] * q[0] + inv[a][1] * q[1] + inv[a][2] * q[2]) / self.spacing[a]
        })
    }

    /// One line: `NXxNYxNZ spacing X,Y,Z origin X,Y,Z` (for errors that
    /// name two grids).
    pub fn describe(&self) -> String {
        let s = self.spacing;
        let o = self.geometry.origin;
        format!(
            "{} spacing {},{},{} origin {},{},{} ({})",
            self.dims,
            s[0],
            s[1],
            s[2],
            o[0],
            o[1],
            o[2],
            self.geometry.orientation()
        )
    }

    /// Whether two grids put the same voxels at the same places (dims
    /// equal, spacing, origin and directions equal to a relative 1e-6 of
    /// the spacing).
    pub fn same_as(&self, o: &Grid) -> bool {
        if self.dims != o.dims {
            return false;
        }
        let tol = 1e-6
            * self
                .spacing
                .iter()
                .chain(&o.spacing)
                .fold(0.0f64, |a, &b| a.max(b.abs()));
        let close = |a: f64, b: f64| (a - b).abs() <= tol.max(1e-12);
        (0..3).all(|a| close(self.spacing[a], o.spacing[a]))
            && (0..3).all(|r| close(self.geometry.origin[r], o.geometry.origin[r]))
            && (0..3).all(|r| {
                (0..3).all(|c| {
                    (self.geometry.direction[r][c] - o.geometry.direction[r][c]).abs() <= 1e-6
                })
            })
    }
}

/// The inverse of a 3x3 matrix (the identity for a singular one, which
/// [`Geometry::from_axes`] refuses to build).
pub fn invert3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = m[0][0] * c(1, 2, 1, 2) - m[0][1] * c(1, 2, 0, 2) + m[0][2] * c(1, 2, 0, 1);
    if det.abs() < 1e-300 || !det.is_finite() {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let adj = [
        [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
        [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
        [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
    ];
    adj.map(|row| row.map(|v| v / det))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_inverts_world_on_a_rotated_grid() {
        let g = Geometry::from_axes(
            [10.0, -5.0, 3.0],
            [[0.6, 0.8, 0.0], [-0.8, 0.6, 0.0], [0.0, 0.0, -1.0]],
        )
        .unwrap();
        let grid = Grid {
            dims: Dims::new(4, 5, 6).unwrap(),
            spacing: [0.5, 0.7, 2.0],
            geometry: g,
        };
        let ijk = [1.25, 3.5, -2.0];
        let back = grid.index(grid.world(ijk));
        for a in 0..3 {
            assert!((back[a] - ijk[a]).abs() < 1e-12, "{back:?}");
        }
    }
}
