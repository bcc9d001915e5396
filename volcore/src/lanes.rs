//! Trilinear blends of `u8` cells in SSE2 lanes, bit for bit the scalar
//! [`crate::grid::blend`] of the same corners.
//!
//! A cell whose neighbours along x are adjacent bytes (bricks, x-fastest
//! slices) holds its eight corners as four rows of two bytes: one 16-bit
//! load per row instead of eight byte loads and conversions. The blend's
//! first four lerps (along x) run as one lane-wise lerp, then along y and
//! z as the scalar blend does; each lane does the scalar's operations in
//! the scalar's order, so the results are the same floats.
//!
//! A central-difference gradient reads the cell's cross of neighbours: the
//! differences along an axis `o` are the rows at `+o` minus the rows at
//! `−o` (exact: integers below 2^24), and the three axes' x lerps land in
//! lanes that one transpose turns into the y and z lerps of all three at
//! once.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// The samples a cell at `base` with neighbours `1, oy, oz` apart reads
/// lie in `s`; and, with `cross`, also the cross of neighbours around it
/// (`base − m ..= base + 1 + oy + oz + m`, `m` the largest distance).
#[inline(always)]
fn fits(s: &[u8], base: usize, oy: usize, oz: usize, cross: bool) -> bool {
    let m = if cross { oy.max(oz).max(1) } else { 0 };
    base >= m
        && base
            .checked_add(1 + oy + oz + m)
            .is_some_and(|hi| hi < s.len())
}

/// The value of the cell at `base` (corners `1, oy, oz` apart) at offsets
/// `t`, or `None` when its samples do not all lie in `s`.
#[inline(always)]
pub fn cell_blend(s: &[u8], base: usize, oy: usize, oz: usize, t: [f32; 3]) -> Option<f32> {
    if !fits(s, base, oy, oz, false) {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `fits` checked every byte read; SSE2 is part of the
        // x86-64 baseline.
        Some(unsafe { sse2::cell_blend(s.as_ptr(), base, oy, oz, t) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = t;
        None
    }
}

/// The blends of the cell's central differences along x, y and z (not
/// halved) at offsets `t`, or `None` when the cross around the cell does
/// not lie in `s`.
#[inline(always)]
pub fn cross_blend(s: &[u8], base: usize, oy: usize, oz: usize, t: [f32; 3]) -> Option<[f32; 3]> {
    if !fits(s, base, oy, oz, true) {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: as in `cell_blend`, for the whole cross.
        Some(unsafe { sse2::cross_blend(s.as_ptr(), base, oy, oz, t) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = t;
        None
    }
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::*;

    /// Four rows of two bytes at `p`, `p + oy`, `p + oz`, `p + oy + oz`:
    /// their first bytes and their second bytes, as f32 lanes in that row
    /// order (for `p` a cell's base: corners 0, 2, 4, 6 and 1, 3, 5, 7).
    ///
    /// # Safety
    /// Bytes `p ..= p + oy + oz + 1` of `s` must be readable.
    #[inline(always)]
    unsafe fn rows(s: *const u8, p: usize, oy: usize, oz: usize) -> (__m128, __m128) {
        let two = |a: usize| i32::from(s.add(a).cast::<u16>().read_unaligned());
        let mut v = _mm_cvtsi32_si128(two(p));
        v = _mm_insert_epi16::<1>(v, two(p + oy));
        v = _mm_insert_epi16::<2>(v, two(p + oz));
        v = _mm_insert_epi16::<3>(v, two(p + oy + oz));
        let zero = _mm_setzero_si128();
        let w = _mm_unpacklo_epi8(v, zero);
        let lo = _mm_cvtepi32_ps(_mm_unpacklo_epi16(w, zero));
        let hi = _mm_cvtepi32_ps(_mm_unpackhi_epi16(w, zero));
        (
            _mm_shuffle_ps::<0b10_00_10_00>(lo, hi),
            _mm_shuffle_ps::<0b11_01_11_01>(lo, hi),
        )
    }

    /// `a + (b − a)·t` per lane, the scalar lerp's operations.
    #[inline(always)]
    unsafe fn lerp(a: __m128, b: __m128, t: __m128) -> __m128 {
        _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), t))
    }

    /// See [`super::cell_blend`].
    ///
    /// # Safety
    /// Bytes `base ..= base + 1 + oy + oz` of `s` must be readable.
    #[inline(always)]
    pub unsafe fn cell_blend(s: *const u8, base: usize, oy: usize, oz: usize, t: [f32; 3]) -> f32 {
        let (a, b) = rows(s, base, oy, oz);
        // x00 x10 x01 x11
        let x = lerp(a, b, _mm_set1_ps(t[0]));
        let lo = _mm_shuffle_ps::<0b00_00_10_00>(x, x); // x00 x01
        let hi = _mm_shuffle_ps::<0b00_00_11_01>(x, x); // x10 x11
        let y = lerp(lo, hi, _mm_set1_ps(t[1]));
        let y0 = _mm_cvtss_f32(y);
        let y1 = _mm_cvtss_f32(_mm_shuffle_ps::<0b00_00_00_01>(y, y));
        y0 + (y1 - y0) * t[2]
    }

    /// See [`super::cross_blend`].
    ///
    /// # Safety
    /// Bytes `base − m ..= base + 1 + oy + oz + m` of `s` must be
    /// readable, `m = max(1, oy, oz)`.
    #[inline(always)]
    pub unsafe fn cross_blend(
        s: *const u8,
        base: usize,
        oy: usize,
        oz: usize,
        t: [f32; 3],
    ) -> [f32; 3] {
        let tx = _mm_set1_ps(t[0]);
        // The x lerps of one axis's differences: x00 x10 x01 x11.
        let axis = |o: usize| {
            let (pa, pb) = rows(s, base + o, oy, oz);
            let (ma, mb) = rows(s, base - o, oy, oz);
            lerp(_mm_sub_ps(pa, ma), _mm_sub_ps(pb, mb), tx)
        };
        let (gx, gy, gz) = (axis(1), axis(oy), axis(oz));
        // Transpose to lanes x, y, z (the fourth a copy of z).
        let t0 = _mm_unpacklo_ps(gx, gy); // x00 y00 x10 y10
        let t1 = _mm_unpacklo_ps(gz, gz); // z00 z00 z10 z10
        let t2 = _mm_unpackhi_ps(gx, gy); // x01 y01 x11 y11
        let t3 = _mm_unpackhi_ps(gz, gz); // z01 z01 z11 z11
        let c00 = _mm_movelh_ps(t0, t1);
        let c10 = _mm_movehl_ps(t1, t0);
        let c01 = _mm_movelh_ps(t2, t3);
        let c11 = _mm_movehl_ps(t3, t2);
        let ty = _mm_set1_ps(t[1]);
        let r = lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), _mm_set1_ps(t[2]));
        let mut out = [0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), r);
        [out[0], out[1], out[2]]
    }
}

