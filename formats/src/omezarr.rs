//! OME-Zarr (NGFF) through `zarrs`: read and write NGFF 0.4 (Zarr v2)
//! and 0.5 (Zarr v3) images, written with a multiscale pyramid.
//!
//! Reading takes the first multiscale's full-resolution dataset; `t` and
//! `c` axes are fixed with `--time-point` and `--channel` (required when longer
//! than one); the `z`, `y`, `x` axes give the volume (a missing `z` is one
//! slice). Spacing and origin come from the dataset's `scale` and
//! `translation` transformations (the multiscale's own ones applied
//! after); the axis directions volkit writes in its `volkit` attribute are
//! restored (NGFF has no rotations).
//!
//! Writing streams: slabs of whole chunk layers go out as they arrive,
//! and each pyramid level is computed from pairs of slices of the level
//! above (2×2×2 mean or max) while they pass, so memory stays at one
//! chunk layer per level. Chunks are zstd-compressed.

use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceSample, SliceType};
use serde_json::{json, Value};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use volcore::{Dims, Geometry, LengthUnit, Sample, SampleType, Shard};
use zarrs::array::Array;
use zarrs::filesystem::FilesystemStore;

/// Chunk edge of written arrays (voxels; smaller along short axes).
pub const CHUNK: u64 = 64;

/// Which NGFF version (and so which Zarr format) a writer produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Ngff {
    /// NGFF 0.4 on Zarr v2 (`.zgroup`, `.zattrs`, `.zarray`, chunks
    /// under `/`-separated keys): what napari-ome-zarr, Fiji's readers
    /// and every ome-zarr-py release read, so the default.
    #[default]
    V04,
    /// NGFF 0.5 on Zarr v3 (`zarr.json`, attributes under `ome`): read by
    /// ome-zarr-py 0.10 and later (zarr-python 3).
    V05,
}

impl Ngff {
    /// The version as NGFF writes it (`"0.4"`, `"0.5"`).
    pub fn version(self) -> &'static str {
        match self {
            Ngff::V04 => "0.4",
            Ngff::V05 => "0.5",
        }
    }
}

/// How a pyramid level is computed from the one above.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Downsample {
    /// Mean of each 2×2×2 block (rounded for integers).
    #[default]
    Mean,
    /// Maximum of each block (keeps thin bright structures).
    Max,
}

fn zerr(e: impl std::fmt::Display) -> Error {
    Error::invalid(format!("zarr: {e}"))
}

/// Whether `path` is (or names) an OME-Zarr: a `.zarr` name, or a
/// directory holding Zarr metadata.
pub fn is_zarr(path: &Path) -> bool {
    let name = path
        .to_string_lossy()
        .trim_end_matches('/')
        .to_ascii_lowercase();
    name.ends_with(".zarr")
        || (path.is_dir()
            && (path.join("zarr.json").is_file()
                || path.join(".zattrs").is_file()
                || path.join(".zgroup").is_file()))
}

fn read_json(p: &Path) -> Option<Value> {
    serde_json::from_slice(&std::fs::read(p).ok()?).ok()
}

/// The group attributes: `zarr.json` (v3; NGFF 0.5 nests them under
/// `ome`) or `.zattrs` (v2, NGFF 0.4).
fn ome_attributes(root: &Path) -> Option<(Value, &'static str)> {
    if let Some(j) = read_json(&root.join("zarr.json")) {
        let a = j.get("attributes")?;
        let mut o = a.get("ome").cloned().unwrap_or_else(|| a.clone());
        if let (Some(obj), Some(v)) = (o.as_object_mut(), a.get("volkit")) {
            obj.insert("volkit".into(), v.clone());
        }
        return Some((o, "0.5"));
    }
    read_json(&root.join(".zattrs")).map(|a| (a, "0.4"))
}

fn floats(v: &Value) -> Option<Vec<f64>> {
    v.as_array()?.iter().map(|x| x.as_f64()).collect()
}

/// `scale` and `translation` of a list of coordinate transformations.
fn transforms(v: Option<&Value>, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut scale = vec![1.0; n];
    let mut trans = vec![0.0; n];
    for t in v.and_then(|v| v.as_array()).into_iter().flatten() {
        match t.get("type").and_then(|x| x.as_str()) {
            Some("scale") => {
                if let Some(s) = t.get("scale").and_then(floats).filter(|s| s.len() == n) {
                    scale = s;
                }
            }
            Some("translation") => {
                if let Some(s) = t
                    .get("translation")
                    .and_then(floats)
                    .filter(|s| s.len() == n)
                {
                    trans = s;
                }
            }
            _ => {}
        }
    }
    (scale, trans)
}

/// An OME-Zarr image read slab by slab (one chunk layer of z at a time).
pub struct ZarrReader {
    info: InputInfo,
    array: Array<FilesystemStore>,
    /// Array index of the z, y, x axes (`None`: no z axis) and fixed
    /// indices of the others.
    axis_z: Option<usize>,
    axis_y: usize,
    axis_x: usize,
    fixed: Vec<Option<u64>>,
    slab: u64,
    cache: Mutex<Option<(u64, Vec<SliceData>)>>,
    bytes: u64,
}

