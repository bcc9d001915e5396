//! The subprocess driver: runs vol-gen, vol-render, vol-psnr and
//! vol-convert from the directory they live in, insists on success, and
//! reads their `--json` reports (render times, PSNR).

use anyhow::{anyhow, bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Everything a render needs besides the scene and the setting.
pub struct Ctx {
    /// Directory holding the tools.
    pub bin: PathBuf,
    /// Directory for the volumes, images, CSV and plots.
    pub out: PathBuf,
    /// Runs per setting (the median is reported).
    pub repeat: u32,
    /// A quick (CI-sized) study.
    pub quick: bool,
}

/// The executable's file name on this platform.
pub fn exe(name: &str) -> String {
    format!("{name}{}", std::env::consts::EXE_SUFFIX)
}

/// Strings from string slices.
pub fn strs(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

/// A path as a command-line argument (must be UTF-8 for the tools).
pub fn path_arg(p: &Path) -> Result<String> {
    p.to_str()
        .map(str::to_string)
        .ok_or_else(|| anyhow!("{}: path is not UTF-8", p.display()))
}

/// Run a tool, insist on success, return its stdout.
pub fn tool(ctx: &Ctx, name: &str, args: &[String]) -> Result<String> {
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
pub struct Timing {
    /// Median frame time, seconds.
    pub median_s: f64,
    /// Fastest run, seconds.
    pub min_s: f64,
    /// Slowest run, seconds.
    pub max_s: f64,
    /// Samples taken.
    pub samples: u64,
    /// Precomputation outside the frame time (`ao_field_s`, or a
    /// budget's `probe_s`), seconds.
    pub build_s: f64,
}

/// Render once (or `repeat` times) with --hdr: the median, fastest and
/// slowest frame, the samples taken, and any precomputation.
pub fn render(
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
        // An AO field's precomputation, or a budget's probe frames.
        build_s: v["ao_field_s"]
            .as_f64()
            .or_else(|| v["budget"]["probe_s"].as_f64())
            .unwrap_or(0.0),
    })
}

/// PSNR (dB) of `b` against `a`; None when identical.
pub fn psnr(ctx: &Ctx, a: &Path, b: &Path) -> Result<Option<f64>> {
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
