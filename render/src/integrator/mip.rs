//! Projections that reduce the samples to one value: MIP, MinIP, X-ray.

use super::sample::value;
use super::{RayCtx, RayResult, Walk};
use crate::ray::Ray;
use volcore::Cursor;

/// Maximum (`MAX = true`) or minimum intensity along the ray. `ESS` skips
/// cells whose range cannot beat the running value; `ERT` stops once the
/// running value reaches the volume's extreme (nothing can beat it). NaN
/// samples are ignored.
pub fn mip<C: Cursor, const TRI: bool, const MAX: bool, const ESS: bool, const ERT: bool>(
    ctx: &RayCtx,
    cur: &mut C,
    ray: &Ray,
    t0: f32,
    t1: f32,
) -> RayResult {
    let mut out = RayResult::empty();
    let w = Walk::new(ctx, ray, t0, t1);
    let mut best = if MAX {
        f32::NEG_INFINITY
    } else {
        f32::INFINITY
    };
    let extreme = if MAX {
        ctx.value_range.1
    } else {
        ctx.value_range.0
    };
    let mut k = w.k0;
    while k <= w.k1 {
        let t = w.t(k);
        let p = w.at(t);
        if ESS {
            if let Some(skip) = ctx.skip {
                let levels = skip.index().levels();
                let cannot_beat = |l: usize, i: usize, _| {
                    if MAX {
                        levels[l].max()[i] <= best
                    } else {
                        levels[l].min()[i] >= best
                    }
                };
                if let Some(u) = skip.skip_until(p, w.o, w.d, w.inv_d, cannot_beat) {
                    if let Some(kn) = w.after_skip(k, u) {
                        k = kn;
                        out.skips += 1;
                        continue;
                    }
                }
            }
        }
        let v = value::<C, TRI>(&w.loc, cur, p);
        out.samples += 1;
        if (MAX && v > best) || (!MAX && v < best) {
            best = v;
            out.depth = t;
            if ERT && ((MAX && best >= extreme) || (!MAX && best <= extreme)) {
                break;
            }
        }
        k += 1;
    }
    if best.is_finite() {
        out.value = best;
    }
    out
}

/// X-ray: the sum of `value × step` along the ray (`MEAN = false`, the line
/// integral in value·world units) or the mean sample value (`MEAN = true`).
/// NaN samples count as 0. `ESS` skips cells holding only zeros (counting
/// their samples, so the mean stays exact). Accumulates in f64.
pub fn xray<C: Cursor, const TRI: bool, const MEAN: bool, const ESS: bool>(
    ctx: &RayCtx,
    cur: &mut C,
    ray: &Ray,
    t0: f32,
    t1: f32,
) -> RayResult {
    let mut out = RayResult::empty();
    let w = Walk::new(ctx, ray, t0, t1);
    let mut sum = 0.0f64;
    let mut count = 0i64;
    let mut k = w.k0;
    while k <= w.k1 {
        let t = w.t(k);
        let p = w.at(t);
        if ESS {
            if let Some(skip) = ctx.skip {
                if let Some(u) = skip.skip_until(p, w.o, w.d, w.inv_d, |_, _, f| f != 0) {
                    if let Some(kn) = w.after_skip(k, u) {
                        count += kn - k;
                        k = kn;
                        out.skips += 1;
                        continue;
                    }
                }
            }
        }
        let v = value::<C, TRI>(&w.loc, cur, p);
        out.samples += 1;
        if !v.is_nan() {
            sum += v as f64;
        }
        count += 1;
        k += 1;
    }
    if count > 0 {
        out.value = if MEAN {
            (sum / count as f64) as f32
        } else {
            (sum * w.step) as f32
        };
    }
    out
}
