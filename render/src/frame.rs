//! A whole frame: settings resolved into one specialised integrator,
//! tiles traced in parallel into a film, the film resolved into a frame.

use crate::accel::{cull, FixedCells, IsoSides};
use crate::camera::Camera;
use crate::classify::{srgb_to_linear, Classifier, GradientBound, TfTable, TfTable2d};
use crate::dispatch::{
    self, ClassifierRef, DvrEffects, DvrPlan, IntegratorVisitor, IsoPlan, IsoShadows, MipPlan,
    XrayPlan,
};
use crate::distributed::ShareBox;
use crate::effects::{self, Ao, AoMethod, EffectStats, ShadowMethod, Shadows};
use crate::error::RenderError;
use crate::film::{Display, Film, Frame};
use crate::integrator::dvr::PhongShading;
use crate::integrator::xray::XrayOutput;
use crate::integrator::{FrameGeometry, Integrator, RayResult, Span};
use crate::ray::intersect_box;
use crate::settings::{Mode, RenderSettings};
use crate::tf::{Tf, TransferFunction};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use volcore::{Volume, VolumeVisitor, VoxelSource};
use volindex::MajorantIndex;

/// The most samples one ray may take. Settings that imply more (a step
/// tiny against the volume's size, or a voxel spacing so small or so
/// large on one axis that the default step is) are refused before any ray
/// is traced, so no input can make a ray's loop run without end.
pub const MAX_SAMPLES_PER_RAY: f64 = 1e7;

/// The volume's box diagonal in world units, in f64 (`None` when the
/// extent `(dims − 1) × spacing` is not a finite f32 on some axis).
pub fn world_diagonal(vol: &Volume) -> Option<f64> {
    let e = vol.meta.world_extent();
    e.iter().all(|c| c.is_finite()).then(|| {
        e.iter()
            .map(|&c| (c as f64) * (c as f64))
            .sum::<f64>()
            .sqrt()
    })
}

/// Memory a frame may use for its per-pixel buffers (film, ray results,
/// the resolved frame and its output encodings).
pub const FRAME_MEMORY_BUDGET: u64 = 8 << 30;

/// Bytes a frame needs per pixel, all buffers together (an upper bound).
pub const FRAME_BYTES_PER_PIXEL: u64 = 160;

fn check(settings: &RenderSettings, vol: &Volume, camera: &Camera) -> Result<(), RenderError> {
    let (w, h) = (camera.width() as u64, camera.height() as u64);
    let need = w * h * FRAME_BYTES_PER_PIXEL;
    if need > FRAME_MEMORY_BUDGET {
        return Err(RenderError::Setting(format!(
            "a {w}x{h} frame needs about {:.1} GiB ({FRAME_BYTES_PER_PIXEL} bytes per pixel), \
             more than the budget of {} GiB: ask for a smaller --size",
            need as f64 / (1u64 << 30) as f64,
            FRAME_MEMORY_BUDGET >> 30
        )));
    }
    let s = settings.step;
    let diagonal = check_step("step", s, vol)?;
    if let Some(sh) = &settings.shadows {
        check_shadows(settings, sh, vol)?;
    }
    if let Some(ao) = &settings.ao {
        check_ao(settings, ao)?;
    }
    // Sample positions are f32: far from the origin consecutive samples
    // would round to the same point and a ray's sample index overflow.
    let reach = camera.eye().as_dvec3().length() + diagonal;
    if reach * f32::EPSILON as f64 > s as f64 {
        let e = camera.eye();
        return Err(RenderError::Camera(format!(
            "eye {},{},{} is too far from the volume for step {s}: f32 positions there are coarser than the step",
            e.x, e.y, e.z
        )));
    }
    if let Some(t) = settings.ert {
        if !(t > 0.0 && t <= 1.0) {
            return Err(RenderError::Setting(format!(
                "termination threshold {t} must be in (0, 1]"
            )));
        }
    }
    if settings.tile == 0 {
        return Err(RenderError::Setting("tile size must be at least 1".into()));
    }
    if let Mode::Iso(v) = settings.mode {
        if !v.is_finite() {
            return Err(RenderError::Setting("iso value must be finite".into()));
        }
    }
    Ok(())
}

