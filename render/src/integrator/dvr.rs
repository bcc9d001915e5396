//! Emission-absorption compositing, front to back.

use super::march::{march, one_by_one, Flow, RayMarch, RaySteps};
use super::reconstruct::{Gradient, Reconstruct};
use super::{FrameGeometry, Integrator, RayResult, Span};
use crate::accel::Accel;
use crate::classify::Classifier;
use crate::effects::RayEffects;
use crate::light::Light;
use crate::ray::Ray;
use crate::shade::{Lanes3, Lighting, ViewShading};
use glam::Vec3;
use std::marker::PhantomData;
use volcore::grid::Locator;
use volcore::Cursor;

/// When a ray may stop before it leaves the volume.
pub trait Termination: Copy + Send + Sync + 'static {
    /// Whether accumulated opacity `alpha` ends the ray.
    fn reached(&self, alpha: f32) -> bool;
}

/// Rays run to the end of the volume.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoTermination;

/// Early ray termination: a ray stops once its opacity reaches the
/// threshold (what it would still gather is at most `1 − threshold`).
#[derive(Clone, Copy, Debug)]
pub struct OpacityThreshold(pub f32);

impl Termination for NoTermination {
    #[inline(always)]
    fn reached(&self, _: f32) -> bool {
        false
    }
}

impl Termination for OpacityThreshold {
    #[inline(always)]
    fn reached(&self, alpha: f32) -> bool {
        alpha >= self.0
    }
}

/// How a classified sample's colour is lit.
pub trait Shading: Sync {
    /// What the shading works out once per ray (and what it counts along
    /// it).
    type PerRay;
    /// Whether it shades at all (then the integrator computes gradients
    /// of visible samples).
    const ON: bool;
    /// The per-ray part for `ray` through `pixel`.
    fn for_ray(&self, ray: &Ray, pixel: [u32; 2]) -> Self::PerRay;
    /// `colour` lit at ray parameter `t`, where the world-space gradient
    /// is `grad`, of squared length `len2`; effects that sample the volume
    /// (shadows) read it through `cur`.
    fn shade<C: Cursor>(
        &self,
        per_ray: &mut Self::PerRay,
        cur: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3;
    /// What the effects did along the ray (nothing, for plain shading).
    #[inline(always)]
    fn effects(_per_ray: &Self::PerRay) -> RayEffects {
        RayEffects::default()
    }
    /// Whether [`Shading::shade8`] may shade runs of eight samples (it
    /// then reads nothing through a cursor).
    const LANES: bool = false;
    /// [`Shading::shade`] of eight samples at ray parameters `t` of
    /// colours `colour` and world gradients `grad` (per component, then
    /// per lane), bit for bit, for the lanes set in `visible` (the others
    /// are garbage); `None` where it cannot here (then the samples go one
    /// by one).
    #[inline(always)]
    fn shade8(
        &self,
        _per_ray: &mut Self::PerRay,
        _colour: &Lanes3,
        _grad: &Lanes3,
        _t: &[f32; 8],
        _visible: u8,
    ) -> Option<Lanes3> {
        None
    }
}

/// Classified colour as is.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unshaded;

impl Shading for Unshaded {
    type PerRay = ();
    const ON: bool = false;
    #[inline(always)]
    fn for_ray(&self, _: &Ray, _: [u32; 2]) {}
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        _: &mut (),
        _: &mut C,
        colour: Vec3,
        _: Vec3,
        _: f32,
        _: f32,
    ) -> Vec3 {
        colour
    }
}

/// Blinn-Phong with one light that arrives from the same direction all
/// along a ray (a headlight or a directional light): the light's part of
/// the shading is worked out once per ray. Samples whose gradient is too
/// short to give a normal keep their colour.
#[derive(Clone, Copy, Debug)]
pub struct Phong<'a> {
    lighting: &'a Lighting,
    light: Light,
    threshold2: f32,
}

