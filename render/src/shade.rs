//! Shading models: how a lit point reflects light towards the eye.
//! Blinn-Phong is the one the ray caster uses; a phase function will sit
//! beside it for scattering media.

use crate::light::{Incident, Light};
use glam::Vec3;

/// The Blinn-Phong reflection model's weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnPhong {
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
            diffuse: 0.65,
            specular: 0.35,
            shininess: 24.0,
        }
    }
}

impl BlinnPhong {
    /// The specular exponent when it is a whole number up to 256 (the
    /// usual case: then by multiplication, not `powf`).
    fn whole_exponent(&self) -> Option<u32> {
        let whole = self.shininess.fract() == 0.0 && (0.0..=256.0).contains(&self.shininess);
        whole.then_some(self.shininess as u32)
    }

    /// `(diffuse term, specular term)` for unit normal `n` facing the eye,
    /// unit `l` towards the light and half vector `h`.
    #[inline(always)]
    fn terms(&self, n: Vec3, l: Vec3, h: Vec3, whole: Option<u32>) -> (f32, f32) {
        let diff = n.dot(l).max(0.0);
        let spec = if diff > 0.0 {
            let c = n.dot(h).max(0.0);
            match whole {
                Some(e) => pow_whole(c, e),
                None => c.powf(self.shininess),
            }
        } else {
            0.0
        };
        (self.diffuse * diff, self.specular * spec)
    }
}

/// Lights, an ambient term and the reflection model: everything shading
/// needs. A lit point of colour `c` shows `c·(ambient + Σ Lᵢ·kd·max(n·lᵢ,
/// 0)) + Σ Lᵢ·ks·(n·hᵢ)^shininess`, two-sided (the normal is flipped to
/// face the viewer).
#[derive(Clone, Debug, PartialEq)]
pub struct Lighting {
    /// The lights (none: ambient only).
    pub lights: Vec<Light>,
    /// Ambient light (linear RGB), reflected whatever the normal.
    pub ambient: Vec3,
    /// The reflection model.
    pub model: BlinnPhong,
}

impl Default for Lighting {
    /// A white headlight and an ambient term of 0.25.
    fn default() -> Self {
        Lighting {
            lights: vec![Light::HEADLIGHT],
            ambient: Vec3::splat(0.25),
            model: BlinnPhong::default(),
        }
    }
}

impl Lighting {
    /// Shade `colour` at world point `p` with (unnormalised) gradient
    /// `grad`, seen along unit `view_dir` (from the eye into the scene);
    /// a zero gradient gets the ambient term only.
    pub fn shade_at(&self, colour: Vec3, grad: Vec3, view_dir: Vec3, p: Vec3) -> Vec3 {
        self.shade_shadowed(colour, grad, view_dir, p, 1.0, |_, _| 1.0)
    }

    /// [`Lighting::shade_at`] with the ambient term multiplied by the
    /// ambient occlusion `ao` and each light's share by
    /// `transmittance(light index, incident light)`, which is asked only
    /// for lights that add anything at this normal (the same bits as
    /// `shade_at` when both are 1).
    #[inline]
    pub fn shade_shadowed(
        &self,
        colour: Vec3,
        grad: Vec3,
        view_dir: Vec3,
        p: Vec3,
        ao: f32,
        mut transmittance: impl FnMut(usize, &Incident) -> f32,
    ) -> Vec3 {
        let ambient = self.ambient * ao;
        let unit = grad.normalize_or_zero();
        if unit == Vec3::ZERO {
            return colour * ambient;
        }
        let to_eye = -view_dir;
        let n = facing(unit, to_eye);
        let whole = self.model.whole_exponent();
        let (mut d, mut s) = (Vec3::ZERO, Vec3::ZERO);
        for (i, light) in self.lights.iter().enumerate() {
            let inc = light.at(p, view_dir);
            let h = (inc.towards + to_eye).normalize_or_zero();
            let (kd, ks) = self.model.terms(n, inc.towards, h, whole);
            if kd == 0.0 && ks == 0.0 {
                continue;
            }
            let t = transmittance(i, &inc);
            d += inc.radiance * kd * t;
            s += inc.radiance * ks * t;
        }
        colour * (ambient + d) + s
    }

    /// A point without a normal under shadows and ambient occlusion:
    /// `colour · (a·ao + (1 − a)·T̄)` with `a` the ambient term (clamped to
    /// [0, 1]), `ao` the ambient occlusion and `T̄` the lights'
    /// transmittance averaged with their radiance as weights (1 when there
    /// is no light).
    #[inline]
    pub fn unlit_shadowed(
        &self,
        colour: Vec3,
        view_dir: Vec3,
        p: Vec3,
        ao: f32,
        mut transmittance: impl FnMut(usize, &Incident) -> f32,
    ) -> Vec3 {
        let (mut sum, mut weight) = (0.0f32, 0.0f32);
        for (i, light) in self.lights.iter().enumerate() {
            let inc = light.at(p, view_dir);
            let w = inc.radiance.element_sum();
            if w > 0.0 && w.is_finite() {
                sum += w * transmittance(i, &inc);
                weight += w;
            }
        }
        let lit = if weight > 0.0 { sum / weight } else { 1.0 };
        let a = self.ambient.clamp(Vec3::ZERO, Vec3::ONE);
        colour * (a * ao + (Vec3::ONE - a) * lit)
    }

