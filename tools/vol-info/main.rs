//! vol-info: describe a volume file and optionally verify its checksums
//! or give its statistics.

mod stats;

use anyhow::Result;
use clap::Parser;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Dims, Layout, SampleType, Volume};
use volformats::dicom::{Scan, SeriesInfo, Skipped};
use volformats::open::{input_kind, InputKind};
use volformats::stacks::Stacks;
use volformats::tiff::ChannelSel;
use volformats::vvol;
use volkit_cli::json;
use volkit_cli::{outln, Selection};

mod levels;
mod listing;

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
/// An input with several channels or time points (colour TIFF, ImageJ
/// hyperstack, OME-TIFF, OME-Zarr, 4D NIfTI) is described without a
/// selection too: its first channel at its first time point, with the
/// number of channels and time points, the time step where the file
/// states it, and the flags that pick another (--channel, --time-point).
///
/// An OME-Zarr pyramid is described at its full resolution (or the level
/// --level N picks), with every level's dimensions and spacing.
///
/// A DICOM input holding several series is listed instead (UID, number,
/// description, modality, images, dimensions), one series a line, with
/// what keeps a series from reading as a volume; pick one with --series.
/// Files that join no series (a DICOMDIR, reports, images without
/// ImagePositionPatient, multi-frame or colour images, damaged files)
/// are skipped and listed after the description or the series, each with
/// its reason; the exit status is 0 while some series reads.
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
    #[command(flatten, next_help_heading = "Statistics")]
    stats: stats::StatsFlags,
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
  vol-info cells.ome.tif               # channels: 2, time points: 5; described: channel 0, time point 0
  vol-info cells.ome.tif --channel 1 --time-point 4
  vol-info cells.ome.zarr              # pyramid levels: their dims and spacing
  vol-info cells.ome.zarr --level 2    # describe level 2
  vol-info ct-series/                  # one series: described; several: listed
  vol-info ct-series/ --series 3       # by SeriesNumber, or a unique UID prefix
  vol-info --json 'ct/*.dcm'
  vol-info --stats scan.nii.gz         # count, min, max, mean, SD, percentiles, histogram
  vol-info --stats --json --bins 64 scan.nii.gz
  vol-info brain.nii.gz --mask brain-mask.nii.gz          # the same inside the mask
  vol-info ct.nrrd --labels seg.nrrd   # per label: voxels, volume (mm³), mean, SD, min, max
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
    let mut opts = volkit_cli::select::read_options(&cli.input_sel, &[&cli.input])?;
    opts.vvol = vvol::OpenOptions {
        verify: cli.verify,
        ..Default::default()
    };
    let kind = if cli.input.as_os_str() == "-" {
        None
    } else {
        Some(input_kind(&cli.input, &opts)?)
    };
    // The channels and time points of the file, whatever is selected.
    // Without a selection the first channel and time point are described.
    let stacks = match kind {
        None | Some(InputKind::DicomDir | InputKind::Dicom) => Ok(Stacks::default()),
        Some(_) => volformats::open::stacks(&cli.input, &opts),
    };
    let sizes = stacks.as_ref().copied().unwrap_or_default();
    let sel = &cli.input_sel;
    if sizes.channels > 1 && sel.channel.is_none() {
        opts.channel = ChannelSel::Channel(0);
    }
    if sizes.time_points > 1 && sel.time_index().is_none() {
        opts.time = Some(0);
    }
    // A DICOM input's skipped files, listed after the description.
    let mut skipped = None;
    // A DICOM series' time points and echoes, from its scan.
    let mut dicom_sizes = None;
    // The format named as vol-convert names it (the reader's words:
    // "dicom series (CT, 120 images)", "nifti-1 (nii, gzip)").
    let (vol, format) = if matches!(kind, Some(InputKind::DicomDir | InputKind::Dicom)) {
        use volformats::convert::SliceReader;
        let scan = volformats::open::dicom_scan(&cli.input, &opts)?;
        if cli.input_sel.series.is_none() && scan.series().len() > 1 {
            scan.check_readable()?;
            if !cli.quiet {
                list_series(cli, &scan, start.elapsed().as_secs_f64())?;
            }
            return Ok(());
        }
        skipped = Some(scan.skipped().to_vec());
        // A series of several volumes: the first is described, with the
        // sizes of its axes.
        let series = scan.info(sel.series.as_deref())?;
        dicom_sizes = Some(Stacks {
            time_points: series.time_points,
            echoes: series.echoes,
            time_step: series.time_step,
            time_unit: series
                .time_step
                .map(|_| volformats::stacks::TimeUnit::Second),
            ..Stacks::default()
        });
        let echo = sel.echo.or((series.echoes > 1).then_some(0));
        let time = sel.time_index().or((series.time_points > 1).then_some(0));
        let reader = scan.open(volformats::dicom::Pick {
            echo,
            time,
            ..opts.dicom_pick()
        })?;
        let format = reader.info().format.clone();
        (volformats::open::load(Box::new(reader), None)?, format)
    } else {
        volformats::open::open_described(&cli.input, &opts)?
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
    // The reader's error, when there is one, came first: it says more.
    // Along an axis of one, any pick the reader let pass read the one.
    let sizes = match dicom_sizes {
        Some(s) => s,
        None => stacks?,
    };
    let described = Described {
        sizes,
        channel: sel
            .channel
            .map_or(0, u64::from)
            .min(sizes.channels.saturating_sub(1)),
        time_point: sel
            .time_index()
            .unwrap_or(0)
            .min(sizes.time_points.saturating_sub(1)),
        echo: sel.echo.unwrap_or(0).min(sizes.echoes.saturating_sub(1)),
        channel_given: sel.channel.is_some(),
        time_point_given: sel.time_index().is_some(),
        echo_given: sel.echo.is_some(),
    };
    let levels = match kind {
        Some(InputKind::OmeZarr) => Some(levels::Levels {
            all: volformats::omezarr::levels(&cli.input)?,
            level: sel.level.unwrap_or(0),
            given: sel.level.is_some(),
        }),
        _ => None,
    };
    let figures = stats::compute(&cli.input, &opts, &vol, &cli.stats, cli.quiet)?;
    if !cli.quiet {
        let found = Found {
            format: &format,
            file_bytes,
            skipped: skipped.as_deref(),
            levels: levels.as_ref(),
            seconds: start.elapsed().as_secs_f64(),
            stats: figures.as_ref().map(stats::Figures::json),
        };
        report(cli, &vol, &described, found)?;
        if let (Some(f), false) = (&figures, cli.json) {
            f.print()?;
        }
    }
    Ok(())
}

