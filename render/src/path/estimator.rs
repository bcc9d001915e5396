//! The radiance one camera sample carries: a volumetric path traced from
//! the eye with delta tracking, next-event estimation toward every sun and
//! point light at each real scattering event (transmittance by ratio
//! tracking), continuation by sampling the phase function, and the
//! environment where a path leaves the volume.
//!
//! An environment map is also sampled at every event (in proportion to
//! its luminance) and met where paths escape; the two estimates are
//! combined by multiple importance sampling (the power heuristic between
//! the map's density and the phase function's), so neither a small bright
//! sun in the map nor a peaked phase function leaves fireflies. A
//! constant environment is met by escaping paths alone (a direction drawn
//! from the phase function is already its perfect sample).
//!
//! With hybrid scattering on, each event first reads the extinction's
//! gradient and, with a probability that rises with its magnitude,
//! reflects off a [`Surface`] BRDF around it instead of the phase
//! function (lights, map and continuation all use that BRDF). Off, no
//! gradient is read.
//!
//! Bounces count scattering events: with `bounces = D` a path scatters at
//! most D times; after the D-th event only the environment can still be
//! reached (the continuation ray is traced for it, and stops at its first
//! real collision). Russian roulette on the throughput starts after
//! [`ROULETTE_DEPTH`] events. A medium with albedo 0 everywhere never
//! scatters: its pixels are the background's radiance times the camera
//! ray's transmittance, by ratio tracking, and no scattering code runs.

use super::envmap::EnvMap;
use super::medium::Medium;
use super::phase::HenyeyGreenstein;
use super::surface::{surface_probability, Surface};
use super::tracking::{Flight, Tracker};
use super::{PathCounters, PathLights};
use crate::accel::VoxelRay;
use crate::camera::Camera;
use crate::light::MIN_DISTANCE2;
use crate::ray::{intersect_box, Ray};
use crate::sampler::{HashSampler, PixelSampler, Slot};
use glam::Vec3;
use volcore::Cursor;

/// Scattering events after which Russian roulette on the throughput
/// starts.
pub const ROULETTE_DEPTH: u32 = 3;

/// Everything a sample needs that is fixed for the frame.
pub struct Estimator<'a, M: Medium> {
    /// Tracking over the majorant grid.
    pub tracker: Tracker<'a, M>,
    /// The camera.
    pub camera: &'a Camera,
    /// `1 / spacing` per axis (world to voxel coordinates).
    pub inv_spacing: Vec3,
    /// The volume's world box `[0, extent]`.
    pub extent: Vec3,
    /// The phase function.
    pub phase: HenyeyGreenstein,
    /// The lights.
    pub lights: &'a PathLights,
    /// Radiance a camera ray sees where it leaves the volume unscattered
    /// (`None`: the environment).
    pub background: Option<Vec3>,
    /// The environment map, when the scene has one that is not black.
    pub env_map: Option<&'a EnvMap>,
    /// Scattering events allowed.
    pub bounces: u32,
    /// Hybrid scattering's gradient scale (`None`: off).
    pub hybrid: Option<f32>,
    /// Whether the medium can scatter at all.
    pub scatters: bool,
    /// The frame's random numbers.
    pub sampler: HashSampler,
    /// The image blocks whose camera rays may meet a cell with extinction
    /// (`None`: all may); a sample elsewhere is what its camera ray sees
    /// behind the volume, as tracing it would find.
    pub visible: Option<&'a crate::accel::cull::BlockMask>,
}

/// How light scatters at an event: the medium's phase function, or a
/// surface.
#[derive(Clone, Copy)]
enum Lobe {
    Phase,
    Surface(Surface),
}

/// A world ray's stretch inside the box, and its voxel-space twin.
struct Inside {
    ray: VoxelRay,
    t0: f32,
    t1: f32,
}

