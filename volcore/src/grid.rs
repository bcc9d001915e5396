//! The sampling interface and its three implementations.
//!
//! Every consumer of samples goes through [`VoxelSource`] (shared, `Sync`)
//! and the per-thread [`Cursor`] it hands out. A cursor may keep state, such
//! as the last decoded brick, so that sampling compressed volumes costs a
//! cache lookup only when a ray moves to another brick.
//!
//! Sampling rules, identical for every layout so that all layouts give the
//! same bits:
//! - Coordinates are in voxels: voxel `(i, j, k)` sits at point `(i, j, k)`.
//! - A point is first clamped to the box `[0, dims − 1]` (NaN clamps to 0).
//! - Trilinear interpolation reads the cell at `floor(p)`; a neighbour past
//!   the far face repeats the edge voxel (clamp to edge). Each axis is
//!   blended as `a + (b − a)·t`, x first, then y, then z.
//! - Nearest picks `round(p)` (halves away from zero) of the clamped point.
//! - The gradient is the central difference of the interpolant with unit
//!   offsets, `(f(p + e) − f(p − e)) / 2` per axis, each point clamped.

use crate::brick::BrickGeometry;
use crate::cache::BrickCache;
use crate::dims::Dims;
use crate::sample::{Sample, SampleType};
use crate::storage::Data;
use std::sync::{Arc, OnceLock};

pub use crate::lanes::{Cross8, Samples8};

/// Read access to the samples of one volume of sample type `Self::Sample`.
pub trait VoxelSource: Sync {
    /// The stored sample type.
    type Sample: Sample;
    /// A per-thread sampler.
    type Cursor<'a>: Cursor
    where
        Self: 'a;

    /// The volume's dimensions.
    fn dims(&self) -> Dims;

    /// A new sampler; create one per thread (cursors are cheap).
    fn cursor(&self) -> Self::Cursor<'_>;

    /// Copy voxels `x0 .. x0 + out.len()` of row `(y, z)` into `out`.
    /// The row must lie inside the volume.
    fn read_row(&self, x0: u64, y: u64, z: u64, out: &mut [Self::Sample]);

    /// The first error met while decoding stored data, if any. Cursors
    /// cannot fail mid-sample; a brick that fails to decode reads as zeros
    /// and its error is kept here for the caller to report after the job.
    fn error(&self) -> Option<String> {
        None
    }
}

/// A sampler over one volume, used from one thread.
pub trait Cursor {
    /// The volume's dimensions.
    fn dims(&self) -> Dims;

    /// Whether every value this cursor reads, and every blend of them, is
    /// finite (integer samples), so a reader may leave out its checks for
    /// infinities and NaN. A constant for each sample type.
    #[inline(always)]
    fn finite(&self) -> bool {
        false
    }

    /// The voxel at integer coordinates inside the volume.
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32;

    /// The eight values of the cell at base `(i, j, k)` (each inside the
    /// volume), neighbours past the far face clamped to the edge, ordered
    /// `dx + 2·dy + 4·dz`.
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8];

    /// The differences `cell(+1) − cell(−1)` along x, y and z around the
    /// cell at base `(i, j, k)`, corner by corner (ordered as
    /// [`Cursor::cell`]): what a central-difference gradient blends. For
    /// interior cells only: the caller guarantees `i, j, k >= 1` and
    /// `i + 2`, `j + 2`, `k + 2` inside the volume, so no neighbour is
    /// clamped. Layouts override it to read the cross from one address.
    #[inline(always)]
    fn cross_diffs(&mut self, i: u64, j: u64, k: u64) -> [[f32; 8]; 3] {
        let diff = |a: [f32; 8], b: [f32; 8]| std::array::from_fn(|c| a[c] - b[c]);
        [
            diff(self.cell(i + 1, j, k), self.cell(i - 1, j, k)),
            diff(self.cell(i, j + 1, k), self.cell(i, j - 1, k)),
            diff(self.cell(i, j, k + 1), self.cell(i, j, k - 1)),
        ]
    }

    /// The trilinear value of the cell at base `(i, j, k)` at offsets `t`:
    /// [`blend`] of [`Cursor::cell`], bit for bit (layouts override it to
    /// blend without gathering the corners one by one).
    #[inline(always)]
    fn cell_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> f32 {
        blend(&self.cell(i, j, k), t)
    }

    /// The blends at offsets `t` of [`Cursor::cross_diffs`] around the
    /// cell at base `(i, j, k)`, per axis (interior cells only, as there),
    /// bit for bit; layouts override it as [`Cursor::cell_blend`].
    #[inline(always)]
    fn cross_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> [f32; 3] {
        let [dx, dy, dz] = self.cross_diffs(i, j, k);
        [blend(&dx, t), blend(&dy, t), blend(&dz, t)]
    }

    /// Eight samples of the ray `o + d·t` (voxel space) at
    /// `t[i] = ((k + i)·step)` rounded to f32, and their trilinear values,
    /// each bit for bit [`Cursor::trilinear`] of the point
    /// `o[a] + d[a]·t[i]`; `None` (the default) when the layout has no
    /// batched path for them, and the caller takes them one at a time.
    #[inline(always)]
    fn trilinear8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Samples8> {
        let _ = (o, d, k, step);
        None
    }

    /// The central-difference blends ([`Cursor::cross_blend`], not halved)
    /// at the eight samples [`Cursor::trilinear8`] reads, for those whose
    /// cells are interior; `None` (the default) where it declines.
    #[inline(always)]
    fn cross_blend8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Cross8> {
        let _ = (o, d, k, step);
        None
    }

    /// Whether [`Cursor::trilinear8`] can answer at all (callers ask once
    /// per ray, not per batch).
    #[inline(always)]
    fn batches(&self) -> bool {
        false
    }

    /// Trilinear interpolation at a point in voxel coordinates.
    #[inline]
    fn trilinear(&mut self, p: [f32; 3]) -> f32 {
        let (base, t) = locate(p, self.dims());
        self.cell_blend(base[0], base[1], base[2], t)
    }

    /// The nearest voxel's value at a point in voxel coordinates.
    #[inline]
    fn nearest(&mut self, p: [f32; 3]) -> f32 {
        let d = self.dims().as_array();
        let i: [u64; 3] = std::array::from_fn(|a| clamp_axis(p[a], d[a]).round() as u64);
        self.voxel(i[0], i[1], i[2])
    }

    /// Central-difference gradient of the interpolant, per voxel.
    #[inline]
    fn gradient(&mut self, p: [f32; 3]) -> [f32; 3] {
        let mut g = [0.0; 3];
        for (a, ga) in g.iter_mut().enumerate() {
            let mut hi = p;
            let mut lo = p;
            hi[a] += 1.0;
            lo[a] -= 1.0;
            *ga = (self.trilinear(hi) - self.trilinear(lo)) * 0.5;
        }
        g
    }
}

