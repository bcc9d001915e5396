//! vol-render: a tiled, parallel CPU ray caster.

use anyhow::{bail, Context, Result};
use clap::{Parser, ValueEnum};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use volcore::Volume;
use volformats::{open_volume, vvol};
use volindex::{BuildOptions, MajorantIndex};
use volrender::tf::TransferFunction;
use volrender::{
    render, Camera, Frame, GradientMethod, Interp, Lighting, Mode, Projection, RenderSettings,
};

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum ModeArg {
    /// Emission-absorption through the transfer function.
    Dvr,
    /// Maximum intensity projection.
    Mip,
    /// Minimum intensity projection.
    Minip,
    /// X-ray: line integral of the value (value × world length).
    Xray,
    /// X-ray: mean sample value along the ray.
    XrayMean,
    /// Iso-surface at --iso.
    Iso,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum InterpArg {
    Nearest,
    Trilinear,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum ShadingArg {
    None,
    Phong,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum GradientArg {
    Central,
    Analytic,
}

/// Render a volume to an image with a tiled, parallel CPU ray caster.
///
/// World space follows VTK: voxel (i, j, k) sits at (i·sx, j·sy, k·sz) and the
/// volume's box is [0, (dims − 1)·spacing]. The image is the same, bit for
/// bit, whatever the thread count, tile size, storage layout, and whether
/// empty-space skipping is on.
#[derive(Parser, Debug)]
#[command(name = "vol-render", version, after_help = EXAMPLES)]
struct Cli {
    /// The volume (.vvol, .vol, .raw).
    volume: PathBuf,
    /// Output PNG (8-bit sRGB).
    #[arg(short, long)]
    output: PathBuf,
    /// A .vidx index made by vol-index for this volume (otherwise one is
    /// built in memory when skipping is on).
    #[arg(long)]
    index: Option<PathBuf>,
    /// Transfer function: a file, or a preset (grey, ct, shapes).
    #[arg(long, default_value = "grey")]
    tf: String,
    /// What each ray computes.
    #[arg(long, value_enum, default_value = "dvr")]
    mode: ModeArg,
    /// Iso value for --mode iso (default: the middle of the value range).
    #[arg(long, allow_hyphen_values = true)]
    iso: Option<f32>,
    /// Image size WxH.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    size: (u32, u32),
    /// Camera position x,y,z (world units); needs --look-at.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// Point the camera looks at (default: the volume's centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    look_at: Option<Vec3>,
    /// Up vector.
    #[arg(long, value_parser = parse_vec3, default_value = "0,1,0", allow_hyphen_values = true)]
    up: Vec3,
    /// Orbit camera: azimuth, elevation (degrees) and distance from the
    /// volume's centre (default when no --eye: 30,20 and 1.8 diagonals).
    #[arg(long, value_parser = parse_vec3, conflicts_with = "eye", allow_hyphen_values = true)]
    orbit: Option<Vec3>,
    /// Vertical field of view in degrees (perspective).
    #[arg(long, default_value_t = 45.0)]
    fov: f32,
    /// Orthographic projection with this image height in world units (0 =
    /// fit the volume's diagonal).
    #[arg(long, num_args = 0..=1, default_missing_value = "0")]
    ortho: Option<f32>,
    /// Distance between samples along a ray, world units (default: half the
    /// smallest voxel spacing).
    #[arg(long, allow_hyphen_values = true)]
    step: Option<f32>,
    /// Early ray termination threshold (accumulated opacity).
    #[arg(long, default_value_t = 0.99)]
    ert: f32,
    /// Turn early ray termination off.
    #[arg(long)]
    no_ert: bool,
    /// Turn empty-space skipping off.
    #[arg(long)]
    no_ess: bool,
    /// Reconstruction between voxels.
    #[arg(long, value_enum, default_value = "trilinear")]
    interp: InterpArg,
    /// Shading for DVR (iso surfaces are always shaded).
    #[arg(long, value_enum, default_value = "none")]
    shading: ShadingArg,
    /// Gradient method for shading.
    #[arg(long, value_enum, default_value = "central")]
    gradient: GradientArg,
    /// Direction towards the light x,y,z (default: a headlight).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    light: Option<Vec3>,
    /// Background colour r,g,b (0-255).
    #[arg(long, value_parser = parse_vec3, default_value = "0,0,0")]
    background: Vec3,
    /// Write an RGBA PNG with coverage alpha instead of compositing onto the background.
    #[arg(long)]
    alpha: bool,
    /// Tile edge in pixels.
    #[arg(long, default_value_t = 16)]
    tile: u32,
    /// Macrocell edge of an index built in memory.
    #[arg(long, default_value_t = 8)]
    cell: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Read an uncompressed .vvol into memory (backed by huge pages where
    /// the system offers them) instead of sampling the memory-mapped file
    /// in place: start-up costs a copy of the file, frames cost about the
    /// same.
    #[arg(long)]
    in_memory: bool,
    /// Render this many times and report the median time (for benchmarks).
    #[arg(long, default_value_t = 1)]
    repeat: u32,
    /// Also write the linear float image (.pfm).
    #[arg(long)]
    hdr: Option<PathBuf>,
    /// Also write a samples-per-pixel heat map with a colour scale (.png).
    #[arg(long)]
    heatmap: Option<PathBuf>,
    /// Print one JSON object with the figures.
    #[arg(long)]
    json: bool,
    /// No progress messages.
    #[arg(short, long)]
    quiet: bool,
}

const EXAMPLES: &str = "Examples:
  vol-render shapes.vvol --tf shapes --shading phong -o shapes.png
  vol-render shapes.vvol --tf shapes --shading phong --step 0.2 --size 700x700 \\
      --eye 1100,1100,1100 --look-at 0,0,0 --fov 60 -o thesis.png --json
  vol-render ct.vvol --tf ct --orbit 45,30,600 --hdr ct.pfm -o ct.png
  vol-render sphere.vvol --mode iso --iso 128 -o iso.png
  vol-render noise.vvol --mode mip --ortho -o mip.png --heatmap samples.png
  vol-render shapes.vvol --index shapes.vvol.vidx --no-ert --threads 1 -o a.png

Transfer function files: one statement per line, # for comments:
  domain 0 255              value range the table covers
  step 1                    reference step for the opacities (world units)
  range 85 95 255 0 0 0.02  [lo, hi): colour R G B (0-255), opacity per unit length
  point 100 0 255 0 0.6     control point: value, R G B, opacity (linear between points)";

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', ','])
        .ok_or_else(|| format!("'{s}' is not WxH"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{s}' is not WxH"))
    };
    match (p(w)?, p(h)?) {
        (w, h) if (1..=32768).contains(&w) && (1..=32768).contains(&h) => Ok((w, h)),
        _ => Err(format!("'{s}': width and height must be 1..=32768")),
    }
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not x,y,z"))?;
    match v[..] {
        [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("'{s}' is not three finite numbers x,y,z")),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
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

    let tf = match cli.mode {
        ModeArg::Dvr => Some(load_tf(cli, &vol)?),
        _ => None,
    };
    let camera = make_camera(cli, &vol)?;
    let settings = make_settings(cli, &vol)?;

    let mut times = Vec::new();
    let mut frame: Option<Frame> = None;
    for _ in 0..cli.repeat.max(1) {
        let f = render(&vol, index.as_ref(), tf.as_ref(), &camera, &settings)
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

    write_png(&cli.output, &frame, cli.alpha).with_context(|| cli.output.display().to_string())?;
    if let Some(p) = &cli.hdr {
        let rgb: Vec<f32> = frame
            .rgba
            .iter()
            .flat_map(|px| [px[0], px[1], px[2]])
            .collect();
        volcompare::pfm::write_pfm(p, frame.width, frame.height, &rgb)
            .with_context(|| p.display().to_string())?;
    }
    if let Some(p) = &cli.heatmap {
        let spp: Vec<f32> = frame.samples.iter().map(|&s| s as f32).collect();
        volcompare::heatmap::write_heatmap(p, &spp, frame.width, frame.height)
            .with_context(|| p.display().to_string())?;
    }
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

fn load_tf(cli: &Cli, vol: &Volume) -> Result<TransferFunction> {
    let range = (vol.meta.range.min as f32, vol.meta.range.max as f32);
    if let Some(tf) = TransferFunction::preset(&cli.tf, range) {
        return Ok(tf);
    }
    let path = Path::new(&cli.tf);
    let text = std::fs::read_to_string(path).with_context(|| {
        format!(
            "{}: not a preset ({}) and not a readable file",
            cli.tf,
            volrender::tf::PRESETS.join(", ")
        )
    })?;
    volrender::tf::parse::parse(&text).with_context(|| cli.tf.clone())
}

fn volume_box(vol: &Volume) -> (Vec3, Vec3) {
    let d = vol.dims().as_array();
    let s = vol.meta.spacing;
    let hi = Vec3::new(
        (d[0] - 1) as f32 * s[0],
        (d[1] - 1) as f32 * s[1],
        (d[2] - 1) as f32 * s[2],
    );
    (hi * 0.5, hi)
}

fn make_camera(cli: &Cli, vol: &Volume) -> Result<Camera> {
    let (centre, hi) = volume_box(vol);
    let diagonal = hi.length().max(1.0);
    let projection = match cli.ortho {
        Some(h) if h > 0.0 => Projection::Orthographic(h),
        Some(_) => Projection::Orthographic(diagonal * 1.05),
        None => Projection::Perspective(cli.fov),
    };
    let (w, h) = cli.size;
    let target = cli.look_at.unwrap_or(centre);
    let cam = match (cli.eye, cli.orbit) {
        (Some(eye), _) => Camera::look_at(eye, target, cli.up, projection, w, h),
        (None, Some(o)) => Camera::orbit(target, o.x, o.y, o.z, projection, w, h),
        (None, None) => Camera::orbit(target, 30.0, 20.0, 1.8 * diagonal, projection, w, h),
    };
    Ok(cam?)
}

fn make_settings(cli: &Cli, vol: &Volume) -> Result<RenderSettings> {
    let min_spacing = vol
        .meta
        .spacing
        .iter()
        .cloned()
        .fold(f32::INFINITY, f32::min);
    let mode = match cli.mode {
        ModeArg::Dvr => Mode::Dvr,
        ModeArg::Mip => Mode::Mip,
        ModeArg::Minip => Mode::Minip,
        ModeArg::Xray => Mode::XraySum,
        ModeArg::XrayMean => Mode::XrayMean,
        ModeArg::Iso => Mode::Iso(
            cli.iso
                .unwrap_or(((vol.meta.range.min + vol.meta.range.max) * 0.5) as f32),
        ),
    };
    if cli.iso.is_some() && cli.mode != ModeArg::Iso {
        bail!("--iso needs --mode iso");
    }
    let lighting = Lighting {
        light_dir: match cli.light {
            Some(l) if l.length() > 0.0 => Some(l.normalize()),
            Some(_) => bail!("--light must not be the zero vector"),
            None => None,
        },
        ..Default::default()
    };
    Ok(RenderSettings {
        mode,
        step: cli.step.unwrap_or(0.5 * min_spacing),
        interp: match cli.interp {
            InterpArg::Nearest => Interp::Nearest,
            InterpArg::Trilinear => Interp::Trilinear,
        },
        gradient: match cli.gradient {
            GradientArg::Central => GradientMethod::Central,
            GradientArg::Analytic => GradientMethod::Analytic,
        },
        shading: cli.shading == ShadingArg::Phong,
        lighting,
        ert: (!cli.no_ert).then_some(cli.ert),
        ess: !cli.no_ess,
        tile: cli.tile,
        background: (cli.background / 255.0).to_array(),
        ..Default::default()
    })
}

/// Linear light to an 8-bit sRGB code.
fn srgb8(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

fn write_png(path: &Path, frame: &Frame, alpha: bool) -> Result<()> {
    let channels = if alpha { 4 } else { 3 };
    let mut data = Vec::with_capacity(frame.rgba.len() * channels);
    for px in &frame.rgba {
        data.extend([srgb8(px[0]), srgb8(px[1]), srgb8(px[2])]);
        if alpha {
            data.push((px[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
        }
    }
    volcompare::heatmap::write_png8(path, frame.width, frame.height, channels, &data)?;
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
