//! DICOM series (a directory of files, a glob or a list file) read as one
//! volume, through dicom-rs (`dicom-object` for the data sets,
//! `dicom-pixeldata` for the pixel data and its codecs: native, RLE,
//! JPEG, JPEG 2000, deflate; JPEG-LS through `pure_jpegls`).
//!
//! - Every file yields slices or is skipped with its reason
//!   ([`SkipReason`]): not DICOM, unreadable, truncated or damaged, no
//!   image (a `DICOMDIR`, and objects without Rows and Columns whose SOP
//!   class is no image storage class: reports, presentation states, RT
//!   structure sets), a multi-frame image without per-frame functional
//!   groups, an undecodable transfer syntax, colour, a mosaic that cannot
//!   be unpacked, or an image without SeriesInstanceUID, Rows and Columns,
//!   ImagePositionPatient or ImageOrientationPatient. Only an input left
//!   without a series is refused.
//! - A single-frame image is one slice; a Siemens mosaic one slice per
//!   tile (`mosaic`, by its CSA header, `csa`); an enhanced multi-frame
//!   image one slice per frame, placed by its functional groups
//!   (`enhanced`).
//! - A series is its SeriesInstanceUID with its SeriesNumber ([`Scan`]);
//!   slices that cannot share a volume (another size, orientation or
//!   pixel type) form sub-series. `--series` picks one by any ID vol-info
//!   lists, its number, its whole UID or a unique prefix of it.
//! - Slices at one position are volumes of a time series (`volumes`),
//!   told apart by dcm2niix's keys in its order, picked with
//!   `--time-point` and `--echo`.
//! - Slices are sorted by ImagePositionPatient projected on the slice
//!   normal (the cross product of the ImageOrientationPatient rows), not by
//!   file name or InstanceNumber.
//! - Spacing: PixelSpacing (rows, then columns) for y and x; z from the
//!   measured positions. Gaps that differ from the median by more than 1%
//!   (or 0.01 mm) are refused: a whole multiple of the spacing is reported
//!   as missing slices, anything else as uneven spacing. Positions that do
//!   not follow the normal (gantry tilt) are refused too.
//! - RescaleSlope/RescaleIntercept are applied per slice: CT pixels become
//!   Hounsfield units (integers, so `i16` when they fit, else `f32`).
//!   A Philips private scale (2005,100E) is named, and applied with
//!   `--philips-scale precise` ([`PhilipsScale`]).
//! - Geometry: origin at the first slice's ImagePositionPatient, axes
//!   along the row, column and normal directions (DICOM is LPS, like volkit).
//!
//! The reader is here; its jobs are in `guard` (refusing files whose
//! element lengths would make dicom-rs allocate more than the file
//! holds), `header` (one file's header as its slices), `mosaic`, `csa`
//! and `enhanced` (the files of several slices), `series` (grouping the
//! slices into series and sub-series and picking one), `volumes` (the
//! volumes at one position), `skip` (why a file was skipped, and the
//! summaries of them) and `pixels` (decoding a slice's pixel data, RLE and
//! JPEG-LS included).

pub mod csa;
mod enhanced;
mod guard;
mod header;
mod mosaic;
mod pixels;
mod series;
mod sidecar;
mod skip;
mod volumes;

pub use series::{Scan, SeriesInfo};
pub use skip::{shown, SkipReason, Skipped};

use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use dicom_object::DefaultDicomObject;
use header::SliceHeader;
use pixels::{stored_type, widest};
use skip::skipped_notes;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use volcore::{Dims, Geometry};

/// Relative tolerance of slice gaps (and at least this many mm).
const GAP_TOLERANCE: f64 = 0.01;
const GAP_TOLERANCE_MM: f64 = 0.01;

/// Whether bytes start like a DICOM Part 10 file (`DICM` after the
/// 128-byte preamble).
pub fn sniff(b: &[u8]) -> bool {
    b.len() >= 132 && &b[128..132] == b"DICM"
}

