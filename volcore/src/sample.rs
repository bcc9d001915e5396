//! Sample types and their conversions.

use std::fmt;
use std::str::FromStr;

/// The type of one stored sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SampleType {
    /// Unsigned 8-bit integer.
    U8,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 16-bit integer (CT Hounsfield units).
    I16,
    /// 32-bit IEEE float.
    F32,
    /// 64-bit IEEE float: a storage type (files and conversions keep it
    /// exactly); volumes opened for rendering hold it as `f32`, converted
    /// once (see [`crate::meta::Narrowing`]).
    F64,
}

impl SampleType {
    /// Every supported type, in code order.
    pub const ALL: [SampleType; 5] = [
        SampleType::U8,
        SampleType::U16,
        SampleType::I16,
        SampleType::F32,
        SampleType::F64,
    ];

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            SampleType::U8 => 1,
            SampleType::U16 | SampleType::I16 => 2,
            SampleType::F32 => 4,
            SampleType::F64 => 8,
        }
    }

    /// Short lowercase name used on command lines and in JSON (`u8`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SampleType::U8 => "u8",
            SampleType::U16 => "u16",
            SampleType::I16 => "i16",
            SampleType::F32 => "f32",
            SampleType::F64 => "f64",
        }
    }

    /// The long name (`uint8`, `uint16`, `int16`, `float32`, `float64`):
    /// numpy's dtype name, and the type in Open SciVis raw file names.
    pub fn long_name(self) -> &'static str {
        match self {
            SampleType::U8 => "uint8",
            SampleType::U16 => "uint16",
            SampleType::I16 => "int16",
            SampleType::F32 => "float32",
            SampleType::F64 => "float64",
        }
    }

    /// Numeric code stored in file headers.
    pub fn code(self) -> u8 {
        match self {
            SampleType::U8 => 1,
            SampleType::U16 => 2,
            SampleType::I16 => 3,
            SampleType::F32 => 4,
            SampleType::F64 => 5,
        }
    }

    /// Inverse of [`SampleType::code`].
    pub fn from_code(code: u8) -> Option<SampleType> {
        SampleType::ALL.into_iter().find(|t| t.code() == code)
    }

    /// The range a type can represent, or `None` for floats.
    pub fn integer_range(self) -> Option<(f64, f64)> {
        match self {
            SampleType::U8 => Some((0.0, 255.0)),
            SampleType::U16 => Some((0.0, 65535.0)),
            SampleType::I16 => Some((-32768.0, 32767.0)),
            SampleType::F32 | SampleType::F64 => None,
        }
    }
}

impl fmt::Display for SampleType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SampleType {
    type Err = String;
    /// Accepts `u8 u16 i16 f32 f64` and the Open SciVis spellings
    /// `uint8 uint16 int16 float32 float64` (and `float`, `double`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "u8" | "uint8" => Ok(SampleType::U8),
            "u16" | "uint16" => Ok(SampleType::U16),
            "i16" | "int16" => Ok(SampleType::I16),
            "f32" | "float32" | "float" => Ok(SampleType::F32),
            "f64" | "float64" | "double" => Ok(SampleType::F64),
            other => Err(format!(
                "unknown sample type '{}' (expected u8, u16, i16, f32 or f64)",
                crate::text::excerpt(other)
            )),
        }
    }
}

