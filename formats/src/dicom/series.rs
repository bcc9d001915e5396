//! Series scanning: each file's header read up to its pixel data, each
//! file that cannot join a series skipped with its reason, the images
//! grouped by series and each series checked as a volume, and one series
//! picked by `--series`.

use super::header::{read_file, SliceHeader};
use super::skip::{skipped_brief, SkipReason, Skipped};
use super::volumes::{self, Volumes};
use super::{bad, DicomReader, PhilipsScale, Pick};
use crate::reader::{CResult, ConvertError};
use crate::rescale::Rescale;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One series of a DICOM input, as listed: a SeriesInstanceUID with
/// its SeriesNumber, or a sub-series of one (images of one size,
/// orientation and pixel type, where the series mixes several: a
/// localizer beside the scan).
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesInfo {
    /// What `--series` takes to pick this one alone: the SeriesNumber
    /// (or the UID where no number, or the number of several UIDs), with
    /// `-K` for sub-series K (from 1) of a mixed series.
    pub id: String,
    /// SeriesInstanceUID.
    pub uid: String,
    /// SeriesNumber, when the files give one.
    pub number: Option<i64>,
    /// The sub-series (from 1), when the series mixes images that cannot
    /// share a volume.
    pub sub: Option<usize>,
    /// SeriesDescription (empty when none).
    pub description: String,
    /// Modality (empty when none).
    pub modality: String,
    /// Images (slices: a mosaic file holds several, as does a
    /// multi-frame one).
    pub images: usize,
    /// Columns, rows and slices of one volume.
    pub dims: [u64; 3],
    /// Echoes (1 when echoes are no axis of their own).
    pub echoes: u64,
    /// Time points (volumes per echo).
    pub time_points: u64,
    /// Seconds between time points (RepetitionTime of a time series).
    pub time_step: Option<f64>,
    /// What the volumes are, `120 time points (by AcquisitionNumber), TR
    /// 2 s`; empty for one volume.
    pub volumes: String,
    /// Why the series cannot be read as volumes (missing slices, gantry
    /// tilt, slices no attribute tells apart, ...), the error opening it
    /// gives; `None` when it can.
    pub problem: Option<String>,
}

impl SeriesInfo {
    /// `3 UID (CT, 10 images of 16x12)`, for messages: the id first.
    pub fn describe(&self) -> String {
        format!(
            "{}{} ({}{} images of {}x{}{})",
            if self.id == self.uid {
                String::new()
            } else {
                format!("#{} ", self.id)
            },
            self.uid,
            if self.modality.is_empty() {
                String::new()
            } else {
                format!("{}, ", self.modality)
            },
            self.images,
            self.dims[0],
            self.dims[1],
            if self.volumes.is_empty() {
                String::new()
            } else {
                format!(", {}", self.volumes)
            }
        )
    }
}

/// Whether two slices can share a volume: one size, orientation, pixel
/// spacing, pixel type and (in an enhanced file) stack.
fn same_shape(a: &SliceHeader, b: &SliceHeader) -> bool {
    (a.rows, a.cols, a.bits_allocated, a.signed) == (b.rows, b.cols, b.bits_allocated, b.signed)
        && a.stack == b.stack
        && !super::differ(&a.orientation, &b.orientation)
        && !super::differ(&a.pixel_spacing, &b.pixel_spacing)
}

/// `slices` of one series split into groups that can each share a
/// volume, the largest first (the scan before its localizer).
fn sub_series(slices: Vec<SliceHeader>) -> Vec<Vec<SliceHeader>> {
    let mut groups: Vec<Vec<SliceHeader>> = Vec::new();
    for s in slices {
        match groups.iter_mut().find(|g| same_shape(&g[0], &s)) {
            Some(g) => g.push(s),
            None => groups.push(vec![s]),
        }
    }
    // Stable: equal sizes keep the order of their first file.
    groups.sort_by_key(|g| std::cmp::Reverse(g.len()));
    groups
}

/// The files of a DICOM input read up to their pixel data: the images
/// grouped by series (SeriesInstanceUID and SeriesNumber; in order of
/// SeriesNumber, then UID), split into sub-series and volumes, each
/// checked, and the files skipped with their reasons.
pub struct Scan {
    input: PathBuf,
    series: Vec<(SeriesInfo, CResult<Volumes>)>,
    skipped: Vec<Skipped>,
}

/// An error about the input as a whole.
fn problem_text(input: &Path, e: &ConvertError) -> String {
    // The input is named once, by whoever prints the problem.
    if e.path == input {
        e.error.to_string()
    } else {
        e.to_string()
    }
}

