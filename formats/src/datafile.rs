//! The samples a header describes (NRRD, MetaImage, NIfTI): in the header's
//! own file or a detached one, at an offset or at the end, raw or
//! compressed; opened as a random-access or a streaming slice reader.

use crate::error::Error;
use crate::raw::RawFileReader;
use crate::reader::{At, CResult, ConvertError, Described, SliceReader};
use crate::slice::SliceType;
use crate::stream::{skip_bytes, Counted, SampleLayout, StreamEnd, StreamReader};
use std::io::Read;
use std::path::{Path, PathBuf};
use volcore::{Dims, Geometry};

/// How the samples after a header are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Plain samples.
    Raw,
    /// A gzip stream (NRRD `encoding: gzip`).
    Gzip,
    /// A zlib stream (MetaImage `CompressedData = True`).
    Zlib,
}

/// Where the samples a header describes start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataStart {
    /// At this byte offset of the data file.
    At(u64),
    /// At the end of the data file: the last `size` bytes (raw only).
    AtEnd,
}

/// What a NRRD or MetaImage header says of its samples: their layout and
/// their place in space, the part of a [`DataSpec`] both formats state
/// alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeaderSamples {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SliceType,
    /// Byte order of the samples.
    pub big_endian: bool,
    /// Voxel spacing, when given.
    pub spacing: Option<[f32; 3]>,
    /// Origin and axis directions (LPS).
    pub geometry: Geometry,
}

/// The file a header names for its detached samples: `name` itself when
/// absolute, else `name` beside the header at `header`.
pub fn detached_file(header: &Path, name: &str) -> PathBuf {
    let p = PathBuf::from(name);
    if p.is_absolute() {
        p
    } else {
        header.parent().unwrap_or(Path::new("")).join(p)
    }
}

/// What a NRRD, MetaImage or NIfTI header says about its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct DataSpec {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SliceType,
    /// Byte order of the samples.
    pub big_endian: bool,
    /// Voxel spacing, when given.
    pub spacing: Option<[f32; 3]>,
    /// Origin and axis directions (LPS).
    pub geometry: Geometry,
    /// A linear map from stored to real values (NIfTI `scl_slope`,
    /// `scl_inter`), applied as the slices are read.
    pub rescale: Option<crate::rescale::Rescale>,
    /// The file holding the samples.
    pub data_file: PathBuf,
    /// Where in it the (possibly compressed) data starts.
    pub start: DataStart,
    /// Raw or compressed.
    pub encoding: Encoding,
    /// Decompressed bytes to skip before the samples (NRRD `byte skip`
    /// with compressed encodings).
    pub skip_after_decode: u64,
    /// Format name for reports.
    pub format: String,
    /// NIfTI: the qform and sform codes to keep (see
    /// [`crate::reader::InputInfo::nifti_codes`]).
    pub nifti_codes: Option<crate::reader::NiftiCodes>,
}

impl DataSpec {
    /// The samples of a NRRD or MetaImage header: `samples` in
    /// `data_file` from `start`, encoded as `encoding`, with nothing to
    /// skip after decoding, and no rescale or NIfTI codes (those formats
    /// state neither); `format` names the input in reports.
    pub fn unscaled(
        samples: HeaderSamples,
        data_file: PathBuf,
        start: DataStart,
        encoding: Encoding,
        format: String,
    ) -> DataSpec {
        let HeaderSamples {
            dims,
            sample_type,
            big_endian,
            spacing,
            geometry,
        } = samples;
        DataSpec {
            dims,
            sample_type,
            big_endian,
            spacing,
            geometry,
            rescale: None,
            data_file,
            start,
            encoding,
            skip_after_decode: 0,
            format,
            nifti_codes: None,
        }
    }
}

