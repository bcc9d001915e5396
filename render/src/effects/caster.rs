//! Shadows at a shaded point: per light, a grid read or a shadow ray; and
//! the DVR shading that multiplies each light by its transmittance and the
//! ambient term by the ambient occlusion.

use super::ao::AoSource;
use super::light_grid::LightGrid;
use super::occluder::Occluder;
use super::shadow_ray::transmittance;
use super::RayEffects;
use crate::accel::open_sky::OpenSky;
use crate::accel::{Accel, NoSkipping};
use crate::integrator::dvr::Shading;
use crate::integrator::march::RaySteps;
use crate::integrator::FrameGeometry;
use crate::light::Incident;
use crate::ray::{intersect_box, Ray};
use crate::shade::{Lanes3, Lighting, ViewShading};
use glam::Vec3;
use volcore::Cursor;

/// Transmittance from a point toward each light of a frame.
pub struct ShadowCaster<'a, O, A> {
    occ: O,
    skip: Option<&'a A>,
    /// Shadow-ray sample placement (the shadow step).
    geom: FrameGeometry,
    /// The far corner of the volume's box.
    hi: Vec3,
    /// Per light: its grid, or `None` for shadow rays.
    grids: &'a [Option<LightGrid>],
    /// Per light: where a shadow ray's way to it becomes clear, if known.
    skies: &'a [Option<OpenSky>],
    /// Whether the CPU has AVX2 (shadow rays march in code compiled for
    /// it).
    avx2: bool,
    /// Voxels along the light by which a grid read moves off the point
    /// (iso-surfaces: so the surface does not shadow itself).
    grid_offset: f32,
}

impl<'a, O: Occluder, A: Accel<O::Query>> ShadowCaster<'a, O, A> {
    /// Shadows through `occ`, marched at `geom.step` with skipping `skip`
    /// in the box `[0, hi]`; lights with a grid in `grids` read it (moved
    /// `grid_offset` voxels toward the light).
    pub fn new(
        occ: O,
        skip: Option<&'a A>,
        geom: FrameGeometry,
        hi: Vec3,
        grids: &'a [Option<LightGrid>],
        grid_offset: f32,
    ) -> Self {
        ShadowCaster {
            occ,
            skip,
            geom,
            hi,
            grids,
            skies: &[],
            avx2: volcore::lanes::avx2_available(),
            grid_offset,
        }
    }

    /// The same caster, its shadow rays stopping where `skies` finds the
    /// rest of their way clear (per light, as in `grids`).
    pub fn with_open_skies(self, skies: &'a [Option<OpenSky>]) -> Self {
        ShadowCaster { skies, ..self }
    }

    /// The fraction of light `light` (arriving as `inc`) that reaches
    /// world point `p`, with query `q`; counts shadow rays into `fx`.
    #[inline]
    pub fn transmittance<C: Cursor>(
        &self,
        cur: &mut C,
        light: usize,
        p: Vec3,
        inc: &Incident,
        q: O::Query,
        fx: &mut RayEffects,
    ) -> f32 {
        if let Some(grid) = self.grid(light) {
            return self.grid_transmittance(grid, p, inc);
        }
        let inv = self.geom.inv_spacing;
        fx.shadow_rays += 1;
        let ray = Ray {
            origin: p,
            dir: inc.towards,
        };
        let Some((_, t1)) = intersect_box(&ray, Vec3::ZERO, self.hi) else {
            return 1.0;
        };
        let mut t1 = t1.min(inc.distance);
        if let Some(Some(sky)) = self.skies.get(light) {
            // Past this point the ray meets only clear cells: the samples
            // left out would each add zero depth.
            t1 = t1.min(sky.clear_after(p * inv));
        }
        let steps = RaySteps::new(&self.geom, &ray, self.geom.step, t1);
        let (t, samples) = match self.skip {
            Some(a) => march_shadow(self.avx2, &self.occ, a, cur, &steps, q),
            None => march_shadow(self.avx2, &self.occ, &NoSkipping, cur, &steps, q),
        };
        fx.shadow_samples += samples as u64;
        t
    }
}

