//! The resampling and smoothing study (issue 52): what each kernel costs
//! and buys, against the exact answer. The volume is vol-gen's `waves`
//! scene, a sum of plane waves below half its Nyquist limit, so the true
//! function is known everywhere ([`volcore::scene::Waves`]): every output
//! voxel is compared with the function at its own world position (read
//! from the output file's origin, spacing and directions, so a tool that
//! puts its grid elsewhere is measured where it put it, and the `grid`
//! column says so).
//!
//! Resampling: down ×2 and ×3 and up ×2 of an isotropic volume, and the
//! CT case (0.5 × 0.5 × 2 to 1 mm isotropic: x and y down ×2, z up ×2),
//! with every `--kernel`, with and without anti-aliasing, against
//! SimpleITK's ResampleImageFilter (nearest, linear, BSpline,
//! LanczosWindowedSinc; no anti-aliasing) and `unu resample` (box, tent,
//! Catmull-Rom, prefiltered B-spline, Hann-windowed sinc of radius 3;
//! anti-aliased as unu always is when downsampling; its `cheap` kernel,
//! subsampling by nearest, is its one way without). Two PSNRs: against the function sampled on the output
//! grid (what the issue asks; when the output grid cannot hold every wave,
//! this rewards aliasing), and against its ideal low-pass on that grid
//! (the waves above the output's Nyquist limit on any axis removed: what
//! anti-aliasing aims at).
//!
//! Smoothing: `--smooth gauss:σ` against the exact convolution (each
//! wave keeps exp(−2π²Σσₐ²kₐ²) of its amplitude), beside SimpleITK's
//! DiscreteGaussian and SmoothingRecursiveGaussian and unu's `gauss:σ,4`.
//!
//! Only interior voxels count: those at least [`MARGIN`] input voxels
//! (and 5σ) inside the input's first and last voxel centres, so the
//! border rules (replicate, bleed, ITK's zero-flux Neumann) do not enter.
//! Times are wall seconds from reading the input to writing the output:
//! a whole `vol-convert` process, a whole `unu` process (two for the
//! prefiltered B-spline), and for SimpleITK ReadImage to WriteImage inside
//! one Python process (its start and import left out; a filter whose
//! runs pass 30 s stops repeating), on all cores.
//! Peers that are missing are skipped with a note.

use crate::drive::{exe, path_arg, strs, tool, Ctx};
use crate::files::write_via_temp;
use crate::plot::{
    drawing_error, grid_size, legend, seconds, titled_grid, write_png_svg, Chart, COLOURS,
};
use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use volcore::scene::Waves;

/// Interior margin, in input voxels: more than the widest kernel's reach
/// (Lanczos-3 widened ×3 reads 9 voxels each side; the B-spline
/// prefilter's influence falls by 0.268 per voxel).
pub const MARGIN: f64 = 12.0;

/// The waves' peak value (the PSNR's peak: the function spans 0..PEAK).
const PEAK: f64 = 255.0;

/// The waves' seed.
const SEED: &str = "1";

/// Where the peers are.
pub struct Peers {
    /// A Python that imports SimpleITK, or why not.
    pub python: std::result::Result<PathBuf, String>,
    /// The `unu` executable, or why not.
    pub unu: std::result::Result<PathBuf, String>,
}

