//! Scene files: everything one render needs, in TOML. Their keys are
//! vol-render's flags by their long names (`look-at = [0, 0, 0]` is
//! `--look-at 0,0,0`, `volume` the positional argument), each value read
//! through clap as the flag's text would be ([`crate::args`] turns a
//! value into that text), so the options have one definition
//! ([`crate::options`]): a new flag is a key, with the flag's parser,
//! default and checks. What no flag says is all a [`Scene`] keeps apart:
//! `[[lights]]` and `tf-text`.
//!
//! This module reads, checks and writes the file; [`crate::merge`] puts
//! it under the options given.

use crate::args::{arg_of, command_args, key_of};
use crate::error::{Error, Result};
use crate::lights::LightSpec;
use crate::options::Options;
use clap::error::ErrorKind as ClapKind;
use clap::{Arg, Command, CommandFactory};
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::Path;

/// The keys no flag says: read as tables and text, not through clap
/// (the ids of [`crate::pairs::SCENE_ONLY`] as keys).
const SCENE_ONLY_KEYS: [&str; 2] = ["lights", "tf-text"];

/// Options a scene file may not hold (by id): a scene inside a scene,
/// and printing one.
const NOT_KEYS: [&str; 2] = ["scene", "print_scene"];

/// A scene: option values under the flags' long names, and what no flag
/// says.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// The options in the file's order, each under its flag's long name
    /// (`look-at`; the positional `volume`), its value as written (in
    /// JSON's data model: TOML and JSON scenes hold the same values).
    pub options: Vec<(String, Value)>,
    /// Transfer-function text written in the scene (instead of `tf`).
    pub tf_text: Option<String>,
    /// The lights (none given: a headlight).
    pub lights: Option<Vec<LightSpec>>,
}

/// The keys no flag says, read with serde where the TOML parser still
/// knows lines (the other keys are ignored here).
#[derive(Deserialize)]
struct SceneOnly {
    #[serde(default)]
    lights: Option<Vec<LightSpec>>,
    #[serde(default, rename = "tf-text")]
    tf_text: Option<String>,
}

impl Scene {
    /// Read and check the scene file at `path`.
    pub fn read(path: &Path) -> Result<Scene> {
        let name = volcore::text::escape(&path.display().to_string());
        let text = match std::fs::read(path) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(t) => t,
                Err(_) => return Err(Error::file(format!("{name}: not a UTF-8 text file"))),
            },
            Err(e) => return Err(Error::file(format!("{name}: {e}"))),
        };
        Scene::parse(&text).map_err(|e| Error::file(format!("{name}: {e}")))
    }

    /// Parse scene text; an error says where (line and key) and what.
    pub fn parse(text: &str) -> std::result::Result<Scene, String> {
        let table: toml::Table = toml::from_str(text).map_err(|e| describe(text, &e))?;
        let only: SceneOnly = toml::from_str(text).map_err(|e| describe(text, &e))?;
        let mut entries: Vec<(usize, String, Value)> = Vec::new();
        for (key, value) in table {
            if SCENE_ONLY_KEYS.contains(&key.as_str()) {
                continue;
            }
            let value = json_of(&value).map_err(|what| at_key(text, &key, &what))?;
            entries.push((key_line(text, &key).unwrap_or(usize::MAX), key, value));
        }
        // The file's order (the table's is by name).
        entries.sort_by_key(|(line, _, _)| *line);
        let scene = Scene {
            options: entries.into_iter().map(|(_, k, v)| (k, v)).collect(),
            tf_text: only.tf_text,
            lights: only.lights,
        };
        scene.check().map_err(|(key, what)| match key {
            Some(key) => at_key(text, &key, &what),
            None => what,
        })?;
        Ok(scene)
    }

    /// The value given for the option with this key (`look-at`).
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.options.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    /// Check every key and value as the command line checks its flag,
    /// the lights, and the keys that exclude each other; an error is
    /// the key at fault, when there is one, and what is wrong.
    pub fn check(&self) -> std::result::Result<(), (Option<String>, String)> {
        let cmd = Options::command();
        for (key, value) in &self.options {
            let fail = |what: String| (Some(key.clone()), what);
            if key == "time" {
                return Err(fail("key `time` is gone: use `seconds` for the path-tracing time budget (vol-render --seconds); the volume's time point is vol-render's --time-point".into()));
            }
            let arg = match arg_of(&cmd, key) {
                Some(a) if !a.is_hide_set() && !NOT_KEYS.contains(&a.get_id().as_str()) => a,
                _ => return Err(fail(format!("unknown key `{}`", shown(key)))),
            };
            check_value(&cmd, arg, value).map_err(fail)?;
        }
        if let Some(lights) = &self.lights {
            for (i, l) in lights.iter().enumerate() {
                l.light().map_err(|e| (None, format!("lights[{i}]: {e}")))?;
            }
        }
        if self.tf_text.is_some() && self.get("tf").is_some() {
            return Err((None, "give `tf` or `tf-text`, not both".into()));
        }
        if self.lights.is_some() && self.get("light").is_some() {
            return Err((None, "give `light` or `lights`, not both".into()));
        }
        Ok(())
    }
}