/// Check a sample spacing along rays (`what` names it in errors) against
/// the volume: positive, not absurdly small, and at most
/// [`MAX_SAMPLES_PER_RAY`] samples across the diagonal, which it returns.
fn check_step(what: &str, s: f32, vol: &Volume) -> Result<f64, RenderError> {
    if !(s.is_finite() && s > 0.0) {
        return Err(RenderError::Setting(format!(
            "{what} {s} must be a positive number"
        )));
    }
    if s < vol.meta.min_spacing() * 1e-4 {
        return Err(RenderError::Setting(format!(
            "{what} {s} is below 1e-4 of the voxel spacing: a frame would take billions of samples per ray"
        )));
    }
    let sp = vol.meta.spacing;
    let Some(diagonal) = world_diagonal(vol) else {
        return Err(RenderError::Setting(format!(
            "the volume's extent (dims {} x spacing {},{},{}) is too large for f32 world coordinates",
            vol.dims(),
            sp[0],
            sp[1],
            sp[2]
        )));
    };
    let per_ray = diagonal / s as f64;
    if per_ray > MAX_SAMPLES_PER_RAY {
        return Err(RenderError::Setting(format!(
            "{what} {s} across the volume's diagonal of {diagonal:.6e} world units (spacing {},{},{}) \
             means {per_ray:.3e} samples per ray, more than the limit of {MAX_SAMPLES_PER_RAY:e}",
            sp[0], sp[1], sp[2]
        )));
    }
    Ok(diagonal)
}

/// Check the shadow settings: a mode and shading that have light to
/// shadow, a valid grid divisor and shadow step.
fn check_shadows(settings: &RenderSettings, sh: &Shadows, vol: &Volume) -> Result<(), RenderError> {
    match settings.mode {
        Mode::Dvr if !settings.shading => {
            return Err(RenderError::Setting(
                "shadows need shading: an unshaded DVR frame has no light to shadow".into(),
            ))
        }
        Mode::Dvr | Mode::Iso(_) => {}
        _ => {
            return Err(RenderError::Setting(
                "shadows apply to the DVR and iso modes only".into(),
            ))
        }
    }
    if let ShadowMethod::Grid { divisor } = sh.method {
        if ![1, 2, 4].contains(&divisor) {
            return Err(RenderError::Setting(format!(
                "shadow grid divisor {divisor} must be 1, 2 or 4"
            )));
        }
    }
    if let Some(h) = sh.step {
        check_step("shadow step", h, vol)?;
    }
    Ok(())
}

/// Check the ambient occlusion settings: a mode and shading with an
/// ambient term to occlude, direction counts within their limits, a
/// radius that is a number.
fn check_ao(settings: &RenderSettings, ao: &Ao) -> Result<(), RenderError> {
    match settings.mode {
        Mode::Dvr if !settings.shading => {
            return Err(RenderError::Setting(
                "ambient occlusion needs shading: an unshaded DVR frame has no ambient light"
                    .into(),
            ))
        }
        Mode::Dvr | Mode::Iso(_) => {}
        _ => {
            return Err(RenderError::Setting(
                "ambient occlusion applies to the DVR and iso modes only".into(),
            ))
        }
    }
    match ao.method {
        AoMethod::Rays { n } if !(1..=effects::ao::MAX_AO_RAYS).contains(&n) => {
            return Err(RenderError::Setting(format!(
                "AO directions {n} must be 1 to {}",
                effects::ao::MAX_AO_RAYS
            )))
        }
        AoMethod::Field { k, .. } if !(1..=effects::ao::MAX_AO_FIELD_DIRECTIONS).contains(&k) => {
            return Err(RenderError::Setting(format!(
                "AO field directions {k} must be 1 to {}",
                effects::ao::MAX_AO_FIELD_DIRECTIONS
            )))
        }
        AoMethod::Field { cell, .. } if !(1..=effects::ao::MAX_AO_FIELD_CELL).contains(&cell) => {
            return Err(RenderError::Setting(format!(
                "AO field cell {cell} must be 1 to {} voxels",
                effects::ao::MAX_AO_FIELD_CELL
            )))
        }
        _ => {}
    }
    if let Some(r) = ao.radius {
        if !(r.is_finite() && r >= 0.0) {
            return Err(RenderError::Setting(format!(
                "AO radius {r} must be a finite number, 0 or more"
            )));
        }
    }
    Ok(())
}

