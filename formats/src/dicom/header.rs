//! One file's header read up to its pixel data: the slices it holds
//! (one for a single-frame image), each with where its pixels lie
//! ([`PixelSource`]) and the keys that tell its volume apart from others
//! at the same position ([`VolumeKeys`]), or why it can join no series
//! ([`SkipReason`]).

use super::guard::check_lengths;
use super::skip::SkipReason;
use crate::rescale::Rescale;
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, InMemDicomObject, OpenFileOptions};
use std::path::{Path, PathBuf};

/// What one slice of a series says about itself: a single-frame file, a
/// tile of a mosaic or a frame of a multi-frame file (see [`PixelSource`]).
#[derive(Clone, Debug)]
pub(super) struct SliceHeader {
    pub(super) path: PathBuf,
    pub(super) series: String,
    pub(super) series_number: Option<i64>,
    pub(super) description: String,
    pub(super) modality: String,
    pub(super) rows: u16,
    pub(super) cols: u16,
    pub(super) position: [f64; 3],
    pub(super) orientation: [f64; 6],
    pub(super) pixel_spacing: [f64; 2],
    pub(super) rescale: Rescale,
    pub(super) bits_allocated: u16,
    pub(super) bits_stored: u16,
    pub(super) signed: bool,
    /// Where in the file the slice's pixels are.
    pub(super) pixels: PixelSource,
    /// What tells this slice's volume from others at the same position.
    pub(super) keys: VolumeKeys,
    /// StackID (0020,9056): an enhanced file's frames of one stack. Two
    /// stacks are two sub-series, even where their frames would line up.
    pub(super) stack: Option<String>,
    /// Philips' private scale slope (2005,100E), when the file states a
    /// usable one: the "precise" values are the displayed ones divided by
    /// RescaleSlope times it.
    pub(super) philips_scale: Option<f64>,
    /// The acquisition as a BIDS sidecar states it (see `sidecar`).
    pub(super) sidecar: std::sync::Arc<serde_json::Map<String, serde_json::Value>>,
}

/// Where one slice's pixels lie in its file: a frame (0 for single-frame
/// files) and, for a mosaic, the tile of that frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct PixelSource {
    /// The frame, from 0.
    pub(super) frame: u32,
    /// The mosaic tile cut from the frame, `None` for the whole frame.
    pub(super) tile: Option<Tile>,
}

/// One tile of a mosaic frame: tile `index` (row-major) of a grid
/// `across` tiles wide, each `rows` x `cols` pixels (the slice's size).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Tile {
    /// The tile's number in the frame, row-major from the top left.
    pub(super) index: u32,
    /// Tiles per row of the frame.
    pub(super) across: u32,
    /// The frame's width in pixels (its Columns).
    pub(super) frame_cols: u32,
}

/// The attributes scanners tell volumes apart by when several images of a
/// series lie at one position (dcm2niix's order of precedence): the
/// first that differs between two images sets their volumes apart.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct VolumeKeys {
    /// TemporalPositionIdentifier (0020,0100).
    pub(super) temporal_position: Option<i64>,
    /// AcquisitionNumber (0020,0012).
    pub(super) acquisition_number: Option<i64>,
    /// AcquisitionTime (0008,0032), in seconds since midnight.
    pub(super) acquisition_time: Option<f64>,
    /// TriggerTime (0018,1060), ms: cardiac phases.
    pub(super) trigger_time: Option<f64>,
    /// Diffusion b-value, s/mm² (DiffusionBValue or the vendors' private
    /// tags).
    pub(super) b_value: Option<f64>,
    /// Diffusion gradient direction, in patient coordinates (LPS).
    pub(super) b_vector: Option<[f64; 3]>,
    /// EchoNumbers (0018,0086).
    pub(super) echo_number: Option<i64>,
    /// EchoTime (0018,0081), ms.
    pub(super) echo_time: Option<f64>,
    /// ImageType (0008,0008), its values joined by `\\`.
    pub(super) image_type: String,
    /// RepetitionTime (0018,0080), ms.
    pub(super) repetition_time: Option<f64>,
    /// InstanceNumber (0020,0013): the order of images the other keys
    /// cannot tell apart.
    pub(super) instance_number: Option<i64>,
}