/// What [`bricked_values8`] needs of a bricked `u8` volume: its brick
/// addressing as 32-bit lane arithmetic. It exists only where the CPU has
/// AVX2 and the volume fits the lanes (power-of-two bricks, every voxel
/// coordinate exact in `f32`, brick numbers and in-brick offsets in
/// `i32`).
#[derive(Clone, Copy, Debug)]
pub struct BrickLanes {
    /// log2 of the owned brick edge.
    shift: i32,
    /// Apron before the owned voxels.
    lo: i32,
    /// Stored brick edge.
    e: i32,
    /// Bricks along x and y.
    nx: i32,
    ny: i32,
    /// Samples from one brick's start to the next's.
    stride: usize,
    /// Samples of one stored brick (`e³`).
    stored: usize,
    /// `dims − 1` per axis (the clamping box).
    hi: [f32; 3],
    /// The dimensions.
    dims: [i32; 3],
    /// Where every brick's offset fits an `i32`: the bytes a volume's
    /// bricks take (lanes then read from each one's own brick, so a run
    /// may cross brick faces).
    flat_end: Option<usize>,
}

impl BrickLanes {
    /// The lanes' view of bricks of owned edge `brick` (stored edge
    /// `stored_edge`, apron `apron_lo` before), `counts` bricks per axis,
    /// `stride` samples apart, in a volume of `dims`; `None` when the CPU
    /// lacks AVX2 or the volume does not fit 32-bit lanes.
    pub fn new(
        dims: [u64; 3],
        brick: u64,
        stored_edge: u64,
        apron_lo: u64,
        counts: [u64; 3],
        stride: usize,
    ) -> Option<BrickLanes> {
        if !avx2_available() || !brick.is_power_of_two() {
            return None;
        }
        let fits = |v: u64| v < (1 << 24);
        let bricks = counts[0].checked_mul(counts[1])?.checked_mul(counts[2])?;
        let stored = stored_edge.checked_pow(3)?;
        if !(dims.iter().all(|&d| d >= 1 && fits(d)) && bricks < (1 << 31) && stored < (1 << 30)) {
            return None;
        }
        // No read leaves its brick's stored samples: a cell's first corner
        // lies at most at owned offset `b − 1` (+ apron 1 = `b`) on each
        // axis (points are clamped to the box), a gathered word reads three
        // more along x, ending at `e = b + 3` of a row, and rows go to at
        // most `b + 2 = e − 1` along y and z (the cross's outer rows), so
        // the last byte read is below `e³`. If the last brick's end fits an
        // i32, so does every offset.
        let flat_end = (bricks - 1)
            .checked_mul(stride as u64)
            .and_then(|b| b.checked_add(stored))
            .filter(|&end| end <= i32::MAX as u64)
            .map(|end| end as usize);
        Some(BrickLanes {
            flat_end,
            shift: brick.trailing_zeros() as i32,
            lo: apron_lo as i32,
            e: stored_edge as i32,
            nx: counts[0] as i32,
            ny: counts[1] as i32,
            stride,
            stored: stored as usize,
            hi: dims.map(|d| (d - 1) as f32),
            dims: dims.map(|d| d as i32),
        })
    }
}