/// Clamp one coordinate to `[0, d − 1]`, mapping NaN to 0.
#[inline(always)]
pub fn clamp_axis(p: f32, d: u64) -> f32 {
    clamp_to(p, (d - 1) as f32)
}

/// Clamp one coordinate to `[0, hi]`, mapping NaN to 0.
#[inline(always)]
fn clamp_to(p: f32, hi: f32) -> f32 {
    // Comparisons rather than `min`, whose NaN rule costs instructions
    // that `p > 0` (false for NaN) has already made unnecessary.
    if p > 0.0 {
        if p < hi {
            p
        } else {
            hi
        }
    } else {
        0.0
    }
}

/// `c` truncated to an integer, for `0 <= c < 2^63` (clamped coordinates):
/// one instruction on x86-64, where `as` adds the saturation fix-ups that
/// clamped values never need. Other values give an unspecified integer.
#[inline(always)]
pub fn trunc_in_range(c: f32) -> i64 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvttss_si64, _mm_set_ss};
        // SAFETY: SSE is part of the x86-64 baseline, and the conversion
        // is defined for every input (out of range gives i64::MIN).
        unsafe { _mm_cvttss_si64(_mm_set_ss(c)) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        c as i64
    }
}

/// The cell base and fractional offsets of a point (see the module rules).
#[inline(always)]
pub fn locate(p: [f32; 3], dims: Dims) -> ([u64; 3], [f32; 3]) {
    Locator::new(dims).locate(p)
}

/// Finds the cell of points in one volume, with the clamping bounds worked
/// out once: for loops that locate many points ([`locate`] recomputes them
/// per call).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Locator {
    /// `dims − 1` per axis, as f32.
    hi: [f32; 3],
}

impl Locator {
    /// The locator of a volume of `dims`.
    pub fn new(dims: Dims) -> Locator {
        Locator {
            hi: dims.as_array().map(|d| (d - 1) as f32),
        }
    }

    /// `p` clamped to the volume's box (NaN to 0), per the module rules.
    #[inline(always)]
    pub fn clamp(&self, p: [f32; 3]) -> [f32; 3] {
        [
            clamp_to(p[0], self.hi[0]),
            clamp_to(p[1], self.hi[1]),
            clamp_to(p[2], self.hi[2]),
        ]
    }

    /// The cell base and fractional offsets of `p` (see the module rules).
    #[inline(always)]
    pub fn locate(&self, p: [f32; 3]) -> ([u64; 3], [f32; 3]) {
        let c = self.clamp(p);
        let mut base = [0u64; 3];
        let mut t = [0f32; 3];
        for a in 0..3 {
            // 0 <= c < 2^63, so truncation is floor; through i64 because
            // float/u64 conversions cost several instructions on x86-64.
            let i = trunc_in_range(c[a]);
            base[a] = i as u64;
            t[a] = c[a] - i as f32;
        }
        (base, t)
    }

    /// The cell base of `p`: the first voxel the sampler reads there.
    #[inline(always)]
    pub fn voxel(&self, p: [f32; 3]) -> [u64; 3] {
        self.clamp(p).map(|c| trunc_in_range(c) as u64)
    }
}

/// Trilinear blend of cell values `c` with offsets `t`.
#[inline(always)]
pub fn blend(c: &[f32; 8], t: [f32; 3]) -> f32 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(c[0], c[1], t[0]);
    let x10 = lerp(c[2], c[3], t[0]);
    let x01 = lerp(c[4], c[5], t[0]);
    let x11 = lerp(c[6], c[7], t[0]);
    let y0 = lerp(x00, x10, t[1]);
    let y1 = lerp(x01, x11, t[1]);
    lerp(y0, y1, t[2])
}

/// The trilinear interpolant of cell values `c` at offsets `t` where
/// [`blend`] gives no finite value: infinite corners and finite ones near
/// ±FLT_MAX. A corner whose weight is zero does not count; an infinite
/// corner with weight gives its infinity (NaN when both infinities have
/// weight, or a NaN corner does); finite corners are blended in f64, so
/// values of opposite sign near ±FLT_MAX do not overflow. Equal to
/// [`blend`] (up to rounding) wherever that is finite; MIP and MinIP read
/// a sample through it when [`blend`] gives ±inf or NaN.
pub fn blend_extended(c: &[f32; 8], t: [f32; 3]) -> f32 {
    let (mut sum, mut pos, mut neg) = (0.0f64, false, false);
    for (i, &v) in c.iter().enumerate() {
        let w = (0..3)
            .map(|a| {
                let ta = t[a] as f64;
                if i >> a & 1 == 1 {
                    ta
                } else {
                    1.0 - ta
                }
            })
            .product::<f64>();
        if w <= 0.0 {
            continue;
        }
        if v.is_nan() {
            return f32::NAN;
        }
        if v == f32::INFINITY {
            pos = true;
        } else if v == f32::NEG_INFINITY {
            neg = true;
        } else {
            sum += w * v as f64;
        }
    }
    match (pos, neg) {
        (true, true) => f32::NAN,
        (true, false) => f32::INFINITY,
        (false, true) => f32::NEG_INFINITY,
        (false, false) => sum as f32,
    }
}

/// [`blend`] of the cell whose first corner is `s[base]`, corners `ox`,
/// `oy`, `oz` apart: the scalar [`Sample::cell_blend`].
#[inline(always)]
pub(crate) fn blend_cell_from<T: Sample>(s: &[T], base: usize, o: [usize; 3], t: [f32; 3]) -> f32 {
    blend(&cell_from(s, base, o[0], o[1], o[2]), t)
}

/// [`blend`] of each axis's [`cross_diffs_from`]: the scalar
/// [`Sample::cross_blend`].
#[inline(always)]
pub(crate) fn blend_cross_from<T: Sample>(
    s: &[T],
    base: usize,
    o: [usize; 3],
    t: [f32; 3],
) -> [f32; 3] {
    let [dx, dy, dz] = cross_diffs_from(s, base, o[0], o[1], o[2]);
    [blend(&dx, t), blend(&dy, t), blend(&dz, t)]
}

#[inline(always)]
pub(crate) fn cell_from<T: Sample>(
    s: &[T],
    base: usize,
    ox: usize,
    oy: usize,
    oz: usize,
) -> [f32; 8] {
    // One bounds check for the whole cell instead of eight.
    let s = &s[base..=base + ox + oy + oz];
    [
        s[0].to_f32(),
        s[ox].to_f32(),
        s[oy].to_f32(),
        s[ox + oy].to_f32(),
        s[oz].to_f32(),
        s[ox + oz].to_f32(),
        s[oy + oz].to_f32(),
        s[ox + oy + oz].to_f32(),
    ]
}