impl Peers {
    /// Look for the peers: `python` (default `python3`) must import
    /// SimpleITK; `unu` (default `unu`, then Debian's `teem-unu`, on PATH).
    pub fn find(python: Option<&Path>, unu: Option<&Path>) -> Peers {
        let py = python.map_or_else(|| PathBuf::from("python3"), Path::to_path_buf);
        let python = match Command::new(&py)
            .args(["-c", "import SimpleITK"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
        {
            Ok(s) if s.success() => Ok(py),
            Ok(_) => Err(format!(
                "{} cannot import SimpleITK (pip install SimpleITK, or give --python)",
                py.display()
            )),
            Err(e) => Err(format!("{}: {e}", py.display())),
        };
        let candidates: Vec<PathBuf> = match unu {
            Some(u) => vec![u.to_path_buf()],
            None => vec!["unu".into(), "teem-unu".into()],
        };
        let unu = candidates
            .iter()
            .find(|u| {
                Command::new(u)
                    .arg("about")
                    .stdin(Stdio::null())
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .status()
                    .is_ok()
            })
            .cloned()
            .ok_or_else(|| {
                "unu not found (Debian: apt-get install teem-apps, or give --unu)".to_string()
            });
        Peers { python, unu }
    }
}

/// One measured output: a row of `resample.csv`.
#[derive(Clone, Debug)]
pub struct Row {
    /// `resample` or `smooth`.
    study: &'static str,
    /// The case: `iso-down2`, `iso-down3`, `iso-up2`, `ct-1mm`,
    /// `iso-gauss1`, `ct-gauss1`, ...
    case: String,
    /// `volkit`, `SimpleITK` or `unu`.
    tool: &'static str,
    /// The kernel or filter, in the tool's own name.
    kernel: String,
    /// `yes`, `no`, or `-` (upsampling, smoothing).
    antialias: &'static str,
    median_s: f64,
    min_s: f64,
    max_s: f64,
    /// Against the function on the output grid (or the exact convolution).
    psnr_db: f64,
    /// Against the ideal low-pass of the output grid (resampling only).
    psnr_lowpass_db: Option<f64>,
    /// Largest interior error, as a fraction of the function's range.
    max_err: f64,
    /// Whether the output grid is the one the issue's convention gives.
    grid_same: bool,
}

/// An input volume of the study.
struct Input {
    /// `iso` or `ct`.
    name: &'static str,
    dims: [u64; 3],
    spacing: [f64; 3],
    /// The NIfTI every tool but unu reads, and the NRRD unu reads.
    nii: PathBuf,
    nrrd: PathBuf,
}

/// A resampling case: the `--resample` spacing and the output spacing.
struct Case {
    name: String,
    spacing: [f64; 3],
    spec: String,
}

/// The output grid of `--resample spacing:` by the issue's convention:
/// the box from the first voxel's outer face to the last's, new dims
/// round(extent / spacing) (at least 1), the new box centred on the old;
/// the input has origin 0 and identity directions.
pub fn expected_grid(dims: [u64; 3], spacing: [f64; 3], out: [f64; 3]) -> ([u64; 3], [f64; 3]) {
    let mut n = [1u64; 3];
    let mut origin = [0.0; 3];
    for a in 0..3 {
        let extent = dims[a] as f64 * spacing[a];
        n[a] = ((extent / out[a]).round() as u64).max(1);
        origin[a] = (dims[a] - 1) as f64 * spacing[a] / 2.0 - (n[a] - 1) as f64 * out[a] / 2.0;
    }
    (n, origin)
}

/// The study's kernels: volkit's `--kernel` names and unu's `-k` (SimpleITK's are in
/// the Python peer).
const VOLKIT_KERNELS: [&str; 6] = [
    "nearest", "linear", "cubic", "bspline3", "lanczos3", "label",
];
const UNU_KERNELS: [&str; 5] = ["box", "tent", "cubic:0,0.5", "bspl3ai+bspl3", "hann:3"];

/// The Python side of the SimpleITK peer: resample or smooth, timing
/// ReadImage → filter → WriteImage per run, one JSON line per filter.
const SITK_PY: &str = r#"# vol-accuracy's SimpleITK peer (written by vol-accuracy --resample).
import json, os, sys, time
import SimpleITK as sitk
sitk.ProcessObject.SetGlobalDefaultNumberOfThreads(os.cpu_count() or 1)
mode, src, prefix, repeat = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
args = [float(a) for a in sys.argv[5:]]
def resampler(interp):
    size, spacing, origin = [int(a) for a in args[0:3]], args[3:6], args[6:9]
    def run(img):
        f = sitk.ResampleImageFilter()
        f.SetSize(size)
        f.SetOutputSpacing(spacing)
        f.SetOutputOrigin(origin)
        f.SetOutputDirection(img.GetDirection())
        f.SetInterpolator(interp)
        f.SetDefaultPixelValue(0)
        f.SetOutputPixelType(sitk.sitkFloat32)
        return f.Execute(img)
    return run
def discrete(img):
    s = args[0:3]
    return sitk.DiscreteGaussian(img, variance=[v * v for v in s], maximumKernelWidth=128, maximumError=0.001, useImageSpacing=True)
def recursive(img):
    return sitk.SmoothingRecursiveGaussian(img, args[0:3])
if mode == "resample":
    filters = [("nearest", resampler(sitk.sitkNearestNeighbor)), ("linear", resampler(sitk.sitkLinear)),
               ("bspline", resampler(sitk.sitkBSpline)), ("lanczos", resampler(sitk.sitkLanczosWindowedSinc))]
else:
    filters = [("DiscreteGaussian", discrete), ("SmoothingRecursiveGaussian", recursive)]
for name, run in filters:
    out = f"{prefix}-{name}.nii"
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        sitk.WriteImage(run(sitk.ReadImage(src, sitk.sitkFloat32)), out)
        runs.append(time.perf_counter() - t)
        if sum(runs) > 30:  # slow filters (Lanczos upsampling): fewer runs
            break
    print(json.dumps({"kernel": name, "runs": runs, "output": out}), flush=True)
"#;

/// Sizes of a full and a quick study: the isotropic volume's edge and
/// the CT-like volume's dims (divisible by 6, so that ×2 and ×3 grids
/// land on whole voxels and unu's grid is the convention's).
fn sizes(quick: bool) -> (u64, [u64; 3]) {
    if quick {
        (48, [48, 48, 30])
    } else {
        (120, [120, 120, 40])
    }
}

/// Run the study; writes `resample.csv`, `resample.md` and, with a font,
/// `resample.png` and `.svg`.
pub fn run(ctx: &Ctx, font: bool, peers: &Peers) -> Result<Vec<PathBuf>> {
    let quick = ctx.quick;
    check_volkit(ctx)?;
    for (name, p) in [
        ("SimpleITK", peers.python.as_ref().map(|_| ())),
        ("unu", peers.unu.as_ref().map(|_| ())),
    ] {
        if let Err(why) = p {
            say!("vol-accuracy: peer {name} skipped: {why}");
        }
    }
    let (n, ct) = sizes(quick);
    let inputs = [
        make_input(ctx, "iso", [n, n, n], [1.0; 3])?,
        make_input(ctx, "ct", ct, [0.5, 0.5, 2.0])?,
    ];
    let mut rows = Vec::new();
    for input in &inputs {
        let cases: Vec<Case> = if input.name == "iso" {
            [("down2", 2.0), ("down3", 3.0), ("up2", 0.5)]
                .iter()
                .map(|&(c, s)| Case {
                    name: format!("iso-{c}"),
                    spacing: [s; 3],
                    spec: format!("spacing:{s}"),
                })
                .collect()
        } else {
            vec![Case {
                name: "ct-1mm".into(),
                spacing: [1.0; 3],
                spec: "spacing:1".into(),
            }]
        };
        for case in &cases {
            rows.extend(resample_case(ctx, input, case, peers)?);
        }
        let sigmas: &[f64] = if input.name == "iso" {
            &[0.5, 1.0, 2.0]
        } else {
            &[1.0]
        };
        for &sigma in sigmas {
            rows.extend(smooth_case(ctx, input, sigma, peers)?);
        }
    }
    let csv = ctx.out.join("resample.csv");
    let md = ctx.out.join("resample.md");
    write_via_temp(&csv, "partial", &csv_text(&rows))?;
    write_via_temp(&md, "partial", &summary(&rows))?;
    if font {
        plot(&ctx.out, &rows, quick)?;
    }
    say!("vol-accuracy: wrote {} and {}", csv.display(), md.display());
    Ok(vec![csv, md])
}

/// Refuse a vol-convert without the issue's flags, with one line.
fn check_volkit(ctx: &Ctx) -> Result<()> {
    let help = tool(ctx, "vol-convert", &strs(&["--help"]))?;
    for flag in ["--resample", "--kernel", "--no-antialias", "--smooth"] {
        if !help.contains(flag) {
            bail!("this vol-convert has no {flag} (issue 52's preprocessing): rebuild it");
        }
    }
    Ok(())
}

/// Generate the waves volume of `dims` at `spacing` and write it as NIfTI
/// and NRRD (f32).
fn make_input(ctx: &Ctx, name: &'static str, dims: [u64; 3], spacing: [f64; 3]) -> Result<Input> {
    let vvol = ctx.out.join(format!("waves-{name}.vvol"));
    let nii = ctx.out.join(format!("waves-{name}.nii"));
    let nrrd = ctx.out.join(format!("waves-{name}.nrrd"));
    say!(
        "vol-accuracy: waves {name}: {}x{}x{} at {},{},{}",
        dims[0],
        dims[1],
        dims[2],
        spacing[0],
        spacing[1],
        spacing[2]
    );
    tool(
        ctx,
        "vol-gen",
        &[
            "waves".into(),
            "--dims".into(),
            format!("{},{},{}", dims[0], dims[1], dims[2]),
            "--spacing".into(),
            format!("{},{},{}", spacing[0], spacing[1], spacing[2]),
            "--type".into(),
            "f32".into(),
            "--seed".into(),
            SEED.into(),
            "--value".into(),
            PEAK.to_string(),
            "-o".into(),
            path_arg(&vvol)?,
            "--quiet".into(),
        ],
    )?;
    for out in [&nii, &nrrd] {
        tool(
            ctx,
            "vol-convert",
            &[path_arg(&vvol)?, "-q".into(), "-o".into(), path_arg(out)?],
        )?;
    }
    Ok(Input {
        name,
        dims,
        spacing,
        nii,
        nrrd,
    })
}

/// Run `cmd` (program and arguments) `repeat` times: the wall seconds of
/// each run.
fn time_runs(program: &Path, args: &[String], repeat: u32) -> Result<Vec<f64>> {
    let mut runs = Vec::new();
    for _ in 0..repeat {
        let t = Instant::now();
        let out = Command::new(program)
            .args(args)
            .stdin(Stdio::null())
            .output()
            .with_context(|| format!("{}: cannot start", program.display()))?;
        runs.push(t.elapsed().as_secs_f64());
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let line = err.lines().next().unwrap_or("failed without a message");
            bail!("{} {}: {line}", program.display(), args.join(" "));
        }
    }
    Ok(runs)
}

/// Median, fastest and slowest of some runs.
fn spread(runs: &[f64]) -> (f64, f64, f64) {
    let mut v: Vec<f64> = runs.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let m = if v.len() % 2 == 1 {
        v[v.len() / 2]
    } else {
        (v[v.len() / 2 - 1] + v[v.len() / 2]) / 2.0
    };
    (m, v[0], v[v.len() - 1])
}

/// What an output holds against the exact answer.
struct Score {
    psnr_db: f64,
    psnr_lowpass_db: Option<f64>,
    max_err: f64,
    grid_same: bool,
}

/// Compare the volume at `path` with `exact` (and `lowpass`), both in
/// world coordinates, over the voxels at least `margin` (world units, per
/// axis) inside the input's box of voxel centres `[0, (n−1)s]`; check its
/// grid against `grid` (dims, spacing, origin) when given.
fn score(
    path: &Path,
    exact: &Waves,
    lowpass: Option<&Waves>,
    input: &Input,
    margin: [f64; 3],
    grid: Option<([u64; 3], [f64; 3], [f64; 3])>,
) -> Result<Score> {
    let vol =
        volformats::open(path, &volformats::ReadOptions::default()).map_err(|e| anyhow!("{e}"))?;
    let d = vol.meta.dims.as_array();
    let s = vol.meta.spacing.map(f64::from);
    let g = vol.meta.geometry;
    let values = vol.to_f32_vec();
    let grid_same = grid.is_none_or(|(n, sp, o)| {
        n == d
            && (0..3).all(|a| {
                (sp[a] - s[a]).abs() <= 1e-5 * sp[a]
                    && (o[a] - g.origin[a]).abs() <= 1e-4 * sp[a]
                    && (0..3)
                        .all(|b| (g.direction[a][b] - f64::from(u8::from(a == b))).abs() < 1e-6)
            })
    });
    let hi: Vec<f64> = (0..3)
        .map(|a| (input.dims[a] - 1) as f64 * input.spacing[a] - margin[a])
        .collect();
    let (mut se, mut se_low, mut worst, mut count) = (0.0f64, 0.0f64, 0.0f64, 0u64);
    let mut i = 0usize;
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                let v = f64::from(values[i]);
                i += 1;
                let idx = [x as f64 * s[0], y as f64 * s[1], z as f64 * s[2]];
                let p: [f64; 3] = [0, 1, 2].map(|r| {
                    g.origin[r]
                        + g.direction[r][0] * idx[0]
                        + g.direction[r][1] * idx[1]
                        + g.direction[r][2] * idx[2]
                });
                if (0..3).any(|a| p[a] < margin[a] || p[a] > hi[a]) {
                    continue;
                }
                let e = v - exact.at(p);
                se += e * e;
                worst = worst.max(e.abs());
                if let Some(l) = lowpass {
                    let e = v - l.at(p);
                    se_low += e * e;
                }
                count += 1;
            }
        }
    }
    if count == 0 {
        bail!(
            "{}: no voxel lies {:?} inside the input (volume too small for the margin)",
            path.display(),
            margin
        );
    }
    let psnr = |se: f64| 10.0 * (PEAK * PEAK / (se / count as f64).max(1e-300)).log10();
    Ok(Score {
        psnr_db: psnr(se),
        psnr_lowpass_db: lowpass.map(|_| psnr(se_low)),
        max_err: worst / PEAK,
        grid_same,
    })
}

