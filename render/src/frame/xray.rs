//! An X-ray frame's set-up: the [`Xray`] integrator traced over the
//! tiles.

use crate::accel::FixedCells;
use crate::error::RenderError;
use crate::film::Film;
use crate::integrator::xray::{Xray, XrayOutput};
use crate::tiles::Tiles;
use crate::trace::FrameGeometry;
use volcore::Volume;

/// Render an X-ray frame of `vol`, skipping the zero cells of `skip` when
/// given.
pub fn render_frame(
    vol: &Volume,
    skip: Option<&FixedCells<'_>>,
    tiles: &Tiles<'_>,
    geom: FrameGeometry,
    output: XrayOutput,
) -> Result<Film, RenderError> {
    tiles.render(vol, &Xray::new(geom, skip, output))
}
