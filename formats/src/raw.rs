//! Headerless sample arrays: x fastest, then y, then z.
//!
//! Dimensions and type come from flags or from the Open SciVis naming
//! convention `name_XxYxZ_type.raw` (e.g. `bonsai_256x256x256_uint8.raw`).
//! volkit writes raw files little-endian; it reads either byte order.
//!
//! [`RawSpec`] is the one description of a raw file every tool uses; with
//! the `clap` feature it is also the tools' raw-input options
//! (`--raw-dims`, `--raw-type`, `--raw-endian`, `--raw-skip`).

use crate::error::{Error, Result};
use crate::pipeline::write_rows;
use crate::reader::{Access, At, CResult, ConvertError, Described, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use memmap2::Mmap;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volcore::volume::{OpenSample, TypedGrid};
use volcore::{
    Data, Dims, Geometry, RegionSource, Sample, SampleType, SlicedGrid, Volume, VolumeMeta,
};

/// Byte order of raw samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum, serde::Serialize))]
#[cfg_attr(feature = "clap", serde(rename_all = "lowercase"))]
pub enum Endian {
    /// Least significant byte first (what volkit writes).
    #[default]
    Little,
    /// Most significant byte first.
    Big,
}

/// How to read a headerless raw file: every field may be left out and
/// taken from an Open SciVis name (`NAME_XxYxZ_TYPE.raw`).
///
/// With the `clap` feature it serialises (as flags' ids to the texts they
/// parse) for vol-render's printed scene.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args, serde::Serialize))]
pub struct RawSpec {
    /// Raw input: dimensions X,Y,Z (otherwise from NAME_XxYxZ_TYPE.raw).
    #[cfg_attr(feature = "clap", arg(id = "raw_dims", long = "raw-dims", value_name = "X,Y,Z", value_parser = parse_dims))]
    #[cfg_attr(
        feature = "clap",
        serde(rename = "raw_dims", serialize_with = "as_text")
    )]
    pub dims: Option<Dims>,
    /// Raw input: sample type u8, i8, u16, i16, u32, i32, f32, f64
    /// (otherwise from the name).
    #[cfg_attr(feature = "clap", arg(id = "raw_type", long = "raw-type", value_name = "TYPE", value_parser = parse_type))]
    #[cfg_attr(
        feature = "clap",
        serde(rename = "raw_type", serialize_with = "as_text")
    )]
    pub sample_type: Option<SliceType>,
    /// Raw input: byte order.
    #[cfg_attr(
        feature = "clap",
        arg(
            id = "raw_endian",
            long = "raw-endian",
            value_enum,
            default_value = "little"
        )
    )]
    #[cfg_attr(feature = "clap", serde(rename = "raw_endian"))]
    pub endian: Endian,
    /// Raw input: bytes to skip before the samples.
    #[cfg_attr(
        feature = "clap",
        arg(
            id = "raw_skip",
            long = "raw-skip",
            value_name = "BYTES",
            default_value_t = 0
        )
    )]
    #[cfg_attr(feature = "clap", serde(rename = "raw_skip"))]
    pub skip: u64,
}

/// A value as the text its flag parses (`64x64x32`, `u16`).
#[cfg(feature = "clap")]
fn as_text<T: std::fmt::Display, S: serde::Serializer>(
    v: &Option<T>,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    match v {
        Some(v) => s.serialize_some(&v.to_string()),
        None => s.serialize_none(),
    }
}

/// A raw file's description with everything known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawLayout {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SliceType,
    /// Whether samples are big-endian.
    pub big_endian: bool,
    /// Bytes to skip before the first sample.
    pub skip: u64,
}

impl RawLayout {
    /// Bytes of samples.
    pub fn data_len(&self) -> Result<u64> {
        Ok(self.dims.checked_bytes(self.sample_type.size() as u64)?)
    }
}

