//! Iso-surfaces: the first crossing, refined by bisection, shaded.

use crate::accel::skip::{ISO_ABOVE, ISO_BELOW};
use crate::accel::{Accel, IsoSides};
use crate::effects::{AoSource, IsoInside, ShadowCaster};
use crate::ray::Ray;
use crate::shade::Lighting;
use crate::trace::march::{march, Flow, RayMarch, RaySteps};
use crate::trace::reconstruct::Gradient;
use crate::trace::{FrameGeometry, Integrator, RayResult, Span};
use glam::Vec3;
use std::marker::PhantomData;
use volcore::Cursor;

/// Bisection steps refining a crossing (the bracket shrinks 2^-20-fold).
const BISECTIONS: u32 = 20;

/// The first crossing of `level`: march until the sample class (value ≥
/// level, NaN counting as below) changes between consecutive samples;
/// outside the volume counts as below. The crossing is bracketed by those
/// two samples and refined by bisection, then shaded with the gradient
/// from `G`. With skipping on, cells whose every value is on the ray's side
/// are skipped, and a uniform cell's class is known without a sample.
pub struct Iso<'a, G> {
    geom: FrameGeometry,
    skip: Option<&'a IsoSides<'a>>,
    level: f32,
    /// Linear surface colour.
    colour: Vec3,
    lighting: &'a Lighting,
    /// Shadows, if the frame casts them.
    shadows: Option<&'a IsoCaster<'a>>,
    /// Ambient occlusion, if the frame asks for it.
    ao: Option<&'a AoSource<'a>>,
    _gradient: PhantomData<G>,
}

/// Shadows on an iso-surface: its inside blocks light.
pub type IsoCaster<'a> = ShadowCaster<'a, IsoInside, IsoSides<'a>>;

impl<'a, G> Iso<'a, G> {
    /// The integrator for iso value `level`, surface colour `colour`
    /// (linear) lit by `lighting`, skipping by `skip`, shadowed by
    /// `shadows` and occluded by `ao` when given.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        geom: FrameGeometry,
        skip: Option<&'a IsoSides<'a>>,
        level: f32,
        colour: Vec3,
        lighting: &'a Lighting,
        shadows: Option<&'a IsoCaster<'a>>,
        ao: Option<&'a AoSource<'a>>,
    ) -> Self {
        Iso {
            geom,
            skip,
            level,
            colour,
            lighting,
            shadows,
            ao,
            _gradient: PhantomData,
        }
    }
}

impl<G: Gradient> Integrator for Iso<'_, G> {
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = IsoRay {
            iso: self,
            steps: &steps,
            ray,
            pixel,
            t0: span.t0,
            prev: false,
            out: RayResult::empty(),
        };
        // A share of the ray starts, like the whole ray, below the level:
        // the whole trace stops at its first crossing, so it is still below
        // wherever a later share's samples begin, and a crossing between
        // the last sample of one share and the first of the next is found
        // by the next (its bisection starts at the sample before, `k0`
        // being the whole ray's).
        let skips = march(&mut st, &self.skip, cur, &steps);
        RayResult { skips, ..st.out }
    }
}

struct IsoRay<'i, 'a, G> {
    iso: &'i Iso<'a, G>,
    steps: &'i RaySteps,
    ray: &'i Ray,
    pixel: [u32; 2],
    t0: f32,
    /// The class of the previous sample (above the level or not).
    prev: bool,
    out: RayResult,
}

impl<G: Gradient> RayMarch for IsoRay<'_, '_, G> {
    type Query = bool;
    const CACHE_BUSY: bool = false;

    #[inline(always)]
    fn query(&self) -> bool {
        self.prev
    }

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        k: i64,
        t: f32,
        p: Vec3,
        cell: Option<usize>,
    ) -> Flow {
        let iso = self.iso;
        // A uniform cell tells the class without a sample.
        let known = match cell.map(|c| iso.skip.flag(c)) {
            Some(ISO_ABOVE) => Some(true),
            Some(ISO_BELOW) => Some(false),
            _ => None,
        };
        let class = match known {
            Some(c) => c,
            None => {
                self.out.samples += 1;
                iso.geom.interp.value(&iso.geom.locator, cur, p) >= iso.level
            }
        };
        if class != self.prev {
            let s = self.steps;
            let lo_t = if k > s.k0 { s.t(k - 1) } else { self.t0.min(t) };
            let hit = self.refine(cur, lo_t, t, class);
            self.out.samples += BISECTIONS;
            self.shade_hit(cur, hit);
            return Flow::Stop;
        }
        self.prev = class;
        Flow::Next
    }
}

impl<G: Gradient> IsoRay<'_, '_, G> {
    /// Bisect `[a, b]`, where the class at `b` is `class_b` and at `a` the
    /// opposite, down to `BISECTIONS` halvings; returns the midpoint.
    fn refine<C: Cursor>(&self, cur: &mut C, mut a: f32, mut b: f32, class_b: bool) -> f32 {
        let geom = &self.iso.geom;
        for _ in 0..BISECTIONS {
            let m = 0.5 * (a + b);
            if (geom.interp.value(&geom.locator, cur, self.steps.at(m)) >= self.iso.level)
                == class_b
            {
                b = m;
            } else {
                a = m;
            }
        }
        0.5 * (a + b)
    }

    fn shade_hit<C: Cursor>(&mut self, cur: &mut C, t: f32) {
        let iso = self.iso;
        let loc = &iso.geom.locator;
        let p = self.steps.at(t);
        let (v, early) = G::value(iso.geom.interp, loc, cur, p);
        let g = G::gradient(early, loc, cur, p) * iso.geom.inv_spacing;
        let at = self.ray.origin + self.ray.dir * t;
        // The side the view ray arrived from is the outside: the gradient
        // points into it when the outside is above the level.
        let outside = self.prev;
        let fx = &mut self.out.effects;
        let ao = iso.ao.map_or(1.0, |src| {
            let n = crate::effects::outward_normal(if outside { -g } else { g });
            src.occlusion(at, n, self.pixel, 0, fx)
        });
        let c = if g.length() > 0.0 {
            match iso.shadows {
                None => iso
                    .lighting
                    .shade_shadowed(iso.colour, g, self.ray.dir, at, ao, |_, _| 1.0),
                Some(caster) => {
                    let mut light = |i: usize, inc: &crate::light::Incident| {
                        caster.transmittance(cur, i, at, inc, outside, fx)
                    };
                    iso.lighting
                        .shade_shadowed(iso.colour, g, self.ray.dir, at, ao, &mut light)
                }
            }
        } else {
            iso.colour * (iso.lighting.ambient * ao)
        };
        self.out.rgba = [c.x, c.y, c.z, 1.0];
        self.out.value = v as f64;
        self.out.depth = t;
    }
}