/// [`Cursor::cross_diffs`] around the cell whose first corner is
/// `s[base]`, with neighbours `ox`, `oy`, `oz` samples apart (all in `s`).
/// Integer samples are subtracted before they are converted
/// ([`Sample::diff_f32`]): 24 conversions instead of 48, the same bits.
#[inline(always)]
pub(crate) fn cross_diffs_from<T: Sample>(
    s: &[T],
    base: usize,
    ox: usize,
    oy: usize,
    oz: usize,
) -> [[f32; 8]; 3] {
    // One bounds check for the whole cross: the lowest sample read is
    // `base − m`, the highest `base + ox + oy + oz + m`, `m` the largest
    // neighbour distance.
    let m = ox.max(oy).max(oz);
    let s = &s[base - m..=base + ox + oy + oz + m];
    let corners = [0, ox, oy, ox + oy, oz, ox + oz, oy + oz, ox + oy + oz];
    let diffs = |o: usize| -> [f32; 8] {
        std::array::from_fn(|c| T::diff_f32(s[m + corners[c] + o], s[m + corners[c] - o]))
    };
    [diffs(ox), diffs(oy), diffs(oz)]
}

// ----------------------------------------------------------- any layout --

/// Any cursor behind a trait object: one compiled copy of a loop serves
/// every sample type and layout, at the cost of a call per read. For the
/// paths that are not worth a copy per layout (fallbacks for CPUs without
/// the vector units the fast copy is compiled for); the values are the
/// wrapped cursor's, bit for bit.
pub struct DynCursor<'a>(pub &'a mut dyn Cursor);

impl Cursor for DynCursor<'_> {
    fn dims(&self) -> Dims {
        self.0.dims()
    }
    fn finite(&self) -> bool {
        self.0.finite()
    }
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32 {
        self.0.voxel(x, y, z)
    }
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8] {
        self.0.cell(i, j, k)
    }
    fn cross_diffs(&mut self, i: u64, j: u64, k: u64) -> [[f32; 8]; 3] {
        self.0.cross_diffs(i, j, k)
    }
    fn cell_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> f32 {
        self.0.cell_blend(i, j, k, t)
    }
    fn cross_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> [f32; 3] {
        self.0.cross_blend(i, j, k, t)
    }
    fn trilinear8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Samples8> {
        self.0.trilinear8(o, d, k, step)
    }
    fn cross_blend8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Cross8> {
        self.0.cross_blend8(o, d, k, step)
    }
    fn batches(&self) -> bool {
        self.0.batches()
    }
    fn trilinear(&mut self, p: [f32; 3]) -> f32 {
        self.0.trilinear(p)
    }
    fn nearest(&mut self, p: [f32; 3]) -> f32 {
        self.0.nearest(p)
    }
    fn gradient(&mut self, p: [f32; 3]) -> [f32; 3] {
        self.0.gradient(p)
    }
}

// ---------------------------------------------------------------- sliced --

/// The order of a sliced grid's samples in storage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SliceOrder {
    /// x fastest, z slowest: index `x + X·(y + Y·z)` (volkit's own).
    XFastest,
    /// z fastest, x slowest: index `z + Z·(y + Y·x)` (the thesis `.vol`).
    ZFastest,
}

impl SliceOrder {
    /// Samples between neighbours along x, y and z in a `dims` volume.
    pub fn strides(self, dims: Dims) -> [u64; 3] {
        match self {
            SliceOrder::XFastest => [1, dims.x, dims.x * dims.y],
            SliceOrder::ZFastest => [dims.y * dims.z, dims.z, 1],
        }
    }
}

/// Samples in one array (owned or mapped), x fastest or z fastest. Both
/// orders sample alike: a cell's corners are read in the same order and
/// blended the same way, so they give the same bits.
pub struct SlicedGrid<T: Sample> {
    dims: Dims,
    order: SliceOrder,
    data: Data<T>,
}

impl<T: Sample> SlicedGrid<T> {
    /// Wrap x-fastest `data`, which must hold exactly `dims.count()`
    /// samples.
    pub fn new(dims: Dims, data: Data<T>) -> crate::Result<SlicedGrid<T>> {
        SlicedGrid::with_order(dims, SliceOrder::XFastest, data)
    }

    /// Wrap `data` stored in `order`, which must hold exactly
    /// `dims.count()` samples: a z-fastest file is sampled in place, with
    /// no transposing copy.
    pub fn with_order(dims: Dims, order: SliceOrder, data: Data<T>) -> crate::Result<Self> {
        if data.len() as u64 != dims.count() {
            return Err(crate::Error::Corrupt(format!(
                "sliced data has {} samples, {dims} needs {}",
                data.len(),
                dims.count()
            )));
        }
        Ok(SlicedGrid { dims, order, data })
    }

    /// The order of the samples in storage.
    pub fn order(&self) -> SliceOrder {
        self.order
    }

    /// All samples, in [`SlicedGrid::order`].
    pub fn samples(&self) -> &[T] {
        &self.data
    }

    /// Where the samples live (for [`Data::read_at`]).
    pub fn data(&self) -> &Data<T> {
        &self.data
    }

    /// Whether the samples are memory-mapped.
    pub fn is_mapped(&self) -> bool {
        self.data.is_mapped()
    }
}

/// Cursor over a [`SlicedGrid`].
pub struct SlicedCursor<'a, T: Sample> {
    dims: Dims,
    /// Samples between neighbours along x, y and z.
    strides: [usize; 3],
    data: &'a [T],
    /// The batched path's addressing, where the CPU and volume allow it.
    lanes: Option<crate::lanes::SliceLanes>,
}

impl<T: Sample> SlicedCursor<'_, T> {
    /// Index in the samples of voxel `(i, j, k)`.
    #[inline(always)]
    fn at(&self, i: u64, j: u64, k: u64) -> usize {
        let [sx, sy, sz] = self.strides;
        i as usize * sx + j as usize * sy + k as usize * sz
    }
}

impl<T: Sample> VoxelSource for SlicedGrid<T> {
    type Sample = T;
    type Cursor<'a> = SlicedCursor<'a, T>;

    fn dims(&self) -> Dims {
        self.dims
    }

