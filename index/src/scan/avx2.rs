//! The box fold (see `scan::fold_box`) written with AVX2 intrinsics: the
//! compiler keeps the portable version's bound arrays partly on the stack,
//! these stay in registers, and each row of a chunk column costs one load
//! and two min/max instructions.
//!
//! Every operation gives, lane by lane, the same result as the portable
//! [`ScanSample::lower`] and [`ScanSample::upper`] (NaN samples skipped,
//! which of two equal zeros is kept included), so both builds give the same
//! index bits; the tests compare them.

use super::{count_column, fold_box_rest, Bounds, BoxTargets, ExactCounts, RowBox, Run};
use super::{Avx2, ScanSample};
use std::arch::x86_64::*;

/// A sample type whose bounds fold on 256-bit registers (32 bytes of
/// samples at a time).
pub(crate) trait Lanes: ScanSample {
    /// Lane-wise [`ScanSample::lower`]`(acc, v)`.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    unsafe fn lower_lanes(acc: __m256i, v: __m256i) -> __m256i;
    /// Lane-wise [`ScanSample::upper`]`(acc, v)`.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    unsafe fn upper_lanes(acc: __m256i, v: __m256i) -> __m256i;
    /// [`ScanSample::TOP`] in every lane.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    unsafe fn top_lanes() -> __m256i;
    /// [`ScanSample::BOTTOM`] in every lane.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    unsafe fn bottom_lanes() -> __m256i;
    /// Whether every lane of `lo` and `hi` holds lane 0 of `lo`.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    unsafe fn one_value(lo: __m256i, hi: __m256i) -> bool;
}

macro_rules! int_lanes {
    ($t:ty, $min:ident, $max:ident, $set1:ident, $spread:ident, $eq:ident, $as:ty) => {
        impl Lanes for $t {
            #[inline]
            #[target_feature(enable = "avx2")]
            unsafe fn lower_lanes(acc: __m256i, v: __m256i) -> __m256i {
                $min(acc, v)
            }
            #[inline]
            #[target_feature(enable = "avx2")]
            unsafe fn upper_lanes(acc: __m256i, v: __m256i) -> __m256i {
                $max(acc, v)
            }
            #[inline]
            #[target_feature(enable = "avx2")]
            unsafe fn top_lanes() -> __m256i {
                $set1(<$t>::MAX as $as)
            }
            #[inline]
            #[target_feature(enable = "avx2")]
            unsafe fn bottom_lanes() -> __m256i {
                $set1(<$t>::MIN as $as)
            }
            #[inline]
            #[target_feature(enable = "avx2")]
            unsafe fn one_value(lo: __m256i, hi: __m256i) -> bool {
                let first = $spread(_mm256_castsi256_si128(lo));
                let same = _mm256_and_si256($eq(lo, first), $eq(hi, first));
                _mm256_movemask_epi8(same) == -1
            }
        }
    };
}

int_lanes!(
    u8,
    _mm256_min_epu8,
    _mm256_max_epu8,
    _mm256_set1_epi8,
    _mm256_broadcastb_epi8,
    _mm256_cmpeq_epi8,
    i8
);
int_lanes!(
    u16,
    _mm256_min_epu16,
    _mm256_max_epu16,
    _mm256_set1_epi16,
    _mm256_broadcastw_epi16,
    _mm256_cmpeq_epi16,
    i16
);
int_lanes!(
    i16,
    _mm256_min_epi16,
    _mm256_max_epi16,
    _mm256_set1_epi16,
    _mm256_broadcastw_epi16,
    _mm256_cmpeq_epi16,
    i16
);