/// Where a slice's attributes are looked up, first to last: for a frame
/// of an enhanced multi-frame file, the functional-group items of its
/// per-frame entry, then the shared ones, then the data set; for any other
/// image, the data set alone.
pub(super) struct Attrs<'a> {
    layers: Vec<&'a InMemDicomObject>,
}

impl<'a> Attrs<'a> {
    /// The data set alone.
    pub(super) fn of(obj: &'a InMemDicomObject) -> Attrs<'a> {
        Attrs { layers: vec![obj] }
    }

    /// Frame `per_frame` (its entry of the Per-frame Functional Groups
    /// Sequence) of `obj`, with the `shared` functional groups.
    pub(super) fn frame(
        obj: &'a InMemDicomObject,
        per_frame: &'a InMemDicomObject,
        shared: Option<&'a InMemDicomObject>,
    ) -> Attrs<'a> {
        let groups = |item: &'a InMemDicomObject| {
            item.iter()
                .filter_map(|e| e.items())
                .flat_map(|items| items.iter())
                .collect::<Vec<_>>()
        };
        let mut layers = groups(per_frame);
        layers.extend(shared.map(groups).unwrap_or_default());
        layers.push(obj);
        Attrs { layers }
    }

    fn element(&self, tag: Tag) -> Option<&'a dicom_object::mem::InMemElement> {
        self.layers.iter().find_map(|l| l.get(tag))
    }

    /// A text attribute, trimmed of padding.
    pub(super) fn text(&self, tag: Tag) -> Option<String> {
        self.element(tag)
            .and_then(|e| e.to_str().ok())
            .map(|s| s.trim().trim_end_matches('\0').to_string())
    }

    /// A numeric attribute's values.
    pub(super) fn floats(&self, tag: Tag) -> Option<Vec<f64>> {
        self.element(tag).and_then(|e| e.to_multi_float64().ok())
    }

    /// A numeric attribute's first value.
    pub(super) fn first_float(&self, tag: Tag) -> Option<f64> {
        self.floats(tag).and_then(|v| v.first().copied())
    }

    /// An integer attribute.
    pub(super) fn int(&self, tag: Tag) -> Option<i64> {
        self.element(tag).and_then(|e| e.to_int::<i64>().ok())
    }

    /// The first item of sequence `tag`, as attributes of their own.
    fn item(&self, tag: Tag) -> Option<Attrs<'a>> {
        let item = self.element(tag)?.items()?.first()?;
        Some(Attrs::of(item))
    }
}

fn text(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    Attrs::of(obj).text(tag)
}

fn int(obj: &InMemDicomObject, tag: Tag) -> Option<i64> {
    Attrs::of(obj).int(tag)
}

/// The Media Storage Directory (`DICOMDIR`) SOP class.
const DICOMDIR_CLASS: &str = "1.2.840.10008.1.3.10";

/// What `obj` holds when it is no image, `None` for an image: a DICOMDIR
/// (by its SOP class or its name), or an object without Rows and Columns
/// whose SOP class is not an image storage class. An image class without
/// Rows stays an image, to be skipped as one without Rows and Columns.
fn non_image(path: &Path, obj: &DefaultDicomObject) -> Option<String> {
    use dicom_core::dictionary::UidDictionary;
    let class = text(obj, tags::SOP_CLASS_UID)
        .filter(|c| !c.is_empty())
        .unwrap_or_else(|| {
            obj.meta()
                .media_storage_sop_class_uid()
                .trim_end_matches(['\0', ' '])
                .to_string()
        });
    let named_dicomdir = path
        .file_name()
        .is_some_and(|n| n.eq_ignore_ascii_case("DICOMDIR"));
    if class == DICOMDIR_CLASS || named_dicomdir {
        return Some("DICOMDIR".into());
    }
    let name = dicom_dictionary_std::StandardSopClassDictionary
        .by_uid(&class)
        .map(|e| e.name.to_string());
    let has_size = int(obj, tags::ROWS).is_some() && int(obj, tags::COLUMNS).is_some();
    let image_class = name.as_deref().is_some_and(|n| n.contains("Image"));
    if has_size || image_class {
        return None;
    }
    Some(name.unwrap_or_else(|| {
        if class.is_empty() {
            "an object without SOP class".into()
        } else {
            format!("SOP class {}", volcore::text::excerpt(&class))
        }
    }))
}