/// Open the OME-Zarr image at `root`.
pub fn open(root: &Path, channel: Option<u64>, time: Option<u64>) -> CResult<ZarrReader> {
    let (attrs, version) = ome_attributes(root).ok_or_else(|| {
        ConvertError::new(
            root,
            Error::invalid("no Zarr group metadata (zarr.json or .zattrs)"),
        )
    })?;
    let ms = attrs
        .get("multiscales")
        .and_then(|m| m.as_array())
        .and_then(|m| m.first())
        .ok_or_else(|| {
            ConvertError::new(root, Error::invalid("Zarr group without OME multiscales"))
        })?;
    let axes: Vec<String> = ms
        .get("axes")
        .and_then(|a| a.as_array())
        .map(|a| {
            a.iter()
                .map(|x| {
                    x.get("name")
                        .and_then(|n| n.as_str())
                        .or(x.as_str())
                        .unwrap_or("")
                        .to_ascii_lowercase()
                })
                .collect()
        })
        .unwrap_or_else(|| ["t", "c", "z", "y", "x"].map(String::from).to_vec());
    // Each axis's unit (NGFF names; an axis without one states none).
    let units: Vec<Option<String>> = ms
        .get("axes")
        .and_then(|a| a.as_array())
        .map(|a| {
            a.iter()
                .map(|x| x.get("unit").and_then(|u| u.as_str()).map(String::from))
                .collect()
        })
        .unwrap_or_default();
    let ds = ms
        .get("datasets")
        .and_then(|d| d.as_array())
        .and_then(|d| d.first())
        .ok_or_else(|| {
            ConvertError::new(root, Error::invalid("OME multiscales without datasets"))
        })?;
    let ds_path = ds
        .get("path")
        .and_then(|p| p.as_str())
        .unwrap_or("0")
        .to_string();
    let n = axes.len();
    let (mut scale, mut trans) = transforms(ds.get("coordinateTransformations"), n);
    let (s2, t2) = transforms(ms.get("coordinateTransformations"), n);
    for a in 0..n {
        trans[a] = trans[a] * s2[a] + t2[a];
        scale[a] *= s2[a];
    }
    let store = Arc::new(FilesystemStore::new(root).map_err(zerr).at(root)?);
    let array = Array::open(store, &format!("/{ds_path}"))
        .map_err(zerr)
        .at(root)?;
    let shape = array.shape().to_vec();
    if shape.len() != n {
        return Err(ConvertError::new(
            root,
            Error::invalid(format!(
                "array has {} dimensions but the axes are {axes:?}",
                shape.len()
            )),
        ));
    }
    let find = |name: &str| axes.iter().position(|a| a == name);
    let (axis_y, axis_x) = match (find("y"), find("x")) {
        (Some(y), Some(x)) => (y, x),
        _ => {
            return Err(ConvertError::new(
                root,
                Error::invalid(format!("axes {axes:?} have no y and x")),
            ))
        }
    };
    let axis_z = find("z");
    let mut fixed = vec![None; n];
    for (a, name) in axes.iter().enumerate() {
        if Some(a) == axis_z || a == axis_y || a == axis_x {
            continue;
        }
        let (want, flag) = match name.as_str() {
            "c" => (channel, "--channel"),
            "t" => (time, "--time-point"),
            other => {
                return Err(ConvertError::new(
                    root,
                    Error::invalid(format!(
                        "axis '{}' is not supported (t, c, z, y, x)",
                        volcore::text::excerpt(other)
                    )),
                ))
            }
        };
        let pick = match want {
            Some(i) if i < shape[a] => i,
            Some(i) => {
                return Err(ConvertError::new(
                    root,
                    Error::invalid(format!(
                        "{flag} {i} asked for, but axis {name} has {}",
                        match shape[a] {
                            0 => "no points".to_string(),
                            n => format!("0..{}", n - 1),
                        }
                    )),
                ))
            }
            None if shape[a] == 1 => 0,
            None => {
                return Err(ConvertError::new(
                    root,
                    Error::invalid(format!(
                        "OME-Zarr with axes {} holds {} values along {name}: pick one with {flag}",
                        axes.join("").to_uppercase(),
                        shape[a]
                    )),
                ))
            }
        };
        fixed[a] = Some(pick);
    }
    let dt = array.data_type().to_string();
    let t = slice_type(dt.split_whitespace().next().unwrap_or("")).at(root)?;
    let nz = axis_z.map(|z| shape[z]).unwrap_or(1);
    let dims = Dims::new(shape[axis_x], shape[axis_y], nz).at(root)?;
    // x, y, z in one unit: the first stated one (x's, as a rule).
    let unit_of = |a: Option<usize>| -> CResult<LengthUnit> {
        let Some(name) = a.and_then(|a| units.get(a).cloned().flatten()) else {
            return Ok(LengthUnit::Unknown);
        };
        LengthUnit::parse(&name).ok_or_else(|| {
            ConvertError::new(
                root,
                Error::invalid(format!(
                    "axis unit '{}' is not a unit of length volkit knows (meter, centimeter, millimeter, micrometer, nanometer, angstrom)",
                    volcore::text::excerpt(&name)
                )),
            )
        })
    };
    let axis_units = [
        unit_of(Some(axis_x))?,
        unit_of(Some(axis_y))?,
        unit_of(axis_z)?,
    ];
    let unit = axis_units
        .into_iter()
        .find(|u| *u != LengthUnit::Unknown)
        .unwrap_or_default();
    for (a, u) in [Some(axis_x), Some(axis_y), axis_z]
        .into_iter()
        .zip(axis_units)
    {
        if let (Some(a), Some(k)) = (a, u.factor_to(unit)) {
            scale[a] *= k;
            trans[a] *= k;
        }
    }
    let sp = |a: Option<usize>| a.map(|a| scale[a]).unwrap_or(1.0);
    let spacing = [sp(Some(axis_x)), sp(Some(axis_y)), sp(axis_z)].map(|v| {
        if v.is_finite() && v > 0.0 {
            v as f32
        } else {
            1.0
        }
    });
    let tr = |a: Option<usize>| a.map(|a| trans[a]).unwrap_or(0.0);
    let origin = [tr(Some(axis_x)), tr(Some(axis_y)), tr(axis_z)];
    let direction = attrs
        .get("volkit")
        .and_then(|v| v.get("direction"))
        .and_then(|d| d.as_array())
        .and_then(|rows| {
            let r: Option<Vec<Vec<f64>>> = rows.iter().map(floats).collect();
            r.filter(|r| r.len() == 3 && r.iter().all(|x| x.len() == 3))
        });
    let axes3 = match direction {
        Some(d) => [0, 1, 2].map(|a| [d[0][a], d[1][a], d[2][a]]),
        None => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };
    let geometry = Geometry::from_axes(origin, axes3)
        .map_err(|e| Error::invalid(format!("OME-Zarr geometry: {e}")))
        .at(root)?
        .with_unit(unit);
    // What the metadata says one chunk holds, checked: every chunk read
    // is held to it, so it must be a size a machine can hold.
    let chunk = array.chunk_shape(&vec![0; n]).map_err(zerr).at(root)?;
    chunk_bytes(&chunk, t.size()).at(root)?;
    let plane = dims.slice_len().saturating_mul(t.size() as u64).max(1);
    let chunk_z = axis_z
        .map(|z| chunk[z].get())
        .unwrap_or(1)
        .clamp(1, 256)
        .min((MAX_SLAB_BYTES / plane).max(1));
    let bytes = dir_size(root);
    Ok(ZarrReader {
        info: InputInfo {
            nifti_codes: None,
            path: root.to_path_buf(),
            dims,
            sample_type: t,
            spacing: Some(spacing),
            geometry,
            format: format!("ome-zarr {version} ({})", axes.join("").to_uppercase()),
        },
        array,
        axis_z,
        axis_y,
        axis_x,
        fixed,
        slab: chunk_z,
        cache: Mutex::new(None),
        bytes,
    })
}

fn dir_size(root: &Path) -> u64 {
    let mut total = 0;
    let mut todo = vec![root.to_path_buf()];
    let mut seen = 0usize;
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            seen += 1;
            if seen > 1 << 22 {
                return total;
            }
            match e.metadata() {
                Ok(m) if m.is_dir() => todo.push(e.path()),
                Ok(m) => total += m.len(),
                Err(_) => {}
            }
        }
    }
    total
}

fn slice_type(name: &str) -> crate::error::Result<SliceType> {
    Ok(match name {
        "uint8" => SliceType::U8,
        "int8" => SliceType::I8,
        "uint16" => SliceType::U16,
        "int16" => SliceType::I16,
        "uint32" => SliceType::U32,
        "int32" => SliceType::I32,
        "float32" => SliceType::F32,
        "float64" => SliceType::F64,
        other => {
            return Err(Error::invalid(format!(
                "Zarr data type {} is not supported (8, 16, 32-bit integers, float32, float64)",
                volcore::text::excerpt(other)
            )))
        }
    })
}

/// The most decoded bytes one chunk may take (metadata asking for more is
/// refused: no reader holds such a chunk).
pub const MAX_CHUNK_BYTES: u64 = 2 << 30;

/// The most bytes of samples one slab read holds (a chunk layer of z is
/// cut into fewer slices when larger).
pub const MAX_SLAB_BYTES: u64 = 1 << 30;

