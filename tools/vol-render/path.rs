//! `vol-render --mode path`: the path tracer's options resolved into its
//! settings, the progressive render (with a progress bar, an optional
//! state file to continue from, and a budget of samples, time or error),
//! and its outputs: a tone-mapped PNG, the linear image (.pfm or .exr),
//! a noise heat map and the figures.

use crate::args::{sun_spec, Cli, ModeArg, TonemapArg};
use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::path::Path;
use std::time::Instant;
use volcore::Volume;
use volformats::image::{write_exr, write_heatmap, write_pfm, write_png8};
use volindex::{BuildOptions, MajorantIndex};
use volkit_cli::{noteln, outln};
use volrender::classify::srgb_to_linear;
use volrender::path::{
    Accumulator, Budget, EnvMap, MajorantMode, MediumSpec, PathCounters, PathLights, PathSettings,
    PathTracer, PointLight, Sun,
};
use volrender::tf::Tf;
use volrender::{Camera, Light};

/// Samples per pixel when no budget is given.
pub const DEFAULT_SPP: u64 = 64;

/// Bytes a path-traced frame needs per pixel (f64 sums, the mean image
/// and its encodings), for the memory check.
const BYTES_PER_PIXEL: u64 = 32 + 12 + 12 + 8;

/// Options only the path tracer reads, refused in other modes (those with
/// defaults cannot be told from unset and are ignored there).
pub fn refuse_path_options(cli: &Cli) -> Result<()> {
    let given = [
        ("--spp", cli.spp.is_some()),
        ("--time", cli.time.is_some()),
        ("--until-error", cli.until_error.is_some()),
        ("--density-scale", cli.density_scale.is_some()),
        ("--albedo", cli.albedo.is_some()),
        ("--sun", !cli.sun.is_empty()),
        ("--env", cli.env.is_some()),
        ("--env-map", cli.env_map.is_some()),
        ("--hybrid", cli.hybrid.is_some()),
        ("--accumulate", cli.accumulate.is_some()),
        ("--variance", cli.variance.is_some()),
    ];
    match given.iter().find(|(_, g)| *g) {
        Some((flag, _)) => Err(volkit_cli::usage(format!("{flag} needs --mode path"))),
        None => Ok(()),
    }
}

/// The path tracer's settings and budget from the command line (and the
/// scene file's lights: directional ones are suns, point lights stay
/// point lights, the headlight has no place in a path-traced scene).
pub fn settings(
    cli: &Cli,
    lights: &[Light],
    tf: Option<&Tf>,
    notes: &mut Vec<String>,
) -> Result<(PathSettings, Budget)> {
    let medium = match (cli.density_scale, tf) {
        (Some(scale), _) => MediumSpec::Density {
            scale,
            albedo: cli.albedo.unwrap_or(Vec3::splat(0.8)),
        },
        (None, Some(Tf::OneD(t))) => {
            if cli.albedo.is_some() {
                bail!("--albedo is for --density-scale: with a transfer function the albedo is its colour");
            }
            MediumSpec::Table(t.clone())
        }
        (None, Some(Tf::TwoD(_))) => bail!(
            "--mode path takes a 1D transfer function (its medium has no gradient), or --density-scale"
        ),
        (None, None) => bail!("--mode path needs a transfer function or --density-scale"),
    };
    let mut suns = Vec::new();
    for s in &cli.sun {
        let (dir, e) = sun_spec(s).map_err(|e| volkit_cli::usage(format!("--sun {e}")))?;
        let Some(travel) = volrender::ray::unit(dir) else {
            bail!("--sun {s}: the direction must be finite and not zero");
        };
        suns.push(Sun {
            travel,
            irradiance: Vec3::splat(e),
        });
    }
    let mut points = Vec::new();
    // Lights from --light or the scene file; the default headlight is
    // not one the user asked for.
    if cli.light.is_some() || cli.lights.is_some() {
        for l in lights {
            match *l {
                Light::Directional { towards, radiance } => suns.push(Sun {
                    travel: -towards,
                    irradiance: radiance,
                }),
                Light::Point {
                    position,
                    intensity,
                } => points.push(PointLight {
                    position,
                    intensity,
                }),
                Light::Headlight { .. } => {
                    notes.push("the headlight does not light a path-traced scene".into())
                }
            }
        }
    }
    let env_map = match &cli.env_map {
        Some(p) => {
            if cli.env.is_some() {
                bail!("give --env or --env-map, not both");
            }
            Some(std::sync::Arc::new(load_env_map(p)?))
        }
        None => None,
    };
    let env = cli.env.unwrap_or(
        if suns.is_empty() && points.is_empty() && env_map.is_none() {
            Vec3::ONE
        } else {
            Vec3::ZERO
        },
    );
    let majorant = match cli.majorant.as_str() {
        "grid" => MajorantMode::Grid,
        "global" => MajorantMode::Global,
        other => bail!(
            "majorant `{}`: expected grid or global",
            volcore::text::clip(&volcore::text::escape(other), 40)
        ),
    };
    if let Some(t) = cli.time {
        if !(t.is_finite() && t >= 0.0) {
            bail!("--time {t} must be a number of seconds >= 0");
        }
    }
    if let Some(e) = cli.until_error {
        if !(e.is_finite() && e > 0.0) {
            bail!("--until-error {e} must be a number above 0");
        }
    }
    if cli.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    if cli.repeat > 1 {
        bail!(
            "--repeat times the ray caster's frames; a path-traced render is timed by its budget \
             (--spp, --time or --until-error; render_s in --json)"
        );
    }
    if !(cli.exposure.is_finite() && cli.exposure >= 0.0) {
        bail!("--exposure {} must be a finite number >= 0", cli.exposure);
    }
    let budget = Budget {
        spp: cli
            .spp
            .or((cli.time.is_none() && cli.until_error.is_none()).then_some(DEFAULT_SPP)),
        seconds: cli.time,
        until_error: cli.until_error,
    };
    let hybrid = match cli.hybrid.as_deref() {
        None | Some("off") => None,
        Some(text) => match text.parse::<f32>() {
            Ok(s) if s.is_finite() && s > 0.0 => Some(s),
            _ => bail!(
                "--hybrid `{}`: expected off or a gradient scale above 0",
                volcore::text::clip(&volcore::text::escape(text), 40)
            ),
        },
    };
    let settings = PathSettings {
        medium,
        bounces: cli.bounces,
        g: cli.g,
        hybrid,
        majorant,
        lights: PathLights {
            suns,
            points,
            env,
            env_map,
        },
        background: cli.background_given.then(|| {
            (cli.background / 255.0)
                .to_array()
                .map(srgb_to_linear)
                .into()
        }),
        seed: cli.seed,
    };
    Ok((settings, budget))
}

