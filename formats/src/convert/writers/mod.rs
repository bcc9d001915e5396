//! The outputs of a conversion: [`Target`] names one, [`open_writer`]
//! opens its [`SliceWriter`], which the converter feeds unit by unit from a
//! [`SliceWindow`] and then commits. One module per output format.

mod dir;
mod headed;
mod memory;
mod omezarr;
mod raw;
mod thesis;
mod tiff;
mod vvol;

use crate::convert::SliceWindow;
use crate::error::Error;
use crate::pipeline::ITEM_BYTES;
use crate::reader::{CResult, ConvertError, NiftiCodes};
use crate::slice::SliceSample;
use crate::thesis::ThesisLayout;
use dir::{check_dir_target, check_shard_store, DirOutput};
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use volcore::{Compression, Dims, Geometry, LengthUnit, Shard, ValueRange, Volume};

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
        /// Output directory (must not exist, be empty, or hold only the
        /// slice files of an earlier write, which it replaces).
        path: PathBuf,
    },
    /// An in-memory [`Volume`], left in the slot (what
    /// [`crate::open::load`] uses).
    Memory(MemorySlot),
    /// An OME-Zarr directory (NGFF 0.4 on Zarr v2, or 0.5 on Zarr v3)
    /// with a multiscale pyramid.
    OmeZarr {
        /// Output directory (must not exist, be empty, or hold an earlier
        /// OME-Zarr image, which it replaces).
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
        // The format's codec under --compress, else raw samples.
        let packed = |c| if compress { c } else { DataCodec::Raw };
        let (format, data, codec) = if l.ends_with(".nii.gz") {
            (HeaderFormat::Nifti, None, DataCodec::Gzip)
        } else if l.ends_with(".nii") {
            (HeaderFormat::Nifti, None, DataCodec::Raw)
        } else if l.ends_with(".hdr") {
            let codec = packed(DataCodec::Gzip);
            let img = stem(".hdr") + if compress { ".img.gz" } else { ".img" };
            (HeaderFormat::Nifti, Some(PathBuf::from(img)), codec)
        } else if l.ends_with(".nrrd") {
            let codec = packed(DataCodec::Gzip);
            (HeaderFormat::Nrrd, None, codec)
        } else if l.ends_with(".nhdr") {
            let codec = packed(DataCodec::Gzip);
            let raw = stem(".nhdr") + if compress { ".raw.gz" } else { ".raw" };
            (HeaderFormat::Nrrd, Some(PathBuf::from(raw)), codec)
        } else if l.ends_with(".mha") {
            let codec = packed(DataCodec::Zlib);
            (HeaderFormat::MetaImage, None, codec)
        } else if l.ends_with(".mhd") {
            let codec = packed(DataCodec::Zlib);
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
    /// must not exist or be empty, or hold what an earlier write of the
    /// same kind left (an OME-Zarr image, TIFF slice files), which the
    /// write replaces.
    pub fn preflight(&self) -> CResult<()> {
        match self {
            Target::OmeZarr {
                path,
                shard: Some(_),
                ..
            } => check_shard_store(path),
            Target::TiffDir { path } => check_dir_target(path, DirOutput::TiffSlices).map(drop),
            Target::OmeZarr { path, .. } => check_dir_target(path, DirOutput::OmeZarr).map(drop),
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

/// An output written unit by unit: [`open_writer`] opens one for a
/// [`Target`], the converter feeds it the slices each unit needs, and
/// [`SliceWriter::finish`] commits it. Each format implements it once, in
/// its module here; a new format is one such module plus its line in
/// [`open_writer`].
pub(crate) trait SliceWriter<T: SliceSample> {
    /// The output slices the next unit needs; empty when done.
    fn next_slices(&self) -> Range<u64>;
    /// Write the next unit from a window holding its slices.
    fn write_next(&mut self, w: &SliceWindow<T>) -> CResult<()>;
    /// Complete the output and put it in place (rename the temporary file
    /// or directory to the target).
    fn finish(self: Box<Self>) -> CResult<Written>;
}

/// What a writer wrote.
pub(crate) struct Written {
    /// Bytes written.
    pub bytes: u64,
    /// The value range of the samples, when the writer computed it.
    pub range: Option<ValueRange>,
}

/// Output dimensions and the rest every writer needs.
pub(crate) struct OutSpec<'a> {
    pub dims: Dims,
    pub spacing: [f32; 3],
    pub geometry: Geometry,
    /// A NIfTI input's qform and sform codes, for a NIfTI output.
    pub nifti_codes: Option<NiftiCodes>,
    pub temp_dir: &'a Path,
    pub progress: &'a (dyn Fn(u64) + Sync),
}

/// A boxed writer borrowing from its [`OutSpec`].
type Opened<'a, T> = CResult<Box<dyn SliceWriter<T> + 'a>>;

/// Open the writer of `target`: the output's temporary file or directory
/// is created, nothing is at the target until [`SliceWriter::finish`].
pub(crate) fn open_writer<'a, T: SliceSample>(target: Target, spec: &OutSpec<'a>) -> Opened<'a, T> {
    let path = target.path().to_path_buf();
    match target {
        Target::Vvol {
            brick, compression, ..
        } => vvol::open(path, spec, brick, compression, None),
        Target::VvolPart {
            brick,
            compression,
            shard,
            ..
        } => vvol::open(path, spec, brick, compression, Some(shard)),
        Target::VvolStream(out) => vvol::open_stream(out, spec),
        Target::Thesis { layout, .. } => thesis::open(path, spec, layout),
        Target::Raw { .. } => raw::open(path, spec),
        Target::Tiff { .. } => tiff::open(path, spec),
        Target::TiffDir { .. } => tiff::open_dir(path, spec),
        Target::Headed {
            format,
            data,
            codec,
            level,
            ..
        } => headed::open(path, spec, format, data, (codec, level)),
        Target::OmeZarr {
            levels,
            downsample,
            ngff,
            shard,
            ..
        } => omezarr::open(path, spec, (levels, downsample, ngff), shard),
        Target::Memory(slot) => memory::open(slot, spec),
    }
}

type Drive<'d, T> = dyn FnMut(&mut dyn SliceWriter<T>) -> CResult<()> + 'd;

/// Open the target, let `drive` feed it, and commit it.
pub(crate) fn run_target<T: SliceSample>(
    target: Target,
    spec: &OutSpec<'_>,
    drive: &mut Drive<'_, T>,
) -> CResult<Written> {
    let mut w = open_writer::<T>(target, spec)?;
    drive(&mut *w)?;
    w.finish()
}

/// Slices per unit for slab writers: about 16 MiB, at least one slice.
fn slab(dims: Dims, size: usize) -> u64 {
    ((16 * ITEM_BYTES) / (dims.slice_len() * size as u64).max(1)).max(1)
}

/// Slice `z` of `win`, which the writer asked for.
fn slice_of<'w, T: SliceSample>(win: &'w SliceWindow<T>, z: u64, path: &Path) -> CResult<&'w [T]> {
    win.slice(z)
        .ok_or_else(|| ConvertError::new(path, Error::invalid("slice missing (internal error)")))
}
