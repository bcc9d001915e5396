//! vol-render: a tiled, parallel CPU ray caster. The command line is
//! parsed in [`args`], resolved against the volume in [`plan`], and the
//! frame rendered and written here.

mod args;
mod path;
mod plan;
#[cfg(feature = "mpi")]
mod ranks;
mod scene;

use anyhow::{bail, Context, Result};
use args::Cli;
use clap::parser::ValueSource;
use plan::Plan;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use volcore::Volume;
use volformats::image::{write_heatmap, write_pfm, write_png8};
use volformats::{open_volume, vvol};
use volindex::{BuildOptions, MajorantIndex};
use volkit_cli::{noteln, outln};
use volrender::{render_tf, Frame};

fn main() -> ExitCode {
    #[cfg(feature = "mpi")]
    if ranks::launched() {
        return ranks::main();
    }
    let (mut cli, matches) = match volkit_cli::run::parse_matches::<Cli>("vol-render") {
        Ok(parsed) => parsed,
        Err(code) => return code,
    };
    volkit_cli::run("vol-render", || {
        let volume = resolve_cli(&mut cli, &matches)?;
        run(&cli, &volume)
    })
}

/// Fill `cli` from its `--scene` file (options given on the command line
/// win) and check that there is a volume and an output: the volume's path.
fn resolve_cli(cli: &mut Cli, matches: &clap::ArgMatches) -> Result<PathBuf> {
    let given = |id: &str| matches.value_source(id) == Some(ValueSource::CommandLine);
    cli.background_given = matches.value_source("background") == Some(ValueSource::CommandLine);
    if let Some(path) = cli.scene.clone() {
        let file = volkit_cli::scene::Scene::read(&path)?;
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        scene::apply(file, &dir, cli, given);
    }
    let volume = cli.volume.clone().ok_or_else(|| {
        volkit_cli::usage("no volume: give its path, or `volume` in the --scene file")
    })?;
    if cli.output.is_none() && !cli.print_scene {
        return Err(volkit_cli::usage(
            "no output: give -o FILE.png, or `output` in the --scene file",
        ));
    }
    Ok(volume)
}

/// Start the worker pool with `--threads` workers (rayon's default, one
/// per core, without it).
fn start_threads(cli: &Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the worker threads")?;
    }
    Ok(())
}

