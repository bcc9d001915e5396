//! Rays and the robust ray–box test.

use glam::{DVec3, Vec3};

/// A ray `origin + t·dir` with a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start of the ray (the eye, or a point on the image plane).
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

/// `v` scaled to unit length, or `None` for the zero vector and for
/// non-finite components. Where `v`'s squared length is an ordinary float
/// this is `v.normalize()`; very small and very large vectors (whose
/// squared length would underflow or overflow) are first divided by their
/// largest component, so they keep their direction.
pub fn unit(v: Vec3) -> Option<Vec3> {
    if !v.is_finite() {
        return None;
    }
    let len2 = v.length_squared();
    if len2.is_normal() && len2.is_finite() {
        return Some(v.normalize());
    }
    let m = v.abs().max_element();
    if m == 0.0 {
        return None;
    }
    let s = v / m;
    Some(s / s.length())
}

/// The parameter interval `[t0, t1]` over which `ray` is inside the closed
/// box `[lo, hi]`, clipped to `t >= 0`, or `None` if it misses.
///
/// Robust for every direction: a zero (or negative zero) component never
/// divides; such a ray is inside the slab of that axis for all `t` when its
/// origin is (faces included) and misses otherwise. Origins on a face and
/// rays grazing an edge count as inside. No NaN can arise: only finite
/// values are divided by nonzero ones and compared.
pub fn intersect_box(ray: &Ray, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    slabs(
        ray.origin.to_array(),
        ray.dir.to_array(),
        lo.to_array(),
        hi.to_array(),
    )
}

/// The slab test of [`intersect_box`] in f32 or f64 (the three axes
/// written out: a loop over them stayed a loop, through the stack, at a
/// tenth of a path's instructions in sparse path-traced scenes; inlining
/// `intersect_box` itself as well bought no time and 65 KB of code).
#[inline(always)]
fn slabs<F: Real>(o: [F; 3], d: [F; 3], lo: [F; 3], hi: [F; 3]) -> Option<(F, F)> {
    let mut t = (F::ZERO, F::INFINITY);
    slab(o[0], d[0], lo[0], hi[0], &mut t)?;
    slab(o[1], d[1], lo[1], hi[1], &mut t)?;
    slab(o[2], d[2], lo[2], hi[2], &mut t)?;
    let (t0, t1) = t;
    (t1.finite() && t0 <= t1).then_some((t0, t1))
}

/// One axis of [`slabs`]: narrow `(t0, t1)` to the slab `[lo, hi]`;
/// `None` once the ray misses it.
#[inline(always)]
fn slab<F: Real>(o: F, d: F, lo: F, hi: F, (t0, t1): &mut (F, F)) -> Option<()> {
    if d == F::ZERO {
        // A NaN coordinate fails both tests: the other axes decide.
        return if o < lo || o > hi { None } else { Some(()) };
    }
    let inv = F::ONE / d;
    let (mut near, mut far) = ((lo - o) * inv, (hi - o) * inv);
    if near > far {
        std::mem::swap(&mut near, &mut far);
    }
    if near > *t0 {
        *t0 = near;
    }
    if far < *t1 {
        *t1 = far;
    }
    if *t0 > *t1 {
        None
    } else {
        Some(())
    }
}

/// The float types the slab test runs in.
trait Real:
    Copy
    + PartialOrd
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    const INFINITY: Self;
    fn finite(self) -> bool;
}

impl Real for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    const INFINITY: f32 = f32::INFINITY;
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Real for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    const INFINITY: f64 = f64::INFINITY;
    fn finite(self) -> bool {
        self.is_finite()
    }
}

/// Rays whose origin is this many steps or more from the volume's box are
/// marched from a nearer origin on the same ray ([`EyeRay::near`]).
pub const NEAR_STEPS: f64 = 4096.0;

/// A ray as a camera makes it: the origin in f64 (an eye far from the
/// volume, or an orthographic ray's point on the image plane beside such
/// an eye, keeps its position), the unit direction in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeRay {
    /// Start of the ray.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: Vec3,
}

impl EyeRay {
    /// The ray with its origin rounded to f32.
    pub fn rounded(&self) -> Ray {
        Ray {
            origin: self.origin.as_vec3(),
            dir: self.dir,
        }
    }

    /// The ray to march through the box `[lo, hi]` with samples at
    /// `t = k·step`, and where it starts on this ray (the parameter of its
    /// origin here: add it to a parameter along the ray returned for the
    /// distance from this ray's origin). The origin is this one rounded to
    /// f32 (the start 0) when it lies within [`NEAR_STEPS`] steps of the
    /// box: every ordinary view, whose bits are those of the ray from the
    /// eye. From farther away the origin moves along the ray, in f64, by a
    /// whole number of steps to a point just before the ray enters the box
    /// (or passes closest to it). The moved ray takes the samples of the
    /// one from the eye (the grid `k·step` shifts by whole steps), but its
    /// positions are f32 numbers the size of the box rather than of the
    /// eye's distance, so a camera any finite distance away renders what a
    /// nearer one on the same rays renders.
    pub fn near(&self, lo: Vec3, hi: Vec3, step: f32) -> (Ray, f64) {
        let dir = self.dir;
        let (lo64, hi64) = (lo.as_dvec3(), hi.as_dvec3());
        let outside = (lo64 - self.origin)
            .max(self.origin - hi64)
            .max(DVec3::ZERO);
        let step = f64::from(step);
        // The square root only near the threshold: well inside it, the
        // squared length answers the same.
        let limit = NEAR_STEPS * step;
        if outside.length_squared() < 0.99 * limit * limit || outside.length() < limit {
            return (self.rounded(), 0.0);
        }
        let d = dir.as_dvec3();
        // Where the ray enters the box or, when it misses, where it passes
        // closest to the box's centre (so it misses in f32 too).
        let to = match slabs(
            self.origin.to_array(),
            d.to_array(),
            lo64.to_array(),
            hi64.to_array(),
        ) {
            Some((t0, _)) => t0,
            None => ((lo64 + hi64) * 0.5 - self.origin).dot(d).max(0.0),
        };
        // One step short, so rounding the new origin to f32 cannot put it
        // past the box's face.
        let start = ((to / step).floor() - 1.0).max(0.0) * step;
        let ray = Ray {
            origin: (self.origin + d * start).as_vec3(),
            dir,
        };
        (ray, start)
    }

