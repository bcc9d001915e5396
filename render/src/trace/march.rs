//! The one loop that walks a ray's samples, with or without skipping.
//!
//! Samples lie at `t = k·step` for whole `k` (a grid fixed by the ray
//! alone, so skipping and tiling never move a sample). At each sample the
//! loop asks the frame's [`Accel`] whether the sample's cell can be jumped
//! over; if so it moves to the first sample past the jump, otherwise the
//! integrator takes the sample. Integrators whose skipping rule is fixed
//! for the frame let the loop stop asking until the ray leaves a cell
//! found busy.

use super::FrameGeometry;
use crate::accel::{Accel, Step, VoxelRay};
use crate::ray::Ray;
use glam::Vec3;
use volcore::grid::Locator;
use volcore::Cursor;

/// The ray in voxel coordinates and its sample range `k0 ..= k1`
/// (samples at `t = k·step`).
#[derive(Clone, Copy)]
pub struct RaySteps {
    /// The ray in voxel coordinates.
    pub ray: VoxelRay,
    /// First sample of the ray (inside the volume).
    pub k0: i64,
    /// First sample this trace takes: `k0`, or later for a share of the
    /// ray (see [`super::Span`]).
    pub start: i64,
    /// Last sample this trace takes: `last`, or earlier for a share of
    /// the ray.
    pub k1: i64,
    /// Last sample of the ray (inside the volume).
    pub last: i64,
    /// Distance between samples.
    pub step: f64,
    /// `1 / step`.
    pub inv_step: f64,
    /// Locates sample points in the volume.
    pub loc: Locator,
}

impl RaySteps {
    /// The samples of world-space `ray` over `[t0, t1]` in a frame.
    pub fn new(geom: &FrameGeometry, ray: &Ray, t0: f32, t1: f32) -> RaySteps {
        let (o, d) = (ray.origin * geom.inv_spacing, ray.dir * geom.inv_spacing);
        RaySteps::voxel_space(o, d, t0, t1, geom.step as f64, geom.locator)
    }

    /// The samples of a ray already in voxel coordinates (origin `o`,
    /// direction `d`) over `[t0, t1]`, `step` apart.
    pub fn voxel_space(o: Vec3, d: Vec3, t0: f32, t1: f32, step: f64, loc: Locator) -> RaySteps {
        let k0 = (t0 as f64 / step).ceil() as i64;
        let last = (t1 as f64 / step).floor() as i64;
        RaySteps {
            ray: VoxelRay::new(o, d),
            k0,
            start: k0,
            k1: last,
            last,
            step,
            inv_step: 1.0 / step,
            loc,
        }
    }

    /// The samples of `span` of world-space `ray` in a frame: those of
    /// `[t0, t1]`, cut to the span's share when it has one.
    pub fn for_span(geom: &FrameGeometry, ray: &Ray, span: super::Span) -> RaySteps {
        let mut s = RaySteps::new(geom, ray, span.t0, span.t1);
        if let Some((lo, hi)) = span.share {
            s.start = s.k0.max(lo);
            s.k1 = s.k1.min(hi);
        }
        s
    }

    /// Ray parameter of sample `k` (always this expression, so a sample
    /// lands at the same place whatever skipped or refined around it).
    #[inline(always)]
    pub fn t(&self, k: i64) -> f32 {
        (k as f64 * self.step) as f32
    }

    /// Voxel-space position at ray parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.ray.at(t)
    }

    /// After a skip covering every sample up to parameter `u`, the first
    /// sample past `u`, if that moves past `k` (every sample from `k` to it
    /// is skipped; the one returned is taken normally).
    #[inline(always)]
    pub fn after_skip(&self, k: i64, u: f32) -> Option<i64> {
        let last = self.last_before(u);
        (last >= k).then_some(last.saturating_add(1))
    }

    /// The last sample at or before ray parameter `u`.
    #[inline(always)]
    pub fn last_before(&self, u: f32) -> i64 {
        // A reciprocal instead of a division (on the path from one skip to
        // the next sample): in f64, its rounding can move `u / step` across
        // an integer only when `u` lies within ~1e-12 of a sample, far
        // inside the margin skips keep from cell faces.
        floor_i64(u as f64 * self.inv_step)
    }
}

/// `floor(x)` as an integer (saturating; NaN gives 0), without a call to
/// libm's `floor`, which the baseline x86-64 target cannot inline.
#[inline(always)]
fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    i - ((i as f64) > x) as i64
}

/// Whether the march goes on after a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// On to the next sample.
    Next,
    /// The ray is done.
    Stop,
}