impl<M: Medium> Estimator<'_, M> {
    #[inline(always)]
    fn inside(&self, ray: &Ray, t_max: f32) -> Option<Inside> {
        let (t0, t1) = intersect_box(ray, Vec3::ZERO, self.extent)?;
        let t1 = t1.min(t_max);
        (t0 <= t1).then(|| Inside {
            ray: VoxelRay::new(ray.origin * self.inv_spacing, ray.dir * self.inv_spacing),
            t0,
            t1,
        })
    }

    /// The transmittance from `p` along unit `dir` up to `t_max`, its
    /// first exponential step from `first` (uniform in `[0, 1)`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn transmittance<C: Cursor>(
        &self,
        cur: &mut C,
        p: Vec3,
        dir: Vec3,
        t_max: f32,
        first: f32,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> f32 {
        n.shadow_rays += 1;
        match self.inside(&Ray { origin: p, dir }, t_max) {
            Some(s) => self
                .tracker
                .transmittance(cur, &s.ray, s.t0, s.t1, first, rng, n),
            None => 1.0,
        }
    }

    /// Radiance arriving from the environment along unit `dir` (toward
    /// it).
    #[inline(always)]
    fn sky(&self, dir: Vec3) -> Vec3 {
        match self.env_map {
            Some(m) => m.radiance(dir),
            None => self.lights.env,
        }
    }

    /// What a camera ray along `dir` sees where it leaves the volume
    /// unscattered.
    #[inline(always)]
    fn seen(&self, dir: Vec3) -> Vec3 {
        self.background.unwrap_or_else(|| self.sky(dir))
    }

    /// Light from the environment map scattered at `p` toward the eye of
    /// a ray travelling along `d`: one direction drawn from the map,
    /// weighted against the phase function's density.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn direct_env<C: Cursor>(
        &self,
        map: &EnvMap,
        lobe: &Lobe,
        cur: &mut C,
        p: Vec3,
        d: Vec3,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Vec3 {
        let (u, v) = rng.slot_2d(Slot::EnvU);
        let Some(e) = map.sample(u, v) else {
            return Vec3::ZERO;
        };
        let f = self.lobe_f(lobe, d, e.dir);
        let pdf = match lobe {
            Lobe::Phase => f.x,
            Lobe::Surface(s) => s.pdf(d, e.dir),
        };
        if f.max_element() <= 0.0 || e.radiance == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let first = rng.next_1d();
        let tr = self.transmittance(cur, p, e.dir, f32::INFINITY, first, rng, n);
        if tr <= 0.0 {
            return Vec3::ZERO;
        }
        e.radiance * f * (tr * power_heuristic(e.pdf, pdf) / e.pdf)
    }

    /// What `lobe` scatters from unit direction `wi` (toward the light)
    /// into the eye of a path travelling along `d`: the phase function's
    /// value, or the BRDF times the cosine.
    #[inline(always)]
    fn lobe_f(&self, lobe: &Lobe, d: Vec3, wi: Vec3) -> Vec3 {
        match lobe {
            Lobe::Phase => Vec3::splat(self.phase.eval(wi.dot(d))),
            Lobe::Surface(s) => s.eval(d, wi),
        }
    }

    /// Light from the suns and point lights scattered at `p` toward the
    /// eye of a ray travelling along `d`, per unit throughput.
    #[inline]
    fn direct<C: Cursor>(
        &self,
        lobe: &Lobe,
        cur: &mut C,
        p: Vec3,
        d: Vec3,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Vec3 {
        let mut l = Vec3::ZERO;
        // The first shadow ray's first step is the event's structured
        // draw; the others are hashed.
        let mut shadow = Some(Slot::Shadow);
        let mut first = |rng: &mut PixelSampler| match shadow.take() {
            Some(s) => rng.slot(s),
            None => rng.next_1d(),
        };
        for (towards, irradiance) in self.lights.directional() {
            let f = self.lobe_f(lobe, d, towards);
            if f.max_element() <= 0.0 {
                continue;
            }
            let u = first(rng);
            let tr = self.transmittance(cur, p, towards, f32::INFINITY, u, rng, n);
            if tr > 0.0 {
                l += irradiance * (f * tr);
            }
        }
        for (position, intensity) in self.lights.points() {
            let to = position - p;
            let d2 = to.length_squared().max(MIN_DISTANCE2);
            let dist = d2.sqrt();
            let Some(wi) = crate::ray::unit(to) else {
                continue;
            };
            let f = self.lobe_f(lobe, d, wi);
            if f.max_element() <= 0.0 {
                continue;
            }
            let u = first(rng);
            let tr = self.transmittance(cur, p, wi, dist, u, rng, n);
            if tr > 0.0 {
                l += intensity * (f * tr / d2);
            }
        }
        l
    }

    /// The radiance of sample `index` of pixel `(x, y)` (finite: a
    /// non-finite estimate is counted and dropped).
    pub fn radiance<C: Cursor>(
        &self,
        cur: &mut C,
        x: u32,
        y: u32,
        index: u64,
        n: &mut PathCounters,
    ) -> Vec3 {
        let culled = self.visible.is_some_and(|m| !m.may_see(x, y));
        if culled && self.env_map.is_none() {
            // What every ray of the block sees: no direction needed.
            n.paths += 1;
            n.culled_paths += 1;
            return self.background.unwrap_or(self.lights.env);
        }
        let mut rng = self.sampler.pixel(x, y, index);
        let (jx, jy) = rng.pixel_2d();
        // Free flights have no sample grid: a voxel is the unit that
        // says how far is far for the eye (`EyeRay::near`).
        let voxel = 1.0 / self.inv_spacing.max_element();
        let (ray, _) =
            self.camera
                .ray_at(x as f32 + jx, y as f32 + jy)
                .near(Vec3::ZERO, self.extent, voxel);
        n.paths += 1;
        if culled {
            n.culled_paths += 1;
            return self.seen(ray.dir);
        }
        let l = if self.scatters {
            self.path(cur, ray, &mut rng, n)
        } else {
            self.absorbing(cur, ray, &mut rng, n)
        };
        if l.is_finite() {
            l
        } else {
            n.non_finite += 1;
            Vec3::ZERO
        }
    }

    /// A medium that only absorbs: the background through the camera
    /// ray's transmittance.
    fn absorbing<C: Cursor>(
        &self,
        cur: &mut C,
        ray: Ray,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Vec3 {
        let seen = self.seen(ray.dir);
        if seen == Vec3::ZERO {
            return Vec3::ZERO;
        }
        match self.inside(&ray, f32::INFINITY) {
            Some(s) => {
                rng.event(0);
                let first = rng.slot(Slot::Flight);
                seen * self
                    .tracker
                    .transmittance(cur, &s.ray, s.t0, s.t1, first, rng, n)
            }
            None => seen,
        }
    }

    /// The surface an event at world point `p` (reached travelling along
    /// `d`, in a sample of value `value`) reflects off, drawn with the
    /// hybrid probability; `None`: the phase function scatters.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn surface_at<C: Cursor>(
        &self,
        scale: f32,
        cur: &mut C,
        p: Vec3,
        d: Vec3,
        value: f32,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Option<Surface> {
        let u = rng.slot(Slot::Surface);
        let grad = self.tracker.gradient(cur, p * self.inv_spacing);
        n.density_lookups += 6;
        let top = self.tracker.grid.global();
        let relative = if top > 0.0 { grad.length() / top } else { 0.0 };
        if u >= surface_probability(scale, relative) {
            return None;
        }
        // Per world unit: the voxel gradient through the spacing.
        Surface::new(
            grad * self.inv_spacing,
            d,
            self.tracker.medium.albedo(value),
        )
    }

    /// A scattering path.
    fn path<C: Cursor>(
        &self,
        cur: &mut C,
        mut ray: Ray,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Vec3 {
        let has_sky = self.env_map.is_some() || self.lights.env != Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut l = Vec3::ZERO;
        let mut depth = 0u32;
        // The density of the last continuation's direction (for the map's
        // multiple importance weights).
        let mut phase_pdf = 0.0f32;
        loop {
            // Where the path leaves the volume it meets the environment
            // (the camera ray sees the background instead, when given).
            let escape = |ray: &Ray| {
                if depth == 0 {
                    self.seen(ray.dir)
                } else {
                    match self.env_map {
                        Some(m) => {
                            let (radiance, pdf) = m.radiance_pdf(ray.dir);
                            radiance * power_heuristic(phase_pdf, pdf)
                        }
                        None => self.lights.env,
                    }
                }
            };
            let Some(s) = self.inside(&ray, f32::INFINITY) else {
                l += beta * escape(&ray);
                break;
            };
            rng.event(depth);
            let first = rng.slot(Slot::Flight);
            let (t, value) =
                match self
                    .tracker
                    .free_flight(cur, &s.ray, (s.t0, s.t1), first, rng, n)
                {
                    Flight::Escaped => {
                        l += beta * escape(&ray);
                        break;
                    }
                    Flight::Truncated => break,
                    Flight::Collision { t, value } => (t, value),
                };
            if depth == self.bounces {
                // The continuation after the last event: it reached no
                // light.
                break;
            }
            depth += 1;
            rng.event(depth);
            n.scatter_events += 1;
            let p = ray.origin + ray.dir * t;
            let lobe = match self.hybrid {
                Some(scale) => match self.surface_at(scale, cur, p, ray.dir, value, rng, n) {
                    Some(s) => Lobe::Surface(s),
                    None => Lobe::Phase,
                },
                None => Lobe::Phase,
            };
            match lobe {
                // The surface's albedo is in its BRDF.
                Lobe::Surface(_) => n.surface_events += 1,
                Lobe::Phase => beta *= self.tracker.medium.albedo(value),
            }
            if beta.max_element() <= 0.0 {
                break;
            }
            l += beta * self.direct(&lobe, cur, p, ray.dir, rng, n);
            if let Some(m) = self.env_map {
                l += beta * self.direct_env(m, &lobe, cur, p, ray.dir, rng, n);
            }
            if depth == self.bounces && !has_sky {
                break;
            }
            if depth > ROULETTE_DEPTH {
                let q = beta.max_element().min(1.0);
                if rng.slot(Slot::Roulette) >= q {
                    break;
                }
                beta /= q;
            }
            let (u, v) = rng.slot_2d(Slot::DirU);
            let dir = match lobe {
                Lobe::Phase => {
                    let dir = self.phase.sample(ray.dir, u, v);
                    if self.env_map.is_some() {
                        phase_pdf = self.phase.eval(dir.dot(ray.dir));
                    }
                    dir
                }
                Lobe::Surface(s) => {
                    let Some(e) = s.sample(ray.dir, u, v) else {
                        break;
                    };
                    beta *= e.weight;
                    phase_pdf = e.pdf;
                    e.dir
                }
            };
            ray = Ray { origin: p, dir };
            n.bounce_rays += 1;
        }
        l
    }
}

/// The power-heuristic weight (β = 2) of a sample drawn with density `a`
/// against a second strategy of density `b`: `a² / (a² + b²)`, 1 where
/// only the first could have drawn it, 0 where neither (no division by 0,
/// no overflow for densities up to f32's range).
#[inline(always)]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    let r = b as f64 / a as f64;
    (1.0 / (1.0 + r * r)) as f32
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_weights_sum_to_one_and_survive_extremes() {
        for (a, b) in [
            (1.0f32, 1.0f32),
            (0.3, 7.0),
            (1e-30, 1e30),
            (3e38, 2e-38),
            (5.0, 0.0),
        ] {
            let w = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((w - 1.0).abs() < 1e-6, "{a} {b}: {w}");
        }
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
        assert_eq!(power_heuristic(2.0, 0.0), 1.0);
    }
}
