//! A rank's share of every ray: the samples inside its box.

use crate::integrator::Span;
use crate::ray::Ray;

/// A rank's box in world coordinates, half-open: a point is inside when
/// `lo <= p < hi` on every axis; a missing plane is no bound (the boxes at
/// the volume's faces reach past them, so every sample of a ray inside the
/// volume falls in exactly one box).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShareBox {
    /// Lower planes (inclusive).
    pub lo: [Option<f32>; 3],
    /// Upper planes (exclusive).
    pub hi: [Option<f32>; 3],
}

impl ShareBox {
    /// The samples `lo ..= hi` of `span` along `ray` (samples at
    /// `t = k·step`) that lie in the box, or `None` when there are none.
    ///
    /// Exact for any set of boxes that split space along shared planes:
    /// a plane's crossing parameter is computed by the same expression
    /// for the boxes on both sides and the two sides round it the two
    /// ways of one half-open split, so every sample goes to one box.
    pub fn samples(&self, ray: &Ray, span: Span, step: f32) -> Option<(i64, i64)> {
        let step = f64::from(step);
        let mut lo_k = (f64::from(span.t0) / step).ceil() as i64;
        let mut hi_k = (f64::from(span.t1) / step).floor() as i64;
        for a in 0..3 {
            let (o, d) = (ray.origin[a], ray.dir[a]);
            let (lo, hi) = (self.lo[a], self.hi[a]);
            if d == 0.0 {
                if lo.is_some_and(|l| o < l) || hi.is_some_and(|h| o >= h) {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let t = |c: f32| f64::from((c - o) * inv) / step;
            if d > 0.0 {
                // Inside for t_lo <= t < t_hi.
                if let Some(l) = lo {
                    lo_k = lo_k.max(t(l).ceil() as i64);
                }
                if let Some(h) = hi {
                    hi_k = hi_k.min(t(h).ceil() as i64 - 1);
                }
            } else {
                // Inside for t_hi < t <= t_lo.
                if let Some(h) = hi {
                    lo_k = lo_k.max(t(h).floor() as i64 + 1);
                }
                if let Some(l) = lo {
                    hi_k = hi_k.min(t(l).floor() as i64);
                }
            }
        }
        (lo_k <= hi_k).then_some((lo_k, hi_k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Boxes split at x = 1.3 and, above it, y = 0.7: every sample of
    /// random rays goes to exactly one box, the one that holds it (up to
    /// the rounding of the crossing, a hair from the plane).
    #[test]
    fn every_sample_goes_to_one_box() {
        let boxes = [
            ShareBox {
                hi: [Some(1.3), None, None],
                ..Default::default()
            },
            ShareBox {
                lo: [Some(1.3), None, None],
                hi: [None, Some(0.7), None],
            },
            ShareBox {
                lo: [Some(1.3), Some(0.7), None],
                ..Default::default()
            },
        ];
        let mut rng = fastrand::Rng::with_seed(9);
        for case in 0..3000 {
            let mut d = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            if case % 7 == 0 {
                d.x = 0.0; // parallel to the x plane
            }
            if case % 11 == 0 {
                d = Vec3::new(-1.0, 0.0, 0.0);
            }
            let ray = Ray {
                origin: Vec3::new(rng.f32() * 3.0 - 0.5, rng.f32() * 2.0 - 0.5, 0.1),
                dir: d.normalize(),
            };
            let step = [0.01f32, 0.1, 0.013][case % 3];
            let span = Span::whole(0.0, 4.0);
            let all = span_k(span, step);
            let mut seen = vec![0u8; (all.1 - all.0 + 1) as usize];
            for b in &boxes {
                if let Some((lo, hi)) = b.samples(&ray, span, step) {
                    for k in lo..=hi {
                        seen[(k - all.0) as usize] += 1;
                        let p = ray.origin + ray.dir * (k as f64 * step as f64) as f32;
                        let near = |c: Option<f32>, v: f32| c.is_none_or(|c| (v - c).abs() > 1e-4);
                        let inside = (0..3).all(|a| {
                            b.lo[a].is_none_or(|l| p[a] >= l || !near(Some(l), p[a]))
                                && b.hi[a].is_none_or(|h| p[a] < h || !near(Some(h), p[a]))
                        });
                        assert!(inside, "sample {k} at {p} is not in {b:?}");
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "case {case}: {seen:?}");
        }
    }

    fn span_k(span: Span, step: f32) -> (i64, i64) {
        let s = f64::from(step);
        (
            (f64::from(span.t0) / s).ceil() as i64,
            (f64::from(span.t1) / s).floor() as i64,
        )
    }
}
