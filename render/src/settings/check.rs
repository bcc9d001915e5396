//! The checks a frame's settings pass before anything is built: every
//! value in range, and no input able to make a ray's loop or a frame's
//! buffers grow without bound.

use super::{Mode, RenderSettings};
use crate::camera::Camera;
use crate::effects::{self, Ao, AoMethod, ShadowMethod, Shadows};
use crate::error::RenderError;
use crate::frame::{
    world_diagonal, FRAME_BYTES_PER_PIXEL, FRAME_MEMORY_BUDGET, MAX_SAMPLES_PER_RAY,
};
use volcore::Volume;

/// Check `settings` for a frame of `vol` through `camera` before anything
/// is built: the frame's memory, the steps, the effects' settings, the
/// camera's reach, the termination threshold, the tile size and the iso
/// value.
pub fn frame(settings: &RenderSettings, vol: &Volume, camera: &Camera) -> Result<(), RenderError> {
    let (w, h) = (camera.width() as u64, camera.height() as u64);
    let need = w * h * FRAME_BYTES_PER_PIXEL;
    if need > FRAME_MEMORY_BUDGET {
        return Err(RenderError::Setting(format!(
            "a {w}x{h} frame needs about {:.1} GiB ({FRAME_BYTES_PER_PIXEL} bytes per pixel), \
             more than the budget of {} GiB: ask for a smaller --size",
            need as f64 / (1u64 << 30) as f64,
            FRAME_MEMORY_BUDGET >> 30
        )));
    }
    let s = settings.step;
    let diagonal = step("step", s, vol)?;
    if let Some(sh) = &settings.shadows {
        shadow_settings(settings, sh, vol)?;
    }
    if let Some(ao) = &settings.ao {
        ao_settings(settings, ao)?;
    }
    // Sample positions are f32: far from the origin consecutive samples
    // would round to the same point and a ray's sample index overflow.
    let reach = camera.eye().as_dvec3().length() + diagonal;
    if reach * f32::EPSILON as f64 > s as f64 {
        let e = camera.eye();
        return Err(RenderError::Camera(format!(
            "eye {},{},{} is too far from the volume for step {s}: f32 positions there are coarser than the step",
            e.x, e.y, e.z
        )));
    }
    if let Some(t) = settings.ert {
        if !(t > 0.0 && t <= 1.0) {
            return Err(RenderError::Setting(format!(
                "termination threshold {t} must be in (0, 1]"
            )));
        }
    }
    if settings.tile == 0 {
        return Err(RenderError::Setting("tile size must be at least 1".into()));
    }
    if let Mode::Iso(v) = settings.mode {
        if !v.is_finite() {
            return Err(RenderError::Setting("iso value must be finite".into()));
        }
    }
    Ok(())
}

/// Check a sample spacing along rays (`what` names it in errors) against
/// the volume: positive, not absurdly small, and at most
/// [`MAX_SAMPLES_PER_RAY`] samples across the diagonal, which it returns.
pub fn step(what: &str, s: f32, vol: &Volume) -> Result<f64, RenderError> {
    if !(s.is_finite() && s > 0.0) {
        return Err(RenderError::Setting(format!(
            "{what} {s} must be a positive number"
        )));
    }
    if s < vol.meta.min_spacing() * 1e-4 {
        return Err(RenderError::Setting(format!(
            "{what} {s} is below 1e-4 of the voxel spacing: a frame would take billions of samples per ray"
        )));
    }
    let sp = vol.meta.spacing;
    let Some(diagonal) = world_diagonal(vol) else {
        return Err(RenderError::Setting(format!(
            "the volume's extent (dims {} x spacing {},{},{}) is too large for f32 world coordinates",
            vol.dims(),
            sp[0],
            sp[1],
            sp[2]
        )));
    };
    let per_ray = diagonal / s as f64;
    if per_ray > MAX_SAMPLES_PER_RAY {
        return Err(RenderError::Setting(format!(
            "{what} {s} across the volume's diagonal of {diagonal:.6e} world units (spacing {},{},{}) \
             means {per_ray:.3e} samples per ray, more than the limit of {MAX_SAMPLES_PER_RAY:e}",
            sp[0], sp[1], sp[2]
        )));
    }
    Ok(diagonal)
}