/// Whether the file starts like a DICOM Part 10 file; an error when it
/// cannot be read at all.
fn sniff_file(path: &Path) -> Result<bool, SkipReason> {
    use std::io::Read;
    let mut head = Vec::with_capacity(132);
    std::fs::File::open(path)
        .and_then(|f| f.take(132).read_to_end(&mut head))
        .map_err(|e| SkipReason::Unreadable(e.to_string()))?;
    Ok(super::sniff(&head))
}

/// Read one file's header (its data set up to, not including, its pixel
/// data) as the slices of a series it holds, or say why it can hold none. The checks
/// run from the most to the least fundamental: a multi-frame or colour
/// image is named so even when it lacks ImagePositionPatient too.
pub(super) fn read_file(path: &Path) -> Result<Vec<SliceHeader>, SkipReason> {
    use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
    if !sniff_file(path)? {
        return Err(SkipReason::NotDicom);
    }
    let ts = check_lengths(path).map_err(SkipReason::Damaged)?;
    let unsupported_ts = |name: Option<&str>| SkipReason::TransferSyntax {
        uid: volcore::text::excerpt(&ts),
        name: name.map(str::to_string),
    };
    let syntax = TransferSyntaxRegistry.get(&ts);
    if !ts.is_empty() && syntax.is_none() {
        return Err(unsupported_ts(None));
    }
    let obj = OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .open_file(path)
        .map_err(|e| SkipReason::Damaged(super::chain(&e)))?;
    if let Some(what) = non_image(path, &obj) {
        return Err(SkipReason::NoImage(what));
    }
    let frames = int(&obj, tags::NUMBER_OF_FRAMES).unwrap_or(1);
    if let Some(syntax) = syntax.filter(|s| !super::pixels::decodes(&ts, s.can_decode_all())) {
        return Err(unsupported_ts(Some(syntax.name())));
    }
    let spp = int(&obj, tags::SAMPLES_PER_PIXEL).unwrap_or(1);
    if spp != 1 {
        return Err(SkipReason::Colour(format!("{spp} samples per pixel")));
    }
    let photometric = text(&obj, tags::PHOTOMETRIC_INTERPRETATION).unwrap_or_default();
    if !matches!(photometric.as_str(), "" | "MONOCHROME1" | "MONOCHROME2") {
        return Err(SkipReason::Colour(format!(
            "PhotometricInterpretation {}",
            volcore::text::excerpt(&photometric)
        )));
    }
    let image = image_of(path, &obj)?;
    let per_frame_groups = obj
        .get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .is_some();
    if frames > 1 || per_frame_groups {
        return super::enhanced::frames(path, &obj, frames, &image);
    }
    let whole = slice_of(&image, &Attrs::of(&obj), PixelSource::default())?;
    if super::mosaic::is_mosaic(&whole.keys.image_type) {
        return super::mosaic::unpack(&obj, whole);
    }
    Ok(vec![whole])
}

/// What every slice of one file shares: its series, size and pixel type.
pub(super) struct Image {
    path: PathBuf,
    series: String,
    series_number: Option<i64>,
    description: String,
    modality: String,
    /// Rows and Columns.
    pub(super) rows: u16,
    pub(super) cols: u16,
    /// BitsAllocated (8, 16 or 32).
    pub(super) bits_allocated: u16,
    bits_stored: u16,
    signed: bool,
}