/// One output's row.
#[allow(clippy::too_many_arguments)]
fn row(
    study: &'static str,
    case: &str,
    tool: &'static str,
    kernel: &str,
    antialias: &'static str,
    runs: &[f64],
    s: Score,
) -> Row {
    let (median_s, min_s, max_s) = spread(runs);
    say!(
        "vol-accuracy: {case} {tool} {kernel} aa={antialias}: {} s, PSNR {:.2} dB{}{}",
        seconds(median_s),
        s.psnr_db,
        s.psnr_lowpass_db
            .map_or(String::new(), |p| format!(" (low-pass {p:.2} dB)")),
        if s.grid_same { "" } else { ", another grid" }
    );
    Row {
        study,
        case: case.to_string(),
        tool,
        kernel: kernel.to_string(),
        antialias,
        median_s,
        min_s,
        max_s,
        psnr_db: s.psnr_db,
        psnr_lowpass_db: s.psnr_lowpass_db,
        max_err: s.max_err,
        grid_same: s.grid_same,
    }
}

/// Every tool and kernel on one resampling case.
fn resample_case(ctx: &Ctx, input: &Input, case: &Case, peers: &Peers) -> Result<Vec<Row>> {
    let (n, origin) = expected_grid(input.dims, input.spacing, case.spacing);
    let grid = Some((n, case.spacing, origin));
    let voxels = Waves::new(SEED.parse()?, PEAK);
    let exact = voxels.in_world(input.spacing);
    let lowpass = exact.lowpassed(case.spacing);
    let margin = input.spacing.map(|s| MARGIN * s);
    let downsamples = (0..3).any(|a| case.spacing[a] > input.spacing[a]);
    let mut rows = Vec::new();
    let vc = ctx.bin.join(exe("vol-convert"));
    for kernel in VOLKIT_KERNELS {
        let modes: &[bool] = if downsamples { &[true, false] } else { &[true] };
        for &aa in modes {
            let out = ctx.out.join(format!(
                "{}-volkit-{kernel}{}.nii",
                case.name,
                if aa { "" } else { "-noaa" }
            ));
            let mut args = vec![
                path_arg(&input.nii)?,
                "--resample".into(),
                case.spec.clone(),
                "--kernel".into(),
                kernel.into(),
                "-q".into(),
                "-o".into(),
                path_arg(&out)?,
            ];
            if !aa {
                args.push("--no-antialias".into());
            }
            let runs = time_runs(&vc, &args, ctx.repeat)?;
            let s = score(&out, &exact, Some(&lowpass), input, margin, grid)?;
            let label = match (downsamples, aa) {
                (false, _) => "-",
                (true, true) => "yes",
                (true, false) => "no",
            };
            rows.push(row(
                "resample", &case.name, "volkit", kernel, label, &runs, s,
            ));
        }
    }
    if let Ok(py) = &peers.python {
        let prefix = ctx.out.join(format!("{}-sitk", case.name));
        let mut args = vec![
            path_arg(&ctx.out.join("sitk_peer.py"))?,
            "resample".into(),
            path_arg(&input.nii)?,
            path_arg(&prefix)?,
            ctx.repeat.to_string(),
        ];
        args.extend(n.iter().map(u64::to_string));
        args.extend(case.spacing.iter().map(f64::to_string));
        args.extend(origin.iter().map(f64::to_string));
        for line in python(ctx, py, &args)? {
            let s = score(&line.output, &exact, Some(&lowpass), input, margin, grid)?;
            let aa = if downsamples { "no" } else { "-" };
            rows.push(row(
                "resample",
                &case.name,
                "SimpleITK",
                &line.kernel,
                aa,
                &line.runs,
                s,
            ));
        }
    }
    if let Ok(unu) = &peers.unu {
        let sizes: Vec<String> = n.iter().map(u64::to_string).collect();
        // unu always widens the kernel when downsampling; its one way
        // around that is `-k cheap` (subsampling by nearest): the
        // `-old -cheap` path refuses NRRDs with space directions.
        let cheap = downsamples.then_some("cheap");
        for kernel in UNU_KERNELS.into_iter().chain(cheap) {
            let tag = kernel.replace([':', ','], "_").replace('+', "-");
            let out = ctx.out.join(format!("{}-unu-{tag}.nrrd", case.name));
            let runs = unu_resample(ctx, unu, &input.nrrd, &out, &sizes, kernel)?;
            let s = score(&out, &exact, Some(&lowpass), input, margin, grid)?;
            let label = match (downsamples, kernel) {
                (false, _) => "-",
                (true, "cheap") => "no",
                (true, _) => "yes",
            };
            rows.push(row("resample", &case.name, "unu", kernel, label, &runs, s));
        }
    }
    Ok(rows)
}

