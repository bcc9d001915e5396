//! Scene files in vol-render: the file fills every option not given on
//! the command line, and `--print-scene` writes the effective scene,
//! defaults resolved, so a render can be repeated from its output. The
//! file itself is read and checked by [`volkit_cli::scene`].
//!
//! Relative paths in a file are taken from the file's directory; printed
//! scenes hold absolute paths, so they can be saved anywhere.

use crate::args::Cli;
use glam::Vec3;
use std::path::{Path, PathBuf};
use volkit_cli::scene::{Colour, LightSpec, Scene, Up};
use volrender::Light;

/// Fill every option of `cli` not given on the command line
/// (`on_command_line(id)`, by clap argument id) from the scene;
/// relative paths are taken from `dir`.
pub fn apply(this: Scene, dir: &Path, cli: &mut Cli, on_command_line: impl Fn(&str) -> bool) {
    let path = |p: PathBuf| if p.is_relative() { dir.join(p) } else { p };
    macro_rules! set {
        ($field:ident, $id:literal, $conv:expr) => {
            if let Some(v) = this.$field {
                if !on_command_line($id) {
                    cli.$field = $conv(v);
                }
            }
        };
    }
    let v3 = |v: [f32; 3]| Vec3::from(v);
    set!(volume, "volume", |p| Some(path(p)));
    set!(output, "output", |p| Some(path(p)));
    set!(index, "index", |p| Some(path(p)));
    set!(mode, "mode", |m| m);
    set!(iso, "iso", Some);
    set!(size, "size", |[w, h]: [u32; 2]| (w, h));
    if let Some(up) = this.up.as_ref().and_then(|u| u.arg().ok()) {
        if !on_command_line("up") {
            cli.up = up;
        }
    }
    set!(look_at, "look_at", |v| Some(v3(v)));
    // The command line's camera position wins whichever form it takes.
    if !on_command_line("eye") && !on_command_line("orbit") {
        cli.eye = this.eye.map(v3);
        cli.orbit = this.orbit.map(v3);
    }
    set!(fov, "fov", |f| f);
    set!(ortho, "ortho", Some);
    set!(step, "step", Some);
    set!(ert, "ert", |e| e);
    set!(no_ert, "no_ert", |b| b);
    set!(no_ess, "no_ess", |b| b);
    set!(interp, "interp", |i| i);
    set!(shading, "shading", |s| s);
    set!(gradient, "gradient", |g| g);
    set!(background, "background", v3);
    if this.background.is_some() {
        cli.background_given = true;
    }
    set!(alpha, "alpha", |b| b);
    set!(hdr, "hdr", |p| Some(path(p)));
    set!(heatmap, "heatmap", |p| Some(path(p)));
    set!(ambient, "ambient", |a: Colour| Some(a.rgb()));
    set!(shadows, "shadows", Some);
    set!(shadow_step, "shadow_step", Some);
    set!(ao, "ao", Some);
    set!(ao_field, "ao_field", Some);
    set!(ao_field_cell, "ao_field_cell", Some);
    set!(spp, "spp", Some);
    set!(time, "time", Some);
    set!(until_error, "until_error", Some);
    set!(bounces, "bounces", |b| b);
    set!(g, "g", |g| g);
    set!(hybrid, "hybrid", Some);
    set!(density_scale, "density_scale", Some);
    set!(albedo, "albedo", |a: Colour| Some(a.rgb()));
    set!(sun, "sun", |v| v);
    set!(env, "env", |c: Colour| Some(c.rgb()));
    set!(env_map, "env_map", |p| Some(path(p)));
    set!(majorant, "majorant", |m| m);
    set!(seed, "seed", |s| s);
    set!(exposure, "exposure", |e| e);
    set!(tonemap, "tonemap", |t| t);
    // The command line's transfer function wins whichever form it takes.
    if !on_command_line("tf") {
        match (this.tf, this.tf_text) {
            (Some(tf), _) => {
                // A preset's name as is (presets come first, as in
                // the plan); else a file next to the scene.
                cli.tf = if volrender::tf::PRESETS.contains(&tf.as_str()) {
                    tf
                } else {
                    path(PathBuf::from(&tf)).display().to_string()
                };
            }
            (None, Some(text)) => cli.tf_text = Some(text),
            (None, None) => {}
        }
    }
    // `--light` stands for one directional light; else the scene's.
    if !on_command_line("light") && this.lights.is_some() {
        cli.lights = this.lights;
    }
}

/// `p` as an absolute path (as given when that fails).
fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// The effective scene of a resolved command line: every key the render
/// depends on, so that rendering the printed scene repeats the render.
/// `step`, `look-at`, `orbit` and `iso` are the values resolved against
/// the volume.
pub fn effective(cli: &Cli, resolved: &Resolved) -> Scene {
    // As the plan reads it: the scene's text, else a preset, else a file.
    let (tf, tf_text) = match &cli.tf_text {
        Some(t) => (None, Some(t.clone())),
        None if volrender::tf::PRESETS.contains(&cli.tf.as_str()) => (Some(cli.tf.clone()), None),
        None => (
            Some(absolute(Path::new(&cli.tf)).display().to_string()),
            None,
        ),
    };
    let path = cli.mode == volkit_cli::scene::ModeArg::Path;
    Scene {
        volume: cli.volume.as_deref().map(absolute),
        index: cli.index.as_deref().map(absolute),
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
            .then(|| resolved.lights.iter().map(LightSpec::of).collect()),
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

/// The path tracer's keys, in path mode only.
fn path_keys(cli: &Cli, resolved: &Resolved) -> Scene {
    if cli.mode != volkit_cli::scene::ModeArg::Path {
        return Scene::default();
    }
    let rgb = |v: Vec3| Colour::Rgb(v.to_array());
    Scene {
        spp: resolved.spp,
        time: cli.time,
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
