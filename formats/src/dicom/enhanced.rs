//! Enhanced multi-frame images (Enhanced CT, MR and PET Image Storage and
//! the Legacy Converted Enhanced classes): one file, one frame per slice.
//! Each frame's position, orientation, spacing, rescale and volume keys
//! are in its item of the Per-frame Functional Groups Sequence
//! (5200,9230), else in the Shared Functional Groups Sequence (5200,9229),
//! else in the data set ([`Attrs::frame`]). From there a frame is one
//! slice like any other: sorted by position, split into volumes by its
//! keys and into sub-series by its shape.
//!
//! A multi-frame image without per-frame functional groups (an old
//! NM or ultrasound cine, an RT dose grid) states no position per frame
//! and is refused.

use super::header::{slice_of, Attrs, Image, PixelSource, SliceHeader};
use super::skip::SkipReason;
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;
use std::path::Path;

/// The slices of the multi-frame image `obj` (from `path`) that states
/// `frames` frames, or why it cannot be read as slices.
pub(super) fn frames(
    path: &Path,
    obj: &InMemDicomObject,
    frames: i64,
    image: &Image,
) -> Result<Vec<SliceHeader>, SkipReason> {
    let items = |tag| obj.get(tag).and_then(|e| e.items()).unwrap_or(&[]);
    let per_frame = items(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE);
    let count = u32::try_from(frames.max(1)).unwrap_or(u32::MAX);
    if per_frame.is_empty() {
        return Err(SkipReason::MultiFrame(count));
    }
    // The per-frame items were read from the file, so they bound every
    // loop here; NumberOfFrames must agree with them, and the pixel data
    // must be able to hold that many frames.
    if per_frame.len() as u64 != u64::from(count) {
        return Err(SkipReason::Damaged(format!(
            "NumberOfFrames is {frames} but the Per-frame Functional Groups Sequence holds {} items",
            per_frame.len()
        )));
    }
    check_frames_fit(path, obj, count, image)?;
    let shared = items(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE).first();
    per_frame
        .iter()
        .enumerate()
        .map(|(k, item)| {
            let pixels = PixelSource {
                frame: k as u32,
                tile: None,
            };
            slice_of(image, &Attrs::frame(obj, item, shared), pixels).map_err(|e| match e {
                SkipReason::Missing(what) => SkipReason::Unsupported(format!(
                    "frame {k} of an enhanced multi-frame image has no {what} in its functional groups"
                )),
                other => other,
            })
        })
        .collect()
}

/// Refuse `count` frames that the file's length cannot hold: native
/// pixel data needs Rows x Columns x BitsAllocated/8 bytes a frame,
/// encapsulated pixel data at least an 8-byte item header a frame.
fn check_frames_fit(
    path: &Path,
    obj: &InMemDicomObject,
    count: u32,
    image: &Image,
) -> Result<(), SkipReason> {
    let encapsulated = obj
        .get(tags::PIXEL_DATA)
        .is_some_and(|e| e.value().fragments().is_some());
    let per_frame = if encapsulated {
        8
    } else {
        u64::from(image.rows) * u64::from(image.cols) * u64::from(image.bits_allocated / 8)
    };
    let need = per_frame.saturating_mul(u64::from(count));
    let have = std::fs::metadata(path)
        .map_err(|e| SkipReason::Unreadable(e.to_string()))?
        .len();
    if need > have {
        return Err(SkipReason::Damaged(format!(
            "{count} frames need at least {need} bytes of pixel data; the file holds {have}"
        )));
    }
    Ok(())
}
