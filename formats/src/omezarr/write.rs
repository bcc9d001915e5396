//! Writing an OME-Zarr store slice by slice, whole or one shard of it,
//! with its pyramid levels computed as the slices pass. Each level is
//! made from the full-resolution values, rounded once: a level adds the
//! f64 sums (or maxima) of the level above into its own, not that level's
//! rounded samples.

use super::pyramid::{plan, LevelShape};
use super::{zerr, Downsample, Ngff, CHUNK};
use crate::error::Error;
use crate::slice::SliceSample;
use serde_json::{json, Value};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volcore::{Dims, Geometry, Sample, SampleType, Shard};
use zarrs::array::Array;
use zarrs::filesystem::FilesystemStore;

/// One level of the pyramid being written.
struct Level<T> {
    array: Array<FilesystemStore>,
    shape: LevelShape,
    chunk: [u64; 3],
    /// Slices waiting for a full chunk layer, and the z of the first.
    pending: Vec<Vec<T>>,
    first_z: u64,
    /// Below level 0: the slice being made from the level above.
    acc: Option<Wide>,
    /// Full-resolution voxels each column (x) and row (y) stands for.
    cover: [Vec<u32>; 2],
    /// One past the last slice pushed.
    seen: u64,
    /// One past the last slice this writer writes.
    end_z: u64,
}

/// A slice of the level above the one being made: full-resolution
/// samples (level 0), or a [`Wide`] slice's values.
enum Above<'a, T> {
    Samples(&'a [T]),
    Wide(&'a [f64]),
}

/// A slice of a level in full-resolution terms: per voxel the f64 sum
/// (mean) or maximum (max) of the full-resolution values it stands for,
/// with the number of full-resolution slices it holds.
struct Wide {
    values: Vec<f64>,
    /// Slices of the level above added so far.
    parts: u64,
    /// Full-resolution slices added so far.
    slices: u64,
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
        SampleType::F64 => data_type::float64(),
    }
}

/// Zarr v2 `dtype` of a sample type (little-endian).
fn dtype_v2(t: SampleType) -> &'static str {
    match t {
        SampleType::U8 => "|u1",
        SampleType::U16 => "<u2",
        SampleType::I16 => "<i2",
        SampleType::F32 => "<f4",
        SampleType::F64 => "<f8",
    }
}