    fn cursor(&self) -> SlicedCursor<'_, T> {
        let strides = self.order.strides(self.dims);
        SlicedCursor {
            dims: self.dims,
            strides: strides.map(|s| s as usize),
            data: &self.data,
            lanes: T::BATCHES
                .then(|| {
                    crate::lanes::SliceLanes::new(self.dims.as_array(), strides, self.data.len())
                })
                .flatten(),
        }
    }

    fn read_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        match self.order {
            SliceOrder::XFastest => {
                let start = self.dims.index(x0, y, z) as usize;
                out.copy_from_slice(&self.data[start..start + out.len()]);
            }
            SliceOrder::ZFastest => {
                let [sx, sy, _] = self.order.strides(self.dims).map(|s| s as usize);
                let start = x0 as usize * sx + y as usize * sy + z as usize;
                for (n, o) in out.iter_mut().enumerate() {
                    *o = self.data[start + n * sx];
                }
            }
        }
    }
}

impl<T: Sample> Cursor for SlicedCursor<'_, T> {
    #[inline(always)]
    fn finite(&self) -> bool {
        matches!(T::TYPE, SampleType::U8 | SampleType::U16 | SampleType::I16)
    }
    #[inline(always)]
    fn dims(&self) -> Dims {
        self.dims
    }

    #[inline(always)]
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32 {
        self.data[self.at(x, y, z)].to_f32()
    }

    #[inline(always)]
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8] {
        let d = self.dims;
        let [sx, sy, sz] = self.strides;
        let ox = if i + 1 < d.x { sx } else { 0 };
        let oy = if j + 1 < d.y { sy } else { 0 };
        let oz = if k + 1 < d.z { sz } else { 0 };
        cell_from(self.data, self.at(i, j, k), ox, oy, oz)
    }

    #[inline(always)]
    fn cross_diffs(&mut self, i: u64, j: u64, k: u64) -> [[f32; 8]; 3] {
        let [sx, sy, sz] = self.strides;
        cross_diffs_from(self.data, self.at(i, j, k), sx, sy, sz)
    }

    #[inline(always)]
    fn cell_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> f32 {
        let d = self.dims;
        let [sx, sy, sz] = self.strides;
        let ox = if i + 1 < d.x { sx } else { 0 };
        let oy = if j + 1 < d.y { sy } else { 0 };
        let oz = if k + 1 < d.z { sz } else { 0 };
        T::cell_blend(self.data, self.at(i, j, k), [ox, oy, oz], t)
    }

    #[inline(always)]
    fn cross_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> [f32; 3] {
        T::cross_blend(self.data, self.at(i, j, k), self.strides, t)
    }

    #[inline(always)]
    fn trilinear8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Samples8> {
        let g = self.lanes.as_ref()?;
        T::sliced_values8(self.data, g, o, d, k, step)
    }

    #[inline(always)]
    fn cross_blend8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Cross8> {
        let g = self.lanes.as_ref()?;
        T::sliced_cross8(self.data, g, o, d, k, step)
    }

    #[inline(always)]
    fn batches(&self) -> bool {
        T::BATCHES && self.lanes.is_some()
    }
}

// --------------------------------------------------------------- bricked --

/// Uncompressed bricks, stored back to back `stride` samples apart
/// (owned or mapped). See [`crate::brick`] for the geometry.
pub struct BrickedGrid<T: Sample> {
    geom: BrickGeometry,
    stride: usize,
    data: Data<T>,
}

impl<T: Sample> BrickedGrid<T> {
    /// Wrap `data` holding `geom.brick_count()` bricks, brick `n` starting
    /// at sample `n · stride` (`stride >= geom.stored_len()`).
    pub fn new(geom: BrickGeometry, stride: usize, data: Data<T>) -> crate::Result<Self> {
        let need = (geom.brick_count() as usize)
            .checked_mul(stride)
            .ok_or_else(|| crate::Error::Corrupt("brick data size overflows".into()))?;
        if stride < geom.stored_len() || data.len() < need {
            return Err(crate::Error::Corrupt(format!(
                "brick data has {} samples, {} bricks of stride {stride} need {need}",
                data.len(),
                geom.brick_count()
            )));
        }
        Ok(BrickedGrid { geom, stride, data })
    }

    /// The brick geometry.
    pub fn geometry(&self) -> &BrickGeometry {
        &self.geom
    }

    /// Where the bricks live: brick `n` starts at sample
    /// `n · brick_stride()` (for [`Data::read_at`]).
    pub fn data(&self) -> &Data<T> {
        &self.data
    }

    /// Samples from the start of one brick to the start of the next.
    pub fn brick_stride(&self) -> usize {
        self.stride
    }

    /// The stored samples of brick `index` (apron included).
    pub fn brick(&self, index: u64) -> &[T] {
        let s = index as usize * self.stride;
        &self.data[s..s + self.geom.stored_len()]
    }

    /// Whether the samples are memory-mapped.
    pub fn is_mapped(&self) -> bool {
        self.data.is_mapped()
    }
}

/// Where voxel coordinates fall in the bricked layout.
#[derive(Clone, Copy)]
struct BrickAddr {
    brick: u64,
    local: usize,
}

#[inline(always)]
fn brick_addr(g: &BrickGeometry, i: u64, j: u64, k: u64) -> BrickAddr {
    BrickAddresser::new(g).addr(i, j, k)
}

/// Brick addressing constants of one geometry, worked out once for
/// cursors, which address a brick per sample.
#[derive(Clone, Copy)]
struct BrickAddresser {
    /// Owned edge.
    b: u64,
    /// log2 of the owned edge when it is a power of two (the usual case:
    /// then dividing is shifting, where a 64-bit division per axis would
    /// cost more than the rest of a cell fetch).
    shift: Option<u32>,
    /// Stored edge.
    e: usize,
    /// Bricks along x and y.
    nx: u64,
    ny: u64,
}

impl BrickAddresser {
    fn new(g: &BrickGeometry) -> BrickAddresser {
        let b = g.brick() as u64;
        let [nx, ny, _] = g.counts();
        BrickAddresser {
            b,
            shift: b.is_power_of_two().then(|| b.trailing_zeros()),
            e: g.stored_edge() as usize,
            nx,
            ny,
        }
    }

    #[inline(always)]
    fn addr(&self, i: u64, j: u64, k: u64) -> BrickAddr {
        let b = self.b;
        let (bx, by, bz) = match self.shift {
            Some(s) => (i >> s, j >> s, k >> s),
            None => (i / b, j / b, k / b),
        };
        let e = self.e;
        let lo = crate::brick::APRON_LO as u64;
        let li = (i - bx * b + lo) as usize;
        let lj = (j - by * b + lo) as usize;
        let lk = (k - bz * b + lo) as usize;
        BrickAddr {
            brick: bx + self.nx * (by + self.ny * bz),
            local: li + e * (lj + e * lk),
        }
    }
}