/// What [`sliced_values8`] needs of a sliced `u8` volume (x fastest, or z
/// fastest as the thesis `.vol` stores it): its strides as 32-bit lane
/// arithmetic. It exists only where the CPU has AVX2 and every sample's
/// offset fits an `i32`.
#[derive(Clone, Copy, Debug)]
pub struct SliceLanes {
    /// Whether z is the fastest axis (else x is).
    z_fastest: bool,
    /// Samples between neighbours along x, y and z.
    strides: [i32; 3],
    /// `dims − 1` per axis (the clamping box).
    hi: [f32; 3],
    /// The dimensions.
    dims: [i32; 3],
    /// The samples the lanes were made for.
    len: usize,
    /// The largest first-corner offset whose cell's reads (four bytes
    /// from each row's first corner) stay in the samples.
    cell_limit: i32,
}

impl SliceLanes {
    /// The lanes' view of `len` samples of a `dims` volume whose
    /// neighbours along x, y and z lie `strides` apart; `None` when the CPU
    /// lacks AVX2, neither x nor z is the fastest axis, or the samples do
    /// not fit 32-bit lanes.
    pub fn new(dims: [u64; 3], strides: [u64; 3], len: usize) -> Option<SliceLanes> {
        if !avx2_available() || len > i32::MAX as usize {
            return None;
        }
        let fits = |v: u64| v < (1 << 24);
        if !dims.iter().all(|&d| d >= 2 && fits(d)) || strides.iter().any(|&s| s > len as u64) {
            return None;
        }
        let z_fastest = match strides {
            [1, _, _] => false,
            [_, _, 1] => true,
            _ => return None,
        };
        let [s1, s2] = if z_fastest {
            [strides[0], strides[1]]
        } else {
            [strides[1], strides[2]]
        }
        .map(|s| s as i64);
        // A cell reads up to three bytes past the start of its last row
        // (s1 + s2 on).
        Some(SliceLanes {
            z_fastest,
            strides: strides.map(|s| s as i32),
            hi: dims.map(|d| (d - 1) as f32),
            dims: dims.map(|d| d as i32),
            len,
            cell_limit: (len as i64 - 4 - s1 - s2).max(-1) as i32,
        })
    }
}