impl<O, A> ShadowCaster<'_, O, A> {
    /// Light `light`'s transmittance grid, if it has one (else it casts
    /// shadow rays).
    #[inline(always)]
    pub fn grid(&self, light: usize) -> Option<&LightGrid> {
        self.grids.get(light)?.as_ref()
    }

    /// The fraction of the light arriving as `inc` that reaches world
    /// point `p`, read from its grid `grid` (moved the caster's grid
    /// offset toward the light).
    #[inline(always)]
    pub fn grid_transmittance(&self, grid: &LightGrid, p: Vec3, inc: &Incident) -> f32 {
        let mut pv = p * self.geom.inv_spacing;
        if let Some(s) = self.grid_shift(inc) {
            pv += s;
        }
        grid.transmittance(pv)
    }

    /// The voxel-space move of a grid read toward the light arriving as
    /// `inc` (`grid_offset` voxels along its longest axis), if any.
    #[inline(always)]
    fn grid_shift(&self, inc: &Incident) -> Option<Vec3> {
        if self.grid_offset > 0.0 {
            let lv = inc.towards * self.geom.inv_spacing;
            let m = lv.abs().max_element();
            if m > 0.0 {
                return Some(lv * (self.grid_offset / m));
            }
        }
        None
    }

    /// [`ShadowCaster::grid_transmittance`] at eight world points `p`
    /// (per component, then per lane), bit for bit, the grid read in lanes
    /// where it allows.
    #[inline(always)]
    pub fn grid_transmittance8(&self, grid: &LightGrid, p: &Lanes3, inc: &Incident) -> [f32; 8] {
        let inv = self.geom.inv_spacing;
        let shift = self.grid_shift(inc);
        let lane = |i: usize| Vec3::new(p[0][i], p[1][i], p[2][i]);
        let mut pv = [[0f32; 8]; 3];
        for i in 0..8 {
            let mut v = lane(i) * inv;
            if let Some(s) = shift {
                v += s;
            }
            for (a, lanes) in pv.iter_mut().enumerate() {
                lanes[i] = v[a];
            }
        }
        grid.transmittance8(&pv)
            .unwrap_or_else(|| std::array::from_fn(|i| self.grid_transmittance(grid, lane(i), inc)))
    }
}

/// [`transmittance`], compiled for AVX2 where the CPU has it (so the
/// eight-sample reads and lookups inline into the march) and as usual
/// elsewhere; the same bits either way.
#[inline(always)]
fn march_shadow<C: Cursor, O: Occluder, A: Accel<O::Query>>(
    avx2: bool,
    occ: &O,
    accel: &A,
    cur: &mut C,
    steps: &RaySteps,
    q: O::Query,
) -> (f32, u32) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is set only where the CPU was found to have it.
        return unsafe { transmittance_avx2(occ, accel, cur, steps, q) };
    }
    let _ = avx2;
    transmittance(occ, accel, cur, steps, q)
}

/// [`transmittance`] compiled with AVX2.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn transmittance_avx2<C: Cursor, O: Occluder, A: Accel<O::Query>>(
    occ: &O,
    accel: &A,
    cur: &mut C,
    steps: &RaySteps,
    q: O::Query,
) -> (f32, u32) {
    transmittance(occ, accel, cur, steps, q)
}

/// Blinn-Phong with effects for DVR: each light's share of a sample's
/// light is multiplied by its transmittance from the sample (with
/// shadows), and the ambient term by the sample's ambient occlusion (with
/// AO). Samples whose gradient is too short for a normal keep their colour
/// scaled by the lights' mean transmittance above the ambient part, which
/// is occluded over the whole sphere.
pub struct EffectsPhong<'a, O, A> {
    lighting: &'a Lighting,
    threshold2: f32,
    caster: Option<&'a ShadowCaster<'a, O, A>>,
    ao: Option<&'a AoSource<'a>>,
}

impl<'a, O, A> EffectsPhong<'a, O, A> {
    /// Shading with `lighting` where the squared gradient length exceeds
    /// `threshold2`, shadowed by `caster` and occluded by `ao` when given.
    pub fn new(
        lighting: &'a Lighting,
        threshold2: f32,
        caster: Option<&'a ShadowCaster<'a, O, A>>,
        ao: Option<&'a AoSource<'a>>,
    ) -> Self {
        EffectsPhong {
            lighting,
            threshold2,
            caster,
            ao,
        }
    }
}

/// A DVR ray's effect state: the ray and its pixel, its counters, the
/// index of its next occluded sample, and the per-ray shading when the
/// frame has one light from a fixed direction.
pub struct EffectsRay {
    ray: Ray,
    pixel: [u32; 2],
    fx: RayEffects,
    ao_index: u64,
    one_light: Option<ViewShading>,
}

/// The outward unit normal for ambient occlusion from world gradient
/// `grad` (toward falling values), scaled by its largest component first
/// so tiny and huge gradients normalise alike; `None` when it has no
/// direction.
#[inline]
pub fn outward_normal(grad: Vec3) -> Option<Vec3> {
    let m = grad.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let n = -(grad / m).normalize_or_zero();
    (n != Vec3::ZERO).then_some(n)
}

