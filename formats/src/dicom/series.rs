//! Series scanning: each file's header read up to its pixel data, each
//! file that cannot join a series skipped with its reason, the images
//! grouped by series and each series checked as a volume, and one series
//! picked by `--series`.

use super::header::{read_file, SliceHeader};
use super::skip::{skipped_brief, SkipReason, Skipped};
use super::{bad, DicomReader};
use crate::reader::{CResult, ConvertError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
        let headers: Vec<(&PathBuf, Result<Vec<SliceHeader>, SkipReason>)> =
            files.par_iter().map(|f| (f, read_file(f))).collect();
        let mut by_series: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for (path, h) in headers {
            match h {
                Ok(slices) => {
                    for h in slices {
                        by_series.entry(h.series.clone()).or_default().push(h);
                    }
                }
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
