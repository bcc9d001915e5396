//! Volume dimensions with checked arithmetic.

use crate::error::{Error, Result};
use std::fmt;

/// The number of voxels along x, y and z. Every axis is at least 1 and the
/// voxel count fits in a `u64` (checked by [`Dims::new`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dims {
    /// Voxels along x (the fastest axis in sliced order).
    pub x: u64,
    /// Voxels along y.
    pub y: u64,
    /// Voxels along z (the slowest axis in sliced order).
    pub z: u64,
}

/// The largest extent allowed along one axis. Sampling works in `f32` voxel
/// coordinates, which are exact integers up to 2^24.
pub const MAX_AXIS: u64 = 1 << 24;

impl Dims {
    /// Dimensions after checking that no axis is zero or larger than
    /// [`MAX_AXIS`] and that the voxel count does not overflow.
    pub fn new(x: u64, y: u64, z: u64) -> Result<Dims> {
        let d = Dims { x, y, z };
        if x == 0 || y == 0 || z == 0 {
            return Err(Error::Dims(format!("{d} has a zero axis")));
        }
        if x > MAX_AXIS || y > MAX_AXIS || z > MAX_AXIS {
            return Err(Error::Dims(format!(
                "{d} has an axis longer than {MAX_AXIS}"
            )));
        }
        d.checked_count()
            .ok_or_else(|| Error::Dims(format!("{d}: voxel count overflows 64 bits")))?;
        Ok(d)
    }

    /// Voxel count, or `None` if it overflows.
    pub fn checked_count(&self) -> Option<u64> {
        self.x.checked_mul(self.y)?.checked_mul(self.z)
    }

    /// Voxel count (validated at construction).
    pub fn count(&self) -> u64 {
        self.x * self.y * self.z
    }

    /// Voxels in one z slice.
    pub fn slice_len(&self) -> u64 {
        self.x * self.y
    }

    /// Bytes needed for all voxels at `bytes_per_sample`, checked.
    pub fn checked_bytes(&self, bytes_per_sample: u64) -> Result<u64> {
        self.count()
            .checked_mul(bytes_per_sample)
            .ok_or_else(|| Error::Dims(format!("{self}: byte size overflows 64 bits")))
    }

    /// The axes as an array `[x, y, z]`.
    pub fn as_array(&self) -> [u64; 3] {
        [self.x, self.y, self.z]
    }

    /// Sliced (x-fastest) linear index of voxel `(x, y, z)`.
    #[inline(always)]
    pub fn index(&self, x: u64, y: u64, z: u64) -> u64 {
        x + self.x * (y + self.y * z)
    }
}

impl fmt::Display for Dims {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}x{}", self.x, self.y, self.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_zero_and_overflow() {
        assert!(Dims::new(0, 1, 1).is_err());
        assert!(Dims::new(1, 1, 0).is_err());
        assert!(Dims::new(MAX_AXIS + 1, 1, 1).is_err());
        assert!(Dims::new(MAX_AXIS, MAX_AXIS, MAX_AXIS).is_err());
        let d = Dims::new(2000, 2000, 2000).unwrap();
        assert_eq!(d.count(), 8_000_000_000);
        assert!(d.checked_bytes(4).is_ok());
    }

    #[test]
    fn index_is_x_fastest() {
        let d = Dims::new(3, 4, 5).unwrap();
        assert_eq!(d.index(1, 0, 0), 1);
        assert_eq!(d.index(0, 1, 0), 3);
        assert_eq!(d.index(0, 0, 1), 12);
        assert_eq!(d.index(2, 3, 4), d.count() - 1);
    }
}