/// A stored sample: plain old data with a widening to `f32` (exact for
/// every type the renderer reads; `f64`, a storage type only, rounds to
/// nearest) and a defined narrowing.
pub trait Sample:
    bytemuck::Pod + Copy + Default + Send + Sync + PartialEq + fmt::Debug + 'static
{
    /// The matching runtime tag.
    const TYPE: SampleType;
    /// Whether [`Sample::bricked_values8`] has a batched path (it declines
    /// every call otherwise).
    const BATCHES: bool = false;
    /// Widening conversion (exact but for `f64`, which rounds to nearest).
    fn to_f32(self) -> f32;
    /// `hi.to_f32() − lo.to_f32()`, bit for bit; integer types subtract
    /// before converting (exact: every difference fits `f32`'s 24 bits),
    /// which halves the conversions of a central-difference gradient.
    #[inline(always)]
    fn diff_f32(hi: Self, lo: Self) -> f32 {
        hi.to_f32() - lo.to_f32()
    }
    /// Narrowing from `f32`: round half away from zero, clamp to the type's
    /// range; NaN becomes 0 for integer types and stays NaN for `f32`.
    fn from_f32(v: f32) -> Self;
    /// Narrowing from `f64`: through `f32` ([`Sample::from_f32`] of the
    /// value rounded to `f32`) for every type but `f64`, which keeps it.
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        Self::from_f32(v as f32)
    }
    /// The trilinear value at offsets `t` of the cell whose first corner
    /// is `s[base]`, corners `o` samples apart per axis (all in `s`):
    /// [`crate::grid::blend`] of its corners, bit for bit.
    #[inline(always)]
    fn cell_blend(s: &[Self], base: usize, o: [usize; 3], t: [f32; 3]) -> f32 {
        crate::grid::blend_cell_from(s, base, o, t)
    }
    /// The blends at offsets `t` of the central differences around the
    /// cell at `s[base]` (not halved; neighbours `o` apart, the whole cross
    /// in `s`): [`crate::grid::blend`] of each axis's differences, bit for
    /// bit.
    #[inline(always)]
    fn cross_blend(s: &[Self], base: usize, o: [usize; 3], t: [f32; 3]) -> [f32; 3] {
        crate::grid::blend_cross_from(s, base, o, t)
    }
    /// Eight samples of the ray `o + d·t` at `t = (k + i)·step` and their
    /// trilinear values in bricks `s` laid out as `g` says, bit for bit
    /// the scalar path's (see [`crate::Cursor::trilinear8`]); `None` (the
    /// default) where the type has no batched path or the points straddle
    /// bricks.
    #[inline(always)]
    fn bricked_values8(
        s: &[Self],
        g: &crate::lanes::BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Samples8> {
        let _ = (s, g, o, d, k, step);
        None
    }
    /// The central-difference blends at the eight samples
    /// [`Sample::bricked_values8`] reads, for the interior ones (see
    /// [`crate::lanes::Cross8`]); `None` (the default) where it declines.
    #[inline(always)]
    fn bricked_cross8(
        s: &[Self],
        g: &crate::lanes::BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Cross8> {
        let _ = (s, g, o, d, k, step);
        None
    }
    /// [`Sample::bricked_values8`] for sliced samples `s` laid out as `g`
    /// says; `None` (the default) where the type has no batched path or
    /// the run declines.
    #[inline(always)]
    fn sliced_values8(
        s: &[Self],
        g: &crate::lanes::SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Samples8> {
        let _ = (s, g, o, d, k, step);
        None
    }
    /// [`Sample::bricked_cross8`] for sliced samples; `None` (the default)
    /// where it declines.
    #[inline(always)]
    fn sliced_cross8(
        s: &[Self],
        g: &crate::lanes::SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Cross8> {
        let _ = (s, g, o, d, k, step);
        None
    }
    /// Whether this sample is NaN (always false for integers).
    fn is_nan(self) -> bool {
        false
    }
    /// Convert a little-endian byte slice in place to native order.
    fn slice_from_le(data: &mut [Self]);
    /// Smallest and largest non-NaN sample of a slice, exactly
    /// (`(inf, -inf)` when there is none).
    fn min_max(data: &[Self]) -> (f64, f64);
}

macro_rules! int_sample {
    ($t:ty, $tag:expr $(, $extra:item)*) => {
        impl Sample for $t {
            const TYPE: SampleType = $tag;
            $($extra)*
            #[inline(always)]
            fn to_f32(self) -> f32 {
                self as f32
            }
            #[inline(always)]
            fn diff_f32(hi: Self, lo: Self) -> f32 {
                (hi as i32 - lo as i32) as f32
            }
            #[inline(always)]
            fn from_f32(v: f32) -> Self {
                // Round half away from zero by truncating v ± 0.5, exact in
                // f64 (a libm `round` call costs ~25 instructions per sample
                // on baseline x86-64). `as` saturates and maps NaN to 0,
                // which is the documented rule.
                let w = v as f64;
                (if w >= 0.0 { w + 0.5 } else { w - 0.5 }) as $t
            }
            fn slice_from_le(data: &mut [Self]) {
                for v in data {
                    *v = <$t>::from_le(*v);
                }
            }
            fn min_max(data: &[Self]) -> (f64, f64) {
                if data.is_empty() {
                    return (f64::INFINITY, f64::NEG_INFINITY);
                }
                // Integer min/max in the native type vectorises well.
                let lo = data.iter().copied().fold(<$t>::MAX, <$t>::min);
                let hi = data.iter().copied().fold(<$t>::MIN, <$t>::max);
                (lo as f64, hi as f64)
            }
        }
    };
}

int_sample!(
    u8,
    SampleType::U8,
    // Bytes along x are adjacent in bricks and x-fastest slices: blend in
    // SSE2 lanes there (the same bits; see `crate::lanes`).
    #[inline(always)]
    fn cell_blend(s: &[u8], base: usize, o: [usize; 3], t: [f32; 3]) -> f32 {
        let lanes = if o[0] == 1 {
            crate::lanes::cell_blend(s, base, o[1], o[2], t)
        } else {
            None
        };
        lanes.unwrap_or_else(|| crate::grid::blend_cell_from(s, base, o, t))
    },
    #[inline(always)]
    fn cross_blend(s: &[u8], base: usize, o: [usize; 3], t: [f32; 3]) -> [f32; 3] {
        let lanes = if o[0] == 1 {
            crate::lanes::cross_blend(s, base, o[1], o[2], t)
        } else {
            None
        };
        lanes.unwrap_or_else(|| crate::grid::blend_cross_from(s, base, o, t))
    },
    // Eight points at once in AVX2 lanes, where the CPU has them.
    const BATCHES: bool = true;,
    #[inline(always)]
    fn bricked_values8(
        s: &[u8],
        g: &crate::lanes::BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Samples8> {
        crate::lanes::bricked_values8(s, g, o, d, k, step)
    },
    #[inline(always)]
    fn bricked_cross8(
        s: &[u8],
        g: &crate::lanes::BrickLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Cross8> {
        crate::lanes::bricked_cross8(s, g, o, d, k, step)
    },
    #[inline(always)]
    fn sliced_values8(
        s: &[u8],
        g: &crate::lanes::SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Samples8> {
        crate::lanes::sliced_values8(s, g, o, d, k, step)
    },
    #[inline(always)]
    fn sliced_cross8(
        s: &[u8],
        g: &crate::lanes::SliceLanes,
        o: [f32; 3],
        d: [f32; 3],
        k: i64,
        step: f64,
    ) -> Option<crate::lanes::Cross8> {
        crate::lanes::sliced_cross8(s, g, o, d, k, step)
    }
);
int_sample!(u16, SampleType::U16);
int_sample!(i16, SampleType::I16);

impl Sample for f32 {
    const TYPE: SampleType = SampleType::F32;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v
    }
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
    fn slice_from_le(data: &mut [Self]) {
        for v in data {
            *v = f32::from_bits(u32::from_le(v.to_bits()));
        }
    }
    fn min_max(data: &[Self]) -> (f64, f64) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for &f in data {
            // NaN compares false both ways and is skipped.
            lo = if f < lo { f } else { lo };
            hi = if f > hi { f } else { hi };
        }
        (lo as f64, hi as f64)
    }
}

/// `f64` is a storage type: files and conversions hold it; the renderer's
/// loops never see it (volumes opened for rendering are narrowed to `f32`
/// once, see [`crate::meta::Narrowing`]), so it costs no copy of them.
impl Sample for f64 {
    const TYPE: SampleType = SampleType::F64;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v as f64
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
    fn slice_from_le(data: &mut [Self]) {
        for v in data {
            *v = f64::from_bits(u64::from_le(v.to_bits()));
        }
    }
    fn min_max(data: &[Self]) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for &f in data {
            lo = if f < lo { f } else { lo };
            hi = if f > hi { f } else { hi };
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integer differences converted once equal the difference of the
    /// converted samples, bit for bit, at the types' extremes too.
    #[test]
    fn differences_match_converted_differences() {
        fn check<T: Sample>(values: &[T]) {
            for &a in values {
                for &b in values {
                    let want = a.to_f32() - b.to_f32();
                    assert_eq!(T::diff_f32(a, b).to_bits(), want.to_bits(), "{a:?} - {b:?}");
                }
            }
        }
        check::<u8>(&[0, 1, 127, 128, 254, 255]);
        check::<u16>(&[0, 1, 255, 32768, 65534, 65535]);
        check::<i16>(&[i16::MIN, -32767, -1, 0, 1, 32766, i16::MAX]);
        check::<f32>(&[0.0, -0.0, 1.5, -3.25, 1e30, -1e-30]);
    }

    #[test]
    fn narrowing_rounds_clamps_and_maps_nan() {
        assert_eq!(u8::from_f32(2.5), 3);
        assert_eq!(u8::from_f32(2.4999998), 2);
        assert_eq!(u8::from_f32(0.49999997), 0);
        assert_eq!(i16::from_f32(-2.5), -3);
        assert_eq!(i16::from_f32(-2.4999998), -2);
        assert_eq!(u8::from_f32(-4.0), 0);
        assert_eq!(u8::from_f32(300.0), 255);
        assert_eq!(u8::from_f32(f32::NAN), 0);
        assert_eq!(i16::from_f32(-40000.0), -32768);
        assert_eq!(u16::from_f32(65535.4), 65535);
        assert!(f32::from_f32(f32::NAN).is_nan());
    }

    #[test]
    fn names_parse_back() {
        for t in SampleType::ALL {
            assert_eq!(t.name().parse::<SampleType>().unwrap(), t);
            assert_eq!(SampleType::from_code(t.code()), Some(t));
        }
        assert_eq!("uint16".parse::<SampleType>().unwrap(), SampleType::U16);
        assert!("u32".parse::<SampleType>().is_err());
    }
}
