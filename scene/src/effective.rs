//! The effective scene of a resolved render: the scene file, the options
//! and the defaults resolved against the volume, as one [`Scene`], so a
//! render can be repeated from it (`--print-scene`, the `scene` key of the
//! `--json` report). Printed scenes hold absolute paths, so they can be
//! saved anywhere.

use crate::file::{Colour, LightSpec, Scene, Up};
use crate::options::{ModeArg, Options};
use glam::Vec3;
use std::path::{Path, PathBuf};
use volrender::Light;

/// `p` as an absolute path (as given when that fails).
fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// The effective scene of a resolved command line: every key the render
/// depends on, so that rendering the printed scene repeats the render.
/// `step`, `look-at`, `orbit` and `iso` are the values resolved against
/// the volume.
pub fn effective(cli: &Options, resolved: &Resolved) -> Scene {
    // As the plan reads it: the scene's text, else a preset, else a file.
    let (tf, tf_text) = match &cli.tf_text {
        Some(t) => (None, Some(t.clone())),
        None if volrender::tf::PRESETS.contains(&cli.tf.as_str()) => (Some(cli.tf.clone()), None),
        None => (
            Some(absolute(Path::new(&cli.tf)).display().to_string()),
            None,
        ),
    };
    let path = cli.mode == ModeArg::Path;
    Scene {
        volume: cli.volume.as_deref().map(absolute),
        index: cli.index.as_deref().map(absolute),
        series: cli.input.series.clone(),
        channel: cli.input.channel,
        time_point: cli.input.time_point,
        mode: Some(cli.mode),
        tf,
        tf_text,
        iso: resolved.iso,
        size: Some([cli.size.0, cli.size.1]),
        eye: cli.eye.map(|e| e.to_array()),
        look_at: Some(resolved.look_at.to_array()),
        up: Some(Up::of(cli.up)),
        orbit: resolved.orbit.map(|o| o.to_array()),
        fov: Some(cli.fov),
        ortho: cli.ortho_height.or(cli.ortho),
        step: Some(resolved.step),
        ert: Some(cli.ert),
        no_ert: Some(cli.no_ert),
        no_ess: Some(cli.no_ess),
        interp: Some(cli.interp),
        shading: Some(cli.shading),
        gradient: Some(cli.gradient),
        ambient: Some(Colour::Rgb(resolved.ambient.to_array())),
        // A path-traced scene has no headlight: its lights are the ones
        // asked for.
        lights: (!path || cli.light.is_some() || cli.lights.is_some())
            .then(|| lights(cli, resolved)),
        shadows: cli.shadows.clone(),
        shadow_step: cli.shadow_step,
        ao: cli.ao.clone(),
        ao_field: cli.ao_field.clone(),
        ao_field_cell: cli.ao_field_cell,
        // In path mode the environment shows unless a background is given.
        background: (!path || cli.background_given).then(|| cli.background.to_array()),
        alpha: Some(cli.alpha),
        output: cli.output.as_deref().map(absolute),
        hdr: cli.hdr.as_deref().map(absolute),
        heatmap: cli.heatmap.as_deref().map(absolute),
        ..path_keys(cli, resolved)
    }
}

/// The lights in a form that reads back to the same bits: a directional
/// light's direction as given (`--light` negated, which is exact; a scene
/// file's lights as written), not the resolved unit vector, whose
/// normalisation again can change its last bits.
fn lights(cli: &Options, resolved: &Resolved) -> Vec<LightSpec> {
    match (cli.light, &cli.lights) {
        (Some(towards), _) => resolved
            .lights
            .iter()
            .map(|l| match LightSpec::of(l) {
                LightSpec::Directional {
                    colour, intensity, ..
                } => LightSpec::Directional {
                    direction: (-towards).to_array(),
                    colour,
                    intensity,
                },
                other => other,
            })
            .collect(),
        (None, Some(given)) => given.clone(),
        (None, None) => resolved.lights.iter().map(LightSpec::of).collect(),
    }
}

/// The path tracer's keys, in path mode only.
fn path_keys(cli: &Options, resolved: &Resolved) -> Scene {
    if cli.mode != ModeArg::Path {
        return Scene::default();
    }
    let rgb = |v: Vec3| Colour::Rgb(v.to_array());
    Scene {
        spp: resolved.spp,
        seconds: cli.seconds,
        until_error: cli.until_error,
        bounces: Some(cli.bounces),
        g: Some(cli.g),
        hybrid: Some(cli.hybrid.clone().unwrap_or_else(|| "off".into())),
        density_scale: cli.density_scale,
        albedo: cli
            .density_scale
            .map(|_| rgb(cli.albedo.unwrap_or(Vec3::splat(0.8)))),
        sun: Some(cli.sun.clone()),
        // A map replaces the constant environment (both are refused).
        env: resolved.env.filter(|_| cli.env_map.is_none()).map(rgb),
        env_map: cli.env_map.as_deref().map(absolute),
        majorant: Some(cli.majorant.clone()),
        seed: Some(cli.seed),
        exposure: Some(cli.exposure),
        tonemap: Some(cli.tonemap),
        ..Scene::default()
    }
}

/// What the plan resolved against the volume, for [`effective`].
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    /// Sample distance.
    pub step: f32,
    /// Camera target.
    pub look_at: Vec3,
    /// Orbit, when the camera is not placed by `eye`.
    pub orbit: Option<Vec3>,
    /// Iso value (iso mode).
    pub iso: Option<f32>,
    /// Ambient light.
    pub ambient: Vec3,
    /// The lights.
    pub lights: Vec<Light>,
    /// Path tracing: samples per pixel asked for (the default filled in).
    pub spp: Option<u64>,
    /// Path tracing: the environment radiance (the default filled in).
    pub env: Option<Vec3>,
}
