//! One z slice of samples of any supported type.

use volcore::{Sample, SampleType};

/// The type of the samples an input hands out: one of the stored types,
/// or another (`i8`, `u32`, `i32`) that a conversion maps to a stored
/// type (see [`crate::convert::window`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SliceType {
    /// Unsigned 8-bit.
    U8,
    /// Signed 8-bit.
    I8,
    /// Unsigned 16-bit.
    U16,
    /// Signed 16-bit.
    I16,
    /// Unsigned 32-bit.
    U32,
    /// Signed 32-bit.
    I32,
    /// 32-bit float.
    F32,
    /// 64-bit float.
    F64,
}

impl SliceType {
    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            SliceType::U8 | SliceType::I8 => 1,
            SliceType::U16 | SliceType::I16 => 2,
            SliceType::U32 | SliceType::I32 | SliceType::F32 => 4,
            SliceType::F64 => 8,
        }
    }

    /// The stored type holding exactly these samples, if there is one.
    pub fn stored(self) -> Option<SampleType> {
        match self {
            SliceType::U8 => Some(SampleType::U8),
            SliceType::U16 => Some(SampleType::U16),
            SliceType::I16 => Some(SampleType::I16),
            SliceType::F32 => Some(SampleType::F32),
            SliceType::F64 => Some(SampleType::F64),
            _ => None,
        }
    }

    /// Whether the samples are integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, SliceType::F32 | SliceType::F64)
    }

    /// The range of an integer type (`None` for floats).
    pub fn integer_range(self) -> Option<(f64, f64)> {
        match self {
            SliceType::I8 => Some((-128.0, 127.0)),
            SliceType::U32 => Some((0.0, u32::MAX as f64)),
            SliceType::I32 => Some((i32::MIN as f64, i32::MAX as f64)),
            SliceType::F64 => None,
            other => other.stored().and_then(|t| t.integer_range()),
        }
    }

    /// Short name (`u8`, `i32`, `f64`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SliceType::U8 => "u8",
            SliceType::I8 => "i8",
            SliceType::U16 => "u16",
            SliceType::I16 => "i16",
            SliceType::U32 => "u32",
            SliceType::I32 => "i32",
            SliceType::F32 => "f32",
            SliceType::F64 => "f64",
        }
    }
}

impl From<SampleType> for SliceType {
    fn from(t: SampleType) -> SliceType {
        match t {
            SampleType::U8 => SliceType::U8,
            SampleType::U16 => SliceType::U16,
            SampleType::I16 => SliceType::I16,
            SampleType::F32 => SliceType::F32,
            SampleType::F64 => SliceType::F64,
        }
    }
}

impl PartialEq<SampleType> for SliceType {
    fn eq(&self, t: &SampleType) -> bool {
        *self == SliceType::from(*t)
    }
}

impl std::fmt::Display for SliceType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Run `$body` with `$v` bound to the vector inside any [`SliceData`].
macro_rules! each_slice {
    ($s:expr, $v:ident => $body:expr) => {
        match $s {
            SliceData::U8($v) => $body,
            SliceData::I8($v) => $body,
            SliceData::U16($v) => $body,
            SliceData::I16($v) => $body,
            SliceData::U32($v) => $body,
            SliceData::I32($v) => $body,
            SliceData::F32($v) => $body,
            SliceData::F64($v) => $body,
        }
    };
}
#[allow(unused_imports)]
pub(crate) use each_slice;

/// Rebuild a [`SliceData`] of the same variant from `$v` mapped by `$f`
/// (a generic function over the element type).
macro_rules! map_slice {
    ($s:expr, $v:ident => $body:expr) => {
        match $s {
            SliceData::U8($v) => SliceData::U8($body),
            SliceData::I8($v) => SliceData::I8($body),
            SliceData::U16($v) => SliceData::U16($body),
            SliceData::I16($v) => SliceData::I16($body),
            SliceData::U32($v) => SliceData::U32($body),
            SliceData::I32($v) => SliceData::I32($body),
            SliceData::F32($v) => SliceData::F32($body),
            SliceData::F64($v) => SliceData::F64($body),
        }
    };
}
pub(crate) use map_slice;

/// The samples of one z slice (x fastest), in the type they were read as.
#[derive(Clone, Debug, PartialEq)]
pub enum SliceData {
    /// Unsigned 8-bit samples.
    U8(Vec<u8>),
    /// Signed 8-bit samples.
    I8(Vec<i8>),
    /// Unsigned 16-bit samples.
    U16(Vec<u16>),
    /// Signed 16-bit samples.
    I16(Vec<i16>),
    /// Unsigned 32-bit samples.
    U32(Vec<u32>),
    /// Signed 32-bit samples.
    I32(Vec<i32>),
    /// 32-bit float samples.
    F32(Vec<f32>),
    /// 64-bit float samples.
    F64(Vec<f64>),
}

