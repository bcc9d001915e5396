//! vol-accuracy: what accuracy costs. Renders a reference image of a scene
//! at the finest settings, then sweeps each knob that trades accuracy for
//! time (step size, early ray termination, interpolation, gradient method,
//! macrocell size, tile size, thread count; on the thesis scene also the
//! shadow and ambient-occlusion methods), timing every setting and
//! comparing its linear float image with the reference's. Writes a CSV and
//! a plot (PSNR against time, one panel per knob: amounts as curves, kinds
//! as labelled markers, the default ringed, the reference's time dashed,
//! the spread of the runs as bars) as PNG and SVG. The reference itself is
//! the first row of each scene (PSNR inf).
//!
//! With `--path` it runs the path tracer's study instead
//! ([`path_study`]): PSNR against a long reference by samples per pixel
//! and by time, for the grid and global majorants, single scattering and
//! eight bounces.
//!
//! With `--resample` it runs the resampling and smoothing study instead
//! ([`resample_study`]): vol-convert's `--resample` kernels and `--smooth`
//! on a band-limited analytic volume, PSNR against the exact function by
//! time, beside SimpleITK and unu when they are there.
//!
//! It drives the other tools (`vol-gen`, `vol-render`, `vol-psnr`), which it
//! looks for next to its own executable unless `--bin-dir` says otherwise.
//!
//! This file is the command line; the studies are [`rays`] (the default),
//! [`path_study`] and [`resample_study`]; [`drive`] runs the tools and
//! reads their reports, [`plot`] and [`files`] hold what the studies'
//! plots and tables share.

/// Set by `--quiet`: progress lines are not printed.
static QUIET: AtomicBool = AtomicBool::new(false);

/// A progress line on stderr, unless `--quiet`.
macro_rules! say {
    ($($arg:tt)*) => {{
        if !crate::QUIET.load(::std::sync::atomic::Ordering::Relaxed) {
            ::volkit_cli::noteln!($($arg)*);
        }
    }};
}
mod drive;
mod files;
mod path_study;
mod plot;
mod rays;
mod resample_study;

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use drive::{exe, Ctx};
use plot::load_font;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use volkit_cli::json;

/// Sweep the renderer's accuracy knobs and chart PSNR against render time.
///
/// For each scene: generate the volume, render a reference (smallest step,
/// no early termination, trilinear, central gradients) with vol-render
/// --hdr, then render every setting of every knob with --repeat N, keeping
/// the median time, the fastest and slowest run, the samples taken and the
/// PSNR of its float image against the reference (vol-psnr, peak 1.0).
/// Knobs not being swept keep the base settings (step 0.2, --ert 0.99,
/// trilinear, central, --cell 8, --tile 16, all cores).
#[derive(Parser, Debug)]
#[command(name = "vol-accuracy", version, after_help = AFTER_HELP)]
struct Cli {
    /// CI-sized study: tiny volumes, 64x64 images, one run, few values.
    #[arg(long)]
    quick: bool,
    /// Run the path tracer's study instead: the dense and sparse spheres
    /// of scripts/bench-path.sh, a 4096-spp reference each (single
    /// scattering and 8 bounces), then 1, 2, 4, ... 1024 spp continued
    /// from a state file with the grid and the global majorant: PSNR by
    /// spp and by time (path.csv, path.md, path-SCENE.png and .svg).
    #[arg(long, conflicts_with_all = ["scene", "repeat"])]
    path: bool,
    /// Run the resampling and smoothing study instead (issue 52): the
    /// waves scene resampled down x2, x3, up x2 and CT 0.5x0.5x2 to 1 mm
    /// with every --kernel, with and without anti-aliasing, and smoothed
    /// with --smooth gauss:S, beside SimpleITK and unu resample when
    /// found: PSNR against the exact function by time (resample.csv,
    /// resample.md, resample.png and .svg).
    #[arg(long, conflicts_with_all = ["scene", "path"])]
    resample: bool,
    /// --resample: a Python that imports SimpleITK (default: python3;
    /// SimpleITK's rows are skipped with a note when it cannot).
    #[arg(long, value_name = "FILE", requires = "resample")]
    python: Option<PathBuf>,
    /// --resample: the unu executable (default: unu, then teem-unu, on
    /// PATH; Debian's teem-apps); skipped with a note when missing.
    #[arg(long, value_name = "FILE", requires = "resample")]
    unu: Option<PathBuf>,
    /// Directory for the volumes, images, CSV and plots (`--out` is the
    /// old spelling, still taken).
    #[arg(
        short,
        long,
        alias = "out",
        value_name = "DIR",
        default_value = "out/accuracy"
    )]
    output: PathBuf,
    /// Print one JSON object at the end: the files written, rows, time.
    #[arg(long)]
    json: bool,
    /// Print nothing but errors (and --json): no progress lines.
    #[arg(short, long)]
    quiet: bool,
    /// Runs per setting; the median is reported (default: 3, quick: 1).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    repeat: Option<u32>,
    /// Only this scene (thesis; noise; boundary: the noise volume through
    /// the 2D boundary transfer function; ct: a CT-like head through the
    /// `ct` preset); default: all four.
    #[arg(long, value_name = "NAME")]
    scene: Option<String>,
    /// Directory holding vol-gen, vol-render and vol-psnr (default: next
    /// to this executable).
    #[arg(long, value_name = "DIR")]
    bin_dir: Option<PathBuf>,
    /// TrueType font for the plot's text (default: a DejaVu or Liberation
    /// sans font from the usual system places).
    #[arg(long, value_name = "FILE")]
    font: Option<PathBuf>,
}