/// The volume's recorded value range in f32 (0..0 when it has none).
fn value_range(vol: &Volume) -> (f32, f32) {
    if vol.meta.range.is_empty() {
        (0.0, 0.0)
    } else {
        (vol.meta.range.min as f32, vol.meta.range.max as f32)
    }
}

/// How a frame of `vol` in `mode` shows its film ([`Film::resolve`]):
/// colour for DVR and iso-surfaces, grey over the volume's value range for
/// MIP and MinIP, grey up to the largest value for X-ray.
pub fn display_for(vol: &Volume, mode: Mode) -> Display {
    match mode {
        Mode::Dvr | Mode::Iso(_) => Display::Colour,
        Mode::Mip | Mode::Minip => {
            let (lo, hi) = value_range(vol);
            Display::Grey { lo, hi }
        }
        Mode::XraySum | Mode::XrayMean => Display::GreyToLargest,
    }
}

/// One over the voxel spacing, per axis.
fn inv_spacing(vol: &Volume) -> Vec3 {
    let s = vol.meta.spacing;
    Vec3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2])
}

/// Render one frame of `vol` with a 1D transfer function (see
/// [`render_tf`]).
pub fn render(
    vol: &Volume,
    index: Option<&MajorantIndex>,
    tf: Option<&TransferFunction>,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<Frame, RenderError> {
    let tf = tf.map(|t| Tf::OneD(t.clone()));
    render_tf(vol, index, tf.as_ref(), camera, settings)
}

/// Render one frame of `vol`. `tf` is needed for DVR (presets are in
/// [`Tf::preset`]); `index` enables empty-space skipping when
/// `settings.ess` is on (it must belong to `vol`).
pub fn render_tf(
    vol: &Volume,
    index: Option<&MajorantIndex>,
    tf: Option<&Tf>,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<Frame, RenderError> {
    let (film, display) = render_film(vol, index, tf, camera, settings, None)?;
    let bg = Vec3::from(settings.background.map(srgb_to_linear));
    Ok(film.resolve(display, bg))
}

/// [`render_tf`] up to the film, before it is resolved to an image: with
/// `share`, only the samples of each ray inside the share's box are taken
/// (a rank's part of a data-parallel frame, see [`crate::distributed`]).
pub fn render_film(
    vol: &Volume,
    index: Option<&MajorantIndex>,
    tf: Option<&Tf>,
    camera: &Camera,
    settings: &RenderSettings,
    share: Option<&ShareBox>,
) -> Result<(Film, Display), RenderError> {
    let start = Instant::now();
    check(settings, vol, camera)?;
    if let Some(ix) = index {
        if ix.dims() != vol.dims() {
            return Err(RenderError::Index(format!(
                "index is for {} but the volume is {}",
                ix.dims(),
                vol.dims()
            )));
        }
    }
    let range = value_range(vol);
    let geom = FrameGeometry {
        step: settings.step,
        inv_spacing: inv_spacing(vol),
        locator: volcore::grid::Locator::new(vol.dims()),
    };
    let skip_index = if settings.ess { index } else { None };
    let tiles = Tiles {
        vol,
        camera,
        // A tile larger than the image is the image: never more buffer
        // than pixels (tiling does not change the image).
        tile: settings.tile.min(camera.width().max(camera.height())),
        hi: Vec3::from(vol.meta.world_extent()),
        busy: None,
        share,
        share_pixels: share.and_then(|b| b.pixels(camera, Vec3::from(vol.meta.world_extent()))),
        step: settings.step,
        cancel: &settings.cancel,
    };
    let mut film = match settings.mode {
        Mode::Dvr => {
            let tf =
                tf.ok_or_else(|| RenderError::Setting("DVR needs a transfer function".into()))?;
            dvr_frame(vol, skip_index, tf, geom, range, settings, tiles)?
        }
        Mode::Mip | Mode::Minip => {
            let maximum = settings.mode == Mode::Mip;
            let plan = MipPlan {
                geom,
                interp: settings.interp,
                maximum,
                stop_at_extreme: settings.ert.is_some(),
                extreme: if maximum { range.1 } else { range.0 },
                skip: skip_index,
            };
            dispatch::mip(plan, tiles)
        }
        Mode::XraySum | Mode::XrayMean => {
            let zero = skip_index.map(FixedCells::zero);
            let plan = XrayPlan {
                geom,
                interp: settings.interp,
                output: if settings.mode == Mode::XrayMean {
                    XrayOutput::Mean
                } else {
                    XrayOutput::Sum
                },
                skip: zero.as_ref(),
            };
            dispatch::xray(plan, tiles)
        }
        Mode::Iso(level) => {
            let sides = skip_index.map(|ix| IsoSides::new(ix, level));
            let boxes = sides.as_ref().map(|c| c.clear_boxes_below());
            let sgeom = effects::setup::shadow_geometry(&geom, settings.shadows.as_ref());
            let mut ao_stats = EffectStats::default();
            let ao_parts = match &settings.ao {
                Some(ao) => Some(effects::setup::iso_ao(
                    vol,
                    settings,
                    ao,
                    &sgeom,
                    level,
                    boxes.as_ref(),
                    &mut ao_stats,
                )?),
                None => None,
            };
            let min_spacing = vol.meta.min_spacing();
            let ao_source = ao_parts
                .as_ref()
                .map(|p| p.source(tiles.hi, 1.5, min_spacing));
            let shadow_parts = match &settings.shadows {
                Some(sh) => {
                    let (grids, stats) = effects::setup::iso_grids(
                        vol,
                        settings,
                        sh,
                        &sgeom,
                        level,
                        boxes.as_ref(),
                    )?;
                    let offset = match sh.method {
                        ShadowMethod::Grid { divisor } => 1.5 * divisor as f32,
                        ShadowMethod::Ray => 0.0,
                    };
                    Some((sgeom, grids, stats, offset))
                }
                None => None,
            };
            let plan = IsoPlan {
                geom,
                interp: settings.interp,
                gradient: settings.gradient,
                level,
                colour: Vec3::from(settings.iso_colour.map(srgb_to_linear)),
                lighting: &settings.lighting,
                skip: sides.as_ref(),
                shadows: shadow_parts
                    .as_ref()
                    .map(|(sgeom, grids, _, offset)| IsoShadows {
                        geom: *sgeom,
                        hi: tiles.hi,
                        grids,
                        grid_offset: *offset,
                    }),
                ao: ao_source.as_ref(),
            };
            let mut film = dispatch::iso(plan, tiles);
            if let Some((_, _, stats, _)) = &shadow_parts {
                film.add_grid_stats(stats);
            }
            film.add_grid_stats(&ao_stats);
            film
        }
    };
    if settings.cancel.is_cancelled() {
        return Err(RenderError::Cancelled);
    }
    // The frame's time is its wall time, set-up included (classifier
    // tables, skipping flags, culling, light and occlusion grids), but for
    // the AO field, built once per transfer function and reported beside.
    let wall = start.elapsed().as_secs_f64();
    film.set_render_seconds((wall - film.stats().effects.ao_field_s).max(0.0));
    Ok((film, display_for(vol, settings.mode)))
}

/// A DVR frame: the classifier's table for the frame's step, its
/// transparent cells when skipping, and the integrator for the choices.
fn dvr_frame(
    vol: &Volume,
    skip_index: Option<&MajorantIndex>,
    tf: &Tf,
    geom: FrameGeometry,
    range: (f32, f32),
    settings: &RenderSettings,
    tiles: Tiles<'_>,
) -> Result<Film, RenderError> {
    // Effects apply to shaded samples only (checked before); their depth
    // table is made for the shadow step.
    let effects_on = settings.shading && (settings.shadows.is_some() || settings.ao.is_some());
    let shadow_step =
        effects_on.then(|| effects::setup::shadow_geometry(&geom, settings.shadows.as_ref()).step);
    let frame = DvrFrame {
        vol,
        skip_index,
        geom,
        range,
        settings,
        tiles,
    };
    with_tables(vol, tf, range, settings.step, shadow_step, frame)
}

/// Work that needs a DVR frame's classifier table, of whichever kind the
/// transfer function makes ([`with_tables`]).
trait TableUser {
    /// What the work gives.
    type Output;
    /// Do the work with `table` (as `as_ref` names its kind) and, when a
    /// shadow step was asked for, the same classifier at that step.
    fn run<K: Classifier>(
        self,
        table: &K,
        shadow: Option<&K>,
        as_ref: for<'x> fn(&'x K) -> ClassifierRef<'x>,
    ) -> Self::Output;
}

/// Build the classifier table of `tf` for `step` (and `shadow_step`) over
/// the transfer function's domain, or the volume's `range`, and hand it to
/// `user`.
fn with_tables<U: TableUser>(
    vol: &Volume,
    tf: &Tf,
    range: (f32, f32),
    step: f32,
    shadow_step: Option<f32>,
    user: U,
) -> U::Output {
    let (lo, hi) = tf.domain().unwrap_or(range);
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let bins = TfTable::default_bins(lo, hi);
    match tf {
        Tf::OneD(t) => {
            let table = |step| TfTable::new(t, lo, hi, bins, step);
            let shadow = shadow_step.map(table);
            user.run(&table(step), shadow.as_ref(), |t| ClassifierRef::OneD(t))
        }
        Tf::TwoD(t) => {
            let glimit = (hi - lo) / vol.meta.min_spacing();
            let (glo, ghi) = t.gradient_domain.unwrap_or((0.0, glimit));
            let ghi = if ghi > glo { ghi } else { glo + 1.0 };
            let table = |step| {
                TfTable2d::new(
                    t,
                    (lo, hi),
                    bins,
                    (glo, ghi),
                    crate::classify::table2d::GRADIENT_BINS,
                    step,
                )
            };
            let shadow = shadow_step.map(table);
            user.run(&table(step), shadow.as_ref(), |t| ClassifierRef::TwoD(t))
        }
    }
}

/// The finest-level cells of `index` that a DVR frame with `settings`
/// may take a visible sample in: those its transfer function does not
/// make transparent ([`with_tables`]).
struct DvrBusyCells<'a> {
    index: &'a MajorantIndex,
    gradients: GradientBound,
}

