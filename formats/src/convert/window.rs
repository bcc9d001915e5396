//! Sample type conversion with explicit windowing.
//!
//! Rules (also in `vol-convert --help`):
//! - Without a window, only exact conversions are allowed: the same type,
//!   or a widening one (`u8` to anything; `u16` or `i16` to `f32`). Every
//!   other conversion narrows and is an error unless a window is given.
//! - `--window lo:hi` maps `lo` to the bottom and `hi` to the top of the
//!   output type (0..255, 0..65535, -32768..32767, or 0..1 for `f32`)
//!   linearly; values outside `[lo, hi]` clamp. `lo` must be below `hi`.
//! - `--window auto[:P]` takes `lo` and `hi` from the P-th and (100−P)-th
//!   percentiles of the input histogram (P = 0.5 by default); NaN samples
//!   are left out of the histogram.
//! - `--window full` maps the input type's whole range (for `f32` input,
//!   the volume's actual min..max) onto the output range.
//! - Float to integer rounds half away from zero after the linear map.
//! - NaN maps to the bottom of the output range for integer outputs (0 for
//!   `u8`/`u16`, -32768 for `i16`) and stays NaN for float outputs.
//! - Integer inputs volkit does not store (`i8`, `u32`, `i32`) convert
//!   without a window when every value of the data fits the output type
//!   exactly (within its range; to `f32` up to 2^24). Without `--type`
//!   they become the smallest stored type that holds them ([`fit_type`]).
//! - `f64` is stored as it is; to `f32` (asked for, or for an output that
//!   holds no `f64`) it rounds each value to the nearest `f32` without a
//!   window, and the conversion says how far the values moved.

use crate::error::{Error, Result};
use crate::slice::{SliceData, SliceType};
use std::str::FromStr;
use volcore::{Sample, SampleType};

/// How to choose the value window of a type conversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// Map `[lo, hi]` onto the output range.
    Range(f64, f64),
    /// From the histogram: the given tail percentile on each side.
    Auto(f64),
    /// The input type's whole range (the data range for `f32` input).
    Full,
}

/// Default tail percentile of `--window auto`.
pub const AUTO_TAIL_PERCENT: f64 = 0.5;

impl FromStr for Window {
    type Err = String;
    /// `lo:hi`, `auto`, `auto:P` or `full`.
    fn from_str(s: &str) -> Result<Window, String> {
        match s {
            "full" => return Ok(Window::Full),
            "auto" => return Ok(Window::Auto(AUTO_TAIL_PERCENT)),
            _ => {}
        }
        if let Some(p) = s.strip_prefix("auto:") {
            let p: f64 = p
                .parse()
                .map_err(|_| format!("'{s}': auto percentile must be a number"))?;
            if !(0.0..50.0).contains(&p) {
                return Err(format!("'{s}': auto percentile must be in 0..50"));
            }
            return Ok(Window::Auto(p));
        }
        let (lo, hi) = s
            .split_once(':')
            .ok_or_else(|| format!("'{s}' is not lo:hi, auto or full"))?;
        let lo: f64 = lo
            .trim()
            .parse()
            .map_err(|_| format!("'{s}': '{lo}' is not a number"))?;
        let hi: f64 = hi
            .trim()
            .parse()
            .map_err(|_| format!("'{s}': '{hi}' is not a number"))?;
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(format!("'{s}': window bounds must be finite"));
        }
        if lo == hi {
            return Err(format!("'{s}': window is empty (lo == hi)"));
        }
        if lo > hi {
            return Err(format!("'{s}': window lo must be below hi"));
        }
        Ok(Window::Range(lo, hi))
    }
}

/// Whether every value of `from` is exactly representable in `to`.
pub fn is_exact(from: SliceType, to: SampleType) -> bool {
    use SampleType as S;
    use SliceType as I;
    from == to
        || matches!(
            (from, to),
            (I::U8, _) | (I::U16, S::F32) | (I::I16, S::F32) | (I::I8, S::I16 | S::F32)
        )
}

/// Whether converting `from` to `to` without a window is decided by the
/// values (their range, from a [`Histogram`]) rather than by the types:
/// types that are not stored (`i8`, 32-bit integers), and `f64` to `f32`,
/// which keeps every value `f32` holds and says how far the others moved.
pub fn by_value(from: SliceType, to: SampleType) -> bool {
    from.stored().is_none() || (from == SliceType::F64 && to == SampleType::F32)
}

