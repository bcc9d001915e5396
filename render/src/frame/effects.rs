//! Per-frame setup of the effects: the shadow step, the light grids the
//! frame's lights need, and the occlusion grid and AO field, all built
//! once before any ray is traced.

use crate::accel::open_sky::OpenSky;
use crate::accel::{ClearBoxes, FixedCells};
use crate::effects::ao::{AoField, AoLookup, AoSource, Spiral};
use crate::effects::light_grid::LightGrid;
use crate::effects::occluder::{IsoInside, Occluder};
use crate::effects::occlusion_grid::{Intervals, OcclusionGrid, OCCLUSION_CELL};
use crate::error::RenderError;
use crate::film::EffectStats;
use crate::light::Light;
use crate::sampler::HashSampler;
use crate::settings::{Ao, AoMethod, RenderSettings, ShadowMethod, Shadows};
use crate::trace::FrameGeometry;
use glam::Vec3;
use volcore::{Volume, VolumeVisitor, VoxelSource};

/// Memory the light grids of one frame may take together.
pub const GRID_MEMORY_BUDGET: u64 = 8 << 30;

/// The shadow-ray sample placement: the frame's geometry at the shadow
/// step (the view step unless the settings give one; also the step the
/// effects' optical depth tables are made for).
pub fn shadow_geometry(geom: &FrameGeometry, shadows: Option<&Shadows>) -> FrameGeometry {
    FrameGeometry {
        step: shadows.and_then(|s| s.step).unwrap_or(geom.step),
        ..*geom
    }
}

/// Per light, where shadow rays' way to it becomes clear (see
/// [`OpenSky`]): for the directional lights that cast shadow rays (no grid
/// in `grids`), when the frame skips by `clear`; `None` for the others.
pub fn open_skies(
    lights: &[Light],
    grids: &[Option<LightGrid>],
    clear: Option<&FixedCells<'_>>,
    geom: &FrameGeometry,
) -> Vec<Option<OpenSky>> {
    lights
        .iter()
        .enumerate()
        .map(|(i, light)| {
            let clear = clear?;
            let Light::Directional { towards, .. } = *light else {
                return None;
            };
            if matches!(grids.get(i), Some(Some(_))) {
                return None;
            }
            // The direction shadow rays take in voxel units, as
            // `RaySteps::new` makes it.
            let d = towards * geom.inv_spacing;
            OpenSky::build(clear.index(), |c| !clear.skippable_finest(c), d)
        })
        .collect()
}

/// The grids a frame's lights read: one per directional light under the
/// grid method (`None` for the other lights, which cast shadow rays),
/// through `occ` with query `q`; and what building them cost.
pub fn light_grids<O: Occluder>(
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

/// What a frame's ambient occlusion reads: the occlusion grid, the march
/// of its rays, and the precomputed field when the method is one.
pub struct AoParts {
    /// The settings.
    pub ao: Ao,
    /// The classified volume's extinction, coarse.
    pub grid: OcclusionGrid,
    /// Where occlusion rays sample.
    pub intervals: Intervals,
    /// The precomputed field (`--ao-field`).
    pub field: Option<AoField>,
    /// The directions of a shaded sample (`--ao N`).
    pub spiral: Spiral,
}

impl AoParts {
    /// The frame's occlusion, looked up `offset_cells` occlusion-grid
    /// cells off shaded samples along their normal, in the box `[0, hi]`.
    pub fn source(&self, hi: Vec3, offset_cells: f32, min_spacing: f32) -> AoSource<'_> {
        let lookup = match &self.field {
            Some(f) => AoLookup::Field(f),
            None => AoLookup::Rays {
                spiral: &self.spiral,
                intervals: &self.intervals,
                sampler: HashSampler::new(self.ao.seed),
            },
        };
        AoSource::new(
            &self.grid,
            lookup,
            hi,
            AoSource::offset_for(offset_cells, min_spacing),
        )
    }
}

