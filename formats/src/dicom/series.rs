//! Series scanning: each file's header read up to its pixel data, each
//! file that cannot join a series skipped with its reason, the images
//! grouped by series and each series checked as a volume, and one series
//! picked by `--series`.

use super::guard::check_lengths;
use super::skip::{skipped_brief, SkipReason, Skipped};
use super::{bad, DicomReader};
use crate::reader::{CResult, ConvertError};
use crate::rescale::Rescale;
use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, OpenFileOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What one file of a series says about its slice.
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
}

fn text(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<String> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim().trim_end_matches('\0').to_string())
}

fn floats(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<Vec<f64>> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_multi_float64().ok())
}

fn int(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<i64> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_int::<i64>().ok())
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
/// data) as a slice of a series, or say why it can be none. The checks
/// run from the most to the least fundamental: a multi-frame or colour
/// image is named so even when it lacks ImagePositionPatient too.
fn read_header(path: &Path) -> Result<SliceHeader, SkipReason> {
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
    if frames > 1 {
        return Err(SkipReason::MultiFrame(
            u32::try_from(frames).unwrap_or(u32::MAX),
        ));
    }
    if let Some(syntax) = syntax.filter(|s| !s.can_decode_all()) {
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
    let series = text(&obj, tags::SERIES_INSTANCE_UID)
        .filter(|s| !s.is_empty())
        .ok_or(SkipReason::Missing("SeriesInstanceUID"))?;
    let rows = int(&obj, tags::ROWS).unwrap_or(0);
    let cols = int(&obj, tags::COLUMNS).unwrap_or(0);
    if !(1..=65535).contains(&rows) || !(1..=65535).contains(&cols) {
        return Err(SkipReason::Missing("Rows and Columns"));
    }
    let need = |tag, name| floats(&obj, tag).ok_or(SkipReason::Missing(name));
    let p = need(tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
    let o = need(tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
    let s = floats(&obj, tags::PIXEL_SPACING).unwrap_or_else(|| vec![1.0, 1.0]);
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
    let bits_allocated = int(&obj, tags::BITS_ALLOCATED).unwrap_or(16) as u16;
    if !matches!(bits_allocated, 8 | 16 | 32) {
        return Err(SkipReason::Unsupported(format!(
            "BitsAllocated {bits_allocated} is not supported (8, 16 or 32)"
        )));
    }
    let bits_stored = (int(&obj, tags::BITS_STORED).unwrap_or(bits_allocated as i64) as u16)
        .clamp(1, bits_allocated);
    let slope = floats(&obj, tags::RESCALE_SLOPE)
        .and_then(|v| v.first().copied())
        .unwrap_or(1.0);
    let intercept = floats(&obj, tags::RESCALE_INTERCEPT)
        .and_then(|v| v.first().copied())
        .unwrap_or(0.0);
    if !(slope.is_finite() && intercept.is_finite()) || slope == 0.0 {
        return Err(SkipReason::Unsupported(
            "RescaleSlope or RescaleIntercept is not usable".into(),
        ));
    }
    Ok(SliceHeader {
        path: path.to_path_buf(),
        series,
        series_number: int(&obj, tags::SERIES_NUMBER),
        description: text(&obj, tags::SERIES_DESCRIPTION).unwrap_or_default(),
        modality: text(&obj, tags::MODALITY).unwrap_or_default(),
        rows: rows as u16,
        cols: cols as u16,
        position: [p[0], p[1], p[2]],
        orientation: [o[0], o[1], o[2], o[3], o[4], o[5]],
        pixel_spacing: [s[0], s[1]],
        rescale: Rescale { slope, intercept },
        bits_allocated,
        bits_stored,
        signed: int(&obj, tags::PIXEL_REPRESENTATION) == Some(1),
    })
}

/// One series of a DICOM input, as listed.
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesInfo {
    /// SeriesInstanceUID.
    pub uid: String,
    /// SeriesNumber, when the files give one.
    pub number: Option<i64>,
    /// SeriesDescription (empty when none).
    pub description: String,
    /// Modality (empty when none).
    pub modality: String,
    /// Image files.
    pub images: usize,
    /// Columns, rows and images.
    pub dims: [u64; 3],
    /// Why the series cannot be read as one volume (mixed sizes, missing
    /// slices, gantry tilt, ...), the error opening it gives; `None` when
    /// it can.
    pub problem: Option<String>,
}

impl SeriesInfo {
    /// `#N UID (CT, 10 images of 16x12)`, for messages.
    pub fn describe(&self) -> String {
        format!(
            "{}{} ({}{} images of {}x{})",
            self.number.map(|n| format!("#{n} ")).unwrap_or_default(),
            self.uid,
            if self.modality.is_empty() {
                String::new()
            } else {
                format!("{}, ", self.modality)
            },
            self.images,
            self.dims[0],
            self.dims[1]
        )
    }
}

/// The files of a DICOM input read up to their pixel data: the images
/// grouped by series (in order of SeriesNumber, then UID), each series
/// checked as a volume, and the files skipped with their reasons.
pub struct Scan {
    input: PathBuf,
    series: Vec<(SeriesInfo, CResult<DicomReader>)>,
    skipped: Vec<Skipped>,
}

impl Scan {
    /// Read the headers of `files` (from `input`, named in errors). A file
    /// that cannot join a series is skipped, with its reason; an input
    /// none of whose files joins one is an error naming the first.
    pub fn new(input: &Path, files: &[PathBuf]) -> CResult<Scan> {
        use rayon::prelude::*;
        let headers: Vec<(&PathBuf, Result<SliceHeader, SkipReason>)> =
            files.par_iter().map(|f| (f, read_header(f))).collect();
        let mut by_series: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for (path, h) in headers {
            match h {
                Ok(h) => by_series.entry(h.series.clone()).or_default().push(h),
                Err(reason) => skipped.push(Skipped {
                    path: path.clone(),
                    reason,
                }),
            }
        }
        skipped.sort_by(|a: &Skipped, b: &Skipped| a.path.cmp(&b.path));
        if by_series.is_empty() {
            return Err(bad(
                input,
                format!(
                    "no readable DICOM series: {} skipped",
                    skipped_brief(input, &skipped)
                ),
            ));
        }
        let mut series: Vec<(SeriesInfo, CResult<DicomReader>)> = by_series
            .into_iter()
            .map(|(uid, v)| {
                let first = &v[0];
                let mut info = SeriesInfo {
                    number: v.iter().find_map(|h| h.series_number),
                    description: first.description.clone(),
                    modality: first.modality.clone(),
                    images: v.len(),
                    dims: [first.cols as u64, first.rows as u64, v.len() as u64],
                    uid,
                    problem: None,
                };
                let reader = DicomReader::new(input, v);
                // The input is named once, by whoever prints the problem.
                info.problem = reader.as_ref().err().map(|e| {
                    if e.path == input {
                        e.error.to_string()
                    } else {
                        e.to_string()
                    }
                });
                (info, reader)
            })
            .collect();
        series.sort_by(|a, b| (a.0.number, &a.0.uid).cmp(&(b.0.number, &b.0.uid)));
        Ok(Scan {
            input: input.to_path_buf(),
            series,
            skipped,
        })
    }

    /// The series found.
    pub fn series(&self) -> Vec<SeriesInfo> {
        self.series.iter().map(|(s, _)| s.clone()).collect()
    }

    /// The files skipped, with their reasons.
    pub fn skipped(&self) -> &[Skipped] {
        &self.skipped
    }

    /// The index of the series `sel` names, tried in this order: its
    /// whole UID, its SeriesNumber, a prefix of one UID only; with `None`,
    /// the only series. Anything else is an error listing the candidates.
    fn select(&self, sel: Option<&str>) -> CResult<usize> {
        let list = |idx: &[usize]| {
            idx.iter()
                .map(|&i| self.series[i].0.describe())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let all: Vec<usize> = (0..self.series.len()).collect();
        let Some(sel) = sel else {
            if self.series.len() == 1 {
                return Ok(0);
            }
            return Err(bad(
                &self.input,
                format!(
                    "holds {} DICOM series: pick one with --series (its number, UID or a unique UID prefix): {}",
                    self.series.len(),
                    list(&all)
                ),
            ));
        };
        if let Some(i) = self.series.iter().position(|(s, _)| s.uid == sel) {
            return Ok(i);
        }
        let pick = |found: Vec<usize>, how: &str| -> CResult<Option<usize>> {
            match found.len() {
                0 => Ok(None),
                1 => Ok(Some(found[0])),
                n => Err(bad(
                    &self.input,
                    format!(
                        "--series {sel} is ambiguous: {n} series {how}: {}; give more of the UID",
                        list(&found)
                    ),
                )),
            }
        };
        if let Ok(number) = sel.parse::<i64>() {
            let found = all
                .iter()
                .copied()
                .filter(|&i| self.series[i].0.number == Some(number))
                .collect();
            if let Some(i) = pick(found, "have this number")? {
                return Ok(i);
            }
        }
        let found = all
            .iter()
            .copied()
            .filter(|&i| !sel.is_empty() && self.series[i].0.uid.starts_with(sel))
            .collect();
        if let Some(i) = pick(found, "have UIDs starting so")? {
            return Ok(i);
        }
        Err(bad(
            &self.input,
            format!("no series {sel}; the input holds {}", list(&all)),
        ))
    }

    /// An error unless some series reads as a volume: `no readable DICOM
    /// series`, with the first series' problem and the files skipped.
    pub fn check_readable(&self) -> CResult<()> {
        if self.series.iter().any(|(s, _)| s.problem.is_none()) {
            return Ok(());
        }
        let (first, _) = &self.series[0];
        let mut msg = format!(
            "no readable DICOM series: {} series cannot be read (first: {}: {})",
            self.series.len(),
            first.describe(),
            first.problem.as_deref().unwrap_or_default()
        );
        if !self.skipped.is_empty() {
            msg.push_str(&format!(
                "; {} skipped",
                skipped_brief(&self.input, &self.skipped)
            ));
        }
        Err(bad(&self.input, msg))
    }

    /// Open the series `sel` names (see [`Scan::select`]), whatever else
    /// the input holds: only the series' own problem is an error, with the
    /// files skipped named after it (one of them may be its missing slice).
    pub fn open(mut self, sel: Option<&str>) -> CResult<DicomReader> {
        let i = self.select(sel)?;
        let (_, reader) = self.series.swap_remove(i);
        match reader {
            Ok(mut r) => {
                r.skipped = self.skipped;
                Ok(r)
            }
            Err(e) if self.skipped.is_empty() => Err(e),
            Err(e) => Err(ConvertError::new(
                &e.path,
                crate::error::Error::invalid(format!(
                    "{}; {} skipped",
                    e.error,
                    skipped_brief(&self.input, &self.skipped)
                )),
            )),
        }
    }
}
