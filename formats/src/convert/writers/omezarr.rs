//! OME-Zarr output: a whole store written to a temporary directory and
//! renamed into place, or one shard's chunks written straight into a
//! shared store.

use super::dir::{check_shard_store, DirOutput, PartialDir};
use super::{slice_of, Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::omezarr::{Downsample, Ngff, ZarrWriter};
use crate::reader::{At, CResult};
use crate::slice::SliceSample;
use std::ops::Range;
use std::path::PathBuf;
use volcore::Shard;

struct ZarrOut<'a, T: SliceSample> {
    w: ZarrWriter<T>,
    /// The temporary directory of a whole store (`None`: a shard).
    dir: Option<PartialDir>,
    /// One past the last slice to write.
    end: u64,
    next_z: u64,
    slab: u64,
    done: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: PathBuf,
}

/// A store of `levels` levels, each made from the one above by
/// `downsample`, in NGFF version `ngff`; with `shard`, that shard's chunks.
pub(super) fn open<'a, T: SliceSample>(
    path: PathBuf,
    spec: &OutSpec<'a>,
    (levels, downsample, ngff): (u32, Downsample, Ngff),
    shard: Option<Shard>,
) -> Opened<'a, T> {
    let dims = spec.dims;
    let store = crate::omezarr::StoreSpec {
        dims,
        spacing: spec.spacing,
        geometry: &spec.geometry,
        levels,
        down: downsample,
        ngff,
    };
    // A shard writes its slices straight into the shared store; a whole
    // write goes to a temporary directory renamed when done.
    let (w, zs, dir) = match shard {
        Some(shard) => {
            check_shard_store(&path)?;
            let w = ZarrWriter::<T>::create_shard(&path, &store, shard).at(&path)?;
            let zs = crate::omezarr::shard_slices(dims, spec.spacing, levels, shard).at(&path)?;
            (w, zs, None)
        }
        None => {
            let dir = PartialDir::create(&path, DirOutput::OmeZarr)?;
            let name = crate::omezarr::file_name(&path);
            let w = ZarrWriter::<T>::create_as(dir.temp.path(), &store, &name).at(&path)?;
            (w, 0..dims.z, Some(dir))
        }
    };
    Ok(Box::new(ZarrOut {
        w,
        dir,
        end: zs.end,
        next_z: zs.start,
        slab: crate::omezarr::CHUNK.min(dims.z),
        done: 0,
        progress: spec.progress,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for ZarrOut<'_, T> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.end)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SliceWriter<T>>::next_slices(self);
        for z in zs.clone() {
            let s = slice_of(win, z, &self.path)?;
            self.w.push(s.to_vec()).at(&self.path)?;
            self.done += std::mem::size_of_val(s) as u64;
            (self.progress)(self.done);
        }
        self.next_z = zs.end;
        Ok(())
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let ZarrOut {
            w, dir, done, path, ..
        } = *self;
        w.finish().at(&path)?;
        if let Some(dir) = dir {
            dir.commit()?;
        }
        Ok(Written {
            bytes: done,
            range: None,
        })
    }
}
