//! The checks a frame's settings pass before anything is built: every
//! value in range, and no input able to make a ray's loop or a frame's
//! buffers grow without bound. The frame-memory check ([`memory`]) is the
//! one both pipelines use, the ray caster's ([`frame`]) and the path
//! tracer's ([`crate::path::PathTracer::new`]), each with its own bytes
//! per pixel.

use super::{FRAME_BYTES_PER_PIXEL, FRAME_MEMORY_BUDGET, MAX_SAMPLES_PER_RAY};
use crate::camera::Camera;
use crate::effects;
use crate::error::RenderError;
use crate::ray::NEAR_STEPS;
use crate::settings::{Ao, AoMethod, Mode, RenderSettings, ShadowMethod, Shadows};
use volcore::Volume;

/// Check `settings` for a frame of `vol` through `camera` before anything
/// is built: the frame's memory (from the camera's image size), the steps
/// (f32 positions across the volume: where the eye is does not matter),
/// the effects' settings, the termination threshold, the tile size and the
/// iso value.
pub fn frame(settings: &RenderSettings, vol: &Volume, camera: &Camera) -> Result<(), RenderError> {
    memory(camera, FRAME_BYTES_PER_PIXEL, "frame")?;
    let s = settings.step;
    step("step", s, vol)?;
    if let Some(sh) = &settings.shadows {
        shadow_settings(settings, sh, vol)?;
    }
    if let Some(ao) = &settings.ao {
        ao_settings(settings, ao)?;
    }
    if let Some(t) = settings.ert {
        if !(t > 0.0 && t <= 1.0) {
            return Err(RenderError::Setting(format!(
                "termination threshold {t} must be in (0, 1]"
            )));
        }
    }
    if settings.preintegrated {
        preintegration(settings)?;
    }
    if let Some(tol) = settings.adaptive {
        adaptive(settings, tol)?;
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

/// Check that pre-integration applies: DVR (the only mode with a
/// transfer function) with trilinear values (a pre-integrated segment
/// assumes the value varies linearly between its samples; nearest-voxel
/// values jump, and would make skipped and traced frames differ).
fn preintegration(settings: &RenderSettings) -> Result<(), RenderError> {
    if settings.mode != Mode::Dvr {
        return Err(RenderError::Setting(
            "pre-integration is for DVR: other modes have no transfer function".into(),
        ));
    }
    if settings.interp != crate::settings::Interp::Trilinear {
        return Err(RenderError::Setting(
            "pre-integration needs trilinear values: it assumes the value varies linearly \
             between samples"
                .into(),
        ));
    }
    Ok(())
}

/// Check that adaptive steps apply: DVR (the only mode whose samples
/// stand for steps of a transfer function's integral), without
/// pre-integration (its segments are one step long), with a tolerance
/// that is a positive finite number.
fn adaptive(settings: &RenderSettings, tol: f32) -> Result<(), RenderError> {
    if settings.mode != Mode::Dvr {
        return Err(RenderError::Setting(
            "adaptive steps are for DVR: other modes integrate no transfer function".into(),
        ));
    }
    if settings.preintegrated {
        return Err(RenderError::Setting(
            "adaptive steps and pre-integration do not combine: a pre-integrated segment is \
             one step long"
                .into(),
        ));
    }
    if !(tol.is_finite() && tol > 0.0) {
        return Err(RenderError::Setting(format!(
            "the adaptive tolerance must be a positive number, not {tol}"
        )));
    }
    Ok(())
}

/// Check that a frame through `camera` fits [`FRAME_MEMORY_BUDGET`] when
/// its pipeline needs `bytes_per_pixel` for all its per-pixel buffers
/// together: [`FRAME_BYTES_PER_PIXEL`] for the ray-casting modes,
/// [`crate::path::PATH_BYTES_PER_PIXEL`] for the path tracer. `what`
/// names the frame in the error ("frame", "path-traced frame").
pub fn memory(camera: &Camera, bytes_per_pixel: u64, what: &str) -> Result<(), RenderError> {
    let (w, h) = (camera.width() as u64, camera.height() as u64);
    let need = w.saturating_mul(h).saturating_mul(bytes_per_pixel);
    if need > FRAME_MEMORY_BUDGET {
        return Err(RenderError::Setting(format!(
            "a {w}x{h} {what} needs about {:.1} GiB ({bytes_per_pixel} bytes per pixel), \
             more than the budget of {} GiB: ask for a smaller --size",
            need as f64 / (1u64 << 30) as f64,
            FRAME_MEMORY_BUDGET >> 30
        )));
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
    let Some(diagonal) = vol.meta.world_diagonal() else {
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
    if position_reach(diagonal, s) * f64::from(f32::EPSILON) > f64::from(s) {
        return Err(RenderError::Setting(format!(
            "{what} {s} is finer than f32 positions resolve across the volume's diagonal of \
             {diagonal:.6e} world units"
        )));
    }
    Ok(diagonal)
}

/// The largest distance from the world origin of a sample position along
/// a ray through a box of `diagonal` (with a corner at the origin) with
/// samples `step` apart: rays start at most [`NEAR_STEPS`] steps from the
/// box ([`crate::ray::EyeRay::near`]), whatever the camera, so where the
/// eye is never matters.
fn position_reach(diagonal: f64, step: f32) -> f64 {
    2.0 * diagonal + 2.0 * NEAR_STEPS * f64::from(step)
}

/// The finest step along rays of `vol` that [`frame`] accepts: at least
/// 1e-4 of the smallest voxel spacing, at most [`MAX_SAMPLES_PER_RAY`]
/// samples across the volume's diagonal, and no finer than f32 positions
/// resolve across it. `None` when the volume's extent is not finite in f32
/// (no step is accepted then).
pub fn finest_step(vol: &Volume) -> Option<f32> {
    let diagonal = vol.meta.world_diagonal()?;
    let eps = f64::from(f32::EPSILON);
    let need =
        (diagonal / MAX_SAMPLES_PER_RAY).max(2.0 * diagonal * eps / (1.0 - 2.0 * NEAR_STEPS * eps));
    let mut s = (need as f32)
        .max(f32::MIN_POSITIVE)
        .max(vol.meta.min_spacing() * 1e-4);
    // Up to the first f32 the checks (in f64) accept: `need` is within an
    // ulp or two of it.
    for _ in 0..64 {
        if step("step", s, vol).is_ok() {
            return Some(s);
        }
        s = s.next_up();
    }
    step("step", s, vol).is_ok().then_some(s)
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
