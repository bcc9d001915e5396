//! The effective scene of a resolved render: the scene file, the options
//! and the defaults resolved against the volume, as one [`Scene`], so a
//! render can be repeated from it (`--print-scene`, the `scene` key of the
//! `--json` report). Printed scenes hold absolute paths, so they can be
//! saved anywhere.
//!
//! The options are serialised by their one definition ([`Options`]):
//! every option is written under its flag's name, in `--help`'s order,
//! except those [`NOT_PRINTED`] and, outside `--mode path`, the path
//! tracer's.

use crate::args::key_of;
use crate::error::{Error, Result};
use crate::file::Scene;
use crate::lights::LightSpec;
use crate::options::{ModeArg, Options, NOT_PRINTED, PATH_HEADING};
use clap::{CommandFactory, ValueHint};
use glam::Vec3;
use serde::Serialize;
use serde_json::{Map, Value};
#[cfg(test)]
use std::path::Path;
use volrender::Light;

/// `p` as an absolute path (as given when that fails).
fn absolute(p: &str) -> String {
    std::path::absolute(p).map_or_else(|_| p.to_string(), |a| a.display().to_string())
}

/// `v` as JSON, numbers in their shortest form (an f32 `0.1` is written
/// `0.1`, which reads back to the same f32, not as the f64 it widens to).
fn json<T: Serialize + ?Sized>(v: &T) -> Result<Value> {
    let text = serde_json::to_string(v).map_err(|e| Error::option(e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| Error::option(e.to_string()))
}

/// The effective scene of resolved options: every key the render depends
/// on, so that rendering the printed scene repeats the render. `step`,
/// `look-at`, `orbit`, `iso`, `ambient`, the lights and, in path mode,
/// `spp` and `env` are the values resolved against the volume.
pub fn effective(cli: &Options, resolved: &Resolved) -> Result<Scene> {
    let path = cli.mode == ModeArg::Path;
    let Value::Object(mut values) = json(cli)? else {
        return Err(Error::option("the options do not serialise to a table"));
    };
    resolve(&mut values, cli, resolved)?;
    let defaults = match json(&Options::defaults())? {
        Value::Object(d) => d,
        _ => Map::new(),
    };
    let mut options = Vec::new();
    for arg in Options::command().get_arguments() {
        let id = arg.get_id().as_str();
        let heading = arg.get_help_heading();
        if NOT_PRINTED.contains(&id) || (!path && heading == Some(PATH_HEADING)) {
            continue;
        }
        let Some(value) = values.remove(id).filter(|v| !v.is_null()) else {
            continue;
        };
        // How to read the file: only what differs from the defaults
        // (raw layout flags on any input would be noise).
        if heading == Some("Input") && defaults.get(id) == Some(&value) {
            continue;
        }
        let value = match value {
            Value::String(p) if arg.get_value_hint() == ValueHint::AnyPath => {
                Value::String(absolute(&p))
            }
            v => v,
        };
        options.push((key_of(arg), value));
    }
    // A path-traced scene has no headlight: its lights are the ones asked
    // for.
    let lights =
        (!path || cli.light.is_some() || cli.lights.is_some()).then(|| lights(cli, resolved));
    Ok(Scene {
        options,
        tf_text: cli.tf_text.clone(),
        lights,
    })
}

/// Put the values the plan resolved in place of the options' own.
fn resolve(values: &mut Map<String, Value>, cli: &Options, resolved: &Resolved) -> Result<()> {
    let mut set = |id: &str, v: Value| {
        values.insert(id.to_string(), v);
    };
    set("step", json(&resolved.step)?);
    set("look_at", json(&resolved.look_at)?);
    set("orbit", json(&resolved.orbit)?);
    set("iso", json(&resolved.iso)?);
    set("ambient", json(&resolved.ambient)?);
    set("ortho", json(&cli.ortho_height.or(cli.ortho))?);
    // As the plan reads it: the scene's text, else a preset, else a file.
    let tf = match &cli.tf_text {
        Some(_) => Value::Null,
        None if crate::options::is_preset(&cli.tf) => Value::String(cli.tf.clone()),
        None => Value::String(absolute(&cli.tf)),
    };
    set("tf", tf);
    if cli.mode == ModeArg::Path {
        set("spp", json(&resolved.spp)?);
        // A map replaces the constant environment (both are refused).
        let env = resolved.env.filter(|_| cli.env_map.is_none());
        set("env", json(&env)?);
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::Request;
    use clap::ArgAction;

    /// A value other than the default for every option a scene prints
    /// (empty: a flag without a value). An option missing here fails
    /// [`every_printed_option_reads_back`]: add it, and it is tested.
    const SAMPLES: [(&str, &str); 64] = [
        ("volume", "/d/v.raw"),
        ("raw_dims", "4x5x6"),
        ("raw_type", "u16"),
        ("raw_endian", "big"),
        ("raw_skip", "8"),
        ("series", "2"),
        ("channel", "1"),
        ("time_point", "3"),
        ("echo", "2"),
        ("philips_scale", "precise"),
        ("level", "2"),
        ("output", "/d/o.png"),
        ("index", "/d/v.vidx"),
        ("tf", "/d/t.tf"),
        ("mode", "xray-mean"),
        ("iso", "0.3"),
        ("size", "30x20"),
        ("eye", "1,2,3"),
        ("look_at", "0.1,0.2,0.3"),
        ("up", "patient"),
        ("orbit", "10,20,30"),
        ("fov", "33.3"),
        ("ortho", "5"),
        ("ortho_height", "6"),
        ("step", "0.1"),
        ("ert", "0.9"),
        ("no_ert", ""),
        ("no_ess", ""),
        ("interp", "nearest"),
        ("preintegrated", ""),
        ("adaptive", "0.02"),
        ("budget", "0.25"),
        ("shading", "phong"),
        ("gradient", "analytic"),
        ("light", "1,-2,3"),
        ("ambient", "0.1,0.2,0.3"),
        ("shadows", "grid:4"),
        ("shadow_step", "0.7"),
        ("ao", "8:2.5"),
        ("ao_field", "16"),
        ("ao_field_cell", "4"),
        ("background", "10,20,30"),
        ("alpha", ""),
        ("hdr", "/d/h.pfm"),
        ("heatmap", "/d/m.png"),
        ("spp", "5"),
        ("seconds", "1.5"),
        ("until_error", "0.01"),
        ("bounces", "3"),
        ("g", "-0.3"),
        ("hybrid", "10"),
        ("density_scale", "0.2"),
        ("albedo", "0.5"),
        ("sun", "-1,-1,0:2"),
        ("env", "0.3"),
        ("env_map", "/d/e.exr"),
        ("majorant", "global"),
        ("seed", "7"),
        ("sampler", "hash"),
        ("transmittance", "ratio"),
        ("exposure", "2"),
        ("tonemap", "aces"),
        ("ortho", "0"),
        ("tf", "auto:2"),
    ];

    /// The options `args` give, with the values a plan resolves filled
    /// in (as a plan would), and what it resolved.
    fn resolved(args: &[String]) -> (Options, Resolved) {
        let mut o = Request::parse(args).unwrap().into_options();
        o.step = Some(o.step.unwrap_or(0.5));
        o.look_at = Some(o.look_at.unwrap_or(Vec3::ZERO));
        if o.eye.is_none() {
            o.orbit = Some(o.orbit.unwrap_or(Vec3::new(30.0, 20.0, 4.0)));
        }
        o.ambient = Some(o.ambient.unwrap_or(Vec3::splat(0.25)));
        let r = Resolved {
            step: o.step.unwrap_or_default(),
            look_at: o.look_at.unwrap_or_default(),
            orbit: o.orbit,
            iso: o.iso,
            ambient: o.ambient.unwrap_or_default(),
            lights: o.light.and_then(Light::directional).into_iter().collect(),
            spp: o.spp,
            env: o.env,
        };
        (o, r)
    }

    /// The options as a printed scene holds them (`--ortho-height` is
    /// `ortho`, `--light` is in `lights`).
    fn comparable(o: &Options) -> Value {
        let mut o = o.clone();
        o.ortho = o.ortho_height.take().or(o.ortho);
        let Ok(Value::Object(mut m)) = json(&o) else {
            panic!("options serialise");
        };
        for id in NOT_PRINTED {
            m.remove(id);
        }
        Value::Object(m)
    }

    /// `--print-scene` repeats every option: each one given on a command
    /// line, printed, read back as a scene file, gives the same options.
    #[test]
    fn every_printed_option_reads_back() {
        let cmd = Options::command();
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            // Printed in another form: `lights`, `ortho`.
            let other_form = ["light", "ortho_height"].contains(&id);
            if (NOT_PRINTED.contains(&id) && !other_form) || arg.is_hide_set() {
                continue;
            }
            let samples: Vec<&str> = SAMPLES
                .iter()
                .filter(|(s, _)| *s == id)
                .map(|(_, v)| *v)
                .collect();
            assert!(!samples.is_empty(), "no sample value for --{id}: add one");
            for value in samples {
                let mut args = Vec::new();
                if arg.get_help_heading() == Some(PATH_HEADING) {
                    args.push("--mode=path".to_string());
                }
                if id == "ao_field_cell" {
                    args.push("--ao-field=8".into());
                }
                match (arg.get_long(), arg.get_action()) {
                    (None, _) => args.extend(["--".into(), value.into()]),
                    (Some(l), ArgAction::SetTrue) => args.push(format!("--{l}")),
                    (Some(l), _) => args.push(format!("--{l}={value}")),
                }
                let (want, r) = resolved(&args);
                let scene = effective(&want, &r).unwrap();
                let text = to_toml_text(&scene);
                let read = Scene::parse(&text).unwrap_or_else(|e| panic!("{args:?}: {e}\n{text}"));
                let got = Request::parse(Vec::<String>::new())
                    .unwrap()
                    .with_scene(read, Path::new("/elsewhere/s.toml"))
                    .unwrap_or_else(|e| panic!("{args:?}: {e}\n{text}"))
                    .into_options();
                assert_eq!(comparable(&got), comparable(&want), "{args:?}\n{text}");
                if id == "light" {
                    assert_eq!(got.lights.map(|l| l.len()), Some(1), "{text}");
                }
            }
        }
    }

    /// A scene at the defaults still names every option a default
    /// decides (`mode`, `size`, `fov`...), so a later change of a default
    /// does not change what a printed scene renders.
    #[test]
    fn a_default_scene_prints_every_option_that_has_a_default() {
        let (o, r) = resolved(&["--".to_string(), "/d/v.vvol".to_string()]);
        let scene = effective(&o, &r).unwrap();
        // The input flags are printed when they differ from the defaults.
        let input = <volformats::Selection as clap::Args>::augment_args(clap::Command::new("i"));
        let is_input = |id: &str| input.get_arguments().any(|a| a.get_id() == id);
        for arg in Options::command().get_arguments() {
            let id = arg.get_id().as_str();
            let skip = NOT_PRINTED.contains(&id)
                || is_input(id)
                || arg.get_help_heading() == Some(PATH_HEADING)
                || arg.get_default_values().is_empty();
            if !skip {
                let key = key_of(arg);
                assert!(scene.get(&key).is_some(), "`{key}` is not printed");
            }
        }
    }

    fn to_toml_text(scene: &Scene) -> String {
        crate::file::to_toml(scene).unwrap()
    }
}
