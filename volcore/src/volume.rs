//! An open volume of any sample type and layout, and the visitor that
//! dispatches to code monomorphised for it.

use crate::dims::Dims;
use crate::grid::{BrickedGrid, CompressedGrid, Cursor, SlicedGrid, VoxelSource};
use crate::meta::{ValueRange, VolumeMeta};
use crate::sample::Sample;
use crate::storage::Data;

/// The samples of a volume of one sample type, in one of the layouts.
pub enum TypedGrid<T: Sample> {
    /// x-fastest array.
    Sliced(SlicedGrid<T>),
    /// Uncompressed bricks.
    Bricked(BrickedGrid<T>),
    /// zstd bricks behind a cache.
    Compressed(CompressedGrid<T>),
}

/// The samples of a volume, whatever their type.
pub enum VolumeData {
    /// Unsigned 8-bit samples.
    U8(TypedGrid<u8>),
    /// Unsigned 16-bit samples.
    U16(TypedGrid<u16>),
    /// Signed 16-bit samples.
    I16(TypedGrid<i16>),
    /// 32-bit float samples.
    F32(TypedGrid<f32>),
}

/// Code generic over the sample source, run by [`Volume::visit`] with the
/// concrete layout and sample type, so its loops are specialised for them.
pub trait VolumeVisitor {
    /// What the visit returns.
    type Output;
    /// Run with the volume's concrete source.
    fn visit<S: VoxelSource>(self, src: &S) -> Self::Output;
}

/// An open volume: metadata plus samples.
pub struct Volume {
    /// Dimensions, spacing, type, range and layout.
    pub meta: VolumeMeta,
    /// The samples.
    pub data: VolumeData,
}

/// Wrap a typed grid into the matching [`VolumeData`] variant.
pub trait IntoVolumeData: Sample {
    /// The variant holding `grid`.
    fn into_data(grid: TypedGrid<Self>) -> VolumeData;
}

macro_rules! into_data {
    ($t:ty, $v:ident) => {
        impl IntoVolumeData for $t {
            fn into_data(grid: TypedGrid<$t>) -> VolumeData {
                VolumeData::$v(grid)
            }
        }
    };
}
into_data!(u8, U8);
into_data!(u16, U16);
into_data!(i16, I16);
into_data!(f32, F32);

/// Sample types a volume can be opened from: the renderer's four as they
/// are, and `f64`, converted once to `f32` ([`Volume::narrowed_from_f64`])
/// so the hot loops never get an `f64` copy.
pub trait OpenSample: Sample {
    /// The volume a `grid` of this type described by `meta` opens as.
    fn open_grid(meta: VolumeMeta, grid: TypedGrid<Self>) -> crate::Result<Volume>;
}

impl<T: IntoVolumeData> OpenSample for T {
    fn open_grid(meta: VolumeMeta, grid: TypedGrid<T>) -> crate::Result<Volume> {
        Ok(Volume {
            meta,
            data: T::into_data(grid),
        })
    }
}

impl OpenSample for f64 {
    fn open_grid(meta: VolumeMeta, grid: TypedGrid<f64>) -> crate::Result<Volume> {
        Volume::narrowed_from_f64(meta, &grid)
    }
}

fn visit_grid<T: Sample, V: VolumeVisitor>(g: &TypedGrid<T>, v: V) -> V::Output {
    match g {
        TypedGrid::Sliced(s) => v.visit(s),
        TypedGrid::Bricked(b) => v.visit(b),
        TypedGrid::Compressed(c) => v.visit(c),
    }
}

