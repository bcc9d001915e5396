//! Iso-surfaces: the first crossing, refined by bisection, shaded.

use super::sample::{central_gradient, value, value_and_analytic_gradient};
use super::{RayCtx, RayResult, Walk};
use crate::ray::Ray;
use crate::skip::ISO_ABOVE;
use volcore::Cursor;

/// Bisection steps refining a crossing (the bracket shrinks 2^-20-fold).
const BISECTIONS: u32 = 20;

/// March until the sample class (value ≥ iso, NaN counting as below)
/// changes between consecutive samples; outside the volume counts as
/// below. The crossing is then bracketed by those two samples and refined
/// by bisection. `ESS` skips cells whose every value is on one side (their
/// class is known without sampling).
#[allow(clippy::too_many_arguments)]
pub fn iso<C: Cursor, const TRI: bool, const ANALYTIC: bool, const ESS: bool>(
    ctx: &RayCtx,
    cur: &mut C,
    ray: &Ray,
    t0: f32,
    t1: f32,
    level: f32,
) -> RayResult {
    let mut out = RayResult::empty();
    let w = Walk::new(ctx, ray, t0, t1);
    let above = |v: f32| v >= level;
    let mut prev = false;
    let mut k = w.k0;
    while k <= w.k1 {
        let t = w.t(k);
        let p = w.at(t);
        let class = if let (true, Some(skip)) = (ESS, ctx.skip) {
            match skip.flag_at(p) {
                0 => None,
                flag => Some(flag == ISO_ABOVE),
            }
        } else {
            None
        };
        let class = match class {
            Some(c) => {
                if c == prev {
                    // Uniform cell on the side we are on: jump through it.
                    let flag = if c { ISO_ABOVE } else { crate::skip::ISO_BELOW };
                    if let Some(skip) = ctx.skip {
                        if let Some(u) = skip.skip_until(p, w.o, w.d, w.inv_d, |_, _, f| f == flag)
                        {
                            if let Some(kn) = w.after_skip(k, u) {
                                k = kn;
                                out.skips += 1;
                                continue;
                            }
                        }
                    }
                }
                c
            }
            None => {
                out.samples += 1;
                above(value::<C, TRI>(&w.loc, cur, p))
            }
        };
        if class != prev {
            let lo_t = if k > w.k0 { w.t(k - 1) } else { t0.min(t) };
            let hit = refine::<C, TRI>(cur, &w, lo_t, t, class, level);
            out.samples += BISECTIONS;
            shade_hit::<C, TRI, ANALYTIC>(ctx, cur, ray, &w, hit, &mut out);
            return out;
        }
        prev = class;
        k += 1;
    }
    out
}

/// Bisect `[a, b]`, where the class at `b` is `class_b` and at `a` the
/// opposite, down to `BISECTIONS` halvings; returns the midpoint.
fn refine<C: Cursor, const TRI: bool>(
    cur: &mut C,
    w: &Walk,
    mut a: f32,
    mut b: f32,
    class_b: bool,
    level: f32,
) -> f32 {
    for _ in 0..BISECTIONS {
        let m = 0.5 * (a + b);
        if (value::<C, TRI>(&w.loc, cur, w.at(m)) >= level) == class_b {
            b = m;
        } else {
            a = m;
        }
    }
    0.5 * (a + b)
}

fn shade_hit<C: Cursor, const TRI: bool, const ANALYTIC: bool>(
    ctx: &RayCtx,
    cur: &mut C,
    ray: &Ray,
    w: &Walk,
    t: f32,
    out: &mut RayResult,
) {
    let p = w.at(t);
    let (v, g) = if ANALYTIC {
        value_and_analytic_gradient::<C, TRI>(&w.loc, cur, p)
    } else {
        (
            value::<C, TRI>(&w.loc, cur, p),
            central_gradient(&w.loc, cur, p),
        )
    };
    let g = g * ctx.inv_spacing;
    let c = if g.length() > 0.0 {
        ctx.lighting.shade(ctx.iso_colour, g, ray.dir)
    } else {
        ctx.iso_colour * ctx.lighting.ambient
    };
    out.rgba = [c.x, c.y, c.z, 1.0];
    out.value = v;
    out.depth = t;
}