/// The channels and time points of the input and the one volume of them
/// described.
struct Described {
    sizes: Stacks,
    channel: u64,
    time_point: u64,
    echo: u64,
    channel_given: bool,
    time_point_given: bool,
    echo_given: bool,
}

impl Described {
    /// Whether the input holds more than one volume.
    fn several(&self) -> bool {
        self.sizes.channels > 1 || self.sizes.time_points > 1 || self.sizes.echoes > 1
    }

    /// The `channels`, `time_points`, `echoes`, `time_step`, `time_unit`,
    /// `channel`, `time_point` and `echo` keys: present for every input
    /// (1, 1, 1, null, null, 0, 0, 0 for a single volume).
    fn json(&self) -> serde_json::Value {
        let s = &self.sizes;
        json!({
            "channels": s.channels,
            "time_points": s.time_points,
            "echoes": s.echoes,
            "time_step": s.time_step,
            "time_unit": s.time_unit.map(|u| u.ngff_name()),
            "channel": self.channel,
            "time_point": self.time_point,
            "echo": self.echo,
        })
    }

    /// The text lines (without indent): none for a single volume; else
    /// the sizes, the time step, and which volume is described with the
    /// flags that pick another.
    fn lines(&self) -> Vec<String> {
        let s = &self.sizes;
        if !self.several() {
            return Vec::new();
        }
        let step = match (s.time_step, s.time_unit) {
            (Some(v), Some(u)) => format!(" (step {v} {})", u.symbol()),
            (Some(v), None) => format!(" (step {v}, no unit stated)"),
            _ => String::new(),
        };
        let mut which = Vec::new();
        let mut flags = Vec::new();
        if s.channels > 1 {
            which.push(format!("channel {}", self.channel));
            if !self.channel_given {
                flags.push("--channel C");
            }
        }
        if s.time_points > 1 {
            which.push(format!("time point {}", self.time_point));
            if !self.time_point_given {
                flags.push("--time-point T");
            }
        }
        if s.echoes > 1 {
            which.push(format!("echo {}", self.echo));
            if !self.echo_given {
                flags.push("--echo E");
            }
        }
        let mut described = format!("described: {}", which.join(", "));
        if !flags.is_empty() {
            described.push_str(&format!("; pick another with {}", flags.join(", ")));
        }
        let mut lines = vec![
            format!("channels: {}", s.channels),
            format!("time points: {}{step}", s.time_points),
        ];
        if s.echoes > 1 {
            lines.push(format!("echoes: {}", s.echoes));
        }
        lines.push(described);
        lines
    }

