//! Emission-absorption compositing, front to back.
//!
//! The integrator ([`Dvr`]) is generic only over what changes its inner
//! loop: gradient method, classifier (1D or 2D) and shading ([`shading`]:
//! unshaded or Blinn-Phong). The reconstruction, early termination and
//! empty-space skipping are runtime values, decided once per ray or per
//! sample taken one by one; the frame's set-up ([`crate::frame::dvr`])
//! picks the types.

pub mod shading;

use crate::accel::FixedCells;
use crate::classify::{over, Classifier};
use crate::ray::Ray;
use crate::trace::march::{march, one_by_one, Flow, RayMarch, RaySteps};
use crate::trace::reconstruct::{Gradient, Interp};
use crate::trace::{FrameGeometry, Integrator, RayResult, Span};
use glam::Vec3;
use shading::Shading;
use std::marker::PhantomData;
use volcore::grid::Locator;
use volcore::Cursor;

/// Emission-absorption: composite `C += (1 − A)·α·c`, `A += (1 − A)·α`
/// front to back over the samples, each classified by `K` (reading its
/// gradient, from `G`, when `K` asks for it), lit by `S`, skipping the
/// cells the frame found transparent (when skipping is on), stopping once
/// the opacity reaches the termination threshold (infinite when early
/// termination is off).
pub struct Dvr<'a, G, K, S> {
    geom: FrameGeometry,
    classifier: &'a K,
    shading: S,
    termination: f32,
    skip: Option<&'a FixedCells<'a>>,
    _gradient: PhantomData<G>,
}

impl<'a, G, K, S> Dvr<'a, G, K, S> {
    /// The integrator from its parts: rays stop once their opacity reaches
    /// `termination` (`None`: they run to the end of the volume), and skip
    /// the cells of `skip` (`None`: no skipping).
    pub fn new(
        geom: FrameGeometry,
        classifier: &'a K,
        shading: S,
        termination: Option<f32>,
        skip: Option<&'a FixedCells<'a>>,
    ) -> Self {
        Dvr {
            geom,
            classifier,
            shading,
            // An opacity never reaches infinity: no ray stops early.
            termination: termination.unwrap_or(f32::INFINITY),
            skip,
            _gradient: PhantomData,
        }
    }
}

impl<G, K, S> Integrator for Dvr<'_, G, K, S>
where
    G: Gradient,
    K: Classifier,
    S: Shading,
{
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = DvrRay {
            dvr: self,
            steps: &steps,
            front: None,
            loc: self.geom.locator,
            inv_spacing: self.geom.inv_spacing,
            interp: self.geom.interp,
            view: self.shading.for_ray(ray, pixel),
            colour: Vec3::ZERO,
            alpha: 0.0,
            samples: 0,
            stretch: 1,
        };
        let skips = march(&mut st, &self.skip, cur, &steps);
        RayResult {
            rgba: [st.colour.x, st.colour.y, st.colour.z, st.alpha],
            samples: st.samples,
            skips,
            effects: S::effects(&st.view),
            ..RayResult::empty()
        }
    }
}

struct DvrRay<'d, 'a, G, K, S: Shading> {
    dvr: &'d Dvr<'a, G, K, S>,
    /// The ray's samples (read again for a segment's front sample).
    steps: &'d RaySteps,
    /// For classifiers of segments: the value of the sample before the
    /// next one taken, when the ray took it (`None`: read it again).
    front: Option<f32>,
    // Copies of the frame geometry the samples read, local to the ray so
    // they stay in registers.
    loc: Locator,
    inv_spacing: Vec3,
    interp: Interp,
    view: S::PerRay,
    colour: Vec3,
    alpha: f32,
    samples: u32,
    /// Steps the next sample stands for (adaptive steps; else 1).
    stretch: u32,
}