/// Largest integer magnitude `f32` holds exactly.
const F32_EXACT_INT: f64 = 16_777_216.0;

/// Whether data of type `from` with values `range` (min, max; `None`: no
/// non-NaN value) fits `to` exactly (`f64` into `f32` rounds).
pub fn fits(from: SliceType, range: Option<(f64, f64)>, to: SampleType) -> bool {
    if is_exact(from, to) {
        return true;
    }
    let Some((lo, hi)) = range else {
        // No value but NaN: only floats hold that.
        return !from.is_integer() && to == SampleType::F32;
    };
    match (from.is_integer(), to.integer_range()) {
        (true, Some((a, b))) => lo >= a && hi <= b,
        (true, None) => lo >= -F32_EXACT_INT && hi <= F32_EXACT_INT,
        (false, None) => from == SliceType::F64 && lo >= f32::MIN as f64 && hi <= f32::MAX as f64,
        (false, Some(_)) => false,
    }
}

/// The smallest stored type that holds data of type `from` with values in
/// `range` exactly: the type itself when it is stored, else `u8`, `u16`,
/// `i16` or `f32` (integers), `f32` (`f64` data); `None` when no stored
/// type does.
pub fn fit_type(from: SliceType, range: Option<(f64, f64)>) -> Option<SampleType> {
    if let Some(t) = from.stored() {
        return Some(t);
    }
    let order: &[SampleType] = if from.is_integer() {
        &[
            SampleType::U8,
            SampleType::U16,
            SampleType::I16,
            SampleType::F32,
        ]
    } else {
        &[SampleType::F32]
    };
    order.iter().copied().find(|&t| fits(from, range, t))
}

/// The output range a window maps onto.
fn out_range(t: SampleType) -> (f64, f64) {
    t.integer_range().unwrap_or((0.0, 1.0))
}

/// How input values become output values: exact, or a clamped linear map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValueMap {
    /// The value is kept (same type or widening).
    Exact,
    /// `[lo, hi]` maps linearly onto the output range and clamps.
    Linear {
        /// Input value mapped to the bottom of the output range.
        lo: f64,
        /// Input value mapped to the top of the output range.
        hi: f64,
    },
}

impl ValueMap {
    /// Decide the map for converting `from` to `to` with an optional window;
    /// `stats` must be given for `Auto` and for `Full` with `f32` input.
    pub fn plan(
        from: SliceType,
        to: SampleType,
        window: Option<Window>,
        stats: Option<&Histogram>,
    ) -> Result<ValueMap> {
        ValueMap::plan_stored(from, None, to, window, stats)
    }

    /// [`ValueMap::plan`] for values of type `from` that the file stores
    /// as `stored` (a rescaled DICOM series: i16 samples, i32 values), so
    /// its messages name the file's type.
    pub fn plan_stored(
        from: SliceType,
        stored: Option<SliceType>,
        to: SampleType,
        window: Option<Window>,
        stats: Option<&Histogram>,
    ) -> Result<ValueMap> {
        let range = stats.and_then(|h| h.range());
        let (lo, hi) = match window {
            None if is_exact(from, to) => return Ok(ValueMap::Exact),
            None if by_value(from, to) && stats.is_some() && fits(from, range, to) => {
                return Ok(ValueMap::Exact)
            }
            None if by_value(from, to) && stats.is_some() => {
                let (lo, hi) = range.unwrap_or((0.0, 0.0));
                let values = match stored {
                    Some(s) => format!("{s} values rescaled to"),
                    None => format!("{from} values"),
                };
                return Err(Error::invalid(format!(
                    "{values} {lo}..{hi} do not fit {to}: pass --window lo:hi, --window auto or --window full"
                )));
            }
            None => {
                let from = match stored {
                    Some(s) => format!("{s} (rescaled to {from})"),
                    None => from.to_string(),
                };
                return Err(Error::invalid(format!(
                    "converting {from} to {to} loses values: pass --window lo:hi, --window auto or --window full"
                )));
            }
            Some(Window::Range(lo, hi)) => {
                if !(lo.is_finite() && hi.is_finite()) || lo >= hi {
                    return Err(Error::invalid(format!(
                        "window {lo}:{hi} is empty or reversed (lo must be below hi)"
                    )));
                }
                (lo, hi)
            }
            Some(Window::Auto(p)) => {
                let h = stats.ok_or_else(|| Error::invalid("auto window needs a histogram"))?;
                h.percentiles(p).ok_or_else(|| {
                    Error::invalid("auto window: the volume has no non-NaN sample")
                })?
            }
            Some(Window::Full) => match from.integer_range() {
                // 32-bit integers: the data's range, like floats (their
                // type range would crush every real image to one value).
                Some(_) if from.size() == 4 => {
                    let h = stats.ok_or_else(|| Error::invalid("full window needs the range"))?;
                    h.range().ok_or_else(|| {
                        Error::invalid("full window: the volume has no non-NaN sample")
                    })?
                }
                Some(r) => r,
                None => {
                    let h = stats.ok_or_else(|| Error::invalid("full window needs the range"))?;
                    h.range().ok_or_else(|| {
                        Error::invalid("full window: the volume has no non-NaN sample")
                    })?
                }
            },
        };
        // A constant volume gives an empty automatic window: widen it so the
        // constant maps to the bottom of the output range (by at least 1,
        // and by |lo| where 1 is below lo's precision: past 2^53, lo + 1
        // is lo, and the map would divide by zero).
        let hi = if hi > lo { hi } else { lo + lo.abs().max(1.0) };
        Ok(ValueMap::Linear { lo, hi })
    }

