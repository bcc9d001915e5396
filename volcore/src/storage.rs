//! Where samples live: an owned vector or a region of a memory map.

use crate::error::{Error, Result};
use crate::sample::Sample;
use memmap2::Mmap;
use std::sync::Arc;

/// A read-only array of samples, owned or borrowed from a shared memory map.
/// Either way it dereferences to `&[T]`.
pub enum Data<T: Sample> {
    /// Samples in an owned vector.
    Owned(Vec<T>),
    /// `len` samples starting `offset` bytes into a memory map.
    Mapped {
        /// The shared map (one per open file).
        map: Arc<Mmap>,
        /// Byte offset of the first sample.
        offset: usize,
        /// Number of samples.
        len: usize,
        /// The type marker.
        _t: std::marker::PhantomData<T>,
    },
}

// Samples stored in files are little-endian; mapping them in place is only
// correct on little-endian hosts, which are the only ones volkit builds for.
#[cfg(target_endian = "big")]
compile_error!("volkit maps little-endian sample data in place and needs a little-endian host");

impl<T: Sample> Data<T> {
    /// A view of `len` samples at byte `offset` of `map`, checking bounds and
    /// alignment.
    pub fn mapped(map: Arc<Mmap>, offset: usize, len: usize) -> Result<Data<T>> {
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())
            .and_then(|b| b.checked_add(offset))
            .ok_or_else(|| Error::Corrupt("mapped region overflows".into()))?;
        if bytes > map.len() {
            return Err(Error::Corrupt(format!(
                "mapped region ends at byte {bytes} but the file has {}",
                map.len()
            )));
        }
        if bytemuck::try_cast_slice::<u8, T>(&map[offset..bytes]).is_err() {
            return Err(Error::Corrupt(format!(
                "samples at byte {offset} are not aligned for {}",
                T::TYPE
            )));
        }
        Ok(Data::Mapped {
            map,
            offset,
            len,
            _t: std::marker::PhantomData,
        })
    }

    /// The samples.
    #[inline(always)]
    pub fn as_slice(&self) -> &[T] {
        match self {
            Data::Owned(v) => v,
            Data::Mapped {
                map, offset, len, ..
            } => {
                let end = offset + len * std::mem::size_of::<T>();
                // Bounds and alignment were checked in `mapped`.
                bytemuck::cast_slice(&map[*offset..end])
            }
        }
    }

    /// Whether the samples come from a memory map.
    pub fn is_mapped(&self) -> bool {
        matches!(self, Data::Mapped { .. })
    }
}

impl<T: Sample> std::ops::Deref for Data<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        self.as_slice()
    }
}
