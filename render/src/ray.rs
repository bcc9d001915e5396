//! Rays and the robust ray–box test.

use glam::Vec3;

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
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for a in 0..3 {
        let o = ray.origin[a];
        let d = ray.dir[a];
        if d == 0.0 {
            if o < lo[a] || o > hi[a] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d;
        let (mut near, mut far) = ((lo[a] - o) * inv, (hi[a] - o) * inv);
        if near > far {
            std::mem::swap(&mut near, &mut far);
        }
        if near > t0 {
            t0 = near;
        }
        if far < t1 {
            t1 = far;
        }
        if t0 > t1 {
            return None;
        }
    }
    (t1.is_finite() && t0 <= t1).then_some((t0, t1))
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