/// Whether the file at `path` is a DICOM Part 10 file.
pub fn is_dicom_file(path: &Path) -> bool {
    use std::io::Read;
    let mut b = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut b))
        .map(|_| sniff(&b))
        .unwrap_or(false)
}

fn bad(path: &Path, msg: impl Into<String>) -> ConvertError {
    ConvertError::new(path, Error::invalid(msg.into()))
}

/// An error with its causes, `outer: inner: ...` (dicom-rs's errors say
/// little at the top: "Could not read data set token"), escaped and
/// clipped: its text may quote the file.
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    volcore::text::clip(&s, 200)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The files of a DICOM input: a directory (every regular, non-hidden
/// file: those that are no DICOM file are skipped as such by [`Scan`]),
/// a glob or a list file.
pub fn list_files(input: &Path, files: Option<Vec<PathBuf>>) -> CResult<Vec<PathBuf>> {
    let files = match files {
        Some(f) => f,
        None => {
            let mut v = Vec::new();
            for e in std::fs::read_dir(input).at(input)? {
                let e = e.at(input)?;
                let hidden = e.file_name().to_string_lossy().starts_with('.');
                if !hidden && e.path().is_file() {
                    v.push(e.path());
                }
            }
            v
        }
    };
    if files.is_empty() {
        return Err(bad(input, "holds no DICOM files"));
    }
    Ok(files)
}

/// A DICOM series, read slice by slice (any slice from any thread).
pub struct DicomReader {
    info: InputInfo,
    /// The type the files store (before the rescale widens it).
    stored: SliceType,
    slices: Vec<SliceHeader>,
    bytes: u64,
    skipped: Vec<Skipped>,
    /// The convention applied, where a Philips private scale was there to
    /// apply.
    philips: Option<PhilipsScale>,
    /// The frame decoded last (its file and number): the tiles of a
    /// mosaic, read one after another, decode their frame once.
    last_frame: Mutex<Option<LastFrame>>,
    /// The file opened last: the frames of a multi-frame file, read one
    /// after another, open it once.
    last_file: Mutex<Option<(PathBuf, Arc<DefaultDicomObject>)>>,
}

/// A decoded frame kept for the next slice cut from it.
type LastFrame = ((PathBuf, u32), Arc<Vec<u8>>);

/// Which values a Philips series with a private scale slope (2005,100E)
/// gives: DICOM's displayed values (RescaleSlope and RescaleIntercept,
/// what every DICOM viewer shows; the default) or Philips' "precise"
/// floating-point values, the displayed ones divided by RescaleSlope
/// times the private slope (what dcm2niix writes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum, serde::Serialize))]
#[cfg_attr(feature = "clap", serde(rename_all = "kebab-case"))]
pub enum PhilipsScale {
    /// RescaleSlope and RescaleIntercept, as the standard says.
    #[default]
    Displayed,
    /// (stored x RescaleSlope + RescaleIntercept) / (RescaleSlope x
    /// private scale slope), as dcm2niix writes them.
    Precise,
}

/// What to read of a DICOM input: the series, the volume of it, and the
/// value convention.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pick<'a> {
    /// The series (see [`Scan`]); `None`: the only one.
    pub series: Option<&'a str>,
    /// The echo of a multi-echo series.
    pub echo: Option<u64>,
    /// The time point of a series of several volumes.
    pub time: Option<u64>,
    /// Philips series with a private scale: which values.
    pub philips: PhilipsScale,
}

/// Open a volume of the series in `files` (from `input`), as `pick` says.
pub fn open(input: &Path, files: Vec<PathBuf>, pick: Pick) -> CResult<DicomReader> {
    Scan::new(input, &files)?.open(pick)
}

