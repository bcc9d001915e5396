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
mod path_study;
mod resample_study;

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
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

/// One scene of a study: how to make the volume and how to look at it.
struct Scene {
    /// Short name used in file names and the CSV.
    name: &'static str,
    /// vol-gen arguments (without -o).
    gen: Vec<String>,
    /// vol-render arguments shared by every render of this scene.
    view: Vec<String>,
    /// Transfer function file contents to write, or None for a preset.
    tf_file: Option<&'static str>,
    /// Also study shadows and ambient occlusion (as the scenes
    /// `NAME-shadows` and `NAME-ao`).
    effects: bool,
}

/// The values swept for each knob.
struct Sweep {
    step: Vec<&'static str>,
    ert: Vec<&'static str>,
    cell: Vec<&'static str>,
    tile: Vec<&'static str>,
    threads: Vec<&'static str>,
    /// Shadow-ray steps and light-grid divisors (scenes with `shadows`).
    shadow_steps: Vec<&'static str>,
    shadow_grids: Vec<&'static str>,
    /// AO directions sampled and field directions (scenes with effects).
    ao_rays: Vec<&'static str>,
    ao_fields: Vec<&'static str>,
    /// Spacings of a 32-direction field's points, voxels (the default 8
    /// is the `AO field` panel's K = 32 point).
    ao_field_cells: Vec<&'static str>,
}

/// The noise scene's transfer function: empty below 110, a thin blue haze
/// up to 150, an orange shell from 150 to 190, opaque white cores above.
const NOISE_TF: &str = "# vol-accuracy: transfer function for the noise scene
domain 0 255
step 1
point 0   0 0 0 0
point 110 0 0 0 0
point 150 40 90 220 0.02
point 170 240 150 40 0.15
point 200 250 240 220 0.5
point 255 255 255 255 0.9
";

/// Base settings of every render that is not the reference.
const BASE_STEP: &str = "0.2";
const BASE_ERT: &str = "0.99";
/// Reference step, full and quick studies.
const REF_STEP: &str = "0.01";
const REF_STEP_QUICK: &str = "0.02";

/// One measured setting: a row of the CSV.
struct Row {
    scene: String,
    knob: &'static str,
    value: String,
    median_s: f64,
    min_s: f64,
    max_s: f64,
    samples: u64,
    /// None when the image equals the reference.
    psnr_db: Option<f64>,
    /// Seconds of precomputation outside the frame time (an AO field).
    build_s: f64,
}

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
    let repeat = cli.repeat.unwrap_or(if cli.quick { 1 } else { 3 });
    if cli.resample {
        let font = load_font(cli.font.as_deref())?;
        let ctx = Ctx {
            bin: bin_dir,
            out: cli.output.clone(),
            repeat,
            ref_step: REF_STEP,
        };
        let peers = resample_study::Peers::find(cli.python.as_deref(), cli.unu.as_deref());
        return resample_study::run(&ctx, cli.quick, font, &peers);
    }
    if cli.path {
        let font = load_font(cli.font.as_deref())?;
        let ctx = Ctx {
            bin: bin_dir,
            out: cli.output.clone(),
            repeat,
            ref_step: REF_STEP,
        };
        path_study::run(&ctx, cli.quick, font)?;
        return Ok(vec![ctx.out.join("path.csv"), ctx.out.join("path.md")]);
    }
    let (scenes, sweep) = study(cli.quick);
    let scenes: Vec<Scene> = match &cli.scene {
        None => scenes,
        Some(want) => {
            let s: Vec<Scene> = scenes.into_iter().filter(|s| s.name == want).collect();
            if s.is_empty() {
                bail!("unknown scene '{want}' (thesis, noise, boundary, ct)");
            }
            s
        }
    };
    let font = load_font(cli.font.as_deref())?;
    let ctx = Ctx {
        bin: bin_dir,
        out: cli.output.clone(),
        repeat,
        ref_step: if cli.quick { REF_STEP_QUICK } else { REF_STEP },
    };
    let mut rows = Vec::new();
    for scene in &scenes {
        let scene_rows = run_scene(&ctx, scene, &sweep)?;
        if font {
            plot(&ctx.out, scene.name, &scene_rows, cli.quick)?;
        }
        rows.extend(scene_rows);
        if scene.effects {
            for study in [
                shadow_study(&ctx, scene, &sweep),
                ao_study(&ctx, scene, &sweep),
            ] {
                let effect_rows = run_effect(&ctx, scene, &study)?;
                if font {
                    plot(&ctx.out, &study.name, &effect_rows, cli.quick)?;
                }
                rows.extend(effect_rows);
            }
        }
    }
    let csv = ctx.out.join("accuracy.csv");
    write_csv(&csv, &rows)?;
    say!("vol-accuracy: wrote {}", csv.display());
    Ok(vec![csv])
}

