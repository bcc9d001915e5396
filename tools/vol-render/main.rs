//! vol-render: a tiled, parallel CPU ray caster. The command line is
//! parsed in [`args`], resolved against the volume in [`plan`], and the
//! frame rendered and written here.

mod args;
mod plan;

use anyhow::{bail, Context, Result};
use args::Cli;
use plan::Plan;
use std::process::ExitCode;
use std::time::Instant;
use volcore::Volume;
use volformats::image::{write_heatmap, write_pfm, write_png8};
use volformats::{open_volume, vvol};
use volindex::{BuildOptions, MajorantIndex};
use volrender::{render_tf, Frame};

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-render") {
        Ok(c) => c,
        Err(code) => return code,
    };
    volkit_cli::run("vol-render", || run(&cli))
}

fn run(cli: &Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the worker threads")?;
    }
    let name = cli.volume.display().to_string();
    let t = Instant::now();
    let opts = vvol::OpenOptions {
        in_memory: cli.in_memory,
        ..Default::default()
    };
    let vol = open_volume(&cli.volume, opts, None).with_context(|| name.clone())?;
    let load_s = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let index = load_index(cli, &vol)?;
    let index_s = t.elapsed().as_secs_f64();

    let plan = Plan::new(cli, &vol, index.as_ref())?;
    if !cli.quiet {
        for note in &plan.notes {
            volkit_cli::noteln!("vol-render: {name}: {note}");
        }
    }
    let mut times = Vec::new();
    let mut frame: Option<Frame> = None;
    for _ in 0..cli.repeat.max(1) {
        let f = render_tf(
            &vol,
            index.as_ref(),
            plan.tf.as_ref(),
            &plan.camera,
            &plan.settings,
        )
        .with_context(|| name.clone())?;
        times.push(f.stats.render_s);
        frame = Some(f);
    }
    let Some(frame) = frame else {
        bail!("nothing rendered")
    };
    if let Some(e) = vol.error() {
        bail!("{name}: {e}");
    }
    times.sort_by(f64::total_cmp);
    let render_s = times[times.len() / 2];
    write_outputs(cli, &frame)?;
    report(cli, &frame, load_s, index_s, render_s, &times);
    Ok(())
}

fn load_index(cli: &Cli, vol: &Volume) -> Result<Option<MajorantIndex>> {
    if cli.no_ess {
        return Ok(None);
    }
    match &cli.index {
        Some(p) => {
            let name = p.display().to_string();
            let fp = volformats::fingerprint(&cli.volume)
                .with_context(|| cli.volume.display().to_string())?;
            let mut f =
                std::io::BufReader::new(std::fs::File::open(p).with_context(|| name.clone())?);
            let ix = MajorantIndex::read_for_volume(&mut f, &vol.meta, fp)
                .with_context(|| name.clone())?;
            Ok(Some(ix))
        }
        None => {
            let opts = BuildOptions {
                cell_edge: cli.cell,
                ..Default::default()
            };
            let ix = MajorantIndex::build_volume(vol, &opts, 0)
                .with_context(|| format!("{}: building the index", cli.volume.display()))?;
            Ok(Some(ix))
        }
    }
}

/// The PNG, and the float image and heat map when asked for.
fn write_outputs(cli: &Cli, frame: &Frame) -> Result<()> {
    let (w, h) = (frame.width, frame.height);
    let channels = if cli.alpha { 4 } else { 3 };
    write_png8(&cli.output, w, h, channels, &frame.srgb8(cli.alpha))
        .with_context(|| cli.output.display().to_string())?;
    if let Some(p) = &cli.hdr {
        write_pfm(p, w, h, &frame.linear_rgb()).with_context(|| p.display().to_string())?;
    }
    if let Some(p) = &cli.heatmap {
        write_heatmap(p, &frame.sample_counts(), w, h).with_context(|| p.display().to_string())?;
    }
    Ok(())
}

/// The process's peak resident memory in MiB (Linux; `None` elsewhere).
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn report(cli: &Cli, frame: &Frame, load_s: f64, index_s: f64, render_s: f64, times: &[f64]) {
    let s = &frame.stats;
    let mpix = (frame.width as f64 * frame.height as f64) / 1e6;
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-render",
            "path": cli.volume.display().to_string(),
            "output": cli.output.display().to_string(),
            "mode": format!("{:?}", cli.mode).to_lowercase(),
            "width": frame.width,
            "height": frame.height,
            "threads": rayon::current_num_threads(),
            "rays": s.rays,
            "samples": s.samples,
            "skips": s.skips,
            "load_s": load_s,
            "index_s": index_s,
            "render_s": render_s,
            "render_runs_s": times,
            "samples_per_s": s.samples as f64 / render_s.max(1e-12),
            "ert": !cli.no_ert,
            "ess": !cli.no_ess,
            "peak_rss_mb": peak_rss_mb(),
        });
        println!("{v}");
    } else if !cli.quiet {
        eprintln!(
            "vol-render: {} {}x{} in {:.3} s ({:.1} Mpix/s), {} rays, {:.1} M samples, {} skips; load {:.2} s, index {:.2} s",
            cli.output.display(),
            frame.width,
            frame.height,
            render_s,
            mpix / render_s.max(1e-12),
            s.rays,
            s.samples as f64 / 1e6,
            s.skips,
            load_s,
            index_s
        );
    }
}