/// Check one option's value as clap checks its flag's: the value alone
/// on a command line, with the errors that need other options (what it
/// requires or conflicts with) left to the whole scene's parse.
fn check_value(cmd: &Command, arg: &Arg, value: &Value) -> std::result::Result<(), String> {
    let key = key_of(arg);
    let (args, _) =
        command_args(cmd, [(key.as_str(), value.clone())]).map_err(|e| e.message().to_string())?;
    let argv = std::iter::once("vol-render".to_string()).chain(args);
    match cmd.clone().try_get_matches_from(argv) {
        Ok(_) => Ok(()),
        Err(e)
            if matches!(
                e.kind(),
                ClapKind::MissingRequiredArgument | ClapKind::ArgumentConflict
            ) =>
        {
            Ok(())
        }
        Err(e) => Err(crate::error::clap_message(&e)),
    }
}

/// A TOML value in JSON's data model; NaN, infinities and dates are
/// refused (no flag takes them, and a printed scene could not hold them).
pub fn json_of(v: &toml::Value) -> std::result::Result<Value, String> {
    Ok(match v {
        toml::Value::String(s) => Value::String(s.clone()),
        toml::Value::Integer(i) => Value::from(*i),
        toml::Value::Float(f) => match serde_json::Number::from_f64(*f) {
            Some(n) => Value::Number(n),
            None => return Err("must be a finite number".into()),
        },
        toml::Value::Boolean(b) => Value::Bool(*b),
        toml::Value::Array(items) => Value::Array(
            items
                .iter()
                .map(json_of)
                .collect::<std::result::Result<_, _>>()?,
        ),
        toml::Value::Table(t) => Value::Object(
            t.iter()
                .map(|(k, v)| Ok((k.clone(), json_of(v)?)))
                .collect::<std::result::Result<_, String>>()?,
        ),
        toml::Value::Datetime(_) => return Err("a date is no option's value".into()),
    })
}

/// The line (from 1) where `key` is set at the top of `text`.
fn key_line(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            l.split_once('=').is_some_and(|(k, _)| {
                let k = k.trim();
                k == key || k.trim_matches('"') == key || k.trim_matches('\'') == key
            })
        })
        .map(|i| i + 1)
}

/// `what` is wrong with `key`, as `line N, key `k`: what`.
fn at_key(text: &str, key: &str, what: &str) -> String {
    match key_line(text, key) {
        Some(n) => format!("line {n}, key `{}`: {what}", shown(key)),
        None => format!("key `{}`: {what}", shown(key)),
    }
}

/// A key as an error shows it: escaped and clipped.
fn shown(key: &str) -> String {
    volcore::text::clip(&volcore::text::escape(key), 40)
}

