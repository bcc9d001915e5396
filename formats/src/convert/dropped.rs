//! What an output format cannot hold of the geometry: TIFF and the
//! thesis `.vol` have no origin or direction, raw files no geometry at
//! all. Dropping them is said in one note, when the input's are not the
//! defaults (origin 0, identity direction, spacing 1 for raw).

use super::Target;
use volcore::Geometry;

/// The note for writing `spacing` and `geometry` to `target`, if it
/// drops any of them.
pub fn note(spacing: [f32; 3], geometry: &Geometry, target: &Target) -> Option<String> {
    let (format, holds_spacing) = match target {
        Target::Raw { .. } => ("raw", false),
        Target::Tiff { .. } | Target::TiffDir { .. } => ("TIFF", true),
        Target::Thesis { .. } => ("the thesis .vol", true),
        _ => return None,
    };
    let mut lost = Vec::new();
    if !holds_spacing && spacing != [1.0; 3] {
        lost.push(format!("spacing {}", triple(spacing.map(f64::from))));
    }
    if geometry.origin != [0.0; 3] {
        lost.push(format!("origin {}", triple(geometry.origin)));
    }
    if geometry.direction != Geometry::IDENTITY.direction {
        lost.push(format!("direction ({})", geometry.orientation()));
    }
    if lost.is_empty() {
        return None;
    }
    Some(format!(
        "{format} holds no {}: dropped {} (.vvol, NIfTI, NRRD, MetaImage and OME-Zarr keep them)",
        if holds_spacing {
            "origin or direction"
        } else {
            "geometry"
        },
        lost.join(", ")
    ))
}

/// `x,y,z`.
fn triple(v: [f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}