/// The attributes of `obj` its slices share, checked.
fn image_of(path: &Path, obj: &InMemDicomObject) -> Result<Image, SkipReason> {
    let series = text(obj, tags::SERIES_INSTANCE_UID)
        .filter(|s| !s.is_empty())
        .ok_or(SkipReason::Missing("SeriesInstanceUID"))?;
    let rows = int(obj, tags::ROWS).unwrap_or(0);
    let cols = int(obj, tags::COLUMNS).unwrap_or(0);
    if !(1..=65535).contains(&rows) || !(1..=65535).contains(&cols) {
        return Err(SkipReason::Missing("Rows and Columns"));
    }
    let bits_allocated = int(obj, tags::BITS_ALLOCATED).unwrap_or(16);
    if !matches!(bits_allocated, 8 | 16 | 32) {
        return Err(SkipReason::Unsupported(format!(
            "BitsAllocated {bits_allocated} is not supported (8, 16 or 32)"
        )));
    }
    let bits_stored = int(obj, tags::BITS_STORED)
        .unwrap_or(bits_allocated)
        .clamp(1, bits_allocated);
    Ok(Image {
        path: path.to_path_buf(),
        series,
        series_number: int(obj, tags::SERIES_NUMBER),
        description: text(obj, tags::SERIES_DESCRIPTION).unwrap_or_default(),
        modality: text(obj, tags::MODALITY).unwrap_or_default(),
        rows: rows as u16,
        cols: cols as u16,
        bits_allocated: bits_allocated as u16,
        bits_stored: bits_stored as u16,
        signed: int(obj, tags::PIXEL_REPRESENTATION) == Some(1),
    })
}