/// Bytes of one chunk of `shape` with samples of `size` bytes: the
/// checked product, refused past [`MAX_CHUNK_BYTES`].
fn chunk_bytes(shape: &[std::num::NonZeroU64], size: usize) -> crate::error::Result<u64> {
    shape
        .iter()
        .try_fold(size as u64, |a, d| a.checked_mul(d.get()))
        .filter(|&b| b <= MAX_CHUNK_BYTES)
        .ok_or_else(|| {
            let dims: Vec<u64> = shape.iter().map(|d| d.get()).collect();
            Error::invalid(format!(
                "chunks of {dims:?} samples of {size} bytes are larger than the {} GiB volkit decodes at once",
                MAX_CHUNK_BYTES >> 30
            ))
        })
}

/// Whether `len` bytes agree with a representation: exactly a fixed size,
/// at most a bounded one (an unbounded one admits nothing).
fn fits(rep: &zarrs::array::BytesRepresentation, len: u64) -> bool {
    use zarrs::array::BytesRepresentation as R;
    match *rep {
        R::FixedSize(n) => len == n,
        R::BoundedSize(n) => len <= n,
        R::UnboundedSize => false,
    }
}

/// Undo one compressor stage, producing at most `limit` bytes (one more
/// is read to tell a chunk that is too long). zstd and gzip stream through
/// a reader cut at the limit; blosc, which sizes its output from its
/// header, is refused when the header claims more; shuffle keeps lengths.
/// Other compressors are refused: their output could not be bounded.
fn bounded_decode(
    codec: &dyn zarrs::array::codec::api::BytesToBytesCodecTraits,
    bytes: Vec<u8>,
    rep: &zarrs::array::BytesRepresentation,
    limit: u64,
    options: &zarrs::array::codec::api::CodecOptions,
) -> Result<Vec<u8>, String> {
    use std::io::Read;
    use zarrs::array::codec::{BloscCodec, GzipCodec, ShuffleCodec, ZstdCodec};
    let any = codec.as_any();
    let cap = usize::try_from(limit).map_err(|e| e.to_string())?;
    let read_bounded = |r: &mut dyn Read| -> Result<Vec<u8>, String> {
        let mut out = Vec::with_capacity(cap);
        r.take(limit + 1)
            .read_to_end(&mut out)
            .map_err(|e| e.to_string())?;
        if out.len() as u64 > limit {
            return Err(format!(
                "decompresses to more than the {limit} bytes of one chunk"
            ));
        }
        Ok(out)
    };
    if any.is::<ZstdCodec>() {
        let mut d =
            zstd::stream::read::Decoder::new(bytes.as_slice()).map_err(|e| e.to_string())?;
        read_bounded(&mut d)
    } else if any.is::<GzipCodec>() {
        read_bounded(&mut flate2::read::GzDecoder::new(bytes.as_slice()))
    } else if any.is::<BloscCodec>() || any.is::<ShuffleCodec>() {
        if any.is::<BloscCodec>() {
            // Blosc's header: bytes 4..8 hold the decompressed length.
            let claimed = bytes
                .get(4..8)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
                .ok_or("blosc header is truncated")?;
            if claimed > limit {
                return Err(format!(
                    "blosc header claims {claimed} bytes, more than the {limit} of one chunk"
                ));
            }
        }
        codec
            .decode(std::borrow::Cow::Owned(bytes), rep, options)
            .map(|b| b.into_owned())
            .map_err(|e| e.to_string())
    } else {
        Err(format!(
            "compressor {:?} is not supported (zstd, gzip, blosc, shuffle)",
            codec
        ))
    }
}

/// Copy the part of a decoded chunk (C order, origin `start`, `shape`)
/// that lies inside the block `ranges` into `out` (C order over the
/// ranges' lengths), one run along the last axis at a time.
fn copy_overlap<T: Copy>(
    chunk: &[T],
    start: &[u64],
    shape: &[u64],
    out: &mut [T],
    ranges: &[Range<u64>],
) {
    let n = ranges.len();
    if n == 0 || start.len() != n || shape.len() != n {
        return;
    }
    let lo: Vec<u64> = (0..n).map(|a| ranges[a].start.max(start[a])).collect();
    let hi: Vec<u64> = (0..n)
        .map(|a| ranges[a].end.min(start[a].saturating_add(shape[a])))
        .collect();
    if (0..n).any(|a| lo[a] >= hi[a]) {
        return;
    }
    let run = (hi[n - 1] - lo[n - 1]) as usize;
    // The position being copied, over every axis but the last.
    let mut pos = lo.clone();
    loop {
        let (mut src, mut dst) = (0usize, 0usize);
        for a in 0..n {
            let len = ranges[a].end - ranges[a].start;
            src = src * shape[a] as usize + (pos[a] - start[a]) as usize;
            dst = dst * len as usize + (pos[a] - ranges[a].start) as usize;
        }
        if let (Some(from), Some(to)) = (chunk.get(src..src + run), out.get_mut(dst..dst + run)) {
            to.copy_from_slice(from);
        }
        // Next position: the odometer over axes n-2 .. 0.
        let mut a = n - 1;
        loop {
            if a == 0 {
                return;
            }
            a -= 1;
            pos[a] += 1;
            if pos[a] < hi[a] {
                break;
            }
            pos[a] = lo[a];
        }
    }
}

impl ZarrReader {
    /// Slices `zs` (z order), decoded chunk layer by chunk layer.
    fn read_slab(&self, zs: Range<u64>) -> CResult<Vec<SliceData>> {
        let path = &self.info.path;
        let n = self.fixed.len();
        let d = self.info.dims;
        let mut ranges: Vec<Range<u64>> = vec![0..1; n];
        for (a, r) in ranges.iter_mut().enumerate() {
            *r = match self.fixed[a] {
                Some(i) => i..i + 1,
                None if Some(a) == self.axis_z => zs.clone(),
                None if a == self.axis_y => 0..d.y,
                None => 0..d.x,
            };
        }
        let plane = (d.x * d.y) as usize;
        macro_rules! get {
            ($t:ty, $v:ident) => {{
                let v: Vec<$t> = self.read_block(&ranges).at(path)?;
                self.reorder(v, plane, zs.end - zs.start)
                    .into_iter()
                    .map(SliceData::$v)
                    .collect()
            }};
        }
        Ok(match self.info.sample_type {
            SliceType::U8 => get!(u8, U8),
            SliceType::I8 => get!(i8, I8),
            SliceType::U16 => get!(u16, U16),
            SliceType::I16 => get!(i16, I16),
            SliceType::U32 => get!(u32, U32),
            SliceType::I32 => get!(i32, I32),
            SliceType::F32 => get!(f32, F32),
            SliceType::F64 => get!(f64, F64),
        })
    }

