//! The outputs of a conversion, each fed unit by unit from a
//! [`SliceWindow`].

use super::{At, CResult, ConvertError, SliceSample, SliceWindow};
use crate::error::Error;
use crate::output::{AtomicFile, Sink};
use crate::pipeline::{write_rows, ITEM_BYTES};
use crate::thesis::ThesisLayout;
use crate::vvol::VvolWriter;
use memmap2::Mmap;
use rayon::prelude::*;
use std::fs::File;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use volcore::{
    BrickGeometry, Compression, Dims, Layout, RegionSource, Sample, SampleType, ValueRange,
    VolumeMeta,
};

/// Where and how to write the converted volume.
pub enum Target {
    /// A `.vvol` file, sliced (`brick: None`) or bricked, maybe compressed.
    Vvol {
        /// Output file.
        path: PathBuf,
        /// Brick edge, or `None` for sliced.
        brick: Option<u32>,
        /// Per-brick compression (bricked only).
        compression: Compression,
    },
    /// A sliced `.vvol` stream (standard output).
    VvolStream(Box<dyn Write + Send>),
    /// The thesis `.vol` format (u8 only).
    Thesis {
        /// Output file.
        path: PathBuf,
        /// Sliced or bricked.
        layout: ThesisLayout,
    },
    /// Headerless little-endian samples, x fastest.
    Raw {
        /// Output file.
        path: PathBuf,
    },
    /// One multipage TIFF (BigTIFF past 4 GiB).
    Tiff {
        /// Output file.
        path: PathBuf,
    },
    /// A directory of single-page TIFFs `slice_0000.tif`, ...
    TiffDir {
        /// Output directory (must not exist, or be empty).
        path: PathBuf,
    },
}

impl Target {
    /// The output path (`-` for a stream).
    pub fn path(&self) -> &Path {
        match self {
            Target::Vvol { path, .. }
            | Target::Thesis { path, .. }
            | Target::Raw { path }
            | Target::Tiff { path }
            | Target::TiffDir { path } => path,
            Target::VvolStream(_) => Path::new("-"),
        }
    }

    /// Check what can be checked before any work: a directory target
    /// must not exist or be empty.
    pub fn preflight(&self) -> CResult<()> {
        if let Target::TiffDir { path } = self {
            check_dir_target(path)?;
        }
        Ok(())
    }

    /// Where temporary files go by default: beside the output.
    pub fn temp_dir(&self) -> PathBuf {
        match self {
            Target::VvolStream(_) => std::env::temp_dir(),
            other => {
                let p = other.path();
                let p = if matches!(other, Target::TiffDir { .. }) {
                    p.components().as_path()
                } else {
                    p
                };
                match p.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                    _ => PathBuf::from("."),
                }
            }
        }
    }
}

/// An output written unit by unit.
pub(crate) trait SlabSink<T: Sample> {
    /// The output slices the next unit needs; empty when done.
    fn next_slices(&self) -> Range<u64>;
    /// Write the next unit from a window holding its slices.
    fn write_next(&mut self, w: &SliceWindow<T>) -> CResult<()>;
}

/// Output dimensions and the rest every writer needs.
pub(crate) struct OutSpec<'a> {
    pub dims: Dims,
    pub spacing: [f32; 3],
    pub temp_dir: &'a Path,
    pub progress: &'a (dyn Fn(u64) + Sync),
}

type Drive<'d, T> = dyn FnMut(&mut dyn SlabSink<T>) -> CResult<()> + 'd;

/// Slices per unit for slab writers: about 16 MiB, at least one slice.
fn slab(dims: Dims, size: usize) -> u64 {
    ((16 * ITEM_BYTES) / (dims.slice_len() * size as u64).max(1)).max(1)
}