impl DicomReader {
    fn new(input: &Path, mut slices: Vec<SliceHeader>) -> CResult<DicomReader> {
        // One size, orientation and pixel type: the scan's sub-series
        // (series.rs) hold nothing else.
        let first = slices[0].clone();
        let o = first.orientation;
        let row = [o[0], o[1], o[2]];
        let col = [o[3], o[4], o[5]];
        let normal = cross(row, col);
        let geometry_axes = |n: [f64; 3]| [row, col, n];
        let nn = dot(normal, normal).sqrt();
        if nn < 1e-6 {
            return Err(bad(
                &first.path,
                "ImageOrientationPatient rows are parallel",
            ));
        }
        let normal = normal.map(|v| v / nn);
        slices.sort_by(|a, b| dot(a.position, normal).total_cmp(&dot(b.position, normal)));
        let along: Vec<f64> = slices.iter().map(|s| dot(s.position, normal)).collect();
        let spacing_z = check_gaps(input, &slices, &along)?;
        if slices.len() > 1 {
            // Gantry tilt: the slices' origins leave the normal.
            let span = sub3(slices[slices.len() - 1].position, slices[0].position);
            let d = dot(span, normal);
            let lateral = sub3(span, normal.map(|v| v * d));
            let off = dot(lateral, lateral).sqrt();
            if off > (0.01 * d.abs()).max(0.01) {
                return Err(bad(
                    input,
                    format!(
                        "slice positions drift {off:.3} mm sideways over {:.3} mm (gantry tilt): volkit reads series whose slices stack along their normal; resample the series first",
                        d.abs()
                    ),
                ));
            }
        }
        let geometry = Geometry::from_axes(slices[0].position, geometry_axes(normal))
            .map_err(|e| bad(&first.path, format!("DICOM geometry: {e}")))?
            // DICOM states every position and spacing in millimetres.
            .with_unit(volcore::LengthUnit::Millimeter);
        let stored = stored_type(first.bits_allocated, first.signed);
        let out = slices
            .iter()
            .map(|s| {
                if s.rescale.is_identity() {
                    stored
                } else {
                    s.rescale.output_type(stored)
                }
            })
            .fold(stored, widest);
        let dims =
            Dims::new(first.cols as u64, first.rows as u64, slices.len() as u64).at(input)?;
        // A file of several slices (a mosaic) counts once.
        let files: std::collections::BTreeSet<&Path> =
            slices.iter().map(|s| s.path.as_path()).collect();
        let bytes = files
            .iter()
            .map(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0))
            .sum();
        Ok(DicomReader {
            stored,
            skipped: Vec::new(),
            philips: None,
            last_frame: Mutex::new(None),
            last_file: Mutex::new(None),
            info: InputInfo {
                nifti_codes: None,
                path: input.to_path_buf(),
                dims,
                sample_type: out,
                spacing: Some([
                    first.pixel_spacing[1] as f32,
                    first.pixel_spacing[0] as f32,
                    spacing_z as f32,
                ]),
                geometry,
                format: format!(
                    "dicom series ({}{} image{})",
                    if first.modality.is_empty() {
                        String::new()
                    } else {
                        format!("{}, ", first.modality)
                    },
                    slices.len(),
                    if slices.len() == 1 { "" } else { "s" }
                ),
            },
            slices,
            bytes,
        })
    }
}

/// The note that says which Philips convention was applied, and how to
/// get the other.
fn philips_note(input: &Path, applied: PhilipsScale) -> String {
    match applied {
        PhilipsScale::Displayed => format!(
            "{}: Philips private scale slope (2005,100E) present: wrote DICOM's displayed values (RescaleSlope/RescaleIntercept); --philips-scale precise gives the floating-point values dcm2niix writes",
            input.display()
        ),
        PhilipsScale::Precise => format!(
            "{}: Philips private scale slope (2005,100E) applied: wrote the precise values (displayed / (RescaleSlope x scale slope)), as dcm2niix does; --philips-scale displayed gives DICOM's",
            input.display()
        ),
    }
}

