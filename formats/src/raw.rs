//! Headerless sample arrays: x fastest, then y, then z.
//!
//! Dimensions and type come from flags or from the Open SciVis naming
//! convention `name_XxYxZ_type.raw` (e.g. `bonsai_256x256x256_uint8.raw`).
//! volkit writes raw files little-endian; it reads either byte order.

use crate::error::{Error, Result};
use crate::pipeline::write_rows;
use memmap2::Mmap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;
use std::sync::Arc;
use volcore::volume::{IntoVolumeData, TypedGrid};
use volcore::{Data, Dims, RegionSource, Sample, SampleType, SlicedGrid, Volume, VolumeMeta};

/// How to interpret a raw file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSpec {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SampleType,
    /// Whether samples are big-endian.
    pub big_endian: bool,
    /// Bytes to skip before the first sample.
    pub skip: u64,
}

impl RawSpec {
    /// Bytes of samples.
    pub fn data_len(&self) -> Result<u64> {
        Ok(self.dims.checked_bytes(self.sample_type.size() as u64)?)
    }
}

/// Dimensions and type from a name like `bonsai_256x256x256_uint8.raw`.
pub fn parse_name(path: &Path) -> Option<(Dims, SampleType)> {
    let stem = path.file_stem()?.to_str()?;
    let mut parts = stem.rsplitn(3, '_');
    let ty: SampleType = parts.next()?.parse().ok()?;
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

/// Open a raw file. Little-endian files whose samples are aligned are
/// memory-mapped in place; others are read and converted.
pub fn open(path: &Path, spec: RawSpec) -> Result<Volume> {
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
    let data = match spec.sample_type {
        SampleType::U8 => typed::<u8>(map, f, spec)?,
        SampleType::U16 => typed::<u16>(map, f, spec)?,
        SampleType::I16 => typed::<i16>(map, f, spec)?,
        SampleType::F32 => typed::<f32>(map, f, spec)?,
    };
    finish(spec, data)
}

fn finish(spec: RawSpec, data: volcore::VolumeData) -> Result<Volume> {
    let mut v = Volume {
        meta: VolumeMeta::sliced(spec.dims, spec.sample_type),
        data,
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

fn typed<T: IntoVolumeData>(
    map: Arc<Mmap>,
    file: Arc<File>,
    spec: RawSpec,
) -> Result<volcore::VolumeData> {
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
    Ok(T::into_data(TypedGrid::Sliced(SlicedGrid::new(
        spec.dims, data,
    )?)))
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

/// Read raw samples from a stream (such as standard input).
pub fn read_stream(r: &mut dyn Read, spec: RawSpec) -> Result<Volume> {
    std::io::copy(&mut r.take(spec.skip), &mut std::io::sink())?;
    let want = spec.data_len()?;
    let mut bytes = Vec::with_capacity(want.min(64 << 20) as usize);
    let got = r.take(want).read_to_end(&mut bytes)? as u64;
    if got != want {
        return Err(Error::invalid(format!(
            "stream is truncated: {} {} needs {want} bytes but only {got} arrived",
            spec.dims, spec.sample_type
        )));
    }
    let data = match spec.sample_type {
        SampleType::U8 => owned::<u8>(spec, &bytes)?,
        SampleType::U16 => owned::<u16>(spec, &bytes)?,
        SampleType::I16 => owned::<i16>(spec, &bytes)?,
        SampleType::F32 => owned::<f32>(spec, &bytes)?,
    };
    finish(spec, data)
}

fn owned<T: IntoVolumeData>(spec: RawSpec, bytes: &[u8]) -> Result<volcore::VolumeData> {
    let mut v: Vec<T> = bytemuck::pod_collect_to_vec(bytes);
    swap_if_needed(&mut v, spec.big_endian);
    Ok(T::into_data(TypedGrid::Sliced(SlicedGrid::new(
        spec.dims,
        Data::Owned(v),
    )?)))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_open_scivis_names() {
        let (d, t) = parse_name(Path::new("data/bonsai_256x256x256_uint8.raw")).unwrap();
        assert_eq!((d.x, d.y, d.z, t), (256, 256, 256, SampleType::U8));
        let (d, t) = parse_name(Path::new("foot_of_cat_64x32x16_float32.raw")).unwrap();
        assert_eq!((d.x, d.z, t), (64, 16, SampleType::F32));
        assert!(parse_name(Path::new("plain.raw")).is_none());
        assert!(parse_name(Path::new("x_0x2x2_uint8.raw")).is_none());
    }
}
