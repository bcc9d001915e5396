//! Emission-absorption compositing, front to back.

use super::sample::{central_gradient, value, value_and_analytic_gradient};
use super::{RayCtx, RayResult, Walk};
use crate::ray::Ray;
use crate::skip::Step;
use glam::Vec3;
use volcore::Cursor;

/// Composite `C += (1 − A)·α·c`, `A += (1 − A)·α` over the samples in
/// `[t0, t1]`. `SHADE` applies Blinn-Phong where the gradient is longer
/// than the threshold, with the `ANALYTIC` or central-difference gradient;
/// `ESS` skips cells whose opacity is zero under the table; `ERT` stops at
/// the termination threshold.
#[allow(clippy::too_many_arguments)]
pub fn dvr<
    C: Cursor,
    const TRI: bool,
    const SHADE: bool,
    const ANALYTIC: bool,
    const ESS: bool,
    const ERT: bool,
>(
    ctx: &RayCtx,
    cur: &mut C,
    ray: &Ray,
    t0: f32,
    t1: f32,
) -> RayResult {
    let mut out = RayResult::empty();
    let Some(table) = ctx.table else {
        return out;
    };
    let w = Walk::new(ctx, ray, t0, t1);
    let light = ctx.lighting.for_view(ray.dir);
    // Compared with squared lengths; never below 0, so a zero gradient is
    // never normalised.
    let threshold2 = ctx.gradient_threshold.max(0.0).powi(2);
    let mut colour = Vec3::ZERO;
    let mut alpha = 0.0f32;
    let mut k = w.k0;
    // Samples up to `busy_until` lie in (or just past) a level-0 cell found
    // not skippable: they need no further check (its flags are fixed for
    // the frame, and taking a sample is never wrong).
    let mut busy_until = i64::MIN;
    while k <= w.k1 {
        let t = w.t(k);
        let p = w.at(t);
        if ESS && k > busy_until {
            if let Some(skip) = ctx.skip {
                match skip.step(p, w.o, w.d, w.inv_d, |_, _, f| f != 0) {
                    Step::Skip(u) => {
                        if let Some(kn) = w.after_skip(k, u) {
                            k = kn;
                            out.skips += 1;
                            continue;
                        }
                    }
                    Step::Busy(exit) => busy_until = w.last_before(exit),
                }
            }
        }
        let (v, grad) = if SHADE && ANALYTIC {
            value_and_analytic_gradient::<C, TRI>(&w.loc, cur, p)
        } else {
            (value::<C, TRI>(&w.loc, cur, p), Vec3::ZERO)
        };
        out.samples += 1;
        let e = table.lookup(v);
        if e[3] > 0.0 {
            let mut c = Vec3::new(e[0], e[1], e[2]);
            if SHADE {
                let g = if ANALYTIC {
                    grad
                } else {
                    central_gradient(&w.loc, cur, p)
                } * ctx.inv_spacing;
                let len2 = g.length_squared();
                if len2 > threshold2 {
                    c = light.shade_normal(c, g * len2.sqrt().recip());
                }
            }
            let weight = (1.0 - alpha) * e[3];
            colour += c * weight;
            alpha += weight;
            if ERT && alpha >= ctx.ert {
                break;
            }
        }
        k += 1;
    }
    out.rgba = [colour.x, colour.y, colour.z, alpha];
    out
}
