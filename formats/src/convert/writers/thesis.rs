//! The thesis `.vol` format (u8 only). Its layouts are z-fastest or
//! bricked over all of z: the samples are spooled to a temporary file,
//! and the output is written from it at the end.

use super::raw::Rows;
use super::{Opened, OutSpec, SliceWriter, Written};
use crate::convert::spool::SPOOL_PREFIX;
use crate::convert::SliceWindow;
use crate::error::Error;
use crate::output::AtomicFile;
use crate::reader::{At, CResult, ConvertError};
use crate::slice::SliceSample;
use crate::thesis::ThesisLayout;
use memmap2::Mmap;
use std::io::Write;
use std::ops::Range;
use std::path::PathBuf;
use tempfile::NamedTempFile;
use volcore::{Dims, RegionSource, SampleType};

struct ThesisOut<'a> {
    rows: Rows<'a>,
    spool: NamedTempFile,
    temp_dir: PathBuf,
    dims: Dims,
    spacing: [f32; 3],
    layout: ThesisLayout,
    progress: &'a (dyn Fn(u64) + Sync),
    path: PathBuf,
}

pub(super) fn open<'a, T: SliceSample>(
    path: PathBuf,
    spec: &OutSpec<'a>,
    layout: ThesisLayout,
) -> Opened<'a, T> {
    if T::TYPE != SampleType::U8 {
        return Err(ConvertError::new(
            &path,
            Error::invalid(format!(
                "the thesis .vol format holds u8 samples only, not {}: add --type u8 --window ...",
                T::TYPE
            )),
        ));
    }
    let spool = crate::output::temp_file_in(spec.temp_dir, SPOOL_PREFIX, "").at(spec.temp_dir)?;
    Ok(Box::new(ThesisOut {
        rows: Rows::new::<u8>(spec.dims, &|_| {}),
        spool,
        temp_dir: spec.temp_dir.to_path_buf(),
        dims: spec.dims,
        spacing: spec.spacing,
        layout,
        progress: spec.progress,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for ThesisOut<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.rows.next_slices()
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        self.rows.write(win, self.spool.as_file_mut(), &self.path)
    }
    fn finish(mut self: Box<Self>) -> CResult<Written> {
        let path = &self.path;
        self.spool.as_file_mut().flush().at(path)?;
        // SAFETY: our own temporary file, not truncated meanwhile.
        let map = unsafe { Mmap::map(self.spool.as_file()) }.at(&self.temp_dir)?;
        let src = MappedU8 {
            dims: self.dims,
            map,
        };
        let mut file = AtomicFile::create(path).at(path)?;
        let bytes =
            crate::thesis::write(&src, self.spacing, self.layout, file.file(), self.progress)
                .at(path)?;
        file.commit().at(path)?;
        Ok(Written { bytes, range: None })
    }
}

/// A memory-mapped sliced u8 volume.
struct MappedU8 {
    dims: Dims,
    map: Mmap,
}

impl RegionSource for MappedU8 {
    type Sample = u8;
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [u8]) {
        let s = self.dims.index(x0, y, z) as usize;
        out.copy_from_slice(&self.map[s..s + out.len()]);
    }
}
