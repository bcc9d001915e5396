//! An X-ray frame's set-up: the [`Xray`] integrator traced over the
//! tiles.

use super::FrameInputs;
use crate::accel::FixedCells;
use crate::error::RenderError;
use crate::film::Film;
use crate::integrator::xray::{Xray, XrayOutput};
use crate::settings::Mode;

/// Render an X-ray frame: the mean along each ray in mode
/// [`Mode::XrayMean`], else the sum; with skipping on, the index's cells
/// holding only zeros are skipped.
pub fn render_frame(inputs: &FrameInputs<'_>) -> Result<Film, RenderError> {
    let skip = inputs.skip_index.map(FixedCells::zero);
    let output = if inputs.settings.mode == Mode::XrayMean {
        XrayOutput::Mean
    } else {
        XrayOutput::Sum
    };
    let xray = Xray::new(inputs.geom, skip.as_ref(), output);
    inputs.tiles.render(inputs.vol, &xray)
}