impl SliceData {
    /// The sample type held.
    pub fn sample_type(&self) -> SliceType {
        match self {
            SliceData::U8(_) => SliceType::U8,
            SliceData::I8(_) => SliceType::I8,
            SliceData::U16(_) => SliceType::U16,
            SliceData::I16(_) => SliceType::I16,
            SliceData::U32(_) => SliceType::U32,
            SliceData::I32(_) => SliceType::I32,
            SliceData::F32(_) => SliceType::F32,
            SliceData::F64(_) => SliceType::F64,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        each_slice!(self, v => v.len())
    }

    /// Whether the slice holds no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i` as `f64` (exact for every type).
    #[inline]
    pub fn value(&self, i: usize) -> f64 {
        #[allow(clippy::unnecessary_cast)]
        let v = each_slice!(self, v => v[i] as f64);
        v
    }

    /// The samples as native-order bytes.
    pub fn as_bytes(&self) -> &[u8] {
        each_slice!(self, v => bytemuck::cast_slice(v))
    }

    /// The samples as mutable native-order bytes.
    pub fn as_bytes_mut(&mut self) -> &mut [u8] {
        each_slice!(self, v => bytemuck::cast_slice_mut(v))
    }

    /// A slice of `n` samples of type `t`, reusing the allocation of
    /// `old` when it holds the same type (contents unspecified: callers
    /// overwrite every sample). Reusing buffers saves the page faults of
    /// fresh allocations, which cost more than decoding plain slices.
    pub fn reuse(old: Option<SliceData>, t: impl Into<SliceType>, n: usize) -> SliceData {
        fn fit<T: Copy + Default>(mut v: Vec<T>, n: usize) -> Vec<T> {
            v.resize(n, T::default());
            v.truncate(n);
            v
        }
        let t = t.into();
        match old {
            Some(s) if s.sample_type() == t => map_slice!(s, v => fit(v, n)),
            _ => SliceData::zeros(t, n),
        }
    }

    /// `n` zero samples of type `t`.
    pub fn zeros(t: impl Into<SliceType>, n: usize) -> SliceData {
        match t.into() {
            SliceType::U8 => SliceData::U8(vec![0; n]),
            SliceType::I8 => SliceData::I8(vec![0; n]),
            SliceType::U16 => SliceData::U16(vec![0; n]),
            SliceType::I16 => SliceData::I16(vec![0; n]),
            SliceType::U32 => SliceData::U32(vec![0; n]),
            SliceType::I32 => SliceData::I32(vec![0; n]),
            SliceType::F32 => SliceData::F32(vec![0.0; n]),
            SliceType::F64 => SliceData::F64(vec![0.0; n]),
        }
    }

    /// A slice of type `t` from native-order bytes.
    pub fn from_native_bytes(t: impl Into<SliceType>, bytes: &[u8]) -> SliceData {
        let t = t.into();
        let mut s = SliceData::zeros(t, bytes.len() / t.size());
        let n = s.as_bytes().len();
        s.as_bytes_mut().copy_from_slice(&bytes[..n]);
        s
    }

    /// A slice of type `t` from bytes in the given byte order.
    pub fn from_bytes(t: impl Into<SliceType>, bytes: &[u8], big_endian: bool) -> SliceData {
        let mut s = SliceData::from_native_bytes(t, bytes);
        if big_endian != cfg!(target_endian = "big") {
            s.swap_bytes();
        }
        s
    }

    /// Reverse the byte order of every sample.
    pub fn swap_bytes(&mut self) {
        let size = self.sample_type().size();
        if size > 1 {
            for c in self.as_bytes_mut().chunks_exact_mut(size) {
                c.reverse();
            }
        }
    }

    /// The samples at indices `idx` (in that order), same type.
    pub fn gather(&self, idx: impl Iterator<Item = usize> + Clone) -> SliceData {
        map_slice!(self, v => idx.clone().map(|i| v[i]).collect())
    }
}

/// Sample types that can be moved in and out of a [`SliceData`].
pub trait SliceSample: Sample + volcore::volume::OpenSample {
    /// Wrap samples of this type.
    fn wrap(v: Vec<Self>) -> SliceData;
    /// The samples, if `d` holds this type.
    fn unwrap(d: SliceData) -> Result<Vec<Self>, SliceData>;
}

macro_rules! slice_sample {
    ($t:ty, $v:ident) => {
        impl SliceSample for $t {
            fn wrap(v: Vec<$t>) -> SliceData {
                SliceData::$v(v)
            }
            fn unwrap(d: SliceData) -> Result<Vec<$t>, SliceData> {
                match d {
                    SliceData::$v(v) => Ok(v),
                    other => Err(other),
                }
            }
        }
    };
}
slice_sample!(u8, U8);
slice_sample!(u16, U16);
slice_sample!(i16, I16);
slice_sample!(f32, F32);
slice_sample!(f64, F64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_orders() {
        let be = [0x01, 0x02, 0xff, 0xfe];
        assert_eq!(
            SliceData::from_bytes(SampleType::U16, &be, true),
            SliceData::U16(vec![0x0102, 0xfffe])
        );
        assert_eq!(
            SliceData::from_bytes(SampleType::I16, &be, false),
            SliceData::I16(vec![0x0201, -257])
        );
        let f = 1.5f32.to_be_bytes();
        assert_eq!(
            SliceData::from_bytes(SampleType::F32, &f, true),
            SliceData::F32(vec![1.5])
        );
        let d = SliceData::U8(vec![1, 2]);
        assert_eq!(d.as_bytes(), &[1, 2]);
        assert_eq!(u8::unwrap(d).unwrap(), vec![1, 2]);
        let d = SliceData::from_bytes(SliceType::I32, &[0xff, 0xff, 0xff, 0xfe], true);
        assert_eq!(d, SliceData::I32(vec![-2]));
        assert_eq!(d.value(0), -2.0);
        let d = SliceData::from_bytes(SliceType::F64, &2.5f64.to_be_bytes(), true);
        assert_eq!(d, SliceData::F64(vec![2.5]));
        assert_eq!(
            SliceData::I8(vec![1, -2, 3]).gather([2usize, 1].into_iter()),
            SliceData::I8(vec![3, -2])
        );
    }
}
