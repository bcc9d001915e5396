//! A frame's figures for the cost panel: the time, the samples taken,
//! and the fraction a plain march would have taken that empty-space
//! skipping and early ray termination saved.

use serde_json::{json, Value};
use volrender::ray::intersect_box;
use volrender::Camera;
use volscene::{Image, Rendered};

/// Every how many pixels, across and down, a ray is cast to estimate
/// the plain march's samples.
const STRIDE: u32 = 4;

/// The cost panel's figures for `rendered`: `render_s`, `samples`, and
/// for a ray-cast frame `skipped_fraction` (1 − samples / the samples of
/// a plain march through the volume's box at `step`, estimated from a
/// ray every [`STRIDE`] pixels); for path tracing `spp`,
/// `relative_error` and the empty majorant cells' fraction.
pub fn figures(rendered: &Rendered, camera: &Camera, extent: [f32; 3], step: f32) -> Value {
    match &rendered.image {
        Image::Frame(f) => {
            let plain = plain_samples(camera, extent, step);
            let skipped = if plain > 0.0 {
                (1.0 - f.stats.samples as f64 / plain).clamp(0.0, 1.0)
            } else {
                0.0
            };
            json!({
                "render_s": rendered.times.render_s,
                "samples": f.stats.samples,
                "rays": f.stats.rays,
                "skips": f.stats.skips,
                "plain_samples": plain.round(),
                "skipped_fraction": skipped,
            })
        }
        Image::Path(t) => json!({
            "render_s": rendered.times.render_s,
            "spp": t.acc.spp(),
            "paths": t.counters.paths,
            "samples": t.counters.density_lookups,
            "relative_error": t.acc.relative_error(),
            "skipped_fraction": t.empty_fraction,
        }),
    }
}

/// The samples a march without skipping or termination would take: the
/// length of each ray inside the box over `step`, from a ray every
/// [`STRIDE`] pixels, scaled to the whole image.
pub fn plain_samples(camera: &Camera, extent: [f32; 3], step: f32) -> f64 {
    if step.is_nan() || step <= 0.0 {
        return 0.0;
    }
    let (lo, hi) = (glam::Vec3::ZERO, glam::Vec3::from(extent));
    let mut total = 0.0f64;
    let mut rays = 0u64;
    for y in (0..camera.height()).step_by(STRIDE as usize) {
        for x in (0..camera.width()).step_by(STRIDE as usize) {
            rays += 1;
            let ray = camera.ray(x, y).rounded();
            if let Some((t0, t1)) = intersect_box(&ray, lo, hi) {
                let len = (t1 - t0.max(0.0)).max(0.0);
                total += (len / step).floor() as f64 + 1.0;
            }
        }
    }
    let pixels = camera.width() as f64 * camera.height() as f64;
    if rays == 0 {
        0.0
    } else {
        total * pixels / rays as f64
    }
}
