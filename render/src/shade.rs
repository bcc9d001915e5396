//! Shading models: how a lit point reflects light towards the eye.
//! Blinn-Phong is the one the ray caster uses; a phase function will sit
//! beside it for scattering media.

use crate::lanes::Lanes3;
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

    /// [`Lighting::unlit_shadowed`] of eight samples (per component, then
    /// per lane) with occlusion `ao`, for lighting with one per-ray light
    /// ([`Lighting::single_per_ray_light`]) along a ray travelling along
    /// `view_dir`, whose transmittance at each sample is `tr`; bit for bit
    /// (the same operations in the same order), in AVX2 lanes. `None` for
    /// other lighting or where the CPU lacks AVX2.
    #[inline]
    pub fn unlit_shadowed8(
        &self,
        colour: &Lanes3,
        view_dir: Vec3,
        ao: &[f32; 8],
        tr: &[f32; 8],
    ) -> Option<Lanes3> {
        let light = self.single_per_ray_light()?;
        // `at` is `for_ray` for per-ray lights.
        let w = light.for_ray(view_dir).radiance.element_sum();
        let a = self.ambient.clamp(Vec3::ZERO, Vec3::ONE);
        #[cfg(target_arch = "x86_64")]
        if volcore::lanes::avx2_available() {
            let weight = (w > 0.0 && w.is_finite()).then_some(w);
            // SAFETY: AVX2 was just found on this CPU.
            return Some(unsafe { avx2::unlit_shadowed8(colour, a, ao, tr, weight) });
        }
        let _ = (colour, ao, tr, w, a);
        None
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

impl ViewShading {
    /// Eight samples of colours `colour` and world gradients `grad` shaded
    /// at once, where this CPU has AVX2 and the exponent is whole: per
    /// lane, `colour` where the squared gradient length is at most
    /// `threshold2` (or NaN), elsewhere [`ViewShading::shade_normal`] of
    /// the gradient over its length, or with `shadowed` = (transmittance,
    /// occlusion) [`ViewShading::shade_normal_shadowed`] with that lane's
    /// occlusion and transmittance; bit for bit (the same operations in
    /// the same order); `None` where [`ViewShading::lanes`] says no.
    pub fn shade8(
        &self,
        colour: &Lanes3,
        grad: &Lanes3,
        threshold2: f32,
        shadowed: Option<(&[f32; 8], &[f32; 8])>,
    ) -> Option<Lanes3> {
        let e = self.whole_exponent?;
        #[cfg(target_arch = "x86_64")]
        if volcore::lanes::avx2_available() {
            // SAFETY: AVX2 was just found on this CPU.
            return Some(unsafe { avx2::shade8(self, e, colour, grad, threshold2, shadowed) });
        }
        let _ = (e, colour, grad, threshold2, shadowed);
        None
    }

    /// Whether [`ViewShading::shade8`] shades in lanes here (this CPU has
    /// AVX2 and the exponent is whole).
    pub fn lanes(&self) -> bool {
        self.whole_exponent.is_some() && volcore::lanes::avx2_available()
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Lanes3, ViewShading};
    use std::arch::x86_64::*;

    /// `a + b` per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn add(a: __m256, b: __m256) -> __m256 {
        _mm256_add_ps(a, b)
    }

    /// `a · b` per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn mul(a: __m256, b: __m256) -> __m256 {
        _mm256_mul_ps(a, b)
    }

    /// `a · b` per lane for vectors `a` in lanes and `b` in every lane,
    /// summed as `Vec3::dot` sums.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn dot(a: &[__m256; 3], b: glam::Vec3) -> __m256 {
        add(
            add(
                mul(a[0], _mm256_set1_ps(b.x)),
                mul(a[1], _mm256_set1_ps(b.y)),
            ),
            mul(a[2], _mm256_set1_ps(b.z)),
        )
    }

    /// See [`super::Lighting::unlit_shadowed8`]: `a` is the clamped
    /// ambient term, `weight` the light's radiance sum where it counts.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn unlit_shadowed8(
        colour: &Lanes3,
        a: glam::Vec3,
        ao: &[f32; 8],
        tr: &[f32; 8],
        weight: Option<f32>,
    ) -> Lanes3 {
        let zero = _mm256_setzero_ps();
        // `sum / weight`, each summed from zero as one by one.
        let lit = match weight {
            Some(w) => _mm256_div_ps(
                add(zero, mul(_mm256_set1_ps(w), _mm256_loadu_ps(tr.as_ptr()))),
                _mm256_set1_ps(0.0 + w),
            ),
            None => _mm256_set1_ps(1.0),
        };
        let ao = _mm256_loadu_ps(ao.as_ptr());
        let mut out = [[0f32; 8]; 3];
        for (j, o) in out.iter_mut().enumerate() {
            // `colour · (a·ao + (1 − a)·lit)`.
            let f = add(
                mul(_mm256_set1_ps(a[j]), ao),
                mul(_mm256_set1_ps(1.0 - a[j]), lit),
            );
            let c = mul(_mm256_loadu_ps(colour[j].as_ptr()), f);
            _mm256_storeu_ps(o.as_mut_ptr(), c);
        }
        out
    }

    /// See [`ViewShading::shade8`]; `e` is the whole exponent.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn shade8(
        v: &ViewShading,
        e: u32,
        colour: &Lanes3,
        grad: &Lanes3,
        threshold2: f32,
        shadowed: Option<(&[f32; 8], &[f32; 8])>,
    ) -> Lanes3 {
        let zero = _mm256_setzero_ps();
        let g = [
            _mm256_loadu_ps(grad[0].as_ptr()),
            _mm256_loadu_ps(grad[1].as_ptr()),
            _mm256_loadu_ps(grad[2].as_ptr()),
        ];
        // |g|², as `length_squared` sums it.
        let len2 = add(add(mul(g[0], g[0]), mul(g[1], g[1])), mul(g[2], g[2]));
        let lit = _mm256_cmp_ps::<_CMP_GT_OQ>(len2, _mm256_set1_ps(threshold2));
        let r = _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(len2));
        // The normal −g·r, flipped to face the eye (sign flips, as `-n`).
        let sign = _mm256_set1_ps(-0.0);
        let mut n = [zero; 3];
        for j in 0..3 {
            n[j] = _mm256_xor_ps(mul(g[j], r), sign);
        }
        let away = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(dot(&n, v.to_eye), zero), sign);
        for c in &mut n {
            *c = _mm256_xor_ps(*c, away);
        }
        // `max(x, 0)` gives 0 for NaN, as `f32::max` does.
        let diff = _mm256_max_ps(dot(&n, v.l), zero);
        let (mut x, mut p, mut k) = (_mm256_max_ps(dot(&n, v.h), zero), _mm256_set1_ps(1.0), e);
        while k > 0 {
            if k & 1 == 1 {
                p = mul(p, x);
            }
            x = mul(x, x);
            k >>= 1;
        }
        let spec = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(diff, zero), p);
        let kd = mul(_mm256_set1_ps(v.model.diffuse), diff);
        let ks = mul(_mm256_set1_ps(v.model.specular), spec);
        // With shadows: the light's share scaled by the lane's
        // transmittance, the ambient part by its occlusion, and lanes the
        // light adds nothing to keep the ambient part alone (as
        // `shade_normal_shadowed` returns early).
        let shadow = shadowed.map(|(t, ao)| {
            let dark = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_EQ_OQ>(kd, zero),
                _mm256_cmp_ps::<_CMP_EQ_OQ>(ks, zero),
            );
            (
                _mm256_loadu_ps(t.as_ptr()),
                _mm256_loadu_ps(ao.as_ptr()),
                dark,
            )
        });
        let mut out = [[0f32; 8]; 3];
        for (j, o) in out.iter_mut().enumerate() {
            let col = _mm256_loadu_ps(colour[j].as_ptr());
            let mut amb = _mm256_set1_ps(v.ambient[j]);
            let mut rad = _mm256_set1_ps(v.radiance[j]);
            if let Some((t, ao, _)) = shadow {
                rad = mul(rad, t);
                amb = mul(amb, ao);
            }
            let mut shaded = add(mul(col, add(amb, mul(rad, kd))), mul(rad, ks));
            if let Some((_, _, dark)) = shadow {
                shaded = _mm256_blendv_ps(shaded, mul(col, amb), dark);
            }
            _mm256_storeu_ps(o.as_mut_ptr(), _mm256_blendv_ps(col, shaded, lit));
        }
        out
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
    fn lanes_shade_as_one_by_one_bit_for_bit() {
        let Some(_) = Lighting::default()
            .for_view(Light::HEADLIGHT, Vec3::NEG_Z)
            .shade8(&[[0.0; 8]; 3], &[[0.0; 8]; 3], 0.0, None)
        else {
            return; // No AVX2 here: nothing runs in lanes.
        };
        assert!(Lighting::default()
            .for_view(Light::HEADLIGHT, Vec3::NEG_Z)
            .lanes());
        let mut rng = fastrand::Rng::with_seed(12);
        let unit = |rng: &mut fastrand::Rng| {
            Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5).normalize_or(Vec3::X)
        };
        // Gradients that stress the edges: zero, tiny, huge, NaN, infinite,
        // along an axis, at right angles to the light.
        let special = [
            Vec3::ZERO,
            Vec3::splat(1e-30),
            Vec3::new(3e19, -1e19, 0.0),
            Vec3::new(f32::NAN, 1.0, 0.0),
            Vec3::new(f32::INFINITY, 0.0, 0.0),
            Vec3::X,
            Vec3::NEG_Z,
        ];
        let mut lit = 0;
        for round in 0..400 {
            let light = if round % 3 == 0 {
                Light::HEADLIGHT
            } else {
                Light::directional(unit(&mut rng)).unwrap()
            };
            let lighting = Lighting {
                lights: vec![light],
                ambient: Vec3::new(rng.f32(), 0.0, 0.25),
                model: BlinnPhong {
                    shininess: [1.0, 2.0, 24.0, 255.0][round % 4],
                    ..Default::default()
                },
            };
            let view = lighting.for_view(light, unit(&mut rng));
            let threshold2 = [0.0, 1e-6, 0.5][round % 3];
            let mut colour = [[0f32; 8]; 3];
            let mut grad = [[0f32; 8]; 3];
            let mut transmittance = [0f32; 8];
            let mut ao = [0f32; 8];
            for i in 0..8 {
                let g = match rng.usize(0..10) {
                    0 => special[rng.usize(0..special.len())],
                    1 => view.l.cross(unit(&mut rng)) * 3.0,
                    _ => unit(&mut rng) * rng.f32() * 100.0,
                };
                for j in 0..3 {
                    colour[j][i] = match rng.usize(0..20) {
                        0 => -0.0,
                        1 => 0.0,
                        _ => rng.f32(),
                    };
                    grad[j][i] = g[j];
                }
                transmittance[i] = match rng.usize(0..6) {
                    0 => 0.0,
                    1 => 1.0,
                    2 => 1e-38,
                    _ => rng.f32(),
                };
                ao[i] = match rng.usize(0..6) {
                    0 => 0.0,
                    1 => 1.0,
                    _ => rng.f32(),
                };
            }
            // Every other round with shadows and occlusion: each lane's
            // light scaled by its transmittance, its ambient part by its
            // occlusion.
            let shadowed = round % 2 == 1;
            let out = view
                .shade8(
                    &colour,
                    &grad,
                    threshold2,
                    shadowed.then_some((&transmittance, &ao)),
                )
                .unwrap();
            for i in 0..8 {
                let c = Vec3::new(colour[0][i], colour[1][i], colour[2][i]);
                let g = Vec3::new(grad[0][i], grad[1][i], grad[2][i]);
                let len2 = g.length_squared();
                let want = if len2 > threshold2 {
                    lit += 1;
                    let unit = g * len2.sqrt().recip();
                    if shadowed {
                        view.shade_normal_shadowed(c, unit, ao[i], || transmittance[i])
                    } else {
                        view.shade_normal(c, unit)
                    }
                } else {
                    c
                };
                for j in 0..3 {
                    assert_eq!(
                        out[j][i].to_bits(),
                        want[j].to_bits(),
                        "round {round} lane {i}: {g} gives {} not {}",
                        out[j][i],
                        want[j]
                    );
                }
            }
        }
        assert!(lit > 2000, "{lit}");
    }

    #[test]
    fn unlit_lanes_shade_as_one_by_one_bit_for_bit() {
        let mut rng = fastrand::Rng::with_seed(5);
        let mut compared = 0;
        for round in 0..300 {
            let dir = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, 0.3).normalize();
            // Lights that count, one of no radiance, one of infinite
            // radiance (neither weighs: the light's share is then 1).
            let radiance = match round % 5 {
                0 => Vec3::ZERO,
                1 => Vec3::new(f32::INFINITY, 1.0, 1.0),
                _ => Vec3::new(rng.f32() * 3.0, rng.f32(), 0.5),
            };
            let light = if round % 4 == 0 {
                Light::Headlight { radiance }
            } else {
                Light::Directional {
                    towards: dir,
                    radiance,
                }
            };
            let lighting = Lighting {
                lights: vec![light],
                // Ambient terms outside [0, 1] are clamped.
                ambient: Vec3::new(rng.f32() * 1.4 - 0.2, 0.0, 0.25),
                ..Default::default()
            };
            let view_dir = Vec3::new(0.2, rng.f32() - 0.5, -1.0).normalize();
            let pick = |rng: &mut fastrand::Rng| match rng.usize(0..8) {
                0 => 0.0,
                1 => 1.0,
                2 => 1e-38,
                3 => -0.0,
                _ => rng.f32(),
            };
            let colour: Lanes3 = std::array::from_fn(|_| std::array::from_fn(|_| pick(&mut rng)));
            let ao: [f32; 8] = std::array::from_fn(|_| pick(&mut rng));
            let tr: [f32; 8] = std::array::from_fn(|_| pick(&mut rng));
            let Some(out) = lighting.unlit_shadowed8(&colour, view_dir, &ao, &tr) else {
                return; // No AVX2 here: nothing runs in lanes.
            };
            for i in 0..8 {
                let c = Vec3::new(colour[0][i], colour[1][i], colour[2][i]);
                let p = Vec3::new(1.0, 2.0, 3.0);
                let want = lighting.unlit_shadowed(c, view_dir, p, ao[i], |l, inc| {
                    assert_eq!((l, inc.towards), (0, light.for_ray(view_dir).towards));
                    tr[i]
                });
                for j in 0..3 {
                    assert_eq!(out[j][i].to_bits(), want[j].to_bits(), "round {round}");
                }
                compared += 1;
            }
        }
        assert_eq!(compared, 2400);
        // Other lighting does not run in lanes.
        let two = Lighting {
            lights: vec![Light::HEADLIGHT, Light::HEADLIGHT],
            ..Default::default()
        };
        let zero = [[0.0; 8]; 3];
        assert!(two
            .unlit_shadowed8(&zero, Vec3::Z, &[1.0; 8], &[1.0; 8])
            .is_none());
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
