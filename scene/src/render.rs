//! Run one resolved render: the ray caster's frame (`--repeat` times,
//! the median time kept) or the path tracer's passes (continuing from and
//! saving an `--accumulate` state), stopping between tiles or passes
//! when the caller raises a [`Cancel`] flag.

use crate::budget::{self, Choice, Model};
use crate::error::{Error, ErrorKind, Kind, Result};
use crate::options::Options;
use crate::plan::Plan;
use crate::source::Source;
use std::time::Instant;
use volindex::{BuildOptions, MinMaxIndex};
use volrender::film::PathFilm;
use volrender::path::{PathCounters, PathTracer};
use volrender::{render_tf, Cancel, Frame};

/// What a render made: the image and the seconds it took.
pub struct Rendered {
    /// The ray caster's frame, or the path tracer's accumulated passes.
    pub image: Image,
    /// How long each part took.
    pub times: Times,
    /// What `--budget` chose, and what it cost.
    pub budget: Option<Budgeted>,
}

/// What a frame-time budget chose and what it cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budgeted {
    /// The budget, seconds.
    pub seconds: f64,
    /// The step the choice's multiples are of.
    pub base_step: f64,
    /// The setting chosen.
    pub choice: Choice,
    /// Seconds of the probe frames (in the budget).
    pub probe_s: f64,
    /// Seconds of the upsampling (in `render_s`).
    pub upsample_s: f64,
    /// The model the choice came from.
    pub model: Model,
}

/// The image of a render.
pub enum Image {
    /// A ray-cast frame.
    Frame(Frame),
    /// Path-traced passes.
    Path(Traced),
}

/// A path-traced render: the sums of every pass (those of a state it
/// continued from too) and the tracer's counters for the passes added.
pub struct Traced {
    /// The per-pixel sums; `spp()` counts every sample in them.
    pub acc: PathFilm,
    /// The counters of the passes this render added.
    pub counters: PathCounters,
    /// Samples per pixel this render added.
    pub spp_added: u64,
    /// The fraction of majorant cells that are empty.
    pub empty_fraction: f64,
}

/// How long each part of a render took, seconds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Times {
    /// Opening the volume.
    pub load_s: f64,
    /// Reading or building the index (in path mode, also the build a
    /// render without one needs).
    pub index_s: f64,
    /// The frame (the median of `runs`), or the passes.
    pub render_s: f64,
    /// Each ray-cast frame's time (`--repeat`), as rendered, sorted.
    pub runs: Vec<f64>,
}

/// How far a path-traced render is, after each pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Samples per pixel added so far.
    pub spp_added: u64,
    /// The image's relative standard error, when there is an estimate.
    pub relative_error: Option<f64>,
}

/// Render `plan` from `source`: frames or passes as `options` say,
/// `progress` called after each path-traced pass; the error
/// [`ErrorKind::Cancelled`] when `cancel` is raised first. Errors name
/// the volume, as vol-render prints them.
pub fn render(
    options: &Options,
    source: &Source,
    plan: &Plan,
    cancel: &Cancel,
    progress: impl FnMut(&Progress),
) -> Result<Rendered> {
    render_from(options, source, plan, cancel, None, progress)
}

/// [`render`], path-traced passes added to `prior` (the film of
/// an earlier render of the same scene, as [`Rendered::into_passes`]
/// gives it back) instead of starting anew: a viewer refines its frame a
/// pass at a time, and N passes of one sample equal one of N, bit for
/// bit. `prior` from another scene or image size is refused; a ray-cast
/// render takes no `prior`.
pub fn render_from(
    options: &Options,
    source: &Source,
    plan: &Plan,
    cancel: &Cancel,
    prior: Option<PathFilm>,
    progress: impl FnMut(&Progress),
) -> Result<Rendered> {
    match (&plan.path, prior) {
        (Some(_), prior) => trace(options, source, plan, cancel, prior, progress),
        (None, None) => cast(options, source, plan, cancel),
        (None, Some(_)) => Err(Error::option(
            "only a path-traced render continues from earlier passes",
        )),
    }
}

impl Rendered {
    /// The path tracer's film, to continue with
    /// [`render_from`]; `None` for a ray-cast frame.
    pub fn into_passes(self) -> Option<PathFilm> {
        match self.image {
            Image::Path(t) => Some(t.acc),
            Image::Frame(_) => None,
        }
    }
}