/// An integrator's state along one ray, as the march loop drives it.
pub trait RayMarch {
    /// What the ray's state adds to the skipping rule.
    type Query: Copy;
    /// Whether a cell found busy stays busy for the rest of the ray (the
    /// rule is fixed for the frame), so the loop need not ask again until
    /// the ray leaves it.
    const CACHE_BUSY: bool;
    /// The ray's current contribution to the rule.
    fn query(&self) -> Self::Query;
    /// Samples `from .. to` were skipped (all of them the ray's own: `to`
    /// is at most one past its last sample); an integrator whose samples
    /// stand for the segment before them may still take sample `from`
    /// here (`cur` reads it) and stop the ray.
    #[inline(always)]
    fn skipped<C: Cursor>(&mut self, cur: &mut C, from: i64, to: i64, s: &RaySteps) -> Flow {
        let _ = (cur, from, to, s);
        Flow::Next
    }
    /// Take sample `k` at ray parameter `t`, voxel-space point `p`;
    /// `cell` is the sample's level-0 macrocell when the loop looked it up
    /// for this sample.
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: f32,
        p: Vec3,
        cell: Option<usize>,
    ) -> Flow;
    /// With adaptive steps: the next sample taken stands for `n` steps
    /// (until told otherwise; 1 when steps are not adaptive).
    #[inline(always)]
    fn stretch(&mut self, n: u32) {
        let _ = n;
    }
    /// Whether the loop may hand runs of eight samples to
    /// [`RayMarch::sample8`] with their trilinear values read at once (the
    /// samples read nothing else to find their value, nor their cell).
    const BATCH: bool = false;
    /// Whether this ray's samples are trilinear values (asked once per
    /// ray; a frame that reconstructs otherwise takes them one by one).
    #[inline(always)]
    fn reads_trilinear(&self) -> bool {
        true
    }
    /// Take samples `k .. k + 8` at ray parameters `t` (points
    /// `s.at(t[i])`), whose trilinear values are `v`, in order, exactly as
    /// [`RayMarch::sample`] would one by one; stop where it would.
    #[inline(always)]
    fn sample8<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: &[f32; 8],
        v: &[f32; 8],
        s: &RaySteps,
    ) -> Flow {
        let _ = v;
        one_by_one(self, cur, k, t, s)
    }
}

/// Take samples `k .. k + 8` at parameters `t` with [`RayMarch::sample`],
/// one at a time (what a run of eight is without lanes).
#[inline(always)]
pub fn one_by_one<M: RayMarch + ?Sized, C: Cursor>(
    m: &mut M,
    cur: &mut C,
    k: i64,
    t: &[f32; 8],
    s: &RaySteps,
) -> Flow {
    for (i, &ti) in t.iter().enumerate() {
        if m.sample(cur, k + i as i64, ti, s.at(ti), None) == Flow::Stop {
            return Flow::Stop;
        }
    }
    Flow::Next
}