    /// The output value of one input value (`f64` in, rounded and clamped
    /// output sample out).
    #[inline]
    pub fn apply<T: Sample>(&self, v: f64) -> T {
        let float = matches!(T::TYPE, SampleType::F32 | SampleType::F64);
        match *self {
            ValueMap::Exact => T::from_f64(v),
            ValueMap::Linear { lo, hi } => {
                let (a, b) = out_range(T::TYPE);
                if v.is_nan() {
                    return if float {
                        T::from_f64(f64::NAN)
                    } else {
                        T::from_f32(a as f32)
                    };
                }
                let m = (a + (v - lo) * (b - a) / (hi - lo)).clamp(a, b);
                if float {
                    T::from_f64(m)
                } else {
                    // Round half away from zero in f64, then the value is an
                    // integer well inside f32's exact range.
                    T::from_f32(m.round() as f32)
                }
            }
        }
    }
}

/// Converts slices of any input type to output samples of type `T`,
/// using a lookup table for 8 and 16-bit inputs.
pub struct Mapper<T: Sample> {
    map: ValueMap,
    lut: Option<Vec<T>>,
    from: SliceType,
}

impl<T: Sample> Mapper<T> {
    /// A mapper for input of type `from`.
    pub fn new(from: impl Into<SliceType>, map: ValueMap) -> Mapper<T> {
        let from = from.into();
        let lut = match from {
            SliceType::U8 => Some((0..=255u32).map(|v| map.apply(v as f64)).collect()),
            SliceType::I8 => Some(
                (0..=255u32)
                    .map(|v| map.apply((v as u8 as i8) as f64))
                    .collect(),
            ),
            SliceType::U16 => Some((0..=65535u32).map(|v| map.apply(v as f64)).collect()),
            SliceType::I16 => Some(
                (0..=65535u32)
                    .map(|v| map.apply((v as u16 as i16) as f64))
                    .collect(),
            ),
            _ => None,
        };
        Mapper { map, lut, from }
    }

    /// The value map.
    pub fn map(&self) -> ValueMap {
        self.map
    }

    /// Whether input samples are passed through unchanged (same type, exact).
    pub fn is_identity(&self) -> bool {
        self.map == ValueMap::Exact && self.from == T::TYPE
    }

    /// Map `src[i]` for each `i` in `idx` (an index iterator) into `out`.
    #[inline]
    pub fn map_indexed(
        &self,
        src: &SliceData,
        idx: impl Iterator<Item = usize> + Clone,
        out: &mut [T],
    ) {
        match (src, &self.lut) {
            (SliceData::U8(s), Some(l)) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = l[s[i] as usize];
                }
            }
            (SliceData::U16(s), Some(l)) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = l[s[i] as usize];
                }
            }
            (SliceData::I16(s), Some(l)) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = l[s[i] as u16 as usize];
                }
            }
            (SliceData::I8(s), Some(l)) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = l[s[i] as u8 as usize];
                }
            }
            (SliceData::F32(s), _) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = self.map.apply(s[i] as f64);
                }
            }
            (SliceData::F64(s), _) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = self.map.apply(s[i]);
                }
            }
            // Wide types, through f64.
            (other, _) => {
                for (o, i) in out.iter_mut().zip(idx) {
                    *o = self.map.apply(other.value(i));
                }
            }
        }
    }
}

