//! The volume vol-view shows, opened once, and the renders the page asks
//! for: its option pairs become a [`Request`] through the one definition
//! of vol-render's options, the startup scene file under them, and each
//! frame renders through `volscene`, one at a time for the whole server.

use clap::{CommandFactory, ValueHint};
use serde_json::{Map, Value};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};
use volscene::{Cancel, Error, Options, Plan, Rendered, Request, Scene, Source};

/// The opened volume and what the server was started with.
pub struct Viewer {
    /// The volume and its index.
    pub source: Source,
    /// The volume's path, as given.
    pub volume: PathBuf,
    /// The startup `--scene` file and its contents.
    scene: Option<(PathBuf, Scene)>,
    /// The startup options (scene file merged).
    pub startup: Options,
    /// Held while a frame renders: one frame at a time, whoever asks.
    render_lock: Mutex<()>,
    /// The seconds a ray-cast preview aims at, its transfer to the page
    /// included.
    pub preview_budget_s: f64,
}

/// The default preview budget: 30 previews per second.
pub const PREVIEW_BUDGET_S: f64 = 1.0 / 30.0;

impl Viewer {
    /// Open `volume` (or the `volume` of the `scene` file) with the
    /// scene's options; the errors name the file at fault.
    pub fn open(volume: Option<&Path>, scene: Option<&Path>) -> Result<Viewer, Error> {
        let mut args: Vec<OsString> = Vec::new();
        if let Some(s) = scene {
            args.push("--scene".into());
            args.push(s.into());
        }
        if let Some(v) = volume {
            args.push("--".into());
            args.push(v.into());
        }
        let request = Request::parse(args)?.with_scene_file()?;
        let volume = request.volume()?;
        let startup = without_outputs(request.into_options());
        let scene = match scene {
            Some(path) => Some((path.to_path_buf(), Scene::read(path)?)),
            None => None,
        };
        let source = Source::open(&startup, &volume)?;
        // The startup view must resolve, or the page would open on an error.
        Plan::for_source(&startup, &source)?;
        Ok(Viewer {
            source,
            volume,
            scene,
            startup,
            render_lock: Mutex::new(()),
            preview_budget_s: PREVIEW_BUDGET_S,
        })
    }

    /// The options `pairs` ask for: each checked and parsed as its flag
    /// would be, the startup scene file filling the rest. The page may
    /// not name files (the options whose values are paths, and `tf`
    /// other than a preset): those come from the startup scene only.
    pub fn options(&self, pairs: &Map<String, Value>) -> Result<Options, Error> {
        check_pairs(pairs)?;
        let mut request = Request::from_pairs(pairs.iter().map(|(k, v)| (k.as_str(), v.clone())))?;
        if let Some((path, scene)) = &self.scene {
            request = request.with_scene(scene.clone(), path)?;
        }
        let mut options = without_outputs(request.into_options());
        options.volume = Some(self.volume.clone());
        options.scene = self.scene.as_ref().map(|(p, _)| p.clone());
        Ok(options)
    }

    /// The options resolved against the volume.
    pub fn plan(&self, options: &Options) -> Result<Plan, Error> {
        Plan::for_source(options, &self.source)
    }

    /// Render `plan` (passes added to `prior` when path tracing), after
    /// any other frame of the server has finished; stops when `cancel` is
    /// raised.
    pub fn render(
        &self,
        options: &Options,
        plan: &Plan,
        cancel: &Cancel,
        prior: Option<volrender::film::PathFilm>,
    ) -> Result<Rendered, Error> {
        let _one_at_a_time = self.lock();
        if cancel.is_cancelled() {
            return Err(Error::cancelled());
        }
        volscene::render_from(options, &self.source, plan, cancel, prior, |_| {})
    }

    /// Fit the frame-time models of the view `options` asks for (as
    /// `plan` resolves it) with probe frames, after any other frame of
    /// the server has finished. The probes grow as they need: they run
    /// once per view, and every preview after them calibrates the cost.
    pub fn probe(
        &self,
        options: &Options,
        plan: &Plan,
        cancel: &Cancel,
    ) -> Result<volscene::budget::Probed, Error> {
        let _one_at_a_time = self.lock();
        volscene::render::probe(options, &self.source, plan, f64::INFINITY, cancel)
    }