impl TableUser for DvrBusyCells<'_> {
    type Output = Result<Vec<bool>, RenderError>;
    fn run<K: Classifier>(
        self,
        table: &K,
        _shadow: Option<&K>,
        _as_ref: for<'x> fn(&'x K) -> ClassifierRef<'x>,
    ) -> Self::Output {
        let mut levels = table.transparent_cells(self.index, &self.gradients)?;
        let finest = if levels.is_empty() {
            Vec::new()
        } else {
            levels.swap_remove(0)
        };
        Ok(finest.into_iter().map(|clear| !clear).collect())
    }
}

/// Per finest-level cell of `index` (x fastest): whether a frame of `vol`
/// with `settings` (and `tf` for DVR) can take a sample there that shows:
/// under DVR the cells the transfer function does not make transparent,
/// for iso-surfaces the cells reaching the iso value, for X-ray the cells
/// holding a non-zero value, for MIP and MinIP every cell. A data-parallel
/// split balances ranks by these counts ([`crate::distributed`]).
pub fn busy_cells(
    vol: &Volume,
    index: &MajorantIndex,
    tf: Option<&Tf>,
    settings: &RenderSettings,
) -> Result<Vec<bool>, RenderError> {
    let level = index.level(0);
    let by_range = |f: &dyn Fn(f32, f32) -> bool| -> Vec<bool> {
        level
            .min()
            .iter()
            .zip(level.max())
            .map(|(&lo, &hi)| f(lo, hi))
            .collect()
    };
    Ok(match settings.mode {
        Mode::Dvr => {
            let tf =
                tf.ok_or_else(|| RenderError::Setting("DVR needs a transfer function".into()))?;
            let gradients = GradientBound {
                method: settings.gradient,
                inv_spacing: inv_spacing(vol),
            };
            let user = DvrBusyCells { index, gradients };
            with_tables(vol, tf, value_range(vol), settings.step, None, user)?
        }
        // NaN counts as below the level (as the iso rule has it).
        Mode::Iso(l) => by_range(&|_, hi| hi >= l),
        Mode::XraySum | Mode::XrayMean => by_range(&|lo, hi| !(lo == 0.0 && hi == 0.0)),
        Mode::Mip | Mode::Minip => vec![true; level.len()],
    })
}