    /// The C-order block `ranges` (one range per array axis), assembled
    /// from chunks decoded one by one with [`ZarrReader::chunk`], a few at
    /// a time in parallel; missing chunks read as the fill value.
    fn read_block<T: bytemuck::Pod + Send>(
        &self,
        ranges: &[Range<u64>],
    ) -> crate::error::Result<Vec<T>> {
        use rayon::prelude::*;
        let size = std::mem::size_of::<T>();
        let lens: Vec<u64> = ranges.iter().map(|r| r.end - r.start).collect();
        let count = lens
            .iter()
            .try_fold(1u64, |a, &l| a.checked_mul(l))
            .filter(|&c| c.saturating_mul(size as u64) <= MAX_SLAB_BYTES)
            .and_then(|c| usize::try_from(c).ok())
            .ok_or_else(|| {
                Error::invalid(format!(
                    "a read of {lens:?} samples is more than the {} GiB read at once",
                    MAX_SLAB_BYTES >> 30
                ))
            })?;
        let fill = self.array.fill_value().as_ne_bytes();
        let fill: T = if fill.len() == size {
            bytemuck::pod_read_unaligned(fill)
        } else {
            T::zeroed()
        };
        let mut out = vec![fill; count];
        let subset = zarrs::array::ArraySubset::new_with_ranges(ranges);
        let chunks = match self.array.chunks_in_array_subset(&subset).map_err(zerr)? {
            Some(c) => c,
            None => return Ok(out),
        };
        // Chunk indices are walked, not collected: a grid of tiny chunks
        // has as many as the block has samples.
        let mut all = chunks.indices().into_iter().map(|i| i.to_vec()).peekable();
        // Decode in batches: at most one chunk per thread, and no more
        // than MAX_SLAB_BYTES of decoded chunks at a time (one at least).
        let threads = rayon::current_num_threads().max(1);
        while all.peek().is_some() {
            let mut batch = Vec::with_capacity(threads);
            let mut bytes = 0u64;
            while let Some(idx) = all.peek() {
                let b = chunk_bytes(&self.array.chunk_shape(idx).map_err(zerr)?, size)?;
                if batch.len() == threads || (!batch.is_empty() && bytes + b > MAX_SLAB_BYTES) {
                    break;
                }
                bytes += b;
                batch.extend(all.next());
            }
            let decoded = batch
                .par_iter()
                .map(|idx| self.chunk::<T>(idx).map(|c| (idx, c)))
                .collect::<crate::error::Result<Vec<_>>>()?;
            for (idx, chunk) in decoded {
                let Some(chunk) = chunk else { continue };
                let cs = self.array.chunk_subset(idx).map_err(zerr)?;
                copy_overlap(&chunk, cs.start(), cs.shape(), &mut out, ranges);
            }
        }
        Ok(out)
    }

    /// Chunk `idx` decoded (`None`: not stored, so the fill value), held
    /// to what the metadata says a chunk is at every step: the stored
    /// bytes are sized before they are read and may not exceed what the
    /// codecs can make of one chunk, each compressor decodes into at most
    /// the size the next step expects (zstd and gzip through a bounded
    /// reader, blosc by its header), and the result must be exactly one
    /// chunk. A chunk that disagrees is an error, never a larger buffer.
    fn chunk<T: bytemuck::Pod>(&self, idx: &[u64]) -> crate::error::Result<Option<Vec<T>>> {
        use zarrs::array::codec::api::ArrayToBytesCodecTraits;
        use zarrs::array::codec::api::CodecOptions;
        use zarrs::array::codec::CodecChain;
        use zarrs::storage::ReadableStorageTraits;
        let size = std::mem::size_of::<T>();
        let shape = self.array.chunk_shape(idx).map_err(zerr)?;
        let want = chunk_bytes(&shape, size)?;
        let at = || format!("chunk {idx:?}");
        let codecs = self.array.codecs();
        let (dt, fill) = (self.array.data_type(), self.array.fill_value());
        let inner = CodecChain::new(
            codecs.array_to_array_codecs().to_vec(),
            codecs.array_to_bytes_codec().clone(),
            Vec::new(),
        );
        // The bytes each compressor stage decodes to, innermost first.
        let mut reps = vec![inner
            .encoded_representation(&shape, dt, fill)
            .map_err(zerr)?];
        for c in codecs.bytes_to_bytes_codecs() {
            let last = &reps[reps.len() - 1];
            reps.push(c.encoded_representation(last));
        }
        let stored_most = reps[reps.len() - 1].size().ok_or_else(|| {
            Error::invalid(format!(
                "{}: the codecs give no bound on a chunk's size",
                at()
            ))
        })?;
        let key = self.array.chunk_key(idx);
        match self.array.storage().size_key(&key).map_err(zerr)? {
            None => return Ok(None),
            Some(len) if !fits(&reps[reps.len() - 1], len) => {
                return Err(Error::invalid(format!(
                    "{} is stored in {len} bytes, but one chunk of {shape:?} takes at most {stored_most}",
                    at()
                )))
            }
            Some(_) => {}
        }
        let Some(stored) = self.array.retrieve_encoded_chunk(idx).map_err(zerr)? else {
            return Ok(None);
        };
        if !fits(&reps[reps.len() - 1], stored.len() as u64) {
            return Err(Error::invalid(format!(
                "{} changed size while it was read ({} bytes)",
                at(),
                stored.len()
            )));
        }
        let options = CodecOptions::default();
        let mut bytes = stored;
        for (c, rep) in codecs.bytes_to_bytes_codecs().iter().zip(&reps).rev() {
            let limit = rep.size().unwrap_or(0);
            bytes = bounded_decode(c.as_ref(), bytes, rep, limit, &options)
                .map_err(|e| Error::invalid(format!("{}: {e}", at())))?;
            if !fits(rep, bytes.len() as u64) {
                return Err(Error::invalid(format!(
                    "{} decompresses to {} bytes, but one chunk of {shape:?} takes {limit}",
                    at(),
                    bytes.len()
                )));
            }
        }
        let decoded = inner
            .decode(std::borrow::Cow::Owned(bytes), &shape, dt, fill, &options)
            .map_err(zerr)?
            .into_fixed()
            .map_err(zerr)?;
        if decoded.len() as u64 != want {
            return Err(Error::invalid(format!(
                "{} decodes to {} bytes, not the {want} of one chunk of {shape:?}",
                at(),
                decoded.len()
            )));
        }
        Ok(Some(bytemuck::pod_collect_to_vec(&decoded)))
    }
    /// Split a C-order block into x-fastest z slices (transposing when the
    /// array stores x before y).
    fn reorder<T: Copy>(&self, v: Vec<T>, plane: usize, nz: u64) -> Vec<Vec<T>> {
        let d = self.info.dims;
        let x_last = self.axis_x > self.axis_y;
        let z_first = self.axis_z.is_none_or(|z| z < self.axis_y.min(self.axis_x));
        (0..nz as usize)
            .map(|k| {
                if x_last && z_first {
                    v[k * plane..(k + 1) * plane].to_vec()
                } else {
                    // General order: compute each element's position.
                    let mut out = Vec::with_capacity(plane);
                    for y in 0..d.y as usize {
                        for x in 0..d.x as usize {
                            out.push(v[self.flat(k, y, x)]);
                        }
                    }
                    out
                }
            })
            .collect()
    }

    /// Index of (z, y, x) in a C-order block over z, y, x (fixed axes 1).
    fn flat(&self, z: usize, y: usize, x: usize) -> usize {
        let d = self.info.dims;
        let mut idx = 0usize;
        for a in 0..self.fixed.len() {
            let (len, i) = if Some(a) == self.axis_z {
                (d.z as usize, z)
            } else if a == self.axis_y {
                (d.y as usize, y)
            } else if a == self.axis_x {
                (d.x as usize, x)
            } else {
                (1, 0)
            };
            idx = idx * len + i;
        }
        idx
    }
}

impl SliceReader for ZarrReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        // One chunk layer is decoded once and served slice by slice.
        Access::Sequential
    }
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        let mut cache = self
            .cache
            .lock()
            .map_err(|_| ConvertError::new(&self.info.path, Error::invalid("reader poisoned")))?;
        if let Some((z0, s)) = cache.as_ref() {
            if (*z0..*z0 + s.len() as u64).contains(&z) {
                return Ok(s[(z - z0) as usize].clone());
            }
        }
        let z0 = z - z % self.slab;
        let zs = z0..(z0 + self.slab).min(self.info.dims.z);
        let s = self.read_slab(zs)?;
        let out = s[(z - z0) as usize].clone();
        *cache = Some((z0, s));
        Ok(out)
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
}