/// Cursor over a [`BrickedGrid`].
pub struct BrickedCursor<'a, T: Sample> {
    grid: &'a BrickedGrid<T>,
    /// The samples, resolved once (not per sample through [`Data`]).
    data: &'a [T],
    addr: BrickAddresser,
    /// The batched path's addressing, where the CPU and volume allow it.
    lanes: Option<crate::lanes::BrickLanes>,
}

impl<T: Sample> VoxelSource for BrickedGrid<T> {
    type Sample = T;
    type Cursor<'a> = BrickedCursor<'a, T>;

    fn dims(&self) -> Dims {
        self.geom.dims()
    }

    fn cursor(&self) -> BrickedCursor<'_, T> {
        let g = &self.geom;
        BrickedCursor {
            grid: self,
            data: &self.data,
            addr: BrickAddresser::new(g),
            lanes: crate::lanes::BrickLanes::new(
                g.dims().as_array(),
                g.brick() as u64,
                g.stored_edge() as u64,
                crate::brick::APRON_LO as u64,
                g.counts(),
                self.stride,
            ),
        }
    }

    fn read_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        read_row_bricked(&self.geom, x0, y, z, out, |id| Some(self.brick(id)));
    }
}

/// Copy a row out of bricks, one brick-sized run at a time.
fn read_row_bricked<'b, T: Sample + 'b>(
    g: &BrickGeometry,
    x0: u64,
    y: u64,
    z: u64,
    out: &mut [T],
    mut brick: impl FnMut(u64) -> Option<&'b [T]>,
) {
    let b = g.brick() as u64;
    let mut x = x0;
    let mut done = 0usize;
    while done < out.len() {
        let run = ((b - x % b) as usize).min(out.len() - done);
        let a = brick_addr(g, x, y, z);
        match brick(a.brick) {
            Some(s) => out[done..done + run].copy_from_slice(&s[a.local..a.local + run]),
            None => out[done..done + run].fill(T::default()),
        }
        done += run;
        x += run as u64;
    }
}

impl<T: Sample> BrickedCursor<'_, T> {
    /// Index in `data` of voxel `(i, j, k)` and the stored brick edge.
    #[inline(always)]
    fn at(&self, i: u64, j: u64, k: u64) -> (usize, usize) {
        let a = self.addr.addr(i, j, k);
        (a.brick as usize * self.grid.stride + a.local, self.addr.e)
    }
}

impl<T: Sample> Cursor for BrickedCursor<'_, T> {
    #[inline(always)]
    fn finite(&self) -> bool {
        matches!(T::TYPE, SampleType::U8 | SampleType::U16 | SampleType::I16)
    }
    #[inline(always)]
    fn dims(&self) -> Dims {
        self.grid.geom.dims()
    }

    #[inline(always)]
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32 {
        self.data[self.at(x, y, z).0].to_f32()
    }

    #[inline(always)]
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8] {
        let (base, e) = self.at(i, j, k);
        cell_from(self.data, base, 1, e, e * e)
    }

    #[inline(always)]
    fn cross_diffs(&mut self, i: u64, j: u64, k: u64) -> [[f32; 8]; 3] {
        // The apron (one voxel before, two after) holds the whole cross
        // inside the brick of (i, j, k).
        let (base, e) = self.at(i, j, k);
        cross_diffs_from(self.data, base, 1, e, e * e)
    }

    #[inline(always)]
    fn cell_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> f32 {
        let (base, e) = self.at(i, j, k);
        T::cell_blend(self.data, base, [1, e, e * e], t)
    }

    #[inline(always)]
    fn cross_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> [f32; 3] {
        let (base, e) = self.at(i, j, k);
        T::cross_blend(self.data, base, [1, e, e * e], t)
    }

    #[inline(always)]
    fn trilinear8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Samples8> {
        let g = self.lanes.as_ref()?;
        T::bricked_values8(self.data, g, o, d, k, step)
    }

    #[inline(always)]
    fn cross_blend8(&mut self, o: [f32; 3], d: [f32; 3], k: i64, step: f64) -> Option<Cross8> {
        let g = self.lanes.as_ref()?;
        T::bricked_cross8(self.data, g, o, d, k, step)
    }

    #[inline(always)]
    fn batches(&self) -> bool {
        T::BATCHES && self.lanes.is_some()
    }
}

// ------------------------------------------------------------ compressed --

/// Where one compressed brick lies in the source bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrickEntry {
    /// Byte offset in the source.
    pub offset: u64,
    /// Compressed length in bytes.
    pub length: u64,
    /// CRC-32 (IEEE) of the compressed bytes.
    pub crc32: u32,
}

/// zstd-compressed bricks, decoded on demand into a bounded [`BrickCache`].
pub struct CompressedGrid<T: Sample> {
    geom: BrickGeometry,
    source: Data<u8>,
    entries: Vec<BrickEntry>,
    cache: BrickCache<T>,
    error: OnceLock<String>,
}

impl<T: Sample> CompressedGrid<T> {
    /// Wrap compressed bricks found at `entries` in `source`, caching up to
    /// `cache_bytes` of decoded samples.
    pub fn new(
        geom: BrickGeometry,
        source: Data<u8>,
        entries: Vec<BrickEntry>,
        cache_bytes: usize,
    ) -> crate::Result<Self> {
        if entries.len() as u64 != geom.brick_count() {
            return Err(crate::Error::Corrupt(format!(
                "{} brick entries for {} bricks",
                entries.len(),
                geom.brick_count()
            )));
        }
        for (n, e) in entries.iter().enumerate() {
            let end = e.offset.checked_add(e.length);
            if end.is_none_or(|end| end > source.len() as u64) {
                return Err(crate::Error::Corrupt(format!(
                    "brick {n} lies outside the data ({} bytes at {})",
                    e.length, e.offset
                )));
            }
        }
        let brick_bytes = geom.stored_len() * std::mem::size_of::<T>();
        Ok(CompressedGrid {
            geom,
            source,
            entries,
            cache: BrickCache::new((cache_bytes / brick_bytes).max(64)),
            error: OnceLock::new(),
        })
    }

    /// The brick geometry.
    pub fn geometry(&self) -> &BrickGeometry {
        &self.geom
    }

    /// The brick table.
    pub fn entries(&self) -> &[BrickEntry] {
        &self.entries
    }

    /// The compressed bytes of brick `index`.
    pub fn compressed(&self, index: u64) -> &[u8] {
        let e = self.entries[index as usize];
        &self.source[e.offset as usize..(e.offset + e.length) as usize]
    }