impl<G, K, S> RayMarch for DvrRay<'_, '_, G, K, S>
where
    G: Gradient,
    K: Classifier,
    S: Shading,
{
    type Query = ();
    const CACHE_BUSY: bool = true;

    #[inline(always)]
    fn query(&self) {}

    #[inline(always)]
    fn stretch(&mut self, n: u32) {
        self.stretch = n;
    }

    const BATCH: bool = G::FROM_VALUE.is_some();

    #[inline(always)]
    fn reads_trilinear(&self) -> bool {
        self.interp.is_trilinear()
    }

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let (v, early) = G::value(self.interp, &self.loc, cur, p);
        self.take(cur, k, t, p, v, early, None)
    }

    /// With a classifier of segments, the segment that ends at the first
    /// skipped sample is taken: it may cross values the skipped cells do
    /// not hold. The segments between skipped samples lie inside the
    /// skipped block, so they are transparent; the one after the skip is
    /// taken with the sample that ends it, whose front is read again.
    #[inline(always)]
    fn skipped<C: Cursor>(&mut self, cur: &mut C, from: i64, to: i64, s: &RaySteps) -> Flow {
        if !K::SEGMENTS {
            return Flow::Next;
        }
        let t = s.t(from);
        let p = s.at(t);
        let (v, early) = G::value(self.interp, &self.loc, cur, p);
        let flow = self.take(cur, from, t, p, v, early, None);
        if to > from + 1 {
            self.front = None;
        }
        flow
    }

    #[inline(always)]
    fn sample8<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: &[f32; 8],
        v: &[f32; 8],
        s: &RaySteps,
    ) -> Flow {
        let Some(early) = G::FROM_VALUE else {
            // Not reached: BATCH is false for such gradients.
            return one_by_one(self, cur, k, t, s);
        };
        if S::LANES && G::reads_lane_blends() && !K::NEEDS_GRADIENT {
            return self.take8(cur, k, t, v, early, s);
        }
        // Shaded frames read the central-difference blends of all eight in
        // lanes too, once the first visible sample of the run asks for a
        // gradient (runs with none visible read none); samples whose cells
        // are not interior compute their own.
        let mut cross = None;
        for (i, (&ti, &vi)) in t.iter().zip(v).enumerate() {
            let lanes = LaneGradients {
                cross: &mut cross,
                lane: i,
                k,
                stretch: self.stretch,
                steps: s,
            };
            let ki = k + i as i64;
            if self.take(cur, ki, ti, s.at(ti), vi, early, Some(lanes)) == Flow::Stop {
                return Flow::Stop;
            }
        }
        Flow::Next
    }
}

