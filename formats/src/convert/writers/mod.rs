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
use std::sync::{Arc, Mutex};
use volcore::{
    BrickGeometry, Compression, Dims, Geometry, Layout, LengthUnit, RegionSource, Sample,
    SampleType, Shard, ValueRange, Volume, VolumeMeta,
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
    /// One shard's part of a `.vvol` file (see [`crate::vvol::part`]):
    /// its slices (sliced) or brick layers (bricked), to be merged.
    VvolPart {
        /// Output part file.
        path: PathBuf,
        /// Brick edge, or `None` for sliced.
        brick: Option<u32>,
        /// Per-brick compression (bricked only).
        compression: Compression,
        /// Which shard.
        shard: Shard,
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
    /// An in-memory [`Volume`], left in the slot (what
    /// [`crate::open::load`] uses).
    Memory(MemorySlot),
    /// An OME-Zarr directory (NGFF 0.4 on Zarr v2, or 0.5 on Zarr v3)
    /// with a multiscale pyramid.
    OmeZarr {
        /// Output directory (must not exist, or be empty).
        path: PathBuf,
        /// Pyramid levels, the full resolution included (at least 1).
        levels: u32,
        /// How each level is made from the one above.
        downsample: crate::omezarr::Downsample,
        /// NGFF version, and with it the Zarr format.
        ngff: crate::omezarr::Ngff,
        /// Write only this shard's chunks, straight into the store.
        shard: Option<Shard>,
    },
    /// A header format with its samples (NIfTI, NRRD, MetaImage): in the
    /// header's file or a detached one, raw or compressed.
    Headed {
        /// The header file (or the single file).
        path: PathBuf,
        /// Which header.
        format: HeaderFormat,
        /// Where the samples go when not after the header.
        data: Option<PathBuf>,
        /// How the samples (for `.nii.gz`: the whole file) are compressed.
        codec: DataCodec,
        /// The deflate level of gzip and zlib (1-9).
        level: u32,
    },
}

/// The header formats volkit writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeaderFormat {
    /// NIfTI-1 (NIfTI-2 for dimensions past 32767).
    Nifti,
    /// NRRD (`.nrrd` attached, `.nhdr` detached).
    Nrrd,
    /// MetaImage (`.mha` attached, `.mhd` detached).
    MetaImage,
}

/// Compression of the samples of a [`Target::Headed`] file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataCodec {
    /// Plain little-endian samples.
    Raw,
    /// gzip (NRRD `encoding: gzip`; for NIfTI the whole `.nii.gz`).
    Gzip,
    /// zlib (MetaImage `CompressedData = True`).
    Zlib,
}

impl Target {
    /// The target a file name asks for among the header formats: `.nii`,
    /// `.nii.gz`, `.hdr` (+ `.img`), `.nrrd`, `.nhdr` (+ `.raw`), `.mha`,
    /// `.mhd` (+ `.raw`); `compress` gzips NRRD data and zlibs MetaImage
    /// data (`.nii.gz` is compressed by its name). `None` for other names.
    pub fn headed(path: &Path, compress: bool) -> Option<Target> {
        let s = path.to_string_lossy();
        let l = s.to_ascii_lowercase();
        let stem = |ext: &str| s[..s.len() - ext.len()].to_string();
        let (format, data, codec) = if l.ends_with(".nii.gz") {
            (HeaderFormat::Nifti, None, DataCodec::Gzip)
        } else if l.ends_with(".nii") {
            (HeaderFormat::Nifti, None, DataCodec::Raw)
        } else if l.ends_with(".hdr") {
            let codec = if compress {
                DataCodec::Gzip
            } else {
                DataCodec::Raw
            };
            let img = stem(".hdr") + if compress { ".img.gz" } else { ".img" };
            (HeaderFormat::Nifti, Some(PathBuf::from(img)), codec)
        } else if l.ends_with(".nrrd") {
            let codec = if compress {
                DataCodec::Gzip
            } else {
                DataCodec::Raw
            };
            (HeaderFormat::Nrrd, None, codec)
        } else if l.ends_with(".nhdr") {
            let codec = if compress {
                DataCodec::Gzip
            } else {
                DataCodec::Raw
            };
            let raw = stem(".nhdr") + if compress { ".raw.gz" } else { ".raw" };
            (HeaderFormat::Nrrd, Some(PathBuf::from(raw)), codec)
        } else if l.ends_with(".mha") {
            let codec = if compress {
                DataCodec::Zlib
            } else {
                DataCodec::Raw
            };
            (HeaderFormat::MetaImage, None, codec)
        } else if l.ends_with(".mhd") {
            let codec = if compress {
                DataCodec::Zlib
            } else {
                DataCodec::Raw
            };
            let raw = stem(".mhd") + if compress { ".zraw" } else { ".raw" };
            (HeaderFormat::MetaImage, Some(PathBuf::from(raw)), codec)
        } else {
            return None;
        };
        Some(Target::Headed {
            path: path.to_path_buf(),
            format,
            data,
            codec,
            level: crate::gzip::DEFAULT_LEVEL,
        })
    }