/// Blinn-Phong with any lights (point lights, several lights): every
/// light is evaluated at each shaded sample.
#[derive(Clone, Copy, Debug)]
pub struct PhongLights<'a> {
    lighting: &'a Lighting,
    threshold2: f32,
}

/// Blinn-Phong shading of a frame, as the lights allow it to be computed.
#[derive(Clone, Copy, Debug)]
pub enum PhongShading<'a> {
    /// One per-ray light.
    OneLight(Phong<'a>),
    /// Any lights.
    Lights(PhongLights<'a>),
}

impl<'a> PhongShading<'a> {
    /// Shading with `lighting`, where the squared gradient length exceeds
    /// `threshold2`: the per-ray form when the lighting allows it.
    pub fn new(lighting: &'a Lighting, threshold2: f32) -> PhongShading<'a> {
        match lighting.single_per_ray_light() {
            Some(light) => PhongShading::OneLight(Phong {
                lighting,
                light,
                threshold2,
            }),
            None => PhongShading::Lights(PhongLights {
                lighting,
                threshold2,
            }),
        }
    }
}

impl Shading for Phong<'_> {
    type PerRay = ViewShading;
    const ON: bool = true;
    #[inline(always)]
    fn for_ray(&self, ray: &Ray, _: [u32; 2]) -> ViewShading {
        self.lighting.for_view(self.light, ray.dir)
    }
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        view: &mut ViewShading,
        _: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        _: f32,
    ) -> Vec3 {
        if len2 > self.threshold2 {
            view.shade_normal(colour, grad * len2.sqrt().recip())
        } else {
            colour
        }
    }
    const LANES: bool = true;
    #[inline(always)]
    fn shade8(
        &self,
        view: &mut ViewShading,
        colour: &Lanes3,
        grad: &Lanes3,
        _: &[f32; 8],
        _: u8,
    ) -> Option<Lanes3> {
        view.shade8(colour, grad, self.threshold2, None)
    }
}

impl Shading for PhongLights<'_> {
    type PerRay = Ray;
    const ON: bool = true;
    #[inline(always)]
    fn for_ray(&self, ray: &Ray, _: [u32; 2]) -> Ray {
        *ray
    }
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        ray: &mut Ray,
        _: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3 {
        if len2 > self.threshold2 {
            let p = ray.origin + ray.dir * t;
            self.lighting.shade_at(colour, grad, ray.dir, p)
        } else {
            colour
        }
    }
}

/// Emission-absorption: composite `C += (1 − A)·α·c`, `A += (1 − A)·α`
/// front to back over the samples, each classified by `K` (reading its
/// gradient, from `G`, when `K` asks for it), lit by `S`, skipping
/// transparent cells with `A`, stopping by `T`.
pub struct Dvr<'a, R, G, K, S, T, A> {
    geom: FrameGeometry,
    classifier: &'a K,
    shading: S,
    termination: T,
    accel: A,
    _choices: PhantomData<(R, G)>,
}

impl<'a, R, G, K, S, T, A> Dvr<'a, R, G, K, S, T, A> {
    /// The integrator from its parts.
    pub fn new(
        geom: FrameGeometry,
        classifier: &'a K,
        shading: S,
        termination: T,
        accel: A,
    ) -> Self {
        Dvr {
            geom,
            classifier,
            shading,
            termination,
            accel,
            _choices: PhantomData,
        }
    }
}

impl<R, G, K, S, T, A> Integrator for Dvr<'_, R, G, K, S, T, A>
where
    R: Reconstruct,
    G: Gradient,
    K: Classifier,
    S: Shading,
    T: Termination,
    A: Accel<()>,
{
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = DvrRay {
            dvr: self,
            loc: self.geom.locator,
            inv_spacing: self.geom.inv_spacing,
            view: self.shading.for_ray(ray, pixel),
            colour: Vec3::ZERO,
            alpha: 0.0,
            samples: 0,
        };
        let skips = march(&mut st, &self.accel, cur, &steps);
        RayResult {
            rgba: [st.colour.x, st.colour.y, st.colour.z, st.alpha],
            samples: st.samples,
            skips,
            effects: S::effects(&st.view),
            ..RayResult::empty()
        }
    }
}