    /// The one light, when there is exactly one and it arrives from the
    /// same direction all along a ray (then shading along a ray can be
    /// worked out once per ray: [`Lighting::for_view`]).
    pub fn single_per_ray_light(&self) -> Option<Light> {
        match self.lights[..] {
            [l] if l.is_per_ray() => Some(l),
            _ => None,
        }
    }

    /// What shading along one viewing direction needs, worked out once per
    /// ray, for lighting with one per-ray light (see
    /// [`Lighting::single_per_ray_light`]).
    #[inline(always)]
    pub fn for_view(&self, light: Light, view_dir: Vec3) -> ViewShading {
        let to_eye = -view_dir;
        let inc = light.for_ray(view_dir);
        ViewShading {
            model: self.model,
            ambient: self.ambient,
            radiance: inc.radiance,
            to_eye,
            l: inc.towards,
            h: (inc.towards + to_eye).normalize_or_zero(),
            whole_exponent: self.model.whole_exponent(),
        }
    }
}

/// The unit normal `-unit_grad`, flipped to face the eye.
#[inline(always)]
fn facing(unit_grad: Vec3, to_eye: Vec3) -> Vec3 {
    let n = -unit_grad;
    if n.dot(to_eye) < 0.0 {
        -n
    } else {
        n
    }
}

/// Blinn-Phong for one viewing direction and one light whose direction is
/// fixed along the ray (see [`Lighting::for_view`]).
#[derive(Clone, Copy, Debug)]
pub struct ViewShading {
    model: BlinnPhong,
    ambient: Vec3,
    radiance: Vec3,
    /// Unit vector towards the eye.
    to_eye: Vec3,
    /// Unit vector towards the light.
    l: Vec3,
    /// The half vector.
    h: Vec3,
    whole_exponent: Option<u32>,
}

impl ViewShading {
    /// Shade `colour` at a point whose unit gradient is `unit_grad` (or
    /// zero). Two-sided: the normal is flipped to face the viewer. The
    /// same arithmetic as [`Lighting::shade_at`] with one light.
    #[inline(always)]
    pub fn shade_normal(&self, colour: Vec3, unit_grad: Vec3) -> Vec3 {
        let n = facing(unit_grad, self.to_eye);
        let (kd, ks) = self.model.terms(n, self.l, self.h, self.whole_exponent);
        colour * (self.ambient + self.radiance * kd) + self.radiance * ks
    }
}

impl ViewShading {
    /// [`ViewShading::shade_normal`] with the ambient term multiplied by
    /// the ambient occlusion `ao` and the light's share by
    /// `transmittance()`, which is asked only when the light adds anything
    /// at this normal.
    #[inline(always)]
    pub fn shade_normal_shadowed(
        &self,
        colour: Vec3,
        unit_grad: Vec3,
        ao: f32,
        transmittance: impl FnOnce() -> f32,
    ) -> Vec3 {
        let n = facing(unit_grad, self.to_eye);
        let (kd, ks) = self.model.terms(n, self.l, self.h, self.whole_exponent);
        let ambient = self.ambient * ao;
        if kd == 0.0 && ks == 0.0 {
            return colour * ambient;
        }
        let light = self.radiance * transmittance();
        colour * (ambient + light * kd) + light * ks
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
        let c = l.shade_at(Vec3::ONE, Vec3::Z, view, Vec3::ZERO);
        let m = BlinnPhong::default();
        let want = 0.25 + m.diffuse + m.specular;
        assert!((c - Vec3::splat(want)).length() < 1e-6, "{c}");
        // Two-sided: the opposite gradient shades the same.
        assert_eq!(l.shade_at(Vec3::ONE, Vec3::NEG_Z, view, Vec3::ZERO), c);
        // The per-ray path gives the same bits.
        let v = l.for_view(Light::HEADLIGHT, view);
        assert_eq!(v.shade_normal(Vec3::ONE, Vec3::Z), c);
    }

    #[test]
    fn light_from_the_side_leaves_ambient_only_and_lights_add_up() {
        let side = Light::directional(Vec3::X).unwrap();
        let mut l = Lighting {
            lights: vec![Light::directional(Vec3::Z).unwrap()],
            ..Default::default()
        };
        // A surface facing +x (its gradient points into it), lit from
        // +z: grazing, so ambient only.
        let c = l.shade_at(Vec3::ONE, Vec3::NEG_X, Vec3::NEG_Z, Vec3::ZERO);
        assert!((c - Vec3::splat(0.25)).length() < 1e-6, "{c}");
        // Add a light from +x: its diffuse term adds on.
        l.lights.push(side);
        let c2 = l.shade_at(Vec3::ONE, Vec3::NEG_X, Vec3::NEG_Z, Vec3::ZERO);
        assert!(c2.x > c.x + 0.6, "{c2}");
        // No lights: ambient; a zero gradient: ambient.
        l.lights.clear();
        assert_eq!(
            l.shade_at(Vec3::ONE, Vec3::X, Vec3::NEG_Z, Vec3::ZERO),
            Vec3::splat(0.25)
        );
        assert_eq!(
            Lighting::default().shade_at(Vec3::ONE, Vec3::ZERO, Vec3::NEG_Z, Vec3::ZERO),
            Vec3::splat(0.25)
        );
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
