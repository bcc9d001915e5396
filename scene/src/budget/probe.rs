//! The probe frames a budget is calibrated by, in samples 3-6% of a full
//! frame at the base step (a CT head at 256², where the centre is three
//! times as dense as the whole: 5%):
//! - the whole view at a sixth of each side (at least
//!   [`PROBE_MIN_SIDE`] pixels, doubled while the coarsest takes under
//!   [`PROBE_MIN_S`]) at 2, 4 and 8 times the base step: their times fit
//!   the cost model, their differences the step's error;
//! - the centre of the view at full resolution, as large as those (the
//!   same camera, its field of view narrowed), at [`CROP_STEP`] times the
//!   base step: what it loses when sampled 2x, 4x and 8x more coarsely
//!   and upsampled back is the scale's error, and its cost per sample
//!   against the whole view's is what denser rays save.
//!
//! A probe under [`PROBE_RERUN_BELOW_S`] is timed by its fastest of
//! [`PROBE_RUNS`] runs. Neither the doubling nor the reruns go past the
//! seconds the caller allows the probes (a one-shot `--budget` frame
//! gives them [`PROBE_SHARE`] of its budget): a sharper model is worth
//! less than the frame it would leave no time for.

use super::model::{CostModel, ErrorModel, ProbeFrame};
use super::resize::down_up_mse;
use super::{scaled, Model};
use crate::error::Result;
use crate::options::Options;
use crate::plan::Plan;
use std::time::Instant;
use volrender::camera::Projection;
use volrender::Frame;

/// The probes' scale of each side.
pub const PROBE_SCALE: f64 = 1.0 / 6.0;
/// The fewest pixels on a probe's shorter side (a smaller image is probed
/// at its own size).
pub const PROBE_MIN_SIDE: u32 = 48;
/// The probes' steps, as multiples of the base step: an octave apart.
pub const PROBE_STEPS: [f64; 3] = [2.0, 4.0, 8.0];
/// The centre's step, as a multiple of the base step (the centre is the
/// densest part of most views: at the base step it alone cost a CT head
/// 10% of a frame).
pub const CROP_STEP: f64 = 4.0;

/// The least time of the coarsest probe: below it the probes' side is
/// doubled (up to [`PROBE_MAX_SCALE`]), since a frame's fixed part
/// (about 0.8 ms on two cores) would hide its samples' cost.
pub const PROBE_MIN_S: f64 = 0.002;
/// The largest probe scale the doubling reaches.
pub const PROBE_MAX_SCALE: f64 = 0.5;

/// A probe faster than this is rendered again, up to [`PROBE_RUNS`]
/// times, and its fastest run kept: a millisecond frame's first run is
/// often twice its time (threads waking), which the fit would read as a
/// cost per sample several times too high.
pub const PROBE_RERUN_BELOW_S: f64 = 0.005;
/// The most runs of one probe.
pub const PROBE_RUNS: u32 = 3;

/// The share of a one-shot budget its probes may grow to (by doubling
/// their side and rerunning fast ones); the smallest probes run whatever
/// the budget.
pub const PROBE_SHARE: f64 = 0.25;

/// The probes' cost in units of the coarsest one's: the two finer steps
/// take 4 and 2 times its samples, the centre about 2 times.
const PROBES_PER_COARSE: f64 = 9.0;

/// The most the crop's scale errors are raised by when the volume covers
/// more of the whole image than of the crop.
const MAX_SPREAD: f64 = 4.0;

/// A view's fitted models and what fitting them cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probed {
    /// The models.
    pub model: Model,
    /// Wall seconds of the probes and the fit.
    pub seconds: f64,
}

