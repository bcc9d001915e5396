//! Slices through the volume across one axis, as f32 values for the
//! page to window and to read under the cursor. Large slices are read
//! every `stride` voxels so that none is longer than [`MAX_SIDE`].

use crate::protocol::Axis;
use volcore::grid::{Cursor, VoxelSource};
use volcore::{Volume, VolumeVisitor};

/// The longest side of a slice sent to the page, in samples.
pub const MAX_SIDE: u64 = 1024;

/// One slice: `width × height` values, row by row, each `stride` voxels
/// apart.
#[derive(Clone, Debug, PartialEq)]
pub struct Slice {
    /// The axis it crosses.
    pub axis: Axis,
    /// The voxel index along that axis.
    pub index: u64,
    /// Values per row.
    pub width: u64,
    /// Rows.
    pub height: u64,
    /// Voxels between neighbouring values.
    pub stride: u64,
    /// The values.
    pub values: Vec<f32>,
}

/// The in-plane axes of a slice across `axis`: (columns, rows). Across z
/// (axial) x by y; across y (coronal) x by z; across x (sagittal) y by z.
pub fn plane(axis: Axis) -> (usize, usize) {
    match axis {
        Axis::X => (1, 2),
        Axis::Y => (0, 2),
        Axis::Z => (0, 1),
    }
}

/// The slice across `axis` at voxel `index`; an index outside the
/// volume is an error for the page.
pub fn extract(vol: &Volume, axis: Axis, index: u64) -> Result<Slice, String> {
    let d = vol.dims();
    let dims = [d.x, d.y, d.z];
    let a = match axis {
        Axis::X => 0,
        Axis::Y => 1,
        Axis::Z => 2,
    };
    if index >= dims[a] {
        return Err(format!(
            "slice {index} across {axis:?} is outside the volume (0..{})",
            dims[a]
        ));
    }
    let (u, v) = plane(axis);
    let stride = dims[u].max(dims[v]).div_ceil(MAX_SIDE).max(1);
    let (width, height) = (dims[u].div_ceil(stride), dims[v].div_ceil(stride));
    struct Read {
        a: usize,
        index: u64,
        u: usize,
        v: usize,
        stride: u64,
        width: u64,
        height: u64,
    }
    impl VolumeVisitor for Read {
        type Output = Vec<f32>;
        fn visit<S: VoxelSource>(self, src: &S) -> Vec<f32> {
            let mut c = src.cursor();
            let mut out = Vec::with_capacity((self.width * self.height) as usize);
            for row in 0..self.height {
                for col in 0..self.width {
                    let mut p = [0u64; 3];
                    p[self.a] = self.index;
                    p[self.u] = col * self.stride;
                    p[self.v] = row * self.stride;
                    out.push(c.voxel(p[0], p[1], p[2]));
                }
            }
            out
        }
    }
    let values = vol.visit(Read {
        a,
        index,
        u,
        v,
        stride,
        width,
        height,
    });
    if let Some(e) = vol.error() {
        return Err(e);
    }
    Ok(Slice {
        axis,
        index,
        width,
        height,
        stride,
        values,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::Dims;

    #[test]
    fn slices_read_the_voxels_they_name() {
        let d = Dims { x: 3, y: 4, z: 5 };
        let values: Vec<f32> = (0..60).map(|i| i as f32).collect();
        let vol = Volume::from_samples(d, values).unwrap();
        // Voxel (x, y, z) holds x + 3y + 12z.
        let z = extract(&vol, Axis::Z, 2).unwrap();
        assert_eq!((z.width, z.height, z.stride), (3, 4, 1));
        assert_eq!(z.values[3 + 1], (1 + 3 + 24) as f32);
        let x = extract(&vol, Axis::X, 1).unwrap();
        assert_eq!((x.width, x.height), (4, 5));
        assert_eq!(x.values[4 * 2 + 3], (1 + 9 + 24) as f32);
        let y = extract(&vol, Axis::Y, 3).unwrap();
        assert_eq!(y.values[3 * 4 + 2], (2 + 9 + 48) as f32);
        assert!(extract(&vol, Axis::Z, 5).unwrap_err().contains("outside"));
    }
}