/// Walk the samples of `steps` with the ray state `state`, skipping where
/// `accel` allows (when it is active for the frame); returns the number of
/// skips made. `k` is always a sample index (`t = k·step`).
///
/// With adaptive steps (`accel` strided), a busy level-0 cell's stretch of
/// samples takes its first sample and then those at multiples of the
/// cell's stride `2^s`, each standing for the steps up to the next sample
/// taken (told to the state by [`RayMarch::stretch`]); a run of eight
/// such samples is read in lanes as eight consecutive samples of the step
/// `2^s·step` (the same parameters, bit for bit). Stretches never merge
/// across cells, and a cell the frame's strides mark
/// [`crate::accel::strides::LOOK_UP`] (transparent, without skipping) is
/// looked up at every sample, so a visible cell's first sample is the
/// same with skipping on or off.
#[inline(always)]
pub fn march<C: Cursor, M: RayMarch, A: Accel<M::Query>>(
    state: &mut M,
    accel: &A,
    cur: &mut C,
    steps: &RaySteps,
) -> u32 {
    let mut skips = 0;
    let mut k = steps.start;
    // With CACHE_BUSY, samples up to `busy_until` lie in (or just past) a
    // level-0 cell found not skippable: they need no further check (its
    // flags are fixed for the frame, and taking a sample is never wrong).
    let mut busy_until = i64::MIN;
    // Runs of eight samples that need no skipping check (in a busy cell,
    // or all of them when nothing is skipped) read their values at once
    // where the integrator and the cursor allow it; the rest of a run
    // goes one by one.
    let on = A::ON && accel.active();
    let batch = M::BATCH && state.reads_trilinear() && (M::CACHE_BUSY || !on) && cur.batches();
    // Adaptive steps: `stride` is the log2 stride of the busy stretch up
    // to `busy_until` (0: every sample).
    let strided = on && M::CACHE_BUSY && accel.strided();
    let mut stride = 0u32;
    let (o, d) = (steps.ray.o.to_array(), steps.ray.d.to_array());
    // When a run of eight would cross the end of a busy cell, the loop
    // looks one sample ahead: if that sample's cell is busy too (and, with
    // adaptive steps, both take every sample), the busy stretch grows to
    // its exit (the same samples are taken, in longer runs); otherwise
    // the answer is kept for when the loop reaches it.
    let mut ahead: Option<(i64, Step)> = None;
    while k <= steps.k1 {
        if batch && stride != 0 {
            if let Some(flow) = strided_run8(state, cur, k, stride, busy_until, steps) {
                if flow == Flow::Stop {
                    break;
                }
                k += 8 << stride;
                continue;
            }
        } else if batch {
            if on && k <= busy_until && busy_until < steps.k1 && k.saturating_add(7) > busy_until {
                let next = busy_until + 1;
                if ahead.is_none_or(|(at, _)| at != next) {
                    let step = accel.step(steps.at(steps.t(next)), &steps.ray, state.query());
                    ahead = Some((next, step));
                    if let Step::Busy { exit, cell } = step {
                        if accel.stride_log2(cell) == 0 {
                            busy_until = busy_until.max(steps.last_before(exit));
                        }
                    }
                }
            }
            let last = if on {
                busy_until.min(steps.k1)
            } else {
                steps.k1
            };
            if k.saturating_add(7) <= last {
                if let Some(run) = cur.trilinear8(o, d, k, steps.step) {
                    if state.sample8(cur, k, &run.t, &run.v, steps) == Flow::Stop {
                        break;
                    }
                    k += 8;
                    continue;
                }
            }
        }
        let t = steps.t(k);
        let p = steps.at(t);
        let mut cell = None;
        if on && (!M::CACHE_BUSY || k > busy_until) {
            let step = match ahead {
                Some((at, step)) if at == k => step,
                _ => accel.step(p, &steps.ray, state.query()),
            };
            match step {
                Step::Skip { until, cell: c } => {
                    if let Some(kn) = steps.after_skip(k, until) {
                        // A jump may end past the ray's last sample: only
                        // the ray's own samples were skipped.
                        let to = kn.min(steps.k1.saturating_add(1));
                        if state.skipped(cur, k, to, steps) == Flow::Stop {
                            break;
                        }
                        k = kn;
                        skips += 1;
                        continue;
                    }
                    cell = Some(c);
                    if strided {
                        stride = 0;
                        state.stretch(1);
                    }
                }
                Step::Busy { exit, cell: c } => {
                    if strided {
                        stride = accel.stride_log2(c);
                        if stride == LOOK_UP {
                            stride = 0;
                        } else {
                            busy_until = steps.last_before(exit);
                        }
                        if stride == 0 {
                            state.stretch(1);
                        }
                    } else if M::CACHE_BUSY {
                        busy_until = steps.last_before(exit);
                    }
                    cell = Some(c);
                    // A busy stretch's first eight samples go in lanes too
                    // (integrators that batch read no cell).
                    if batch && stride == 0 && k.saturating_add(7) <= busy_until.min(steps.k1) {
                        if let Some(run) = cur.trilinear8(o, d, k, steps.step) {
                            if state.sample8(cur, k, &run.t, &run.v, steps) == Flow::Stop {
                                break;
                            }
                            k += 8;
                            continue;
                        }
                    }
                }
            }
        }
        // A strided stretch's sample stands for the steps to the next one
        // (its stretch told each time: the last before a cell's exit is
        // cut short); otherwise every sample is taken, each one step (told
        // once, when the stretch began).
        let next = if stride != 0 {
            let next = strided_next(k, stride, busy_until.min(steps.last));
            state.stretch((next - k) as u32);
            next
        } else {
            k + 1
        };
        if state.sample(cur, k, t, p, cell) == Flow::Stop {
            break;
        }
        k = next;
    }
    skips
}

/// Where the strides mark a cell to be looked up at every sample
/// ([`crate::accel::strides::LOOK_UP`]).
const LOOK_UP: u32 = crate::accel::strides::LOOK_UP as u32;

/// With stride `2^log2`, the sample after `k` in a stretch ending at
/// `last`: the next multiple of the stride, or the one past the stretch,
/// whichever comes first (always past `k`).
#[inline(always)]
fn strided_next(k: i64, log2: u32, last: i64) -> i64 {
    let s = 1i64 << log2;
    let aligned = (k.div_euclid(s) + 1) * s;
    aligned.min(last.saturating_add(1)).max(k + 1)
}

/// Samples `k, k + 2^stride, …` (eight of them) read at once and taken
/// as eight consecutive samples of the step `2^stride·step`, when they all
/// lie in the stretch up to `busy_until` (each standing for `2^stride`
/// steps: the stretch holds the one after the eighth too) and the cursor
/// reads them in lanes; `None` to take `k` alone.
#[inline(always)]
fn strided_run8<C: Cursor, M: RayMarch>(
    state: &mut M,
    cur: &mut C,
    k: i64,
    stride: u32,
    busy_until: i64,
    steps: &RaySteps,
) -> Option<Flow> {
    let s = 1i64 << stride;
    let last = busy_until.min(steps.last).min(steps.k1);
    if k & (s - 1) != 0 || k.saturating_add(8 * s - 1) > last {
        return None;
    }
    let (o, d) = (steps.ray.o.to_array(), steps.ray.d.to_array());
    // `(k/s + i)·(s·step)` is `(k + i·s)·step` rounded once, as each
    // sample's own parameter is (`s` is a power of two).
    let run = cur.trilinear8(o, d, k >> stride, steps.step * s as f64)?;
    state.stretch(s as u32);
    Some(state.sample8(cur, k, &run.t, &run.v, steps))
}
