//! vol-info: describe a volume file and optionally verify its checksums.

use anyhow::Result;
use clap::Parser;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Dims, Layout, SampleType, Volume};
use volformats::dicom::{Scan, SeriesInfo};
use volformats::open::{input_kind, InputKind};
use volformats::vvol;
use volkit_cli::json;
use volkit_cli::{noteln, outln, Selection};

/// Describe a volume (any format vol-convert reads: .vvol, .vol, .raw,
/// NRRD, MetaImage, NIfTI, DICOM series, TIFF stacks, OME-Zarr, or - for a
/// stream on stdin) and check it: the header against the file length, the
/// brick table against the data and, with --verify, every checksum (for
/// formats without checksums, --verify reads every sample).
///
/// Prints dimensions, sample type, spacing, layout, value range, and the
/// geometry: the origin (world position of voxel 0,0,0), the direction of
/// each index axis in LPS patient coordinates, and its orientation code.
///
/// A DICOM input holding several series is listed instead (UID, number,
/// description, modality, images, dimensions), one series a line; pick
/// one with --series. Files that hold no image (a DICOMDIR, structured
/// reports, presentation states) are skipped, and counted on stderr.
#[derive(Parser, Debug)]
#[command(name = "vol-info", version, after_help = EXAMPLES)]
struct Cli {
    /// The volume, or - for a stream on stdin.
    input: PathBuf,
    /// Check every checksum (reads the whole file).
    #[arg(long)]
    verify: bool,
    #[command(flatten, next_help_heading = "Input")]
    input_sel: Selection,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Print nothing but errors: the exit status tells whether the volume
    /// reads (and verifies).
    #[arg(short, long)]
    quiet: bool,
}

const EXAMPLES: &str = "Examples:
  vol-info shapes.vvol
  vol-info --verify --json bricked.vvol
  vol-info brain.nii.gz
  vol-info ct-series/                  # one series: described; several: listed
  vol-info ct-series/ --series 3       # by SeriesNumber, or a unique UID prefix
  vol-info --json 'ct/*.dcm'
  vol-gen noise --dims 64,64,64 -o - | vol-info -
  vol-info --raw-dims 256,256,256 --raw-type u16 --raw-endian big scan.raw";

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-info") {
        Ok(c) => c,
        Err(code) => return code,
    };
    volkit_cli::run("vol-info", || info(&cli))
}

fn info(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let name = cli.input.display().to_string();
    let mut opts = volkit_cli::select::read_options(&cli.input_sel)?;
    opts.vvol = vvol::OpenOptions {
        verify: cli.verify,
        ..Default::default()
    };
    let kind = if cli.input.as_os_str() == "-" {
        None
    } else {
        Some(input_kind(&cli.input, &opts)?)
    };
    let mut format = kind.map(|k| k.name().to_string());
    let mut notes = Vec::new();
    let vol = if matches!(kind, Some(InputKind::DicomDir | InputKind::Dicom)) {
        use volformats::convert::SliceReader;
        let scan = volformats::open::dicom_scan(&cli.input, &opts)?;
        if cli.input_sel.series.is_none() && scan.series().len() > 1 {
            if !cli.quiet {
                for note in scan.notes() {
                    noteln!("vol-info: {note}");
                }
                list_series(cli, &scan, start.elapsed().as_secs_f64())?;
            }
            return Ok(());
        }
        let reader = scan.open(cli.input_sel.series.as_deref())?;
        // The words vol-convert uses: "dicom series (CT, 120 images)".
        format = Some(reader.info().format.clone());
        notes = reader.notes();
        volformats::open::load(Box::new(reader), None)?
    } else {
        volformats::open(&cli.input, &opts)?
    };
    let file_bytes = match kind {
        Some(_) if cli.input.is_file() => Some(std::fs::metadata(&cli.input)?.len()),
        _ => None,
    };
    // Formats without checksums: verifying reads every sample.
    if cli.verify && kind != Some(InputKind::Vvol) {
        let _ = vol.to_f32_vec();
    }
    if let Some(e) = vol.error() {
        anyhow::bail!("{name}: {e}");
    }
    if !cli.quiet {
        for note in &notes {
            noteln!("vol-info: {note}");
        }
        let format = format.as_deref().unwrap_or("stream");
        report(cli, &vol, format, file_bytes, start.elapsed().as_secs_f64())?;
    }
    Ok(())
}

