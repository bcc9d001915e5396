//! `--series all`: every series of a DICOM export, after one header
//! scan, each into the file a naming template makes of it (dcm2niix's
//! `-f`): `-o 'out/{number}_{description}.nii.gz'`. A series of several
//! volumes is written as one 4D NIfTI (unless `--time-point T` picks one
//! of each). Series that cannot be read are listed with the reason; the
//! summary table says what was written.

use super::{convert_opened, prepare_output, time_series, usage_at, Cli};
use anyhow::{bail, Result};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;
use volformats::dicom::SeriesInfo;
use volformats::open::InputKind;
use volformats::{Selection, TimePoint};
use volkit_cli::{json, noteln};

/// The template's fields, as `-o` names them.
const FIELDS: &str = "{id}, {number}, {uid}, {description}, {modality}";

/// What became of one series.
enum Outcome {
    /// Written: its bytes.
    Written(u64),
    /// Not converted: the series' own problem (a missing slice, ...).
    Skipped(String),
    /// Its conversion failed: the error.
    Failed(String),
}

/// A template value as a file-name part: letters, digits, `.`, `-`, `+`
/// kept, every other run of characters one `_`, no leading or trailing
/// `.` or `_`, at most 64 characters (`none` when nothing is left).
fn name_part(v: &str) -> String {
    let mut out = String::new();
    for c in v.trim().chars() {
        if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+') {
            out.push(c);
        } else if !out.ends_with('_') {
            out.push('_');
        }
    }
    // No leading dot (a hidden file), no trailing separator.
    let out: String = out
        .trim_matches(|c| c == '_' || c == '.')
        .chars()
        .take(64)
        .collect();
    if out.is_empty() {
        "none".into()
    } else {
        out
    }
}

/// The output `template` names for series `s`.
fn fill(template: &str, s: &SeriesInfo) -> String {
    let number = s.number.map_or_else(|| s.id.clone(), |n| n.to_string());
    template
        .replace("{id}", &name_part(&s.id))
        .replace("{number}", &name_part(&number))
        .replace("{uid}", &name_part(&s.uid))
        .replace("{description}", &name_part(&s.description))
        .replace("{modality}", &name_part(&s.modality))
}

/// `path` with `_ID` before its extension (`.nii.gz` counts as one):
/// the name of a second series the template names the same.
fn with_id(path: &str, id: &str) -> String {
    let (stem, ext) = super::sidecar::split_extension(path);
    format!("{stem}_{}{ext}", name_part(id))
}

/// Convert every series of the DICOM input `input` as `cli` says.
pub fn convert_all_series(cli: &Cli, input: &Path) -> Result<()> {
    let start = Instant::now();
    let template = cli.output.to_string_lossy().into_owned();
    if template == "-" || cli.shard.is_some() {
        return Err(usage_at(
            &cli.output,
            "--series all writes one file per series: give a naming template, not - or --shard",
        ));
    }
    // A series of several volumes is one 4D file unless --time-point T
    // picks one volume of each.
    let pick_one = matches!(cli.input_sel.time_point, Some(TimePoint::At(_)));
    let base = Selection {
        series: None,
        time_point: cli.input_sel.time_point.filter(|_| pick_one),
        ..cli.input_sel.clone()
    };
    let opts = volkit_cli::select::read_options(&base, &[input])?;
    let kind = volformats::open::input_kind(input, &opts)?;
    if !matches!(kind, InputKind::DicomDir | InputKind::Dicom) {
        return Err(usage_at(
            input,
            format!(
                "--series all converts every series of a DICOM input; this is {}",
                kind.name()
            ),
        ));
    }
    let scan = volformats::open::dicom_scan(input, &opts)?;
    let series = scan.series();
    if series.len() > 1 && !template.contains('{') {
        return Err(usage_at(
            &cli.output,
            format!(
                "--series all writes {} series: name them with a template, e.g. -o 'out/{{number}}_{{description}}.nii.gz' ({FIELDS})",
                series.len()
            ),
        ));
    }
    let mut used = BTreeSet::new();
    let mut rows: Vec<(SeriesInfo, PathBuf, Outcome)> = Vec::new();
    let bar = volkit_cli::progress::count_bar(
        Some(series.len() as u64),
        "vol-convert",
        "series",
        cli.quiet,
    );
    for (k, s) in series.into_iter().enumerate() {
        bar.set_position(k as u64);
        let mut name = fill(&template, &s);
        if !used.insert(name.clone()) {
            name = with_id(&name, &s.id);
            used.insert(name.clone());
        }
        let out = PathBuf::from(&name);
        let outcome = match &s.problem {
            Some(p) => Outcome::Skipped(p.clone()),
            None => match convert_one(cli, input, &scan, &base, &s, &out, pick_one) {
                Ok(bytes) => Outcome::Written(bytes),
                Err(e) => Outcome::Failed(format!("{e:#}")),
            },
        };
        rows.push((s, out, outcome));
    }
    bar.finish_and_clear();
    summary(cli, input, &rows, scan.skipped().len(), start)?;
    let failed = rows
        .iter()
        .filter(|r| matches!(r.2, Outcome::Failed(_)))
        .count();
    let written = rows
        .iter()
        .filter(|r| matches!(r.2, Outcome::Written(_)))
        .count();
    if failed > 0 || written == 0 {
        bail!(
            "{}: {written} of {} series written, {failed} failed (the table above says why)",
            input.display(),
            rows.len()
        );
    }
    Ok(())
}

