//! Series scanning: each file's header read up to its pixel data, the
//! files that hold no image skipped, the images grouped by series, and
//! one series picked by `--series`.

use super::guard::check_lengths;
use super::{bad, DicomReader};
use crate::reader::CResult;
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
    pub(super) frames: u32,
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

/// A file of a DICOM input that holds no image, skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// What it holds: `DICOMDIR` or its SOP class's name.
    pub what: String,
}

/// What one file of an input is.
enum Header {
    /// A slice of an image series.
    Image(SliceHeader),
    /// Anything else.
    Other(Skipped),
}

/// The Media Storage Directory (`DICOMDIR`) SOP class.
const DICOMDIR_CLASS: &str = "1.2.840.10008.1.3.10";

/// What `obj` holds when it is no image, `None` for an image: a DICOMDIR
/// (by its SOP class or its name), or an object without Rows and Columns
/// whose SOP class is not an image storage class. An image class without
/// Rows stays an image, to be refused as damaged.
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
            format!("SOP class {class}")
        }
    }))
}

/// Read the data set of one file up to (not including) its pixel data.
fn read_header(path: &Path) -> CResult<Header> {
    check_lengths(path).map_err(|e| bad(path, format!("damaged DICOM file: {e}")))?;
    let obj = OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .open_file(path)
        .map_err(|e| bad(path, format!("not a readable DICOM file: {e}")))?;
    if let Some(what) = non_image(path, &obj) {
        return Ok(Header::Other(Skipped {
            path: path.to_path_buf(),
            what,
        }));
    }
    let need = |tag, name: &str| -> CResult<Vec<f64>> {
        floats(&obj, tag).ok_or_else(|| bad(path, format!("DICOM image without {name}")))
    };
    let series = text(&obj, tags::SERIES_INSTANCE_UID)
        .ok_or_else(|| bad(path, "DICOM file without SeriesInstanceUID"))?;
    let rows = int(&obj, tags::ROWS).unwrap_or(0);
    let cols = int(&obj, tags::COLUMNS).unwrap_or(0);
    if !(1..=65535).contains(&rows) || !(1..=65535).contains(&cols) {
        return Err(bad(path, "DICOM image without Rows and Columns"));
    }
    let p = need(tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
    let o = need(tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
    let s = floats(&obj, tags::PIXEL_SPACING).unwrap_or_else(|| vec![1.0, 1.0]);
    if p.len() != 3 || o.len() != 6 || s.len() != 2 {
        return Err(bad(
            path,
            "DICOM ImagePositionPatient, ImageOrientationPatient or PixelSpacing has the wrong number of values",
        ));
    }
    if p.iter().chain(&o).chain(&s).any(|v| !v.is_finite()) || s.iter().any(|v| *v <= 0.0) {
        return Err(bad(
            path,
            "DICOM position, orientation or spacing is not finite and positive",
        ));
    }
    let spp = int(&obj, tags::SAMPLES_PER_PIXEL).unwrap_or(1);
    if spp != 1 {
        return Err(bad(
            path,
            format!("DICOM image with {spp} samples per pixel (colour): volkit reads grey images"),
        ));
    }
    let bits_allocated = int(&obj, tags::BITS_ALLOCATED).unwrap_or(16) as u16;
    if !matches!(bits_allocated, 8 | 16 | 32) {
        return Err(bad(
            path,
            format!("DICOM BitsAllocated {bits_allocated} is not supported (8, 16 or 32)"),
        ));
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
        return Err(bad(
            path,
            "DICOM RescaleSlope or RescaleIntercept is not usable",
        ));
    }
    let ts = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches('\0')
        .to_string();
    check_transfer_syntax(path, &ts)?;
    Ok(Header::Image(SliceHeader {
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
        frames: int(&obj, tags::NUMBER_OF_FRAMES).unwrap_or(1).max(1) as u32,
    }))
}

/// Fail clearly on a transfer syntax this build cannot decode.
fn check_transfer_syntax(path: &Path, uid: &str) -> CResult<()> {
    use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
    match TransferSyntaxRegistry.get(uid) {
        Some(ts) if ts.can_decode_all() => Ok(()),
        Some(ts) => Err(bad(
            path,
            format!(
                "DICOM transfer syntax {} ({uid}) cannot be decoded by volkit: convert the series to an uncompressed, RLE or JPEG transfer syntax first (e.g. with dcmdjpeg or gdcmconv --raw)",
                ts.name()
            ),
        )),
        None => Err(bad(path, format!("unknown DICOM transfer syntax {uid}"))),
    }
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
/// grouped by series (in order of SeriesNumber, then UID), and the files
/// skipped as no image.
pub struct Scan {
    input: PathBuf,
    series: Vec<(SeriesInfo, Vec<SliceHeader>)>,
    skipped: Vec<Skipped>,
}

impl Scan {
    /// Read the headers of `files` (from `input`, named in errors); an
    /// input whose files hold no image at all is an error.
    pub fn new(input: &Path, files: &[PathBuf]) -> CResult<Scan> {
        use rayon::prelude::*;
        let headers: Vec<Header> = files
            .par_iter()
            .map(|f| read_header(f))
            .collect::<CResult<_>>()?;
        let mut by_series: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for h in headers {
            match h {
                Header::Image(h) => by_series.entry(h.series.clone()).or_default().push(h),
                Header::Other(s) => skipped.push(s),
            }
        }
        if by_series.is_empty() {
            return Err(bad(
                input,
                format!(
                    "holds no DICOM image: {} skipped",
                    skipped_summary(&skipped)
                ),
            ));
        }
        let mut series: Vec<(SeriesInfo, Vec<SliceHeader>)> = by_series
            .into_iter()
            .map(|(uid, v)| {
                let first = &v[0];
                let info = SeriesInfo {
                    number: v.iter().find_map(|h| h.series_number),
                    description: first.description.clone(),
                    modality: first.modality.clone(),
                    images: v.len(),
                    dims: [first.cols as u64, first.rows as u64, v.len() as u64],
                    uid,
                };
                (info, v)
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

    /// The files skipped as no image.
    pub fn skipped(&self) -> &[Skipped] {
        &self.skipped
    }

    /// What the user should hear of: how many files were skipped (what
    /// [`DicomReader`]'s notes say too).
    pub fn notes(&self) -> Vec<String> {
        skipped_notes(&self.input, &self.skipped)
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

    /// Open the series `sel` names (see [`Scan::select`]).
    pub fn open(mut self, sel: Option<&str>) -> CResult<DicomReader> {
        let i = self.select(sel)?;
        let (_, slices) = self.series.swap_remove(i);
        let mut r = DicomReader::new(&self.input, slices)?;
        r.skipped = self.skipped;
        Ok(r)
    }
}

/// `3 files (1 DICOMDIR, 2 Basic Text SR Storage)`: how many files were
/// skipped and what they hold.
fn skipped_summary(skipped: &[Skipped]) -> String {
    let mut kinds: BTreeMap<&str, usize> = BTreeMap::new();
    for s in skipped {
        *kinds.entry(s.what.as_str()).or_default() += 1;
    }
    format!(
        "{} file{} ({})",
        skipped.len(),
        if skipped.len() == 1 { "" } else { "s" },
        kinds
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// `input: skipped 2 files (...) that hold no image`, or nothing.
pub(super) fn skipped_notes(input: &Path, skipped: &[Skipped]) -> Vec<String> {
    if skipped.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "{}: skipped {} that hold{} no image",
        input.display(),
        skipped_summary(skipped),
        if skipped.len() == 1 { "s" } else { "" }
    )]
}
