//! TIFF output: one multipage file (BigTIFF past 4 GiB), or a directory of
//! single-page files `slice_0000.tif`, ...

use super::dir::{DirOutput, PartialDir};
use super::{slab, slice_of, Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::error::Error;
use crate::output::AtomicFile;
use crate::reader::{At, CResult};
use crate::slice::SliceSample;
use ::tiff::encoder::{TiffEncoder, TiffKind};
use rayon::prelude::*;
use std::fs::File;
use std::io::Write;
use std::ops::Range;
use std::path::PathBuf;
use volcore::Dims;

struct TiffOut<'a, K: TiffKind> {
    /// Writes to a handle on `file`.
    enc: TiffEncoder<File, K>,
    file: AtomicFile,
    dims: Dims,
    spacing: [f32; 3],
    /// The first page's ImageJ description (z spacing, unit).
    description: String,
    next_z: u64,
    slab: u64,
    bytes: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: PathBuf,
}

/// One multipage TIFF.
pub(super) fn open<'a, T: SliceSample>(path: PathBuf, spec: &OutSpec<'a>) -> Opened<'a, T> {
    let dims = spec.dims;
    let data = dims.count() * T::TYPE.size() as u64;
    let file = AtomicFile::create(&path).at(&path)?;
    let handle = file.handle().at(&path)?;
    // Standard TIFF offsets are 32-bit: leave room for directories.
    if data + dims.z * 1024 < (1 << 32) - (1 << 20) {
        let enc = TiffEncoder::new(handle)
            .map_err(|e| Error::invalid(e.to_string()))
            .at(&path)?;
        Ok(Box::new(TiffOut::new::<T>(enc, file, spec, path)))
    } else {
        let enc = TiffEncoder::new_big(handle)
            .map_err(|e| Error::invalid(e.to_string()))
            .at(&path)?;
        Ok(Box::new(TiffOut::new::<T>(enc, file, spec, path)))
    }
}

impl<'a, K: TiffKind> TiffOut<'a, K> {
    fn new<T: SliceSample>(
        enc: TiffEncoder<File, K>,
        file: AtomicFile,
        spec: &OutSpec<'a>,
        path: PathBuf,
    ) -> TiffOut<'a, K> {
        TiffOut {
            enc,
            file,
            dims: spec.dims,
            spacing: spec.spacing,
            description: crate::tiff::imagej_description(spec.spacing[2], spec.geometry.unit),
            next_z: 0,
            slab: slab(spec.dims, T::TYPE.size()),
            bytes: 0,
            progress: spec.progress,
            path,
        }
    }
}

fn axis_u32(dims: Dims) -> Result<(u32, u32), Error> {
    match (u32::try_from(dims.x), u32::try_from(dims.y)) {
        (Ok(w), Ok(h)) => Ok((w, h)),
        _ => Err(Error::invalid(format!("{dims} is too wide for TIFF"))),
    }
}

impl<K: TiffKind, T: SliceSample> SliceWriter<T> for TiffOut<'_, K> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SliceWriter<T>>::next_slices(self);
        let (w, h) = axis_u32(self.dims).at(&self.path)?;
        for z in zs.clone() {
            let s = slice_of(win, z, &self.path)?;
            let desc = (z == 0).then_some(self.description.as_str());
            crate::tiff::write_page(&mut self.enc, w, h, s, self.spacing, desc)
                .map_err(Error::invalid)
                .at(&self.path)?;
            self.bytes += std::mem::size_of_val(s) as u64;
            (self.progress)(self.bytes);
        }
        self.next_z = zs.end;
        Ok(())
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let TiffOut {
            enc,
            file,
            bytes,
            path,
            ..
        } = *self;
        drop(enc);
        file.commit().at(&path)?;
        // The committed file's size (pages, directories and all), not that
        // of a file it replaced.
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(bytes);
        Ok(Written { bytes, range: None })
    }
}

struct TiffDirOut<'a> {
    dir: PartialDir,
    dims: Dims,
    spacing: [f32; 3],
    /// Every page's ImageJ description (z spacing, unit).
    description: String,
    /// Digits of the slice number in the file names.
    width: usize,
    next_z: u64,
    slab: u64,
    bytes: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: PathBuf,
}

/// A directory of single-page TIFFs.
pub(super) fn open_dir<'a, T: SliceSample>(path: PathBuf, spec: &OutSpec<'a>) -> Opened<'a, T> {
    let dims = spec.dims;
    let dir = PartialDir::create(&path, DirOutput::TiffSlices)?;
    Ok(Box::new(TiffDirOut {
        dir,
        dims,
        spacing: spec.spacing,
        description: crate::tiff::imagej_description(spec.spacing[2], spec.geometry.unit),
        width: (dims.z.max(1) - 1).to_string().len().max(4),
        next_z: 0,
        slab: slab(dims, T::TYPE.size()).max(rayon::current_num_threads() as u64),
        bytes: 0,
        progress: spec.progress,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for TiffDirOut<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SliceWriter<T>>::next_slices(self);
        let (w, h) = axis_u32(self.dims).at(&self.path)?;
        let path = &self.path;
        let sizes: Vec<u64> = zs
            .clone()
            .into_par_iter()
            .map(|z| -> CResult<u64> {
                let name = format!("slice_{z:0width$}.tif", width = self.width);
                let p = self.dir.temp.path().join(&name);
                let s = slice_of(win, z, path)?;
                let f = File::create(&p).at(path)?;
                let mut bw = std::io::BufWriter::with_capacity(1 << 20, f);
                {
                    let mut enc = TiffEncoder::new(&mut bw)
                        .map_err(|e| Error::invalid(e.to_string()))
                        .at(path)?;
                    crate::tiff::write_page(
                        &mut enc,
                        w,
                        h,
                        s,
                        self.spacing,
                        Some(&self.description),
                    )
                    .map_err(Error::invalid)
                    .at(path)?;
                }
                bw.flush().at(path)?;
                Ok(std::fs::metadata(&p).at(path)?.len())
            })
            .collect::<CResult<_>>()?;
        self.bytes += sizes.iter().sum::<u64>();
        (self.progress)(self.bytes);
        self.next_z = zs.end;
        Ok(())
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let bytes = self.bytes;
        self.dir.commit()?;
        Ok(Written { bytes, range: None })
    }
}
