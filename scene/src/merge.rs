//! A scene file under the given options: the file's options that were
//! not given become the arguments that say them, for one clap parse with
//! the given ones ([`crate::Request::with_scene`]). The file itself is
//! read and checked by [`crate::file`].
//!
//! Relative paths in a file are taken from the file's directory.

use crate::args::{arg_of, command_args};
use crate::error::Result;
use crate::file::Scene;
use crate::options::Options;
use clap::{Arg, Command, CommandFactory, ValueHint};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::Path;

/// The scene file's options as arguments.
#[derive(Clone, Debug, Default)]
pub struct Under {
    /// Flags (`--look-at=0,0,0`).
    pub flags: Vec<String>,
    /// The positional argument (the volume), when the file gives it.
    pub positional: Vec<String>,
    /// The files the scene names, by key, as resolved (`volume`,
    /// `/data/a.vvol`), so errors about them can name the scene too.
    pub paths: Vec<(String, String)>,
}

/// The arguments that say the options of `scene` that the options with
/// ids in `given` leave open: neither given nor excluded by one given
/// (a given `--orbit` overrides the file's `eye`, a given `--tf-text`
/// pair its `tf`). Relative paths are taken from `dir`.
pub fn under(scene: &Scene, dir: &Path, given: &BTreeSet<String>) -> Result<Under> {
    let cmd = Options::command();
    let mut pairs = Vec::new();
    for (key, value) in &scene.options {
        // The file was checked: every key is an option's.
        let Some(arg) = arg_of(&cmd, key) else {
            continue;
        };
        if overridden(&cmd, arg, given) {
            continue;
        }
        pairs.push((key.clone(), from_dir(arg, value, dir)));
    }
    let mut out = Under::default();
    for (key, value) in &pairs {
        let is_path = arg_of(&cmd, key).is_some_and(|a| names_file(a, value));
        if let (true, Value::String(p)) = (is_path, value) {
            out.paths.push((key.clone(), p.clone()));
        }
    }
    let (mut flags, _) = command_args(&cmd, pairs)?;
    if let Some(at) = flags.iter().position(|a| a == "--") {
        out.positional = flags.split_off(at + 1);
        flags.pop();
    }
    out.flags = flags;
    Ok(out)
}

/// Whether an option given overrides `arg`'s value in a scene file: it
/// is `arg`, or excludes it (clap's conflicts, both ways; `tf` and
/// `tf-text`).
fn overridden(cmd: &Command, arg: &Arg, given: &BTreeSet<String>) -> bool {
    let id = arg.get_id().as_str();
    if given.contains(id) || (id == "tf" && given.contains("tf_text")) {
        return true;
    }
    given.iter().any(|g| {
        cmd.get_arguments()
            .find(|a| a.get_id().as_str() == g)
            .is_some_and(|other| conflicts(cmd, arg, other) || conflicts(cmd, other, arg))
    })
}

/// Whether clap refuses `a` with `b`.
fn conflicts(cmd: &Command, a: &Arg, b: &Arg) -> bool {
    cmd.get_arg_conflicts_with(a)
        .iter()
        .any(|c| c.get_id() == b.get_id())
}

/// A file's value as the flag takes it: a relative path (an option whose
/// value is a path, or a `tf` that is not a preset) from `dir`.
fn from_dir(arg: &Arg, value: &Value, dir: &Path) -> Value {
    match value {
        Value::String(p) if names_file(arg, value) && Path::new(p).is_relative() => {
            Value::String(dir.join(p).display().to_string())
        }
        other => other.clone(),
    }
}

/// Whether `value` of `arg` names a file: an option whose value is a
/// path, or a `tf` that is not a preset.
fn names_file(arg: &Arg, value: &Value) -> bool {
    arg.get_value_hint() == ValueHint::AnyPath
        || (arg.get_id().as_str() == "tf"
            && value
                .as_str()
                .is_some_and(|t| !crate::options::is_preset(t)))
}