impl Lanes for f32 {
    // `minps(a, b)` is `a < b ? a : b`: with the sample first, a NaN
    // sample or an equal one keeps the accumulator, as `f32::lower` does.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn lower_lanes(acc: __m256i, v: __m256i) -> __m256i {
        let m = _mm256_min_ps(_mm256_castsi256_ps(v), _mm256_castsi256_ps(acc));
        _mm256_castps_si256(m)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn upper_lanes(acc: __m256i, v: __m256i) -> __m256i {
        let m = _mm256_max_ps(_mm256_castsi256_ps(v), _mm256_castsi256_ps(acc));
        _mm256_castps_si256(m)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn top_lanes() -> __m256i {
        _mm256_castps_si256(_mm256_set1_ps(f32::INFINITY))
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn bottom_lanes() -> __m256i {
        _mm256_castps_si256(_mm256_set1_ps(f32::NEG_INFINITY))
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn one_value(lo: __m256i, hi: __m256i) -> bool {
        // Bitwise: floats are never counted per value, so this only has
        // to be exact, not to treat equal zeros alike.
        let first = _mm256_broadcastd_epi32(_mm256_castsi256_si128(lo));
        let same = _mm256_and_si256(_mm256_cmpeq_epi32(lo, first), _mm256_cmpeq_epi32(hi, first));
        _mm256_movemask_epi8(same) == -1
    }
}

/// Load 32 bytes of samples from `p`.
///
/// # Safety
/// The CPU must support AVX2 and `p` must point at 32 readable bytes.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load<T>(p: *const T) -> __m256i {
    _mm256_loadu_si256(p.cast())
}

/// Widen columns `x .. x + L` of `acc` (`L` samples: 32 bytes) by `lo`
/// and `hi`.
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn widen<T: Lanes, const L: usize>(
    acc: &mut Bounds<'_, T>,
    x: usize,
    lo: __m256i,
    hi: __m256i,
) {
    const { assert!(L * std::mem::size_of::<T>() == 32) };
    let (l, h) = (&mut acc.lo[x..x + L], &mut acc.hi[x..x + L]);
    let (l, h) = (
        l.as_mut_ptr().cast::<__m256i>(),
        h.as_mut_ptr().cast::<__m256i>(),
    );
    // SAFETY: each slice is L samples, 32 bytes, and borrowed mutably.
    unsafe {
        _mm256_storeu_si256(l, T::lower_lanes(_mm256_loadu_si256(l), lo));
        _mm256_storeu_si256(h, T::upper_lanes(_mm256_loadu_si256(h), hi));
    }
}

/// `scan::fold_box` on AVX2 registers, `L` samples (32 bytes) per chunk;
/// the same bits.
///
/// # Safety
/// `_cpu` proves the CPU supports AVX2; nothing else is required.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn fold_box<T: Lanes, const L: usize>(
    _cpu: Avx2,
    mut t: BoxTargets<'_, T>,
    b: RowBox<'_, T>,
    counts: Option<&mut ExactCounts>,
) {
    const { assert!(L * std::mem::size_of::<T>() == 32) };
    let w = t.width();
    let mut counts = counts.filter(|_| T::EXACT_VALUES > 0);
    let mut run = Run::<T, L>::new();
    let (stride, plane, rows) = (b.stride, b.plane, b.rows);
    // Every chunk read below starts at row (z, r) of the box plus x, with
    // x + L <= w, and so ends inside `data` (one bounds check here).
    let data = &b.data[..b.at(b.slices - 1, rows - 1) + w];
    let p = data.as_ptr();
    let mut x = 0;
    while x + L <= w {
        // SAFETY: the CPU supports AVX2 (`_cpu`); every offset passed to
        // `load` is a row start of the box plus x, in `data` (see above).
        unsafe {
            let (top, bottom) = (T::top_lanes(), T::bottom_lanes());
            // The first row of the first slice, the rest of the first
            // slice, the first rows of the other slices, and the rest.
            let s = load(p.add(x));
            let (corner_lo, corner_hi) = (T::lower_lanes(top, s), T::upper_lanes(bottom, s));
            let (mut slice_lo, mut slice_hi) = (corner_lo, corner_hi);
            let mut o = x;
            for _ in 1..rows {
                o += stride;
                let s = load(p.add(o));
                (slice_lo, slice_hi) = (T::lower_lanes(slice_lo, s), T::upper_lanes(slice_hi, s));
            }
            let (mut row_lo, mut row_hi) = (corner_lo, corner_hi);
            let (mut lo, mut hi) = (top, bottom);
            for z in 1..b.slices {
                let mut o = z * plane + x;
                let s = load(p.add(o));
                (row_lo, row_hi) = (T::lower_lanes(row_lo, s), T::upper_lanes(row_hi, s));
                for _ in 1..rows {
                    o += stride;
                    let s = load(p.add(o));
                    (lo, hi) = (T::lower_lanes(lo, s), T::upper_lanes(hi, s));
                }
            }
            lo = T::lower_lanes(T::lower_lanes(lo, slice_lo), row_lo);
            hi = T::upper_lanes(T::upper_lanes(hi, slice_hi), row_hi);
            widen::<T, L>(&mut t.cell, x, lo, hi);
            if let Some(a) = t.row_apron.as_mut() {
                widen::<T, L>(a, x, row_lo, row_hi);
            }
            if let Some(a) = t.slice_apron.as_mut() {
                widen::<T, L>(a, x, slice_lo, slice_hi);
            }
            if let Some(a) = t.corner.as_mut() {
                widen::<T, L>(a, x, corner_lo, corner_hi);
            }
            if let Some(c) = counts.as_deref_mut() {
                count_column(c, &mut run, b, x, T::one_value(lo, hi));
            }
        }
        x += L;
    }
    fold_box_rest(t, b, x, counts, run);
}