/// What a DVR frame has before its classifier is built.
struct DvrFrame<'a> {
    vol: &'a Volume,
    skip_index: Option<&'a MajorantIndex>,
    geom: FrameGeometry,
    range: (f32, f32),
    settings: &'a RenderSettings,
    tiles: Tiles<'a>,
}

/// Render with classifier `table` (as `as_ref` names its kind); with
/// effects, `shadow` is the same classifier at the shadow step.
impl TableUser for DvrFrame<'_> {
    type Output = Result<Film, RenderError>;
    fn run<K: Classifier>(
        self,
        table: &K,
        shadow: Option<&K>,
        as_ref: for<'x> fn(&'x K) -> ClassifierRef<'x>,
    ) -> Result<Film, RenderError> {
        let DvrFrame {
            vol,
            skip_index,
            geom,
            range,
            settings,
            tiles,
        } = self;
        let value_span = (range.1 - range.0).max(f32::MIN_POSITIVE);
        // Compared with squared lengths; never below 0, so a zero gradient
        // is never normalised.
        let threshold2 = (settings.gradient_threshold * value_span).max(0.0).powi(2);
        let shading = settings
            .shading
            .then(|| PhongShading::new(&settings.lighting, threshold2));
        let gradients = GradientBound {
            method: settings.gradient,
            inv_spacing: geom.inv_spacing,
        };
        let skip = transparent_cells(skip_index, table, &gradients)?;
        // Pixel blocks whose rays meet no cell the rule keeps are not
        // traced (their pixels are empty either way).
        let busy = skip.as_ref().and_then(|s| {
            cull::busy_blocks(
                tiles.camera,
                s.index(),
                Vec3::from(vol.meta.spacing),
                tiles.share.map(|b| b.clipped(tiles.hi)),
                |level, cell| !s.skippable(level, cell),
            )
        });
        let tiles = Tiles {
            busy: busy.as_ref(),
            ..tiles
        };
        // Effects: the depth table, its clear cells, the light grids, the
        // occlusion grid and field.
        let effect_parts = match shadow {
            Some(alpha) => {
                let sgeom = effects::setup::shadow_geometry(&geom, settings.shadows.as_ref());
                let depth = alpha.to_optical_depth();
                let clear = transparent_cells(skip_index, alpha, &gradients)?;
                let boxes = clear.as_ref().map(|c| c.clear_boxes());
                let (grids, mut stats) = match &settings.shadows {
                    Some(sh) => effects::setup::dvr_grids(
                        vol,
                        settings,
                        sh,
                        &sgeom,
                        &depth,
                        boxes.as_ref(),
                    )?,
                    None => (Vec::new(), EffectStats::default()),
                };
                let ao = match &settings.ao {
                    Some(ao) => Some(effects::setup::dvr_ao(
                        vol,
                        settings,
                        ao,
                        &sgeom,
                        &depth,
                        boxes.as_ref(),
                        &mut stats,
                    )?),
                    None => None,
                };
                // Shadow rays toward a distant light stop where the rest
                // of their way is clear.
                let skies = match &settings.shadows {
                    Some(_) => effects::setup::open_skies(
                        &settings.lighting.lights,
                        &grids,
                        clear.as_ref(),
                        &sgeom,
                    ),
                    None => Vec::new(),
                };
                Some((sgeom, depth, clear, grids, stats, ao, skies))
            }
            None => None,
        };
        let min_spacing = vol.meta.min_spacing();
        let ao_source = effect_parts
            .as_ref()
            .and_then(|p| p.5.as_ref())
            .map(|ao| ao.source(tiles.hi, 1.0, min_spacing));
        let effects = effect_parts
            .as_ref()
            .map(|(sgeom, depth, clear, grids, _, _, skies)| DvrEffects {
                shadows: settings.shadows.is_some(),
                ao: ao_source.as_ref(),
                depth: as_ref(depth),
                skip: clear.as_ref(),
                geom: *sgeom,
                hi: tiles.hi,
                grids,
                skies,
                lighting: &settings.lighting,
                threshold2,
            });
        let plan = DvrPlan {
            geom,
            interp: settings.interp,
            gradient: settings.gradient,
            classifier: as_ref(table),
            shading,
            termination: settings.ert,
            skip: skip.as_ref(),
            effects,
        };
        let mut film = dispatch::dvr(plan, tiles);
        film.set_culled_blocks(busy.as_ref().map_or(0, |b| b.culled()) as u64);
        if let Some((.., stats, _, _)) = &effect_parts {
            film.add_grid_stats(stats);
        }
        Ok(film)
    }
}

