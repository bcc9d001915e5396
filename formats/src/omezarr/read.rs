//! Reading an OME-Zarr image slab by slab (one chunk layer of z at a
//! time), with every chunk's size checked before it is decoded.

use super::{floats, ome_attributes, transforms, zerr};
use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use serde_json::Value;
use std::ops::Range;
use std::path::Path;
use std::sync::{Arc, Mutex};
use volcore::{Dims, Geometry, LengthUnit};
use zarrs::array::Array;
use zarrs::filesystem::FilesystemStore;

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

/// The group attributes of the image at `root`, its NGFF version, and
/// its first multiscale.
fn multiscale(root: &Path) -> CResult<(Value, &'static str, Value)> {
    let bad = |m: &str| ConvertError::new(root, Error::invalid(m));
    let (attrs, version) =
        ome_attributes(root).ok_or_else(|| bad("no Zarr group metadata (zarr.json or .zattrs)"))?;
    let Some(ms) = attrs
        .get("multiscales")
        .and_then(|m| m.as_array())
        .and_then(|m| m.first())
        .cloned()
    else {
        return Err(bad(&match level_of_parent(root) {
            Some((store, level)) => format!(
                "is level {level} of the OME-Zarr pyramid {}: read it as {} --level {level}",
                store.display(),
                store.display()
            ),
            None => "Zarr group without OME multiscales".to_string(),
        }));
    };
    Ok((attrs, version, ms))
}

/// When `path` is a level's array inside an OME-Zarr pyramid (`x.ome.zarr/1`),
/// the store and the level.
fn level_of_parent(path: &Path) -> Option<(std::path::PathBuf, usize)> {
    let name = path.file_name()?.to_str()?;
    let store = path.parent()?;
    let (attrs, _) = ome_attributes(store)?;
    let ms = attrs.get("multiscales")?.as_array()?.first()?;
    let level = ms
        .get("datasets")?
        .as_array()?
        .iter()
        .position(|d| d.get("path").and_then(|p| p.as_str()) == Some(name))?;
    Some((store.to_path_buf(), level))
}

/// The datasets (pyramid levels) of a multiscale, at least one.
fn datasets<'a>(root: &Path, ms: &'a Value) -> CResult<&'a [Value]> {
    ms.get("datasets")
        .and_then(|d| d.as_array())
        .filter(|d| !d.is_empty())
        .map(|d| d.as_slice())
        .ok_or_else(|| ConvertError::new(root, Error::invalid("OME multiscales without datasets")))
}

/// The `scale` and `translation` of dataset `ds` of multiscale `ms`
/// over `n` axes: the dataset's own, then the multiscale's applied.
fn level_transform(ms: &Value, ds: &Value, n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut scale, mut trans) = transforms(ds.get("coordinateTransformations"), n);
    let (s2, t2) = transforms(ms.get("coordinateTransformations"), n);
    for a in 0..n {
        trans[a] = trans[a] * s2[a] + t2[a];
        scale[a] *= s2[a];
    }
    (scale, trans)
}

/// One level of an OME-Zarr pyramid, as [`levels`] lists it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelInfo {
    /// Voxels along x, y, z.
    pub dims: Dims,
    /// Voxel spacing along x, y, z, in the image's unit.
    pub spacing: [f32; 3],
}

/// The levels of the OME-Zarr pyramid at `root`, full resolution first:
/// what `--level N` reads (metadata only).
pub fn levels(root: &Path) -> CResult<Vec<LevelInfo>> {
    let (_, _, ms) = multiscale(root)?;
    let count = datasets(root, &ms)?.len();
    (0..count)
        .map(|l| {
            // Any channel and time point: the levels' shapes are the same.
            let r = open_level(root, Some(0), Some(0), Some(l as u32))?;
            Ok(LevelInfo {
                dims: r.info.dims,
                spacing: r.info.spacing.unwrap_or([1.0; 3]),
            })
        })
        .collect()
}

/// Open the OME-Zarr image at `root`: level `level` of its first
/// multiscale (0, the full resolution, when `None`), channel `channel`
/// and time point `time` where it has those axes.
pub fn open(
    root: &Path,
    channel: Option<u64>,
    time: Option<u64>,
    level: Option<u32>,
) -> CResult<ZarrReader> {
    let mut r = open_level(root, channel, time, level)?;
    r.bytes = dir_size(root);
    Ok(r)
}