/// `unu resample` to `sizes` with `kernel` (`A+B`: prefilter with A at
/// the same size, then B), cell-centred; wall seconds of each run (both
/// passes of a prefiltered kernel).
fn unu_resample(
    ctx: &Ctx,
    unu: &Path,
    input: &Path,
    out: &Path,
    sizes: &[String],
    kernel: &str,
) -> Result<Vec<f64>> {
    let pass = |k: &str, sizes: &[String], from: &Path, to: &Path| -> Result<Vec<String>> {
        let mut a = strs(&["resample", "-i"]);
        a.push(path_arg(from)?);
        a.push("-s".into());
        a.extend(sizes.iter().cloned());
        a.extend(["-k".into(), k.into(), "-c".into(), "cell".into()]);
        a.extend(["-o".into(), path_arg(to)?]);
        Ok(a)
    };
    match kernel.split_once('+') {
        None => time_runs(unu, &pass(kernel, sizes, input, out)?, ctx.repeat),
        Some((pre, k)) => {
            let mid = out.with_extension("pre.nrrd");
            let same = strs(&["x1", "x1", "x1"]);
            let a = pass(pre, &same, input, &mid)?;
            let b = pass(k, sizes, &mid, out)?;
            let mut runs = Vec::new();
            for _ in 0..ctx.repeat {
                let ta = time_runs(unu, &a, 1)?;
                let tb = time_runs(unu, &b, 1)?;
                runs.push(ta[0] + tb[0]);
            }
            let _ = std::fs::remove_file(&mid);
            Ok(runs)
        }
    }
}