    /// The render lock (a panic elsewhere does not stop the server).
    fn lock(&self) -> MutexGuard<'_, ()> {
        self.render_lock
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The `vol-render` command that renders the view `pairs` ask for to
    /// `STEM.png` and `STEM.pfm` (the names its saves get); with keys
    /// only a scene file holds (`tf-text`, `lights`), the command that
    /// reads its scene file `STEM.toml` (the page's scene download).
    pub fn command(&self, pairs: &Map<String, Value>, stem: &str) -> Result<String, Error> {
        let split = volscene::pairs::split(pairs.iter().map(|(k, v)| (k.as_str(), v.clone())))?;
        let mut words = vec!["vol-render".to_string()];
        if !split
            .given
            .iter()
            .all(|id| !volscene::pairs::SCENE_ONLY.contains(&id.as_str()))
        {
            words.extend(["--scene".into(), quote(&format!("{stem}.toml"))]);
        } else {
            if let Some((p, _)) = &self.scene {
                words.extend(["--scene".into(), quote(&p.display().to_string())]);
            }
            words.push(quote(&self.volume.display().to_string()));
            words.extend(split.args.iter().map(|a| quote(a)));
        }
        words.extend([
            "-o".into(),
            quote(&format!("{stem}.png")),
            "--hdr".into(),
            quote(&format!("{stem}.pfm")),
        ]);
        Ok(words.join(" "))
    }

    /// The command (see [`Viewer::command`]) and scene file (TOML) of a
    /// path-traced frame of the view `pairs` ask for that holds `spp`
    /// passes: both state `spp` and neither a time or error budget, so
    /// they render the frame as it was saved, not the view's budget.
    pub fn stated(
        &self,
        pairs: &Map<String, Value>,
        spp: u64,
        stem: &str,
    ) -> Result<(String, String), Error> {
        let mut pairs = pairs.clone();
        pairs.retain(|k, _| {
            !["spp", "seconds", "until_error"].contains(&volscene::pairs::id_of(k).as_str())
        });
        pairs.insert("spp".into(), Value::from(spp));
        let mut options = self.options(&pairs)?;
        // A startup scene file's budget gives way too.
        options.seconds = None;
        options.until_error = None;
        let toml = volscene::file::to_toml(&self.plan(&options)?.scene)?;
        Ok((self.command(&pairs, stem)?, toml))
    }
}

/// The options without the files vol-render would write (the viewer
/// renders only; saves go through the page or `--save-dir`) and without
/// printing.
fn without_outputs(mut options: Options) -> Options {
    options.output = None;
    options.hdr = None;
    options.heatmap = None;
    options.variance = None;
    options.accumulate = None;
    options.print_scene = false;
    options.json = false;
    options.quiet = true;
    options
}

/// Refuse pairs that name files: an option whose value clap takes as a
/// path, or a transfer function that is not a preset.
fn check_pairs(pairs: &Map<String, Value>) -> Result<(), Error> {
    let cmd = Options::command();
    for (name, value) in pairs {
        let id = volscene::pairs::id_of(name);
        let shown = volcore::text::clip(&volcore::text::escape(name), 40);
        if let Some(arg) = cmd.get_arguments().find(|a| a.get_id().as_str() == id) {
            if arg.get_value_hint() == ValueHint::AnyPath {
                return Err(Error::usage(format!(
                    "option `{shown}`: the page does not name files; give it in the --scene file vol-view starts with"
                )));
            }
        }
        // `tf` names a preset or a file: only presets from the page.
        if let ("tf", Value::String(tf)) = (id.as_str(), value) {
            if !volscene::options::is_preset(tf) {
                return Err(Error::usage(format!(
                    "option `tf`: `{}` is not a preset ({}); the page gives presets or tf-text, files go in the --scene file",
                    volcore::text::clip(&volcore::text::escape(tf), 40),
                    volrender::tf::PRESETS.join(", ")
                )));
            }
        }
    }
    Ok(())
}

/// A word as a POSIX shell reads it back: as is when it is plain, else
/// in single quotes.
pub fn quote(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_=.,/:+@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}