/// One slice of `image` whose own attributes (position, orientation,
/// spacing, rescale, volume keys) `a` gives, its pixels at `pixels`.
pub(super) fn slice_of(
    image: &Image,
    a: &Attrs,
    pixels: PixelSource,
) -> Result<SliceHeader, SkipReason> {
    let need = |tag, name| a.floats(tag).ok_or(SkipReason::Missing(name));
    let p = need(tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
    let o = need(tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
    let s = a
        .floats(tags::PIXEL_SPACING)
        .unwrap_or_else(|| vec![1.0, 1.0]);
    if p.len() != 3 || o.len() != 6 || s.len() != 2 {
        return Err(SkipReason::Unsupported(
            "ImagePositionPatient, ImageOrientationPatient or PixelSpacing has the wrong number of values".into(),
        ));
    }
    if p.iter().chain(&o).chain(&s).any(|v| !v.is_finite()) || s.iter().any(|v| *v <= 0.0) {
        return Err(SkipReason::Unsupported(
            "position, orientation or spacing is not finite and positive".into(),
        ));
    }
    let slope = a.first_float(tags::RESCALE_SLOPE).unwrap_or(1.0);
    let intercept = a.first_float(tags::RESCALE_INTERCEPT).unwrap_or(0.0);
    if !(slope.is_finite() && intercept.is_finite()) || slope == 0.0 {
        return Err(SkipReason::Unsupported(
            "RescaleSlope or RescaleIntercept is not usable".into(),
        ));
    }
    Ok(SliceHeader {
        path: image.path.clone(),
        series: image.series.clone(),
        series_number: image.series_number,
        description: image.description.clone(),
        modality: image.modality.clone(),
        rows: image.rows,
        cols: image.cols,
        position: [p[0], p[1], p[2]],
        orientation: [o[0], o[1], o[2], o[3], o[4], o[5]],
        pixel_spacing: [s[0], s[1]],
        rescale: Rescale { slope, intercept },
        bits_allocated: image.bits_allocated,
        bits_stored: image.bits_stored,
        signed: image.signed,
        pixels,
        keys: volume_keys(a),
        stack: a.text(tags::STACK_ID).filter(|s| !s.is_empty()),
        sidecar: std::sync::Arc::new(super::sidecar::of(a)),
        philips_scale: a
            .first_float(Tag(0x2005, 0x100E))
            .filter(|v| v.is_finite() && *v != 0.0),
    })
}

/// The keys of [`VolumeKeys`] as `a` states them: the classic attributes,
/// or an enhanced frame's (FrameContent's TemporalPositionIndex and
/// FrameAcquisitionDateTime, MREcho's EffectiveEchoTime, MRDiffusion's,
/// CardiacSynchronization's trigger delay, FrameType).
fn volume_keys(a: &Attrs) -> VolumeKeys {
    let diffusion_direction = a
        .item(tags::DIFFUSION_GRADIENT_DIRECTION_SEQUENCE)
        .and_then(|d| d.floats(tags::DIFFUSION_GRADIENT_ORIENTATION));
    let b_vector = a
        .floats(tags::DIFFUSION_GRADIENT_ORIENTATION)
        .or(diffusion_direction)
        // Siemens: DiffusionGradientDirection (0019,100E).
        .or_else(|| a.floats(Tag(0x0019, 0x100E)))
        .filter(|v| v.len() == 3 && v.iter().all(|x| x.is_finite()))
        .map(|v| [v[0], v[1], v[2]]);
    // FrameAcquisitionDateTime is a DT: YYYYMMDD, then the time.
    let frame_time = a
        .text(tags::FRAME_ACQUISITION_DATE_TIME)
        .and_then(|dt| {
            dt.get(8..)
                .map(|t| t.split(['+', '-']).next().unwrap_or("").to_string())
        })
        .and_then(|t| seconds_of_day(&t));
    VolumeKeys {
        temporal_position: a
            .int(tags::TEMPORAL_POSITION_IDENTIFIER)
            .or_else(|| a.int(tags::TEMPORAL_POSITION_INDEX)),
        acquisition_number: a.int(tags::ACQUISITION_NUMBER),
        acquisition_time: a
            .text(tags::ACQUISITION_TIME)
            .and_then(|t| seconds_of_day(&t))
            .or(frame_time),
        trigger_time: a
            .first_float(tags::TRIGGER_TIME)
            .or_else(|| a.first_float(tags::NOMINAL_CARDIAC_TRIGGER_DELAY_TIME)),
        b_value: a
            .first_float(tags::DIFFUSION_B_VALUE)
            // Siemens: B_value (0019,100C), an IS.
            .or_else(|| a.first_float(Tag(0x0019, 0x100C)))
            .filter(|b| b.is_finite() && *b >= 0.0),
        b_vector,
        echo_number: a.int(tags::ECHO_NUMBERS),
        echo_time: a
            .first_float(tags::ECHO_TIME)
            .or_else(|| a.first_float(tags::EFFECTIVE_ECHO_TIME)),
        image_type: a
            .text(tags::FRAME_TYPE)
            .or_else(|| a.text(tags::IMAGE_TYPE))
            .unwrap_or_default(),
        repetition_time: a.first_float(tags::REPETITION_TIME),
        instance_number: a.int(tags::INSTANCE_NUMBER),
    }
}

/// A DICOM TM value (`HHMMSS.FFFFFF`, or the old `HH:MM:SS.frac`) in
/// seconds since midnight; `None` when it is no time.
pub(super) fn seconds_of_day(tm: &str) -> Option<f64> {
    let t: String = tm.trim().chars().filter(|c| *c != ':').collect();
    let (whole, frac) = t.split_once('.').unwrap_or((&t, ""));
    if whole.is_empty() || whole.len() > 6 || !whole.len().is_multiple_of(2) {
        return None;
    }
    if !whole.bytes().all(|b| b.is_ascii_digit()) || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let part = |i: usize| -> f64 {
        whole
            .get(i..i + 2)
            .and_then(|s| s.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    let (h, m, s) = (part(0), part(2), part(4));
    if h >= 24.0 || m >= 60.0 || s >= 61.0 {
        return None;
    }
    let frac = if frac.is_empty() {
        0.0
    } else {
        format!("0.{frac}").parse::<f64>().ok()?
    };
    Some(h * 3600.0 + m * 60.0 + s + frac)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_of_day_parse_both_spellings_and_refuse_the_rest() {
        assert_eq!(seconds_of_day("101530.25"), Some(36930.25));
        assert_eq!(seconds_of_day("10:15:30"), Some(36930.0));
        assert_eq!(seconds_of_day("1015"), Some(36900.0));
        assert_eq!(seconds_of_day(""), None);
        assert_eq!(seconds_of_day("2561"), None);
        assert_eq!(seconds_of_day("12a456"), None);
        assert_eq!(seconds_of_day("12345"), None);
    }
}