/// The finest step along rays of `vol` that [`frame`] accepts: at least
/// 1e-4 of the smallest voxel spacing, at most [`MAX_SAMPLES_PER_RAY`]
/// samples across the volume's diagonal and, with `camera`, no finer than
/// f32 positions resolve between its eye and the far side of the volume.
/// `None` when the volume's extent is not finite in f32 (no step is
/// accepted then).
pub fn finest_step(vol: &Volume, camera: Option<&Camera>) -> Option<f32> {
    let diagonal = world_diagonal(vol)?;
    let per_ray = diagonal / MAX_SAMPLES_PER_RAY;
    let need = match camera {
        Some(c) => per_ray.max((c.eye().as_dvec3().length() + diagonal) * f32::EPSILON as f64),
        None => per_ray,
    };
    // Rounded up to the f32 the checks compare (in f64) against `need`.
    let mut s = (need as f32).max(f32::MIN_POSITIVE);
    while (s as f64) < need {
        s = s.next_up();
    }
    Some(s.max(vol.meta.min_spacing() * 1e-4))
}

/// Check the shadow settings: a mode and shading that have light to
/// shadow, a valid grid divisor and shadow step.
fn shadow_settings(
    settings: &RenderSettings,
    sh: &Shadows,
    vol: &Volume,
) -> Result<(), RenderError> {
    match settings.mode {
        Mode::Dvr if !settings.shading => {
            return Err(RenderError::Setting(
                "shadows need shading: an unshaded DVR frame has no light to shadow".into(),
            ))
        }
        Mode::Dvr | Mode::Iso(_) => {}
        _ => {
            return Err(RenderError::Setting(
                "shadows apply to the DVR and iso modes only".into(),
            ))
        }
    }
    if let ShadowMethod::Grid { divisor } = sh.method {
        if ![1, 2, 4].contains(&divisor) {
            return Err(RenderError::Setting(format!(
                "shadow grid divisor {divisor} must be 1, 2 or 4"
            )));
        }
    }
    if let Some(h) = sh.step {
        step("shadow step", h, vol)?;
    }
    Ok(())
}

/// Check the ambient occlusion settings: a mode and shading with an
/// ambient term to occlude, direction counts within their limits, a
/// radius that is a number.
fn ao_settings(settings: &RenderSettings, ao: &Ao) -> Result<(), RenderError> {
    match settings.mode {
        Mode::Dvr if !settings.shading => {
            return Err(RenderError::Setting(
                "ambient occlusion needs shading: an unshaded DVR frame has no ambient light"
                    .into(),
            ))
        }
        Mode::Dvr | Mode::Iso(_) => {}
        _ => {
            return Err(RenderError::Setting(
                "ambient occlusion applies to the DVR and iso modes only".into(),
            ))
        }
    }
    match ao.method {
        AoMethod::Rays { n } if !(1..=effects::ao::MAX_AO_RAYS).contains(&n) => {
            return Err(RenderError::Setting(format!(
                "AO directions {n} must be 1 to {}",
                effects::ao::MAX_AO_RAYS
            )))
        }
        AoMethod::Field { k, .. } if !(1..=effects::ao::MAX_AO_FIELD_DIRECTIONS).contains(&k) => {
            return Err(RenderError::Setting(format!(
                "AO field directions {k} must be 1 to {}",
                effects::ao::MAX_AO_FIELD_DIRECTIONS
            )))
        }
        AoMethod::Field { cell, .. } if !(1..=effects::ao::MAX_AO_FIELD_CELL).contains(&cell) => {
            return Err(RenderError::Setting(format!(
                "AO field cell {cell} must be 1 to {} voxels",
                effects::ao::MAX_AO_FIELD_CELL
            )))
        }
        _ => {}
    }
    if let Some(r) = ao.radius {
        if !(r.is_finite() && r >= 0.0) {
            return Err(RenderError::Setting(format!(
                "AO radius {r} must be a finite number, 0 or more"
            )));
        }
    }
    Ok(())
}