impl RawSpec {
    /// A complete description.
    pub fn new(dims: Dims, sample_type: impl Into<SliceType>) -> RawSpec {
        RawSpec {
            dims: Some(dims),
            sample_type: Some(sample_type.into()),
            ..RawSpec::default()
        }
    }

    /// Whether any option differs from the defaults (the input is then
    /// read as raw whatever its name).
    pub fn is_given(&self) -> bool {
        *self != RawSpec::default()
    }

    /// Fill what was left out from `path`'s name; fails naming the
    /// options when dims or type stay unknown.
    pub fn resolve(&self, path: &Path) -> Result<RawLayout> {
        let named = parse_name(path);
        let dims = self.dims.or(named.map(|n| n.0));
        let t = self.sample_type.or(named.map(|n| n.1));
        match (dims, t) {
            (Some(dims), Some(sample_type)) => Ok(RawLayout {
                dims,
                sample_type,
                big_endian: self.endian == Endian::Big,
                skip: self.skip,
            }),
            (Some(_), None) => Err(Error::invalid(
                "raw input needs a sample type: pass --raw-type T or name it NAME_XxYxZ_TYPE.raw",
            )),
            _ => Err(Error::invalid(
                "raw input needs dims and type: pass --raw-dims X,Y,Z --raw-type T or name it NAME_XxYxZ_TYPE.raw",
            )),
        }
    }
}