/// The group attributes for `levels` levels: NGFF 0.5 nests the
/// multiscales under `ome` with the version beside them, 0.4 keeps them
/// at the top with the version inside each multiscale. volkit's own
/// `volkit` attribute (directions, origin, frame) sits at the top in both.
pub fn multiscales(
    name: &str,
    levels: &[LevelShape],
    spacing: [f32; 3],
    geometry: &Geometry,
    down: Downsample,
    ngff: Ngff,
) -> Value {
    let datasets: Vec<Value> = levels
        .iter()
        .enumerate()
        .map(|(l, shape)| {
            let f = shape.factor.map(|f| f as f64);
            let s = [2, 1, 0].map(|a| spacing[a] as f64 * f[a]);
            // A level's voxel is centred on the voxels it stands for.
            let shift = |a: usize| (f[a] - 1.0) / 2.0 * spacing[a] as f64;
            let t = [2, 1, 0].map(|a| geometry.origin[a] + shift(a));
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

/// Slices of the full-resolution volume per shard unit of a pyramid
/// `levels`: one chunk layer of the coarsest level, so that every
/// level's chunk layers fall wholly inside one unit.
fn unit_slices(dims: Dims, levels: &[LevelShape]) -> u64 {
    let fz = levels.last().map_or(1, |l| l.factor[2]);
    CHUNK.min(dims.z.max(1)) * fz
}

/// The full-resolution slices shard `shard` of a write of `dims` with
/// `spacing` and `levels` levels converts: its share of the units (see
/// [`unit_slices`]).
pub fn shard_slices(
    dims: Dims,
    spacing: [f32; 3],
    levels: u32,
    shard: Shard,
) -> crate::error::Result<Range<u64>> {
    let unit = unit_slices(dims, &plan(dims, spacing, levels)?);
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
        let shapes = plan(dims, spacing, levels)?;
        std::fs::create_dir_all(path)?;
        let store = Arc::new(FilesystemStore::new(path).map_err(zerr)?);
        let attrs = multiscales(name, &shapes, spacing, geometry, down, ngff);
        let zs = match shard {
            Some(s) => shard_slices(dims, spacing, levels, s)?,
            None => 0..dims.z,
        };
        let mut out = Vec::new();
        for (l, shape) in shapes.iter().enumerate() {
            let d = &shape.dims;
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
            let fz = shape.factor[2];
            let first = zs.start / fz;
            let end = if zs.end == dims.z { d.z } else { zs.end / fz };
            // Full-resolution voxels per column and row (fewer at the end).
            let cover = |n: u64, full: u64, f: u64| -> Vec<u32> {
                (0..n)
                    .map(|i| ((i + 1) * f).min(full).saturating_sub(i * f) as u32)
                    .collect()
            };
            out.push(Level {
                array,
                shape: *shape,
                chunk,
                pending: Vec::new(),
                first_z: first,
                acc: None,
                cover: [
                    cover(d.x, dims.x, shape.factor[0]),
                    cover(d.y, dims.y, shape.factor[1]),
                ],
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
        let last = self.levels[0].seen + 1 == self.levels[0].end_z;
        if self.levels_len() > 1 {
            self.add_below(0, Above::Samples(&slice), 1, last)?;
        }
        self.store(0, slice)
    }

    /// Add a slice of level `l` (standing for `slices` full-resolution
    /// slices; `last`: the level's last slice here) into the slice of
    /// level `l + 1` being made; a complete slice is stored and added to
    /// the level below it in turn.
    fn add_below(
        &mut self,
        l: usize,
        slice: Above<'_, T>,
        slices: u64,
        last: bool,
    ) -> crate::error::Result<()> {
        let how = self.down;
        let above = self.levels[l].shape.dims;
        let lv = &mut self.levels[l + 1];
        let (d, halves) = (lv.shape.dims, lv.shape.halves);
        let acc = lv.acc.get_or_insert_with(|| Wide {
            values: vec![
                match how {
                    Downsample::Mean => 0.0,
                    Downsample::Max => f64::NEG_INFINITY,
                };
                (d.x * d.y) as usize
            ],
            parts: 0,
            slices: 0,
        });
        match slice {
            Above::Samples(s) => add_slice(
                &mut acc.values,
                &|i| f64::from(s[i].to_f32()),
                above,
                d,
                halves,
                how,
            ),
            Above::Wide(w) => add_slice(&mut acc.values, &|i| w[i], above, d, halves, how),
        }
        acc.parts += 1;
        acc.slices += slices;
        if acc.parts < 1 + u64::from(halves[2]) && !last {
            return Ok(());
        }
        let Some(wide) = lv.acc.take() else {
            return Ok(());
        };
        let out = finish_slice::<T>(&wide, &lv.cover, how);
        let last_here = lv.seen + 1 == lv.end_z;
        if l + 2 < self.levels_len() {
            self.add_below(l + 1, Above::Wide(&wide.values), wide.slices, last_here)?;
        }
        self.store(l + 1, out)
    }

    /// Queue a slice of level `l`, writing a chunk layer when it is full.
    fn store(&mut self, l: usize, slice: Vec<T>) -> crate::error::Result<()> {
        let lv = &mut self.levels[l];
        lv.seen += 1;
        lv.pending.push(slice);
        if lv.pending.len() as u64 == lv.chunk[2] || lv.seen == lv.end_z {
            flush(lv)?;
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
    let d = lv.shape.dims;
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

/// Add a slice of the level above (`above` voxels, its values by
/// `value`) into `acc`, a slice of the level below (`d` voxels, halving
/// the axes `halves` of the level above): sums for the mean, maxima
/// (NaN kept) for the max.
fn add_slice(
    acc: &mut [f64],
    value: &impl Fn(usize) -> f64,
    above: Dims,
    d: Dims,
    halves: [bool; 3],
    how: Downsample,
) {
    let (w, h, nx) = (above.x as usize, above.y as usize, d.x as usize);
    let (kx, ky) = (usize::from(halves[0]), usize::from(halves[1]));
    for y in 0..h {
        let row = &mut acc[(y >> ky) * nx..][..nx];
        for x in 0..w {
            let v = value(y * w + x);
            let a = &mut row[x >> kx];
            match how {
                Downsample::Mean => *a += v,
                Downsample::Max => {
                    if v > *a || v.is_nan() {
                        *a = v;
                    }
                }
            }
        }
    }
}

/// The samples of a complete slice: each mean (the sum over the
/// full-resolution voxels it stands for, `cover` columns by rows by
/// `wide.slices`) rounded once for integer types, or each maximum.
fn finish_slice<T: Sample>(wide: &Wide, cover: &[Vec<u32>; 2], how: Downsample) -> Vec<T> {
    let nx = cover[0].len();
    let mut out = Vec::with_capacity(wide.values.len());
    let float = matches!(T::TYPE, SampleType::F32 | SampleType::F64);
    for (i, &v) in wide.values.iter().enumerate() {
        let v = match how {
            Downsample::Mean => {
                let n =
                    f64::from(cover[0][i % nx]) * f64::from(cover[1][i / nx]) * wide.slices as f64;
                let m = v / n.max(1.0);
                // Rounded in f64, once: through f32 first, a mean just
                // under a half could round up to it.
                if float {
                    m
                } else {
                    m.round()
                }
            }
            Downsample::Max => v,
        };
        out.push(T::from_f64(v));
    }
    out
}