    /// [`EyeRay::near`] and the part of the ray returned inside the box,
    /// `(ray, start, t0, t1)` ([`intersect_box`]), or `None` if it misses.
    pub fn enter(&self, lo: Vec3, hi: Vec3, step: f32) -> Option<(Ray, f64, f32, f32)> {
        let (ray, start) = self.near(lo, hi, step);
        intersect_box(&ray, lo, hi).map(|(t0, t1)| (ray, start, t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
        Ray {
            origin: Vec3::from(o),
            dir: Vec3::from(d).normalize(),
        }
    }

    #[test]
    fn hits_misses_and_edge_cases() {
        let (lo, hi) = (Vec3::ZERO, Vec3::splat(10.0));
        assert_eq!(
            intersect_box(&ray([-5.0, 5.0, 5.0], [1.0, 0.0, 0.0]), lo, hi),
            Some((5.0, 15.0))
        );
        // Negative zero components behave like zero.
        let r = Ray {
            origin: Vec3::new(-5.0, 5.0, 5.0),
            dir: Vec3::new(1.0, -0.0, -0.0),
        };
        assert_eq!(intersect_box(&r, lo, hi), Some((5.0, 15.0)));
        // Axis-parallel outside the slab: miss.
        assert_eq!(
            intersect_box(&ray([-5.0, 11.0, 5.0], [1.0, 0.0, 0.0]), lo, hi),
            None
        );
        // Grazing along an edge (origin on two faces): inside.
        assert_eq!(
            intersect_box(&ray([-5.0, 10.0, 0.0], [1.0, 0.0, 0.0]), lo, hi),
            Some((5.0, 15.0))
        );
        // Origin inside: t0 clipped to 0.
        assert_eq!(
            intersect_box(&ray([5.0, 5.0, 5.0], [0.0, 0.0, 1.0]), lo, hi),
            Some((0.0, 5.0))
        );
        // Box behind the ray: miss.
        assert_eq!(
            intersect_box(&ray([5.0, 5.0, 20.0], [0.0, 0.0, 1.0]), lo, hi),
            None
        );
        // Flat box (one voxel thick): a crossing ray touches it at one t.
        let flat = intersect_box(
            &ray([0.0, 5.0, 5.0], [1.0, 1.0, 0.0]),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 10.0),
        );
        assert_eq!(flat, Some((0.0, 0.0)));
        // Diagonal through a corner.
        let d = intersect_box(&ray([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]), lo, hi).unwrap();
        assert!((d.0 - 3f32.sqrt()).abs() < 1e-5 && (d.1 - 11.0 * 3f32.sqrt()).abs() < 1e-4);
    }

    #[test]
    fn unit_keeps_the_direction_of_tiny_and_huge_vectors() {
        let want = Vec3::new(1.0, 1.0, 0.0).normalize();
        for s in [1e-30f32, 1e-25, 1.0, 1e20, 1e30, 3e38] {
            let u = unit(Vec3::new(s, s, 0.0)).unwrap();
            assert!((u - want).length() < 1e-6, "{s}: {u}");
        }
        assert_eq!(unit(Vec3::new(1e-45, 0.0, 0.0)), Some(Vec3::X));
        assert_eq!(unit(Vec3::ZERO), None);
        assert_eq!(unit(Vec3::new(f32::NAN, 1.0, 0.0)), None);
        assert_eq!(unit(Vec3::new(f32::INFINITY, 1.0, 0.0)), None);
        // Ordinary vectors: exactly glam's normalize.
        let v = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(unit(v), Some(v.normalize()));
    }

    #[test]
    fn random_rays_never_give_nan() {
        let mut rng = fastrand::Rng::with_seed(3);
        for _ in 0..100_000 {
            let mut v = || {
                [
                    rng.f32() * 40.0 - 20.0,
                    rng.f32() * 40.0 - 20.0,
                    rng.f32() * 40.0 - 20.0,
                ]
            };
            let o = v();
            let mut d = v();
            for c in d.iter_mut() {
                if rng.u8(..) < 40 {
                    *c = if rng.bool() { 0.0 } else { -0.0 };
                }
            }
            if d == [0.0; 3] {
                continue;
            }
            let r = ray(o, d);
            if let Some((a, b)) = intersect_box(&r, Vec3::ZERO, Vec3::new(10.0, 3.0, 7.0)) {
                assert!(a.is_finite() && b.is_finite() && a <= b && a >= 0.0);
            }
        }
    }
}