/// Whether two slices' values of one attribute differ by more than
/// rounding in their text.
fn differ(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).any(|(a, b)| (a - b).abs() > 1e-4)
}

/// The slice spacing of sorted positions `along` the normal, or an error
/// naming the first bad gap.
fn check_gaps(input: &Path, slices: &[SliceHeader], along: &[f64]) -> CResult<f64> {
    if along.len() < 2 {
        return Ok(1.0);
    }
    let gaps: Vec<f64> = along.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = gaps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    for (k, &g) in gaps.iter().enumerate() {
        let (a, b) = (&slices[k], &slices[k + 1]);
        if g <= GAP_TOLERANCE_MM {
            return Err(bad(
                input,
                format!(
                    "{} and {} lie at the same position ({:.3} mm along the normal)",
                    a.path.display(),
                    b.path.display(),
                    along[k]
                ),
            ));
        }
        let tol = (median * GAP_TOLERANCE).max(GAP_TOLERANCE_MM);
        if (g - median).abs() > tol {
            let ratio = g / median;
            let whole = ratio.round();
            if whole >= 2.0 && (g - whole * median).abs() <= tol * whole {
                return Err(bad(
                    input,
                    format!(
                        "{} slice{} missing between {:.3} mm and {:.3} mm along the normal (gap {:.3} mm, spacing {:.3} mm; after {})",
                        whole as u64 - 1,
                        if whole as u64 == 2 { " is" } else { "s are" },
                        along[k],
                        along[k + 1],
                        g,
                        median,
                        a.path.display()
                    ),
                ));
            }
            return Err(bad(
                input,
                format!(
                    "uneven slice spacing: gap of {g:.3} mm between {} and {} where the series spaces slices {median:.3} mm apart",
                    a.path.display(),
                    b.path.display()
                ),
            ));
        }
    }
    Ok(median)
}

impl DicomReader {
    /// Slice `s`'s file, opened, from the one kept or opened anew (and
    /// kept).
    fn opened(&self, s: &SliceHeader) -> CResult<Arc<DefaultDicomObject>> {
        let kept = self.last_file.lock().ok().and_then(|c| {
            c.as_ref()
                .filter(|(p, _)| *p == s.path)
                .map(|(_, o)| o.clone())
        });
        if let Some(obj) = kept {
            return Ok(obj);
        }
        let obj = Arc::new(pixels::open(s)?);
        if let Ok(mut c) = self.last_file.lock() {
            *c = Some((s.path.clone(), obj.clone()));
        }
        Ok(obj)
    }
}

impl SliceReader for DicomReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        let s = self.slices.get(z as usize).ok_or_else(|| {
            bad(
                &self.info.path,
                format!("slice {z} out of range (internal error)"),
            )
        })?;
        let key = (s.path.clone(), s.pixels.frame);
        let cached = self.last_frame.lock().ok().and_then(|c| {
            c.as_ref()
                .filter(|(k, _)| *k == key)
                .map(|(_, f)| f.clone())
        });
        let frame = match cached {
            Some(f) => f,
            None => {
                let obj = self.opened(s)?;
                let f = Arc::new(pixels::frame_bytes(s, &obj)?);
                if let Ok(mut c) = self.last_frame.lock() {
                    *c = Some((key, f.clone()));
                }
                f
            }
        };
        pixels::slice_from_frame(s, &frame, self.info.sample_type)
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
    fn notes(&self) -> Vec<String> {
        let mut notes = skipped_notes(&self.info.path, &self.skipped);
        if let Some(p) = self.philips {
            notes.push(philips_note(&self.info.path, p));
        }
        notes
    }
    fn stored_type(&self) -> Option<SliceType> {
        (self.stored != self.info.sample_type).then_some(self.stored)
    }
    fn sidecar(&self) -> Option<serde_json::Map<String, serde_json::Value>> {
        self.slices.first().map(|s| (*s.sidecar).clone())
    }
}
