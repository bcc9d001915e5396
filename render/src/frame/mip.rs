//! A MIP or MinIP frame's set-up: the [`Mip`] integrator of the extreme
//! it keeps, traced over the tiles.

use super::FrameInputs;
use crate::error::RenderError;
use crate::film::Film;
use crate::integrator::{Maximum, Minimum, Mip};
use crate::settings::Mode;

/// Render a MIP frame (mode [`Mode::Mip`]) or a MinIP frame (any other
/// mode: [`Mode::Minip`]), skipping over the index when given; with early
/// termination on, rays stop at the volume's largest (MIP) or smallest
/// (MinIP) value.
pub fn render_frame(inputs: &FrameInputs<'_>) -> Result<Film, RenderError> {
    let maximum = inputs.settings.mode == Mode::Mip;
    let extreme = if maximum {
        inputs.range.1
    } else {
        inputs.range.0
    };
    let stop_at_extreme = inputs.settings.ert.is_some();
    let (g, ix, s, e) = (inputs.geom, inputs.skip_index, stop_at_extreme, extreme);
    let (tiles, vol) = (&inputs.tiles, inputs.vol);
    if maximum {
        tiles.render(vol, &Mip::<Maximum>::new(g, ix, s, e))
    } else {
        tiles.render(vol, &Mip::<Minimum>::new(g, ix, s, e))
    }
}