// ---------------------------------------------------------------- write --

/// One level of the pyramid being written.
struct Level<T> {
    array: Array<FilesystemStore>,
    dims: Dims,
    chunk: [u64; 3],
    /// Slices waiting for a full chunk layer, and the z of the first.
    pending: Vec<Vec<T>>,
    first_z: u64,
    /// A slice waiting for its partner to make a slice of the next level.
    carry: Option<Vec<T>>,
    /// One past the last slice pushed.
    seen: u64,
    /// One past the last slice this writer writes.
    end_z: u64,
}

/// Writes an OME-Zarr (NGFF 0.4 on Zarr v2, or 0.5 on Zarr v3) slice by
/// slice, whole or one shard of it.
pub struct ZarrWriter<T: SliceSample> {
    levels: Vec<Level<T>>,
    down: Downsample,
    path: PathBuf,
    shard: Option<Shard>,
    attrs: Value,
    ngff: Ngff,
    store: Arc<FilesystemStore>,
    /// What the write makes, for shards to check they share a store.
    job: String,
}

/// What an OME-Zarr store holds.
#[derive(Clone, Copy, Debug)]
pub struct StoreSpec<'a> {
    /// The full-resolution volume's dims.
    pub dims: Dims,
    /// Its voxel spacing.
    pub spacing: [f32; 3],
    /// Its origin and axis directions.
    pub geometry: &'a Geometry,
    /// Pyramid levels asked for.
    pub levels: u32,
    /// How each level is made.
    pub down: Downsample,
    /// NGFF version.
    pub ngff: Ngff,
}

fn data_type(t: SampleType) -> zarrs::array::DataType {
    use zarrs::array::data_type;
    match t {
        SampleType::U8 => data_type::uint8(),
        SampleType::U16 => data_type::uint16(),
        SampleType::I16 => data_type::int16(),
        SampleType::F32 => data_type::float32(),
    }
}

/// Zarr v2 `dtype` of a sample type (little-endian).
fn dtype_v2(t: SampleType) -> &'static str {
    match t {
        SampleType::U8 => "|u1",
        SampleType::U16 => "<u2",
        SampleType::I16 => "<i2",
        SampleType::F32 => "<f4",
    }
}

/// The group attributes for `levels` levels: NGFF 0.5 nests the
/// multiscales under `ome` with the version beside them, 0.4 keeps them
/// at the top with the version inside each multiscale. volkit's own
/// `volkit` attribute (directions, origin, frame) sits at the top in both.
pub fn multiscales(
    name: &str,
    levels: usize,
    spacing: [f32; 3],
    geometry: &Geometry,
    down: Downsample,
    ngff: Ngff,
) -> Value {
    let datasets: Vec<Value> = (0..levels)
        .map(|l| {
            let f = (1u64 << l) as f64;
            let s = [
                spacing[2] as f64 * f,
                spacing[1] as f64 * f,
                spacing[0] as f64 * f,
            ];
            // A level-l voxel is centred on the mean of the 2^l voxels it covers.
            let shift = |a: usize| (f - 1.0) / 2.0 * spacing[a] as f64;
            let t = [
                geometry.origin[2] + shift(2),
                geometry.origin[1] + shift(1),
                geometry.origin[0] + shift(0),
            ];
            json!({
                "path": l.to_string(),
                "coordinateTransformations": [
                    {"type": "scale", "scale": s},
                    {"type": "translation", "translation": t},
                ],
            })
        })
        .collect();
    let axis = |n: &str| match geometry.unit.ngff_name() {
        Some(u) => json!({"name": n, "type": "space", "unit": u}),
        None => json!({"name": n, "type": "space"}),
    };
    let mut ms = json!({
        "name": name,
        "axes": [axis("z"), axis("y"), axis("x")],
        "datasets": datasets,
        "type": match down { Downsample::Mean => "mean", Downsample::Max => "max" },
    });
    let volkit = json!({
        "direction": geometry.direction,
        "origin": geometry.origin,
        "frame": "LPS",
    });
    match ngff {
        Ngff::V05 => json!({
            "ome": {"version": "0.5", "multiscales": [ms]},
            "volkit": volkit,
        }),
        Ngff::V04 => {
            if let Some(o) = ms.as_object_mut() {
                o.insert("version".into(), json!("0.4"));
            }
            json!({"multiscales": [ms], "volkit": volkit})
        }
    }
}

/// Write the root group with `attrs` in the layout of `ngff`.
fn create_group(
    store: &Arc<FilesystemStore>,
    attrs: Value,
    ngff: Ngff,
) -> crate::error::Result<()> {
    let attrs = attrs.as_object().cloned().unwrap_or_default();
    let group = match ngff {
        Ngff::V05 => zarrs::group::GroupBuilder::new()
            .attributes(attrs)
            .build(store.clone(), "/")
            .map_err(zerr)?,
        Ngff::V04 => zarrs::group::Group::new_with_metadata(
            store.clone(),
            "/",
            zarrs::group::GroupMetadata::V2(
                zarrs::metadata::v2::GroupMetadataV2::new().with_attributes(attrs),
            ),
        )
        .map_err(zerr)?,
    };
    group.store_metadata().map_err(zerr)
}

/// An array of shape `shape` and chunks `chunk` (both z, y, x) at `path`,
/// zstd-compressed, its metadata written: Zarr v3 with dimension names for
/// NGFF 0.5, Zarr v2 with `/` chunk keys (as NGFF 0.4 asks) for 0.4.
fn create_array(
    store: &Arc<FilesystemStore>,
    path: &str,
    shape: [u64; 3],
    chunk: [u64; 3],
    t: SampleType,
    ngff: Ngff,
) -> crate::error::Result<Array<FilesystemStore>> {
    let array = match ngff {
        Ngff::V05 => zarrs::array::ArrayBuilder::new(
            shape.to_vec(),
            chunk.to_vec(),
            data_type(t),
            zarrs::array::FillValue::from(vec![0u8; t.size()]),
        )
        .bytes_to_bytes_codecs(vec![Arc::new(zarrs::array::codec::ZstdCodec::new(
            3, false,
        ))])
        .dimension_names(["z", "y", "x"].into())
        .build(store.clone(), path)
        .map_err(zerr)?,
        Ngff::V04 => {
            let chunks = chunk
                .iter()
                .map(|&c| std::num::NonZeroU64::new(c).ok_or_else(|| zerr("empty chunk")))
                .collect::<crate::error::Result<Vec<_>>>()?;
            let compressor =
                serde_json::from_value(json!({"id": "zstd", "level": 3})).map_err(zerr)?;
            let fill = serde_json::from_value(json!(0)).map_err(zerr)?;
            let meta = zarrs::array::ArrayMetadataV2::new(
                shape.to_vec(),
                chunks,
                zarrs::metadata::v2::DataTypeMetadataV2::Simple(dtype_v2(t).into()),
                fill,
                Some(compressor),
                None,
            )
            .with_dimension_separator(zarrs::metadata::ChunkKeySeparator::Slash);
            Array::new_with_metadata(
                store.clone(),
                path,
                zarrs::metadata::ArrayMetadata::V2(meta),
            )
            .map_err(zerr)?
        }
    };
    Ok(array)
}