/// [`bricked_values8`] for a sliced `u8` volume `s` laid out as `g` says:
/// bit for bit the scalar path's; `None` when `k` is too large for exact
/// f64 lanes, a point's cell lies on a far face (its neighbour would be
/// clamped) or a read would pass the end of `s`.
#[inline]
pub fn sliced_values8(
    s: &[u8],
    g: &SliceLanes,
    o: [f32; 3],
    d: [f32; 3],
    k: i64,
    step: f64,
) -> Option<Samples8> {
    if k.unsigned_abs() >= 1 << 52 {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: a `SliceLanes` exists only where AVX2 was detected; every
        // offset read is checked against the limits made for `s`'s length
        // (and `s` against that length).
        unsafe { avx2::sliced_values8(s, g, o, d, k, step) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (s, g, o, d, step);
        None
    }
}

/// [`bricked_cross8`] for a sliced `u8` volume: the central-difference
/// blends at the samples [`sliced_values8`] reads, for the interior ones;
/// `None` where it declines.
#[inline]
pub fn sliced_cross8(
    s: &[u8],
    g: &SliceLanes,
    o: [f32; 3],
    d: [f32; 3],
    k: i64,
    step: f64,
) -> Option<Cross8> {
    if k.unsigned_abs() >= 1 << 52 {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: as in `sliced_values8`; only interior cells are read, and
        // their crosses lie in `s` (see `avx2::sliced_cross8`).
        unsafe { avx2::sliced_cross8(s, g, o, d, k, step) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (s, g, o, d, step);
        None
    }
}

/// Whether this CPU runs AVX2 (std caches the answer).
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Eight consecutive samples of a ray: their parameters and values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Samples8 {
    /// Ray parameters, `((k + i)·step)` rounded to f32.
    pub t: [f32; 8],
    /// Trilinear values at the points `o + d·t[i]`.
    pub v: [f32; 8],
}

/// The central differences (not halved) blended at eight samples of a ray
/// (see [`bricked_cross8`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cross8 {
    /// Per axis, per sample: the blend of the cell's differences along it.
    pub g: [[f32; 8]; 3],
    /// Bit `i` set: sample `i`'s cell is interior (its cross lies inside
    /// the volume) and `g` holds its blends; the others are not computed.
    pub interior: u8,
}

/// The central-difference blends ([`crate::Cursor::cross_blend`]) at
/// samples `k .. k + 8` of the ray `o + d·t` in a bricked `u8` volume, for
/// the samples whose cells are interior, bit for bit; `None` where
/// [`bricked_values8`] declines.
#[inline]
pub fn bricked_cross8(
    s: &[u8],
    g: &BrickLanes,
    o: [f32; 3],
    d: [f32; 3],
    k: i64,
    step: f64,
) -> Option<Cross8> {
    if k.unsigned_abs() >= 1 << 52 {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: as in `bricked_values8`; only interior cells are read,
        // and their crosses lie in the brick's apron.
        unsafe { avx2::bricked_cross8(s, g, o, d, k, step) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (s, g, o, d, step);
        None
    }
}

/// Samples `k .. k + 8` of the ray `o + d·t` (voxel space, `t = k·step`)
/// in a bricked `u8` volume `s`: each parameter and value bit for bit
/// what the scalar path gives (`(k·step) as f32`; clamp to the box, floor,
/// blend x then y then z); `None` when `k` is too large for exact f64
/// lanes or a brick read lies outside `s`, and in volumes whose brick
/// offsets do not fit 32-bit lanes, also when the points do not all lie
/// in one brick (the caller takes them one by one). (Reading only the lanes in the
/// first point's brick, with a masked gather, and handing over partial
/// runs measured slower: a call per short run costs more than the scalar
/// samples it replaces.)
#[inline]
pub fn bricked_values8(
    s: &[u8],
    g: &BrickLanes,
    o: [f32; 3],
    d: [f32; 3],
    k: i64,
    step: f64,
) -> Option<Samples8> {
    if k.unsigned_abs() >= 1 << 52 {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: a `BrickLanes` exists only where AVX2 was detected; the
        // function checks every read against `s`.
        unsafe { avx2::bricked_values8(s, g, o, d, k, step) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (s, g, o, d, step);
        None
    }
}

/// `a + (b − a)·t` in eight AVX2 lanes: the scalar lerp's operations in
/// its order, so each lane gives the scalar's float. Shared by every
/// blend done in lanes (volume cells here, the renderer's grids).
///
/// # Safety
/// The CPU must have AVX2 (see [`avx2_available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn lerp8(a: __m256, b: __m256, t: __m256) -> __m256 {
    _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), t))
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::lerp8 as lerp;
    use super::*;

    /// One axis of eight points: `o + d·t` clamped to `[0, hi]` (NaN to
    /// 0), its floor and the offset from it, as the scalar locator does.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn axis(o: f32, d: f32, t: __m256, hi: f32) -> (__m256i, __m256) {
        let p = _mm256_add_ps(_mm256_set1_ps(o), _mm256_mul_ps(_mm256_set1_ps(d), t));
        let hi = _mm256_set1_ps(hi);
        let above = _mm256_cmp_ps::<_CMP_GT_OQ>(p, _mm256_setzero_ps());
        let below = _mm256_cmp_ps::<_CMP_LT_OQ>(p, hi);
        let c = _mm256_and_ps(_mm256_blendv_ps(hi, p, below), above);
        let i = _mm256_cvttps_epi32(c);
        (i, _mm256_sub_ps(c, _mm256_cvtepi32_ps(i)))
    }

    /// The two bytes at the start of each gathered word, as f32 lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn pair(w: __m256i) -> (__m256, __m256) {
        let m = _mm256_set1_epi32(0xff);
        (
            _mm256_cvtepi32_ps(_mm256_and_si256(w, m)),
            _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32::<8>(w), m)),
        )
    }

    /// The parameters `(k + i)·step` in f64 (`k + i` exact: `|k| < 2^52`),
    /// rounded to f32, as the scalar path computes them.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn parameters8(k: i64, step: f64) -> __m256 {
        let kf = _mm256_set1_pd(k as f64);
        let st = _mm256_set1_pd(step);
        let lo = _mm256_mul_pd(_mm256_add_pd(kf, _mm256_set_pd(3.0, 2.0, 1.0, 0.0)), st);
        let hi = _mm256_mul_pd(_mm256_add_pd(kf, _mm256_set_pd(7.0, 6.0, 5.0, 4.0)), st);
        _mm256_set_m128(_mm256_cvtpd_ps(hi), _mm256_cvtpd_ps(lo))
    }

    /// Where eight samples of a ray fall in the volume (its bricks, or its
    /// slices).
    struct Where8 {
        /// Ray parameters.
        tv: __m256,
        /// Offsets in the cells.
        f: [__m256; 3],
        /// Cell bases (voxel coordinates).
        i: [__m256i; 3],
        /// Offsets of the cells' first corners from `base`.
        local: __m256i,
        /// The volume's first sample, or the one brick's first sample.
        base: *const i32,
    }

    /// Locate samples `k .. k + 8` of the ray `o + d·t`; `None` when a
    /// brick read would leave `s`, or (volumes whose offsets do not fit
    /// 32-bit lanes) the samples are not all in one brick.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn locate8(
        s: &[u8],
        g: &BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Where8> {
        let tv = parameters8(k, step);
        let (ix, fx) = axis(o[0], d[0], tv, g.hi[0]);
        let (iy, fy) = axis(o[1], d[1], tv, g.hi[1]);
        let (iz, fz) = axis(o[2], d[2], tv, g.hi[2]);
        let sh = _mm_cvtsi32_si128(g.shift);
        let (bx, by, bz) = (
            _mm256_srl_epi32(ix, sh),
            _mm256_srl_epi32(iy, sh),
            _mm256_srl_epi32(iz, sh),
        );
        let brick = _mm256_add_epi32(
            bx,
            _mm256_mullo_epi32(
                _mm256_set1_epi32(g.nx),
                _mm256_add_epi32(by, _mm256_mullo_epi32(_mm256_set1_epi32(g.ny), bz)),
            ),
        );
        let lo = _mm256_set1_epi32(g.lo);
        let local_axis = |i: __m256i, b: __m256i| {
            _mm256_add_epi32(_mm256_sub_epi32(i, _mm256_sll_epi32(b, sh)), lo)
        };
        let (lx, ly, lz) = (local_axis(ix, bx), local_axis(iy, by), local_axis(iz, bz));
        let e = _mm256_set1_epi32(g.e);
        let local = _mm256_add_epi32(
            lx,
            _mm256_mullo_epi32(e, _mm256_add_epi32(ly, _mm256_mullo_epi32(e, lz))),
        );
        let (start, local) = match g.flat_end {
            // Each lane from its own brick: offsets from the volume's start
            // (every brick number is below the count, so no lane reads past
            // the last brick's end).
            Some(end) if end <= s.len() => (
                0,
                _mm256_add_epi32(
                    _mm256_mullo_epi32(brick, _mm256_set1_epi32(g.stride as i32)),
                    local,
                ),
            ),
            _ => {
                let first = _mm_cvtsi128_si32(_mm256_castsi256_si128(brick));
                let same = _mm256_cmpeq_epi32(brick, _mm256_set1_epi32(first));
                if _mm256_movemask_epi8(same) != -1 {
                    return None;
                }
                // Each gather reads four bytes from a row's first corner: at
                // most two past the brick's last stored sample.
                let start = (first as usize).checked_mul(g.stride)?;
                if start.checked_add(g.stored + 2)? > s.len() {
                    return None;
                }
                (start, local)
            }
        };
        Some(Where8 {
            tv,
            f: [fx, fy, fz],
            i: [ix, iy, iz],
            local,
            base: s.as_ptr().add(start).cast::<i32>(),
        })
    }

    /// See [`super::bricked_values8`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn bricked_values8(
        s: &[u8],
        g: &BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Samples8> {
        let w = locate8(s, g, o, d, k, step)?;
        Some(w.samples(values_at::<false>(&w, g.e, g.e * g.e)))
    }

    /// The four bytes from `p − 1` of each gathered word, as f32 lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn quad(w: __m256i) -> [__m256; 4] {
        let m = _mm256_set1_epi32(0xff);
        let byte = |b: __m256i| _mm256_cvtepi32_ps(_mm256_and_si256(b, m));
        [
            byte(w),
            byte(_mm256_srli_epi32::<8>(w)),
            byte(_mm256_srli_epi32::<16>(w)),
            byte(_mm256_srli_epi32::<24>(w)),
        ]
    }

    /// See [`super::bricked_cross8`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn bricked_cross8(
        s: &[u8],
        g: &BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Cross8> {
        let w = locate8(s, g, o, d, k, step)?;
        // Interior cells read their whole cross inside the brick (its
        // apron); the others are left to the caller, and not read.
        let inside = w.interior(g.dims);
        Some(cross8(
            cross_at::<false>(&w, inside, g.e, g.e * g.e),
            inside,
        ))
    }

    impl Where8 {
        /// The run's parameters with values `v`.
        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn samples(&self, v: __m256) -> Samples8 {
            let mut out = Samples8 {
                t: [0.0; 8],
                v: [0.0; 8],
            };
            _mm256_storeu_ps(out.t.as_mut_ptr(), self.tv);
            _mm256_storeu_ps(out.v.as_mut_ptr(), v);
            out
        }

        /// All ones in the lanes whose cells are interior in a volume of
        /// `dims` (1 <= i and i + 2 < dims on every axis: the whole cross
        /// lies inside it).
        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn interior(&self, dims: [i32; 3]) -> __m256i {
            let mut inside = _mm256_set1_epi32(-1);
            for (i, d) in self.i.iter().zip(dims) {
                let ok = _mm256_and_si256(
                    _mm256_cmpgt_epi32(*i, _mm256_setzero_si256()),
                    _mm256_cmpgt_epi32(_mm256_set1_epi32(d - 2), *i),
                );
                inside = _mm256_and_si256(inside, ok);
            }
            inside
        }
    }

    /// Ask the cache for the rows the ray's next run will most likely read,
    /// so that its gathers do not wait on memory (a ray's run waits on its
    /// first row otherwise: the hardware prefetchers do not follow
    /// gathers). The next run's middle and last lanes are extrapolated
    /// from this run's first and last offsets, and the four rows of each
    /// asked for; a guess that crosses a brick's face only fetches a
    /// useless line. Prefetches change no result and never fault; the
    /// addresses are formed with wrapping arithmetic. (Two runs ahead
    /// measured slower than one on the thesis scene.)
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn prefetch_next_run(w: &Where8, s1: i32, s2: i32) {
        let first = _mm256_extract_epi32::<0>(w.local) as isize;
        let last = _mm256_extract_epi32::<7>(w.local) as isize;
        let run = last - first;
        let base = w.base.cast::<i8>();
        for ahead in [last + run / 2, last + run + run / 7] {
            for r in [0, s1 as isize, s2 as isize, (s1 + s2) as isize] {
                _mm_prefetch::<_MM_HINT_T0>(base.wrapping_offset(ahead + r));
            }
        }
    }

    /// The trilinear values at `w`, whose cells' bytes are adjacent along
    /// the fastest axis (x, or z when `Z`) and `s1`, `s2` apart along the
    /// other two (in x, y, z order): four gathered words per lane, one per
    /// row of the cell, blended in the scalar blend's order.
    ///
    /// # Safety
    /// The CPU must have AVX2, and four bytes from each row's first corner
    /// must be readable from `w.base`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn values_at<const Z: bool>(w: &Where8, s1: i32, s2: i32) -> __m256 {
        prefetch_next_run(w, s1, s2);
        let row = |r: i32| {
            let off = _mm256_add_epi32(w.local, _mm256_set1_epi32(r));
            pair(_mm256_i32gather_epi32::<1>(w.base, off))
        };
        let rows = [row(0), row(s1), row(s2), row(s1 + s2)];
        rows_blend::<Z>(rows, w.f)
    }

    /// The central-difference blends (x, y, z; not halved) at `w` for the
    /// lanes set in `inside` (the others read nothing and hold garbage),
    /// laid out as for [`values_at`].
    ///
    /// # Safety
    /// The CPU must have AVX2, and each set lane's cross (one voxel before
    /// its first corner to three bytes past the last, rows `s1`, `s2`
    /// apart) must be readable from `w.base`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cross_at<const Z: bool>(
        w: &Where8,
        inside: __m256i,
        s1: i32,
        s2: i32,
    ) -> [__m256; 3] {
        let zero = _mm256_setzero_si256();
        // A macro, not a closure: LLVM left the closure out of line in
        // some builds (3% more instructions per shaded DVR frame).
        macro_rules! at {
            ($off:expr) => {
                _mm256_mask_i32gather_epi32::<1>(
                    zero,
                    w.base,
                    _mm256_add_epi32(w.local, _mm256_set1_epi32($off)),
                    inside,
                )
            };
        }
        // Rows (d1, d2) in the order d1 + 2·d2 (d1 along the first of the
        // two slower axes); each read from one voxel before its first
        // corner.
        let rows = [0, s1, s2, s1 + s2];
        let wide = rows.map(|r| quad(at!(r - 1)));
        macro_rules! two {
            ($off:expr) => {
                pair(at!($off))
            };
        }
        // Fastest axis: the differences of each row's two corners' outer
        // neighbours.
        let fast = wide.map(|q| (_mm256_sub_ps(q[2], q[0]), _mm256_sub_ps(q[3], q[1])));
        // The slower axes: each row's neighbours one before and one after
        // along the axis (rows of the cell where they are rows of the
        // cell).
        let cell = |r: usize| (wide[r][1], wide[r][2]);
        let diff = |p: (__m256, __m256), m: (__m256, __m256)| {
            (_mm256_sub_ps(p.0, m.0), _mm256_sub_ps(p.1, m.1))
        };
        let first = [
            diff(cell(1), two!(-s1)),
            diff(two!(2 * s1), cell(0)),
            diff(cell(3), two!(s2 - s1)),
            diff(two!(2 * s1 + s2), cell(2)),
        ];
        let second = [
            diff(cell(2), two!(-s2)),
            diff(cell(3), two!(s1 - s2)),
            diff(two!(2 * s2), cell(0)),
            diff(two!(s1 + 2 * s2), cell(1)),
        ];
        let blend = |r| rows_blend::<Z>(r, w.f);
        if Z {
            // z fastest; the slower axes are x, then y.
            [blend(first), blend(second), blend(fast)]
        } else {
            [blend(fast), blend(first), blend(second)]
        }
    }

    /// A run's blends `g` for its `inside` lanes, as a [`Cross8`].
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cross8(g: [__m256; 3], inside: __m256i) -> Cross8 {
        let mut out = Cross8 {
            g: [[0.0; 8]; 3],
            interior: _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u8,
        };
        for (o, g) in out.g.iter_mut().zip(g) {
            _mm256_storeu_ps(o.as_mut_ptr(), g);
        }
        out
    }

    /// The blend of four rows' corner pairs (corner, next corner along the
    /// fastest axis) in the scalar blend's order: along x, then y, then z.
    /// Rows come in the order `d1 + 2·d2` of the two slower axes: (y, z)
    /// for x fastest; (x, y) when `Z` (z fastest), whose pairs run along
    /// z, so the x lerps pair rows instead.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn rows_blend<const Z: bool>(r: [(__m256, __m256); 4], f: [__m256; 3]) -> __m256 {
        let [fx, fy, fz] = f;
        let x = if Z {
            // Corner (dx, dy, dz) is row dx + 2·dy, pair member dz.
            [
                lerp(r[0].0, r[1].0, fx),
                lerp(r[2].0, r[3].0, fx),
                lerp(r[0].1, r[1].1, fx),
                lerp(r[2].1, r[3].1, fx),
            ]
        } else {
            r.map(|(a, b)| lerp(a, b, fx))
        };
        lerp(lerp(x[0], x[1], fy), lerp(x[2], x[3], fy), fz)
    }

    /// Locate samples `k .. k + 8` of the ray `o + d·t` in a sliced
    /// volume; `None` when a cell lies on a far face (its next corner
    /// would be clamped) or its reads would pass the end of `s`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn locate_sliced8(
        s: &[u8],
        g: &SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Where8> {
        let tv = parameters8(k, step);
        let (ix, fx) = axis(o[0], d[0], tv, g.hi[0]);
        let (iy, fy) = axis(o[1], d[1], tv, g.hi[1]);
        let (iz, fz) = axis(o[2], d[2], tv, g.hi[2]);
        let i = [ix, iy, iz];
        let mut past = _mm256_setzero_si256();
        for (i, d) in i.iter().zip(g.dims) {
            past = _mm256_or_si256(past, _mm256_cmpgt_epi32(*i, _mm256_set1_epi32(d - 2)));
        }
        let st = g.strides;
        let local = _mm256_add_epi32(
            _mm256_mullo_epi32(ix, _mm256_set1_epi32(st[0])),
            _mm256_add_epi32(
                _mm256_mullo_epi32(iy, _mm256_set1_epi32(st[1])),
                _mm256_mullo_epi32(iz, _mm256_set1_epi32(st[2])),
            ),
        );
        past = _mm256_or_si256(
            past,
            _mm256_cmpgt_epi32(local, _mm256_set1_epi32(g.cell_limit)),
        );
        if g.len != s.len() || _mm256_movemask_epi8(past) != 0 {
            return None;
        }
        Some(Where8 {
            tv,
            f: [fx, fy, fz],
            i,
            local,
            base: s.as_ptr().cast::<i32>(),
        })
    }

    /// See [`super::sliced_values8`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn sliced_values8(
        s: &[u8],
        g: &SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Samples8> {
        let w = locate_sliced8(s, g, o, d, k, step)?;
        let v = if g.z_fastest {
            values_at::<true>(&w, g.strides[0], g.strides[1])
        } else {
            values_at::<false>(&w, g.strides[1], g.strides[2])
        };
        Some(w.samples(v))
    }

    /// See [`super::sliced_cross8`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub unsafe fn sliced_cross8(
        s: &[u8],
        g: &SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<Cross8> {
        let w = locate_sliced8(s, g, o, d, k, step)?;
        // Only interior cells are read. Their crosses stay in the samples:
        // the lowest read is one row (or byte) before a corner whose
        // coordinate on that axis is at least 1; the highest, three bytes
        // past a row start at most two rows on along one slower axis and
        // one along the other, whose coordinates stay two and one below
        // that axis's far face, so at least one whole row of samples
        // follows.
        let inside = w.interior(g.dims);
        let gr = if g.z_fastest {
            cross_at::<true>(&w, inside, g.strides[0], g.strides[1])
        } else {
            cross_at::<false>(&w, inside, g.strides[1], g.strides[2])
        };
        Some(cross8(gr, inside))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::blend;

    fn scalar_cell(s: &[u8], b: usize, oy: usize, oz: usize) -> [f32; 8] {
        [0, 1, oy, 1 + oy, oz, 1 + oz, oy + oz, 1 + oy + oz].map(|o| f32::from(s[b + o]))
    }

    /// Every lane result equals the scalar blend bit for bit, over random
    /// bytes (with the extremes 0 and 255 frequent), random offsets
    /// (including 0 and just below 1) and brick-like and slice-like
    /// strides (oy, oz of 0 at clamped faces too).
    #[test]
    fn lanes_blend_as_the_scalar_blend_does() {
        let mut rng = fastrand::Rng::with_seed(11);
        for &(oy, oz) in &[(35, 35 * 35), (7, 7 * 9), (0, 12), (5, 0), (0, 0), (1, 2)] {
            let s: Vec<u8> = (0..4000)
                .map(|_| match rng.u8(0..8) {
                    0 => 0,
                    1 => 255,
                    _ => rng.u8(..),
                })
                .collect();
            for _ in 0..3000 {
                let m = oy.max(oz).max(1);
                let b = rng.usize(m..s.len() - 2 - oy - oz - m);
                let pick = |r: &mut fastrand::Rng| match r.u8(0..6) {
                    0 => 0.0,
                    1 => 1.0 - f32::EPSILON / 2.0,
                    _ => r.f32(),
                };
                let t = [pick(&mut rng), pick(&mut rng), pick(&mut rng)];
                let want = blend(&scalar_cell(&s, b, oy, oz), t);
                let got = cell_blend(&s, b, oy, oz, t).unwrap();
                assert_eq!(got.to_bits(), want.to_bits(), "cell at {b}, t {t:?}");
                let diff = |o: usize| {
                    let hi = scalar_cell(&s, b + o, oy, oz);
                    let lo = scalar_cell(&s, b - o, oy, oz);
                    blend(&std::array::from_fn(|c| hi[c] - lo[c]), t)
                };
                let want = [diff(1), diff(oy), diff(oz)];
                let got = cross_blend(&s, b, oy, oz, t).unwrap();
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "cross at {b}"
                );
            }
        }
    }

    /// Cells or crosses reaching past either end of the samples are
    /// refused, not read.
    #[test]
    fn out_of_range_cells_are_refused() {
        let s = [7u8; 100];
        assert!(cell_blend(&s, 100 - 2 - 10 - 20, 10, 20, [0.5; 3]).is_some());
        assert!(cell_blend(&s, 100 - 1 - 10 - 20, 10, 20, [0.5; 3]).is_none());
        assert!(cell_blend(&s, usize::MAX - 3, 1, 1, [0.5; 3]).is_none());
        assert!(cross_blend(&s, 20, 10, 20, [0.5; 3]).is_some());
        assert!(cross_blend(&s, 19, 10, 20, [0.5; 3]).is_none());
        assert!(cross_blend(&s, 100 - 2 - 30 - 20, 10, 20, [0.5; 3]).is_some());
        assert!(cross_blend(&s, 100 - 1 - 30 - 20, 10, 20, [0.5; 3]).is_none());
        assert!(cross_blend(&s, 0, 0, 0, [0.5; 3]).is_none());
    }
}