/// One filter's runs as the Python peer reported them.
struct PyLine {
    kernel: String,
    runs: Vec<f64>,
    output: PathBuf,
}

/// Run the SimpleITK peer script; its JSON lines.
fn python(ctx: &Ctx, py: &Path, args: &[String]) -> Result<Vec<PyLine>> {
    let script = ctx.out.join("sitk_peer.py");
    std::fs::write(&script, SITK_PY)
        .with_context(|| format!("{}: cannot write", script.display()))?;
    let out = Command::new(py)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("{}: cannot start", py.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err.lines().last().unwrap_or("failed without a message");
        bail!("SimpleITK peer {}: {line}", args.join(" "));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| {
            let v: serde_json::Value =
                serde_json::from_str(l).context("the SimpleITK peer printed bad JSON")?;
            Ok(PyLine {
                kernel: v["kernel"].as_str().unwrap_or("?").to_string(),
                runs: v["runs"]
                    .as_array()
                    .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
                    .unwrap_or_default(),
                output: PathBuf::from(v["output"].as_str().unwrap_or_default()),
            })
        })
        .collect()
}

/// Every Gaussian on one σ (world units, every axis).
fn smooth_case(ctx: &Ctx, input: &Input, sigma: f64, peers: &Peers) -> Result<Vec<Row>> {
    let case = format!("{}-gauss{sigma}", input.name);
    let exact = Waves::new(SEED.parse()?, PEAK)
        .in_world(input.spacing)
        .smoothed([sigma; 3]);
    let margin = input.spacing.map(|s| (MARGIN * s).max(5.0 * sigma));
    let same = Some((input.dims, input.spacing, [0.0; 3]));
    let mut rows = Vec::new();
    let out = ctx.out.join(format!("{case}-volkit.nii"));
    let args = vec![
        path_arg(&input.nii)?,
        "--smooth".into(),
        format!("gauss:{sigma}"),
        "-q".into(),
        "-o".into(),
        path_arg(&out)?,
    ];
    let runs = time_runs(&ctx.bin.join(exe("vol-convert")), &args, ctx.repeat)?;
    let s = score(&out, &exact, None, input, margin, same)?;
    rows.push(row(
        "smooth",
        &case,
        "volkit",
        &format!("gauss:{sigma}"),
        "-",
        &runs,
        s,
    ));
    if let Ok(py) = &peers.python {
        let prefix = ctx.out.join(format!("{case}-sitk"));
        let mut args = vec![
            path_arg(&ctx.out.join("sitk_peer.py"))?,
            "smooth".into(),
            path_arg(&input.nii)?,
            path_arg(&prefix)?,
            ctx.repeat.to_string(),
        ];
        args.extend([sigma; 3].iter().map(f64::to_string));
        for line in python(ctx, py, &args)? {
            let s = score(&line.output, &exact, None, input, margin, same)?;
            rows.push(row(
                "smooth",
                &case,
                "SimpleITK",
                &line.kernel,
                "-",
                &line.runs,
                s,
            ));
        }
    }
    if let Ok(unu) = &peers.unu {
        // unu's Gaussian lives in index space: σ in voxels per axis, so
        // one pass per axis when the spacing differs.
        let out = ctx.out.join(format!("{case}-unu.nrrd"));
        let ks: Vec<String> = input
            .spacing
            .iter()
            .map(|s| format!("gauss:{},4", sigma / s))
            .collect();
        let runs = if ks.iter().all(|k| *k == ks[0]) {
            let mut a = strs(&["resample", "-i"]);
            a.push(path_arg(&input.nrrd)?);
            a.extend(strs(&["-s", "x1", "x1", "x1", "-k"]));
            a.push(ks[0].clone());
            a.extend(["-o".into(), path_arg(&out)?]);
            time_runs(unu, &a, ctx.repeat)?
        } else {
            let mut runs = vec![0.0; ctx.repeat as usize];
            let mut from = input.nrrd.clone();
            for (axis, k) in ks.iter().enumerate() {
                let to = out.with_extension(format!("{axis}.nrrd"));
                let mut sz = strs(&["=", "=", "="]);
                sz[axis] = "x1".into();
                let mut a = strs(&["resample", "-i"]);
                a.push(path_arg(&from)?);
                a.push("-s".into());
                a.extend(sz);
                a.extend(["-k".into(), k.clone(), "-o".into(), path_arg(&to)?]);
                for (r, t) in runs.iter_mut().zip(time_runs(unu, &a, ctx.repeat)?) {
                    *r += t;
                }
                from = to;
            }
            std::fs::rename(&from, &out)
                .with_context(|| format!("{}: cannot write", out.display()))?;
            runs
        };
        let s = score(&out, &exact, None, input, margin, same)?;
        rows.push(row(
            "smooth",
            &case,
            "unu",
            &format!("gauss:{sigma}"),
            "-",
            &runs,
            s,
        ));
    }
    Ok(rows)
}