fn narrow_f64<S: VoxelSource<Sample = f64>>(
    mut meta: VolumeMeta,
    src: &S,
) -> crate::Result<Volume> {
    use rayon::prelude::*;
    let d = src.dims();
    let too_big = || crate::Error::Dims(format!("{d} samples do not fit in memory as f32"));
    let n = usize::try_from(d.count()).map_err(|_| too_big())?;
    let plane = usize::try_from(d.slice_len()).map_err(|_| too_big())?;
    let mut out: Vec<f32> = Vec::new();
    out.try_reserve_exact(n).map_err(|_| too_big())?;
    out.resize(n, 0.0);
    // Per slice: the largest change and the largest magnitude.
    let (change, magnitude) = out
        .par_chunks_mut(plane.max(1))
        .enumerate()
        .map(|(z, slice)| {
            let mut row = vec![0f64; d.x as usize];
            let (mut change, mut magnitude) = (0f64, 0f64);
            for (y, dst) in slice.chunks_mut(d.x as usize).enumerate() {
                src.read_row(0, y as u64, z as u64, &mut row);
                for (o, &v) in dst.iter_mut().zip(&row) {
                    let r = v as f32;
                    *o = r;
                    if v.is_finite() {
                        change = change.max((r as f64 - v).abs());
                        magnitude = magnitude.max(v.abs());
                    }
                }
            }
            (change, magnitude)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
    if let Some(e) = src.error() {
        return Err(crate::Error::Corrupt(e));
    }
    meta.narrowed = Some(crate::meta::Narrowing {
        from: meta.sample_type,
        layout: meta.layout,
        compression: meta.compression,
        largest_change: change,
        largest_magnitude: magnitude,
    });
    meta.sample_type = crate::SampleType::F32;
    // The range as the f32 samples have it (each bound rounds like a sample).
    meta.range.min = meta.range.min as f32 as f64;
    meta.range.max = meta.range.max as f32 as f64;
    meta.layout = crate::meta::Layout::Sliced;
    meta.compression = crate::meta::Compression::None;
    let grid = SlicedGrid::new(d, Data::Owned(out))?;
    Ok(Volume {
        meta,
        data: VolumeData::F32(TypedGrid::Sliced(grid)),
    })
}

impl Volume {
    /// A sliced in-memory volume from samples in x-fastest order; the value
    /// range is computed (`f64` samples open as `f32`, see [`OpenSample`]).
    pub fn from_samples<T: OpenSample>(dims: Dims, samples: Vec<T>) -> crate::Result<Volume> {
        let mut meta = VolumeMeta::sliced(dims, T::TYPE);
        meta.range = ValueRange::of(&samples);
        let grid = SlicedGrid::new(dims, Data::Owned(samples))?;
        T::open_grid(meta, TypedGrid::Sliced(grid))
    }

    /// Run `v` with the concrete sample source.
    pub fn visit<V: VolumeVisitor>(&self, v: V) -> V::Output {
        match &self.data {
            VolumeData::U8(g) => visit_grid(g, v),
            VolumeData::U16(g) => visit_grid(g, v),
            VolumeData::I16(g) => visit_grid(g, v),
            VolumeData::F32(g) => visit_grid(g, v),
        }
    }

    /// An `f64` volume as the renderer reads it: its samples converted once
    /// to `f32` (in parallel, slice by slice) into a sliced in-memory grid.
    /// `meta` becomes `f32`, sliced and uncompressed, and records in
    /// [`VolumeMeta::narrowed`] how far the values moved. Fails cleanly
    /// when the samples do not fit in memory.
    pub fn narrowed_from_f64(meta: VolumeMeta, grid: &TypedGrid<f64>) -> crate::Result<Volume> {
        match grid {
            TypedGrid::Sliced(g) => narrow_f64(meta, g),
            TypedGrid::Bricked(g) => narrow_f64(meta, g),
            TypedGrid::Compressed(g) => narrow_f64(meta, g),
        }
    }

    /// The volume's dimensions.
    pub fn dims(&self) -> Dims {
        self.meta.dims
    }

    /// Trilinear sample at a point in voxel coordinates. Convenient, but
    /// dispatches on every call: loops should use [`Volume::visit`].
    pub fn trilinear(&self, p: [f32; 3]) -> f32 {
        struct At([f32; 3]);
        impl VolumeVisitor for At {
            type Output = f32;
            fn visit<S: VoxelSource>(self, src: &S) -> f32 {
                src.cursor().trilinear(self.0)
            }
        }
        self.visit(At(p))
    }

    /// Trilinear sample at a point in world coordinates (voxel `i` sits at
    /// `i · spacing`).
    pub fn trilinear_world(&self, p: [f32; 3]) -> f32 {
        let s = self.meta.spacing;
        self.trilinear(std::array::from_fn(|a| {
            if s[a] > 0.0 {
                p[a] / s[a]
            } else {
                0.0
            }
        }))
    }

    /// All samples as `f32` in sliced order (for tests and small volumes).
    pub fn to_f32_vec(&self) -> Vec<f32> {
        struct All;
        impl VolumeVisitor for All {
            type Output = Vec<f32>;
            fn visit<S: VoxelSource>(self, src: &S) -> Vec<f32> {
                let d = src.dims();
                let mut row = vec![S::Sample::default(); d.x as usize];
                let mut out = Vec::with_capacity(d.count() as usize);
                for z in 0..d.z {
                    for y in 0..d.y {
                        src.read_row(0, y, z, &mut row);
                        out.extend(row.iter().map(|v| v.to_f32()));
                    }
                }
                out
            }
        }
        self.visit(All)
    }

    /// The first decode error met so far (compressed volumes only).
    pub fn error(&self) -> Option<String> {
        struct Err;
        impl VolumeVisitor for Err {
            type Output = Option<String>;
            fn visit<S: VoxelSource>(self, src: &S) -> Option<String> {
                src.error()
            }
        }
        self.visit(Err)
    }
}
