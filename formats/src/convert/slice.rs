//! One z slice of samples of any supported type.

use volcore::{Sample, SampleType};

/// The samples of one z slice (x fastest), in the type they were read as.
#[derive(Clone, Debug, PartialEq)]
pub enum SliceData {
    /// Unsigned 8-bit samples.
    U8(Vec<u8>),
    /// Unsigned 16-bit samples.
    U16(Vec<u16>),
    /// Signed 16-bit samples.
    I16(Vec<i16>),
    /// 32-bit float samples.
    F32(Vec<f32>),
}

impl SliceData {
    /// The sample type held.
    pub fn sample_type(&self) -> SampleType {
        match self {
            SliceData::U8(_) => SampleType::U8,
            SliceData::U16(_) => SampleType::U16,
            SliceData::I16(_) => SampleType::I16,
            SliceData::F32(_) => SampleType::F32,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        match self {
            SliceData::U8(v) => v.len(),
            SliceData::U16(v) => v.len(),
            SliceData::I16(v) => v.len(),
            SliceData::F32(v) => v.len(),
        }
    }

    /// Whether the slice holds no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The samples as little-endian-independent native bytes.
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            SliceData::U8(v) => v,
            SliceData::U16(v) => bytemuck::cast_slice(v),
            SliceData::I16(v) => bytemuck::cast_slice(v),
            SliceData::F32(v) => bytemuck::cast_slice(v),
        }
    }

    /// The samples as mutable native bytes.
    pub fn as_bytes_mut(&mut self) -> &mut [u8] {
        match self {
            SliceData::U8(v) => v,
            SliceData::U16(v) => bytemuck::cast_slice_mut(v),
            SliceData::I16(v) => bytemuck::cast_slice_mut(v),
            SliceData::F32(v) => bytemuck::cast_slice_mut(v),
        }
    }

    /// A slice of `n` samples of type `t`, reusing the allocation of
    /// `old` when it holds the same type (contents unspecified: callers
    /// overwrite every sample). Reusing buffers saves the page faults of
    /// fresh allocations, which cost more than decoding plain slices.
    pub fn reuse(old: Option<SliceData>, t: SampleType, n: usize) -> SliceData {
        fn fit<T: Copy + Default>(mut v: Vec<T>, n: usize) -> Vec<T> {
            v.resize(n, T::default());
            v.truncate(n);
            v
        }
        match (old, t) {
            (Some(SliceData::U8(v)), SampleType::U8) => SliceData::U8(fit(v, n)),
            (Some(SliceData::U16(v)), SampleType::U16) => SliceData::U16(fit(v, n)),
            (Some(SliceData::I16(v)), SampleType::I16) => SliceData::I16(fit(v, n)),
            (Some(SliceData::F32(v)), SampleType::F32) => SliceData::F32(fit(v, n)),
            (_, SampleType::U8) => SliceData::U8(vec![0; n]),
            (_, SampleType::U16) => SliceData::U16(vec![0; n]),
            (_, SampleType::I16) => SliceData::I16(vec![0; n]),
            (_, SampleType::F32) => SliceData::F32(vec![0.0; n]),
        }
    }

    /// A slice of `n` samples of type `t` from native-order bytes.
    pub fn from_native_bytes(t: SampleType, bytes: &[u8]) -> SliceData {
        match t {
            SampleType::U8 => SliceData::U8(bytes.to_vec()),
            SampleType::U16 => SliceData::U16(bytemuck::pod_collect_to_vec(bytes)),
            SampleType::I16 => SliceData::I16(bytemuck::pod_collect_to_vec(bytes)),
            SampleType::F32 => SliceData::F32(bytemuck::pod_collect_to_vec(bytes)),
        }
    }

    /// A slice of type `t` from bytes in the given byte order.
    pub fn from_bytes(t: SampleType, bytes: &[u8], big_endian: bool) -> SliceData {
        let mut s = SliceData::from_native_bytes(t, bytes);
        if big_endian != cfg!(target_endian = "big") {
            s.swap_bytes();
        }
        s
    }

    /// Reverse the byte order of every sample.
    pub fn swap_bytes(&mut self) {
        match self {
            SliceData::U8(_) => {}
            SliceData::U16(v) => v.iter_mut().for_each(|x| *x = x.swap_bytes()),
            SliceData::I16(v) => v.iter_mut().for_each(|x| *x = x.swap_bytes()),
            SliceData::F32(v) => v
                .iter_mut()
                .for_each(|x| *x = f32::from_bits(x.to_bits().swap_bytes())),
        }
    }
}

/// Sample types that can be moved in and out of a [`SliceData`].
pub trait SliceSample: Sample {
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
    }
}