    /// The same target compressing at deflate `level` (1-9; header
    /// formats only, others are returned as they are).
    pub fn with_deflate_level(self, level: u32) -> Target {
        match self {
            Target::Headed {
                path,
                format,
                data,
                codec,
                ..
            } => Target::Headed {
                path,
                format,
                data,
                codec,
                level: level.clamp(1, 9),
            },
            other => other,
        }
    }
}

/// Where a [`Target::Memory`] conversion leaves its volume.
#[derive(Clone, Default)]
pub struct MemorySlot(Arc<Mutex<Option<Volume>>>);

impl MemorySlot {
    /// The volume, once the conversion is done.
    pub fn take(&self) -> Option<Volume> {
        self.0.lock().ok().and_then(|mut v| v.take())
    }

    fn put(&self, v: Volume) {
        if let Ok(mut s) = self.0.lock() {
            *s = Some(v);
        }
    }
}

impl Target {
    /// The output path (`-` for a stream).
    pub fn path(&self) -> &Path {
        match self {
            Target::Vvol { path, .. }
            | Target::VvolPart { path, .. }
            | Target::Thesis { path, .. }
            | Target::Raw { path }
            | Target::Tiff { path }
            | Target::TiffDir { path }
            | Target::Headed { path, .. }
            | Target::OmeZarr { path, .. } => path,
            Target::VvolStream(_) | Target::Memory(_) => Path::new("-"),
        }
    }

    /// The units of length the output can state, and its name for the
    /// message when it cannot state the input's: NIfTI has codes for m,
    /// mm and µm only, MetaImage has no unit field (ITK and everything
    /// that reads it takes millimetres). `None`: the output holds every
    /// unit, or no geometry at all (raw, `.vol`).
    pub fn units(&self) -> Option<(&'static [LengthUnit], &'static str)> {
        match self {
            Target::Headed {
                format: HeaderFormat::Nifti,
                ..
            } => Some((&crate::nifti::UNITS, "NIfTI")),
            Target::Headed {
                format: HeaderFormat::MetaImage,
                ..
            } => Some((&[LengthUnit::Millimeter], "MetaImage")),
            _ => None,
        }
    }

    /// Whether the output holds `f64` samples: every file format volkit
    /// writes `f64` to does; an in-memory volume is read by the renderer,
    /// which takes `f64` as `f32` (see [`volcore::Narrowing`]).
    pub fn holds_f64(&self) -> bool {
        !matches!(self, Target::Memory(_))
    }

    /// Check what can be checked before any work: a directory target
    /// must not exist or be empty, or (OME-Zarr) hold an earlier OME-Zarr
    /// image, which the write replaces.
    pub fn preflight(&self) -> CResult<()> {
        match self {
            Target::OmeZarr {
                path,
                shard: Some(_),
                ..
            } => check_shard_store(path),
            Target::TiffDir { path } => check_dir_target(path, false).map(drop),
            Target::OmeZarr { path, .. } => check_dir_target(path, true).map(drop),
            _ => Ok(()),
        }
    }