/// The ray caster: within `--budget` when there is one, else
/// [`cast_frames`].
fn cast(options: &Options, source: &Source, plan: &Plan, cancel: &Cancel) -> Result<Rendered> {
    match options.budget {
        Some(seconds) => cast_within(options, source, plan, cancel, seconds),
        None => cast_frames(options, source, plan, cancel),
    }
}

/// A frame within `seconds`: probe the view, choose the step and scale,
/// render (`--repeat` times) and upsample to the size asked for.
fn cast_within(
    options: &Options,
    source: &Source,
    plan: &Plan,
    cancel: &Cancel,
    seconds: f64,
) -> Result<Rendered> {
    let base_step = f64::from(plan.settings.step);
    let probed = probe(
        options,
        source,
        plan,
        seconds * budget::probe::PROBE_SHARE,
        cancel,
    )?;
    let choice = budget::choose(
        &probed.model,
        base_step,
        options.size,
        seconds - probed.seconds,
    );
    let mut o = options.clone();
    o.budget = None;
    o.step = Some(choice.step as f32);
    o.size = (choice.width, choice.height);
    let chosen = Plan::for_source(&o, source)?;
    let mut rendered = cast_frames(&o, source, &chosen, cancel)?;
    let t = Instant::now();
    if let Image::Frame(f) = rendered.image {
        let (w, h) = options.size;
        rendered.image = Image::Frame(budget::resize::upsample_frame(f, w, h));
    }
    let upsample_s = t.elapsed().as_secs_f64();
    rendered.times.render_s += upsample_s;
    for r in &mut rendered.times.runs {
        *r += upsample_s;
    }
    rendered.budget = Some(Budgeted {
        seconds,
        base_step,
        choice,
        probe_s: probed.seconds,
        upsample_s,
        model: probed.model,
    });
    Ok(rendered)
}

/// Fit the frame-time models of the view `options` asks for (as `plan`
/// resolves it; the budget's base step is its step) with probe frames of
/// `source` ([`budget::probe`]) that grow only while they take at most
/// `limit_s` seconds in all.
pub fn probe(
    options: &Options,
    source: &Source,
    plan: &Plan,
    limit_s: f64,
    cancel: &Cancel,
) -> Result<budget::Probed> {
    let base_step = f64::from(plan.settings.step);
    budget::probe(options, plan, base_step, limit_s, |o| {
        let plan = Plan::for_source(o, source)?;
        match cast_frames(o, source, &plan, cancel)?.image {
            Image::Frame(f) => Ok((f, f64::from(plan.settings.step))),
            Image::Path(_) => Err(Error::option("--budget is for ray-cast frames")),
        }
    })
}

/// The ray caster: `--repeat` frames, the last kept, the median timed.
fn cast_frames(
    options: &Options,
    source: &Source,
    plan: &Plan,
    cancel: &Cancel,
) -> Result<Rendered> {
    let name = source.name();
    let vol = &source.volume;
    let mut settings = plan.settings.clone();
    settings.cancel = cancel.clone();
    let (frame, Repeated { runs, median_s }) = repeat(options.repeat, || {
        let f = render_tf(
            vol,
            source.index.as_ref(),
            plan.tf.as_ref(),
            &plan.camera,
            &settings,
        )
        .map_err(|e| Error::from_render(e).context(&name))?;
        let s = f.stats.render_s;
        Ok((f, s))
    })?;
    if let Some(e) = vol.error() {
        return Err(Error::file(format!("{name}: {e}")));
    }
    let render_s = median_s;
    Ok(Rendered {
        image: Image::Frame(frame),
        times: Times {
            load_s: source.load_s,
            index_s: source.index_s,
            render_s,
            runs,
        },
        budget: None,
    })
}

/// The times of a frame rendered `--repeat` times.
#[derive(Clone, Debug, PartialEq)]
pub struct Repeated {
    /// Each run's time, seconds, sorted.
    pub runs: Vec<f64>,
    /// Their median (the upper one of an even count).
    pub median_s: f64,
}

