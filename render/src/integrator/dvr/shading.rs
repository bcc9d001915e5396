//! How DVR lights a classified sample: not at all ([`Unshaded`]), or by
//! Blinn-Phong ([`Phong`], the model in [`crate::shade`]) with the frame's
//! effects when it has any. One lit type serves every lighting: the
//! one-light fast path (a light from one direction all along a ray, worked
//! out once per ray) is chosen per frame, and shadows and ambient
//! occlusion are runtime parts that cost a branch per shaded sample when
//! off. The classifier and the gradient stay type parameters of the
//! integrator: they change what the inner loop reads.

use crate::accel::FixedCells;
use crate::effects::{outward_normal, outward_normals8, AoSource, RayEffects, ShadowCaster};
use crate::lanes::Lanes3;
use crate::light::{Incident, Light};
use crate::ray::Ray;
use crate::shade::{Lighting, ViewShading};
use glam::Vec3;
use volcore::Cursor;

/// How a classified sample's colour is lit.
pub trait Shading: Sync {
    /// What the shading works out once per ray (and what it counts along
    /// it).
    type PerRay;
    /// Whether it shades at all (then the integrator computes gradients
    /// of visible samples).
    const ON: bool;
    /// The per-ray part for `ray` through `pixel`.
    fn for_ray(&self, ray: &Ray, pixel: [u32; 2]) -> Self::PerRay;
    /// `colour` lit at ray parameter `t`, where the world-space gradient
    /// is `grad`, of squared length `len2`; effects that sample the volume
    /// (shadow rays) read it through `cur`.
    fn shade<C: Cursor>(
        &self,
        per_ray: &mut Self::PerRay,
        cur: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3;
    /// What the effects did along the ray (nothing, for plain shading).
    fn effects(per_ray: &Self::PerRay) -> RayEffects;
    /// Whether [`Shading::shade8`] may shade runs of eight samples.
    const LANES: bool;
    /// [`Shading::shade`] of eight samples at ray parameters `t` of
    /// colours `colour` and world gradients `grad` (per component, then
    /// per lane), bit for bit, for the lanes set in `visible` (the others
    /// are garbage); `None` where it cannot here (then the samples go one
    /// by one).
    fn shade8(
        &self,
        per_ray: &mut Self::PerRay,
        colour: &Lanes3,
        grad: &Lanes3,
        t: &[f32; 8],
        visible: u8,
    ) -> Option<Lanes3>;
}

/// Classified colour as is.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unshaded;

impl Shading for Unshaded {
    type PerRay = ();
    const ON: bool = false;
    #[inline(always)]
    fn for_ray(&self, _: &Ray, _: [u32; 2]) {}
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        _: &mut (),
        _: &mut C,
        colour: Vec3,
        _: Vec3,
        _: f32,
        _: f32,
    ) -> Vec3 {
        colour
    }
    #[inline(always)]
    fn effects(_: &()) -> RayEffects {
        RayEffects::default()
    }
    const LANES: bool = false;
    #[inline(always)]
    fn shade8(&self, _: &mut (), _: &Lanes3, _: &Lanes3, _: &[f32; 8], _: u8) -> Option<Lanes3> {
        None
    }
}

/// The shadows of a DVR frame: its occluder `O` marched by shadow rays
/// that skip the cells clear for them, or read from light grids.
pub type DvrCaster<'a, O> = ShadowCaster<'a, O, FixedCells<'a>>;

/// Blinn-Phong for DVR, with the frame's shadows and ambient occlusion
/// when it has them.
///
/// Without effects a sample whose gradient is too short for a normal keeps
/// its colour. With effects, each light's share of a lit sample is
/// multiplied by its transmittance from the sample (shadows) and the
/// ambient term by the sample's occlusion (AO); a sample without a normal
/// keeps its colour scaled by the lights' mean transmittance above the
/// ambient part, which is occluded over the whole sphere.
pub struct Phong<'a, O> {
    lighting: &'a Lighting,
    threshold2: f32,
    /// The light, when the frame has one light that arrives from the same
    /// direction all along a ray (its shading is then worked out per ray).
    one_light: Option<Light>,
    caster: Option<&'a DvrCaster<'a, O>>,
    ao: Option<&'a AoSource<'a>>,
    /// Whether the frame has shadows or ambient occlusion.
    effects: bool,
}

impl<'a, O> Phong<'a, O> {
    /// Shading with `lighting` where the squared gradient length exceeds
    /// `threshold2`, shadowed by `caster` and occluded by `ao` when given.
    pub fn new(
        lighting: &'a Lighting,
        threshold2: f32,
        caster: Option<&'a DvrCaster<'a, O>>,
        ao: Option<&'a AoSource<'a>>,
    ) -> Self {
        Phong {
            lighting,
            threshold2,
            one_light: lighting.single_per_ray_light(),
            caster,
            ao,
            effects: caster.is_some() || ao.is_some(),
        }
    }
}

