//! Where samples live: an owned vector or a region of a memory map.

use crate::error::{Error, Result};
use crate::sample::Sample;
use memmap2::Mmap;
use std::fs::File;
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
        /// The file the map shows, when it maps one, for
        /// [`Data::read_at`].
        file: Option<Arc<File>>,
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
        Self::mapped_with(map, None, offset, len)
    }

    /// [`Data::mapped`] for a map of the whole of `file` (from its first
    /// byte), which [`Data::read_at`] then reads directly.
    pub fn mapped_file(
        map: Arc<Mmap>,
        file: Arc<File>,
        offset: usize,
        len: usize,
    ) -> Result<Data<T>> {
        Self::mapped_with(map, Some(file), offset, len)
    }

    fn mapped_with(
        map: Arc<Mmap>,
        file: Option<Arc<File>>,
        offset: usize,
        len: usize,
    ) -> Result<Data<T>> {
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
            file,
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

    /// Whether [`Data::read_at`] reads the mapped file rather than
    /// copying from memory.
    pub fn reads_file(&self) -> bool {
        cfg!(unix) && matches!(self, Data::Mapped { file: Some(_), .. })
    }

    /// Copy samples `start .. start + out.len()` into `out`.
    ///
    /// Samples mapped from a file are read from the file with a positioned
    /// read, bypassing the map: for one pass over a file in the page cache
    /// that costs a copy into `out` (which stays in cache for the caller)
    /// but none of the page-table work of faulting the map in and tearing
    /// it down, which for a large file costs more than the copy.
    pub fn read_at(&self, start: usize, out: &mut [T]) -> std::io::Result<()> {
        let end = start
            .checked_add(out.len())
            .filter(|&e| e <= self.len())
            .ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!(
                        "samples {start}..+{} are outside the {} stored",
                        out.len(),
                        self.len()
                    ),
                )
            })?;
        #[cfg(unix)]
        if let Data::Mapped {
            offset,
            file: Some(file),
            ..
        } = self
        {
            use std::os::unix::fs::FileExt;
            let size = std::mem::size_of::<T>();
            let at = (offset + start * size) as u64;
            return file.read_exact_at(bytemuck::cast_slice_mut(out), at);
        }
        out.copy_from_slice(&self.as_slice()[start..end]);
        Ok(())
    }
}

impl<T: Sample> std::ops::Deref for Data<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        self.as_slice()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A file of `header` bytes then the little-endian u16 samples `0..n`,
    /// mapped whole.
    fn mapped_u16(header: usize, n: u16) -> (Arc<Mmap>, Arc<File>, Vec<u16>) {
        let samples: Vec<u16> = (0..n).map(|v| v.wrapping_mul(2654)).collect();
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(&vec![0xAB; header]).unwrap();
        f.write_all(bytemuck::cast_slice(&samples)).unwrap();
        let map = Arc::new(unsafe { Mmap::map(&f) }.unwrap());
        (map, Arc::new(f), samples)
    }

    #[test]
    fn read_at_reads_the_same_samples_from_file_map_or_vector() {
        let (map, file, want) = mapped_u16(6, 1000);
        let from_file = Data::<u16>::mapped_file(map.clone(), file, 6, 1000).unwrap();
        let from_map = Data::<u16>::mapped(map, 6, 1000).unwrap();
        let owned = Data::Owned(want.clone());
        assert!(from_file.reads_file() == cfg!(unix));
        assert!(!from_map.reads_file() && !owned.reads_file());
        for data in [&from_file, &from_map, &owned] {
            assert_eq!(data.as_slice(), &want[..]);
            for (start, n) in [(0, 1000), (0, 0), (999, 1), (313, 77)] {
                let mut out = vec![7u16; n];
                data.read_at(start, &mut out).unwrap();
                assert_eq!(out, &want[start..start + n], "{start}+{n}");
            }
            // Past the end, or a start so large the end overflows.
            let mut out = vec![0u16; 2];
            for start in [999, 1000, usize::MAX] {
                let e = data.read_at(start, &mut out).unwrap_err();
                assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
            }
        }
    }
}