/// Convert series `s` into `out`; its bytes.
fn convert_one(
    cli: &Cli,
    input: &Path,
    scan: &volformats::dicom::Scan,
    base: &Selection,
    s: &SeriesInfo,
    out: &Path,
    pick_one: bool,
) -> Result<u64> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let sel = Selection {
        series: Some(s.id.clone()),
        ..base.clone()
    };
    let one = Cli {
        input_sel: sel.clone(),
        output: out.to_path_buf(),
        json: false,
        quiet: true,
        ..cli.clone()
    };
    if s.time_points > 1 && !pick_one {
        let four = Cli {
            input_sel: Selection {
                time_point: Some(TimePoint::All),
                ..sel
            },
            ..one
        };
        return Ok(time_series::convert(&four, input, Some(scan), out)?.bytes);
    }
    let opts = volkit_cli::select::read_options(&sel, &[input])?;
    let reader = scan.open(opts.dicom_pick())?;
    let (window, target) = prepare_output(&one, input)?;
    convert_opened(
        &one,
        input,
        Box::new(reader),
        window,
        target,
        Instant::now(),
    )?;
    Ok(std::fs::metadata(out).map(|m| m.len()).unwrap_or(0))
}

/// The table of what was written, skipped and failed (stderr), or
/// `--json`'s object.
fn summary(
    cli: &Cli,
    input: &Path,
    rows: &[(SeriesInfo, PathBuf, Outcome)],
    skipped_files: usize,
    start: Instant,
) -> Result<()> {
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let series: Vec<serde_json::Value> = rows
            .iter()
            .map(|(s, out, o)| {
                let (status, bytes, reason) = match o {
                    Outcome::Written(b) => ("written", Some(*b), None),
                    Outcome::Skipped(r) => ("skipped", None, Some(r.clone())),
                    Outcome::Failed(r) => ("failed", None, Some(r.clone())),
                };
                serde_json::json!({
                    "id": s.id,
                    "number": s.number,
                    "description": s.description,
                    "time_points": s.time_points,
                    "output": matches!(o, Outcome::Written(_)).then(|| out.display().to_string()),
                    "status": status,
                    "bytes": bytes,
                    "reason": reason,
                })
            })
            .collect();
        let v = serde_json::json!({
            "tool": "vol-convert",
            "input": input.display().to_string(),
            "series": series,
            "skipped_files": skipped_files,
            "seconds": seconds,
        });
        json::emit(&v, false)?;
        return Ok(());
    }
    if cli.quiet {
        return Ok(());
    }
    let written = rows
        .iter()
        .filter(|r| matches!(r.2, Outcome::Written(_)))
        .count();
    noteln!(
        "vol-convert: {} series in {seconds:.2} s: {written} written, {} not{}",
        rows.len(),
        rows.len() - written,
        if skipped_files > 0 {
            format!("; {skipped_files} files joined no series (vol-info lists them)")
        } else {
            String::new()
        }
    );
    // Series numbers are short; a UID (two series of one number) is
    // not padded for.
    let id_w = rows
        .iter()
        .map(|r| r.0.id.len())
        .filter(|&w| w <= 12)
        .max()
        .unwrap_or(2)
        .max(2);
    for (s, out, o) in rows {
        let what = match o {
            Outcome::Written(b) => format!("wrote {} ({b} bytes)", out.display()),
            Outcome::Skipped(r) => format!("skipped: {r}"),
            Outcome::Failed(r) => format!("failed: {r}"),
        };
        let description = volcore::text::clip(&s.description, 32);
        let text = volcore::text::escape(&format!("  {:<id_w$}  {description:<24}  {what}", s.id));
        noteln!("{text}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_file_safe_and_seconds_get_their_id() {
        assert_eq!(name_part(" t1_mprage/sag (3D) "), "t1_mprage_sag_3D");
        assert_eq!(name_part("../.."), "none");
        assert_eq!(name_part(""), "none");
        assert_eq!(with_id("out/5_loc.nii.gz", "5-2"), "out/5_loc_5-2.nii.gz");
        assert_eq!(with_id("out/5", "5-2"), "out/5_5-2");
        assert_eq!(with_id("a.b/name", "7"), "a.b/name_7");
    }
}
