//! Samples of every slice type as `f64` and as order-preserving keys.
//!
//! A key is a `u64` whose unsigned order is the samples' numeric order,
//! left-aligned: its top [`key_bits`] bits hold the key, the rest are
//! zero. Integer types flip the sign bit; floats flip the sign bit of
//! positive values and every bit of negative ones (the usual radix-sort
//! mapping). Exact order statistics are found 16 key bits at a time.

use crate::slice::SliceType;

/// A sample type the statistics read: its value and its key.
pub(crate) trait StatSample: Copy + Send + Sync {
    /// The value, exactly.
    fn f64(self) -> f64;
    /// The order-preserving key, left-aligned (see the module docs).
    fn key(self) -> u64;
    /// Whether the value is finite (always, for integers).
    fn finite(self) -> bool {
        true
    }
}

macro_rules! int_sample {
    ($t:ty, $u:ty, $flip:expr) => {
        impl StatSample for $t {
            #[inline]
            fn f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn key(self) -> u64 {
                let bits = 8 * std::mem::size_of::<$t>() as u32;
                // 8-bit types take 16-bit keys, as 16-bit types do.
                let width = bits.max(16);
                (((self as $u) ^ $flip) as u64) << (64 - width)
            }
        }
    };
}
int_sample!(u8, u8, 0);
int_sample!(i8, u8, 0x80);
int_sample!(u16, u16, 0);
int_sample!(i16, u16, 0x8000);
int_sample!(u32, u32, 0);
int_sample!(i32, u32, 0x8000_0000);

impl StatSample for f32 {
    #[inline]
    fn f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn key(self) -> u64 {
        let b = self.to_bits();
        let k = if b >> 31 == 1 { !b } else { b | 1 << 31 };
        (k as u64) << 32
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl StatSample for f64 {
    #[inline]
    fn f64(self) -> f64 {
        self
    }
    #[inline]
    fn key(self) -> u64 {
        let b = self.to_bits();
        if b >> 63 == 1 {
            !b
        } else {
            b | 1 << 63
        }
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

/// Bits of the keys of `t`: 16 for 8- and 16-bit types, 32 or 64 for the
/// wider ones.
pub(crate) fn key_bits(t: SliceType) -> u32 {
    (8 * t.size() as u32).max(16)
}

/// The value whose left-aligned key is `key`, for samples of type `t`.
pub(crate) fn from_key(t: SliceType, key: u64) -> f64 {
    let k = key >> (64 - key_bits(t));
    match t {
        SliceType::U8 => k as f64,
        SliceType::I8 => (k as u8 ^ 0x80) as i8 as f64,
        SliceType::U16 => k as f64,
        SliceType::I16 => (k as u16 ^ 0x8000) as i16 as f64,
        SliceType::U32 => k as f64,
        SliceType::I32 => (k as u32 ^ 0x8000_0000) as i32 as f64,
        SliceType::F32 => {
            let k = k as u32;
            let b = if k >> 31 == 1 { k & !(1 << 31) } else { !k };
            f32::from_bits(b) as f64
        }
        SliceType::F64 => {
            let b = if k >> 63 == 1 { k & !(1 << 63) } else { !k };
            f64::from_bits(b)
        }
    }
}

/// The 16-bit slots of the first key digit that the values of `t` occupy,
/// as `(first slot, slots, value of the first slot)`, for the types whose
/// first digit is the whole key (8- and 16-bit types): each slot is one
/// value.
pub(crate) fn value_slots(t: SliceType) -> Option<(usize, usize, f64)> {
    match t {
        SliceType::U8 => Some((0, 256, 0.0)),
        SliceType::I8 => Some((0, 256, -128.0)),
        SliceType::U16 => Some((0, 65536, 0.0)),
        SliceType::I16 => Some((0, 65536, -32768.0)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check<T: StatSample + PartialOrd>(t: SliceType, mut vals: Vec<T>) {
        vals.sort_by(|a, b| a.partial_cmp(b).unwrap());
        for w in vals.windows(2) {
            assert!(w[0].key() <= w[1].key(), "{} {}", w[0].f64(), w[1].f64());
        }
        for v in vals {
            assert_eq!(from_key(t, v.key()), v.f64(), "{}", v.f64());
        }
    }

    #[test]
    fn keys_keep_the_order_and_give_the_value_back() {
        check(SliceType::U8, vec![0u8, 1, 127, 128, 255]);
        check(SliceType::I8, vec![-128i8, -1, 0, 1, 127]);
        check(SliceType::U16, vec![0u16, 1, 300, 65535]);
        check(SliceType::I16, vec![-32768i16, -300, -1, 0, 1, 32767]);
        check(SliceType::U32, vec![0u32, 1, 1 << 31, u32::MAX]);
        check(SliceType::I32, vec![i32::MIN, -5, 0, 7, i32::MAX]);
        check(
            SliceType::F32,
            vec![f32::MIN, -1.5, -0.0, 1e-40, 0.25, 3.0, f32::MAX],
        );
        check(
            SliceType::F64,
            vec![f64::MIN, -1e-300, -0.0, 5e-324, 0.1, 1e300, f64::MAX],
        );
        // 8-bit keys sit in the first 16-bit digit, one slot per value.
        assert_eq!(200u8.key() >> 48, 200);
        assert_eq!((-128i8).key() >> 48, 0);
        assert_eq!(127i8.key() >> 48, 255);
        assert_eq!((-32768i16).key() >> 48, 0);
    }
}