/// The CSV of every output.
fn csv_text(rows: &[Row]) -> String {
    let mut s = String::from(
        "study,case,tool,kernel,antialias,median_s,min_s,max_s,psnr_db,psnr_lowpass_db,max_err,grid\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},\"{}\",{},{:.6},{:.6},{:.6},{:.3},{},{:.3e},{}",
            r.study,
            r.case,
            r.tool,
            r.kernel,
            r.antialias,
            r.median_s,
            r.min_s,
            r.max_s,
            r.psnr_db,
            r.psnr_lowpass_db
                .map_or(String::new(), |p| format!("{p:.3}")),
            r.max_err,
            if r.grid_same { "same" } else { "differs" }
        );
    }
    s
}

/// Seconds for the tables: milliseconds shown, not an exponent.
fn secs(x: f64) -> String {
    if x >= 10.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3}")
    }
}

/// A Markdown table per case.
fn summary(rows: &[Row]) -> String {
    let mut s = String::new();
    let mut cases: Vec<&str> = Vec::new();
    for r in rows {
        if !cases.contains(&r.case.as_str()) {
            cases.push(&r.case);
        }
    }
    for case in cases {
        let these: Vec<&Row> = rows.iter().filter(|r| r.case == case).collect();
        let resample = these.iter().any(|r| r.study == "resample");
        let _ = writeln!(s, "\n**{case}**\n");
        if resample {
            s.push_str("| tool | kernel | anti-alias | time (s) | PSNR (dB) | PSNR vs low-pass (dB) | max error | grid |\n|---|---|---|---|---|---|---|---|\n");
        } else {
            s.push_str("| tool | filter | time (s) | PSNR (dB) | max error | grid |\n|---|---|---|---|---|---|\n");
        }
        for r in these {
            let grid = if r.grid_same { "same" } else { "differs" };
            if resample {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {:.1} | {} | {:.1e} | {grid} |",
                    r.tool,
                    r.kernel,
                    r.antialias,
                    secs(r.median_s),
                    r.psnr_db,
                    r.psnr_lowpass_db
                        .map_or("-".to_string(), |p| format!("{p:.1}")),
                    r.max_err
                );
            } else {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.1} | {:.1e} | {grid} |",
                    r.tool,
                    r.kernel,
                    secs(r.median_s),
                    r.psnr_db,
                    r.max_err
                );
            }
        }
    }
    s
}