/// Where the shards of a sharded write keep their bookkeeping, inside the
/// store (removed when the last shard completes the store).
pub const SHARDS_DIR: &str = ".volkit-shards";

/// Slices of the full-resolution volume per shard unit with `levels`
/// pyramid levels: one chunk layer of the coarsest level, so that every
/// level's chunk layers fall wholly inside one unit.
fn unit_slices(dims: Dims, levels: usize) -> u64 {
    CHUNK.min(dims.z.max(1)) << (levels.max(1) - 1)
}

/// The most pyramid levels `dims` makes: each level halves the one above
/// (rounding up) until one level is a single voxel along every axis, and
/// that single voxel is no level of its own (the full resolution always is).
pub fn max_levels(dims: Dims) -> u32 {
    let mut n = 1;
    let mut d = dims.x.max(dims.y).max(dims.z);
    // A u64 halves to 1 in at most 64 steps.
    while d > 1 {
        d = d.div_ceil(2);
        if d > 1 {
            n += 1;
        }
    }
    n
}

/// Refuse more pyramid levels than [`max_levels`], saying how many
/// `dims` makes.
pub fn check_levels(dims: Dims, levels: u32) -> crate::error::Result<()> {
    let most = max_levels(dims);
    if levels > most {
        return Err(Error::invalid(format!(
            "--pyramid {levels}: a {dims} volume makes at most {most} pyramid level{} (each halves the one above; the last is {})",
            if most == 1 { "" } else { "s" },
            level_shape(dims, most)
        )));
    }
    Ok(())
}

/// The dims of the `levels` pyramid levels of `dims` (see
/// [`check_levels`]).
fn level_dims(dims: Dims, levels: u32) -> crate::error::Result<Vec<Dims>> {
    check_levels(dims, levels)?;
    let mut dl = Vec::new();
    let mut d = dims;
    for _ in 0..levels.max(1) {
        dl.push(d);
        d = Dims::new(d.x.div_ceil(2), d.y.div_ceil(2), d.z.div_ceil(2))?;
    }
    Ok(dl)
}

/// The shape of level `n` (1 = full resolution) of `dims`, as `XxYxZ`.
fn level_shape(dims: Dims, n: u32) -> String {
    let half = |v: u64| (1..n).fold(v, |v, _| v.div_ceil(2));
    format!("{}x{}x{}", half(dims.x), half(dims.y), half(dims.z))
}

/// The full-resolution slices shard `shard` of a write of `dims` with
/// `levels` levels converts: its share of the units (see [`unit_slices`]).
pub fn shard_slices(dims: Dims, levels: u32, shard: Shard) -> crate::error::Result<Range<u64>> {
    let n = level_dims(dims, levels)?.len();
    let unit = unit_slices(dims, n);
    let units = shard.units(dims.z.div_ceil(unit));
    Ok((units.start * unit).min(dims.z)..(units.end * unit).min(dims.z))
}