    /// Volumes the file holds (C x T x E), saturating.
    fn volumes(&self) -> u64 {
        self.sizes
            .channels
            .saturating_mul(self.sizes.time_points)
            .saturating_mul(self.sizes.echoes)
    }
}

/// What reading the input found, beside the volume itself.
struct Found<'a> {
    /// The input's format name.
    format: &'a str,
    /// The file's size, when it is one file.
    file_bytes: Option<u64>,
    /// DICOM files in the folder that joined no series.
    skipped: Option<&'a [Skipped]>,
    /// An OME-Zarr input's pyramid levels.
    levels: Option<&'a levels::Levels>,
    /// Seconds the reading (and verifying) took.
    seconds: f64,
    /// --stats: the figures, as JSON.
    stats: Option<serde_json::Value>,
}

/// Describe the volume: one JSON object with --json, else lines of text.
fn report(cli: &Cli, vol: &Volume, described: &Described, found: Found) -> std::io::Result<()> {
    let Found {
        format,
        file_bytes,
        skipped,
        levels,
        seconds,
        stats,
    } = found;
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
        json::merge(&mut v, described.json());
        json::merge(&mut v, levels::Levels::json(levels));
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
        if let Some(s) = skipped {
            json::merge(
                &mut v,
                json!({ "skipped": listing::skipped_json(&cli.input, s) }),
            );
        }
        if let Some(stats) = stats {
            json::merge(&mut v, stats);
        }
        return outln!("{v}");
    }
    outln!("{}: {} ({format})", cli.input.display(), m)?;
    for line in described.lines() {
        outln!("  {line}")?;
    }
    for line in levels.map(levels::Levels::lines).unwrap_or_default() {
        outln!("  {line}")?;
    }
    if let Some(b) = file_bytes {
        // The samples of every channel and time point the file holds.
        let all =
            sample_bytes(m.dims, m.sample_type).and_then(|n| n.checked_mul(described.volumes()));
        match all {
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
    for line in listing::skipped_lines(&cli.input, skipped.unwrap_or_default()) {
        outln!("  {line}")?;
    }
    Ok(())
}

/// The series of a DICOM input holding several: a table with a line for
/// each series that cannot be read, then the skipped files; or with
/// --json one object whose `series` and `skipped` list them.
fn list_series(cli: &Cli, scan: &Scan, seconds: f64) -> std::io::Result<()> {
    let series = scan.series();
    if cli.json {
        let list: Vec<serde_json::Value> = series
            .iter()
            .map(|s| {
                json!({
                    "id": s.id,
                    "uid": s.uid,
                    "number": s.number,
                    "sub": s.sub,
                    "description": s.description,
                    "modality": s.modality,
                    "images": s.images,
                    "dims": s.dims,
                    "time_points": s.time_points,
                    "echoes": s.echoes,
                    "time_step": s.time_step,
                    "volumes": s.volumes,
                    "problem": s.problem,
                })
            })
            .collect();
        let v = json!({
            "tool": "vol-info",
            "input": cli.input.display().to_string(),
            "format": InputKind::DicomDir.name(),
            "series": list,
            "skipped": listing::skipped_json(&cli.input, scan.skipped()),
            "seconds": seconds,
        });
        return outln!("{v}");
    }
    outln!(
        "{}: {} DICOM series; pick one with --series ID (or its UID, or a unique UID prefix)",
        cli.input.display(),
        series.len()
    )?;
    for line in series_table(&series) {
        outln!("  {line}")?;
    }
    for s in &series {
        if let Some(p) = &s.problem {
            outln!(
                "  {} cannot be read: {}",
                volcore::text::escape(&s.describe()),
                volcore::text::escape(p)
            )?;
        }
    }
    for line in listing::skipped_lines(&cli.input, scan.skipped()) {
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
        "ID".to_string(),
        "UID".into(),
        "NUMBER".into(),
        "DESCRIPTION".into(),
        "MODALITY".into(),
        "IMAGES".into(),
        "DIMS".into(),
        "VOLUMES".into(),
    ]];
    for s in series {
        rows.push([
            clean(&s.id),
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
            if s.volumes.is_empty() {
                "1".into()
            } else {
                s.volumes.clone()
            },
        ]);
    }
    listing::columns(&rows)
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