/// The skipping rule for a classifier, when skipping is on.
fn transparent_cells<'a>(
    index: Option<&'a MajorantIndex>,
    classifier: &impl Classifier,
    gradients: &GradientBound,
) -> Result<Option<FixedCells<'a>>, RenderError> {
    index
        .map(|ix| {
            classifier
                .transparent_cells(ix, gradients)
                .map(|flags| FixedCells::transparent(ix, flags))
        })
        .transpose()
}

/// The frame's pixels, traced tile by tile on all threads.
#[derive(Clone, Copy)]
struct Tiles<'a> {
    vol: &'a Volume,
    camera: &'a Camera,
    tile: u32,
    /// The far corner of the volume's box.
    hi: Vec3,
    /// Which pixels' rays may take samples; the others are left empty,
    /// untraced.
    busy: Option<&'a cull::BlockMask>,
    /// Take only the samples inside this box.
    share: Option<&'a ShareBox>,
    /// The only pixels whose rays can meet the share's box (columns,
    /// rows); the others are left empty, untraced.
    share_pixels: Option<crate::distributed::share::PixelRect>,
    /// The frame's step (to find a share's samples).
    step: f32,
    /// Checked before each tile: once raised, the remaining tiles are
    /// left untraced (and the frame is refused as cancelled).
    cancel: &'a crate::settings::Cancel,
}