/// Open the target, let `drive` feed it, and commit it. Returns the bytes
/// written and, when known, the value range.
pub(crate) fn run_target<T: SliceSample>(
    target: Target,
    spec: &OutSpec<'_>,
    drive: &mut Drive<'_, T>,
) -> CResult<(u64, Option<ValueRange>)> {
    let dims = spec.dims;
    let path = target.path().to_path_buf();
    match target {
        Target::Vvol {
            brick, compression, ..
        } => {
            let meta = vvol_meta::<T>(spec, brick, compression).at(&path)?;
            let mut file = AtomicFile::create(&path).at(&path)?;
            let stats = {
                let mut sink = VvolSink {
                    w: Some(
                        VvolWriter::new(Sink::File(file.file()), meta, spec.progress).at(&path)?,
                    ),
                    path: &path,
                };
                drive(&mut sink)?;
                sink.finish()?
            };
            file.commit().at(&path)?;
            Ok((stats.bytes, Some(stats.range)))
        }
        Target::VvolStream(mut out) => {
            let meta = vvol_meta::<T>(spec, None, Compression::None).at(&path)?;
            let mut sink = VvolSink {
                w: Some(VvolWriter::new(Sink::Stream(&mut out), meta, spec.progress).at(&path)?),
                path: &path,
            };
            drive(&mut sink)?;
            let stats = sink.finish()?;
            Ok((stats.bytes, Some(stats.range)))
        }
        Target::Raw { .. } => {
            let mut file = AtomicFile::create(&path).at(&path)?;
            let bytes = {
                let mut sink = RawSink {
                    out: file.file(),
                    dims,
                    next_z: 0,
                    slab: slab(dims, T::TYPE.size()),
                    done: 0,
                    range: ValueRange::EMPTY,
                    progress: spec.progress,
                    path: &path,
                };
                drive(&mut sink)?;
                sink.out.flush().at(&path)?;
                sink.done
            };
            file.commit().at(&path)?;
            Ok((bytes, None))
        }
        Target::Thesis { layout, .. } => {
            if T::TYPE != SampleType::U8 {
                return Err(ConvertError::new(
                    &path,
                    Error::invalid(format!(
                        "the thesis .vol format holds u8 samples only, not {}: add --type u8 --window ...",
                        T::TYPE
                    )),
                ));
            }
            // The thesis layouts are z-fastest or bricked over all of z:
            // spool the converted samples to a temporary file first.
            let mut tmp = tempfile::Builder::new()
                .prefix(".vol-convert-spool.")
                .tempfile_in(spec.temp_dir)
                .at(spec.temp_dir)?;
            {
                let mut sink = RawSink {
                    out: tmp.as_file_mut(),
                    dims,
                    next_z: 0,
                    slab: slab(dims, 1),
                    done: 0,
                    range: ValueRange::EMPTY,
                    progress: &|_| {},
                    path: &path,
                };
                drive(&mut sink)?;
                sink.out.flush().at(&path)?;
            }
            // SAFETY: our own temporary file, not truncated meanwhile.
            let map = unsafe { Mmap::map(tmp.as_file()) }.at(spec.temp_dir)?;
            let src = MappedU8 { dims, map };
            let mut file = AtomicFile::create(&path).at(&path)?;
            let bytes =
                crate::thesis::write(&src, spec.spacing, layout, file.file(), spec.progress)
                    .at(&path)?;
            file.commit().at(&path)?;
            Ok((bytes, None))
        }
        Target::Tiff { .. } => {
            let data = dims.count() * T::TYPE.size() as u64;
            let mut file = AtomicFile::create(&path).at(&path)?;
            // Standard TIFF offsets are 32-bit: leave room for directories.
            let bytes = if data + dims.z * 1024 < (1 << 32) - (1 << 20) {
                let enc = ::tiff::encoder::TiffEncoder::new(&mut *file.file())
                    .map_err(|e| Error::invalid(e.to_string()))
                    .at(&path)?;
                tiff_multi(enc, spec, &path, drive)?
            } else {
                let enc = ::tiff::encoder::TiffEncoder::new_big(&mut *file.file())
                    .map_err(|e| Error::invalid(e.to_string()))
                    .at(&path)?;
                tiff_multi(enc, spec, &path, drive)?
            };
            file.commit().at(&path)?;
            Ok((bytes, None))
        }
        Target::TiffDir { .. } => {
            let dir = PartialDir::create(&path)?;
            let width = (dims.z.max(1) - 1).to_string().len().max(4);
            let mut sink = TiffDirSink {
                dir: dir.temp.path(),
                dims,
                spacing: spec.spacing,
                width,
                next_z: 0,
                slab: slab(dims, T::TYPE.size()).max(rayon::current_num_threads() as u64),
                bytes: 0,
                progress: spec.progress,
                path: &path,
            };
            drive(&mut sink)?;
            let bytes = sink.bytes;
            dir.commit()?;
            Ok((bytes, None))
        }
    }
}

