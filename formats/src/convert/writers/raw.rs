//! Headerless samples, x fastest; [`Rows`] writes them for the header
//! formats and the `.vol` spool too.

use super::{slab, Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::output::AtomicFile;
use crate::pipeline::write_rows;
use crate::reader::{At, CResult};
use crate::slice::SliceSample;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use volcore::{Dims, Sample};

/// Slices written in order, slab by slab, to a byte stream.
pub(super) struct Rows<'a> {
    dims: Dims,
    next_z: u64,
    slab: u64,
    /// Bytes written.
    pub(super) done: u64,
    progress: &'a (dyn Fn(u64) + Sync),
}

impl<'a> Rows<'a> {
    pub(super) fn new<T: Sample>(dims: Dims, progress: &'a (dyn Fn(u64) + Sync)) -> Rows<'a> {
        Rows {
            dims,
            next_z: 0,
            slab: slab(dims, T::TYPE.size()),
            done: 0,
            progress,
        }
    }

    pub(super) fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }

    /// Write the next slab from `win` to `out` (errors at `path`).
    pub(super) fn write<T: SliceSample>(
        &mut self,
        win: &SliceWindow<T>,
        out: &mut (dyn Write + Send),
        path: &Path,
    ) -> CResult<()> {
        let zs = self.next_slices();
        let y = self.dims.y;
        let base = self.done;
        let progress = self.progress;
        let w = write_rows(win, zs.start * y..zs.end * y, out, &|n| progress(base + n)).at(path)?;
        self.done += w.bytes;
        self.next_z = zs.end;
        Ok(())
    }
}

struct RawOut<'a> {
    rows: Rows<'a>,
    file: AtomicFile,
    path: PathBuf,
}

pub(super) fn open<'a, T: SliceSample>(path: PathBuf, spec: &OutSpec<'a>) -> Opened<'a, T> {
    let file = AtomicFile::create(&path).at(&path)?;
    Ok(Box::new(RawOut {
        rows: Rows::new::<T>(spec.dims, spec.progress),
        file,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for RawOut<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.rows.next_slices()
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        self.rows.write(win, self.file.file(), &self.path)
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let RawOut {
            rows,
            mut file,
            path,
        } = *self;
        file.file().flush().at(&path)?;
        file.commit().at(&path)?;
        Ok(Written {
            bytes: rows.done,
            range: None,
        })
    }
}
