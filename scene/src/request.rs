//! One render as asked: the options, which of them were given (on the
//! command line, or as name/value pairs), the arguments that gave them,
//! and the scene file under them. Options given win over the scene file;
//! the scene file wins over the defaults.

use crate::error::{clap_error, Error, Result};
use crate::file::Scene;
use crate::options::Options;
use clap::parser::ValueSource;
use clap::{ArgAction, ArgMatches, CommandFactory, FromArgMatches};
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

pub use crate::error::clap_message;

/// The options of one render, the ids (field names, `look_at`) of those
/// that were given, and the arguments that said them, so a scene file
/// can go under them through the same parse.
#[derive(Clone, Debug)]
pub struct Request {
    options: Options,
    given: BTreeSet<String>,
    /// The given options as flags (`--look-at=0,0,0`).
    flags: Vec<OsString>,
    /// The given positional argument (the volume).
    positional: Vec<OsString>,
    /// The files the scene file named, by key (`volume`), as resolved.
    scene_paths: Vec<(String, String)>,
}

impl Request {
    /// The options clap parsed from a command line (or from pairs), and
    /// its matches: the options given are those whose value came from
    /// the arguments.
    pub fn from_matches(options: Options, matches: &ArgMatches) -> Request {
        let mut request = Request {
            options,
            given: BTreeSet::new(),
            flags: Vec::new(),
            positional: Vec::new(),
            scene_paths: Vec::new(),
        };
        for arg in Options::command().get_arguments() {
            let id = arg.get_id().as_str();
            if matches.value_source(id) != Some(ValueSource::CommandLine) {
                continue;
            }
            request.given.insert(id.to_string());
            let raw: Vec<OsString> = matches
                .get_raw(id)
                .map(|v| v.map(OsString::from).collect())
                .unwrap_or_default();
            match arg.get_long() {
                None => request.positional.extend(raw),
                Some(long) => match arg.get_action() {
                    ArgAction::SetTrue => request.flags.push(format!("--{long}").into()),
                    _ => request.flags.extend(raw.into_iter().map(|v| {
                        let mut flag = OsString::from(format!("--{long}="));
                        flag.push(v);
                        flag
                    })),
                },
            }
        }
        request
    }

    /// Parse vol-render's arguments (without the program's name), as the
    /// command line would be; an error is clap's message on one line.
    pub fn parse<I, T>(args: I) -> Result<Request>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        let argv =
            std::iter::once(OsString::from("vol-render")).chain(args.into_iter().map(Into::into));
        let matches = Options::command()
            .try_get_matches_from(argv)
            .map_err(clap_error)?;
        let options = Options::from_arg_matches(&matches).map_err(clap_error)?;
        Ok(Request::from_matches(options, &matches))
    }

    /// The options as they stand.
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// The options, to change them (a viewer moving the camera); what was
    /// given stays as it was.
    pub fn options_mut(&mut self) -> &mut Options {
        &mut self.options
    }

    /// The options, given or not.
    pub fn into_options(self) -> Options {
        self.options
    }

    /// Whether the option with this id (`look_at`) was given.
    pub fn is_given(&self, id: &str) -> bool {
        self.given.contains(id)
    }

    /// Mark the options with these ids given (pairs that no flag says:
    /// `lights`, `tf_text`).
    pub(crate) fn mark_given(&mut self, ids: impl IntoIterator<Item = String>) {
        self.given.extend(ids);
    }

    /// Fill every option not given from the `--scene` file, when there is
    /// one (relative paths in it are taken from its folder).
    pub fn with_scene_file(self) -> Result<Request> {
        let Some(path) = self.options.scene.clone() else {
            return Ok(self);
        };
        let file = Scene::read(&path)?;
        self.with_scene(file, &path)
    }

    /// Fill every option not given from `scene`, read from the file at
    /// `path` (relative paths in it are taken from its folder): the
    /// file's options become the flags that say them, in front of the
    /// given ones, and clap parses them all, so the file's values are
    /// parsed, defaulted and checked (requirements and conflicts
    /// included) as the flags are. An error names the file.
    pub fn with_scene(mut self, scene: Scene, path: &Path) -> Result<Request> {
        let name = volcore::text::escape(&path.display().to_string());
        let dir = path.parent().unwrap_or(Path::new(""));
        let under = crate::merge::under(&scene, dir, &self.given)
            .map_err(|e| Error::usage(format!("{name}: {}", e.message())))?;
        let mut flags: Vec<OsString> = under.flags.into_iter().map(OsString::from).collect();
        flags.append(&mut self.flags);
        if self.positional.is_empty() {
            self.positional = under.positional.into_iter().map(OsString::from).collect();
        }
        let argv = std::iter::once(OsString::from("vol-render"))
            .chain(flags.iter().cloned())
            .chain((!self.positional.is_empty()).then(|| OsString::from("--")))
            .chain(self.positional.iter().cloned());
        let parsed = Options::command()
            .try_get_matches_from(argv)
            .and_then(|m| Options::from_arg_matches(&m))
            .map_err(|e| Error::usage(format!("{name}: {}", clap_message(&e))))?;
        let mut options = parsed;
        // What no flag says: the given one's, else the file's (a given
        // `--tf` or `--light` stands in place of the file's text or
        // lights).
        let tf_given = self.is_given("tf") || self.is_given("tf_text");
        options.tf_text = match tf_given {
            true => self.options.tf_text.take(),
            false => scene.tf_text,
        };
        let lights_given = self.is_given("light") || self.is_given("lights");
        options.lights = match lights_given {
            true => self.options.lights.take(),
            false => scene.lights,
        };
        self.options = options;
        self.flags = flags;
        self.scene_paths = under.paths;
        Ok(self)
    }

    /// `e`, naming the scene file and its key too when it is about a file
    /// the scene file named (`a.toml: key `volume`: /data/b.vvol: no such
    /// file or directory`): the path alone does not say where it came
    /// from.
    pub fn naming_scene(&self, e: Error) -> Error {
        let Some(scene) = &self.options.scene else {
            return e;
        };
        let about = self.scene_paths.iter().find(|(_, p)| {
            let shown = volcore::text::escape(p);
            e.message()
                .strip_prefix(shown.as_str())
                .is_some_and(|rest| rest.starts_with(':'))
        });
        match about {
            Some((key, _)) => e.context(format!(
                "{}: key `{key}`",
                volcore::text::escape(&scene.display().to_string())
            )),
            None => e,
        }
    }

    /// The volume's path, or the error that there is none (naming the
    /// `--scene` file, when one was given without a `volume`).
    pub fn volume(&self) -> Result<PathBuf> {
        self.options.volume.clone().ok_or_else(|| match &self.options.scene {
            Some(scene) => Error::usage(format!(
                "{}: no volume: the scene file has no `volume`, and none was given on the command line",
                volcore::text::escape(&scene.display().to_string())
            )),
            None => Error::usage("no volume: give its path, or `volume` in the --scene file"),
        })
    }
}
