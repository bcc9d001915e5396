//! vol-psnr: how far apart two images or two volumes are (PSNR, MSE,
//! maximum error, differing elements), for people and for scripts.

use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use volcompare::image::image_extension;
use volcompare::{
    compare_images, compare_volumes, write_heatmap, Image, ImageComparison, ImageOptions, Metrics,
    VolumeComparison, VolumeOptions,
};
use volkit_cli::{noteln, outln, Selection};

/// Exit status: an input could not be read, or --diff not written.
const EXIT_READ: u8 = 1;
/// Exit status: usage error (clap's own, or options that do not fit).
const EXIT_USAGE: u8 = 2;
/// Exit status: the inputs cannot be compared.
const EXIT_MISMATCH: u8 = 3;
/// Exit status: the PSNR is below --min-psnr.
const EXIT_BELOW: u8 = 4;
/// Exit status: standard output was closed by its reader (nothing printed).
const EXIT_BROKEN_PIPE: u8 = volkit_cli::run::EXIT_BROKEN_PIPE;

/// Compare two images or two volumes: PSNR, MSE, maximum absolute error,
/// and how many elements differ.
///
/// A is the reference, B the candidate. Images are .png (8 or 16-bit; grey,
/// grey+alpha, RGB, RGBA), .pfm or .exr (float); volumes are anything
/// vol-convert reads (.vvol, .vol, .raw, NRRD, MetaImage, NIfTI, DICOM
/// series, TIFF stacks, OME-Zarr, or - for a stream on stdin). Both inputs must be of the same
/// kind and size; images also of the same sample type and colour channels.
///
/// Conventions: MSE is the mean of (a − b)² over every compared value,
/// pooled over the colour channels (alpha is ignored unless --alpha), in
/// f64. PSNR = 10·log10(peak² / MSE) with peak = the data range: 255 for
/// 8-bit, 65535 for 16-bit, 1.0 for float images; for volumes the
/// reference's type range (255 u8, 65535 u16 and i16) or, for f32, its
/// value range max − min; --range R overrides all. Identical inputs give
/// PSNR = inf (JSON: "psnr": null, "identical": true). For 8-bit RGB this is
/// scikit-image's peak_signal_noise_ratio. NaN equals NaN; a difference
/// that is not finite counts as differing, is left out of MSE and max,
/// is counted as "not finite" (JSON: "nonfinite") and fails --min-psnr.
/// Volume samples of any type are compared as their values.
#[derive(Parser, Debug)]
#[command(name = "vol-psnr", version, after_help = AFTER_HELP)]
struct Cli {
    /// The reference image or volume.
    a: PathBuf,
    /// The image or volume to compare with A.
    b: PathBuf,
    /// Peak (data range) for the PSNR, instead of the inputs' default.
    #[arg(long, value_name = "R", value_parser = positive)]
    range: Option<f64>,
    /// Images: compare the alpha channel too (both images must have one).
    #[arg(long)]
    alpha: bool,
    /// Images: compare Rec. 709 luma Y' = 0.2126 R + 0.7152 G + 0.0722 B of
    /// the stored values instead; the figures, --min-psnr and --diff then
    /// refer to Y'.
    #[arg(long)]
    luma: bool,
    /// Also give the figures of each channel.
    #[arg(long)]
    per_channel: bool,
    /// Exit with status 4 when the PSNR is below X dB (inf: only identical
    /// inputs pass). Any difference that is not finite (NaN against a
    /// number, an infinity) fails, whatever X.
    #[arg(long, value_name = "X", value_parser = not_nan)]
    min_psnr: Option<f64>,
    /// Write a heat map of the error with a colour scale as a PNG: for
    /// images the largest absolute channel error per pixel, for volumes the
    /// largest absolute error along z at each (x, y).
    #[arg(long, value_name = "OUT.png")]
    diff: Option<PathBuf>,
    #[command(flatten, next_help_heading = "Input (volumes)")]
    input_sel: Selection,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Print nothing but errors: the exit status tells.
    #[arg(short, long)]
    quiet: bool,
}

const AFTER_HELP: &str = "Exit status:
  0  compared (and the PSNR is at least --min-psnr)
  1  an input could not be read (missing, unknown type, malformed), or --diff could not be written
  2  usage error
  3  the inputs cannot be compared: image against volume, different sizes or
     dimensions, sample types or channel counts
  4  the PSNR is below --min-psnr, or some difference is not finite
  141 standard output was closed by its reader (e.g. | head): nothing more is printed