fn vvol_meta<T: Sample>(
    spec: &OutSpec<'_>,
    brick: Option<u32>,
    compression: Compression,
) -> crate::Result<VolumeMeta> {
    let layout = match brick {
        None => Layout::Sliced,
        Some(b) => Layout::Bricked(BrickGeometry::new(spec.dims, b)?),
    };
    if layout == Layout::Sliced && compression != Compression::None {
        return Err(Error::invalid(
            "--compress needs --layout bricked:B (compression is per brick)",
        ));
    }
    Ok(VolumeMeta {
        dims: spec.dims,
        spacing: spec.spacing,
        sample_type: T::TYPE,
        range: ValueRange::EMPTY,
        layout,
        compression,
    })
}

// ----------------------------------------------------------------- vvol --

struct VvolSink<'a, 'p> {
    w: Option<VvolWriter<'a>>,
    path: &'p Path,
}

impl VvolSink<'_, '_> {
    fn finish(&mut self) -> CResult<crate::vvol::WriteStats> {
        match self.w.take() {
            Some(w) => w.finish().at(self.path),
            None => Err(ConvertError::new(
                self.path,
                Error::invalid("finished twice"),
            )),
        }
    }
}

impl<T: SliceSample> SlabSink<T> for VvolSink<'_, '_> {
    fn next_slices(&self) -> Range<u64> {
        match &self.w {
            Some(w) => w.next_slices(),
            None => 0..0,
        }
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        match &mut self.w {
            Some(w) => w.write_next(win).at(self.path),
            None => Ok(()),
        }
    }
}

// ------------------------------------------------------------------ raw --

struct RawSink<'a> {
    out: &'a mut File,
    dims: Dims,
    next_z: u64,
    slab: u64,
    done: u64,
    range: ValueRange,
    progress: &'a (dyn Fn(u64) + Sync),
    path: &'a Path,
}

impl<T: SliceSample> SlabSink<T> for RawSink<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SlabSink<T>>::next_slices(self);
        let y = self.dims.y;
        let base = self.done;
        let progress = self.progress;
        let w = write_rows(win, zs.start * y..zs.end * y, self.out, &|n| {
            progress(base + n)
        })
        .at(self.path)?;
        self.done += w.bytes;
        self.range = self.range.merge(w.range);
        self.next_z = zs.end;
        Ok(())
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

// ----------------------------------------------------------------- tiff --

struct TiffMultiSink<'a, W: Write + std::io::Seek, K: ::tiff::encoder::TiffKind> {
    enc: ::tiff::encoder::TiffEncoder<W, K>,
    dims: Dims,
    spacing: [f32; 3],
    next_z: u64,
    slab: u64,
    bytes: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: &'a Path,
}

fn tiff_multi<W: Write + std::io::Seek, K: ::tiff::encoder::TiffKind, T: SliceSample>(
    enc: ::tiff::encoder::TiffEncoder<W, K>,
    spec: &OutSpec<'_>,
    path: &Path,
    drive: &mut Drive<'_, T>,
) -> CResult<u64> {
    let mut sink = TiffMultiSink {
        enc,
        dims: spec.dims,
        spacing: spec.spacing,
        next_z: 0,
        slab: slab(spec.dims, T::TYPE.size()),
        bytes: 0,
        progress: spec.progress,
        path,
    };
    drive(&mut sink)?;
    drop(sink.enc);
    Ok(std::fs::metadata(path)
        .map(|m| m.len())
        .unwrap_or(sink.bytes))
}

fn axis_u32(dims: Dims) -> Result<(u32, u32), Error> {
    match (u32::try_from(dims.x), u32::try_from(dims.y)) {
        (Ok(w), Ok(h)) => Ok((w, h)),
        _ => Err(Error::invalid(format!("{dims} is too wide for TIFF"))),
    }
}