/// Parse `X,Y,Z` (or `XxYxZ`) dimensions.
pub fn parse_dims(s: &str) -> std::result::Result<Dims, String> {
    let v: Vec<u64> = s
        .split([',', 'x'])
        .map(|p| p.trim().parse::<u64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z with whole numbers"))?;
    match v[..] {
        [x, y, z] => Dims::new(x, y, z).map_err(|e| format!("'{s}': {e}")),
        _ => Err(format!("'{s}' is not X,Y,Z")),
    }
}

/// Parse a sample type name: volkit's (`u8`, `i16`, `f32`, ...) or the Open
/// SciVis ones (`uint8`, `int16`, `float32`, `float64`, ...).
pub fn parse_type(s: &str) -> std::result::Result<SliceType, String> {
    Ok(match s.to_ascii_lowercase().as_str() {
        "u8" | "uint8" => SliceType::U8,
        "i8" | "int8" => SliceType::I8,
        "u16" | "uint16" => SliceType::U16,
        "i16" | "int16" => SliceType::I16,
        "u32" | "uint32" => SliceType::U32,
        "i32" | "int32" => SliceType::I32,
        "f32" | "float32" | "float" => SliceType::F32,
        "f64" | "float64" | "double" => SliceType::F64,
        _ => {
            return Err(format!(
                "'{s}' is not a sample type (u8, i8, u16, i16, u32, i32, f32, f64)"
            ))
        }
    })
}

/// Dimensions and type from a name like `bonsai_256x256x256_uint8.raw`.
pub fn parse_name(path: &Path) -> Option<(Dims, SliceType)> {
    let stem = path.file_stem()?.to_str()?;
    let mut parts = stem.rsplitn(3, '_');
    let ty: SliceType = parse_type(parts.next()?).ok()?;
    let dims: Vec<u64> = parts
        .next()?
        .split('x')
        .map(|s| s.parse().ok())
        .collect::<Option<_>>()?;
    match dims[..] {
        [x, y, z] => Some((Dims::new(x, y, z).ok()?, ty)),
        _ => None,
    }
}

/// Open a raw file of a stored type. Little-endian files whose samples
/// are aligned are memory-mapped in place; others are read and converted.
/// (Wider types go through [`RawFileReader`] and a conversion.)
pub fn open(path: &Path, spec: RawLayout) -> Result<Volume> {
    let Some(t) = spec.sample_type.stored() else {
        return Err(Error::invalid(format!(
            "{} samples must be converted to a stored type first",
            spec.sample_type
        )));
    };
    let f = File::open(path)?;
    let len = f.metadata()?.len();
    let want = spec
        .data_len()?
        .checked_add(spec.skip)
        .ok_or_else(|| Error::invalid("size overflows"))?;
    if len != want {
        return Err(Error::invalid(format!(
            "{} {} raw data with {} header bytes needs {want} bytes but the file has {len}",
            spec.dims, spec.sample_type, spec.skip
        )));
    }
    // SAFETY: read-only map; the file must not be truncated meanwhile.
    let map = Arc::new(unsafe { Mmap::map(&f)? });
    let f = Arc::new(f);
    let meta = VolumeMeta::sliced(spec.dims, t);
    let mut v = match t {
        SampleType::U8 => typed::<u8>(map, f, spec, meta)?,
        SampleType::U16 => typed::<u16>(map, f, spec, meta)?,
        SampleType::I16 => typed::<i16>(map, f, spec, meta)?,
        SampleType::F32 => typed::<f32>(map, f, spec, meta)?,
        SampleType::F64 => typed::<f64>(map, f, spec, meta)?,
    };
    v.meta.range = range_of(&v);
    Ok(v)
}

fn range_of(v: &Volume) -> volcore::ValueRange {
    struct R;
    impl volcore::VolumeVisitor for R {
        type Output = volcore::ValueRange;
        fn visit<S: volcore::VoxelSource>(self, src: &S) -> volcore::ValueRange {
            use rayon::prelude::*;
            let d = src.dims();
            (0..d.y * d.z)
                .into_par_iter()
                .fold(
                    || {
                        (
                            vec![S::Sample::default(); d.x as usize],
                            volcore::ValueRange::EMPTY,
                        )
                    },
                    |(mut row, r), i| {
                        src.read_row(0, i % d.y, i / d.y, &mut row);
                        let rr = volcore::ValueRange::of(&row);
                        (row, r.merge(rr))
                    },
                )
                .map(|(_, r)| r)
                .reduce(|| volcore::ValueRange::EMPTY, |a, b| a.merge(b))
        }
    }
    v.visit(R)
}

fn typed<T: OpenSample>(
    map: Arc<Mmap>,
    file: Arc<File>,
    spec: RawLayout,
    meta: VolumeMeta,
) -> Result<Volume> {
    let n = spec.dims.count() as usize;
    let aligned = (spec.skip as usize).is_multiple_of(std::mem::align_of::<T>());
    let data = if !spec.big_endian && aligned {
        Data::mapped_file(map, file, spec.skip as usize, n)?
    } else {
        let bytes = &map[spec.skip as usize..];
        let mut v: Vec<T> = bytemuck::pod_collect_to_vec(&bytes[..n * std::mem::size_of::<T>()]);
        swap_if_needed(&mut v, spec.big_endian);
        Data::Owned(v)
    };
    let grid = TypedGrid::Sliced(SlicedGrid::new(spec.dims, data)?);
    Ok(T::open_grid(meta, grid)?)
}

fn swap_if_needed<T: Sample>(v: &mut [T], big_endian: bool) {
    if big_endian {
        for s in v.iter_mut() {
            bytemuck::bytes_of_mut(s).reverse();
        }
    } else {
        T::slice_from_le(v);
    }
}

/// Write every sample of `src` little-endian, x fastest. Returns the
/// bytes written.
pub fn write<R: RegionSource>(
    src: &R,
    out: &mut (dyn Write + Send),
    progress: &(dyn Fn(u64) + Sync),
) -> Result<u64> {
    let d = src.dims();
    let rows = write_rows(src, 0..d.y * d.z, out, progress)?;
    out.flush()?;
    Ok(rows.bytes)
}

/// Headerless samples in a file at a byte offset, read slice by slice
/// with positioned reads (not mapped, so resident memory stays at the
/// slices in flight however large the file).
pub struct RawFileReader {
    info: InputInfo,
    path: PathBuf,
    file: std::fs::File,
    len: u64,
    offset: u64,
    big_endian: bool,
}

/// Read `count` samples of type `t` at byte `start` of `file`, converting
/// from the given byte order.
pub(crate) fn read_typed(
    file: &std::fs::File,
    t: SliceType,
    start: u64,
    count: usize,
    big_endian: bool,
    reuse: Option<SliceData>,
) -> std::io::Result<SliceData> {
    use std::os::unix::fs::FileExt;
    let mut s = SliceData::reuse(reuse, t, count);
    file.read_exact_at(s.as_bytes_mut(), start)?;
    if big_endian != cfg!(target_endian = "big") {
        s.swap_bytes();
    }
    Ok(s)
}

impl RawFileReader {
    /// Map `path`, whose samples start at `offset`; the file must hold at
    /// least the samples `dims` and `t` need (exactly, when `exact`).
    pub fn open(
        path: &Path,
        dims: Dims,
        t: SliceType,
        big_endian: bool,
        offset: u64,
        exact: bool,
        format: &str,
    ) -> CResult<RawFileReader> {
        let f = std::fs::File::open(path).at(path)?;
        let len = f.metadata().at(path)?.len();
        let need = dims.checked_bytes(t.size() as u64).at(path)?;
        let want = need.checked_add(offset);
        let fits = match want {
            Some(w) if exact => w == len,
            Some(w) => w <= len,
            None => false,
        };
        if !fits {
            return Err(ConvertError::new(
                path,
                Error::invalid(format!(
                    "{dims} {t} needs {need} bytes of samples after {offset} header bytes but the file has {len} bytes"
                )),
            ));
        }
        Ok(RawFileReader {
            info: InputInfo {
                nifti_codes: None,
                path: path.to_path_buf(),
                dims,
                sample_type: t,
                spacing: None,
                geometry: Geometry::IDENTITY,
                format: format.to_string(),
            },
            path: path.to_path_buf(),
            file: f,
            len,
            offset,
            big_endian,
        })
    }

    /// Name the input `path` in reports (a header naming this data file).
    pub fn named(mut self, path: &Path) -> Self {
        self.info.path = path.to_path_buf();
        self
    }
}

impl Described for RawFileReader {
    fn info_mut(&mut self) -> &mut InputInfo {
        &mut self.info
    }
}

impl SliceReader for RawFileReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let d = self.info.dims;
        let t = self.info.sample_type;
        let start = self.offset + z * d.slice_len() * t.size() as u64;
        read_typed(
            &self.file,
            t,
            start,
            d.slice_len() as usize,
            self.big_endian,
            reuse,
        )
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => ConvertError::new(
                &self.path,
                Error::invalid("file is truncated (shorter than when it was opened)"),
            ),
            _ => ConvertError::new(&self.path, e),
        })
    }
    fn bytes_in(&self) -> u64 {
        self.len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_open_scivis_names() {
        let (d, t) = parse_name(Path::new("data/bonsai_256x256x256_uint8.raw")).unwrap();
        assert_eq!((d.x, d.y, d.z, t), (256, 256, 256, SliceType::U8));
        let (d, t) = parse_name(Path::new("foot_of_cat_64x32x16_float32.raw")).unwrap();
        assert_eq!((d.x, d.z, t), (64, 16, SliceType::F32));
        let (_, t) = parse_name(Path::new("ct_4x4x4_int32.raw")).unwrap();
        assert_eq!(t, SliceType::I32);
        let spec = RawSpec::default();
        assert!(!spec.is_given());
        let l = spec.resolve(Path::new("a_2x3x4_u16.raw")).unwrap();
        assert_eq!(
            (l.dims.y, l.sample_type, l.big_endian),
            (3, SliceType::U16, false)
        );
        let e = RawSpec {
            dims: Some(Dims::new(2, 2, 2).unwrap()),
            ..spec
        }
        .resolve(Path::new("plain.raw"))
        .unwrap_err()
        .to_string();
        assert!(e.contains("--raw-type"), "{e}");
        assert!(parse_name(Path::new("plain.raw")).is_none());
        assert!(parse_name(Path::new("x_0x2x2_uint8.raw")).is_none());
    }
}
