//! A MIP or MinIP frame's set-up: the [`Mip`] integrator of the extreme
//! it keeps, traced over the tiles.

use crate::error::RenderError;
use crate::film::Film;
use crate::integrator::{Maximum, Minimum, Mip};
use crate::tiles::Tiles;
use crate::trace::FrameGeometry;
use volcore::Volume;
use volindex::MinMaxIndex;

/// Render a MIP (`maximum`) or MinIP frame of `vol`, skipping over
/// `index` when given; rays stop at the volume's `extreme` when
/// `stop_at_extreme`.
pub fn render_frame(
    vol: &Volume,
    index: Option<&MinMaxIndex>,
    tiles: &Tiles<'_>,
    geom: FrameGeometry,
    maximum: bool,
    stop_at_extreme: bool,
    extreme: f32,
) -> Result<Film, RenderError> {
    let (g, ix, s, e) = (geom, index, stop_at_extreme, extreme);
    if maximum {
        tiles.render(vol, &Mip::<Maximum>::new(g, ix, s, e))
    } else {
        tiles.render(vol, &Mip::<Minimum>::new(g, ix, s, e))
    }
}
