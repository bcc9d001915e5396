//! Files of a DICOM input that join no series: why each was skipped, and
//! the one-line summaries the tools print of them.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a file of a DICOM input joins no series. Text taken from the file
/// (a transfer syntax UID, a photometric interpretation) is escaped when
/// the reason is made, so it never reaches a terminal raw.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SkipReason {
    /// No DICOM Part 10 file: no `DICM` after the 128-byte preamble.
    NotDicom,
    /// The file cannot be opened or read (the system's error).
    Unreadable(String),
    /// Truncated or damaged: dicom-rs cannot read it, or an element claims
    /// more bytes than the file holds (the detail).
    Damaged(String),
    /// It holds no image: a DICOMDIR, or an object of the SOP class named.
    NoImage(String),
    /// A multi-frame image without per-frame functional groups (its
    /// NumberOfFrames): no frame states where it lies.
    MultiFrame(u32),
    /// A transfer syntax this build cannot decode: its UID and, when the
    /// registry knows it, its name.
    TransferSyntax {
        /// The transfer syntax UID.
        uid: String,
        /// Its name, `None` for a UID dicom-rs does not know.
        name: Option<String>,
    },
    /// A colour image (samples per pixel or the photometric
    /// interpretation, as the file states them).
    Colour(String),
    /// An image without an attribute every slice of a volume needs (its
    /// name: `SeriesInstanceUID`, `ImagePositionPatient`, ...).
    Missing(&'static str),
    /// An image whose values volkit cannot use (the detail: BitsAllocated,
    /// a rescale of slope 0, positions that are not finite, ...).
    Unsupported(String),
}

impl SkipReason {
    /// A stable key per variant, for JSON: `not-dicom`, `unreadable`,
    /// `damaged`, `no-image`, `multi-frame`, `transfer-syntax`, `colour`,
    /// `missing`, `unsupported`.
    pub fn key(&self) -> &'static str {
        match self {
            SkipReason::NotDicom => "not-dicom",
            SkipReason::Unreadable(_) => "unreadable",
            SkipReason::Damaged(_) => "damaged",
            SkipReason::NoImage(_) => "no-image",
            SkipReason::MultiFrame(_) => "multi-frame",
            SkipReason::TransferSyntax { .. } => "transfer-syntax",
            SkipReason::Colour(_) => "colour",
            SkipReason::Missing(_) => "missing",
            SkipReason::Unsupported(_) => "unsupported",
        }
    }

    /// The short words summaries count files under: `DICOMDIR`, `no
    /// ImagePositionPatient`, `truncated or damaged`, `transfer syntax
    /// JPEG 2000 Image Compression`, ...
    pub fn label(&self) -> String {
        match self {
            SkipReason::NotDicom => "not DICOM".into(),
            SkipReason::Unreadable(_) => "unreadable".into(),
            SkipReason::Damaged(_) => "truncated or damaged".into(),
            SkipReason::NoImage(what) => what.clone(),
            SkipReason::MultiFrame(_) => "multi-frame".into(),
            SkipReason::TransferSyntax { uid, name } => {
                format!("transfer syntax {}", name.as_deref().unwrap_or(uid))
            }
            SkipReason::Colour(_) => "colour".into(),
            SkipReason::Missing(what) => format!("no {what}"),
            SkipReason::Unsupported(_) => "unsupported".into(),
        }
    }
}

impl fmt::Display for SkipReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SkipReason::NotDicom => write!(f, "not a DICOM file (no DICM marker at byte 128)"),
            SkipReason::Unreadable(e) => write!(f, "unreadable: {e}"),
            SkipReason::Damaged(e) => write!(f, "truncated or damaged (dicom-rs cannot read it): {e}"),
            SkipReason::NoImage(what) => write!(f, "holds no image: {what}"),
            SkipReason::MultiFrame(n) => write!(
                f,
                "multi-frame image ({n} frames) without per-frame functional groups: no frame states its position (volkit reads enhanced multi-frame images and series of single-frame images)"
            ),
            SkipReason::TransferSyntax { uid, name: Some(name) } => write!(
                f,
                "transfer syntax {name} ({uid}) cannot be decoded by volkit: convert it to an uncompressed, RLE, JPEG, JPEG-LS or JPEG 2000 transfer syntax first (e.g. with gdcmconv --raw)"
            ),
            SkipReason::TransferSyntax { uid, name: None } => {
                write!(f, "unknown transfer syntax {uid}")
            }
            SkipReason::Colour(what) => {
                write!(f, "colour image ({what}): volkit reads grey images")
            }
            SkipReason::Missing(what) => write!(f, "image without {what}"),
            SkipReason::Unsupported(what) => write!(f, "{what}"),
        }
    }
}

/// A file of a DICOM input that joins no series, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// Why it was skipped.
    pub reason: SkipReason,
}

/// `3 files (1 DICOMDIR, 2 no ImagePositionPatient)`: how many files were
/// skipped, counted by [`SkipReason::label`].
pub(super) fn skipped_summary(skipped: &[Skipped]) -> String {
    let mut kinds: BTreeMap<String, usize> = BTreeMap::new();
    for s in skipped {
        *kinds.entry(s.reason.label()).or_default() += 1;
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

/// The summary of [`skipped_summary`] with the first file named: `2 files
/// (...; first: dose.dcm: image without ImagePositionPatient)`, for errors.
pub(super) fn skipped_brief(input: &Path, skipped: &[Skipped]) -> String {
    let summary = skipped_summary(skipped);
    match skipped.first() {
        Some(s) => format!(
            "{}; first: {}: {})",
            summary.trim_end_matches(')'),
            volcore::text::escape(&shown(input, &s.path)),
            s.reason
        ),
        None => summary,
    }
}

/// `path` as a listing shows it: relative to the input directory when it
/// lies in it, else whole.
pub fn shown(input: &Path, path: &Path) -> String {
    path.strip_prefix(input)
        .ok()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(path)
        .display()
        .to_string()
}

/// `input: skipped 2 files (...) that join no series; vol-info INPUT lists
/// them`, or nothing.
pub(super) fn skipped_notes(input: &Path, skipped: &[Skipped]) -> Vec<String> {
    if skipped.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "{}: skipped {} that join{} no series; vol-info {} lists each with its reason",
        input.display(),
        skipped_summary(skipped),
        if skipped.len() == 1 { "s" } else { "" },
        input.display()
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_count_by_label_and_name_the_first_file() {
        let dir = Path::new("/d");
        let s = vec![
            Skipped {
                path: dir.join("dose.dcm"),
                reason: SkipReason::Missing("ImagePositionPatient"),
            },
            Skipped {
                path: dir.join("DICOMDIR"),
                reason: SkipReason::NoImage("DICOMDIR".into()),
            },
            Skipped {
                path: dir.join("b.dcm"),
                reason: SkipReason::Missing("ImagePositionPatient"),
            },
        ];
        assert_eq!(
            skipped_summary(&s),
            "3 files (1 DICOMDIR, 2 no ImagePositionPatient)"
        );
        assert_eq!(
            skipped_brief(dir, &s),
            "3 files (1 DICOMDIR, 2 no ImagePositionPatient; first: dose.dcm: image without ImagePositionPatient)"
        );
        assert!(skipped_notes(dir, &[]).is_empty());
        assert_eq!(shown(dir, Path::new("/e/x.dcm")), "/e/x.dcm");
    }
}
