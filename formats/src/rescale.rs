//! Stored values mapped to real ones as slices are read: NIfTI
//! `scl_slope`/`scl_inter`, DICOM RescaleSlope/RescaleIntercept.

use crate::reader::{Access, CResult, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};

/// `real = slope · stored + intercept`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rescale {
    /// Multiplier.
    pub slope: f64,
    /// Offset added after the multiplication.
    pub intercept: f64,
}

impl Rescale {
    /// Whether the map changes nothing.
    pub fn is_identity(&self) -> bool {
        self.slope == 1.0 && self.intercept == 0.0
    }

    /// The type real values of stored type `t` take: `i32` when an integer
    /// type meets an integer slope and intercept (Hounsfield units from
    /// `u16` or `i16` pixels), `f64` otherwise.
    pub fn output_type(&self, t: SliceType) -> SliceType {
        let whole = |v: f64| v.fract() == 0.0 && v.abs() <= 65536.0;
        if t.is_integer() && t.size() <= 2 && whole(self.slope) && whole(self.intercept) {
            SliceType::I32
        } else {
            SliceType::F64
        }
    }

    /// The real values of `s`.
    pub fn apply(&self, s: &SliceData) -> SliceData {
        let n = s.len();
        match self.output_type(s.sample_type()) {
            SliceType::I32 => {
                let (m, b) = (self.slope as i64, self.intercept as i64);
                SliceData::I32(
                    (0..n)
                        .map(|i| {
                            (s.value(i) as i64 * m + b).clamp(i32::MIN as i64, i32::MAX as i64)
                                as i32
                        })
                        .collect(),
                )
            }
            _ => SliceData::F64(
                (0..n)
                    .map(|i| s.value(i) * self.slope + self.intercept)
                    .collect(),
            ),
        }
    }
}

/// A reader whose slices are rescaled on the way.
pub struct Rescaled {
    inner: Box<dyn SliceReader>,
    info: InputInfo,
    map: Rescale,
}

impl Rescaled {
    /// Rescale every slice of `inner`.
    pub fn new(inner: Box<dyn SliceReader>, map: Rescale) -> Rescaled {
        let mut info = inner.info().clone();
        info.sample_type = map.output_type(info.sample_type);
        Rescaled { inner, info, map }
    }
}

impl SliceReader for Rescaled {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        self.inner.access()
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        Ok(self.map.apply(&self.inner.read_slice(z)?))
    }
    fn bytes_in(&self) -> u64 {
        self.inner.bytes_in()
    }
    fn finish(&self) -> CResult<()> {
        self.inner.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hounsfield_units_stay_integers() {
        let m = Rescale {
            slope: 1.0,
            intercept: -1024.0,
        };
        assert_eq!(m.output_type(SliceType::U16), SliceType::I32);
        assert_eq!(
            m.apply(&SliceData::U16(vec![0, 1024, 4095])),
            SliceData::I32(vec![-1024, 0, 3071])
        );
        let f = Rescale {
            slope: 0.5,
            intercept: 1.0,
        };
        assert_eq!(
            f.apply(&SliceData::I16(vec![-2, 3])),
            SliceData::F64(vec![0.0, 2.5])
        );
        assert_eq!(f.output_type(SliceType::F32), SliceType::F64);
    }
}
