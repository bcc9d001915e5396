//! Options from name/value pairs: the names are vol-render's flags and
//! the scene file's keys (`look-at`, or `look_at` as Python spells a
//! keyword), the values JSON values (`[0, 0, 0]`, `"ct"`, `true`). Each
//! pair becomes the command-line argument that says the same, and clap
//! parses those with the one definition of the options ([`Options`]),
//! so a pair is checked, parsed and defaulted exactly as the flag is.
//!
//! Two scene-file keys have no flag: `lights` (a list of tables, as in
//! the file) and `tf-text`; they are read as the scene file reads them.

use crate::error::{clap_error, Error, Result};
use crate::file::Scene;
use crate::lights::LightSpec;
use crate::options::Options;
use crate::request::Request;
use clap::{CommandFactory, FromArgMatches};
use serde_json::Value;
use std::collections::BTreeSet;

pub use crate::args::{command_args, id_of};

/// The keys that only a scene file (or a pair) can give: no flag says them.
pub const SCENE_ONLY: [&str; 2] = ["lights", "tf_text"];

/// What a list of pairs says, taken apart.
#[derive(Clone, Debug, Default)]
pub struct Pairs {
    /// The vol-render arguments that say the same as the pairs with a
    /// flag (without the program's name): `--look-at=0,0,0`.
    pub args: Vec<String>,
    /// The pairs without a flag (`lights`, `tf-text`), as a scene.
    pub scene_only: Scene,
    /// The ids of every option named (`look_at`), `null` values aside.
    pub given: BTreeSet<String>,
}

/// Take `pairs` apart into arguments and scene-only keys. An unknown
/// name is refused naming it; a `null` value is as if the pair were not
/// there.
pub fn split<I, K>(pairs: I) -> Result<Pairs>
where
    I: IntoIterator<Item = (K, Value)>,
    K: AsRef<str>,
{
    let mut out = Pairs::default();
    let mut flagged = Vec::new();
    let mut scene_only = serde_json::Map::new();
    for (name, value) in pairs {
        let id = id_of(name.as_ref());
        if value.is_null() {
            continue;
        }
        if SCENE_ONLY.contains(&id.as_str()) {
            scene_only.insert(id.replace('_', "-"), value);
            out.given.insert(id);
            continue;
        }
        flagged.push((name.as_ref().to_string(), value));
    }
    let (args, given) = command_args(&Options::command(), flagged)?;
    out.args = args;
    out.given.extend(given);
    if let Some(text) = scene_only.remove("tf-text") {
        match text {
            Value::String(t) => out.scene_only.tf_text = Some(t),
            _ => return Err(Error::usage("option `tf-text`: expected a text")),
        }
    }
    if let Some(lights) = scene_only.remove("lights") {
        let lights: Vec<LightSpec> = serde_json::from_value(lights).map_err(|e| {
            Error::usage(format!(
                "option `lights`: {}",
                volcore::text::clip(&volcore::text::escape(&e.to_string()), 160)
            ))
        })?;
        for (i, l) in lights.iter().enumerate() {
            l.light()
                .map_err(|e| Error::usage(format!("lights[{i}]: {e}")))?;
        }
        out.scene_only.lights = Some(lights);
    }
    Ok(out)
}

impl Request {
    /// The render that `pairs` ask for: each name an option's (as a flag
    /// or a scene-file key), each value parsed and checked as the flag's
    /// would be. Options not named keep their defaults, which a scene
    /// file (the `scene` pair, then [`Request::with_scene_file`]) fills.
    pub fn from_pairs<I, K>(pairs: I) -> Result<Request>
    where
        I: IntoIterator<Item = (K, Value)>,
        K: AsRef<str>,
    {
        let p = split(pairs)?;
        let argv = std::iter::once("vol-render".to_string()).chain(p.args);
        let matches = Options::command()
            .try_get_matches_from(argv)
            .map_err(clap_error)?;
        let mut options = Options::from_arg_matches(&matches).map_err(clap_error)?;
        if p.scene_only.tf_text.is_some() && p.given.contains("tf") {
            return Err(Error::usage("give `tf` or `tf-text`, not both"));
        }
        if p.scene_only.lights.is_some() && p.given.contains("light") {
            return Err(Error::usage("give `light` or `lights`, not both"));
        }
        options.lights = p.scene_only.lights;
        options.tf_text = p.scene_only.tf_text;
        let mut request = Request::from_matches(options, &matches);
        request.mark_given(p.given);
        Ok(request)
    }
}