/// A DVR ray's shading state: the ray and its pixel, the effects'
/// counters, the index of its next occluded sample, and the per-ray
/// shading when the frame has one light from a fixed direction.
pub struct PhongRay {
    ray: Ray,
    pixel: [u32; 2],
    fx: RayEffects,
    ao_index: u64,
    view: Option<ViewShading>,
}

impl<O: crate::effects::Occluder<Query = ()>> Shading for Phong<'_, O> {
    type PerRay = PhongRay;
    const ON: bool = true;
    #[inline(always)]
    fn for_ray(&self, ray: &Ray, pixel: [u32; 2]) -> PhongRay {
        PhongRay {
            ray: *ray,
            pixel,
            fx: RayEffects::default(),
            ao_index: 0,
            view: self.one_light.map(|l| self.lighting.for_view(l, ray.dir)),
        }
    }
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        st: &mut PhongRay,
        cur: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3 {
        if self.effects {
            return self.shade_effects(st, cur, colour, grad, len2, t);
        }
        // Too short a gradient (or NaN) for a normal: the colour as is.
        let lit = len2 > self.threshold2;
        match (&st.view, lit) {
            (_, false) => colour,
            (Some(view), true) => view.shade_normal(colour, grad * len2.sqrt().recip()),
            (None, true) => {
                let p = st.ray.origin + st.ray.dir * t;
                self.lighting.shade_at(colour, grad, st.ray.dir, p)
            }
        }
    }
    #[inline(always)]
    fn effects(st: &PhongRay) -> RayEffects {
        st.fx
    }
    const LANES: bool = true;
    /// Runs of eight shade in lanes when the frame has one light from a
    /// fixed direction whose shadows, if any, come from a transmittance
    /// grid (grid reads count nothing and read no volume). Occlusion is
    /// worked out per visible lane in lane order, as [`Shading::shade`]
    /// takes the samples, so every lane keeps its index into the
    /// directions' sampler; the lanes the light leaves unlit (too short a
    /// gradient) are shaded one by one, as in [`Shading::shade`].
    #[inline(always)]
    fn shade8(
        &self,
        st: &mut PhongRay,
        colour: &Lanes3,
        grad: &Lanes3,
        t: &[f32; 8],
        visible: u8,
    ) -> Option<Lanes3> {
        if self.effects {
            return self.shade8_effects(st, colour, grad, t, visible);
        }
        st.view
            .as_ref()?
            .shade8(colour, grad, self.threshold2, None)
    }
}