impl IntegratorVisitor for Tiles<'_> {
    type Output = Film;
    fn visit<I: Integrator>(self, integrator: I) -> Film {
        self.vol.visit(Trace {
            tiles: self,
            integrator: &integrator,
        })
    }
}

struct Trace<'a, I> {
    tiles: Tiles<'a>,
    integrator: &'a I,
}

impl<I: Integrator> VolumeVisitor for Trace<'_, I> {
    type Output = Film;
    fn visit<S: VoxelSource>(self, src: &S) -> Film {
        let Tiles {
            camera,
            tile,
            hi,
            busy,
            share,
            share_pixels,
            step,
            cancel,
            ..
        } = self.tiles;
        let (w, h) = (camera.width(), camera.height());
        let (tx, ty) = (w.div_ceil(tile), h.div_ceil(tile));
        // Per tile, the rays traced (pixel and result); the other pixels'
        // rays met nothing, and the film starts that way.
        let results: Vec<Vec<([u32; 2], RayResult)>> = (0..tx * ty)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::new();
                if cancel.is_cancelled() {
                    return out;
                }
                let (x0, y0) = ((i % tx) * tile, (i / tx) * tile);
                let mut cur = src.cursor();
                let (x1, y1) = ((x0 + tile).min(w), (y0 + tile).min(h));
                for y in y0..y1 {
                    for x in x0..x1 {
                        if busy.is_some_and(|b| !b.may_see(x, y))
                            || share_pixels.is_some_and(|r| !r.contains(x, y))
                        {
                            continue;
                        }
                        let ray = camera.ray(x, y);
                        let Some((t0, t1)) = intersect_box(&ray, Vec3::ZERO, hi) else {
                            continue;
                        };
                        let span = Span::whole(t0, t1);
                        let r = match share.map(|b| b.samples(&ray, span, step)) {
                            None => self.integrator.trace(&mut cur, &ray, [x, y], span),
                            Some(None) => continue,
                            Some(Some(k)) => self.integrator.trace(
                                &mut cur,
                                &ray,
                                [x, y],
                                Span {
                                    share: Some(k),
                                    ..span
                                },
                            ),
                        };
                        out.push(([x, y], r));
                    }
                }
                out
            })
            .collect();
        let mut film = Film::one_empty_ray_each(w, h);
        for ([x, y], r) in results.iter().flatten() {
            film.put_ray(*x, *y, r);
        }
        film
    }
}