fn open_level(
    root: &Path,
    channel: Option<u64>,
    time: Option<u64>,
    level: Option<u32>,
) -> CResult<ZarrReader> {
    let (attrs, version, ms) = multiscale(root)?;
    let ms = &ms;
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
    let all = datasets(root, ms)?;
    let pick = level.unwrap_or(0);
    let ds = all.get(pick as usize).ok_or_else(|| {
        ConvertError::new(
            root,
            Error::invalid(format!(
                "--level {pick} asked for, but the pyramid has {} level{} (0..{})",
                all.len(),
                if all.len() == 1 { "" } else { "s" },
                all.len() - 1
            )),
        )
    })?;
    let ds_path = ds
        .get("path")
        .and_then(|p| p.as_str())
        .unwrap_or("0")
        .to_string();
    let n = axes.len();
    let (mut scale, mut trans) = level_transform(ms, ds, n);
    // Level 0's translation: the origin is level 0's, moved along the
    // axis directions by what the level's translation adds to it.
    let (_, mut trans0) = level_transform(ms, &all[0], n);
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
            trans0[a] *= k;
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
    let tr = |t: &[f64], a: Option<usize>| a.map(|a| t[a]).unwrap_or(0.0);
    let index_axes = [Some(axis_x), Some(axis_y), axis_z];
    let origin0 = index_axes.map(|a| tr(&trans0, a));
    let shift = index_axes.map(|a| tr(&trans, a) - tr(&trans0, a));
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
    let origin =
        [0, 1, 2].map(|r| origin0[r] + (0..3).map(|a| axes3[a][r] * shift[a]).sum::<f64>());
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
        bytes: 0,
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
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
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

/// The channels and time points of the OME-Zarr image at `root`: the
/// lengths of its `c` and `t` axes (1 without them), and the time step,
/// the `t` axis's scale in its unit, when it states either (see
/// [`crate::stacks`]). Reads the metadata only.
pub fn stacks(root: &Path) -> CResult<crate::stacks::Stacks> {
    use crate::stacks::{step, Stacks, TimeUnit};
    let bad = |m: &str| ConvertError::new(root, Error::invalid(m));
    let (_, _, ms) = multiscale(root)?;
    let ms = &ms;
    // Each axis's name and unit.
    let axes: Vec<(String, Option<&str>)> = match ms.get("axes").and_then(|a| a.as_array()) {
        Some(a) => a
            .iter()
            .map(|x| {
                let name = x.get("name").and_then(|n| n.as_str()).or(x.as_str());
                let unit = x.get("unit").and_then(|u| u.as_str());
                (name.unwrap_or("").to_ascii_lowercase(), unit)
            })
            .collect(),
        None => ["t", "c", "z", "y", "x"]
            .map(|a| (a.to_string(), None))
            .to_vec(),
    };
    let ds = &datasets(root, ms)?[0];
    let ds_path = ds.get("path").and_then(|p| p.as_str()).unwrap_or("0");
    let n = axes.len();
    let (scale, _) = level_transform(ms, ds, n);
    let store = Arc::new(FilesystemStore::new(root).map_err(zerr).at(root)?);
    let array = Array::open(store, &format!("/{ds_path}"))
        .map_err(zerr)
        .at(root)?;
    let shape = array.shape();
    if shape.len() != n {
        return Err(bad(&format!(
            "array has {} dimensions but the axes are {:?}",
            shape.len(),
            axes.iter().map(|a| &a.0).collect::<Vec<_>>()
        )));
    }
    let find = |name: &str| axes.iter().position(|a| a.0 == name);
    let mut s = Stacks {
        channels: find("c").map_or(1, |a| shape[a]),
        time_points: find("t").map_or(1, |a| shape[a]),
        ..Stacks::default()
    };
    if let Some(t) = find("t").filter(|_| s.time_points > 1) {
        let unit = axes[t].1.and_then(TimeUnit::parse);
        let v = scale[t];
        if unit.is_some() || v != 1.0 {
            s.time_step = step(v);
            s.time_unit = unit.filter(|_| s.time_step.is_some());
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
