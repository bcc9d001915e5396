//! Transmittance toward a light by marching a shadow ray.
//!
//! Shadow samples lie at `t = k·step` for `k ≥ 1` from the shaded point
//! (the point's own sample is the view ray's), through the volume's box
//! (and no farther than a point light). Cells the skipping rule marks
//! clear are jumped over, as on view rays. The ray stops once its optical
//! depth passes [`SHADOW_DEPTH_CUTOFF`] and then counts as fully shadowed.

use super::occluder::Occluder;
use super::SHADOW_DEPTH_CUTOFF;
use crate::accel::Accel;
use crate::trace::march::{march, Flow, RayMarch, RaySteps};
use glam::Vec3;
use volcore::Cursor;

/// The transmittance along `steps` (samples from `k = steps.k0`) through
/// `occ` with query `q`, skipping with `accel`; and the samples taken.
/// In `[0, 1]`: 0 once the depth passes the cutoff (or is infinite),
/// `exp(−depth)` otherwise.
#[inline]
pub fn transmittance<C, O, A>(
    occ: &O,
    accel: &A,
    cur: &mut C,
    steps: &RaySteps,
    q: O::Query,
) -> (f32, u32)
where
    C: Cursor,
    O: Occluder,
    A: Accel<O::Query>,
{
    let mut m = ShadowMarch {
        occ,
        q,
        depth: 0.0,
        samples: 0,
    };
    march(&mut m, accel, cur, steps);
    let t = if m.depth > SHADOW_DEPTH_CUTOFF {
        0.0
    } else {
        (-m.depth).exp()
    };
    (t, m.samples)
}

struct ShadowMarch<'o, O: Occluder> {
    occ: &'o O,
    q: O::Query,
    depth: f32,
    samples: u32,
}

impl<O: Occluder> RayMarch for ShadowMarch<'_, O> {
    type Query = O::Query;
    // The query is fixed for the whole shadow ray, so a busy cell stays
    // busy.
    const CACHE_BUSY: bool = true;

    #[inline(always)]
    fn query(&self) -> O::Query {
        self.q
    }

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        _: i64,
        _: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let depth = self.occ.depth(cur, p, self.q);
        self.add(depth)
    }

    const BATCH: bool = O::FROM_VALUE;

    #[inline(always)]
    fn reads_trilinear(&self) -> bool {
        self.occ.trilinear()
    }

    #[inline(always)]
    fn sample8<C: Cursor>(
        &mut self,
        _: &mut C,
        _: i64,
        _: &[f32; 8],
        v: &[f32; 8],
        _: &RaySteps,
    ) -> Flow {
        for d in self.occ.depth8(v, self.q) {
            if self.add(d) == Flow::Stop {
                return Flow::Stop;
            }
        }
        Flow::Next
    }
}

impl<O: Occluder> ShadowMarch<'_, O> {
    /// Count a sample of optical depth `depth`; stop past the cutoff.
    #[inline(always)]
    fn add(&mut self, depth: f32) -> Flow {
        self.samples += 1;
        self.depth += depth;
        if self.depth > SHADOW_DEPTH_CUTOFF {
            Flow::Stop
        } else {
            Flow::Next
        }
    }
}