Examples:
  vol-psnr reference.png render.png
  vol-psnr reference.pfm render.pfm --range 4 --per-channel
  vol-psnr ref.png out.png --min-psnr 40 --quiet && echo good enough
  vol-psnr ref.png out.png --json --diff error.png
  vol-psnr shapes.vvol shapes-roundtrip.vol";

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive finite number")),
    }
}

fn not_nan(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if !v.is_nan() => Ok(v),
        _ => Err(format!("'{s}' is not a number")),
    }
}

/// A failure: the message for stderr and the exit status.
struct Fail {
    status: u8,
    msg: String,
}

impl Fail {
    fn new(status: u8, msg: impl std::fmt::Display) -> Fail {
        Fail {
            status,
            msg: msg.to_string(),
        }
    }
}

/// A comparison error, mismatches told apart from the rest.
fn compare_fail(e: volcompare::Error) -> Fail {
    match e {
        volcompare::Error::Mismatch(m) => Fail::new(EXIT_MISMATCH, m),
        other => Fail::new(EXIT_READ, other),
    }
}

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-psnr") {
        Ok(c) => c,
        Err(code) => return code,
    };
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) if f.status == EXIT_BROKEN_PIPE => ExitCode::from(f.status),
        Err(f) => {
            volkit_cli::run::report_error("vol-psnr", &f.msg);
            ExitCode::from(f.status)
        }
    }
}

/// A failed write of the report: a closed pipe ends the tool quietly.
fn print_fail(e: std::io::Error) -> Fail {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        Fail::new(EXIT_BROKEN_PIPE, "")
    } else {
        Fail::new(EXIT_READ, format!("standard output: {e}"))
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    Image,
    Volume,
}