struct DvrRay<'d, 'a, R, G, K, S: Shading, T, A> {
    dvr: &'d Dvr<'a, R, G, K, S, T, A>,
    // Copies of the frame geometry the samples read, local to the ray so
    // they stay in registers.
    loc: Locator,
    inv_spacing: Vec3,
    view: S::PerRay,
    colour: Vec3,
    alpha: f32,
    samples: u32,
}

impl<R, G, K, S, T, A> RayMarch for DvrRay<'_, '_, R, G, K, S, T, A>
where
    R: Reconstruct,
    G: Gradient,
    K: Classifier,
    S: Shading,
    T: Termination,
{
    type Query = ();
    const CACHE_BUSY: bool = true;

    #[inline(always)]
    fn query(&self) {}

    const BATCH: bool = R::TRILINEAR && G::FROM_VALUE.is_some();

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        _: i64,
        t: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let (v, early) = G::value::<C, R>(&self.loc, cur, p);
        self.take(cur, t, p, v, early, None)
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
        if S::LANES && G::CENTRAL && !K::NEEDS_GRADIENT {
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
                steps: s,
            };
            if self.take(cur, ti, s.at(ti), vi, early, Some(lanes)) == Flow::Stop {
                return Flow::Stop;
            }
        }
        Flow::Next
    }
}

impl<R, G, K, S, T, A> DvrRay<'_, '_, R, G, K, S, T, A>
where
    R: Reconstruct,
    G: Gradient,
    K: Classifier,
    S: Shading,
    T: Termination,
{
    /// Classify, shade and composite the sample of value `v` at ray
    /// parameter `t`, point `p` (`early`: what reading `v` gave the
    /// gradient; `lanes`: the run of eight it belongs to, whose gradients
    /// can be read together).
    #[inline(always)]
    fn take<C: Cursor>(
        &mut self,
        cur: &mut C,
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
        } else {
            (d.classifier.classify(v, 0.0), Vec3::ZERO, 0.0)
        };
        if e[3] > 0.0 {
            let mut c = Vec3::new(e[0], e[1], e[2]);
            if S::ON {
                if !K::NEEDS_GRADIENT {
                    let blend = match lanes {
                        Some(l) if G::CENTRAL => l.blend(cur),
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

    /// Composite colour `c` of opacity `alpha` behind what the ray holds;
    /// stop once the termination rule says so.
    #[inline(always)]
    fn composite(&mut self, c: Vec3, alpha: f32) -> Flow {
        let weight = (1.0 - self.alpha) * alpha;
        self.colour += c * weight;
        self.alpha += weight;
        if self.dvr.termination.reached(self.alpha) {
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
        let e = d.classifier.classify8(v);
        if !e.iter().any(|e| e[3] > 0.0) {
            self.samples += 8;
            return Flow::Next;
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
                if d.termination.reached(alpha) {
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

/// A sample's place in a run of eight read together, and the run's
/// central-difference blends, read in lanes when first asked for.
struct LaneGradients<'a> {
    cross: &'a mut Option<Option<volcore::grid::Cross8>>,
    lane: usize,
    k: i64,
    steps: &'a RaySteps,
}

impl LaneGradients<'_> {
    /// The blend (not halved) at this sample, if its cell is interior and
    /// the cursor reads the run's blends in lanes.
    #[inline(always)]
    fn blend<C: Cursor>(self, cur: &mut C) -> Option<Vec3> {
        let s = self.steps;
        let c = (*self.cross.get_or_insert_with(|| {
            cur.cross_blend8(s.ray.o.to_array(), s.ray.d.to_array(), self.k, s.step)
        }))?;
        let i = self.lane;
        (c.interior >> i & 1 == 1).then(|| Vec3::new(c.g[0][i], c.g[1][i], c.g[2][i]))
    }
}