/// Read an equirectangular environment map: a linear float image (PFM or
/// OpenEXR; grey maps are spread over RGB, alpha is ignored).
fn load_env_map(p: &Path) -> Result<EnvMap> {
    let name = p.display();
    match volcompare::image::image_extension(p) {
        Some("pfm" | "exr") => {}
        _ => bail!("{name}: an environment map must be a linear .pfm or .exr image"),
    }
    let img = volcompare::image::Image::load(p).with_context(|| format!("{name}: cannot read"))?;
    let ch = img.channels();
    let rgb: Vec<f32> = img
        .samples
        .chunks_exact(ch)
        .flat_map(|s| match img.color {
            1 => [s[0]; 3],
            _ => [s[0], s[1], s[2]],
        })
        .collect();
    EnvMap::new(img.width, img.height, &rgb).map_err(|e| anyhow::anyhow!("{name}: {e}"))
}

/// Where the figures of a render come from.
pub struct Run<'a> {
    /// The parsed command line.
    pub cli: &'a Cli,
    /// The volume's path.
    pub volume: &'a Path,
    /// The output PNG.
    pub output: &'a Path,
    /// The camera.
    pub camera: &'a Camera,
    /// Seconds to open the volume and to load or build the index.
    pub load_s: f64,
    /// See `load_s`.
    pub index_s: f64,
    /// The effective scene, for `--json`.
    pub scene: serde_json::Value,
}

/// Render, write and report.
pub fn run(
    r: &Run,
    vol: &Volume,
    index: Option<&MajorantIndex>,
    settings: &PathSettings,
    budget: &Budget,
) -> Result<()> {
    let cli = r.cli;
    debug_assert_eq!(cli.mode, ModeArg::Path);
    let name = r.volume.display().to_string();
    let (w, h) = (r.camera.width(), r.camera.height());
    let need = u64::from(w) * u64::from(h) * BYTES_PER_PIXEL;
    if need > volrender::frame::FRAME_MEMORY_BUDGET {
        bail!(
            "a {w}x{h} path-traced frame needs about {:.1} GiB, more than the budget of {} GiB: ask for a smaller --size",
            need as f64 / (1u64 << 30) as f64,
            volrender::frame::FRAME_MEMORY_BUDGET >> 30
        );
    }
    // Tracking needs the index's majorants, even under --no-ess.
    let built;
    let (index, index_s) = match index {
        Some(ix) => (ix, r.index_s),
        None => {
            let t = Instant::now();
            built = MajorantIndex::build_volume(vol, &BuildOptions::default(), 0)
                .with_context(|| format!("{name}: building the index"))?;
            (&built, r.index_s + t.elapsed().as_secs_f64())
        }
    };
    let tracer = PathTracer::new(vol, index, r.camera, settings).with_context(|| name.clone())?;
    let volume_id = match volformats::fingerprint(r.volume) {
        Ok(f) => f,
        Err(e) if cli.accumulate.is_some() => {
            return Err(anyhow::anyhow!("{name}: {e}"))
                .context("--accumulate needs a volume file it can recognise again")
        }
        Err(_) => 0,
    };
    let key = tracer.key(volume_id);
    let mut acc = match &cli.accumulate {
        Some(p) if p.exists() => Accumulator::load(p, w, h, key).map_err(|e| {
            anyhow::anyhow!("{}: {e}", volcore::text::escape(&p.display().to_string()))
        })?,
        _ => Accumulator::new(w, h, key),
    };
    let start_spp = acc.spp();
    let bar =
        volkit_cli::progress::count_bar(budget.spp, "path tracing", "spp", cli.quiet || cli.json);
    let t = Instant::now();
    let counters = tracer
        .render(&mut acc, budget, |a, _| {
            bar.set_position(a.spp() - start_spp);
            if let Some(e) = a.relative_error() {
                bar.set_message(format!("error {:.2}%", e * 100.0));
            }
        })
        .with_context(|| name.clone())?;
    let render_s = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if let Some(e) = vol.error() {
        bail!("{name}: {e}");
    }
    if let Some(p) = &cli.accumulate {
        acc.save(p)
            .with_context(|| volcore::text::escape(&p.display().to_string()))?;
    }
    write_outputs(cli, r.output, &acc)?;
    report(
        r,
        &tracer,
        &acc,
        &counters,
        acc.spp() - start_spp,
        render_s,
        index_s,
    )
}

