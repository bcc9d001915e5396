//! Per-frame setup of shadows: the shadow step, and the light grids the
//! frame's lights need, built once before any ray is traced.

use super::light_grid::LightGrid;
use super::occluder::{Classified, IsoInside, Occluder};
use super::{EffectStats, ShadowMethod, Shadows};
use crate::accel::ClearBoxes;
use crate::classify::Classifier;
use crate::error::RenderError;
use crate::integrator::reconstruct::{Analytic, Central, Nearest, NoGradient, Trilinear};
use crate::integrator::FrameGeometry;
use crate::light::Light;
use crate::settings::{GradientMethod, Interp, RenderSettings};
use glam::Vec3;
use volcore::{Volume, VolumeVisitor, VoxelSource};

/// Memory the light grids of one frame may take together.
pub const GRID_MEMORY_BUDGET: u64 = 8 << 30;

/// The shadow-ray sample placement: the frame's geometry at the shadow
/// step (the view step unless the settings give one).
pub fn shadow_geometry(geom: &FrameGeometry, shadows: &Shadows) -> FrameGeometry {
    FrameGeometry {
        step: shadows.step.unwrap_or(geom.step),
        ..*geom
    }
}

/// The grids a frame's lights read: one per directional light under the
/// grid method (`None` for the other lights, which cast shadow rays),
/// through `occ` with query `q`; and what building them cost.
fn grids<O: Occluder>(
    vol: &Volume,
    lights: &[Light],
    shadows: &Shadows,
    step: f32,
    occ: &O,
    q: O::Query,
    clear: Option<&ClearBoxes<'_>>,
) -> Result<(Vec<Option<LightGrid>>, EffectStats), RenderError> {
    let mut stats = EffectStats::default();
    let ShadowMethod::Grid { divisor } = shadows.method else {
        return Ok((vec![None; lights.len()], stats));
    };
    let mut out = Vec::with_capacity(lights.len());
    for light in lights {
        let Light::Directional { towards, .. } = *light else {
            out.push(None);
            continue;
        };
        let budget = GRID_MEMORY_BUDGET.saturating_sub(stats.shadow_grid_bytes);
        // Segments are sampled at the shadow step when one is given, else
        // at half a grid cell (finer buys little after the grid's own
        // trilinear reads), never coarser than the step.
        let sample_spacing = match shadows.step {
            Some(s) => s,
            None => step.max(0.5 * divisor as f32 * vol.meta.min_spacing()),
        };
        let grid = vol.visit(Build {
            occ,
            q,
            towards,
            spacing: vol.meta.spacing,
            divisor,
            step,
            sample_spacing,
            budget,
            clear,
        })?;
        stats.shadow_grids += 1;
        stats.shadow_grid_s += grid.build_s;
        stats.shadow_grid_bytes += grid.bytes();
        stats.shadow_grid_samples += grid.samples;
        out.push(Some(grid));
    }
    Ok((out, stats))
}

struct Build<'o, O: Occluder> {
    clear: Option<&'o ClearBoxes<'o>>,
    occ: &'o O,
    q: O::Query,
    towards: Vec3,
    spacing: [f32; 3],
    divisor: u32,
    step: f32,
    sample_spacing: f32,
    budget: u64,
}

impl<O: Occluder> VolumeVisitor for Build<'_, O> {
    type Output = Result<LightGrid, RenderError>;
    fn visit<S: VoxelSource>(self, src: &S) -> Self::Output {
        LightGrid::build(
            src,
            self.occ,
            self.q,
            self.towards,
            self.spacing,
            self.divisor,
            self.step,
            self.sample_spacing,
            self.budget,
            self.clear,
        )
    }
}

/// The grids of a DVR frame, through the depth table `depth` (optical
/// depth per `geom.step`), reconstructed as the frame reconstructs.
pub fn dvr_grids<K: Classifier>(
    vol: &Volume,
    settings: &RenderSettings,
    shadows: &Shadows,
    geom: &FrameGeometry,
    depth: &K,
    clear: Option<&ClearBoxes<'_>>,
) -> Result<(Vec<Option<LightGrid>>, EffectStats), RenderError> {
    let (loc, inv) = (geom.locator, geom.inv_spacing);
    let lights = &settings.lighting.lights;
    let step = geom.step;
    macro_rules! with {
        ($r:ty, $g:ty) => {
            grids(
                vol,
                lights,
                shadows,
                step,
                &Classified::<$r, $g, K>::new(depth, loc, inv),
                (),
                clear,
            )
        };
    }
    use GradientMethod::{Analytic as A, Central as C};
    match (settings.interp, K::NEEDS_GRADIENT, settings.gradient) {
        (Interp::Trilinear, false, _) => with!(Trilinear, NoGradient),
        (Interp::Trilinear, true, C) => with!(Trilinear, Central),
        (Interp::Trilinear, true, A) => with!(Trilinear, Analytic),
        (Interp::Nearest, false, _) => with!(Nearest, NoGradient),
        (Interp::Nearest, true, C) => with!(Nearest, Central),
        (Interp::Nearest, true, A) => with!(Nearest, Analytic),
    }
}

/// The grids of an iso frame: values at or above `level` block light (the
/// outside is below it).
pub fn iso_grids(
    vol: &Volume,
    settings: &RenderSettings,
    shadows: &Shadows,
    geom: &FrameGeometry,
    level: f32,
    clear: Option<&ClearBoxes<'_>>,
) -> Result<(Vec<Option<LightGrid>>, EffectStats), RenderError> {
    let lights = &settings.lighting.lights;
    match settings.interp {
        Interp::Trilinear => {
            let occ = IsoInside::<Trilinear>::new(level, geom.locator);
            grids(vol, lights, shadows, geom.step, &occ, false, clear)
        }
        Interp::Nearest => {
            let occ = IsoInside::<Nearest>::new(level, geom.locator);
            grids(vol, lights, shadows, geom.step, &occ, false, clear)
        }
    }
}