/// The tools in plot order (one colour each).
const TOOLS: [&str; 3] = ["volkit", "SimpleITK", "unu"];

/// PSNR against time, one panel per case, one colour per tool (hollow
/// markers: without anti-aliasing), as PNG and SVG; see [`y_of`].
fn plot(out: &Path, rows: &[Row], smoke: bool) -> Result<()> {
    let png = out.join("resample.png");
    let svg = out.join("resample.svg");
    let size = grid_size(cases_of(rows).len(), (430, 360));
    write_png_svg(&png, &svg, size, &ResampleChart { rows, smoke })
}

/// The study's plot: its rows, and whether a quick run made it.
struct ResampleChart<'a> {
    rows: &'a [Row],
    smoke: bool,
}

/// The cases in study order.
fn cases_of(rows: &[Row]) -> Vec<String> {
    let mut cases: Vec<String> = Vec::new();
    for r in rows {
        if !cases.contains(&r.case) {
            cases.push(r.case.clone());
        }
    }
    cases
}

/// What a row's marker shows: for resampling the PSNR against the output
/// grid's ideal low-pass (what a resampler should aim at: against the
/// point samples, aliasing would score perfectly), for smoothing against
/// the exact convolution.
fn y_of(r: &Row) -> f64 {
    r.psnr_lowpass_db.unwrap_or(r.psnr_db)
}