    /// Decode brick `index` without the cache, checking its CRC and size.
    pub fn decode(&self, index: u64) -> Result<Vec<T>, String> {
        let bytes = self.compressed(index);
        let e = self.entries[index as usize];
        let crc = crc32fast::hash(bytes);
        if crc != e.crc32 {
            return Err(format!(
                "brick {index}: checksum {crc:08x} does not match {:08x}",
                e.crc32
            ));
        }
        let n = self.geom.stored_len();
        let mut out = vec![T::default(); n];
        let target: &mut [u8] = bytemuck::cast_slice_mut(&mut out);
        let got =
            zstd_decompress(bytes, target).map_err(|err| format!("brick {index}: zstd: {err}"))?;
        if got != target.len() {
            return Err(format!(
                "brick {index}: decoded {got} bytes, expected {}",
                target.len()
            ));
        }
        T::slice_from_le(&mut out);
        Ok(out)
    }

    /// Brick `index` from the cache, decoding it on a miss. A brick that
    /// fails to decode reads as zeros and records the error.
    pub fn brick(&self, index: u64) -> Arc<[T]> {
        match self.cache.get_or_load(index, || self.decode(index)) {
            Ok(b) => b,
            Err(msg) => {
                let _ = self.error.set(msg);
                vec![T::default(); self.geom.stored_len()].into()
            }
        }
    }
}

/// Decompress one zstd frame into `target` with this thread's decoder,
/// created once per thread: a fresh decoder per brick costs more than
/// decoding a small brick.
fn zstd_decompress(bytes: &[u8], target: &mut [u8]) -> std::io::Result<usize> {
    thread_local! {
        static DECODER: std::cell::RefCell<Option<zstd::bulk::Decompressor<'static>>> =
            const { std::cell::RefCell::new(None) };
    }
    DECODER.with(|cell| {
        let mut slot = cell.borrow_mut();
        if slot.is_none() {
            *slot = Some(zstd::bulk::Decompressor::new()?);
        }
        match slot.as_mut() {
            Some(d) => d.decompress_to_buffer(bytes, target),
            None => zstd::bulk::decompress_to_buffer(bytes, target),
        }
    })
}

/// Cursor over a [`CompressedGrid`]; remembers the last brick it used.
pub struct CompressedCursor<'a, T: Sample> {
    grid: &'a CompressedGrid<T>,
    current: Option<(u64, Arc<[T]>)>,
    addr: BrickAddresser,
}

impl<T: Sample> CompressedCursor<'_, T> {
    #[inline(always)]
    fn brick(&mut self, id: u64) -> &[T] {
        let hit = matches!(&self.current, Some((cur, _)) if *cur == id);
        if !hit {
            self.current = Some((id, self.grid.brick(id)));
        }
        match &self.current {
            Some((_, b)) => b,
            None => &[],
        }
    }
}

impl<T: Sample> VoxelSource for CompressedGrid<T> {
    type Sample = T;
    type Cursor<'a> = CompressedCursor<'a, T>;

    fn dims(&self) -> Dims {
        self.geom.dims()
    }

    fn cursor(&self) -> CompressedCursor<'_, T> {
        CompressedCursor {
            grid: self,
            current: None,
            addr: BrickAddresser::new(&self.geom),
        }
    }

    fn read_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        let mut held: Vec<Arc<[T]>> = Vec::new();
        let ids: Vec<u64> = {
            let b = self.geom.brick() as u64;
            let last = x0 + out.len() as u64 - 1;
            (x0 / b..=last / b)
                .map(|bx| brick_addr(&self.geom, bx * b, y, z).brick)
                .collect()
        };
        for &id in &ids {
            held.push(self.brick(id));
        }
        read_row_bricked(&self.geom, x0, y, z, out, |id| {
            ids.iter().position(|&i| i == id).map(|p| &held[p][..])
        });
    }

    fn error(&self) -> Option<String> {
        self.error.get().cloned()
    }
}

