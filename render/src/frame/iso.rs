//! An iso-surface frame's set-up: the uniform cells, the shadows' grids
//! and the occlusion built, then the frame traced with the [`Iso`]
//! integrator of the frame's reconstruction and gradient method.

use super::effects::{iso_ao, iso_grids, shadow_geometry};
use super::FrameInputs;
use crate::accel::IsoSides;
use crate::classify::srgb_to_linear;
use crate::effects::{AoSource, IsoInside, LightGrid, ShadowCaster};
use crate::error::RenderError;
use crate::film::{EffectStats, Film};
use crate::integrator::Iso;
use crate::settings::{GradientMethod, Mode, ShadowMethod};
use crate::shade::Lighting;
use crate::tiles::Tiles;
use crate::trace::reconstruct::{Analytic, Central, Gradient};
use crate::trace::FrameGeometry;
use glam::Vec3;
use volcore::Volume;

/// What an iso frame's shadows need besides its settings.
struct IsoShadows {
    /// Shadow-ray sample placement (the shadow step).
    geom: FrameGeometry,
    /// Per light: its transmittance grid, or `None` for shadow rays.
    grids: Vec<Option<LightGrid>>,
    /// What building the grids cost.
    stats: EffectStats,
    /// Voxels along the light a grid read moves off the surface.
    grid_offset: f32,
}

/// Render an iso-surface frame at the level of its mode ([`Mode::Iso`];
/// another mode is refused), skipping over the index when given: the
/// uniform cells, the shadows' grids and the occlusion are built first,
/// then the frame traced with the integrator of the frame's
/// reconstruction and gradient method.
pub fn render_frame(inputs: &FrameInputs<'_>) -> Result<Film, RenderError> {
    let Mode::Iso(level) = inputs.settings.mode else {
        return Err(RenderError::Setting(
            "an iso-surface frame needs the iso mode and its level".into(),
        ));
    };
    let FrameInputs {
        vol,
        skip_index: index,
        settings,
        geom,
        ref tiles,
        ..
    } = *inputs;
    let sides = index.map(|ix| IsoSides::new(ix, level));
    let boxes = sides.as_ref().map(|c| c.clear_boxes_below());
    let sgeom = shadow_geometry(&geom, settings.shadows.as_ref());
    let mut ao_stats = EffectStats::default();
    let ao_parts = match &settings.ao {
        Some(ao) => Some(iso_ao(
            vol,
            ao,
            &sgeom,
            level,
            boxes.as_ref(),
            &mut ao_stats,
        )?),
        None => None,
    };
    let min_spacing = vol.meta.min_spacing();
    let ao = ao_parts
        .as_ref()
        .map(|p| p.source(tiles.hi, 1.5, min_spacing));
    let shadows = match &settings.shadows {
        Some(sh) => {
            let (grids, stats) = iso_grids(vol, settings, sh, &sgeom, level, boxes.as_ref())?;
            let grid_offset = match sh.method {
                ShadowMethod::Grid { divisor } => 1.5 * divisor as f32,
                ShadowMethod::Ray => 0.0,
            };
            Some(IsoShadows {
                geom: sgeom,
                grids,
                stats,
                grid_offset,
            })
        }
        None => None,
    };
    let frame = IsoFrame {
        vol,
        tiles,
        geom,
        level,
        colour: Vec3::from(settings.iso_colour.map(srgb_to_linear)),
        lighting: &settings.lighting,
        skip: sides.as_ref(),
        shadows: shadows.as_ref(),
        ao: ao.as_ref(),
    };
    let mut film = match settings.gradient {
        GradientMethod::Central => frame.trace::<Central>(),
        GradientMethod::Analytic => frame.trace::<Analytic>(),
    }?;
    if let Some(sh) = &shadows {
        film.add_grid_stats(&sh.stats);
    }
    film.add_grid_stats(&ao_stats);
    Ok(film)
}

/// An iso frame's parts, before its types are chosen.
struct IsoFrame<'a> {
    vol: &'a Volume,
    tiles: &'a Tiles<'a>,
    geom: FrameGeometry,
    level: f32,
    colour: Vec3,
    lighting: &'a Lighting,
    skip: Option<&'a IsoSides<'a>>,
    shadows: Option<&'a IsoShadows>,
    ao: Option<&'a AoSource<'a>>,
}

impl IsoFrame<'_> {
    /// Trace the frame with gradient method `G`.
    fn trace<G: Gradient>(&self) -> Result<Film, RenderError> {
        let caster = self.shadows.map(|sh| {
            let occ = IsoInside::new(self.level, &sh.geom);
            ShadowCaster::new(
                occ,
                self.skip,
                sh.geom,
                self.tiles.hi,
                &sh.grids,
                sh.grid_offset,
            )
        });
        let iso = Iso::<G>::new(
            self.geom,
            self.skip,
            self.level,
            self.colour,
            self.lighting,
            caster.as_ref(),
            self.ao,
        );
        self.tiles.render(self.vol, &iso)
    }
}