/// [`outward_normal`] of eight gradients (per component, then per lane):
/// the normals (zero where there is none) and the lanes that have one, bit
/// for bit.
#[inline]
pub fn outward_normals8(grad: &Lanes3) -> (Lanes3, u8) {
    #[cfg(target_arch = "x86_64")]
    if volcore::lanes::avx2_available() {
        // SAFETY: AVX2 was found.
        return unsafe { avx2::outward_normals8(grad) };
    }
    let mut out = [[0.0; 8]; 3];
    let mut has = 0u8;
    for i in 0..8 {
        if let Some(n) = outward_normal(Vec3::new(grad[0][i], grad[1][i], grad[2][i])) {
            has |= 1 << i;
            for (a, o) in out.iter_mut().enumerate() {
                o[i] = n[a];
            }
        }
    }
    (out, has)
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
    use crate::ray::Ray;
    use crate::shade::Lanes3;
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

    /// See [`super::outward_normals8`]: `outward_normal`'s operations in
    /// lanes (MAXPS picks as `max_element` does, NaN included).
    ///
    /// # Safety
    /// AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn outward_normals8(grad: &Lanes3) -> (Lanes3, u8) {
        let [x, y, z] = grad.each_ref().map(|c| _mm256_loadu_ps(c.as_ptr()));
        let sign = _mm256_set1_ps(-0.0);
        let abs = |v| _mm256_andnot_ps(sign, v);
        let zero = _mm256_setzero_ps();
        let inf = _mm256_set1_ps(f32::INFINITY);
        let m = _mm256_max_ps(abs(x), _mm256_max_ps(abs(y), abs(z)));
        // `m > 0 && m.is_finite()`.
        let scaled = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(m, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(m, inf),
        );
        let q = [x, y, z].map(|c| _mm256_div_ps(c, m));
        let mul = |a, b| _mm256_mul_ps(a, b);
        let dot = _mm256_add_ps(
            _mm256_add_ps(mul(q[0], q[0]), mul(q[1], q[1])),
            mul(q[2], q[2]),
        );
        let rcp = _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(dot));
        // `normalize_or_zero`: `rcp.is_finite() && rcp > 0`.
        let unit = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(rcp, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(rcp, inf),
        );
        let ok = _mm256_and_ps(scaled, unit);
        let n = q.map(|c| _mm256_and_ps(_mm256_xor_ps(mul(c, rcp), sign), ok));
        // `n != ZERO` (NaN counts as not zero).
        let nonzero = n.iter().fold(zero, |acc, &c| {
            _mm256_or_ps(acc, _mm256_cmp_ps::<_CMP_NEQ_UQ>(c, zero))
        });
        let has = _mm256_movemask_ps(_mm256_and_ps(ok, nonzero)) as u8;
        let mut out = [[0f32; 8]; 3];
        for (o, c) in out.iter_mut().zip(n) {
            _mm256_storeu_ps(o.as_mut_ptr(), c);
        }
        (out, has)
    }
}

impl<O: Occluder<Query = ()>, A: Accel<()>> Shading for EffectsPhong<'_, O, A> {
    type PerRay = EffectsRay;
    const ON: bool = true;
    #[inline(always)]
    fn for_ray(&self, ray: &Ray, pixel: [u32; 2]) -> EffectsRay {
        EffectsRay {
            ray: *ray,
            pixel,
            fx: RayEffects::default(),
            ao_index: 0,
            one_light: self
                .lighting
                .single_per_ray_light()
                .map(|l| self.lighting.for_view(l, ray.dir)),
        }
    }
    #[inline(always)]
    fn shade<C: Cursor>(
        &self,
        st: &mut EffectsRay,
        cur: &mut C,
        colour: Vec3,
        grad: Vec3,
        len2: f32,
        t: f32,
    ) -> Vec3 {
        let EffectsRay {
            ray,
            pixel,
            fx,
            ao_index,
            one_light,
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
        if let (Some(view), true) = (one_light.as_ref(), lit) {
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
    #[inline(always)]
    fn effects(st: &EffectsRay) -> RayEffects {
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
        st: &mut EffectsRay,
        colour: &Lanes3,
        grad: &Lanes3,
        t: &[f32; 8],
        visible: u8,
    ) -> Option<Lanes3> {
        let EffectsRay {
            ray,
            pixel,
            fx,
            ao_index,
            one_light,
        } = st;
        let view = one_light.as_ref().filter(|v| v.lanes())?;
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