impl<T: Sample> Cursor for CompressedCursor<'_, T> {
    #[inline(always)]
    fn finite(&self) -> bool {
        matches!(T::TYPE, SampleType::U8 | SampleType::U16 | SampleType::I16)
    }
    #[inline(always)]
    fn dims(&self) -> Dims {
        self.grid.geom.dims()
    }

    #[inline(always)]
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32 {
        let a = self.addr.addr(x, y, z);
        self.brick(a.brick)[a.local].to_f32()
    }

    #[inline(always)]
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8] {
        let a = self.addr.addr(i, j, k);
        let e = self.addr.e;
        cell_from(self.brick(a.brick), a.local, 1, e, e * e)
    }

    #[inline(always)]
    fn cross_diffs(&mut self, i: u64, j: u64, k: u64) -> [[f32; 8]; 3] {
        // The apron holds the whole cross inside the brick of (i, j, k).
        let a = self.addr.addr(i, j, k);
        let e = self.addr.e;
        cross_diffs_from(self.brick(a.brick), a.local, 1, e, e * e)
    }

    #[inline(always)]
    fn cell_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> f32 {
        let a = self.addr.addr(i, j, k);
        let e = self.addr.e;
        T::cell_blend(self.brick(a.brick), a.local, [1, e, e * e], t)
    }

    #[inline(always)]
    fn cross_blend(&mut self, i: u64, j: u64, k: u64, t: [f32; 3]) -> [f32; 3] {
        let a = self.addr.addr(i, j, k);
        let e = self.addr.e;
        T::cross_blend(self.brick(a.brick), a.local, [1, e, e * e], t)
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn blend_extended_follows_infinities_and_agrees_with_blend() {
        use super::{blend, blend_extended};
        let t = [0.25, 0.5, 0.75];
        let finite = [1.0, -2.0, 3.5, 0.0, 7.0, 1e-3, -4.0, 2.0];
        let (a, b) = (blend(&finite, t), blend_extended(&finite, t));
        assert!((a - b).abs() <= 1e-6 * a.abs().max(1.0), "{a} vs {b}");
        // An infinite corner with weight wins; without weight it is not read.
        let mut c = [0.5f32; 8];
        c[7] = f32::INFINITY;
        assert_eq!(blend_extended(&c, t), f32::INFINITY);
        assert!(blend(&c, t).is_nan() || blend(&c, t).is_infinite());
        assert_eq!(blend_extended(&c, [0.0, 0.5, 0.5]), 0.5);
        c[0] = f32::NEG_INFINITY;
        assert!(blend_extended(&c, t).is_nan());
        assert_eq!(blend_extended(&c, [1.0, 1.0, 0.5]), f32::INFINITY);
        // Opposite values near FLT_MAX blend to their mean, not to inf.
        let mut m = [f32::MAX; 8];
        m[..4].fill(-f32::MAX);
        assert_eq!(blend_extended(&m, [0.5, 0.5, 0.5]), 0.0);
        assert!(blend_extended(&[f32::NAN; 8], t).is_nan());
    }
    use super::*;
    use crate::region::{pack_bricks, Rows};

    #[test]
    fn locator_clamps_and_floors_by_the_module_rules() {
        let loc = Locator::new(Dims::new(5, 1, 300).unwrap());
        let (b, t) = loc.locate([2.75, 0.5, 299.0]);
        assert_eq!((b, t), ([2, 0, 299], [0.75, 0.0, 0.0]));
        // NaN and negatives clamp to 0, beyond the far face to the face.
        let (b, t) = loc.locate([f32::NAN, -3.0, 1e30]);
        assert_eq!((b, t), ([0, 0, 299], [0.0; 3]));
        assert_eq!(loc.voxel([4.999, f32::INFINITY, -0.0]), [4, 0, 0]);
        assert_eq!(loc.clamp([-f32::INFINITY, 7.0, 12.5]), [0.0, 0.0, 12.5]);
        for c in [0.0f32, 0.5, 1.0, 16_777_215.0, 3e9] {
            assert_eq!(trunc_in_range(c), c as i64, "{c}");
        }
    }

    /// Eight points at once in a bricked u8 volume read the same bits as
    /// one at a time: rays through random points (in the box, beyond its
    /// faces, straddling bricks, along axes, NaN), on volumes whose edges
    /// are and are not multiples of the brick.
    #[test]
    fn eight_points_at_once_match_one_at_a_time() {
        let mut rng = fastrand::Rng::with_seed(21);
        let mut batched = 0;
        let mut interiors = 0;
        let mut straddles = 0;
        let mut declined = 0;
        for (dims, b) in [((40, 37, 33), 16), ((64, 64, 64), 32), ((9, 70, 5), 4)] {
            let dims = Dims::new(dims.0, dims.1, dims.2).unwrap();
            let samples: Vec<u8> = (0..dims.count()).map(|_| rng.u8(..)).collect();
            let sliced = SlicedGrid::new(dims, Data::Owned(samples)).unwrap();
            let geom = BrickGeometry::new(dims, b).unwrap();
            let bricks = pack_bricks(&Rows(&sliced), &geom);
            let stride = geom.stored_len();
            let grid = BrickedGrid::new(geom, stride, Data::Owned(bricks)).unwrap();
            let mut cur = grid.cursor();
            let mut one = grid.cursor();
            let size = dims.as_array().map(|d| d as f32);
            for i in 0..4000 {
                let o: [f32; 3] = std::array::from_fn(|a| rng.f32() * (size[a] + 4.0) - 2.0);
                let mut d: [f32; 3] = std::array::from_fn(|_| rng.f32() * 2.0 - 1.0);
                if i % 7 == 0 {
                    d = [0.0, 0.0, 0.0];
                    d[i % 3] = if i % 2 == 0 { 1.0 } else { -1.0 };
                }
                let step = [0.2, 0.05, 1.0, 3.0, 0.1][i % 5];
                let k0 = rng.i64(-12..40);
                let Some(got) = cur.trilinear8(o, d, k0, step) else {
                    continue;
                };
                batched += 1;
                let cross = cur.cross_blend8(o, d, k0, step).unwrap();
                let loc = Locator::new(dims);
                let brick = |i: usize| {
                    let t = ((k0 + i as i64) as f64 * step) as f32;
                    loc.locate(std::array::from_fn(|a| o[a] + d[a] * t))
                        .0
                        .map(|c| c / u64::from(b))
                };
                let straddle = brick(0) != brick(7);
                straddles += usize::from(straddle);
                // Volumes whose offsets do not fit the lanes (here: a slice
                // one byte short of the bricks) read runs within one brick
                // only, the same bits.
                let g = cur.lanes.as_ref().unwrap();
                let short = &cur.data[..cur.data.len() - 1];
                match crate::lanes::bricked_values8(short, g, o, d, k0, step) {
                    Some(s) => {
                        assert!(!straddle);
                        assert_eq!(s, got);
                    }
                    None => declined += 1,
                }
                for i in 0..8 {
                    let t = ((k0 + i as i64) as f64 * step) as f32;
                    assert_eq!(got.t[i].to_bits(), t.to_bits());
                    let p = std::array::from_fn(|a| o[a] + d[a] * t);
                    let want = one.trilinear(p);
                    assert_eq!(got.v[i].to_bits(), want.to_bits(), "{p:?}");
                    let (b, f) = loc.locate(p);
                    let interior = (0..3).all(|a| b[a] >= 1 && b[a] + 2 < dims.as_array()[a]);
                    assert_eq!(cross.interior >> i & 1 == 1, interior, "{p:?}");
                    if interior {
                        interiors += 1;
                        let want = one.cross_blend(b[0], b[1], b[2], f);
                        let got = [0, 1, 2].map(|a| cross.g[a][i]);
                        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{p:?}");
                    }
                }
            }
        }
        // Without AVX2 the batched path declines every time.
        let avx2 = crate::lanes::avx2_available();
        assert_eq!(batched > 5000, avx2, "{batched} batches");
        assert_eq!(interiors > 20_000, avx2, "{interiors} interior samples");
        // Runs that cross brick faces read each point from its own brick.
        assert_eq!(straddles > 500, avx2, "{straddles} runs across bricks");
        assert!(
            declined >= straddles && declined < batched / 2,
            "{declined}"
        );
    }

    /// Sliced `u8` volumes in either order batch runs of eight whose cells
    /// all have a neighbour on every axis and whose reads stay in the
    /// samples, each value and interior gradient bit for bit what the
    /// cursor gives one by one; the others are declined, never read: runs
    /// reaching a far face or (rays toward the last corner) the end of the
    /// samples.
    #[test]
    fn sliced_runs_of_eight_match_one_at_a_time() {
        let mut rng = fastrand::Rng::with_seed(5);
        let (mut batched, mut interiors, mut at_end, mut near_end) = (0, 0, 0, 0);
        for order in [SliceOrder::XFastest, SliceOrder::ZFastest] {
            for dims in [(40, 37, 33), (9, 70, 5), (64, 64, 64), (2, 3, 7)] {
                let dims = Dims::new(dims.0, dims.1, dims.2).unwrap();
                let samples: Vec<u8> = (0..dims.count())
                    .map(|_| match rng.u8(0..8) {
                        0 => 0,
                        1 => 255,
                        _ => rng.u8(..),
                    })
                    .collect();
                let len = samples.len() as i64;
                let grid = SlicedGrid::with_order(dims, order, Data::Owned(samples)).unwrap();
                let mut cur = grid.cursor();
                let mut one = grid.cursor();
                assert_eq!(cur.batches(), crate::lanes::avx2_available());
                let loc = Locator::new(dims);
                let n = dims.as_array();
                let size = n.map(|d| d as f32);
                let st = order.strides(dims).map(|s| s as i64);
                // The two slower axes' strides, in x, y, z order.
                let (s1, s2) = match order {
                    SliceOrder::XFastest => (st[1], st[2]),
                    SliceOrder::ZFastest => (st[0], st[1]),
                };
                for i in 0..3000 {
                    let toward_end = i % 3 == 0;
                    let o: [f32; 3] = std::array::from_fn(|a| {
                        if toward_end {
                            size[a] - 1.0 - rng.f32() * 3.0
                        } else {
                            rng.f32() * (size[a] + 4.0) - 2.0
                        }
                    });
                    let mut d: [f32; 3] = std::array::from_fn(|_| rng.f32() * 2.0 - 1.0);
                    if toward_end {
                        d = d.map(|c| c.abs() * 0.3);
                    }
                    if i % 7 == 0 {
                        d = [0.0; 3];
                        d[i % 3] = if i % 2 == 0 { 1.0 } else { -1.0 };
                    }
                    let step = [0.2, 0.05, 1.0, 3.0, 0.1][i % 5];
                    let k0 = rng.i64(-12..40);
                    let points: [([u64; 3], [f32; 3]); 8] = std::array::from_fn(|j| {
                        let t = ((k0 + j as i64) as f64 * step) as f32;
                        loc.locate(std::array::from_fn(|a| o[a] + d[a] * t))
                    });
                    let base = |b: [u64; 3]| (0..3).map(|a| b[a] as i64 * st[a]).sum::<i64>();
                    let on_face = points.iter().any(|(b, _)| (0..3).any(|a| b[a] + 1 >= n[a]));
                    let past_end = points.iter().any(|(b, _)| base(*b) + s1 + s2 + 3 >= len);
                    let got = cur.trilinear8(o, d, k0, step);
                    let expect = crate::lanes::avx2_available() && !on_face && !past_end;
                    assert_eq!(got.is_some(), expect, "{order:?} {dims} {o:?} {d:?} {k0}");
                    at_end += usize::from(past_end && !on_face);
                    let Some(got) = got else {
                        continue;
                    };
                    batched += 1;
                    let interior = |b: [u64; 3]| (0..3).all(|a| b[a] >= 1 && b[a] + 2 < n[a]);
                    // No interior cell's cross reaches past the samples
                    // (so the lanes need not check).
                    let reach = (s1 + 2 * s2).max(2 * s1 + s2);
                    for (b, _) in &points {
                        if interior(*b) {
                            assert!(base(*b) - s1.max(s2) >= 0 && base(*b) + reach + 3 < len);
                            near_end += usize::from(base(*b) + reach + 3 + s2 >= len);
                        }
                    }
                    let cross = cur
                        .cross_blend8(o, d, k0, step)
                        .expect("a batched run's crosses are read");
                    for (j, &(b, f)) in points.iter().enumerate() {
                        let t = ((k0 + j as i64) as f64 * step) as f32;
                        assert_eq!(got.t[j].to_bits(), t.to_bits());
                        let p = std::array::from_fn(|a| o[a] + d[a] * t);
                        let want = one.trilinear(p);
                        assert_eq!(got.v[j].to_bits(), want.to_bits(), "{order:?} {p:?}");
                        assert_eq!(cross.interior >> j & 1 == 1, interior(b), "{p:?}");
                        if interior(b) {
                            interiors += 1;
                            let want = one.cross_blend(b[0], b[1], b[2], f);
                            let got = [0, 1, 2].map(|a| cross.g[a][j]);
                            assert_eq!(
                                got.map(f32::to_bits),
                                want.map(f32::to_bits),
                                "{order:?} {p:?}"
                            );
                        }
                    }
                }
            }
        }
        let avx2 = crate::lanes::avx2_available();
        assert_eq!(batched > 3000, avx2, "{batched} batches");
        assert_eq!(interiors > 20_000, avx2, "{interiors} interior samples");
        assert!(at_end > 50, "{at_end} runs reaching the end");
        // Some interior crosses come within a row of the end.
        assert_eq!(near_end > 0, avx2, "{near_end} crosses near the end");
    }

    /// zstd bricks of `samples`, plus one entry whose bytes pass the
    /// checksum but are not zstd.
    fn compressed(dims: Dims, samples: Vec<u16>) -> CompressedGrid<u16> {
        let sliced = SlicedGrid::new(dims, Data::Owned(samples)).unwrap();
        let geom = BrickGeometry::new(dims, 4).unwrap();
        let mut source = Vec::new();
        let mut entries = Vec::new();
        for b in pack_bricks(&Rows(&sliced), &geom).chunks(geom.stored_len()) {
            let bytes = zstd::bulk::compress(bytemuck::cast_slice(b), 3).unwrap();
            entries.push(BrickEntry {
                offset: source.len() as u64,
                length: bytes.len() as u64,
                crc32: crc32fast::hash(&bytes),
            });
            source.extend_from_slice(&bytes);
        }
        let junk = [7u8; 40];
        entries[1] = BrickEntry {
            offset: source.len() as u64,
            length: junk.len() as u64,
            crc32: crc32fast::hash(&junk),
        };
        source.extend_from_slice(&junk);
        CompressedGrid::new(geom, Data::Owned(source), entries, 0).unwrap()
    }

    /// Bricks decode to their samples one after another and after a
    /// damaged brick, on this thread and on others (the per-thread decoder
    /// is reused and recovers from errors).
    #[test]
    fn decode_reuses_the_decoder_and_recovers_after_damage() {
        let dims = Dims::new(9, 6, 5).unwrap();
        let samples: Vec<u16> = (0..dims.count() as u16).map(|v| v * 7).collect();
        let grid = compressed(dims, samples.clone());
        let check = |grid: &CompressedGrid<u16>| {
            for round in 0..2 {
                let err = grid.decode(1).unwrap_err();
                assert!(err.starts_with("brick 1: zstd"), "{err}");
                for id in (0..grid.geometry().brick_count()).filter(|&id| id != 1) {
                    let b = grid.decode(id).unwrap();
                    assert_eq!(b.len(), grid.geometry().stored_len(), "round {round}");
                }
            }
        };
        check(&grid);
        std::thread::scope(|s| {
            s.spawn(|| check(&grid));
        });
        // Every voxel outside brick 1 reads back; brick 1 reads as zeros.
        let mut row = vec![0u16; 4];
        grid.read_row(0, 0, 0, &mut row);
        assert_eq!(row, samples[..4]);
        grid.read_row(4, 0, 0, &mut row);
        assert_eq!(row, [0; 4]);
        assert!(grid.error().is_some());
    }
}
