//! Emission-absorption compositing, front to back.

use super::march::{march, Flow, RayMarch, RaySteps};
use super::reconstruct::{Gradient, Reconstruct};
use super::{FrameGeometry, Integrator, RayResult};
use crate::accel::Accel;
use crate::classify::Classifier;
use crate::ray::Ray;
use crate::shade::{Lighting, ViewShading};
use glam::Vec3;
use std::marker::PhantomData;
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
    /// What the shading works out once per ray.
    type PerRay: Copy;
    /// Whether it shades at all (then the integrator computes gradients
    /// of visible samples).
    const ON: bool;
    /// The per-ray part for a ray along unit `dir`.
    fn for_ray(&self, dir: Vec3) -> Self::PerRay;
    /// `colour` lit at a point whose world-space gradient is `grad`, of
    /// squared length `len2`.
    fn shade(&self, per_ray: &Self::PerRay, colour: Vec3, grad: Vec3, len2: f32) -> Vec3;
}

/// Classified colour as is.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unshaded;

impl Shading for Unshaded {
    type PerRay = ();
    const ON: bool = false;
    #[inline(always)]
    fn for_ray(&self, _: Vec3) {}
    #[inline(always)]
    fn shade(&self, _: &(), colour: Vec3, _: Vec3, _: f32) -> Vec3 {
        colour
    }
}

/// Blinn-Phong where the gradient is long enough to give a normal.
#[derive(Clone, Copy, Debug)]
pub struct Phong {
    /// Light and reflection model.
    pub lighting: Lighting,
    /// Shade only where the squared gradient length exceeds this.
    pub threshold2: f32,
}

impl Shading for Phong {
    type PerRay = ViewShading;
    const ON: bool = true;
    #[inline(always)]
    fn for_ray(&self, dir: Vec3) -> ViewShading {
        self.lighting.for_view(dir)
    }
    #[inline(always)]
    fn shade(&self, view: &ViewShading, colour: Vec3, grad: Vec3, len2: f32) -> Vec3 {
        if len2 > self.threshold2 {
            view.shade_normal(colour, grad * len2.sqrt().recip())
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
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, t0: f32, t1: f32) -> RayResult {
        let steps = RaySteps::new(&self.geom, ray, t0, t1);
        let mut st = DvrRay {
            dvr: self,
            view: self.shading.for_ray(ray.dir),
            colour: Vec3::ZERO,
            alpha: 0.0,
            samples: 0,
        };
        let skips = march(&mut st, &self.accel, cur, &steps);
        RayResult {
            rgba: [st.colour.x, st.colour.y, st.colour.z, st.alpha],
            samples: st.samples,
            skips,
            ..RayResult::empty()
        }
    }
}

struct DvrRay<'d, 'a, R, G, K, S: Shading, T, A> {
    dvr: &'d Dvr<'a, R, G, K, S, T, A>,
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

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        _: i64,
        _: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let d = self.dvr;
        let loc = &d.geom.locator;
        let (v, early) = G::value::<C, R>(loc, cur, p);
        self.samples += 1;
        // A classifier that reads the gradient gets it first, and shading
        // reuses it; otherwise only visible samples compute one.
        let (e, mut grad, mut len2) = if K::NEEDS_GRADIENT {
            let g = G::gradient(early, loc, cur, p) * d.geom.inv_spacing;
            let len2 = g.length_squared();
            (d.classifier.classify(v, len2.sqrt()), g, len2)
        } else {
            (d.classifier.classify(v, 0.0), Vec3::ZERO, 0.0)
        };
        if e[3] > 0.0 {
            let mut c = Vec3::new(e[0], e[1], e[2]);
            if S::ON {
                if !K::NEEDS_GRADIENT {
                    grad = G::gradient(early, loc, cur, p) * d.geom.inv_spacing;
                    len2 = grad.length_squared();
                }
                c = d.shading.shade(&self.view, c, grad, len2);
            }
            let weight = (1.0 - self.alpha) * e[3];
            self.colour += c * weight;
            self.alpha += weight;
            if d.termination.reached(self.alpha) {
                return Flow::Stop;
            }
        }
        Flow::Next
    }
}
