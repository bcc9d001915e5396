//! A scene file under the given options: the file fills every option not
//! given (on the command line, or as a name/value pair). The file itself
//! is read and checked by [`crate::file`].
//!
//! Relative paths in a file are taken from the file's directory.

use crate::file::{Colour, Scene};
use crate::options::Options;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Fill every option of `cli` not given (`on_command_line(id)`, by clap
/// argument id: the field's name) from the scene; relative paths are
/// taken from `dir`.
pub fn apply(this: Scene, dir: &Path, cli: &mut Options, on_command_line: impl Fn(&str) -> bool) {
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
    // The input selection (one definition with every tool's flags).
    if let Some(s) = this.series {
        if !on_command_line("series") {
            cli.input.series = Some(s);
        }
    }
    if let Some(c) = this.channel {
        if !on_command_line("channel") && !on_command_line("luma") {
            cli.input.channel = Some(c);
        }
    }
    if let Some(t) = this.time_point {
        if !on_command_line("time_point") {
            cli.input.time_point = Some(t);
        }
    }
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
    set!(seconds, "seconds", Some);
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
    if !on_command_line("tf") && !on_command_line("tf_text") {
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
    if !on_command_line("light") && !on_command_line("lights") && this.lights.is_some() {
        cli.lights = this.lights;
    }
}
