//! Shadows at a shaded point: per light, a grid read or a shadow ray.

use super::light_grid::LightGrid;
use super::occluder::Occluder;
use super::shadow_ray::transmittance;
use super::RayEffects;
use crate::accel::open_sky::OpenSky;
use crate::accel::Accel;
use crate::lanes::Lanes3;
use crate::light::Incident;
use crate::ray::{intersect_box, Ray};
use crate::trace::march::RaySteps;
use crate::trace::FrameGeometry;
use glam::Vec3;
use volcore::grid::DynCursor;
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
        // Skipping on or off, one compiled march.
        let (t, samples) = march_shadow(self.avx2, &self.occ, &self.skip, cur, &steps, q);
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
/// eight-sample reads and lookups inline into the march) and otherwise
/// once for every layout, reading through a [`DynCursor`]; the same bits
/// either way.
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
    transmittance_any_layout(occ, accel, cur, steps, q)
}

/// [`transmittance`] through a cursor of any layout: the march for CPUs
/// without AVX2, compiled once per occluder rather than once per layout.
#[inline(never)]
fn transmittance_any_layout<O: Occluder, A: Accel<O::Query>>(
    occ: &O,
    accel: &A,
    cur: &mut dyn Cursor,
    steps: &RaySteps,
    q: O::Query,
) -> (f32, u32) {
    transmittance(occ, accel, &mut DynCursor(cur), steps, q)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::NoSkipping;
    use crate::classify::{Classifier, TfTable};
    use crate::effects::Classified;
    use crate::integrator::NoGradient;
    use crate::settings::Interp;
    use crate::tf::TransferFunction;
    use volcore::grid::Locator;
    use volcore::region::pack_sliced;
    use volcore::scene::{NoiseKind, NoiseScene, SceneSource};
    use volcore::{Dims, VoxelSource};

    /// The march for CPUs without AVX2 (through a cursor of any layout)
    /// gives the AVX2 march's bits, samples and all.
    #[test]
    fn every_march_gives_the_same_transmittance() {
        let d = Dims::new(23, 19, 17).unwrap();
        let scene = NoiseScene::new(d, 3, NoiseKind::Value, 4.0, 2, 100.0);
        let grid = volcore::SlicedGrid::new(
            d,
            volcore::Data::Owned(pack_sliced(&SceneSource::<u8>::new(&scene))),
        )
        .unwrap();
        let mut rng = fastrand::Rng::with_seed(9);
        let mut partial = 0;
        for interp in [Interp::Trilinear, Interp::Nearest] {
            let geom = FrameGeometry {
                step: 0.37,
                inv_spacing: Vec3::ONE,
                locator: Locator::new(d),
                interp,
            };
            let tf = TransferFunction::preset("grey", (0.0, 100.0)).unwrap();
            let depth = TfTable::new(&tf, 0.0, 100.0, 256, geom.step).to_optical_depth();
            let occ = Classified::<NoGradient, _>::new(&depth, &geom);
            let hi = Vec3::new(22.0, 18.0, 16.0);
            let (mut a, mut b) = (grid.cursor(), grid.cursor());
            for _ in 0..200 {
                let p = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * hi;
                let dir = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
                let Some(dir) = crate::ray::unit(dir) else {
                    continue;
                };
                let ray = Ray { origin: p, dir };
                let Some((_, t1)) = intersect_box(&ray, Vec3::ZERO, hi) else {
                    continue;
                };
                let steps = RaySteps::new(&geom, &ray, geom.step, t1);
                let any = transmittance_any_layout(&occ, &NoSkipping, &mut a, &steps, ());
                let plain = transmittance(&occ, &NoSkipping, &mut b, &steps, ());
                assert_eq!(any.0.to_bits(), plain.0.to_bits());
                assert_eq!(any.1, plain.1);
                partial += usize::from(any.0 > 0.0 && any.0 < 1.0);
                #[cfg(target_arch = "x86_64")]
                if volcore::lanes::avx2_available() {
                    // SAFETY: AVX2 was found.
                    let fast = unsafe { transmittance_avx2(&occ, &NoSkipping, &mut b, &steps, ()) };
                    assert_eq!(any.0.to_bits(), fast.0.to_bits());
                    assert_eq!(any.1, fast.1);
                }
            }
        }
        // Most rays end partly shadowed, not at the cutoff or clear.
        assert!(partial > 200, "{partial} of 400 rays partly shadowed");
    }
}