/// Images by their extension; anything else is a volume (what it is
/// exactly is decided when it is opened).
fn kind_of(path: &Path) -> Result<Kind, Fail> {
    if image_extension(path).is_some() {
        return Ok(Kind::Image);
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if matches!(
        ext.as_str(),
        "jpg" | "jpeg" | "gif" | "bmp" | "webp" | "ppm" | "pgm"
    ) {
        return Err(Fail::new(
            EXIT_READ,
            format!(
                "{}: unknown file type (images: .png, .pfm, .exr; volumes: any format vol-convert reads)",
                path.display()
            ),
        ));
    }
    Ok(Kind::Volume)
}

/// The figures a run reports, whatever the kind of input.
struct Report {
    headline: Metrics,
    json: serde_json::Value,
    lines: Vec<String>,
}

fn run(cli: &Cli) -> Result<(), Fail> {
    let start = Instant::now();
    if cli.a.as_os_str() == "-" && cli.b.as_os_str() == "-" {
        return Err(Fail::new(EXIT_USAGE, "only one input can be - (stdin)"));
    }
    if let Some(d) = &cli.diff {
        if image_extension(d) != Some("png") {
            return Err(Fail::new(
                EXIT_USAGE,
                format!("--diff writes a PNG: name it .png, not {}", d.display()),
            ));
        }
    }
    let (ka, kb) = (kind_of(&cli.a)?, kind_of(&cli.b)?);
    if ka != kb {
        let name = |k| match k {
            Kind::Image => "an image",
            Kind::Volume => "a volume",
        };
        return Err(Fail::new(
            EXIT_MISMATCH,
            format!(
                "{} is {} but {} is {}: compare images with images, volumes with volumes",
                cli.a.display(),
                name(ka),
                cli.b.display(),
                name(kb)
            ),
        ));
    }
    let mut report = match ka {
        Kind::Image => images(cli)?,
        Kind::Volume => volumes(cli)?,
    };
    let m = report.headline;
    let obj = report.json.as_object_mut();
    if let Some(obj) = obj {
        obj.insert("seconds".into(), start.elapsed().as_secs_f64().into());
        if let Some(x) = cli.min_psnr {
            obj.insert("min_psnr".into(), x.into());
            obj.insert("passed".into(), passes(&m, x).into());
        }
    }
    if !cli.quiet {
        if cli.json {
            outln!("{}", report.json).map_err(print_fail)?;
        } else {
            for l in &report.lines {
                outln!("{l}").map_err(print_fail)?;
            }
        }
    }
    match cli.min_psnr {
        Some(x) if m.nonfinite > 0 => Err(Fail::new(
            EXIT_BELOW,
            format!(
                "{} of {} differences are not finite (NaN or infinite): no --min-psnr {x} passes",
                m.nonfinite, m.count
            ),
        )),
        Some(x) if !passes(&m, x) => Err(Fail::new(
            EXIT_BELOW,
            format!("PSNR {:.2} dB is below --min-psnr {x}", m.psnr),
        )),
        _ => Ok(()),
    }
}

/// Whether the figures pass `--min-psnr min`: a difference that is not
/// finite (NaN against a number, infinities) fails every gate, whatever
/// the PSNR of the finite rest.
fn passes(m: &Metrics, min: f64) -> bool {
    m.nonfinite == 0 && m.psnr >= min
}

fn images(cli: &Cli) -> Result<Report, Fail> {
    let load = |p: &Path| {
        Image::load(p).map_err(|e| Fail::new(EXIT_READ, format!("{}: {e}", p.display())))
    };
    let (a, b) = (load(&cli.a)?, load(&cli.b)?);
    let opts = ImageOptions {
        range: cli.range,
        alpha: cli.alpha,
        luma: cli.luma,
        error_map: cli.diff.is_some(),
    };
    let c = compare_images(&a, &b, &opts).map_err(compare_fail)?;
    let scale = match (&cli.diff, &c.error_map) {
        (Some(path), Some(map)) => Some(diff(cli, path, map, c.width, c.height)?),
        _ => None,
    };
    Ok(image_report(cli, &a, &c, scale))
}

fn diff(cli: &Cli, path: &Path, map: &[f32], w: u32, h: u32) -> Result<f64, Fail> {
    let m = write_heatmap(path, map, w, h)
        .map_err(|e| Fail::new(EXIT_READ, format!("{}: {e}", path.display())))?;
    if !cli.quiet && !cli.json {
        noteln!(
            "vol-psnr: wrote {} (error scale 0 to {})",
            path.display(),
            volcompare::heatmap::scale_label(m.max)
        );
    }
    Ok(m.max)
}

fn image_report(cli: &Cli, a: &Image, c: &ImageComparison, scale: Option<f64>) -> Report {
    let head = *c.headline();
    let label = if c.luma.is_some() { "luma " } else { "" };
    let mut lines = vec![format!("{label}{}", summary(&head))];
    if cli.per_channel {
        for (name, m) in c.channels.iter().zip(&c.per_channel) {
            lines.push(format!("  {name:<2}{}", summary(m)));
        }
    }
    let mut json = figures(&head);
    let obj = json.as_object_mut();
    if let Some(o) = obj {
        let mut extra = serde_json::json!({
            "tool": "vol-psnr",
            "kind": "image",
            "a": cli.a.display().to_string(),
            "b": cli.b.display().to_string(),
            "width": c.width,
            "height": c.height,
            "depth": a.depth.name(),
            "channels": c.channels.len(),
            "channel_names": c.channels,
            "metric": if c.luma.is_some() { "luma" } else { "pooled" },
            "peak_source": c.peak_source.name(),
        });
        if c.luma.is_some() {
            extra["pooled"] = figures(&c.pooled);
        }
        if cli.per_channel {
            extra["per_channel"] = c
                .channels
                .iter()
                .zip(&c.per_channel)
                .map(|(n, m)| {
                    let mut f = figures(m);
                    f["channel"] = (*n).into();
                    f
                })
                .collect();
        }
        if let (Some(p), Some(max)) = (&cli.diff, scale) {
            extra["diff"] = serde_json::json!({"path": p.display().to_string(), "scale_max": max});
        }
        if let Some(e) = extra.as_object() {
            o.extend(e.clone());
        }
    }
    Report {
        headline: head,
        json,
        lines,
    }
}

fn volumes(cli: &Cli) -> Result<Report, Fail> {
    if cli.alpha || cli.luma {
        return Err(Fail::new(
            EXIT_USAGE,
            "--alpha and --luma apply to images only",
        ));
    }
    let opts = volkit_cli::select::read_options(&cli.input_sel, &[&cli.a, &cli.b])
        .map_err(|e| Fail::new(EXIT_USAGE, e.to_string()))?;
    let open =
        |p: &Path| volformats::open(p, &opts).map_err(|e| Fail::new(EXIT_READ, e.to_string()));
    let (a, b) = (open(&cli.a)?, open(&cli.b)?);
    for (path, v) in [(&cli.a, &a), (&cli.b, &b)] {
        if let (false, Some(note)) = (cli.quiet, v.meta.narrowed.and_then(|n| n.note())) {
            noteln!("vol-psnr: {}: {note} (compared as f32)", path.display());
        }
    }
    let opts = VolumeOptions {
        range: cli.range,
        error_map: cli.diff.is_some(),
    };
    let c = compare_volumes(&a, &b, &opts).map_err(|e| match e {
        // A decode error names the volume as A or B: name its file instead.
        volcompare::Error::Invalid(m) => {
            let named = match (m.strip_prefix("A: "), m.strip_prefix("B: ")) {
                (Some(rest), _) => format!("{}: {rest}", cli.a.display()),
                (_, Some(rest)) => format!("{}: {rest}", cli.b.display()),
                _ => m,
            };
            Fail::new(EXIT_READ, named)
        }
        other => compare_fail(other),
    })?;
    let scale = match (&cli.diff, &c.error_map) {
        (Some(path), Some(map)) => {
            let too_large = || {
                Fail::new(
                    EXIT_READ,
                    "--diff: the volume's x,y plane is too large for a PNG",
                )
            };
            let w = u32::try_from(c.dims[0]).map_err(|_| too_large())?;
            let h = u32::try_from(c.dims[1]).map_err(|_| too_large())?;
            Some(diff(cli, path, map, w, h)?)
        }
        _ => None,
    };
    Ok(volume_report(cli, &c, scale))
}

fn volume_report(cli: &Cli, c: &VolumeComparison, scale: Option<f64>) -> Report {
    let m = c.metrics;
    // One channel: --per-channel adds nothing to the text.
    let lines = vec![summary(&m)];
    let mut json = figures(&m);
    if let Some(o) = json.as_object_mut() {
        let mut extra = serde_json::json!({
            "tool": "vol-psnr",
            "kind": "volume",
            "a": cli.a.display().to_string(),
            "b": cli.b.display().to_string(),
            "dims": c.dims,
            "type_a": c.type_a.name(),
            "type_b": c.type_b.name(),
            "channels": 1,
            "peak_source": c.peak_source.name(),
            "reference_min": c.reference_range.map(|r| r.0),
            "reference_max": c.reference_range.map(|r| r.1),
        });
        if cli.per_channel {
            let mut f = figures(&m);
            f["channel"] = "V".into();
            extra["per_channel"] = serde_json::json!([f]);
        }
        if let (Some(p), Some(max)) = (&cli.diff, scale) {
            extra["diff"] = serde_json::json!({"path": p.display().to_string(), "scale_max": max});
        }
        if let Some(e) = extra.as_object() {
            o.extend(e.clone());
        }
    }
    Report {
        headline: m,
        json,
        lines,
    }
}

/// The figures of one metric as a JSON object (volcompare's one form).
fn figures(m: &Metrics) -> serde_json::Value {
    m.figures()
}

/// One line: `PSNR 38.21 dB  MSE 9.81  max |d| 41  differing 1.2%`.
fn summary(m: &Metrics) -> String {
    if m.identical() {
        return "PSNR inf (identical)".to_string();
    }
    let psnr = if m.psnr.is_finite() {
        format!("{:.2} dB", m.psnr)
    } else {
        // Every finite difference is zero, but some are not finite.
        "inf".to_string()
    };
    let mut s = format!(
        "PSNR {psnr}  MSE {}  max |d| {}  differing {}",
        number(m.mse),
        number(m.max_abs),
        percent(m.differing_fraction)
    );
    if m.nonfinite > 0 {
        s.push_str(&format!("  not finite {}", m.nonfinite));
    }
    s
}

/// Up to four significant digits, or E notation for very small or large
/// values.
fn number(v: f64) -> String {
    volcompare::heatmap::scale_label(v)
}

/// A fraction as a percentage that never rounds a difference away.
fn percent(f: f64) -> String {
    let p = f * 100.0;
    if p > 99.9 && f < 1.0 {
        ">99.9%".to_string()
    } else if p == 0.0 || p >= 0.1 {
        format!("{p:.1}%")
    } else {
        format!("{}%", number(p))
    }
}