/// A histogram of sample values: exact bins for 8 and 16-bit types, and
/// for wider types 65536 bins over the order-preserving top 16 bits of the
/// value as `f32` (sign, exponent and 7 mantissa bits: relative bin width
/// 2^-7). The exact smallest and largest values are kept beside.
#[derive(Clone, Debug)]
pub struct Histogram {
    t: SliceType,
    counts: Vec<u64>,
    min: f64,
    max: f64,
    nan: u64,
    /// The largest change rounding a sample to f32 makes (wide inputs).
    f32_error: f64,
}

fn f32_key(v: f32) -> usize {
    let b = v.to_bits();
    let k = if b >> 31 == 1 { !b } else { b | 0x8000_0000 };
    (k >> 16) as usize
}

fn f32_of_key(k: usize, upper: bool) -> f64 {
    let k = ((k as u32) << 16) | if upper { 0xffff } else { 0 };
    let b = if k >> 31 == 1 { k & 0x7fff_ffff } else { !k };
    f32::from_bits(b) as f64
}

impl Histogram {
    /// An empty histogram for samples of type `t`.
    pub fn new(t: impl Into<SliceType>) -> Histogram {
        let t = t.into();
        let bins = if t.size() == 1 { 256 } else { 65536 };
        Histogram {
            t,
            counts: vec![0; bins],
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            nan: 0,
            f32_error: 0.0,
        }
    }

    /// Count the samples of a slice (of the histogram's type).
    pub fn add(&mut self, s: &SliceData) {
        let c = &mut self.counts;
        match s {
            SliceData::U8(v) => v.iter().for_each(|&x| c[x as usize] += 1),
            SliceData::I8(v) => v.iter().for_each(|&x| c[x as u8 as usize ^ 0x80] += 1),
            SliceData::U16(v) => v.iter().for_each(|&x| c[x as usize] += 1),
            SliceData::I16(v) => v.iter().for_each(|&x| c[x as u16 as usize ^ 0x8000] += 1),
            other => {
                for i in 0..other.len() {
                    let x = other.value(i);
                    if x.is_nan() {
                        self.nan += 1;
                    } else {
                        let r = x as f32;
                        c[f32_key(r)] += 1;
                        self.f32_error = self.f32_error.max((r as f64 - x).abs());
                        self.min = self.min.min(x);
                        self.max = self.max.max(x);
                    }
                }
            }
        }
    }