fn report(
    cli: &Cli,
    vol: &Volume,
    format: &str,
    file_bytes: Option<u64>,
    seconds: f64,
) -> std::io::Result<()> {
    let m = &vol.meta.as_stored();
    let (brick, bricks) = match m.layout {
        Layout::Sliced => (None, None),
        Layout::Bricked(g) => (Some(g.brick()), Some(g.brick_count())),
    };
    if cli.json {
        let mut v = json!({
            "tool": "vol-info",
            "input": cli.input.display().to_string(),
            "format": format,
        });
        json::merge(&mut v, json::volume(m));
        json::merge(
            &mut v,
            json!({
                "brick": brick,
                "bricks": bricks,
                "bytes": file_bytes,
                "verified": cli.verify,
                "seconds": seconds,
            }),
        );
        return outln!("{v}");
    }
    outln!("{}: {} ({format})", cli.input.display(), m)?;
    if let Some(b) = file_bytes {
        match sample_bytes(m.dims, m.sample_type) {
            Some(samples) => outln!(
                "  {b} bytes on disk, {samples} bytes of samples ({:.3}x)",
                b as f64 / samples.max(1) as f64
            )?,
            None => outln!("  {b} bytes on disk, more than 2^64 bytes of samples")?,
        }
    }
    if let Some(n) = bricks {
        outln!("  {n} bricks")?;
    }
    if m.range.is_empty() {
        outln!("  values: none (all NaN)")?;
    } else {
        outln!("  values {} .. {}", m.range.min, m.range.max)?;
    }
    let g = &m.geometry;
    let o = g.origin;
    outln!("  origin {}, {}, {} (LPS)", o[0], o[1], o[2])?;
    let axes: Vec<String> = (0..3)
        .map(|a| {
            let v = g.axis(a);
            format!("({}, {}, {})", v[0], v[1], v[2])
        })
        .collect();
    outln!(
        "  directions i {} j {} k {}, orientation {}",
        axes[0],
        axes[1],
        axes[2],
        g.orientation()
    )?;
    if cli.verify {
        outln!("  verified in {seconds:.2} s")?;
    }
    Ok(())
}

/// The series of a DICOM input holding several: a table, or with --json
/// one object whose `series` lists them.
fn list_series(cli: &Cli, scan: &Scan, seconds: f64) -> std::io::Result<()> {
    let series = scan.series();
    if cli.json {
        let list: Vec<serde_json::Value> = series
            .iter()
            .map(|s| {
                json!({
                    "uid": s.uid,
                    "number": s.number,
                    "description": s.description,
                    "modality": s.modality,
                    "images": s.images,
                    "dims": s.dims,
                })
            })
            .collect();
        let v = json!({
            "tool": "vol-info",
            "input": cli.input.display().to_string(),
            "format": InputKind::DicomDir.name(),
            "series": list,
            "skipped": scan.skipped().len(),
            "seconds": seconds,
        });
        return outln!("{v}");
    }
    outln!(
        "{}: {} DICOM series; pick one with --series NUMBER or a unique UID prefix",
        cli.input.display(),
        series.len()
    )?;
    for line in series_table(&series) {
        outln!("  {line}")?;
    }
    Ok(())
}

/// The rows of the series table, the header first, columns padded.
fn series_table(series: &[SeriesInfo]) -> Vec<String> {
    // Text from the files: no control characters on the terminal.
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| if c.is_control() { '?' } else { c })
            .collect()
    };
    let mut rows = vec![[
        "UID".to_string(),
        "NUMBER".into(),
        "DESCRIPTION".into(),
        "MODALITY".into(),
        "IMAGES".into(),
        "DIMS".into(),
    ]];
    for s in series {
        rows.push([
            clean(&s.uid),
            s.number
                .map(|n| n.to_string())
                .unwrap_or_else(|| "-".into()),
            if s.description.is_empty() {
                "-".into()
            } else {
                clean(&s.description)
            },
            if s.modality.is_empty() {
                "-".into()
            } else {
                clean(&s.modality)
            },
            s.images.to_string(),
            format!("{}x{}x{}", s.dims[0], s.dims[1], s.dims[2]),
        ]);
    }
    let widths: Vec<usize> = (0..6)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    rows.iter()
        .map(|r| {
            r.iter()
                .zip(&widths)
                .map(|(cell, w)| format!("{cell:<w$}"))
                .collect::<Vec<_>>()
                .join("  ")
                .trim_end()
                .to_string()
        })
        .collect()
}

/// Bytes the samples of `dims` take as `t`, or `None` past 2^64: a
/// header's dims need not fit in the file (compressed bricks), so the
/// product is checked, not trusted.
fn sample_bytes(dims: Dims, t: SampleType) -> Option<u64> {
    dims.checked_count()?.checked_mul(t.size() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_bytes_of_huge_dims_is_none_not_an_overflow() {
        // 2^24 * 2^24 * 2^15 = 2^63 voxels: the count fits, the bytes do not.
        let d = Dims::new(1 << 24, 1 << 24, 1 << 15).unwrap();
        assert_eq!(sample_bytes(d, SampleType::U8), Some(1 << 63));
        assert_eq!(sample_bytes(d, SampleType::U16), None);
        assert_eq!(sample_bytes(d, SampleType::F32), None);
        let small = Dims::new(3, 4, 5).unwrap();
        assert_eq!(sample_bytes(small, SampleType::F32), Some(240));
    }
}
