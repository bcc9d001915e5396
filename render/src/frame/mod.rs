//! A whole frame, set up once before any ray is traced (after pbrt-v4's
//! split of per-frame set-up from per-ray integration): the settings
//! checked ([`check`]), the effects' grids and fields built ([`effects`]),
//! the mode's one concrete integrator chosen ([`dvr`], [`iso`], [`mip`],
//! [`xray`]), its tiles traced in parallel into a film
//! ([`crate::tiles`]), the film resolved into a frame.
//!
//! The four modes' set-ups have one shape: each is a
//! `render_frame(&FrameInputs) -> Result<Film, RenderError>` taking what
//! every frame has ([`FrameInputs`]) and reading its own choices (the
//! extreme MIP keeps, X-ray's output, the iso level, DVR's transfer
//! function) from the settings there.

use crate::camera::Camera;
use crate::classify::{srgb_to_linear, GradientBound};
use crate::distributed::ShareBox;
use crate::error::RenderError;
use crate::film::{Display, Film, Frame};
use crate::settings::{Mode, RenderSettings};
use crate::tf::{Tf, TransferFunction};
use crate::tiles::Tiles;
use crate::trace::FrameGeometry;
use dvr::Tables;
use glam::Vec3;
use std::time::Instant;
use volcore::Volume;
use volindex::MinMaxIndex;

pub mod check;
pub mod dvr;
pub mod effects;
pub mod iso;
pub mod mip;
pub mod xray;

/// The most samples one ray may take. Settings that imply more (a step
/// tiny against the volume's size, or a voxel spacing so small or so
/// large on one axis that the default step is) are refused before any ray
/// is traced, so no input can make a ray's loop run without end.
pub const MAX_SAMPLES_PER_RAY: f64 = 1e7;

/// Memory a frame may use for its per-pixel buffers (film, ray results,
/// the resolved frame and its output encodings), in either pipeline
/// ([`check::memory`]).
pub const FRAME_MEMORY_BUDGET: u64 = 8 << 30;

/// Bytes a ray-cast frame needs per pixel, all buffers together (an upper
/// bound).
pub const FRAME_BYTES_PER_PIXEL: u64 = 160;

/// What every ray-casting mode's frame set-up starts from, after the
/// settings are checked: one shape for all four modes, each mode's
/// `render_frame` taking it.
#[derive(Clone, Copy)]
pub struct FrameInputs<'a> {
    /// The volume.
    pub vol: &'a Volume,
    /// The index to skip with, when skipping is on.
    pub skip_index: Option<&'a MinMaxIndex>,
    /// The volume's index, whether or not skipping is on (adaptive steps
    /// read its cells' ranges).
    pub index: Option<&'a MinMaxIndex>,
    /// The transfer function (DVR needs one).
    pub tf: Option<&'a Tf>,
    /// The frame's settings, checked; the mode among them.
    pub settings: &'a RenderSettings,
    /// Sample placement.
    pub geom: FrameGeometry,
    /// The volume's recorded value range (0..0 when it has none).
    pub range: (f32, f32),
    /// The frame's pixels.
    pub tiles: Tiles<'a>,
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
    index: Option<&MinMaxIndex>,
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
    index: Option<&MinMaxIndex>,
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
    index: Option<&MinMaxIndex>,
    tf: Option<&Tf>,
    camera: &Camera,
    settings: &RenderSettings,
    share: Option<&ShareBox>,
) -> Result<(Film, Display), RenderError> {
    let start = Instant::now();
    check::frame(settings, vol, camera)?;
    if share.is_some() && settings.adaptive.is_some() {
        return Err(RenderError::Setting(
            "adaptive steps are not split across ranks yet: a share of a ray would have to \
             start where the whole ray's strides put a sample"
                .into(),
        ));
    }
    if let Some(ix) = index {
        if ix.dims() != vol.dims() {
            return Err(RenderError::Index(format!(
                "index is for {} but the volume is {}",
                ix.dims(),
                vol.dims()
            )));
        }
    }
    let geom = FrameGeometry {
        step: settings.step,
        inv_spacing: inv_spacing(vol),
        locator: volcore::grid::Locator::new(vol.dims()),
        interp: settings.interp,
    };
    let skip_index = if settings.ess { index } else { None };
    let hi = Vec3::from(vol.meta.world_extent());
    let tiles = Tiles {
        camera,
        // A tile larger than the image is the image: never more buffer
        // than pixels (tiling does not change the image).
        tile: settings.tile.min(camera.width().max(camera.height())),
        hi,
        busy: None,
        share,
        share_pixels: share.and_then(|b| b.pixels(camera, hi)),
        step: settings.step,
        cancel: &settings.cancel,
    };
    let inputs = FrameInputs {
        vol,
        skip_index,
        index,
        tf,
        settings,
        geom,
        range: value_range(vol),
        tiles,
    };
    let mut film = match settings.mode {
        Mode::Dvr => dvr::render_frame(&inputs),
        Mode::Iso(_) => iso::render_frame(&inputs),
        Mode::Mip | Mode::Minip => mip::render_frame(&inputs),
        Mode::XraySum | Mode::XrayMean => xray::render_frame(&inputs),
    }?;
    // The frame's time is its wall time, set-up included (classifier
    // tables, skipping flags, culling, light and occlusion grids), but for
    // the AO field, built once per transfer function and reported beside.
    let wall = start.elapsed().as_secs_f64();
    film.set_render_seconds((wall - film.stats().effects.ao_field_s).max(0.0));
    Ok((film, display_for(vol, settings.mode)))
}

/// Per finest-level cell of `index` (x fastest): whether a frame of `vol`
/// with `settings` (and `tf` for DVR) can take a sample there that shows:
/// under DVR the cells the transfer function does not make transparent,
/// for iso-surfaces the cells reaching the iso value, for X-ray the cells
/// holding a non-zero value, for MIP and MinIP every cell. A data-parallel
/// split balances ranks by these counts ([`crate::distributed`]).
pub fn busy_cells(
    vol: &Volume,
    index: &MinMaxIndex,
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
            let tables = Tables::new(
                vol,
                tf,
                value_range(vol),
                settings.step,
                None,
                settings.preintegrated,
            )?;
            tables.busy_cells(index, &gradients)?
        }
        // NaN counts as below the level (as the iso rule has it).
        Mode::Iso(l) => by_range(&|_, hi| hi >= l),
        Mode::XraySum | Mode::XrayMean => by_range(&|lo, hi| !(lo == 0.0 && hi == 0.0)),
        Mode::Mip | Mode::Minip => vec![true; level.len()],
    })
}