impl<O: crate::effects::Occluder<Query = ()>> Phong<'_, O> {
    /// [`Shading::shade`] with effects. Not inlined: one copy per occluder
    /// and volume layout rather than one in every shaded integrator (a
    /// call costs little beside what an effect computes per sample).
    #[inline(never)]
    fn shade_effects<C: Cursor>(
        &self,
        st: &mut PhongRay,
        cur: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3 {
        let PhongRay {
            ray,
            pixel,
            fx,
            ao_index,
            view,
        } = st;
        let p = ray.origin + ray.dir * t;
        let lit = len2 > self.threshold2;
        let ao = match self.ao {
            Some(src) => {
                let n = if lit { outward_normal(grad) } else { None };
                let a = src.occlusion(p, n, *pixel, *ao_index, fx);
                *ao_index += 1;
                a
            }
            None => 1.0,
        };
        let caster = self.caster;
        if let (Some(view), true) = (view.as_ref(), lit) {
            // One light from one direction along the ray: its incident
            // light is the same everywhere (index 0).
            let inc = self.lighting.lights[0].for_ray(ray.dir);
            let unit = grad * len2.sqrt().recip();
            return view.shade_normal_shadowed(colour, unit, ao, || {
                caster.map_or(1.0, |c| c.transmittance(cur, 0, p, &inc, (), fx))
            });
        }
        let mut light = |i: usize, inc: &Incident| {
            caster.map_or(1.0, |c| c.transmittance(cur, i, p, inc, (), fx))
        };
        if lit {
            self.lighting
                .shade_shadowed(colour, grad, ray.dir, p, ao, &mut light)
        } else {
            self.lighting
                .unlit_shadowed(colour, ray.dir, p, ao, &mut light)
        }
    }

    /// [`Shading::shade8`] with effects (not inlined, as
    /// [`Phong::shade_effects`]).
    #[inline(never)]
    fn shade8_effects(
        &self,
        st: &mut PhongRay,
        colour: &Lanes3,
        grad: &Lanes3,
        t: &[f32; 8],
        visible: u8,
    ) -> Option<Lanes3> {
        let PhongRay {
            ray,
            pixel,
            fx,
            ao_index,
            view,
        } = st;
        let view = view.as_ref().filter(|v| v.lanes())?;
        // Shadow rays read the volume: those samples go one by one.
        let shadow = match self.caster {
            Some(c) => Some((c, c.grid(0)?)),
            None => None,
        };
        let inc = self.lighting.lights[0].for_ray(ray.dir);
        let lane = |l: &Lanes3, i: usize| Vec3::new(l[0][i], l[1][i], l[2][i]);
        // The points, and the lanes lit as `shade` finds them
        // (`len2 > threshold2`, so not NaN).
        let (p, lit) = points8(ray, t, grad, self.threshold2);
        // Every lane's read (those not shaded here are dropped).
        let tr = shadow.map_or([1.0; 8], |(c, g)| c.grid_transmittance8(g, &p, &inc));
        let shaded = |mask: u8| (0..8).filter(move |&i| mask >> i & 1 == 1);
        let mut ao = [1.0f32; 8];
        if let Some(src) = self.ao {
            let (normal, has_normal) = outward_normals8(grad);
            let with_normal = visible & lit & has_normal;
            match src.field8(&p, &normal, with_normal, visible) {
                Some(a) => {
                    // Lanes not shaded here are dropped.
                    ao = a;
                    *ao_index += u64::from(visible.count_ones());
                }
                None => {
                    for i in shaded(visible) {
                        let n = (with_normal >> i & 1 == 1).then(|| lane(&normal, i));
                        ao[i] = src.occlusion(lane(&p, i), n, *pixel, *ao_index, fx);
                        *ao_index += 1;
                    }
                }
            }
        }
        // `lanes()` said the lit lanes shade here.
        let mut out = view.shade8(colour, grad, self.threshold2, Some((&tr, &ao)))?;
        let unlit = visible & !lit;
        if unlit == 0 {
            return Some(out);
        }
        // One light, per ray: its incident light is `inc` everywhere, and
        // its transmittance `tr`.
        let dark = self.lighting.unlit_shadowed8(colour, ray.dir, &ao, &tr);
        for i in shaded(unlit) {
            let c = match &dark {
                Some(d) => lane(d, i),
                None => {
                    let p = lane(&p, i);
                    self.lighting
                        .unlit_shadowed(lane(colour, i), ray.dir, p, ao[i], |_, _| tr[i])
                }
            };
            for (j, o) in out.iter_mut().enumerate() {
                o[i] = c[j];
            }
        }
        Some(out)
    }
}

/// The points `ray.origin + ray.dir * t` of eight parameters (per
/// component, then per lane), and the lanes whose gradient's squared
/// length exceeds `threshold2` (NaN does not), as one by one, bit for bit.
#[inline]
pub fn points8(ray: &Ray, t: &[f32; 8], grad: &Lanes3, threshold2: f32) -> (Lanes3, u8) {
    #[cfg(target_arch = "x86_64")]
    if volcore::lanes::avx2_available() {
        // SAFETY: AVX2 was found.
        return unsafe { avx2::points8(ray, t, grad, threshold2) };
    }
    let p = std::array::from_fn(|a| t.map(|t| ray.origin[a] + ray.dir[a] * t));
    let lit = (0..8)
        .filter(|&i| Vec3::new(grad[0][i], grad[1][i], grad[2][i]).length_squared() > threshold2)
        .fold(0u8, |m, i| m | 1 << i);
    (p, lit)
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::lanes::Lanes3;
    use crate::ray::Ray;
    use std::arch::x86_64::*;

    /// See [`super::points8`].
    ///
    /// # Safety
    /// AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn points8(ray: &Ray, t: &[f32; 8], grad: &Lanes3, threshold2: f32) -> (Lanes3, u8) {
        let mul = |a, b| _mm256_mul_ps(a, b);
        let tv = _mm256_loadu_ps(t.as_ptr());
        let mut p = [[0f32; 8]; 3];
        for (a, o) in p.iter_mut().enumerate() {
            let v = _mm256_add_ps(
                _mm256_set1_ps(ray.origin[a]),
                mul(_mm256_set1_ps(ray.dir[a]), tv),
            );
            _mm256_storeu_ps(o.as_mut_ptr(), v);
        }
        let [x, y, z] = grad.each_ref().map(|c| _mm256_loadu_ps(c.as_ptr()));
        // `length_squared`'s sum.
        let len2 = _mm256_add_ps(_mm256_add_ps(mul(x, x), mul(y, y)), mul(z, z));
        let lit = _mm256_cmp_ps::<_CMP_GT_OQ>(len2, _mm256_set1_ps(threshold2));
        (p, _mm256_movemask_ps(lit) as u8)
    }
}
