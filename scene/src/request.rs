//! One render as asked: the options, which of them were given (on the
//! command line, or as name/value pairs), and the scene file under them.
//! Options given win over the scene file; the scene file wins over the
//! defaults.

use crate::error::{Error, Result};
use crate::file::Scene;
use crate::options::Options;
use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, FromArgMatches};
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The options of one render and the ids (field names, `look_at`) of
/// those that were given, so a scene file fills only the rest.
#[derive(Clone, Debug)]
pub struct Request {
    options: Options,
    given: BTreeSet<String>,
}

impl Request {
    /// `options` of which those with the ids in `given` were given.
    pub fn new(mut options: Options, given: BTreeSet<String>) -> Request {
        options.background_given = given.contains("background");
        Request { options, given }
    }

    /// The options clap parsed from a command line, and its matches (the
    /// options given there are those whose value came from it).
    pub fn from_matches(options: Options, matches: &ArgMatches) -> Request {
        let given = Options::command()
            .get_arguments()
            .map(|a| a.get_id().as_str().to_string())
            .filter(|id| matches.value_source(id) == Some(ValueSource::CommandLine))
            .collect();
        Request::new(options, given)
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

    /// Fill every option not given from the `--scene` file, when there is
    /// one (relative paths in it are taken from its folder).
    pub fn with_scene_file(self) -> Result<Request> {
        let Some(path) = self.options.scene.clone() else {
            return Ok(self);
        };
        let file = Scene::read(&path)?;
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        Ok(self.with_scene(file, &dir))
    }

    /// Fill every option not given from `scene` (relative paths in it
    /// taken from `dir`).
    pub fn with_scene(mut self, scene: Scene, dir: &Path) -> Request {
        let given = &self.given;
        crate::merge::apply(scene, dir, &mut self.options, |id| given.contains(id));
        self
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

/// clap's error as a usage error of one line (see [`clap_message`]).
pub(crate) fn clap_error(e: clap::Error) -> Error {
    Error::usage(clap_message(&e))
}

/// clap's error message on one line: the text up to its usage block,
/// without the `error: ` in front; every tool prints its usage errors so.
pub fn clap_message(e: &clap::Error) -> String {
    let text = e.to_string();
    let lines: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    let msg = lines.join(" ");
    msg.trim_start_matches("error: ").to_string()
}