impl Scan {
    /// Read the headers of `files` (from `input`, named in errors). A file
    /// that cannot join a series is skipped, with its reason; an input
    /// none of whose files joins one is an error naming the first.
    pub fn new(input: &Path, files: &[PathBuf]) -> CResult<Scan> {
        use rayon::prelude::*;
        let headers: Vec<(&PathBuf, Result<Vec<SliceHeader>, SkipReason>)> =
            files.par_iter().map(|f| (f, read_file(f))).collect();
        let mut by_series: BTreeMap<(String, Option<i64>), Vec<SliceHeader>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for (path, h) in headers {
            match h {
                Ok(slices) => {
                    for h in slices {
                        by_series
                            .entry((h.series.clone(), h.series_number))
                            .or_default()
                            .push(h);
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
        // A number names a series alone only when no other UID has it.
        let mut uids_of_number: BTreeMap<i64, usize> = BTreeMap::new();
        for (_, n) in by_series.keys() {
            if let Some(n) = n {
                *uids_of_number.entry(*n).or_default() += 1;
            }
        }
        let mut series: Vec<(SeriesInfo, CResult<Volumes>)> = Vec::new();
        for ((uid, number), v) in by_series {
            let base = match number {
                Some(n) if uids_of_number.get(&n) == Some(&1) => n.to_string(),
                _ => uid.clone(),
            };
            let subs = sub_series(v);
            let several = subs.len() > 1;
            for (k, v) in subs.into_iter().enumerate() {
                let first = &v[0];
                let mut info = SeriesInfo {
                    id: if several {
                        format!("{base}-{}", k + 1)
                    } else {
                        base.clone()
                    },
                    sub: several.then_some(k + 1),
                    number,
                    description: first.description.clone(),
                    modality: first.modality.clone(),
                    images: v.len(),
                    dims: [first.cols as u64, first.rows as u64, v.len() as u64],
                    echoes: 1,
                    time_points: 1,
                    time_step: None,
                    volumes: String::new(),
                    uid: uid.clone(),
                    problem: None,
                };
                let split = volumes::split(v).map_err(|e| bad(input, e));
                // The first volume stands for all: they cover the same
                // positions.
                let checked = split.and_then(|vols| {
                    DicomReader::new(input, vols.volumes[0].clone())?;
                    Ok(vols)
                });
                match &checked {
                    Ok(vols) => {
                        info.dims[2] = vols.volumes[0].len() as u64;
                        info.echoes = vols.echoes as u64;
                        info.time_points = vols.time_points as u64;
                        info.time_step = vols.time_step;
                        if vols.volumes.len() > 1 {
                            info.volumes = vols.describe();
                        }
                    }
                    Err(e) => info.problem = Some(problem_text(input, e)),
                }
                series.push((info, checked));
            }
        }
        series
            .sort_by(|a, b| (a.0.number, &a.0.uid, a.0.sub).cmp(&(b.0.number, &b.0.uid, b.0.sub)));
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

    /// The index of the series `sel` names, tried in this order: its id
    /// (as listed: `3`, `3-2`), its whole UID (with `-K` for a
    /// sub-series), its SeriesNumber, a prefix of one UID only; with
    /// `None`, the only series. Anything else is an error listing the
    /// candidates.
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
        let exact = |i: &usize| {
            let s = &self.series[*i].0;
            s.id == sel || s.sub.is_some_and(|k| format!("{}-{k}", s.uid) == sel)
        };
        if let Some(i) = all.iter().copied().find(exact) {
            return Ok(i);
        }
        let pick = |found: Vec<usize>, how: &str| -> CResult<Option<usize>> {
            match found.len() {
                0 => Ok(None),
                1 => Ok(Some(found[0])),
                n => Err(bad(
                    &self.input,
                    format!(
                        "--series {sel} is ambiguous: {n} series {how}: {}; give the id vol-info lists (or more of the UID)",
                        list(&found)
                    ),
                )),
            }
        };
        let found = all
            .iter()
            .copied()
            .filter(|&i| self.series[i].0.uid == sel)
            .collect();
        if let Some(i) = pick(found, "have this UID")? {
            return Ok(i);
        }
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

    /// The series `sel` names (see [`Scan::select`]).
    pub fn info(&self, sel: Option<&str>) -> CResult<&SeriesInfo> {
        Ok(&self.series[self.select(sel)?].0)
    }

    /// Open the volume `pick` names of the series it names (see
    /// [`Scan::select`]), whatever else the input holds: only the
    /// series' own problem is an error, with the files skipped named after
    /// it (one of them may be its missing slice). A series of several
    /// volumes needs a time point (and an echo where echoes are an axis).
    /// The scan is kept: one scan opens every series of a folder
    /// (`vol-convert --series all`) and every volume of a series.
    pub fn open(&self, pick: Pick) -> CResult<DicomReader> {
        let Pick {
            series: sel,
            echo,
            time,
            philips,
        } = pick;
        let i = self.select(sel)?;
        let volumes = match &self.series[i].1 {
            Ok(v) => Ok(v),
            Err(e) => Err(ConvertError::new(
                &e.path,
                crate::error::Error::invalid(e.error.to_string()),
            )),
        };
        let reader = volumes.and_then(|v| {
            let mut slices = v
                .pick(echo, time)
                .map_err(|e| bad(&self.input, e))?
                .to_vec();
            let scaled = slices.iter().any(|s| s.philips_scale.is_some());
            if philips == PhilipsScale::Precise {
                for s in &mut slices {
                    s.rescale = precise(s)
                        .ok_or_else(|| bad(&s.path, "--philips-scale precise: the file states no usable private scale slope (2005,100E) with its RescaleSlope"))?;
                }
            }
            let mut r = DicomReader::new(&self.input, slices)?;
            r.philips = scaled.then_some(philips);
            if v.volumes.len() > 1 {
                let mut at = Vec::new();
                if v.echoes > 1 {
                    at.push(format!("echo {} of {}", echo.unwrap_or(0), v.echoes));
                }
                if v.time_points > 1 {
                    at.push(format!(
                        "time point {} of {}",
                        time.unwrap_or(0),
                        v.time_points
                    ));
                }
                r.info.format = format!(
                    "{}, {})",
                    r.info.format.trim_end_matches(')'),
                    at.join(", ")
                );
            }
            Ok(r)
        });
        match reader {
            Ok(mut r) => {
                r.skipped = self.skipped.clone();
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

/// Slice `s`'s map to Philips' precise values: (stored x RS + RI) / (RS x
/// SS), for its private scale slope SS; `None` without a usable one.
fn precise(s: &SliceHeader) -> Option<Rescale> {
    let ss = s.philips_scale?;
    let d = s.rescale.slope * ss;
    (d.is_finite() && d != 0.0).then(|| Rescale {
        slope: 1.0 / ss,
        intercept: s.rescale.intercept / d,
    })
}
