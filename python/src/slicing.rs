//! `Volume[key]`: basic slicing keeps the geometry. `v[z0:z1, y0:y1,
//! x0:x1]` is a new Volume in memory whose voxel (0, 0, 0) is the old
//! voxel (z0, y0, x0), so its origin moves to `origin + direction @
//! (spacing * start)`; a step `k` scales that axis's spacing by `|k|`, and
//! a negative step turns its direction around (as ITK's and nibabel's
//! slicers do). Keys that are not all slices (an integer dropping an axis,
//! `None`, index arrays) give the plain numpy array, whose geometry is
//! the caller's.

use crate::volume::{array_of, geometry_of, spacing_of, volume_of_array, PyVolume};
use pyo3::prelude::*;
use pyo3::types::{PyEllipsis, PySlice, PySliceMethods, PyTuple};

/// The (start, step) of each axis (z, y, x) that `key` selects, when it is
/// basic slicing only (slices and at most one `...`), else None.
fn slice_starts(
    key: &Bound<'_, PyAny>,
    shape: [usize; 3],
) -> PyResult<Option<[(isize, isize); 3]>> {
    let items: Vec<Bound<'_, PyAny>> = match key.cast::<PyTuple>() {
        Ok(t) => t.iter().collect(),
        Err(_) => vec![key.clone()],
    };
    if items
        .iter()
        .any(|i| !(i.is_instance_of::<PySlice>() || i.is_instance_of::<PyEllipsis>()))
    {
        return Ok(None);
    }
    let ellipses = items
        .iter()
        .filter(|i| i.is_instance_of::<PyEllipsis>())
        .count();
    let slices = items.len() - ellipses;
    if ellipses > 1 || slices > 3 {
        // numpy's own error for the plain array.
        return Ok(None);
    }
    let mut axes: Vec<Option<Bound<'_, PySlice>>> = Vec::with_capacity(3);
    for i in &items {
        match i.cast::<PySlice>() {
            Ok(s) => axes.push(Some(s.clone())),
            Err(_) => axes.extend(std::iter::repeat_n(None, 3 - slices)),
        }
    }
    axes.resize(3, None);
    let mut out = [(0, 1); 3];
    for (a, s) in axes.iter().enumerate() {
        if let Some(s) = s {
            let n = isize::try_from(shape[a]).unwrap_or(isize::MAX);
            let ind = s.indices(n)?;
            out[a] = (ind.start, ind.step);
        }
    }
    Ok(Some(out))
}

/// `slf[key]`: a Volume for basic slicing, else the numpy array's item.
pub fn get_item<'py>(
    slf: &Bound<'py, PyVolume>,
    key: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let arr = array_of(slf)?;
    let sub = arr.get_item(key)?;
    let v = slf.get();
    let (z, y, x) = v.shape_zyx();
    let Some(starts) = slice_starts(key, [z, y, x])? else {
        return Ok(sub);
    };
    let (d, s, o) = (v.direction_zyx(), v.spacing_zyx(), v.origin_zyx());
    let mut origin = o;
    let mut direction = d;
    let mut spacing = s;
    for (j, &(start, step)) in starts.iter().enumerate() {
        let offset = s[j] * start as f64;
        for r in 0..3 {
            origin[r] += d[r][j] * offset;
            direction[r][j] = d[r][j] * (step.signum() as f64);
        }
        spacing[j] = s[j] * step.unsigned_abs() as f64;
    }
    let mut vol = volume_of_array(&sub)?;
    vol.meta.spacing = spacing_of(spacing)?;
    vol.meta.geometry = geometry_of(Some(origin), Some(direction), v.vol.meta.geometry)?;
    Ok(Bound::new(slf.py(), PyVolume { vol, file: None })?.into_any())
}