/// Everything a render needs besides the scene and the setting.
struct Ctx {
    bin: PathBuf,
    out: PathBuf,
    repeat: u32,
    ref_step: &'static str,
}

/// The executable's file name on this platform.
fn exe(name: &str) -> String {
    format!("{name}{}", std::env::consts::EXE_SUFFIX)
}

/// Strings from string slices.
fn strs(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

/// The default (or quick) scenes and the values swept.
fn study(quick: bool) -> (Vec<Scene>, Sweep) {
    // The thesis scene is 800³ with shapes of size 70 and the eye at
    // (1100, 1100, 1100) looking at the origin; scale all three together.
    let (n, size, img, noise_n, ct_n) = if quick {
        (48u32, 4u32, "64x64", 48u32, 48u32)
    } else {
        (256, 22, "256x256", 128, 192)
    };
    let eye = (1100.0 * f64::from(n) / 800.0).round();
    let thesis = Scene {
        name: "thesis",
        gen: strs(&["shapes", "--seed", "2", "--count", "70", "--value", "100"])
            .into_iter()
            .chain([
                "--size".into(),
                size.to_string(),
                "--dims".into(),
                format!("{n},{n},{n}"),
            ])
            .collect(),
        view: vec![
            "--tf".into(),
            "shapes".into(),
            "--shading".into(),
            "phong".into(),
            "--eye".into(),
            format!("{eye},{eye},{eye}"),
            "--look-at".into(),
            "0,0,0".into(),
            "--fov".into(),
            "60".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: true,
    };
    let noise = Scene {
        name: "noise",
        gen: vec![
            "noise".into(),
            "--dims".into(),
            format!("{noise_n},{noise_n},{noise_n}"),
        ],
        view: vec![
            "--shading".into(),
            "phong".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: Some(NOISE_TF),
        effects: false,
    };
    // The same kind of volume through a 2D transfer function: the
    // boundary preset (opacity rising with the gradient magnitude), whose
    // classification reads a gradient at every sample.
    let boundary = Scene {
        name: "boundary",
        gen: vec![
            "noise".into(),
            "--dims".into(),
            format!("{noise_n},{noise_n},{noise_n}"),
        ],
        view: vec![
            "--tf".into(),
            "boundary".into(),
            "--shading".into(),
            "phong".into(),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: false,
    };
    // A CT-like head (air, skin, a closed skull, brain, small lesions, in
    // Hounsfield units with noise) through the `ct` preset: dense where
    // the thesis scene is sparse, so shadow and occlusion rays cross
    // semi-transparent tissue and stop in bone.
    let ct = Scene {
        name: "ct",
        gen: vec![
            "phantom".into(),
            "--dims".into(),
            format!("{ct_n},{ct_n},{ct_n}"),
        ],
        view: vec![
            "--tf".into(),
            "ct".into(),
            "--shading".into(),
            "phong".into(),
            // The head's long axis is z: look at its face from 30 degrees
            // to the side, close enough for the head to fill the frame.
            "--up".into(),
            "0,0,1".into(),
            "--orbit".into(),
            format!("30,15,{:.0}", 1.1 * 3f64.sqrt() * f64::from(ct_n - 1)),
            "--size".into(),
            img.into(),
        ],
        tf_file: None,
        effects: true,
    };
    let sweep = if quick {
        Sweep {
            step: vec!["0.05", "0.2", "0.8", "1.6"],
            ert: vec!["0.9", "0.99", "off"],
            cell: vec!["4", "16"],
            tile: vec!["8", "32"],
            threads: vec!["1", "2"],
            shadow_steps: vec!["0.5", "2"],
            shadow_grids: vec!["2", "4"],
            ao_rays: vec!["4", "16"],
            ao_fields: vec!["16", "32"],
            ao_field_cells: vec!["4"],
        }
    } else {
        Sweep {
            step: vec!["0.05", "0.1", "0.2", "0.4", "0.8", "1.6"],
            ert: vec!["0.9", "0.95", "0.99", "0.999", "off"],
            cell: vec!["4", "8", "16", "32"],
            tile: vec!["8", "16", "32", "64"],
            threads: vec!["1", "2"],
            shadow_steps: vec!["0.2", "0.5", "1", "2"],
            shadow_grids: vec!["1", "2", "4"],
            ao_rays: vec!["4", "8", "16", "32"],
            ao_fields: vec!["16", "32", "64"],
            ao_field_cells: vec!["2", "4", "16"],
        }
    };
    (vec![thesis, noise, boundary, ct], sweep)
}

/// Generate, render the reference, sweep every knob; returns the rows.
fn run_scene(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> Result<Vec<Row>> {
    let vol = ctx.out.join(format!("{}.vvol", scene.name));
    let mut gen = scene.gen.clone();
    gen.extend(["-o".into(), path_arg(&vol)?, "--quiet".into()]);
    tool(ctx, "vol-gen", &gen)?;
    let mut view = scene.view.clone();
    if let Some(tf) = scene.tf_file {
        let tf_path = ctx.out.join(format!("{}.tf", scene.name));
        std::fs::write(&tf_path, tf)
            .with_context(|| format!("{}: cannot write", tf_path.display()))?;
        view.extend(["--tf".into(), path_arg(&tf_path)?]);
    }
    let reference = ctx.out.join(format!("{}-reference.pfm", scene.name));
    say!(
        "vol-accuracy: {}: reference at step {}",
        scene.name,
        ctx.ref_step
    );
    let r = render(
        ctx,
        &vol,
        &view,
        &strs(&["--step", ctx.ref_step, "--no-ert"]),
        &reference,
        ctx.repeat,
    )?;
    // The reference is the first row (PSNR inf), so times can be compared
    // with it.
    let mut rows = vec![r.reference_row(scene.name, ctx.ref_step.into())];

    // (knob, value as written in the CSV, vol-render arguments)
    let mut settings: Vec<(&'static str, String, Vec<String>)> = Vec::new();
    for s in &sweep.step {
        settings.push(("step", s.to_string(), strs(&["--step", s])));
    }
    for e in &sweep.ert {
        let a = if *e == "off" {
            strs(&["--no-ert"])
        } else {
            strs(&["--ert", e])
        };
        settings.push(("ert", e.to_string(), a));
    }
    for i in ["nearest", "trilinear"] {
        settings.push(("interp", i.into(), strs(&["--interp", i])));
    }
    for g in ["central", "analytic"] {
        settings.push(("gradient", g.into(), strs(&["--gradient", g])));
    }
    for c in &sweep.cell {
        settings.push(("cell", c.to_string(), strs(&["--cell", c])));
    }
    for t in &sweep.tile {
        settings.push(("tile", t.to_string(), strs(&["--tile", t])));
    }
    for t in &sweep.threads {
        settings.push(("threads", t.to_string(), strs(&["--threads", t])));
    }

    for (knob, value, args) in settings {
        // The base settings, except for the knob being swept.
        let mut all = Vec::new();
        if knob != "step" {
            all.extend(strs(&["--step", BASE_STEP]));
        }
        if knob != "ert" {
            all.extend(strs(&["--ert", BASE_ERT]));
        }
        all.extend(args);
        let m = Measured {
            scene: scene.name,
            vol: &vol,
            view: &view,
            reference: &reference,
        };
        rows.push(m.row(ctx, knob, value, &all)?);
    }
    Ok(rows)
}

/// What every setting of one study is measured against.
struct Measured<'a> {
    scene: &'a str,
    vol: &'a Path,
    view: &'a [String],
    reference: &'a Path,
}

impl Measured<'_> {
    /// Render with `args` on top of the view, time it, compare it with the
    /// reference: one row.
    fn row(&self, ctx: &Ctx, knob: &'static str, value: String, args: &[String]) -> Result<Row> {
        let name = self.scene;
        let hdr = ctx
            .out
            .join(format!("{name}-{}-{value}.pfm", knob.replace(' ', "-")));
        let r = render(ctx, self.vol, self.view, args, &hdr, ctx.repeat)?;
        let psnr_db = psnr(ctx, self.reference, &hdr)?;
        say!(
            "vol-accuracy: {name} {knob}={value}: {:.4} s, PSNR {}",
            r.median_s,
            psnr_db.map_or("inf".to_string(), |p| format!("{p:.2} dB"))
        );
        Ok(Row {
            scene: name.into(),
            knob,
            value,
            median_s: r.median_s,
            min_s: r.min_s,
            max_s: r.max_s,
            samples: r.samples,
            psnr_db,
            build_s: r.build_s,
        })
    }
}

/// Light for the effect studies: one directional light.
const SHADOW_LIGHT: &str = "1,2,0.5";
/// The shadow study's reference shadow step, full and quick.
const SHADOW_REF_STEP: &str = "0.05";
const SHADOW_REF_STEP_QUICK: &str = "0.1";
/// Ambient light of the AO study (strong, so occlusion shows).
const AO_AMBIENT: &str = "0.6";
/// The AO study's reference: directions per shaded sample, full and quick.
const AO_REF_RAYS: &str = "256";
const AO_REF_RAYS_QUICK: &str = "64";

/// One effect's study: the scene seen at the base step and termination
/// with `extra` on top, a reference render, and the settings compared
/// with it.
struct EffectStudy {
    /// Scene name in the CSV and file names.
    name: String,
    /// Arguments on top of the scene's view.
    extra: Vec<String>,
    /// The reference's value (as written in the CSV) and arguments.
    reference: (String, Vec<String>),
    /// (knob, value, arguments) per point.
    settings: Vec<(&'static str, String, Vec<String>)>,
}

/// What shadows cost and buy: lit by one directional light; the reference
/// casts shadow rays at a fine shadow step, the points are shadows off,
/// shadow rays at coarser steps, and light grids at each divisor.
fn shadow_study(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> EffectStudy {
    let ref_step = if ctx.ref_step == REF_STEP_QUICK {
        SHADOW_REF_STEP_QUICK
    } else {
        SHADOW_REF_STEP
    };
    let mut settings: Vec<(&'static str, String, Vec<String>)> =
        vec![("shadows off", "off".into(), Vec::new())];
    for st in &sweep.shadow_steps {
        settings.push((
            "shadow rays",
            st.to_string(),
            strs(&["--shadows", "ray", "--shadow-step", st]),
        ));
    }
    for d in &sweep.shadow_grids {
        settings.push((
            "shadow grid",
            d.to_string(),
            vec!["--shadows".into(), format!("grid:{d}")],
        ));
    }
    EffectStudy {
        name: format!("{}-shadows", scene.name),
        extra: strs(&["--light", SHADOW_LIGHT]),
        reference: (
            format!("ray:{ref_step}"),
            strs(&["--shadows", "ray", "--shadow-step", ref_step]),
        ),
        settings,
    }
}

/// What ambient occlusion costs and buys: one directional light and a
/// strong ambient term; the reference occludes with many directions per
/// shaded sample, the points are AO off, N sampled directions, and fields
/// of K directions (whose precomputation is timed apart).
fn ao_study(ctx: &Ctx, scene: &Scene, sweep: &Sweep) -> EffectStudy {
    let ref_rays = if ctx.ref_step == REF_STEP_QUICK {
        AO_REF_RAYS_QUICK
    } else {
        AO_REF_RAYS
    };
    let mut settings: Vec<(&'static str, String, Vec<String>)> =
        vec![("AO off", "off".into(), Vec::new())];
    for n in &sweep.ao_rays {
        settings.push(("AO rays", n.to_string(), strs(&["--ao", n])));
    }
    for k in &sweep.ao_fields {
        settings.push(("AO field", k.to_string(), strs(&["--ao-field", k])));
    }
    for c in &sweep.ao_field_cells {
        settings.push((
            "AO field cell",
            c.to_string(),
            strs(&["--ao-field", "32", "--ao-field-cell", c]),
        ));
    }
    EffectStudy {
        name: format!("{}-ao", scene.name),
        extra: strs(&["--light", SHADOW_LIGHT, "--ambient", AO_AMBIENT]),
        reference: (format!("rays:{ref_rays}"), strs(&["--ao", ref_rays])),
        settings,
    }
}

/// Run an effect study of `scene` (whose volume the main study made).
fn run_effect(ctx: &Ctx, scene: &Scene, study: &EffectStudy) -> Result<Vec<Row>> {
    let name = study.name.as_str();
    let vol = ctx.out.join(format!("{}.vvol", scene.name));
    let mut view = scene.view.clone();
    if scene.tf_file.is_some() {
        let tf_path = ctx.out.join(format!("{}.tf", scene.name));
        view.extend(["--tf".into(), path_arg(&tf_path)?]);
    }
    view.extend(strs(&["--step", BASE_STEP, "--ert", BASE_ERT]));
    view.extend(study.extra.iter().cloned());
    let reference = ctx.out.join(format!("{name}-reference.pfm"));
    let (ref_value, ref_args) = &study.reference;
    say!("vol-accuracy: {name}: reference {}", ref_args.join(" "));
    let r = render(ctx, &vol, &view, ref_args, &reference, ctx.repeat)?;
    let mut rows = vec![r.reference_row(name, ref_value.clone())];
    let m = Measured {
        scene: name,
        vol: &vol,
        view: &view,
        reference: &reference,
    };
    for (knob, value, args) in &study.settings {
        rows.push(m.row(ctx, knob, value.clone(), args)?);
    }
    Ok(rows)
}

/// A path as a command-line argument (must be UTF-8 for the tools).
fn path_arg(p: &Path) -> Result<String> {
    p.to_str()
        .map(str::to_string)
        .ok_or_else(|| anyhow!("{}: path is not UTF-8", p.display()))
}

/// Run a tool, insist on success, return its stdout.
fn tool(ctx: &Ctx, name: &str, args: &[String]) -> Result<String> {
    let out = Command::new(ctx.bin.join(exe(name)))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("{name}: cannot start"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err.lines().next().unwrap_or("failed without a message");
        bail!("{name} {}: {line}", args.join(" "));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// What one setting's renders took.
struct Timing {
    median_s: f64,
    min_s: f64,
    max_s: f64,
    samples: u64,
    /// Precomputation outside the frame time (`ao_field_s`), seconds.
    build_s: f64,
}

impl Timing {
    /// The row of a study's reference (PSNR inf), written first so the
    /// other times can be compared with it.
    fn reference_row(&self, scene: &str, value: String) -> Row {
        Row {
            scene: scene.into(),
            knob: "reference",
            value,
            median_s: self.median_s,
            min_s: self.min_s,
            max_s: self.max_s,
            samples: self.samples,
            psnr_db: None,
            build_s: self.build_s,
        }
    }
}

/// Render once (or `repeat` times) with --hdr: the median, fastest and
/// slowest frame, the samples taken, and any precomputation.
fn render(
    ctx: &Ctx,
    vol: &Path,
    view: &[String],
    knobs: &[String],
    hdr: &Path,
    repeat: u32,
) -> Result<Timing> {
    let png = hdr.with_extension("png");
    let mut args = vec![path_arg(vol)?];
    args.extend(view.iter().cloned());
    args.extend(knobs.iter().cloned());
    args.extend([
        "-o".into(),
        path_arg(&png)?,
        "--hdr".into(),
        path_arg(hdr)?,
        "--repeat".into(),
        repeat.to_string(),
        "--json".into(),
        "--quiet".into(),
    ]);
    let out = tool(ctx, "vol-render", &args)?;
    let v: serde_json::Value =
        serde_json::from_str(out.trim()).context("vol-render did not print one JSON object")?;
    let median = v["render_s"]
        .as_f64()
        .ok_or_else(|| anyhow!("vol-render JSON has no render_s"))?;
    let runs: Vec<f64> = v["render_runs_s"]
        .as_array()
        .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
        .unwrap_or_default();
    let min = runs.iter().copied().fold(median, f64::min);
    let max = runs.iter().copied().fold(median, f64::max);
    let samples = v["samples"]
        .as_u64()
        .ok_or_else(|| anyhow!("vol-render JSON has no samples"))?;
    Ok(Timing {
        median_s: median,
        min_s: min,
        max_s: max,
        samples,
        build_s: v["ao_field_s"].as_f64().unwrap_or(0.0),
    })
}

/// PSNR (dB) of `b` against `a`; None when identical.
fn psnr(ctx: &Ctx, a: &Path, b: &Path) -> Result<Option<f64>> {
    let out = tool(
        ctx,
        "vol-psnr",
        &[path_arg(a)?, path_arg(b)?, "--json".into()],
    )?;
    let v: serde_json::Value =
        serde_json::from_str(out.trim()).context("vol-psnr did not print one JSON object")?;
    if v["identical"].as_bool() == Some(true) {
        return Ok(None);
    }
    v["psnr"]
        .as_f64()
        .map(Some)
        .ok_or_else(|| anyhow!("vol-psnr JSON has no psnr"))
}

/// Write the CSV under a temporary name, then rename.
fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut s = String::from("scene,knob,value,median_s,min_s,max_s,samples,psnr_db,build_s\n");
    for r in rows {
        let p = r.psnr_db.map_or("inf".to_string(), |p| format!("{p:.3}"));
        let _ = writeln!(
            s,
            "{},{},{},{:.6},{:.6},{:.6},{},{},{:.6}",
            r.scene, r.knob, r.value, r.median_s, r.min_s, r.max_s, r.samples, p, r.build_s
        );
    }
    let tmp = path.with_extension("csv.partial");
    std::fs::write(&tmp, s).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

/// Register a sans-serif font for the plot's text. Returns false (after a
/// warning) when none is found and none was asked for: the CSV is still
/// written, the plot is skipped.
fn load_font(asked: Option<&Path>) -> Result<bool> {
    let candidates: Vec<PathBuf> = match asked {
        Some(p) => vec![p.to_path_buf()],
        None => [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
            "/Library/Fonts/Arial.ttf",
            "C:\\Windows\\Fonts\\arial.ttf",
        ]
        .iter()
        .map(PathBuf::from)
        .collect(),
    };
    for p in &candidates {
        if let Ok(bytes) = std::fs::read(p) {
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_err() {
                bail!("{}: not a usable TrueType font", p.display());
            }
            return Ok(true);
        }
    }
    if let Some(p) = asked {
        bail!("{}: cannot read font", p.display());
    }
    say!("vol-accuracy: no font found (give --font FILE.ttf): skipping the plots");
    Ok(false)
}

/// One colour per knob, in sweep order.
const COLOURS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// Knobs whose values are kinds, not amounts: drawn as labelled markers,
/// never joined by lines.
fn categorical(knob: &str) -> bool {
    matches!(knob, "interp" | "gradient" | "shadows off" | "AO off")
}

/// Whether `value` is the base setting of `knob` (what every other panel
/// uses): marked with a ring.
fn is_default(knob: &str, value: &str) -> bool {
    matches!(
        (knob, value),
        ("step", BASE_STEP)
            | ("ert", BASE_ERT)
            | ("interp", "trilinear")
            | ("gradient", "central")
            | ("cell", "8")
            | ("tile", "16")
    )
}

/// Draw PSNR against median time for one scene, one panel per knob, as
/// PNG and SVG; `smoke` marks a quick run's plot as a smoke test.
fn plot(out: &Path, scene: &str, rows: &[Row], smoke: bool) -> Result<()> {
    let png = out.join(format!("accuracy-{scene}.png"));
    let svg = out.join(format!("accuracy-{scene}.svg"));
    let knobs = knobs_of(rows);
    let cols = knobs.len().clamp(1, 3) as u32;
    let panel_rows = (knobs.len() as u32).div_ceil(cols).max(1);
    let size = (cols * 400, 60 + panel_rows * 330);
    draw_png(&png, size, |root| draw(root, scene, rows, smoke))?;
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(root, scene, rows, smoke)
            .with_context(|| format!("{}: cannot draw", svg.display()))?;
    }
    Ok(())
}

/// Draw into an RGB buffer and write it through volformats' PNG encoder
/// (the `image` crate the workspace already builds), so plotters needs no
/// `bitmap_encoder` and no second, older `image` of its own.
fn draw_png<F>(png: &Path, (w, h): (u32, u32), draw: F) -> Result<()>
where
    F: FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
{
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    draw(BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area())
        .with_context(|| format!("{}: cannot draw", png.display()))?;
    volformats::image::write_png8(png, w, h, 3, &rgb)
        .with_context(|| format!("{}: cannot write", png.display()))
}

/// The knobs with a finite PSNR, in sweep order.
fn knobs_of(rows: &[Row]) -> Vec<&'static str> {
    let mut knobs: Vec<&'static str> = Vec::new();
    for r in rows.iter().filter(|r| r.psnr_db.is_some()) {
        if !knobs.contains(&r.knob) {
            knobs.push(r.knob);
        }
    }
    knobs
}

/// A time label with as many digits as its size needs.
fn seconds(x: f64) -> String {
    if x >= 10.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else if x >= 0.1 {
        format!("{x:.2}")
    } else if x >= 0.01 {
        format!("{x:.3}")
    } else {
        format!("{x:.0e}")
    }
}

/// The chart itself, on any backend: a title, then one panel per knob on
/// shared axes (time on a log scale, spread from the fastest to the
/// slowest run as a bar; the reference's time as a dashed line).
fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    scene: &str,
    rows: &[Row],
    smoke: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("{e}");
    root.fill(&WHITE).map_err(err)?;
    let finite: Vec<&Row> = rows.iter().filter(|r| r.psnr_db.is_some()).collect();
    if finite.is_empty() {
        bail!("no setting differs from the reference: nothing to plot");
    }
    let reference = rows.iter().find(|r| r.knob == "reference");
    let (mut t0, mut t1, mut p0, mut p1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for r in &finite {
        let p = r.psnr_db.unwrap_or(0.0);
        t0 = t0.min(r.min_s);
        t1 = t1.max(r.max_s);
        p0 = p0.min(p);
        p1 = p1.max(p);
    }
    if let Some(r) = reference {
        t1 = t1.max(r.median_s);
    }
    let t0 = (t0 * 0.7).max(1e-6);
    let t1 = (t1 * 1.4).max(t0 * 2.0);
    let (p0, p1) = ((p0 - 3.0).floor(), (p1 + 4.0).ceil());
    let title = if smoke {
        format!("{scene}: SMOKE TEST (quick run: tiny sizes, one run each; not a result)")
    } else {
        format!(
            "What accuracy costs: {scene} (PSNR against the reference{})",
            reference.map_or(String::new(), |r| format!(" {}", r.value))
        )
    };
    let body = root.titled(&title, ("sans-serif", 22)).map_err(err)?;
    let knobs = knobs_of(rows);
    let cols = knobs.len().clamp(1, 3);
    let panel_rows = knobs.len().div_ceil(cols).max(1);
    let panels = body.split_evenly((panel_rows, cols));
    for ((i, knob), area) in knobs.iter().enumerate().zip(panels.iter()) {
        let colour = COLOURS[i % COLOURS.len()];
        let mut chart = ChartBuilder::on(area)
            .caption(*knob, ("sans-serif", 17))
            .margin(10)
            .x_label_area_size(38)
            .y_label_area_size(48)
            .build_cartesian_2d((t0..t1).log_scale(), p0..p1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("median frame time (s, log)")
            .y_desc("PSNR (dB)")
            .x_labels(5)
            .y_labels(6)
            .x_label_formatter(&|x| seconds(*x))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        if let Some(r) = reference {
            let dashes: Vec<(f64, f64)> = (0..12)
                .flat_map(|k| {
                    let a = p0 + (p1 - p0) * (2 * k) as f64 / 24.0;
                    let b = p0 + (p1 - p0) * (2 * k + 1) as f64 / 24.0;
                    [(r.median_s, a), (r.median_s, b)]
                })
                .collect();
            chart
                .draw_series(
                    dashes.chunks(2).map(|d| {
                        PathElement::new(vec![d[0], d[1]], BLACK.mix(0.5).stroke_width(1))
                    }),
                )
                .map_err(err)?;
            // Left of the line, so it stays inside the panel.
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("reference {} s", seconds(r.median_s)),
                    (r.median_s / 2.4, p1 - 0.4),
                    ("sans-serif", 12).into_font().color(&BLACK.mix(0.6)),
                )))
                .map_err(err)?;
        }
        let pts: Vec<&&Row> = finite.iter().filter(|r| r.knob == *knob).collect();
        // Spread of the runs: a bar from the fastest to the slowest.
        chart
            .draw_series(pts.iter().map(|r| {
                let y = r.psnr_db.unwrap_or(0.0);
                PathElement::new(vec![(r.min_s, y), (r.max_s, y)], colour.stroke_width(1))
            }))
            .map_err(err)?;
        if !categorical(knob) {
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|r| (r.median_s, r.psnr_db.unwrap_or(0.0))),
                    colour.stroke_width(2),
                ))
                .map_err(err)?;
        }
        chart
            .draw_series(
                pts.iter().map(|r| {
                    Circle::new((r.median_s, r.psnr_db.unwrap_or(0.0)), 4, colour.filled())
                }),
            )
            .map_err(err)?;
        chart
            .draw_series(pts.iter().filter(|r| is_default(knob, &r.value)).map(|r| {
                Circle::new(
                    (r.median_s, r.psnr_db.unwrap_or(0.0)),
                    8,
                    BLACK.stroke_width(2),
                )
            }))
            .map_err(err)?;
        // Value labels beside their markers, cycling through three heights
        // so neighbours at nearly the same time do not overlap.
        let lift = (p1 - p0) / 24.0;
        chart
            .draw_series(pts.iter().enumerate().map(|(j, r)| {
                let dy = lift * [1.5, -1.0, 3.5][j % 3];
                let mut label = r.value.clone();
                if is_default(knob, &r.value) {
                    label.push_str(" (default)");
                }
                if r.build_s > 0.0 {
                    label.push_str(&format!(" (+{} s build)", seconds(r.build_s)));
                }
                Text::new(
                    label,
                    (r.median_s * 1.06, r.psnr_db.unwrap_or(0.0) + dy),
                    ("sans-serif", 12).into_font().color(&colour.mix(0.9)),
                )
            }))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}