/// Probe the view `options` asks for (its size is the full frame's;
/// `base_step` is the step the budget's multiples are of) as `plan`
/// resolves it, growing the probes only while the whole stays within
/// `limit_s` seconds (infinite: no limit); `render` renders one frame of
/// the options it is given (without a budget), and says the step it
/// resolved them to.
pub fn probe(
    options: &Options,
    plan: &Plan,
    base_step: f64,
    limit_s: f64,
    mut render: impl FnMut(&Options) -> Result<(Frame, f64)>,
) -> Result<Probed> {
    let t = Instant::now();
    let clock = Clock { start: t, limit_s };
    let (w, h) = options.size;
    let short = w.min(h).max(1);
    let mut q = PROBE_SCALE
        .max(f64::from(PROBE_MIN_SIDE) / f64::from(short))
        .min(1.0);
    let sized = |q: f64| {
        let mut o = options.clone();
        o.size = (scaled(w, q), scaled(h, q));
        o
    };
    let [s_fine, s_mid, s_coarse] = PROBE_STEPS.map(|f| base_step * f);
    // The coarsest first: it sets the probes' size (at most a few
    // doublings, each bounded by PROBE_MAX_SCALE).
    let (mut coarse, mut coarse_wall) = frame(sized(q), s_coarse, &mut render, &clock)?;
    // Doubled, the side quadruples every probe's pixels.
    while coarse.seconds < PROBE_MIN_S
        && q * 2.0 <= PROBE_MAX_SCALE
        && clock.allows(4.0 * PROBES_PER_COARSE * coarse_wall)
    {
        q *= 2.0;
        (coarse, coarse_wall) = frame(sized(q), s_coarse, &mut render, &clock)?;
    }
    let (fine, _) = frame(sized(q), s_fine, &mut render, &clock)?;
    let (mid, _) = frame(sized(q), s_mid, &mut render, &clock)?;
    let size = sized(q).size;
    let probes = [fine, mid, coarse];
    let [fine, mid, coarse] = &probes;
    let (crop, _) = frame(
        centre(options, plan, size),
        base_step * CROP_STEP,
        &mut render,
        &clock,
    )?;
    // The crop's errors where the volume is, spread over the whole
    // image's coverage.
    let spread = if crop.coverage > 0.0 {
        (fine.coverage / crop.coverage).min(MAX_SPREAD)
    } else {
        1.0
    };
    let scale_mse = [2, 4, 8].map(|factor| spread * down_up_mse(&crop.srgb, size, factor));
    let model = Model {
        cost: CostModel::fit(&probes, q, &crop),
        error: ErrorModel::fit(fine, mid, coarse, scale_mse),
    };
    Ok(Probed {
        model,
        seconds: t.elapsed().as_secs_f64(),
    })
}

/// The options of the centre `size` pixels of the view `plan` resolves
/// `options` to, at full resolution: the same camera with its field of
/// view (or orthographic height) narrowed in proportion.
fn centre(options: &Options, plan: &Plan, size: (u32, u32)) -> Options {
    let mut o = options.clone();
    let part = f64::from(size.1) / f64::from(options.size.1.max(1));
    match plan.camera.projection() {
        Projection::Perspective(fov) => {
            let half = (f64::from(fov).to_radians() / 2.0).tan() * part;
            o.fov = (2.0 * half.atan()).to_degrees() as f32;
        }
        Projection::Orthographic(height) => {
            o.ortho = None;
            o.ortho_height = Some((f64::from(height) * part) as f32);
        }
    }
    o.size = size;
    o
}

/// The probes' time so far and the most they may take.
struct Clock {
    start: Instant,
    limit_s: f64,
}

impl Clock {
    /// Whether `more` seconds still fit the limit.
    fn allows(&self, more: f64) -> bool {
        self.start.elapsed().as_secs_f64() + more <= self.limit_s
    }
}

/// One probe frame of `o` at `step`, rendered by `render`, and the wall
/// seconds of its first run.
fn frame(
    mut o: Options,
    step: f64,
    render: &mut impl FnMut(&Options) -> Result<(Frame, f64)>,
    clock: &Clock,
) -> Result<(ProbeFrame, f64)> {
    o.budget = None;
    o.repeat = 1;
    o.step = Some(step as f32);
    let t = Instant::now();
    let (frame, step) = render(&o)?;
    let wall = t.elapsed().as_secs_f64();
    let mut seconds = frame.stats.render_s;
    for _ in 1..PROBE_RUNS {
        if seconds >= PROBE_RERUN_BELOW_S || !clock.allows(wall) {
            break;
        }
        seconds = seconds.min(render(&o)?.0.stats.render_s);
    }
    let probe = ProbeFrame {
        step,
        pixels: f64::from(frame.width) * f64::from(frame.height),
        samples: frame.stats.samples as f64 + frame.stats.effects.shadow_samples as f64,
        seconds,
        srgb: frame.srgb8(false).into_iter().map(f32::from).collect(),
        coverage: coverage(&frame.rgba),
    };
    Ok((probe, wall))
}

/// The fraction of pixels with a coverage alpha of at least half an
/// 8-bit step.
fn coverage(rgba: &[[f32; 4]]) -> f64 {
    if rgba.is_empty() {
        return 0.0;
    }
    let covered = rgba.iter().filter(|p| p[3] >= 0.5 / 255.0).count();
    covered as f64 / rgba.len() as f64
}