fn run(cli: &Cli, volume: &Path) -> Result<()> {
    start_threads(cli)?;
    let name = volume.display().to_string();
    let t = Instant::now();
    let opts = vvol::OpenOptions {
        in_memory: cli.in_memory,
        ..Default::default()
    };
    let vol = open_volume(volume, opts, None).with_context(|| name.clone())?;
    let load_s = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let index = load_index(cli, volume, &vol)?;
    let index_s = t.elapsed().as_secs_f64();

    let plan = Plan::new(cli, &vol, index.as_ref()).with_context(|| name.clone())?;
    let effective = scene::effective(cli, &plan.resolved);
    if cli.print_scene {
        outln!("{}", volkit_cli::scene::to_toml(&effective)?)?;
        return Ok(());
    }
    let Some(output) = cli.output.as_deref() else {
        bail!("no output")
    };
    if !cli.quiet {
        for note in &plan.notes {
            noteln!("vol-render: {name}: {note}");
        }
    }
    if let Some((settings, budget)) = &plan.path {
        let run = path::Run {
            cli,
            volume,
            output,
            camera: &plan.camera,
            load_s,
            index_s,
            scene: serde_json::to_value(&effective)?,
        };
        return path::run(&run, &vol, index.as_ref(), settings, budget);
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
    write_outputs(cli, output, &frame)?;
    let scene = serde_json::to_value(&effective)?;
    let times = Times {
        load_s,
        index_s,
        render_s,
        runs: &times,
    };
    report(cli, volume, output, &frame, &times, scene, None)?;
    Ok(())
}

fn load_index(cli: &Cli, volume: &Path, vol: &Volume) -> Result<Option<MajorantIndex>> {
    if cli.no_ess {
        return Ok(None);
    }
    match &cli.index {
        Some(p) => {
            let name = p.display().to_string();
            let fp =
                volformats::fingerprint(volume).with_context(|| volume.display().to_string())?;
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
                .with_context(|| format!("{}: building the index", volume.display()))?;
            Ok(Some(ix))
        }
    }
}

/// The PNG, and the float image and heat map when asked for.
fn write_outputs(cli: &Cli, output: &Path, frame: &Frame) -> Result<()> {
    let (w, h) = (frame.width, frame.height);
    let channels = if cli.alpha { 4 } else { 3 };
    write_png8(output, w, h, channels, &frame.srgb8(cli.alpha))
        .with_context(|| output.display().to_string())?;
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

/// How long each part took, seconds.
struct Times<'a> {
    load_s: f64,
    index_s: f64,
    render_s: f64,
    runs: &'a [f64],
}

/// What a data-parallel frame adds to the report: keys for `--json` and a
/// line for people.
#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
struct RankReport {
    /// A JSON object whose keys join the report's.
    json: serde_json::Value,
    /// One line (without the tool's name).
    line: String,
}

fn report(
    cli: &Cli,
    volume: &Path,
    output: &Path,
    frame: &Frame,
    t: &Times,
    scene: serde_json::Value,
    ranks: Option<&RankReport>,
) -> Result<()> {
    let s = &frame.stats;
    let (load_s, index_s, render_s) = (t.load_s, t.index_s, t.render_s);
    let mpix = (frame.width as f64 * frame.height as f64) / 1e6;
    if cli.json {
        let mut v = serde_json::json!({
            "tool": "vol-render",
            "path": volume.display().to_string(),
            "output": output.display().to_string(),
            "mode": format!("{:?}", cli.mode).to_lowercase(),
            "width": frame.width,
            "height": frame.height,
            "threads": rayon::current_num_threads(),
            "rays": s.rays,
            "samples": s.samples,
            "skips": s.skips,
            "culled_blocks": s.culled_blocks,
            "load_s": load_s,
            "index_s": index_s,
            "render_s": render_s,
            "render_runs_s": t.runs,
            "samples_per_s": s.samples as f64 / render_s.max(1e-12),
            "ert": !cli.no_ert,
            "ess": !cli.no_ess,
            "peak_rss_mb": peak_rss_mb(),
            "scene": scene,
        });
        if let (Some(r), Some(obj)) = (ranks, v.as_object_mut()) {
            if let Some(extra) = r.json.as_object() {
                obj.extend(extra.clone());
            }
        }
        // Each effect's counters, only when it is on.
        if cli.shadows.is_some() {
            let e = &s.effects;
            v["shadow_rays"] = e.shadow_rays.into();
            v["shadow_samples"] = e.shadow_samples.into();
            v["shadow_grids"] = e.shadow_grids.into();
            v["shadow_grid_s"] = e.shadow_grid_s.into();
            v["shadow_grid_bytes"] = e.shadow_grid_bytes.into();
            v["shadow_grid_samples"] = e.shadow_grid_samples.into();
        }
        if cli.ao.is_some() || cli.ao_field.is_some() {
            let e = &s.effects;
            v["ao_rays"] = e.ao_rays.into();
            v["ao_samples"] = e.ao_samples.into();
            v["ao_grid_s"] = e.ao_grid_s.into();
            v["ao_grid_bytes"] = e.ao_grid_bytes.into();
            v["ao_grid_samples"] = e.ao_grid_samples.into();
        }
        if cli.ao_field.is_some() {
            let e = &s.effects;
            v["ao_field_s"] = e.ao_field_s.into();
            v["ao_field_bytes"] = e.ao_field_bytes.into();
            v["ao_field_samples"] = e.ao_field_samples.into();
            v["ao_field_cell"] = cli
                .ao_field_cell
                .unwrap_or(volrender::effects::ao::DEFAULT_AO_FIELD_CELL)
                .into();
        }
        outln!("{v}")?;
    } else if !cli.quiet {
        noteln!(
            "vol-render: {} {}x{} in {:.3} s ({:.1} Mpix/s), {} rays, {:.1} M samples, {} skips; load {:.2} s, index {:.2} s",
            output.display(),
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
        if let Some(r) = ranks {
            noteln!("vol-render: {}", r.line);
        }
        if cli.shadows.is_some() {
            let e = &s.effects;
            noteln!(
                "vol-render: shadows: {} shadow rays, {:.1} M shadow samples; {} grids ({:.1} MB, built in {:.3} s)",
                e.shadow_rays,
                e.shadow_samples as f64 / 1e6,
                e.shadow_grids,
                e.shadow_grid_bytes as f64 / 1e6,
                e.shadow_grid_s
            );
        }
        if cli.ao.is_some() || cli.ao_field.is_some() {
            let e = &s.effects;
            noteln!(
                "vol-render: ambient occlusion: {} rays, {:.1} M grid reads; occlusion grid {:.1} MB built in {:.3} s{}",
                e.ao_rays,
                e.ao_samples as f64 / 1e6,
                e.ao_grid_bytes as f64 / 1e6,
                e.ao_grid_s,
                if cli.ao_field.is_some() {
                    format!(
                        "; field (points every {} voxels) {:.1} MB precomputed in {:.3} s (not in the frame time)",
                        cli.ao_field_cell
                            .unwrap_or(volrender::effects::ao::DEFAULT_AO_FIELD_CELL),
                        e.ao_field_bytes as f64 / 1e6,
                        e.ao_field_s
                    )
                } else {
                    String::new()
                }
            );
        }
    }
    Ok(())
}