/// The samples a header describes, memory-mapped in place when they can
/// be used as stored: uncompressed, little-endian, of a stored type,
/// unscaled, at an offset aligned for the type, and ending the file;
/// `None` when they cannot (the caller reads them through [`open_data`]).
pub fn open_mapped(spec: &DataSpec) -> crate::error::Result<Option<volcore::Volume>> {
    let DataStart::At(offset) = spec.start else {
        return Ok(None);
    };
    let Some(t) = spec.sample_type.stored() else {
        return Ok(None);
    };
    let as_stored = spec.encoding == Encoding::Raw
        && !spec.big_endian
        && spec.skip_after_decode == 0
        && spec.rescale.is_none_or(|m| m.is_identity())
        && offset.is_multiple_of(t.size() as u64);
    if !as_stored {
        return Ok(None);
    }
    let len = std::fs::metadata(&spec.data_file)?.len();
    let want = spec
        .dims
        .checked_bytes(t.size() as u64)?
        .checked_add(offset);
    if want != Some(len) {
        return Ok(None);
    }
    let layout = crate::raw::RawLayout {
        dims: spec.dims,
        sample_type: spec.sample_type,
        big_endian: false,
        skip: offset,
    };
    let mut v = crate::raw::open(&spec.data_file, layout)?;
    v.meta.spacing = spec.spacing.unwrap_or([1.0; 3]);
    v.meta.geometry = spec.geometry;
    Ok(Some(v))
}

/// A reader for the samples a header describes; `input` is the header's
/// path (named in errors about the header, while errors about the data
/// name the data file).
pub fn open_data(input: &Path, spec: &DataSpec) -> CResult<Box<dyn SliceReader>> {
    let r = open_stored(input, spec)?;
    Ok(match spec.rescale {
        Some(m) if !m.is_identity() => Box::new(crate::rescale::Rescaled::new(r, m)),
        _ => r,
    })
}

fn open_stored(input: &Path, spec: &DataSpec) -> CResult<Box<dyn SliceReader>> {
    let path = &spec.data_file;
    let size = spec
        .dims
        .checked_bytes(spec.sample_type.size() as u64)
        .at(input)?;
    match spec.encoding {
        Encoding::Raw => {
            let (offset, exact) = match spec.start {
                DataStart::At(o) => (o, false),
                DataStart::AtEnd => {
                    let len = std::fs::metadata(path).at(path)?.len();
                    let o = len.checked_sub(size).ok_or_else(|| {
                        ConvertError::new(
                            path,
                            Error::invalid(format!(
                                "{} {} needs {size} bytes but the file has {len}",
                                spec.dims, spec.sample_type
                            )),
                        )
                    })?;
                    (o, true)
                }
            };
            let r = RawFileReader::open(
                path,
                spec.dims,
                spec.sample_type,
                spec.big_endian,
                offset,
                exact,
                &spec.format,
            )?
            .with_geometry(spec.spacing, spec.geometry)
            .with_nifti_codes(spec.nifti_codes)
            .named(input);
            Ok(Box::new(r))
        }
        Encoding::Gzip | Encoding::Zlib => {
            let offset = match spec.start {
                DataStart::At(o) => o,
                DataStart::AtEnd => {
                    return Err(ConvertError::new(
                        input,
                        Error::invalid("compressed data cannot be located from the file's end"),
                    ))
                }
            };
            let mut f = std::fs::File::open(path).at(path)?;
            use std::io::Seek;
            f.seek(std::io::SeekFrom::Start(offset)).at(path)?;
            let counted = Counted::new(std::io::BufReader::with_capacity(1 << 20, f));
            let counter = counted.counter();
            let mut dec: Box<dyn Read + Send> = match spec.encoding {
                Encoding::Gzip => Box::new(flate2::read::MultiGzDecoder::new(counted)),
                _ => Box::new(flate2::read::ZlibDecoder::new(counted)),
            };
            skip_bytes(&mut dec, spec.skip_after_decode).at(path)?;
            let r = StreamReader::new(
                path,
                dec,
                counter,
                SampleLayout {
                    dims: spec.dims,
                    sample_type: spec.sample_type,
                    big_endian: spec.big_endian,
                },
                StreamEnd::Ignore,
                &spec.format,
            )
            .with_geometry(spec.spacing, spec.geometry)
            .with_nifti_codes(spec.nifti_codes);
            Ok(Box::new(r))
        }
    }
}
