//! Siemens mosaics: one image (ImageType `MOSAIC`) whose frame is a grid
//! of the slices of a volume. Unpacked into one slice per tile, as
//! dcm2niix and nibabel.nicom do:
//!
//! - the tile count is NumberOfImagesInMosaic from the CSA image header
//!   (0029,1010), or the Siemens MR header's (0019,100A); the grid is the
//!   smallest square that holds them, and each tile is Rows / grid by
//!   Columns / grid;
//! - ImagePositionPatient is the corner of the whole frame: the first
//!   tile's corner lies half the frame less one tile further along the
//!   rows and columns;
//! - the tiles stack along the CSA header's SliceNormalVector, one
//!   SpacingBetweenSlices (else SliceThickness) apart.
//!
//! A mosaic without what this needs (no CSA header, no tile count, a grid
//! that does not divide the frame, a normal off the image plane's) is
//! refused, never read as one 2D image.

use super::csa::CsaHeader;
use super::header::{Attrs, SliceHeader, Tile};
use super::skip::SkipReason;
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;

/// Whether ImageType (its values joined by `\`) marks a mosaic.
pub(super) fn is_mosaic(image_type: &str) -> bool {
    image_type
        .split('\\')
        .any(|v| v.trim().eq_ignore_ascii_case("MOSAIC"))
}

/// The refusal of a mosaic that cannot be unpacked, saying why.
fn refuse(why: impl std::fmt::Display) -> SkipReason {
    SkipReason::Unsupported(format!(
        "a Siemens mosaic (ImageType MOSAIC) that cannot be unpacked: {why}"
    ))
}

/// The CSA image header of `obj`, when it has one that parses.
fn csa_image_header(obj: &InMemDicomObject) -> Result<CsaHeader, SkipReason> {
    let bytes = obj
        .get(dicom_core::Tag(0x0029, 0x1010))
        .and_then(|e| e.to_bytes().ok())
        .ok_or_else(|| refuse("it has no Siemens CSA image header (0029,1010)"))?;
    CsaHeader::parse(&bytes).map_err(|e| refuse(format!("its CSA header (0029,1010) {e}")))
}

/// The slices of mosaic `whole` (the header read as one image), one per
/// tile, or why it cannot be unpacked.
pub(super) fn unpack(
    obj: &InMemDicomObject,
    whole: SliceHeader,
) -> Result<Vec<SliceHeader>, SkipReason> {
    let csa = csa_image_header(obj)?;
    let a = Attrs::of(obj);
    let count = csa
        .number("NumberOfImagesInMosaic")
        .or_else(|| a.first_float(dicom_core::Tag(0x0019, 0x100A)))
        .ok_or_else(|| refuse("its CSA header has no NumberOfImagesInMosaic"))?;
    if !((1.0..=65535.0).contains(&count) && count.fract() == 0.0) {
        return Err(refuse(format!("NumberOfImagesInMosaic is {count}")));
    }
    let count = count as u32;
    let across = (1..=256u32)
        .find(|g| g * g >= count)
        .ok_or_else(|| refuse(format!("{count} tiles")))?;
    let (rows, cols) = (u32::from(whole.rows), u32::from(whole.cols));
    if !(rows.is_multiple_of(across) && cols.is_multiple_of(across)) {
        return Err(refuse(format!(
            "its {cols}x{rows} frame does not divide into a {across}x{across} grid of {count} tiles"
        )));
    }
    let (tile_rows, tile_cols) = (rows / across, cols / across);
    let o = whole.orientation;
    let (row_dir, col_dir) = ([o[0], o[1], o[2]], [o[3], o[4], o[5]]);
    let plane_normal = super::cross(row_dir, col_dir);
    let normal = csa
        .vector("SliceNormalVector")
        .ok_or_else(|| refuse("its CSA header has no SliceNormalVector"))?;
    let (nn, pn) = (
        super::dot(normal, normal).sqrt(),
        super::dot(plane_normal, plane_normal).sqrt(),
    );
    if !(nn > 1e-6 && pn > 1e-6) || (super::dot(normal, plane_normal) / (nn * pn)).abs() < 0.999 {
        return Err(refuse(format!(
            "its SliceNormalVector {normal:?} does not stand on the image plane"
        )));
    }
    let normal = normal.map(|v| v / nn);
    let spacing = a
        .first_float(tags::SPACING_BETWEEN_SLICES)
        .filter(|s| s.is_finite() && *s > 0.0)
        .or_else(|| a.first_float(tags::SLICE_THICKNESS))
        .filter(|s| s.is_finite() && *s > 0.0)
        .ok_or_else(|| refuse("it states neither SpacingBetweenSlices nor SliceThickness"))?;
    // From the frame's corner to the first tile's: half the frame less
    // one tile, along the rows (column spacing) and the columns (row
    // spacing).
    let [row_spacing, col_spacing] = whole.pixel_spacing;
    let shift_x = f64::from(cols - tile_cols) / 2.0 * col_spacing;
    let shift_y = f64::from(rows - tile_rows) / 2.0 * row_spacing;
    let corner: [f64; 3] =
        std::array::from_fn(|i| whole.position[i] + row_dir[i] * shift_x + col_dir[i] * shift_y);
    Ok((0..count)
        .map(|k| {
            let mut s = whole.clone();
            s.rows = tile_rows as u16;
            s.cols = tile_cols as u16;
            s.position = std::array::from_fn(|i| corner[i] + normal[i] * spacing * f64::from(k));
            s.pixels.tile = Some(Tile {
                index: k,
                across,
                frame_cols: cols,
            });
            s
        })
        .collect())
}