const AFTER_HELP: &str = "Examples:
  vol-accuracy                      # default study, out/accuracy/
  vol-accuracy --quick -o /tmp/acc --json
  vol-accuracy --scene noise --repeat 5
  vol-accuracy --path                 # the path tracer's convergence study
  vol-accuracy --resample --python ~/venv/bin/python   # resampling study

Outputs: accuracy.csv (scene, knob, value, median_s, min_s, max_s, samples,
psnr_db; psnr_db is inf when the image equals the reference) and, per scene,
accuracy-SCENE.png and accuracy-SCENE.svg. With --path: path.csv (scene,
bounces, majorant, spp, seconds, psnr_db, relative_error, lookups_per_path),
path.md (a summary table) and path-SCENE.png and .svg. With --resample:
resample.csv (study, case, tool, kernel, antialias, median_s, min_s, max_s,
psnr_db, psnr_lowpass_db, max_err, grid), resample.md (a table per case)
and resample.png and .svg.";

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-accuracy") {
        Ok(c) => c,
        Err(code) => return code,
    };
    // One escaped error line; a closed pipe ends the study quietly.
    volkit_cli::run("vol-accuracy", || run(&cli))
}

/// The study, then its `--json` report.
fn run(cli: &Cli) -> Result<()> {
    QUIET.store(cli.quiet, Ordering::Relaxed);
    let start = std::time::Instant::now();
    let files = study_files(cli)?;
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-accuracy",
            "output": cli.output.display().to_string(),
            "study": if cli.path { "path" } else if cli.resample { "resample" } else { "ray casting" },
            "files": files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "seconds": start.elapsed().as_secs_f64(),
            "threads": std::thread::available_parallelism().map_or(1, |n| n.get()),
        });
        json::emit(&v, false)?;
    }
    Ok(())
}

/// The whole study; the tables it wrote.
fn study_files(cli: &Cli) -> Result<Vec<PathBuf>> {
    let bin_dir = match &cli.bin_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()
            .context("cannot find this executable's directory")?
            .parent()
            .map(Path::to_path_buf)
            .ok_or_else(|| anyhow!("cannot find this executable's directory"))?,
    };
    let needed: &[&str] = if cli.resample {
        &["vol-gen", "vol-convert"]
    } else {
        &["vol-gen", "vol-render", "vol-psnr"]
    };
    for t in needed {
        let p = bin_dir.join(exe(t));
        if !p.is_file() {
            bail!(
                "{}: not found (build with cargo build --release --bins, or give --bin-dir)",
                p.display()
            );
        }
    }
    std::fs::create_dir_all(&cli.output)
        .with_context(|| format!("{}: cannot create directory", cli.output.display()))?;
    let ctx = Ctx {
        bin: bin_dir,
        out: cli.output.clone(),
        repeat: cli.repeat.unwrap_or(if cli.quick { 1 } else { 3 }),
        quick: cli.quick,
    };
    if cli.resample {
        let font = load_font(cli.font.as_deref())?;
        let peers = resample_study::Peers::find(cli.python.as_deref(), cli.unu.as_deref());
        return resample_study::run(&ctx, font, &peers);
    }
    if cli.path {
        let font = load_font(cli.font.as_deref())?;
        path_study::run(&ctx, font)?;
        return Ok(vec![ctx.out.join("path.csv"), ctx.out.join("path.md")]);
    }
    rays::run(&ctx, cli.scene.as_deref(), cli.font.as_deref())
}