/// The last component of `path` (the store's name).
pub(crate) fn file_name(path: &Path) -> String {
    path.components()
        .next_back()
        .map(|n| n.as_os_str().to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Write `bytes` to `path` through a temporary file and a rename.
fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

impl<T: SliceSample> ZarrWriter<T> {
    /// Create the group and the arrays of `levels` levels (at least one;
    /// fewer when the volume runs out of voxels) under `path`.
    pub fn create(
        path: &Path,
        dims: Dims,
        spacing: [f32; 3],
        geometry: &Geometry,
        levels: u32,
        down: Downsample,
        ngff: Ngff,
    ) -> crate::error::Result<ZarrWriter<T>> {
        let spec = StoreSpec {
            dims,
            spacing,
            geometry,
            levels,
            down,
            ngff,
        };
        Self::start(path, &spec, None, &file_name(path))
    }

    /// [`ZarrWriter::create`] into `path` (a temporary directory) of the
    /// store that will be named `name` (the multiscale's name).
    pub fn create_as(
        path: &Path,
        spec: &StoreSpec<'_>,
        name: &str,
    ) -> crate::error::Result<ZarrWriter<T>> {
        Self::start(path, spec, None, name)
    }

    /// Start shard `shard` of a sharded write into the store at `path`
    /// (created if missing, else holding only other shards of the same
    /// write): it writes the chunks of its slices ([`shard_slices`])
    /// straight into the store. The store's metadata is written by the
    /// shard that completes it last, so a store missing any shard's chunks
    /// is not an OME-Zarr to any reader.
    pub fn create_shard(
        path: &Path,
        spec: &StoreSpec<'_>,
        shard: Shard,
    ) -> crate::error::Result<ZarrWriter<T>> {
        Self::start(path, spec, Some(shard), &file_name(path))
    }

    fn start(
        path: &Path,
        spec: &StoreSpec<'_>,
        shard: Option<Shard>,
        name: &str,
    ) -> crate::error::Result<ZarrWriter<T>> {
        let &StoreSpec {
            dims,
            spacing,
            geometry,
            levels,
            down,
            ngff,
        } = spec;
        std::fs::create_dir_all(path)?;
        let store = Arc::new(FilesystemStore::new(path).map_err(zerr)?);
        let dl = level_dims(dims, levels)?;
        let attrs = multiscales(name, dl.len(), spacing, geometry, down, ngff);
        let zs = match shard {
            Some(s) => shard_slices(dims, levels, s)?,
            None => 0..dims.z,
        };
        let mut out = Vec::new();
        for (l, d) in dl.iter().enumerate() {
            let chunk = [d.x.min(CHUNK), d.y.min(CHUNK), d.z.min(CHUNK)];
            let array = create_array(
                &store,
                &format!("/{l}"),
                [d.z, d.y, d.x],
                [chunk[2], chunk[1], chunk[0]],
                T::TYPE,
                ngff,
            )?;
            // The level's slices of the shard's units (units hold whole
            // chunk layers of every level).
            let first = zs.start >> l;
            let end = if zs.end == dims.z { d.z } else { zs.end >> l };
            out.push(Level {
                array,
                dims: *d,
                chunk,
                pending: Vec::new(),
                first_z: first,
                carry: None,
                seen: first,
                end_z: end,
            });
        }
        let job = json!({
            "dims": dims.as_array(),
            "type": T::TYPE.name(),
            "attrs": attrs,
            "ngff": ngff.version(),
            "shards": shard.map(|s| s.count),
        })
        .to_string();
        let w = ZarrWriter {
            levels: out,
            down,
            path: path.to_path_buf(),
            shard,
            attrs,
            ngff,
            store,
            job,
        };
        match shard {
            None => w.store_metadata()?,
            Some(_) => w.claim_store()?,
        }
        Ok(w)
    }

    /// Write the group's and every level's metadata.
    fn store_metadata(&self) -> crate::error::Result<()> {
        create_group(&self.store, self.attrs.clone(), self.ngff)?;
        for lv in &self.levels {
            lv.array.store_metadata().map_err(zerr)?;
        }
        Ok(())
    }

    /// A shard's check that the store is new or another shard's of the
    /// same write, recording the write's description for the others.
    fn claim_store(&self) -> crate::error::Result<()> {
        let dir = self.path.join(SHARDS_DIR);
        std::fs::create_dir_all(&dir)?;
        let job = dir.join("job.json");
        match std::fs::read_to_string(&job) {
            Ok(found) if found == self.job => Ok(()),
            Ok(_) => Err(Error::invalid(
                "holds the shards of another conversion (other dims, type, levels, shard count or geometry): remove it or write elsewhere",
            )),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Ok(write_atomic(&job, self.job.as_bytes())?)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// A shard's end: mark it done, and if every shard is done, write the
    /// metadata that makes the store an OME-Zarr and remove the marks.
    fn complete_shard(&self, shard: Shard) -> crate::error::Result<()> {
        let dir = self.path.join(SHARDS_DIR);
        write_atomic(&dir.join(format!("done-{}", shard.index)), b"")?;
        let done = (0..shard.count)
            .filter(|k| dir.join(format!("done-{k}")).exists())
            .count();
        if done == shard.count as usize {
            self.store_metadata()?;
            match std::fs::remove_dir_all(&dir) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e.into()),
                _ => {}
            }
        }
        Ok(())
    }

    /// Add the next z slice of the full-resolution volume.
    pub fn push(&mut self, slice: Vec<T>) -> crate::error::Result<()> {
        self.push_at(0, slice)
    }

    fn push_at(&mut self, l: usize, slice: Vec<T>) -> crate::error::Result<()> {
        let last_z;
        let mut down = None;
        let more = l + 1 < self.levels_len();
        let how = self.down;
        {
            let lv = &mut self.levels[l];
            lv.seen += 1;
            last_z = lv.seen == lv.end_z;
            if more {
                match lv.carry.take() {
                    Some(a) => down = Some(downsample(&a, Some(&slice), lv.dims, how)),
                    None if last_z => down = Some(downsample(&slice, None, lv.dims, how)),
                    None => lv.carry = Some(slice.clone()),
                }
            }
            lv.pending.push(slice);
            if lv.pending.len() as u64 == lv.chunk[2] || last_z {
                flush(lv)?;
            }
        }
        if let Some(s) = down {
            self.push_at(l + 1, s)?;
        }
        Ok(())
    }

    fn levels_len(&self) -> usize {
        self.levels.len()
    }

    /// Check every level is complete (a shard: its slices of every
    /// level), and complete a sharded store when this is its last shard.
    pub fn finish(self) -> crate::error::Result<()> {
        for (l, lv) in self.levels.iter().enumerate() {
            if lv.seen != lv.end_z || !lv.pending.is_empty() {
                return Err(Error::invalid(format!(
                    "{}: level {l} got slices up to {} of {} (internal error)",
                    self.path.display(),
                    lv.seen,
                    lv.end_z
                )));
            }
        }
        match self.shard {
            Some(s) => self.complete_shard(s),
            None => Ok(()),
        }
    }
}

/// Write the pending slices of a level as one layer of chunks.
fn flush<T: SliceSample>(lv: &mut Level<T>) -> crate::error::Result<()> {
    use rayon::prelude::*;
    let d = lv.dims;
    let [cx, cy, _] = lv.chunk;
    let nz = lv.pending.len();
    let cz_index = lv.first_z / lv.chunk[2];
    let (nbx, nby) = (d.x.div_ceil(cx), d.y.div_ceil(cy));
    let pending = &lv.pending;
    let array = &lv.array;
    (0..nbx * nby)
        .into_par_iter()
        .try_for_each(|b| -> crate::error::Result<()> {
            let (bx, by) = (b % nbx, b / nbx);
            let xs = bx * cx..((bx + 1) * cx).min(d.x);
            let ys = by * cy..((by + 1) * cy).min(d.y);
            // Edge chunks are stored whole: pad with zeros.
            let mut chunk = vec![T::from_f32(0.0); (lv.chunk[2] * cy * cx) as usize];
            for (k, s) in pending.iter().enumerate().take(nz) {
                for y in ys.clone() {
                    let src = (y * d.x + xs.start) as usize;
                    let dst = ((k as u64 * cy + (y - ys.start)) * cx) as usize;
                    chunk[dst..dst + xs.clone().count()]
                        .copy_from_slice(&s[src..src + xs.clone().count()]);
                }
            }
            let bytes: &[u8] = bytemuck::cast_slice(&chunk);
            array
                .store_chunk(
                    &[cz_index, by, bx],
                    zarrs::array::ArrayBytes::new_flen(bytes.to_vec()),
                )
                .map_err(zerr)
        })?;
    lv.first_z += nz as u64;
    lv.pending.clear();
    Ok(())
}

/// One slice of the next level from two slices (`b` missing at an odd end).
fn downsample<T: Sample>(a: &[T], b: Option<&[T]>, d: Dims, how: Downsample) -> Vec<T> {
    let (nx, ny) = (d.x.div_ceil(2) as usize, d.y.div_ceil(2) as usize);
    let (w, h) = (d.x as usize, d.y as usize);
    let mut out = Vec::with_capacity(nx * ny);
    for y in 0..ny {
        for x in 0..nx {
            let mut sum = 0f64;
            let mut max = f32::NEG_INFINITY;
            let mut n = 0u32;
            for s in [Some(a), b].into_iter().flatten() {
                for yy in 2 * y..(2 * y + 2).min(h) {
                    for xx in 2 * x..(2 * x + 2).min(w) {
                        let v = s[yy * w + xx].to_f32();
                        sum += v as f64;
                        if v > max || v.is_nan() {
                            max = v;
                        }
                        n += 1;
                    }
                }
            }
            let v = match how {
                Downsample::Mean => {
                    let m = sum / n as f64;
                    if T::TYPE == SampleType::F32 {
                        m as f32
                    } else {
                        m.round() as f32
                    }
                }
                Downsample::Max => max,
            };
            out.push(T::from_f32(v));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_pyramid_levels_than_the_dims_make_are_refused() {
        let d = Dims::new(64, 64, 20).unwrap();
        // 64, 32, 16, 8, 4, 2 along x: six levels; a seventh would be 1x1x1.
        assert_eq!(max_levels(d), 6);
        assert_eq!(level_dims(d, 6).unwrap().len(), 6);
        let e = level_dims(d, 9).unwrap_err().to_string();
        assert!(e.contains("at most 6") && e.contains("2x2x1"), "{e}");
        assert_eq!(max_levels(Dims::new(1, 1, 1).unwrap()), 1);
        assert_eq!(max_levels(Dims::new(2, 1, 1).unwrap()), 1);
        assert_eq!(max_levels(Dims::new(3, 1, 1).unwrap()), 2);
        assert!(check_levels(Dims::new(1, 1, 1).unwrap(), 2).is_err());
    }

    /// Write a 70x5x67 u16 volume with three levels in `ngff`'s layout.
    /// The test volume's value at voxel (x, y, z).
    fn val(x: u64, y: u64, z: u64) -> u16 {
        (x + 100 * y + 1000 * z) as u16
    }

    fn write_pyramid(p: &Path, ngff: Ngff) -> (Dims, Geometry) {
        let dims = Dims::new(70, 5, 67).unwrap();
        let g = Geometry::from_axes(
            [1.0, 2.0, 3.0],
            [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        let mut w =
            ZarrWriter::<u16>::create(p, dims, [0.5, 0.5, 2.0], &g, 3, Downsample::Mean, ngff)
                .unwrap();
        for z in 0..dims.z {
            let s: Vec<u16> = (0..dims.y)
                .flat_map(|y| (0..dims.x).map(move |x| val(x, y, z)))
                .collect();
            w.push(s).unwrap();
        }
        w.finish().unwrap();
        (dims, g)
    }

    /// Read back values, geometry and the level-1 mean of a written pyramid.
    fn check_pyramid(p: &Path, dims: Dims, g: &Geometry) {
        let r = open(p, None, None).unwrap();
        assert_eq!(r.info().dims, dims);
        assert_eq!(r.info().spacing, Some([0.5, 0.5, 2.0]));
        assert_eq!(&r.info().geometry, g);
        for z in [0, 63, 64, 66] {
            let s = r.read_slice(z).unwrap();
            assert_eq!(s.value((3 * 70 + 69) as usize), val(69, 3, z) as f64);
        }
        // Level 1 is the 2x2x2 mean: (0,0,0) averages x 0..2, y 0..2, z 0..2.
        let a = Array::open(Arc::new(FilesystemStore::new(p).unwrap()), "/1").unwrap();
        assert_eq!(a.shape(), &[34, 3, 35]);
        let v: Vec<u16> = a
            .retrieve_array_subset::<Vec<u16>>(&[0..1, 0..1, 0..1])
            .unwrap();
        assert_eq!(v[0], (0.5f64 + 50.0 + 500.0).round() as u16);
    }

    /// The error reading slice 0 of the store at `p` gives.
    fn first_slice_error(p: &Path) -> String {
        let r = open(p, None, None).unwrap();
        match r.read_slice(0) {
            Ok(_) => panic!("a bad chunk read as data"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn chunk_decompressing_past_one_chunk_is_refused_for_both_versions() {
        for ngff in [Ngff::V04, Ngff::V05] {
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join("v.ome.zarr");
            write_pyramid(&p, ngff);
            // Level 0's chunks are 64x5x64 u16 (40960 bytes); this zstd
            // frame of 16 MiB of zeros takes a few hundred bytes.
            let bomb = zstd::bulk::compress(&vec![0u8; 16 << 20], 3).unwrap();
            let chunk = match ngff {
                Ngff::V04 => p.join("0/0/0/0"),
                Ngff::V05 => p.join("0/c/0/0/0"),
            };
            assert!(chunk.is_file(), "{}", chunk.display());
            std::fs::write(&chunk, &bomb).unwrap();
            let e = first_slice_error(&p);
            assert!(e.contains("v.ome.zarr"), "{e}");
            assert!(
                e.contains("chunk [0, 0, 0]") && e.contains("more than the 40960 bytes"),
                "{e}"
            );
        }
    }

    #[test]
    fn chunk_stored_in_more_bytes_than_its_codecs_make_is_refused_unread() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        write_pyramid(&p, Ngff::V04);
        std::fs::write(p.join("0/0/0/0"), vec![7u8; 1 << 20]).unwrap();
        let e = first_slice_error(&p);
        assert!(
            e.contains("chunk [0, 0, 0] is stored in 1048576 bytes"),
            "{e}"
        );
    }

    #[test]
    fn chunk_shape_larger_than_a_reader_holds_is_refused_at_open() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        write_pyramid(&p, Ngff::V04);
        let meta = p.join("0/.zarray");
        let mut z: Value = serde_json::from_slice(&std::fs::read(&meta).unwrap()).unwrap();
        // 2^40 x 2^40 x 2^40 samples: the product overflows 64 bits.
        z["chunks"] = json!([1u64 << 40, 1u64 << 40, 1u64 << 40]);
        std::fs::write(&meta, z.to_string()).unwrap();
        let e = match open(&p, None, None) {
            Ok(_) => panic!("opened a store of impossible chunks"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("v.ome.zarr") && e.contains("larger than the 2 GiB"),
            "{e}"
        );
        // Large but not overflowing: 2^20 x 2^10 x 2^10 u16 is 2 TiB.
        z["chunks"] = json!([1u64 << 20, 1u64 << 10, 1u64 << 10]);
        std::fs::write(&meta, z.to_string()).unwrap();
        assert!(open(&p, None, None).is_err());
    }

    #[test]
    fn copy_overlap_places_a_chunk_part_in_a_block() {
        // A 2x3 chunk at (1, 2) into the block rows 0..3, columns 3..5.
        let chunk = [1, 2, 3, 4, 5, 6];
        let mut out = [0; 6];
        copy_overlap(&chunk, &[1, 2], &[2, 3], &mut out, &[0..3, 3..5]);
        assert_eq!(out, [0, 0, 2, 3, 5, 6]);
        // No overlap: nothing changes.
        copy_overlap(&chunk, &[9, 9], &[2, 3], &mut out, &[0..3, 3..5]);
        assert_eq!(out, [0, 0, 2, 3, 5, 6]);
    }

    #[test]
    fn ngff_05_pyramid_round_trips_with_scale_and_translation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        let (dims, g) = write_pyramid(&p, Ngff::V05);
        check_pyramid(&p, dims, &g);
        assert_eq!(
            open(&p, None, None).unwrap().info().format,
            "ome-zarr 0.5 (ZYX)"
        );
        let meta: Value =
            serde_json::from_slice(&std::fs::read(p.join("zarr.json")).unwrap()).unwrap();
        assert_eq!(meta["zarr_format"], 3);
        assert_eq!(meta["attributes"]["ome"]["version"], "0.5");
        let ds = &meta["attributes"]["ome"]["multiscales"][0]["datasets"];
        assert_eq!(ds.as_array().unwrap().len(), 3);
        assert_eq!(
            ds[1]["coordinateTransformations"][0]["scale"],
            json!([4.0, 1.0, 1.0])
        );
        assert!(!p.join(".zattrs").exists() && p.join("0/zarr.json").is_file());
    }

    #[test]
    fn ngff_04_pyramid_on_zarr_v2_round_trips_with_scale_and_translation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.ome.zarr");
        let (dims, g) = write_pyramid(&p, Ngff::V04);
        check_pyramid(&p, dims, &g);
        assert_eq!(
            open(&p, None, None).unwrap().info().format,
            "ome-zarr 0.4 (ZYX)"
        );
        assert!(!p.join("zarr.json").exists());
        let group: Value =
            serde_json::from_slice(&std::fs::read(p.join(".zgroup")).unwrap()).unwrap();
        assert_eq!(group["zarr_format"], 2);
        let attrs: Value =
            serde_json::from_slice(&std::fs::read(p.join(".zattrs")).unwrap()).unwrap();
        let ms = &attrs["multiscales"][0];
        assert_eq!(ms["version"], "0.4");
        assert_eq!(ms["datasets"].as_array().unwrap().len(), 3);
        // Level 2 covers 4 voxels per axis: scale x4, centred on their mean.
        assert_eq!(
            ms["datasets"][2]["coordinateTransformations"][0]["scale"],
            json!([8.0, 2.0, 2.0])
        );
        assert_eq!(
            ms["datasets"][2]["coordinateTransformations"][1]["translation"],
            json!([3.0 + 3.0, 2.0 + 0.75, 1.0 + 0.75])
        );
        let zarray: Value =
            serde_json::from_slice(&std::fs::read(p.join("0/.zarray")).unwrap()).unwrap();
        assert_eq!(zarray["zarr_format"], 2);
        assert_eq!(zarray["dtype"], "<u2");
        assert_eq!(zarray["dimension_separator"], "/");
        assert_eq!(zarray["compressor"]["id"], "zstd");
        // Chunk keys are nested directories, z/y/x.
        assert!(p.join("0/1/0/0").is_file(), "chunk 1,0,0 of level 0");
    }
}