    /// Add another histogram of the same type.
    pub fn merge(mut self, o: Histogram) -> Histogram {
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            *a += b;
        }
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
        self.nan += o.nan;
        self.f32_error = self.f32_error.max(o.f32_error);
        self
    }

    /// The largest absolute change storing the samples as f32 makes (0
    /// when every sample is an f32 value; infinite when one overflows).
    pub fn f32_error(&self) -> f64 {
        self.f32_error
    }

    /// Number of non-NaN samples counted.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    fn bin_value(&self, k: usize, upper: bool) -> f64 {
        match self.t {
            SliceType::U8 | SliceType::U16 => k as f64,
            SliceType::I8 => (k as i64 - 128) as f64,
            SliceType::I16 => (k as i64 - 32768) as f64,
            _ => f32_of_key(k, upper).clamp(self.min, self.max),
        }
    }

    /// Smallest and largest non-NaN value, if any.
    pub fn range(&self) -> Option<(f64, f64)> {
        if self.t.size() > 2 {
            return (self.min <= self.max).then_some((self.min, self.max));
        }
        let first = self.counts.iter().position(|&c| c > 0)?;
        let last = self.counts.iter().rposition(|&c| c > 0)?;
        Some((self.bin_value(first, false), self.bin_value(last, true)))
    }

    /// The values at the `p`-th and `(100 − p)`-th percentiles.
    pub fn percentiles(&self, p: f64) -> Option<(f64, f64)> {
        let n = self.total();
        if n == 0 {
            return None;
        }
        let rank_lo = ((p / 100.0) * (n - 1) as f64).floor() as u64;
        let rank_hi = (((100.0 - p) / 100.0) * (n - 1) as f64).ceil() as u64;
        let at = |rank: u64, upper: bool| {
            let mut seen = 0u64;
            for (k, &c) in self.counts.iter().enumerate() {
                seen += c;
                if seen > rank {
                    return self.bin_value(k, upper);
                }
            }
            self.bin_value(self.counts.len() - 1, upper)
        };
        Some((at(rank_lo, false), at(rank_hi, true)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_windows() {
        assert_eq!("0:255".parse::<Window>(), Ok(Window::Range(0.0, 255.0)));
        assert_eq!(
            "-1000.5:3000".parse::<Window>(),
            Ok(Window::Range(-1000.5, 3000.0))
        );
        assert_eq!("auto".parse::<Window>(), Ok(Window::Auto(0.5)));
        assert_eq!("auto:2".parse::<Window>(), Ok(Window::Auto(2.0)));
        assert_eq!("full".parse::<Window>(), Ok(Window::Full));
        assert!("5:5".parse::<Window>().unwrap_err().contains("lo == hi"));
        assert!("6:5".parse::<Window>().is_err());
        assert!("a:5".parse::<Window>().is_err());
        assert!("auto:60".parse::<Window>().is_err());
        assert!("nan:5".parse::<Window>().is_err());
    }

    #[test]
    fn narrowing_needs_a_window() {
        use SampleType::*;
        let (u8_, u16_, i16_, f32_) = (
            SliceType::U8,
            SliceType::U16,
            SliceType::I16,
            SliceType::F32,
        );
        assert_eq!(
            ValueMap::plan(u8_, U16, None, None).unwrap(),
            ValueMap::Exact
        );
        assert_eq!(
            ValueMap::plan(i16_, F32, None, None).unwrap(),
            ValueMap::Exact
        );
        let e = ValueMap::plan(u16_, U8, None, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--window"), "{e}");
        assert!(ValueMap::plan(f32_, I16, None, None).is_err());
        assert!(ValueMap::plan(i16_, U16, None, None).is_err());
        assert!(ValueMap::plan(u8_, U8, Some(Window::Range(3.0, 3.0)), None).is_err());
        assert_eq!(
            ValueMap::plan(u16_, U8, Some(Window::Full), None).unwrap(),
            ValueMap::Linear {
                lo: 0.0,
                hi: 65535.0
            }
        );
    }

    #[test]
    fn wide_types_fit_by_their_values() {
        use SampleType::*;
        assert_eq!(fit_type(SliceType::I32, Some((-1024.0, 3071.0))), Some(I16));
        assert_eq!(fit_type(SliceType::I32, Some((0.0, 255.0))), Some(U8));
        assert_eq!(fit_type(SliceType::U32, Some((0.0, 60000.0))), Some(U16));
        assert_eq!(fit_type(SliceType::I32, Some((0.0, 1e6))), Some(F32));
        assert_eq!(fit_type(SliceType::I32, Some((0.0, 3e7))), None);
        assert_eq!(fit_type(SliceType::F64, Some((-0.5, 2.0))), Some(F64));
        assert_eq!(fit_type(SliceType::F64, Some((0.0, 1e300))), Some(F64));
        let mut h = Histogram::new(SliceType::F64);
        h.add(&SliceData::F64(vec![0.1, -2.0]));
        assert!(h.f32_error() > 0.0);
        assert!(by_value(SliceType::F64, F32) && !by_value(SliceType::F64, F64));
        assert_eq!(
            ValueMap::plan(SliceType::F64, F32, None, Some(&h)).unwrap(),
            ValueMap::Exact
        );
        assert!(ValueMap::plan(SliceType::F64, U8, None, Some(&h)).is_err());
        assert_eq!(ValueMap::Exact.apply::<f64>(0.1), 0.1);
        assert_eq!(ValueMap::Exact.apply::<f32>(0.1), 0.1f32);
        assert_eq!(fit_type(SliceType::I8, None), Some(I16));
        let mut h = Histogram::new(SliceType::I32);
        h.add(&SliceData::I32(vec![-1024, 0, 3071]));
        assert_eq!(h.range(), Some((-1024.0, 3071.0)));
        assert_eq!(
            ValueMap::plan(SliceType::I32, I16, None, Some(&h)).unwrap(),
            ValueMap::Exact
        );
        let e = ValueMap::plan(SliceType::I32, U8, None, Some(&h))
            .unwrap_err()
            .to_string();
        assert!(e.contains("--window") && e.contains("3071"), "{e}");
        assert_eq!(
            ValueMap::plan(SliceType::I32, U8, Some(Window::Full), Some(&h)).unwrap(),
            ValueMap::Linear {
                lo: -1024.0,
                hi: 3071.0
            }
        );
        let m = Mapper::<i16>::new(SliceType::I32, ValueMap::Exact);
        let mut out = [0i16; 3];
        m.map_indexed(&SliceData::I32(vec![-1024, 0, 3071]), 0..3, &mut out);
        assert_eq!(out, [-1024, 0, 3071]);
        let m = Mapper::<i16>::new(SliceType::I8, ValueMap::Exact);
        let mut out = [0i16; 2];
        m.map_indexed(&SliceData::I8(vec![-128, 127]), 0..2, &mut out);
        assert_eq!(out, [-128, 127]);
    }

    #[test]
    fn linear_map_clamps_rounds_and_maps_nan() {
        let m = ValueMap::Linear {
            lo: 100.0,
            hi: 200.0,
        };
        assert_eq!(m.apply::<u8>(100.0), 0);
        assert_eq!(m.apply::<u8>(200.0), 255);
        assert_eq!(m.apply::<u8>(50.0), 0);
        assert_eq!(m.apply::<u8>(1e9), 255);
        assert_eq!(m.apply::<u8>(150.0), 128); // 127.5 rounds up
        assert_eq!(m.apply::<u8>(f64::NAN), 0);
        assert_eq!(m.apply::<i16>(f64::NAN), -32768);
        assert_eq!(m.apply::<i16>(200.0), 32767);
        assert!(m.apply::<f32>(f64::NAN).is_nan());
        assert_eq!(m.apply::<f32>(150.0), 0.5);
        assert_eq!(m.apply::<f32>(-5.0), 0.0);
        // Exact float to int never happens without a window, but widening
        // keeps values.
        assert_eq!(ValueMap::Exact.apply::<f32>(-3.0), -3.0);
    }

    #[test]
    fn mapper_lut_matches_direct() {
        let m = ValueMap::Linear {
            lo: -1000.0,
            hi: 1000.0,
        };
        let mapper = Mapper::<u8>::new(SampleType::I16, m);
        let src = SliceData::I16(vec![-32768, -1000, 0, 1000, 32767, 3]);
        let mut out = [0u8; 6];
        mapper.map_indexed(&src, 0..6, &mut out);
        assert_eq!(out, [0, 0, 128, 255, 255, 128]);
        let mut rev = [0u8; 3];
        mapper.map_indexed(&src, [2usize, 1, 0].into_iter(), &mut rev);
        assert_eq!(rev, [128, 0, 0]);
    }

    #[test]
    fn a_constant_volume_maps_to_the_bottom_whatever_its_value() {
        for v in [0.0f64, 7.0, -3.0, 1e20, -1e20, 3e300] {
            let mut h = Histogram::new(SliceType::F64);
            h.add(&SliceData::F64(vec![v; 5]));
            for w in [Window::Auto(0.5), Window::Full] {
                let m = ValueMap::plan(SliceType::F64, SampleType::U8, Some(w), Some(&h)).unwrap();
                let ValueMap::Linear { lo, hi } = m else {
                    panic!("{v}: {m:?}")
                };
                assert!(hi > lo, "{v}: window {lo}..{hi}");
                assert_eq!(m.apply::<u8>(v), 0, "{v}");
                assert_eq!(m.apply::<f32>(v), 0.0, "{v}");
            }
        }
    }

    #[test]
    fn histogram_percentiles() {
        let mut h = Histogram::new(SampleType::U8);
        h.add(&SliceData::U8((0..=99).collect()));
        assert_eq!(h.percentiles(0.0), Some((0.0, 99.0)));
        assert_eq!(h.percentiles(10.0), Some((9.0, 90.0)));
        let mut h = Histogram::new(SampleType::I16);
        h.add(&SliceData::I16(vec![-1000, -1000, 5, 2000]));
        assert_eq!(h.range(), Some((-1000.0, 2000.0)));
        let mut f = Histogram::new(SampleType::F32);
        f.add(&SliceData::F32(vec![f32::NAN, -2.5, 0.0, 1.0, 3.25]));
        let g = f.clone().merge(Histogram::new(SampleType::F32));
        assert_eq!(g.total(), 4);
        assert_eq!(f.range(), Some((-2.5, 3.25)));
        let (lo, hi) = f.percentiles(0.0).unwrap();
        assert_eq!((lo, hi), (-2.5, 3.25));
        let (lo, _) = f.percentiles(30.0).unwrap();
        assert!((-2.6..=0.0).contains(&lo), "{lo}");
        // Ordering of the float keys.
        let vals = [-1e30f32, -2.0, -0.5, 0.0, 1e-20, 0.5, 7.0, 1e30];
        for w in vals.windows(2) {
            assert!(f32_key(w[0]) <= f32_key(w[1]));
        }
    }
}
