//! An in-memory [`volcore::Volume`], left in a [`MemorySlot`].

use super::{slab, slice_of, MemorySlot, Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::error::Error;
use crate::reader::{At, CResult, ConvertError};
use crate::slice::SliceSample;
use std::ops::Range;
use std::path::Path;
use volcore::{Dims, Geometry, Volume};

struct MemoryOut<T> {
    samples: Vec<T>,
    slot: MemorySlot,
    dims: Dims,
    spacing: [f32; 3],
    geometry: Geometry,
    next_z: u64,
    slab: u64,
}

/// Where errors are said to be: the volume has no path.
const NO_PATH: &str = "-";

pub(super) fn open<'a, T: SliceSample>(slot: MemorySlot, spec: &OutSpec<'a>) -> Opened<'a, T> {
    let dims = spec.dims;
    let path = Path::new(NO_PATH);
    let n = dims
        .checked_count()
        .ok_or_else(|| ConvertError::new(path, Error::invalid(format!("{dims} is too large"))))?;
    let mut samples: Vec<T> = Vec::new();
    samples.try_reserve_exact(n as usize).map_err(|_| {
        ConvertError::new(
            path,
            Error::invalid(format!(
                "{dims} {} does not fit in memory: convert it to a .vvol file first",
                T::TYPE
            )),
        )
    })?;
    Ok(Box::new(MemoryOut {
        samples,
        slot,
        dims,
        spacing: spec.spacing,
        geometry: spec.geometry,
        next_z: 0,
        slab: slab(dims, T::TYPE.size()),
    }))
}

impl<T: SliceSample> SliceWriter<T> for MemoryOut<T> {
    fn next_slices(&self) -> Range<u64> {
        self.next_z..(self.next_z + self.slab).min(self.dims.z)
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let zs = self.next_slices();
        for z in zs.clone() {
            let s = slice_of(win, z, Path::new(NO_PATH))?;
            self.samples.extend_from_slice(s);
        }
        self.next_z = zs.end;
        Ok(())
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let bytes = std::mem::size_of_val(self.samples.as_slice()) as u64;
        let mut v = Volume::from_samples(self.dims, self.samples).at(Path::new(NO_PATH))?;
        v.meta.spacing = self.spacing;
        v.meta.geometry = self.geometry;
        let range = v.meta.range;
        self.slot.put(v);
        Ok(Written {
            bytes,
            range: Some(range),
        })
    }
}