impl<W: Write + std::io::Seek, K: ::tiff::encoder::TiffKind, T: SliceSample> SlabSink<T>
    for TiffMultiSink<'_, W, K>
{
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SlabSink<T>>::next_slices(self);
        let (w, h) = axis_u32(self.dims).at(self.path)?;
        for z in zs.clone() {
            let s = win.slice(z).ok_or_else(|| {
                ConvertError::new(self.path, Error::invalid("slice missing (internal error)"))
            })?;
            let desc = (z == 0).then(|| crate::tiff::imagej_description(self.spacing[2]));
            crate::tiff::write_page(&mut self.enc, w, h, s, self.spacing, desc.as_deref())
                .map_err(Error::invalid)
                .at(self.path)?;
            self.bytes += std::mem::size_of_val(s) as u64;
            (self.progress)(self.bytes);
        }
        self.next_z = zs.end;
        Ok(())
    }
}

fn check_dir_target(target: &Path) -> CResult<()> {
    if let Ok(mut entries) = std::fs::read_dir(target) {
        if entries.next().is_some() {
            return Err(ConvertError::new(
                target,
                Error::invalid("output directory exists and is not empty"),
            ));
        }
    } else if target.exists() {
        return Err(ConvertError::new(
            target,
            Error::invalid("exists and is not a directory"),
        ));
    }
    Ok(())
}

/// A directory written under a temporary name beside the target and
/// renamed into place when complete (removed if dropped before).
struct PartialDir {
    temp: tempfile::TempDir,
    target: PathBuf,
}

impl PartialDir {
    fn create(target: &Path) -> CResult<PartialDir> {
        let target = target.components().as_path().to_path_buf();
        check_dir_target(&target)?;
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".partial")
            .tempdir_in(&parent)
            .at(&parent)?;
        Ok(PartialDir { temp, target })
    }

    fn commit(self) -> CResult<()> {
        let target = self.target.clone();
        if target.is_dir() {
            // Empty (checked at creation): rename replaces it.
            std::fs::remove_dir(&target).at(&target)?;
        }
        let temp = self.temp.keep();
        std::fs::rename(&temp, &target).map_err(|e| {
            let _ = std::fs::remove_dir_all(&temp);
            ConvertError::new(&target, e)
        })
    }
}

struct TiffDirSink<'a> {
    dir: &'a Path,
    dims: Dims,
    spacing: [f32; 3],
    width: usize,
    next_z: u64,
    slab: u64,
    bytes: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: &'a Path,
}

impl<T: SliceSample> SlabSink<T> for TiffDirSink<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SlabSink<T>>::next_slices(self);
        let (w, h) = axis_u32(self.dims).at(self.path)?;
        let sizes: Vec<u64> = zs
            .clone()
            .into_par_iter()
            .map(|z| -> CResult<u64> {
                let name = format!("slice_{z:0width$}.tif", width = self.width);
                let p = self.dir.join(&name);
                let s = win.slice(z).ok_or_else(|| {
                    ConvertError::new(self.path, Error::invalid("slice missing (internal error)"))
                })?;
                let f = File::create(&p).at(self.path)?;
                let mut bw = std::io::BufWriter::with_capacity(1 << 20, f);
                {
                    let mut enc = ::tiff::encoder::TiffEncoder::new(&mut bw)
                        .map_err(|e| Error::invalid(e.to_string()))
                        .at(self.path)?;
                    let desc = crate::tiff::imagej_description(self.spacing[2]);
                    crate::tiff::write_page(&mut enc, w, h, s, self.spacing, Some(&desc))
                        .map_err(Error::invalid)
                        .at(self.path)?;
                }
                bw.flush().at(self.path)?;
                Ok(std::fs::metadata(&p).at(self.path)?.len())
            })
            .collect::<CResult<_>>()?;
        self.bytes += sizes.iter().sum::<u64>();
        (self.progress)(self.bytes);
        self.next_z = zs.end;
        Ok(())
    }
}