/// Run `frame` `times` times (at least once), each returning its result
/// and its time in seconds: the last result, and the runs' times with
/// their median (`--repeat`). The first error ends the runs.
pub fn repeat<T, E>(
    times: u32,
    mut frame: impl FnMut() -> std::result::Result<(T, f64), E>,
) -> std::result::Result<(T, Repeated), E> {
    let (mut last, s) = frame()?;
    let mut runs = vec![s];
    for _ in 1..times.max(1) {
        let (f, s) = frame()?;
        runs.push(s);
        last = f;
    }
    runs.sort_by(f64::total_cmp);
    let median_s = runs[runs.len() / 2];
    Ok((last, Repeated { runs, median_s }))
}

/// The path tracer: passes until the budget is spent, from `prior` or
/// the `--accumulate` state, and into that state.
fn trace(
    options: &Options,
    source: &Source,
    plan: &Plan,
    cancel: &Cancel,
    prior: Option<PathFilm>,
    mut progress: impl FnMut(&Progress),
) -> Result<Rendered> {
    let Some((settings, budget)) = &plan.path else {
        return Err(Error::option("not a path-traced render"));
    };
    let name = source.name();
    let vol = &source.volume;
    let (w, h) = (plan.camera.width(), plan.camera.height());
    // Tracking needs the index's majorants, even under --no-ess.
    let built;
    let (index, index_s) = match source.index.as_ref() {
        Some(ix) => (ix, source.index_s),
        None => {
            let t = Instant::now();
            built = MinMaxIndex::build_volume(vol, &BuildOptions::default(), 0)
                .kind_ctx(ErrorKind::File, format_args!("{name}: building the index"))?;
            (&built, source.index_s + t.elapsed().as_secs_f64())
        }
    };
    let tracer = PathTracer::new(vol, index, &plan.camera, settings)
        .map_err(|e| Error::from_render(e).context(&name))?
        .with_cancel(cancel.clone());
    let fingerprint = source
        .fingerprint
        .clone()
        .unwrap_or_else(|| volformats::fingerprint(&source.path).map_err(|e| e.to_string()));
    let volume_id = match fingerprint {
        Ok(f) => f,
        Err(e) if options.accumulate.is_some() => {
            return Err(Error::file(format!(
                "--accumulate needs a volume file it can recognise again: {name}: {e}"
            )))
        }
        Err(_) => 0,
    };
    let key = tracer.key(volume_id);
    let state = |p: &std::path::Path| volcore::text::escape(&p.display().to_string());
    let mut acc = match (prior, &options.accumulate) {
        (Some(acc), _) if acc.key() == key && (acc.width(), acc.height()) == (w, h) => acc,
        (Some(_), _) => {
            return Err(Error::option(format!(
                "{name}: the passes to continue are of another scene or image size"
            )))
        }
        (None, Some(p)) if p.exists() => {
            PathFilm::load(p, w, h, key).map_err(|e| Error::file(format!("{}: {e}", state(p))))?
        }
        (None, _) => PathFilm::new(w, h, key),
    };
    let start_spp = acc.spp();
    let t = Instant::now();
    let counters = tracer
        .render(&mut acc, budget, |a, _| {
            progress(&Progress {
                spp_added: a.spp() - start_spp,
                relative_error: a.relative_error(),
            })
        })
        .map_err(|e| Error::from_render(e).context(&name))?;
    let render_s = t.elapsed().as_secs_f64();
    if let Some(e) = vol.error() {
        return Err(Error::file(format!("{name}: {e}")));
    }
    if let Some(p) = &options.accumulate {
        save_state(&acc, p).kind_ctx(ErrorKind::File, state(p))?;
    }
    let spp_added = acc.spp() - start_spp;
    let empty_fraction = tracer.empty_fraction();
    Ok(Rendered {
        image: Image::Path(Traced {
            acc,
            counters,
            spp_added,
            empty_fraction,
        }),
        times: Times {
            load_s: source.load_s,
            index_s,
            render_s,
            runs: vec![render_s],
        },
        budget: None,
    })
}

/// Write an `--accumulate` state: under a temporary name beside it,
/// renamed over the previous state only when complete, so that a render
/// that is killed or runs out of space keeps the previous state intact.
fn save_state(acc: &PathFilm, path: &std::path::Path) -> std::io::Result<()> {
    use std::io::Write;
    let mut file = volformats::output::AtomicFile::create(path)?;
    {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file.file());
        acc.write_to(&mut w)?;
        w.flush()?;
    }
    file.commit()
}
