//! Pinhole and orthographic cameras, rays through pixel centres.

use crate::error::RenderError;
use crate::ray::{unit, EyeRay};
use glam::Vec3;

/// How the image plane maps to rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with this vertical field of view in degrees (0, 180).
    Perspective(f32),
    /// Orthographic with this image-plane height in world units.
    Orthographic(f32),
}

/// A camera with an orthonormal frame and an image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    projection: Projection,
    width: u32,
    height: u32,
    /// Half extents of the image plane at unit distance (perspective) or in
    /// world units (orthographic).
    half: (f32, f32),
}

impl Camera {
    /// A camera at `eye` looking at `target`. `up` need only be roughly up:
    /// when it is parallel to the view direction (looking straight up or
    /// down) the world axis least aligned with the view is used instead, so
    /// the frame is always well defined.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Camera, RenderError> {
        let bad = |m: &str| Err(RenderError::Camera(m.into()));
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return bad("eye, look-at and up must be finite");
        }
        if width == 0 || height == 0 || width > 1 << 15 || height > 1 << 15 {
            return bad("image size must be 1..=32768 pixels per side");
        }
        let Some(forward) = unit(target - eye) else {
            if eye == target {
                return bad(&format!(
                    "eye and look-at are the same point {},{},{}",
                    eye.x, eye.y, eye.z
                ));
            }
            // Finite points whose difference overflows f32.
            return bad(&format!(
                "eye {},{},{} and look-at {},{},{} are too far apart for f32",
                eye.x, eye.y, eye.z, target.x, target.y, target.z
            ));
        };
        let half_plane = match projection {
            Projection::Perspective(fov) if fov > 0.0 && fov < 180.0 => {
                (fov.to_radians() * 0.5).tan()
            }
            Projection::Perspective(fov) => {
                return bad(&format!(
                    "field of view {fov} is not between 0 and 180 degrees"
                ))
            }
            Projection::Orthographic(h) if h > 0.0 && h.is_finite() => h * 0.5,
            Projection::Orthographic(h) => {
                return bad(&format!("orthographic height {h} must be positive"))
            }
        };
        // Any length of up will do: scaled to unit length first, so a huge
        // or tiny one neither overflows nor underflows the cross product.
        let up = unit(up).unwrap_or(Vec3::ZERO);
        let mut right = forward.cross(up);
        if right.length() < 1e-6 || up == Vec3::ZERO {
            // Looking along the up vector: fall back to the world axis least
            // aligned with the view direction.
            let a = forward.abs();
            let alt = if a.x <= a.y && a.x <= a.z {
                Vec3::X
            } else if a.y <= a.z {
                Vec3::Y
            } else {
                Vec3::Z
            };
            right = forward.cross(alt);
        }
        let right = right.normalize();
        let up = right.cross(forward).normalize();
        let aspect = width as f32 / height as f32;
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            projection,
            width,
            height,
            half: (half_plane * aspect, half_plane),
        })
    }

    /// A camera orbiting `centre` at `distance`, at `azimuth` degrees around
    /// the y axis (0 looks along −z) and `elevation` degrees above the xz
    /// plane, with y up ([`Camera::orbit_up`] with +y).
    pub fn orbit(
        centre: Vec3,
        azimuth: f32,
        elevation: f32,
        distance: f32,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Camera, RenderError> {
        let up = Vec3::Y;
        Camera::orbit_up(
            centre, azimuth, elevation, distance, up, projection, width, height,
        )
    }

    /// A camera orbiting `centre` at `distance`, at `azimuth` degrees around
    /// the `up` axis and `elevation` degrees above the plane across it,
    /// with `up` up (any length). Azimuth 0 puts the eye on the side of
    /// +z seen from the centre (of −y when `up` is within about 25° of
    /// ±z), looking back; with `up` = +y: around the y axis, 0 looking
    /// along −z, elevation above the xz plane.
    #[allow(clippy::too_many_arguments)]
    pub fn orbit_up(
        centre: Vec3,
        azimuth: f32,
        elevation: f32,
        distance: f32,
        up: Vec3,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Camera, RenderError> {
        if !(distance > 0.0 && distance.is_finite()) {
            return Err(RenderError::Camera(format!(
                "orbit distance {distance} must be a positive finite number"
            )));
        }
        let Some(u) = unit(up) else {
            return Err(RenderError::Camera(
                "the up vector must not be the zero vector".into(),
            ));
        };
        // The orbit's frame: `front` (azimuth 0) and `side` (azimuth 90)
        // across `u`; exactly +z and +x for u = +y.
        let reference = if u.z.abs() < 0.9 {
            Vec3::Z
        } else {
            Vec3::NEG_Y
        };
        let front = if u == Vec3::Y {
            Vec3::Z
        } else {
            unit(reference - u * reference.dot(u)).unwrap_or(Vec3::Z)
        };
        let side = u.cross(front);
        let (az, el) = (azimuth.to_radians(), elevation.to_radians());
        let offset = (side * (el.cos() * az.sin()) + u * el.sin() + front * (el.cos() * az.cos()))
            * distance;
        let eye = centre + offset;
        if !eye.is_finite() {
            return Err(RenderError::Camera(format!(
                "orbit distance {distance} from {},{},{} leaves f32 range",
                centre.x, centre.y, centre.z
            )));
        }
        Camera::look_at(eye, centre, u, projection, width, height)
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// The projection.
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// The unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Where point `p` lands on the image, in pixel coordinates with pixel
    /// `(x, y)`'s centre at `(x, y)` (the inverse of [`Camera::ray`]), or
    /// `None` when a perspective camera does not see it in front of the
    /// eye (or the result is not finite).
    pub fn project(&self, p: Vec3) -> Option<[f32; 2]> {
        // In f64: an eye far from the volume is still a point, not a
        // rounding of one.
        let d = p.as_dvec3() - self.eye.as_dvec3();
        let (right, up) = (self.right.as_dvec3(), self.up.as_dvec3());
        let (a, b) = match self.projection {
            Projection::Perspective(_) => {
                let z = d.dot(self.forward.as_dvec3());
                // In front of the eye only (NaN is not).
                if z.is_nan() || z <= 0.0 {
                    return None;
                }
                (d.dot(right) / z, d.dot(up) / z)
            }
            Projection::Orthographic(_) => (d.dot(right), d.dot(up)),
        };
        let x = (a / f64::from(self.half.0) + 1.0) * 0.5 * f64::from(self.width) - 0.5;
        let y = (1.0 - b / f64::from(self.half.1)) * 0.5 * f64::from(self.height) - 0.5;
        let (x, y) = (x as f32, y as f32);
        (x.is_finite() && y.is_finite()).then_some([x, y])
    }

    /// The bounds `[(x_min, x_max), (y_min, y_max)]` of where the eight
    /// corners of the box `lo..hi` land on the image ([`Camera::project`]),
    /// or `None` when a corner does not: then the box's projection is not
    /// the hull of its corners' (the eye is beside or in the box).
    pub fn project_box(&self, lo: Vec3, hi: Vec3) -> Option<[(f32, f32); 2]> {
        let mut x = (f32::INFINITY, f32::NEG_INFINITY);
        let mut y = (f32::INFINITY, f32::NEG_INFINITY);
        for k in 0..8 {
            let p = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let [px, py] = self.project(p)?;
            x = (x.0.min(px), x.1.max(px));
            y = (y.0.min(py), y.1.max(py));
        }
        Some([x, y])
    }

    /// The ray through the centre of pixel `(x, y)`, row 0 at the top.
    #[inline]
    pub fn ray(&self, x: u32, y: u32) -> EyeRay {
        self.ray_at(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// The ray through image-plane position `(fx, fy)` in pixel units,
    /// `(0, 0)` the top-left corner of the image and pixel `(x, y)`
    /// covering `[x, x + 1) × [y, y + 1)` (jittered samples). Its origin
    /// is in f64 ([`EyeRay::near`] rounds it for marching).
    #[inline]
    pub fn ray_at(&self, fx: f32, fy: f32) -> EyeRay {
        let u = (fx / self.width as f32) * 2.0 - 1.0;
        let v = 1.0 - (fy / self.height as f32) * 2.0;
        let offset = self.right * (u * self.half.0) + self.up * (v * self.half.1);
        match self.projection {
            Projection::Perspective(_) => EyeRay {
                origin: self.eye.as_dvec3(),
                dir: (self.forward + offset).normalize(),
            },
            // The sum rounded to f32 is the f32 sum (an f64 sum of two
            // f32 numbers is exact unless their exponents are 29 apart).
            Projection::Orthographic(_) => EyeRay {
                origin: self.eye.as_dvec3() + offset.as_dvec3(),
                dir: self.forward,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_frame_is_orthonormal() {
        let c = Camera::look_at(
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::ZERO,
            Vec3::Y,
            Projection::Perspective(60.0),
            101,
            51,
        )
        .unwrap();
        let r = c.ray(50, 25);
        assert!((r.dir - Vec3::NEG_Z).length() < 1e-6);
        // Top row points up, right column points right.
        assert!(c.ray(50, 0).dir.y > 0.0 && c.ray(100, 25).dir.x > 0.0);
    }

    /// `project` inverts `ray`: points along the ray through a pixel's
    /// centre land on that pixel, for both projections; a point behind a
    /// perspective eye lands nowhere.
    #[test]
    fn projection_inverts_rays() {
        let eye = Vec3::new(300.0, -120.0, 500.0);
        for proj in [
            Projection::Perspective(50.0),
            Projection::Orthographic(80.0),
        ] {
            let c =
                Camera::look_at(eye, Vec3::new(10.0, 20.0, 30.0), Vec3::Y, proj, 64, 48).unwrap();
            for (x, y) in [(0, 0), (63, 47), (17, 30), (32, 24)] {
                let r = c.ray(x, y).rounded();
                for t in [1.0f32, 50.0, 700.0] {
                    let [px, py] = c.project(r.origin + r.dir * t).unwrap();
                    assert!(
                        (px - x as f32).abs() < 1e-2 && (py - y as f32).abs() < 1e-2,
                        "{proj:?} {x},{y} at {t}: {px},{py}"
                    );
                }
            }
            let behind = eye - c.forward() * 10.0;
            let seen = c.project(behind).is_some();
            assert_eq!(
                seen,
                matches!(proj, Projection::Orthographic(_)),
                "{proj:?}"
            );
        }
    }

    #[test]
    fn looking_along_up_is_well_defined() {
        for up in [Vec3::Y, Vec3::NEG_Y, Vec3::new(0.0, 1e-9, 0.0)] {
            let c = Camera::look_at(
                Vec3::new(1.0, 10.0, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
                up,
                Projection::Perspective(45.0),
                8,
                8,
            )
            .unwrap();
            for (x, y) in [(0, 0), (7, 7), (3, 4)] {
                assert!(c.ray(x, y).dir.is_finite());
            }
        }
        assert!(Camera::look_at(
            Vec3::ONE,
            Vec3::ONE,
            Vec3::Y,
            Projection::Perspective(45.0),
            8,
            8
        )
        .is_err());
        assert!(Camera::look_at(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Projection::Perspective(180.0),
            8,
            8
        )
        .is_err());
        assert!(Camera::look_at(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Projection::Orthographic(0.0),
            8,
            8
        )
        .is_err());
        assert!(Camera::look_at(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Projection::Perspective(60.0),
            0,
            8
        )
        .is_err());
    }

    #[test]
    fn orbit_turns_around_any_up() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        for up in [
            Vec3::Y,
            Vec3::Z,
            Vec3::new(1e30, 1e30, 0.0),
            Vec3::new(0.3, -0.2, 0.9),
        ] {
            let u = unit(up).unwrap();
            for (az, el) in [(0.0f32, 0.0f32), (40.0, 25.0), (200.0, -60.0)] {
                let cam =
                    Camera::orbit_up(c, az, el, 10.0, up, Projection::Perspective(45.0), 8, 8)
                        .unwrap();
                let off = cam.eye() - c;
                // Elevation above the plane across up, at the distance.
                assert!((off.length() - 10.0).abs() < 1e-4, "{up} {az} {el}");
                assert!((off.dot(u) - 10.0 * el.to_radians().sin()).abs() < 1e-4);
                // The image's up is on up's side.
                assert!(cam.up.dot(u) > 0.0 || el.abs() > 89.0, "{up} {az} {el}");
            }
        }
        // With +y it is the classic orbit, bit for bit.
        let a = Camera::orbit(c, 33.0, 21.0, 9.0, Projection::Perspective(40.0), 8, 8).unwrap();
        let (az, el) = (33f32.to_radians(), 21f32.to_radians());
        let eye = c + Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos()) * 9.0;
        let b = Camera::look_at(eye, c, Vec3::Y, Projection::Perspective(40.0), 8, 8).unwrap();
        assert_eq!(a, b);
        assert!(Camera::orbit_up(
            c,
            0.0,
            0.0,
            1.0,
            Vec3::ZERO,
            Projection::Perspective(40.0),
            8,
            8
        )
        .is_err());
    }

    #[test]
    fn far_apart_and_huge_vectors_say_what_is_wrong() {
        let p = Projection::Perspective(45.0);
        let up = Vec3::new(1e30, 1e30, 0.0);
        let a = Camera::look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, up, p, 8, 8).unwrap();
        let b = Camera::look_at(
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 0.0),
            p,
            8,
            8,
        )
        .unwrap();
        assert_eq!(a, b);
        let far = Camera::look_at(Vec3::splat(1e20), Vec3::ZERO, Vec3::Y, p, 8, 8).unwrap();
        assert!(far.forward().is_finite());
        let e = Camera::look_at(Vec3::splat(3e38), Vec3::splat(-3e38), Vec3::Y, p, 8, 8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("too far apart"), "{e}");
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let c = Camera::orbit(
            Vec3::splat(5.0),
            30.0,
            20.0,
            50.0,
            Projection::Orthographic(10.0),
            16,
            16,
        )
        .unwrap();
        assert!((c.ray(0, 0).dir - c.ray(15, 15).dir).length() < 1e-7);
        assert!((c.ray(0, 0).origin - c.ray(15, 0).origin).length() > 8.0);
    }
}