/// The AO radius for a volume: the setting, or a tenth of the diagonal.
pub fn ao_radius(vol: &Volume, ao: &Ao) -> f32 {
    ao.radius
        .unwrap_or_else(|| vol.meta.world_diagonal().map_or(0.0, |d| (d / 10.0) as f32))
}

/// Build what `ao` needs through `occ` (query `q`, depth per `step`),
/// skipping samples in `clear`; adds the costs to `stats` (the grid's
/// build counts in the frame, the field's is reported beside it).
pub fn ao_parts<O: Occluder>(
    vol: &Volume,
    ao: &Ao,
    step: f32,
    occ: &O,
    q: O::Query,
    clear: Option<&ClearBoxes<'_>>,
    stats: &mut EffectStats,
) -> Result<AoParts, RenderError> {
    let spacing = vol.meta.spacing;
    let budget = GRID_MEMORY_BUDGET.saturating_sub(stats.shadow_grid_bytes);
    let grid = vol.visit(BuildOcclusion {
        occ,
        q,
        spacing,
        step,
        budget,
        clear,
    })?;
    // The grid is part of the frame for sampled AO; for a field it is
    // part of the precomputation (the frame reads only the field).
    match ao.method {
        AoMethod::Rays { .. } => stats.ao_grid_s += grid.build_s,
        AoMethod::Field { .. } => stats.ao_field_s += grid.build_s,
    }
    stats.ao_grid_bytes += grid.bytes();
    stats.ao_grid_samples += grid.samples;
    let cell = OCCLUSION_CELL as f32 * vol.meta.min_spacing();
    let intervals = Intervals::new(ao_radius(vol, ao), 0.5 * cell, cell);
    let field = match ao.method {
        AoMethod::Field {
            k,
            cell: field_cell,
        } => {
            let d = vol.dims().as_array();
            let dims = [d[0] as usize, d[1] as usize, d[2] as usize];
            let budget = budget.saturating_sub(grid.bytes());
            let f = AoField::build(&grid, &intervals, dims, spacing, k, field_cell, budget)?;
            stats.ao_field_s += f.build_s;
            stats.ao_field_bytes += f.bytes();
            stats.ao_field_samples += f.samples;
            Some(f)
        }
        AoMethod::Rays { .. } => None,
    };
    let spiral = match ao.method {
        AoMethod::Rays { n } => Spiral::new(n),
        AoMethod::Field { .. } => Spiral::new(0),
    };
    Ok(AoParts {
        ao: *ao,
        grid,
        intervals,
        field,
        spiral,
    })
}

struct BuildOcclusion<'o, O: Occluder> {
    occ: &'o O,
    q: O::Query,
    spacing: [f32; 3],
    step: f32,
    budget: u64,
    clear: Option<&'o ClearBoxes<'o>>,
}

impl<O: Occluder> VolumeVisitor for BuildOcclusion<'_, O> {
    type Output = Result<OcclusionGrid, RenderError>;
    fn visit<S: VoxelSource>(self, src: &S) -> Self::Output {
        OcclusionGrid::build(
            src,
            self.occ,
            self.q,
            self.spacing,
            self.step,
            self.budget,
            self.clear,
        )
    }
}

/// The AO of an iso frame: values at or above `level` occlude (the outside
/// is below it); adds its costs to `stats`.
pub fn iso_ao(
    vol: &Volume,
    ao: &Ao,
    geom: &FrameGeometry,
    level: f32,
    clear: Option<&ClearBoxes<'_>>,
    stats: &mut EffectStats,
) -> Result<AoParts, RenderError> {
    let occ = IsoInside::new(level, geom);
    ao_parts(vol, ao, geom.step, &occ, false, clear, stats)
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
    let occ = IsoInside::new(level, geom);
    light_grids(vol, lights, shadows, geom.step, &occ, false, clear)
}