/// The chart on any backend.
impl Chart for ResampleChart<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (rows, smoke) = (self.rows, self.smoke);
        root.fill(&WHITE).map_err(drawing_error)?;
        let title = if smoke {
            "resample: SMOKE TEST (quick run: tiny sizes, one run each; not a result)".to_string()
        } else {
            "Resampling and smoothing: PSNR against the exact function, by time".to_string()
        };
        let cases = cases_of(rows);
        let areas = titled_grid(&root, &title, cases.len())?;
        for (case, area) in cases.iter().zip(areas.iter()) {
            let pts: Vec<&Row> = rows
                .iter()
                .filter(|r| &r.case == case && y_of(r).is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let (mut t0, mut t1, mut p0, mut p1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for r in &pts {
                t0 = t0.min(r.min_s);
                t1 = t1.max(r.max_s);
                p0 = p0.min(y_of(r));
                p1 = p1.max(y_of(r));
            }
            let (t0, t1) = ((t0 * 0.7).max(1e-6), (t1 * 1.6).max(t0 * 2.0));
            let (p0, p1) = ((p0 - 3.0).floor(), (p1 + 4.0).ceil());
            let mut chart = ChartBuilder::on(area)
                .caption(case, ("sans-serif", 17))
                .margin(10)
                .x_label_area_size(38)
                .y_label_area_size(48)
                .build_cartesian_2d((t0..t1).log_scale(), p0..p1)
                .map_err(drawing_error)?;
            chart
                .configure_mesh()
                .x_desc("median time (s, log)")
                .y_desc(if pts.iter().any(|r| r.psnr_lowpass_db.is_some()) {
                    "PSNR against the low-pass (dB)"
                } else {
                    "PSNR against the convolution (dB)"
                })
                .x_labels(5)
                .y_labels(6)
                .x_label_formatter(&|x| seconds(*x))
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(drawing_error)?;
            for (t, name) in TOOLS.iter().enumerate() {
                let colour = COLOURS[t % COLOURS.len()];
                let mine: Vec<&&Row> = pts.iter().filter(|r| r.tool == *name).collect();
                if mine.is_empty() {
                    continue;
                }
                chart
                    .draw_series(mine.iter().map(|r| {
                        PathElement::new(
                            vec![(r.min_s, y_of(r)), (r.max_s, y_of(r))],
                            colour.stroke_width(1),
                        )
                    }))
                    .map_err(drawing_error)?;
                chart
                    .draw_series(mine.iter().map(|r| {
                        let style = if r.antialias == "no" {
                            colour.stroke_width(2)
                        } else {
                            colour.filled()
                        };
                        Circle::new((r.median_s, y_of(r)), 4, style)
                    }))
                    .map_err(drawing_error)?
                    .label(*name)
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, colour.filled()));
                let lift = (p1 - p0) / 30.0;
                chart
                    .draw_series(mine.iter().enumerate().map(|(j, r)| {
                        let dy = lift * [1.2, -1.0, 2.6][j % 3];
                        let label = if r.antialias == "no" {
                            format!("{} (no AA)", r.kernel)
                        } else {
                            r.kernel.clone()
                        };
                        Text::new(
                            label,
                            (r.median_s * 1.06, y_of(r) + dy),
                            ("sans-serif", 11).into_font().color(&colour.mix(0.9)),
                        )
                    }))
                    .map_err(drawing_error)?;
            }
            legend(&mut chart)?;
        }
        root.present().map_err(drawing_error)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The convention's grid: CT 0.5 × 0.5 × 2 to 1 mm, and ×3 on a
    /// length that does not divide (the new box centred on the old).
    #[test]
    fn expected_grid_follows_the_issue_convention() {
        let (n, o) = expected_grid([120, 120, 40], [0.5, 0.5, 2.0], [1.0; 3]);
        assert_eq!(n, [60, 60, 80]);
        // Old centres 0..59.5 (x), 0..78 (z); new ones 0.25..59.25, -0.5..78.5.
        assert_eq!(o, [0.25, 0.25, -0.5]);
        let (n, o) = expected_grid([128, 1, 1], [1.0; 3], [3.0; 3]);
        assert_eq!(n, [43, 1, 1]);
        // Box 129 wide centred on 128: origin 63.5 - 63.
        assert!((o[0] - 0.5).abs() < 1e-12);
        assert_eq!(o[1], 0.0);
    }

    /// The median of an even count is the mean of the middle two.
    #[test]
    fn spread_takes_the_median() {
        assert_eq!(spread(&[3.0, 1.0, 2.0]), (2.0, 1.0, 3.0));
        assert_eq!(spread(&[4.0, 1.0, 2.0, 3.0]), (2.5, 1.0, 4.0));
    }
}