/// A TOML or type error as `line N, key `k`: what` (the key as written on
/// that line, when there is one).
fn describe(text: &str, e: &toml::de::Error) -> String {
    let what = e.message();
    // serde's list of expected keys is long: the key is what matters.
    let what = match what.split_once(", expected one of") {
        Some((head, _)) => head.replace("unknown field", "unknown key"),
        None => what.to_string(),
    };
    let what = volcore::text::clip(&volcore::text::escape(&what), 160);
    let Some(span) = e.span() else {
        return what;
    };
    let start = span.start.min(text.len());
    let line_no = text[..start].matches('\n').count() + 1;
    let line = text.lines().nth(line_no - 1).unwrap_or("");
    match line.split_once('=') {
        Some((key, _)) if !key.trim().is_empty() && !key.trim_start().starts_with('[') => {
            format!("line {line_no}, key `{}`: {what}", shown(key.trim()))
        }
        // Errors inside a light point at its table (serde reads tagged
        // tables whole).
        _ if line.trim_start().starts_with('[') => {
            let table = volcore::text::clip(&volcore::text::escape(line.trim()), 40);
            format!("line {line_no}, table `{table}`: {what}")
        }
        _ => format!("line {line_no}: {what}"),
    }
}

/// A scene is a map: the options in order, then `tf-text` and the lights
/// (TOML writes tables last).
impl Serialize for Scene {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let extra = usize::from(self.tf_text.is_some()) + usize::from(self.lights.is_some());
        let mut map = s.serialize_map(Some(self.options.len() + extra))?;
        for (k, v) in &self.options {
            map.serialize_entry(k, v)?;
        }
        if let Some(t) = &self.tf_text {
            map.serialize_entry("tf-text", t)?;
        }
        if let Some(l) = &self.lights {
            map.serialize_entry("lights", l)?;
        }
        map.end()
    }
}