    /// Where temporary files go by default: beside the output.
    pub fn temp_dir(&self) -> PathBuf {
        match self {
            Target::VvolStream(_) | Target::Memory(_) => std::env::temp_dir(),
            other => {
                let p = other.path();
                let p = if matches!(other, Target::TiffDir { .. } | Target::OmeZarr { .. }) {
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
    pub geometry: Geometry,
    /// A NIfTI input's qform and sform codes, for a NIfTI output.
    pub nifti_codes: Option<super::NiftiCodes>,
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
        Target::VvolPart {
            brick,
            compression,
            shard,
            ..
        } => {
            let meta = vvol_meta::<T>(spec, brick, compression).at(&path)?;
            let mut file = AtomicFile::create(&path).at(&path)?;
            let stats = {
                let mut sink = VvolSink {
                    w: Some(
                        VvolWriter::new_part(file.file(), meta, shard, spec.progress).at(&path)?,
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
            let mut tmp =
                crate::output::temp_file_in(spec.temp_dir, super::spool::SPOOL_PREFIX, "")
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
        Target::Headed {
            format,
            data,
            codec,
            level,
            ..
        } => write_headed::<T>(&path, format, data.as_deref(), (codec, level), spec, drive),
        Target::OmeZarr {
            levels,
            downsample,
            ngff,
            shard,
            ..
        } => {
            let store = crate::omezarr::StoreSpec {
                dims,
                spacing: spec.spacing,
                geometry: &spec.geometry,
                levels,
                down: downsample,
                ngff,
            };
            // A shard writes its slices straight into the shared store; a
            // whole write goes to a temporary directory renamed when done.
            let (w, zs, dir) = match shard {
                Some(shard) => {
                    check_shard_store(&path)?;
                    let w = crate::omezarr::ZarrWriter::<T>::create_shard(&path, &store, shard)
                        .at(&path)?;
                    let zs = crate::omezarr::shard_slices(dims, levels, shard).at(&path)?;
                    (w, zs, None)
                }
                None => {
                    let dir = PartialDir::create(&path, true)?;
                    let name = crate::omezarr::file_name(&path);
                    let w =
                        crate::omezarr::ZarrWriter::<T>::create_as(dir.temp.path(), &store, &name)
                            .at(&path)?;
                    (w, 0..dims.z, Some(dir))
                }
            };
            let mut sink = ZarrSink {
                w: Some(w),
                end: zs.end,
                next_z: zs.start,
                slab: crate::omezarr::CHUNK.min(dims.z),
                done: 0,
                progress: spec.progress,
                path: &path,
            };
            drive(&mut sink)?;
            if let Some(w) = sink.w.take() {
                w.finish().at(&path)?;
            }
            if let Some(dir) = dir {
                dir.commit()?;
            }
            Ok((sink.done, None))
        }
        Target::Memory(slot) => {
            let n = dims.checked_count().ok_or_else(|| {
                ConvertError::new(&path, Error::invalid(format!("{dims} is too large")))
            })?;
            let mut samples: Vec<T> = Vec::new();
            samples.try_reserve_exact(n as usize).map_err(|_| {
                ConvertError::new(
                    &path,
                    Error::invalid(format!(
                        "{dims} {} does not fit in memory: convert it to a .vvol file first",
                        T::TYPE
                    )),
                )
            })?;
            {
                let mut sink = MemorySink {
                    out: &mut samples,
                    dims,
                    next_z: 0,
                    slab: slab(dims, T::TYPE.size()),
                };
                drive(&mut sink)?;
            }
            let bytes = std::mem::size_of_val(samples.as_slice()) as u64;
            let mut v = Volume::from_samples(dims, samples).at(&path)?;
            v.meta.spacing = spec.spacing;
            v.meta.geometry = spec.geometry;
            let range = v.meta.range;
            slot.put(v);
            Ok((bytes, Some(range)))
        }
        Target::TiffDir { .. } => {
            let dir = PartialDir::create(&path, false)?;
            let width = (dims.z.max(1) - 1).to_string().len().max(4);
            let mut sink = TiffDirSink {
                dir: dir.temp.path(),
                dims,
                spacing: spec.spacing,
                description: crate::tiff::imagej_description(spec.spacing[2], spec.geometry.unit),
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

/// The header of a [`Target::Headed`] file for `T` samples; `data_name`
/// is the detached data file's name, relative to the header.
fn header_bytes<T: Sample>(
    format: HeaderFormat,
    spec: &OutSpec<'_>,
    data_name: Option<&str>,
    codec: DataCodec,
) -> Vec<u8> {
    match format {
        HeaderFormat::Nifti => {
            let layout = if data_name.is_some() {
                crate::nifti::NiftiLayout::Pair
            } else {
                crate::nifti::NiftiLayout::Single
            };
            crate::nifti::encode_header(
                spec.dims,
                T::TYPE,
                spec.spacing,
                &spec.geometry,
                spec.nifti_codes.unwrap_or(super::NiftiCodes::SCANNER),
                layout,
            )
        }
        HeaderFormat::Nrrd => crate::nrrd::write_header(&crate::nrrd::NrrdOut {
            dims: spec.dims,
            sample_type: T::TYPE,
            spacing: spec.spacing,
            geometry: spec.geometry,
            gzip: codec == DataCodec::Gzip,
            data_file: data_name.map(str::to_string),
        })
        .into_bytes(),
        HeaderFormat::MetaImage => crate::mhd::write_header(
            spec.dims,
            T::TYPE,
            spec.spacing,
            &spec.geometry,
            codec == DataCodec::Zlib,
            data_name.unwrap_or("LOCAL"),
        )
        .into_bytes(),
    }
}

/// `w` behind the codec's encoder.
fn encoder<'w>(
    w: &'w mut (dyn Write + Send),
    (codec, level): (DataCodec, u32),
) -> Box<dyn FinishWrite + 'w> {
    let level = flate2::Compression::new(level);
    match codec {
        DataCodec::Raw => Box::new(std::io::BufWriter::with_capacity(1 << 20, w)),
        // Members compressed on every core (crate::gzip).
        DataCodec::Gzip => Box::new(crate::gzip::ParallelGz::new(
            std::io::BufWriter::with_capacity(1 << 20, w),
            level.level(),
        )),
        DataCodec::Zlib => Box::new(flate2::write::ZlibEncoder::new(w, level)),
    }
}

/// A writer that must be told when the data ends (compressors).
trait FinishWrite: Write + Send {
    fn finish_all(self: Box<Self>) -> std::io::Result<()>;
}

impl<W: Write + Send> FinishWrite for std::io::BufWriter<W> {
    fn finish_all(mut self: Box<Self>) -> std::io::Result<()> {
        self.flush()
    }
}

impl<W: Write + Send> FinishWrite for crate::gzip::ParallelGz<W> {
    fn finish_all(self: Box<Self>) -> std::io::Result<()> {
        self.finish().and_then(|mut w| w.flush())
    }
}

impl<W: Write + Send> FinishWrite for flate2::write::ZlibEncoder<W> {
    fn finish_all(self: Box<Self>) -> std::io::Result<()> {
        self.finish().map(|_| ())
    }
}

/// Write a header format and its samples; both files appear only when
/// complete: the data file first, then the header (the commit point; an
/// older header is removed before the data file is replaced).
fn write_headed<T: SliceSample>(
    path: &Path,
    format: HeaderFormat,
    data: Option<&Path>,
    (codec, level): (DataCodec, u32),
    spec: &OutSpec<'_>,
    drive: &mut Drive<'_, T>,
) -> CResult<(u64, Option<ValueRange>)> {
    let data_name = data.map(|d| {
        d.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    let header = header_bytes::<T>(format, spec, data_name.as_deref(), codec);
    let mut head_file = AtomicFile::create(path).at(path)?;
    let mut data_file = match data {
        Some(d) => Some((AtomicFile::create(d).at(d)?, d)),
        None => None,
    };
    {
        let mut head_out = std::io::BufWriter::with_capacity(1 << 16, head_file.file());
        match data_file.as_mut() {
            Some((f, d)) => {
                head_out.write_all(&header).at(path)?;
                let mut enc = encoder(f.file(), (codec, level));
                stream_samples::<T>(&mut *enc, spec, d, drive)?;
                enc.finish_all().at(d)?;
            }
            // A .nii.gz is one gzip stream of header and samples.
            None if format == HeaderFormat::Nifti => {
                let mut enc = encoder(&mut head_out, (codec, level));
                enc.write_all(&header).at(path)?;
                stream_samples::<T>(&mut *enc, spec, path, drive)?;
                enc.finish_all().at(path)?;
            }
            // Attached data: a plain header, then the (compressed) samples.
            None => {
                head_out.write_all(&header).at(path)?;
                let mut enc = encoder(&mut head_out, (codec, level));
                stream_samples::<T>(&mut *enc, spec, path, drive)?;
                enc.finish_all().at(path)?;
            }
        }
        head_out.flush().at(path)?;
    }
    let mut bytes = 0;
    if let Some((f, d)) = data_file {
        // The header is the pair's commit point: data first, header last.
        // An older header goes before the data is replaced, so that no
        // moment shows it beside data it does not describe (killed in
        // between, the output is absent: a data file alone is not one).
        match std::fs::remove_file(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(ConvertError::new(path, e))
            }
            _ => {}
        }
        f.commit().at(d)?;
        bytes += std::fs::metadata(d).map(|m| m.len()).unwrap_or(0);
    }
    head_file.commit().at(path)?;
    bytes += std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    Ok((bytes, None))
}

/// Feed every sample of the conversion to `out`, slab by slab.
fn stream_samples<T: SliceSample>(
    out: &mut (dyn Write + Send),
    spec: &OutSpec<'_>,
    path: &Path,
    drive: &mut Drive<'_, T>,
) -> CResult<()> {
    let mut sink = RawSink {
        out,
        dims: spec.dims,
        next_z: 0,
        slab: slab(spec.dims, T::TYPE.size()),
        done: 0,
        range: ValueRange::EMPTY,
        progress: spec.progress,
        path,
    };
    drive(&mut sink)
}

struct ZarrSink<'a, T: SliceSample> {
    w: Option<crate::omezarr::ZarrWriter<T>>,
    /// One past the last slice to write.
    end: u64,
    next_z: u64,
    slab: u64,
    done: u64,
    progress: &'a (dyn Fn(u64) + Sync),
    path: &'a Path,
}

impl<T: SliceSample> SlabSink<T> for ZarrSink<'_, T> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.end)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SlabSink<T>>::next_slices(self);
        for z in zs.clone() {
            let s = win.slice(z).ok_or_else(|| {
                ConvertError::new(self.path, Error::invalid("slice missing (internal error)"))
            })?;
            if let Some(w) = self.w.as_mut() {
                w.push(s.to_vec()).at(self.path)?;
            }
            self.done += std::mem::size_of_val(s) as u64;
            (self.progress)(self.done);
        }
        self.next_z = zs.end;
        Ok(())
    }
}

struct MemorySink<'a, T> {
    out: &'a mut Vec<T>,
    dims: Dims,
    next_z: u64,
    slab: u64,
}

impl<T: SliceSample> SlabSink<T> for MemorySink<'_, T> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = <Self as SlabSink<T>>::next_slices(self);
        for z in zs.clone() {
            match win.slice(z) {
                Some(s) => self.out.extend_from_slice(s),
                None => {
                    return Err(ConvertError::new(
                        Path::new("-"),
                        Error::invalid("slice missing (internal error)"),
                    ))
                }
            }
        }
        self.next_z = zs.end;
        Ok(())
    }
}

fn vvol_meta<T: Sample>(
    spec: &OutSpec<'_>,
    brick: Option<u32>,
    compression: Compression,
) -> crate::error::Result<VolumeMeta> {
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
        geometry: spec.geometry,
        narrowed: None,
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
    out: &'a mut (dyn Write + Send),
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
    /// The first page's ImageJ description (z spacing, unit).
    description: String,
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
        description: crate::tiff::imagej_description(spec.spacing[2], spec.geometry.unit),
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
            let desc = (z == 0).then_some(self.description.as_str());
            crate::tiff::write_page(&mut self.enc, w, h, s, self.spacing, desc)
                .map_err(Error::invalid)
                .at(self.path)?;
            self.bytes += std::mem::size_of_val(s) as u64;
            (self.progress)(self.bytes);
        }
        self.next_z = zs.end;
        Ok(())
    }
}

/// What a directory output found at its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Found {
    /// Nothing, or an empty directory.
    Nothing,
    /// An OME-Zarr image (an earlier write's), which the new one replaces.
    Store,
}

/// What is at a directory output's target: nothing or an empty directory,
/// or (`store`: an OME-Zarr output) an OME-Zarr image, which the output
/// replaces as a file output replaces a file. Anything else is refused: a
/// directory of other files is never replaced, nor a file.
fn check_dir_target(target: &Path, store: bool) -> CResult<Found> {
    if let Ok(mut entries) = std::fs::read_dir(target) {
        if entries.next().is_some() {
            if store && crate::omezarr::is_image_store(target) {
                return Ok(Found::Store);
            }
            return Err(ConvertError::new(
                target,
                Error::invalid(if store {
                    "output directory exists and is not empty, and is no OME-Zarr image to replace"
                } else {
                    "output directory exists and is not empty"
                }),
            ));
        }
    } else if target.exists() {
        return Err(ConvertError::new(
            target,
            Error::invalid("exists and is not a directory"),
        ));
    }
    Ok(Found::Nothing)
}

/// A shard's OME-Zarr store must be new, or hold only other shards of an
/// unfinished sharded write (their bookkeeping directory is there).
fn check_shard_store(target: &Path) -> CResult<()> {
    let unfinished = target.join(crate::omezarr::SHARDS_DIR).is_dir();
    if unfinished {
        return Ok(());
    }
    check_dir_target(target, false).map(drop)
}

/// A directory written under a temporary name beside the target and
/// renamed into place when complete (removed if dropped before; swept by
/// the next write of the same target if the writer is killed, see
/// [`crate::output::temp_dir_in`]). An OME-Zarr store (`store`) replaces
/// an earlier one at the target in one swap
/// ([`crate::output::replace_dir`]).
struct PartialDir {
    temp: tempfile::TempDir,
    /// The temporary directory, open: its lock marks the writer alive.
    _lock: File,
    target: PathBuf,
    store: bool,
}

impl PartialDir {
    fn create(target: &Path, store: bool) -> CResult<PartialDir> {
        let target = target.components().as_path().to_path_buf();
        check_dir_target(&target, store)?;
        let parent = crate::output::parent_dir(&target);
        let (temp, lock) = crate::output::temp_dir_in(
            &parent,
            &crate::output::temp_prefix(&target),
            crate::output::PARTIAL,
        )
        .at(&parent)?;
        Ok(PartialDir {
            temp,
            _lock: lock,
            target,
            store,
        })
    }

    fn commit(self) -> CResult<()> {
        let target = self.target.clone();
        let temp = self.temp.keep();
        // What is there now (checked at creation too).
        let done = check_dir_target(&target, self.store).and_then(|found| match found {
            Found::Store => crate::output::replace_dir(&temp, &target).at(&target),
            Found::Nothing => {
                if target.is_dir() {
                    // Empty: rename replaces it.
                    std::fs::remove_dir(&target).at(&target)?;
                }
                std::fs::rename(&temp, &target).at(&target)
            }
        });
        if done.is_err() {
            let _ = std::fs::remove_dir_all(&temp);
        }
        done
    }
}

struct TiffDirSink<'a> {
    dir: &'a Path,
    dims: Dims,
    spacing: [f32; 3],
    /// Every page's ImageJ description (z spacing, unit).
    description: String,
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
                    crate::tiff::write_page(
                        &mut enc,
                        w,
                        h,
                        s,
                        self.spacing,
                        Some(&self.description),
                    )
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
