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
