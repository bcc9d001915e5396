//! A rank's share of every ray: the samples inside its box.

use crate::camera::Camera;
use crate::ray::Ray;
use crate::trace::Span;
use glam::Vec3;

/// A rectangle of pixels: columns `x[0]..x[1]`, rows `y[0]..y[1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    /// Columns, half-open.
    pub x: [u32; 2],
    /// Rows, half-open.
    pub y: [u32; 2],
}

impl PixelRect {
    /// Whether pixel `(x, y)` is in the rectangle.
    #[inline]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x[0]..self.x[1]).contains(&x) && (self.y[0]..self.y[1]).contains(&y)
    }
}

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

    /// The box clipped to the volume's `[0, hi]`: its lower and upper
    /// corners.
    pub fn clipped(&self, hi: Vec3) -> (Vec3, Vec3) {
        let lo = Vec3::from(std::array::from_fn(|a| self.lo[a].unwrap_or(0.0).max(0.0)));
        let up = Vec3::from(std::array::from_fn(|a| {
            self.hi[a].unwrap_or(hi[a]).min(hi[a])
        }));
        (lo, up)
    }

    /// The pixels whose rays can take a sample in the box (none when the
    /// box is off the image), for the box
    /// clipped to the volume's `[0, hi]`; `None` when that cannot be told
    /// from the corners (a corner not in front of a perspective eye: the
    /// eye is in or beside the box). Conservative by a pixel.
    pub fn pixels(&self, camera: &Camera, hi: Vec3) -> Option<PixelRect> {
        let (lo, up) = self.clipped(hi);
        let [x, y] = camera.project_box(lo, up)?;
        // Pixel centres within the corners' hull, widened by a pixel.
        let range = |(a, b): (f32, f32), n: u32| {
            let first = (a - 1.0).ceil().clamp(0.0, n as f32) as u32;
            let end = ((b + 1.0).floor() + 1.0).clamp(0.0, n as f32) as u32;
            (first, end.max(first))
        };
        let (x, y) = (range(x, camera.width()), range(y, camera.height()));
        Some(PixelRect {
            x: [x.0, x.1],
            y: [y.0, y.1],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// Every pixel whose ray takes a sample in a box is in the box's
    /// pixel rectangle, and the rectangle leaves pixels out.
    #[test]
    fn pixel_rectangles_hold_every_ray_that_meets_the_box() {
        use crate::camera::Projection;
        use crate::ray::intersect_box;
        let hi = Vec3::new(40.0, 30.0, 50.0);
        let boxes = [
            ShareBox {
                hi: [Some(20.0), None, None],
                ..Default::default()
            },
            ShareBox {
                lo: [Some(20.0), Some(10.0), None],
                hi: [None, None, Some(25.0)],
            },
        ];
        let cams = [
            Projection::Perspective(50.0),
            Projection::Orthographic(80.0),
        ];
        for p in cams {
            let cam = Camera::look_at(Vec3::new(90.0, 60.0, 120.0), hi * 0.5, Vec3::Y, p, 64, 48)
                .unwrap();
            for b in &boxes {
                let r = b.pixels(&cam, hi).unwrap();
                let mut met = 0;
                for y in 0..48 {
                    for x in 0..64 {
                        let ray = cam.ray(x, y).rounded();
                        let Some((t0, t1)) = intersect_box(&ray, Vec3::ZERO, hi) else {
                            continue;
                        };
                        if b.samples(&ray, Span::whole(t0, t1), 0.25).is_some() {
                            met += 1;
                            assert!(r.contains(x, y), "{p:?} {b:?}: ({x}, {y}) not in {r:?}");
                        }
                    }
                }
                let area = (r.x[1] - r.x[0]) * (r.y[1] - r.y[0]);
                assert!(met > 0 && area < 64 * 48, "{p:?} {b:?}: {met} rays, {r:?}");
            }
        }
        // An eye inside a box: no rectangle.
        let inside = Camera::look_at(
            Vec3::new(5.0, 5.0, 5.0),
            hi,
            Vec3::Y,
            Projection::Perspective(60.0),
            8,
            8,
        )
        .unwrap();
        assert!(boxes[0].pixels(&inside, hi).is_none());
    }

    fn span_k(span: Span, step: f32) -> (i64, i64) {
        let s = f64::from(step);
        (
            (f64::from(span.t0) / s).ceil() as i64,
            (f64::from(span.t1) / s).floor() as i64,
        )
    }
}