impl<G, K, S> DvrRay<'_, '_, G, K, S>
where
    G: Gradient,
    K: Classifier,
    S: Shading,
{
    /// Classify, shade and composite sample `k` of value `v` at ray
    /// parameter `t`, point `p` (`early`: what reading `v` gave the
    /// gradient; `lanes`: the run of eight it belongs to, whose gradients
    /// can be read together).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn take<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: f32,
        p: Vec3,
        v: f32,
        early: G::Early,
        lanes: Option<LaneGradients<'_>>,
    ) -> Flow {
        let d = self.dvr;
        let loc = &self.loc;
        self.samples += 1;
        // A classifier that reads the gradient gets it first, and shading
        // reuses it; otherwise only visible samples compute one.
        let (e, mut grad, mut len2) = if K::NEEDS_GRADIENT {
            let g = G::gradient(early, loc, cur, p) * self.inv_spacing;
            let len2 = g.length_squared();
            (d.classifier.classify(v, len2.sqrt()), g, len2)
        } else if K::SEGMENTS {
            (self.segment_entry(cur, k, v), Vec3::ZERO, 0.0)
        } else {
            (d.classifier.classify(v, 0.0), Vec3::ZERO, 0.0)
        };
        if e[3] > 0.0 {
            let e = self.stretched(e);
            let mut c = Vec3::new(e[0], e[1], e[2]);
            if S::ON {
                if !K::NEEDS_GRADIENT {
                    let blend = match lanes {
                        Some(l) if G::reads_lane_blends() => l.blend(cur),
                        _ => None,
                    };
                    grad = self.world_gradient(cur, blend, early, p);
                    len2 = grad.length_squared();
                }
                c = d.shading.shade(&mut self.view, cur, c, grad, len2, t);
            }
            return self.composite(c, e[3]);
        }
        Flow::Next
    }

    /// The value of the sample before sample `k` (of value `v`): the one
    /// the ray holds, else read again; `None` for the ray's first sample.
    /// `v` becomes the front of the next sample.
    #[inline(always)]
    fn front_of<C: Cursor>(&mut self, cur: &mut C, k: i64, v: f32) -> Option<f32> {
        let front = match self.front {
            Some(f) => Some(f),
            None if k > self.steps.k0 => {
                let s = self.steps;
                Some(G::value(self.interp, &self.loc, cur, s.at(s.t(k - 1))).0)
            }
            None => None,
        };
        self.front = Some(v);
        front
    }

    /// For a classifier of segments, the entry of sample `k` of value `v`:
    /// the segment from the sample before it; half a step of `v` before
    /// the ray's first sample, and half a step after its last, so the
    /// samples cover the ray as single samples do.
    #[inline(always)]
    fn segment_entry<C: Cursor>(&mut self, cur: &mut C, k: i64, v: f32) -> [f32; 4] {
        let c = self.dvr.classifier;
        let e = match self.front_of(cur, k, v) {
            Some(front) => c.classify_segment(front, v),
            None => c.classify_half(v),
        };
        if k == self.steps.last {
            over(e, c.classify_half(v))
        } else {
            e
        }
    }

    /// The entries of samples `k .. k + 8` of values `v`: each alone, or
    /// each the segment from the sample before it.
    #[inline(always)]
    fn classify8<C: Cursor>(&mut self, cur: &mut C, k: i64, v: &[f32; 8]) -> [[f32; 4]; 8] {
        if !K::SEGMENTS {
            return self.dvr.classifier.classify8(v);
        }
        std::array::from_fn(|i| self.segment_entry(cur, k + i as i64, v[i]))
    }

    /// The world gradient at `p`: from the blend of its cell's central
    /// differences where the run read it (what `central_gradient` gives
    /// for an interior cell), else from `G`.
    #[inline(always)]
    fn world_gradient<C: Cursor>(
        &self,
        cur: &mut C,
        blend: Option<Vec3>,
        early: G::Early,
        p: Vec3,
    ) -> Vec3 {
        let g = match blend {
            Some(b) => b * 0.5,
            None => G::gradient(early, &self.loc, cur, p),
        };
        g * self.inv_spacing
    }

    /// Entry `e` for a sample that stands for [`Self::stretch`] steps:
    /// its opacity `1 − (1 − α)^n` (in f64: exact at 0 and 1, and
    /// accurate for small α; never below α, so a visible sample stays
    /// visible), the colour unchanged.
    #[inline(always)]
    fn stretched(&self, mut e: [f32; 4]) -> [f32; 4] {
        if self.stretch != 1 && e[3] > 0.0 {
            let a = (1.0 - (1.0 - f64::from(e[3])).powi(self.stretch as i32)) as f32;
            e[3] = a.max(e[3]);
        }
        e
    }

    /// Composite colour `c` of opacity `alpha` behind what the ray holds;
    /// stop once the termination rule says so.
    #[inline(always)]
    fn composite(&mut self, c: Vec3, alpha: f32) -> Flow {
        let weight = (1.0 - self.alpha) * alpha;
        self.colour += c * weight;
        self.alpha += weight;
        if self.alpha >= self.dvr.termination {
            Flow::Stop
        } else {
            Flow::Next
        }
    }

    /// Samples `k .. k + 8` (parameters `t`, values `v`) as [`Self::take`]
    /// takes them one by one, with the visible ones' gradients read and
    /// their shading worked out in lanes; the same bits. For classifiers
    /// that read no gradient and central-difference gradients.
    #[inline(always)]
    fn take8<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: &[f32; 8],
        v: &[f32; 8],
        early: G::Early,
        s: &RaySteps,
    ) -> Flow {
        let d = self.dvr;
        let mut e = self.classify8(cur, k, v);
        if !e.iter().any(|e| e[3] > 0.0) {
            self.samples += 8;
            return Flow::Next;
        }
        if self.stretch != 1 {
            e = e.map(|e| self.stretched(e));
        }
        // Visible samples' gradients: the run's blends where the cell is
        // interior, `central_gradient` elsewhere (what `take` reads).
        let mut cross = None;
        let (mut colour, mut grad) = ([[0f32; 8]; 3], [[0f32; 8]; 3]);
        let mut visible = 0u8;
        for (i, e) in e.iter().enumerate() {
            if e[3] > 0.0 {
                visible |= 1 << i;
                let lanes = LaneGradients {
                    cross: &mut cross,
                    lane: i,
                    k,
                    stretch: self.stretch,
                    steps: s,
                };
                let blend = lanes.blend(cur);
                let g = self.world_gradient(cur, blend, early, s.at(t[i]));
                for j in 0..3 {
                    colour[j][i] = e[j];
                    grad[j][i] = g[j];
                }
            }
        }
        // The visible samples the ray composites before it terminates
        // (the same opacity sums `composite` makes): only those are shaded,
        // as one by one, so effects count the same work.
        let mut reached = 0u8;
        let mut alpha = self.alpha;
        for (i, e) in e.iter().enumerate() {
            if visible >> i & 1 == 1 {
                reached |= 1 << i;
                alpha += (1.0 - alpha) * e[3];
                if alpha >= d.termination {
                    break;
                }
            }
        }
        let shaded = d.shading.shade8(&mut self.view, &colour, &grad, t, reached);
        for (i, e) in e.iter().enumerate() {
            self.samples += 1;
            if e[3] > 0.0 {
                let c = match shaded {
                    Some(sh) => Vec3::new(sh[0][i], sh[1][i], sh[2][i]),
                    None => {
                        let g = Vec3::new(grad[0][i], grad[1][i], grad[2][i]);
                        let c = Vec3::new(e[0], e[1], e[2]);
                        d.shading
                            .shade(&mut self.view, cur, c, g, g.length_squared(), t[i])
                    }
                };
                if self.composite(c, e[3]) == Flow::Stop {
                    return Flow::Stop;
                }
            }
        }
        Flow::Next
    }
}

/// A sample's place in a run of eight read together (samples `k`,
/// `k + stretch`, …), and the run's central-difference blends, read in
/// lanes when first asked for.
struct LaneGradients<'a> {
    cross: &'a mut Option<Option<volcore::grid::Cross8>>,
    lane: usize,
    k: i64,
    /// Steps between the run's samples: a power of two that divides `k`.
    stretch: u32,
    steps: &'a RaySteps,
}

impl LaneGradients<'_> {
    /// The blend (not halved) at this sample, if its cell is interior and
    /// the cursor reads the run's blends in lanes.
    #[inline(always)]
    fn blend<C: Cursor>(self, cur: &mut C) -> Option<Vec3> {
        let s = self.steps;
        // The run as eight consecutive samples of `stretch` steps (as the
        // march read their values).
        let (k, step) = (
            self.k.div_euclid(i64::from(self.stretch)),
            s.step * f64::from(self.stretch),
        );
        let c = (*self.cross.get_or_insert_with(|| {
            cur.cross_blend8(s.ray.o.to_array(), s.ray.d.to_array(), k, step)
        }))?;
        let i = self.lane;
        (c.interior >> i & 1 == 1).then(|| Vec3::new(c.g[0][i], c.g[1][i], c.g[2][i]))
    }
}
