//! Shading models: how a lit point reflects light towards the eye.
//! Blinn-Phong is the one the ray caster uses; a phase function will sit
//! beside it for scattering media.

use crate::light::Light;
use glam::Vec3;

/// The Blinn-Phong reflection model's weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnPhong {
    /// Ambient weight.
    pub ambient: f32,
    /// Diffuse weight.
    pub diffuse: f32,
    /// Specular weight.
    pub specular: f32,
    /// Specular exponent.
    pub shininess: f32,
}

impl Default for BlinnPhong {
    fn default() -> Self {
        BlinnPhong {
            ambient: 0.25,
            diffuse: 0.65,
            specular: 0.35,
            shininess: 24.0,
        }
    }
}

/// A light and the shading model that reflects it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// The light.
    pub light: Light,
    /// The reflection model.
    pub model: BlinnPhong,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting {
            light: Light::Headlight,
            model: BlinnPhong::default(),
        }
    }
}

impl Lighting {
    /// Shade `colour` at a point with (unnormalised, nonzero) gradient
    /// `grad`, seen along unit `view_dir` (from the eye into the scene).
    /// Two-sided: the normal is flipped to face the viewer.
    #[inline(always)]
    pub fn shade(&self, colour: Vec3, grad: Vec3, view_dir: Vec3) -> Vec3 {
        self.for_view(view_dir)
            .shade_normal(colour, grad.normalize_or_zero())
    }

    /// What shading along one viewing direction needs, worked out once per
    /// ray rather than per sample.
    #[inline(always)]
    pub fn for_view(&self, view_dir: Vec3) -> ViewShading {
        let to_eye = -view_dir;
        let l = self.light.for_ray(view_dir).towards;
        let m = self.model;
        let whole = m.shininess.fract() == 0.0 && (0.0..=256.0).contains(&m.shininess);
        ViewShading {
            model: m,
            to_eye,
            l,
            h: (l + to_eye).normalize_or_zero(),
            whole_exponent: whole.then_some(m.shininess as u32),
        }
    }
}

/// Blinn-Phong for one viewing direction and one light whose direction is
/// fixed along the ray (see [`Lighting::for_view`]).
#[derive(Clone, Copy, Debug)]
pub struct ViewShading {
    model: BlinnPhong,
    /// Unit vector towards the eye.
    to_eye: Vec3,
    /// Unit vector towards the light.
    l: Vec3,
    /// The half vector.
    h: Vec3,
    /// The specular exponent when it is a whole number up to 256 (the
    /// usual case: then by multiplication, not `powf`).
    whole_exponent: Option<u32>,
}

impl ViewShading {
    /// Shade `colour` at a point whose unit gradient is `unit_grad` (or
    /// zero). Two-sided: the normal is flipped to face the viewer.
    #[inline(always)]
    pub fn shade_normal(&self, colour: Vec3, unit_grad: Vec3) -> Vec3 {
        let m = &self.model;
        let mut n = -unit_grad;
        if n.dot(self.to_eye) < 0.0 {
            n = -n;
        }
        let diff = n.dot(self.l).max(0.0);
        let spec = if diff > 0.0 {
            let c = n.dot(self.h).max(0.0);
            match self.whole_exponent {
                Some(e) => pow_whole(c, e),
                None => c.powf(m.shininess),
            }
        } else {
            0.0
        };
        colour * (m.ambient + m.diffuse * diff) + Vec3::splat(m.specular * spec)
    }
}

/// `x^n` by repeated squaring, inline (`powi` with an exponent known only
/// at run time becomes a library call).
#[inline(always)]
fn pow_whole(mut x: f32, mut n: u32) -> f32 {
    let mut r = 1.0;
    while n > 0 {
        if n & 1 == 1 {
            r *= x;
        }
        x *= x;
        n >>= 1;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headlight_on_a_facing_surface_is_ambient_plus_diffuse_plus_specular() {
        let l = Lighting::default();
        let view = Vec3::NEG_Z;
        // Gradient pointing away from the eye: the normal faces the viewer.
        let c = l.shade(Vec3::ONE, Vec3::Z, view);
        let m = BlinnPhong::default();
        let want = m.ambient + m.diffuse + m.specular;
        assert!((c - Vec3::splat(want)).length() < 1e-6, "{c}");
        // Two-sided: the opposite gradient shades the same.
        assert_eq!(l.shade(Vec3::ONE, Vec3::NEG_Z, view), c);
    }

    #[test]
    fn light_from_behind_leaves_ambient_only() {
        let l = Lighting {
            light: Light::directional(Vec3::Z).unwrap(),
            ..Default::default()
        };
        // Eye looks along -z (towards_eye = +z); the light is at +z too, so
        // a surface facing +z is lit; one facing x is lit at grazing angle
        // zero: ambient only.
        let c = l.shade(Vec3::ONE, Vec3::X, Vec3::NEG_Z);
        assert!((c - Vec3::splat(0.25)).length() < 1e-6, "{c}");
    }

    #[test]
    fn whole_and_fractional_exponents_agree() {
        for e in [1.0f32, 7.0, 24.0, 256.0] {
            for x in [0.0f32, 0.3, 0.9, 1.0] {
                let a = pow_whole(x, e as u32);
                let b = x.powf(e);
                assert!((a - b).abs() <= 1e-5 * b.max(1e-30) + 1e-30, "{x}^{e}");
            }
        }
    }
}