/// The scene as TOML text.
pub fn to_toml(scene: &Scene) -> Result<String> {
    toml::to_string(scene).map_err(|e| Error::option(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Colour;
    use glam::Vec3;
    use serde_json::json;
    use volrender::Light;

    #[test]
    fn keys_and_lights_parse() {
        let s = Scene::parse(
            r#"
volume = "a.vvol"
mode = "dvr"
size = [64, 32]
look-at = [1, 2, 3]
ambient = 0.2
[[lights]]
type = "directional"
direction = [0, -1, 0]
colour = [1, 0.5, 0.25]
intensity = 2
[[lights]]
type = "point"
position = [10, 10, 10]
"#,
        )
        .unwrap();
        assert_eq!(s.get("size"), Some(&json!([64, 32])));
        assert_eq!(s.get("look-at"), Some(&json!([1, 2, 3])));
        let keys: Vec<&str> = s.options.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(keys, ["volume", "mode", "size", "look-at", "ambient"]);
        let lights = s.lights.unwrap();
        assert_eq!(lights.len(), 2);
        match lights[0].light().unwrap() {
            // Travelling down: towards the light is up.
            Light::Directional { towards, radiance } => {
                assert_eq!(towards, Vec3::Y);
                assert_eq!(radiance, Vec3::new(2.0, 1.0, 0.5));
            }
            l => panic!("{l:?}"),
        }
        assert!(matches!(lights[1].light().unwrap(), Light::Point { .. }));
    }

    #[test]
    fn errors_name_the_line_and_the_key() {
        let e = Scene::parse("mode = \"dvr\"\nfov = \"wide\"\n").unwrap_err();
        assert!(
            e.starts_with("line 2, key `fov`: invalid value 'wide' for '--fov"),
            "{e}"
        );
        let e = Scene::parse("mode = \"dvr\"\n\nfovv = 3\n").unwrap_err();
        assert_eq!(e, "line 3, key `fovv`: unknown key `fovv`");
        // Keys are the flags' names, not the fields'.
        let e = Scene::parse("look_at = [0, 0, 0]\n").unwrap_err();
        assert_eq!(e, "line 1, key `look_at`: unknown key `look_at`");
        let e = Scene::parse("scene = \"other.toml\"\n").unwrap_err();
        assert_eq!(e, "line 1, key `scene`: unknown key `scene`");
        let e = Scene::parse("mode = \"sideways\"\n").unwrap_err();
        assert!(
            e.starts_with("line 1, key `mode`: invalid value 'sideways'"),
            "{e}"
        );
        let e = Scene::parse("[[lights]]\ntype = \"point\"\nposition = [0, 0]\n").unwrap_err();
        assert_eq!(
            e,
            "line 1, table `[[lights]]`: invalid length 2, expected an array of length 3"
        );
        let e = Scene::parse("[[lights]]\ntype = \"laser\"\n").unwrap_err();
        assert!(e.contains("laser"), "{e}");
        let e = Scene::parse("[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 0]\n")
            .unwrap_err();
        assert_eq!(e, "lights[0]: direction must be a finite, non-zero vector");
        let e = Scene::parse("[[lights]]\ntype = \"headlight\"\nbrightness = 2\n").unwrap_err();
        assert!(e.contains("brightness"), "{e}");
        let e = Scene::parse("size = [0, 10]\n").unwrap_err();
        assert!(
            e.starts_with("line 1, key `size`: invalid value '0,10'"),
            "{e}"
        );
        let e = Scene::parse("fov = nan\n").unwrap_err();
        assert_eq!(e, "line 1, key `fov`: must be a finite number");
        let e = Scene::parse("step = -inf\n").unwrap_err();
        assert_eq!(e, "line 1, key `step`: must be a finite number");
        let e = Scene::parse("eye = [1, 2,\n").unwrap_err();
        assert!(e.starts_with("line "), "{e}");
        let e = Scene::parse("tf = \"ct\"\ntf-text = \"domain 0 1\"\n").unwrap_err();
        assert_eq!(e, "give `tf` or `tf-text`, not both");
        let e = Scene::parse("time = 3\n").unwrap_err();
        assert!(e.contains("`seconds`"), "{e}");
    }

    #[test]
    fn a_printed_scene_reads_back_the_same() {
        let s = Scene {
            options: vec![
                ("volume".into(), json!("/data/a.vvol")),
                ("mode".into(), json!("iso")),
                ("iso".into(), json!(0.1)),
                ("size".into(), json!([7, 9])),
                ("orbit".into(), json!([30.0, 20.0, 1.0e-3])),
                ("ambient".into(), json!([0.25, 0.25, 0.25])),
                ("sun".into(), json!(["-1,-1.2,0.4:4"])),
                ("no-ert".into(), json!(true)),
            ],
            lights: Some(vec![
                LightSpec::of(&Light::HEADLIGHT),
                LightSpec::of(&Light::Point {
                    position: Vec3::new(1.0, 2.0, 3.0),
                    intensity: Vec3::splat(1.0e6),
                }),
                LightSpec::Headlight {
                    colour: Some(Colour::Grey(0.5)),
                    intensity: None,
                },
            ]),
            tf_text: Some("domain 0 1\npoint 0 0 0 0 0\n".into()),
        };
        let text = to_toml(&s).unwrap();
        assert_eq!(Scene::parse(&text).unwrap(), s, "{text}");
    }

    /// Every option but the few that make no sense in a file is a key,
    /// under its flag's name, and the field's name is the flag's (so the
    /// printed scene, serialised by field, writes the flags' names).
    #[test]
    fn every_option_is_a_key_under_its_flags_name() {
        let cmd = Options::command();
        for arg in cmd.get_arguments().filter(|a| !a.is_hide_set()) {
            let id = arg.get_id().as_str();
            if let Some(long) = arg.get_long() {
                assert_eq!(long.replace('-', "_"), id, "--{long}");
            }
            let key = key_of(arg);
            let found = arg_of(&cmd, &key).map(|a| a.get_id().as_str());
            assert_eq!(found, Some(id), "{key}");
        }
    }
}