/// Linear radiance to a display value in [0, 1].
fn tonemap(c: f32, exposure: f32, how: TonemapArg) -> f32 {
    let x = (c * exposure).max(0.0);
    let y = match how {
        TonemapArg::Clamp => x,
        TonemapArg::Reinhard => x / (1.0 + x),
        TonemapArg::Aces => (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14),
    };
    if y.is_nan() {
        0.0
    } else {
        y.clamp(0.0, 1.0)
    }
}

fn write_outputs(cli: &Cli, output: &Path, acc: &Accumulator) -> Result<()> {
    let (w, h) = (acc.width(), acc.height());
    let rgb = acc.mean_rgb();
    let png: Vec<u8> = rgb
        .iter()
        .map(|&c| volrender::film::srgb8(tonemap(c, cli.exposure, cli.tonemap)))
        .collect();
    write_png8(output, w, h, 3, &png).with_context(|| output.display().to_string())?;
    if let Some(p) = &cli.hdr {
        let exr = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if exr {
            write_exr(p, w, h, &rgb)
        } else {
            write_pfm(p, w, h, &rgb)
        }
        .with_context(|| p.display().to_string())?;
    }
    if let Some(p) = &cli.variance {
        write_heatmap(p, &acc.standard_errors(), w, h).with_context(|| p.display().to_string())?;
    }
    Ok(())
}

fn report(
    r: &Run,
    tracer: &PathTracer,
    acc: &Accumulator,
    n: &PathCounters,
    spp_added: u64,
    render_s: f64,
    index_s: f64,
) -> Result<()> {
    let cli = r.cli;
    let threads = rayon::current_num_threads();
    let paths_per_s = n.paths as f64 / render_s.max(1e-12);
    let error = acc.relative_error();
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-render",
            "path": r.volume.display().to_string(),
            "output": r.output.display().to_string(),
            "mode": "path",
            "width": acc.width(),
            "height": acc.height(),
            "threads": threads,
            "spp": acc.spp(),
            "spp_added": spp_added,
            "paths": n.paths,
            "real_collisions": n.real_collisions,
            "null_collisions": n.null_collisions,
            "majorant_cells": n.majorant_cells,
            "empty_cells": n.empty_cells,
            "density_lookups": n.density_lookups,
            "shadow_rays": n.shadow_rays,
            "scatter_events": n.scatter_events,
            "surface_events": n.surface_events,
            "bounce_rays": n.bounce_rays,
            "truncated": n.truncated,
            "non_finite": n.non_finite,
            "majorant": cli.majorant,
            "empty_cell_fraction": tracer.empty_fraction(),
            "load_s": r.load_s,
            "index_s": index_s,
            "render_s": render_s,
            "paths_per_s": paths_per_s,
            "paths_per_s_per_core": paths_per_s / threads.max(1) as f64,
            "lookups_per_path": n.density_lookups as f64 / n.paths.max(1) as f64,
            "relative_error": error,
            "peak_rss_mb": crate::peak_rss_mb(),
            "scene": r.scene,
        });
        outln!("{v}")?;
    } else if !cli.quiet {
        noteln!(
            "vol-render: {} {}x{} path traced: {} spp ({} added) in {:.3} s, {:.2} M paths/s, {:.1} lookups per path{}; load {:.2} s, index {:.2} s",
            r.output.display(),
            acc.width(),
            acc.height(),
            acc.spp(),
            spp_added,
            render_s,
            paths_per_s / 1e6,
            n.density_lookups as f64 / n.paths.max(1) as f64,
            error.map_or(String::new(), |e| format!(", error {:.2}%", e * 100.0)),
            r.load_s,
            index_s
        );
        if n.truncated + n.non_finite > 0 {
            noteln!(
                "vol-render: {} tracking calls hit the collision limit, {} samples were not finite (dropped)",
                n.truncated,
                n.non_finite
            );
        }
    }
    Ok(())
}
