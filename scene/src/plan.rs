//! The options resolved against the volume: the camera, the render
//! settings and the transfer function a frame needs, with every default
//! filled in from the volume's size, spacing and value range, every check
//! made, the notes for the user and the effective scene.

use crate::effective::{effective, Resolved};
use crate::error::{Error, ErrorKind, Kind, Result};
use crate::file::Scene;
use crate::options::{GradientArg, InterpArg, ModeArg, Options, ShadingArg, UpArg};
use glam::{DMat3, DVec3, Vec3};
use std::path::Path;
use volcore::Volume;
use volindex::{BuildOptions, MinMaxIndex};
use volrender::path::{Budget, PathSettings};
use volrender::tf::{
    looks_like_hounsfield, parse::parse_any, Tf, TransferFunction, AUTO_TAIL_PERCENT, PRESETS,
};
use volrender::{
    Camera, GradientMethod, Interp, Light, Lighting, Mode, Projection, RenderSettings,
};

/// What one render is: everything but the volume and its index.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The camera and image size.
    pub camera: Camera,
    /// Mode and the knobs of the ray caster.
    pub settings: RenderSettings,
    /// The transfer function (DVR only).
    pub tf: Option<Tf>,
    /// The defaults as resolved against the volume (for the effective
    /// scene).
    pub resolved: Resolved,
    /// Warnings for the user (one line each; `--quiet` drops them).
    pub notes: Vec<String>,
    /// Path tracing (`--mode path`): the scene and when to stop.
    pub path: Option<(PathSettings, Budget)>,
    /// The effective scene: every key the render depends on, defaults
    /// resolved (`--print-scene`, and `scene` in the report).
    pub scene: Scene,
}

impl Plan {
    /// Resolve `cli` for `vol`; `index`, when there is one, gives the
    /// finite value range for defaults and `--tf auto` its histogram.
    /// Errors do not name the volume (the caller does).
    pub fn new(cli: &Options, vol: &Volume, index: Option<&MinMaxIndex>) -> Result<Plan> {
        let mut notes = Vec::new();
        if let Some(note) = vol.meta.narrowed.and_then(|n| n.note()) {
            notes.push(format!(
                "{note} (the renderer reads f32; converted once on opening)"
            ));
        }
        let tf = match cli.mode {
            ModeArg::Dvr => Some(transfer_function(cli, vol, index, &mut notes)?),
            ModeArg::Path if cli.density_scale.is_none() => {
                Some(transfer_function(cli, vol, index, &mut notes)?)
            }
            _ => None,
        };
        if let Some(Tf::TwoD(_)) = &tf {
            if cli.preintegrated {
                return Err(Error::usage(format!(
                    "--preintegrated: {}",
                    volrender::frame::dvr::not_pre_integrated()
                )));
            }
            if cli.adaptive.is_some() {
                return Err(Error::usage(format!(
                    "--adaptive: {}",
                    volrender::frame::dvr::not_adaptive()
                )));
            }
        }
        let (camera, look_at, orbit) = camera(cli, vol)?;
        let step = match cli.step {
            Some(step) => step,
            None => default_step(cli, vol, &mut notes),
        };
        let settings = settings(cli, vol, index, step)?;
        let path = match cli.mode {
            ModeArg::Path => Some(crate::path::settings(
                cli,
                &settings.lighting.lights,
                tf.as_ref(),
                &mut notes,
            )?),
            _ => {
                crate::path::refuse_path_options(cli)?;
                None
            }
        };
        if settings.ao.is_some() && cli.mode == ModeArg::Dvr && cli.shading != ShadingArg::Phong {
            notes.push("ambient occlusion turns on --shading phong".into());
        }
        if let Some(sh) = &settings.shadows {
            if cli.mode == ModeArg::Dvr && cli.shading != ShadingArg::Phong {
                notes.push("--shadows turns on --shading phong".into());
            }
            if matches!(sh.method, volrender::ShadowMethod::Grid { .. })
                && settings
                    .lighting
                    .lights
                    .iter()
                    .any(|l| !matches!(l, Light::Directional { .. }))
            {
                notes.push(
                    "shadow grids serve directional lights; the headlight and point lights \
                     cast shadow rays"
                        .into(),
                );
            }
        }
        let resolved = Resolved {
            step: settings.step,
            look_at,
            orbit,
            iso: match settings.mode {
                Mode::Iso(v) => Some(v),
                _ => None,
            },
            ambient: settings.lighting.ambient,
            lights: settings.lighting.lights.clone(),
            spp: path.as_ref().and_then(|(_, b)| b.spp),
            env: path.as_ref().map(|(p, _)| p.lights.env),
        };
        let scene = effective(cli, &resolved)?;
        Ok(Plan {
            camera,
            settings,
            tf,
            resolved,
            notes,
            path,
            scene,
        })
    }
}

/// The volume's value range as f32, `(0, 1)` when it is unknown.
fn value_range(vol: &Volume) -> (f32, f32) {
    (vol.meta.range.min as f32, vol.meta.range.max as f32)
}

/// `--tf`: a preset by name, else a file (1D or 2D); or the scene file's
/// `tf-text`. `ct` on data that does not look like Hounsfield units adds a
/// note suggesting `auto`.
fn transfer_function(
    cli: &Options,
    vol: &Volume,
    index: Option<&MinMaxIndex>,
    notes: &mut Vec<String>,
) -> Result<Tf> {
    if let Some(text) = &cli.tf_text {
        return parse_any(text).kind_ctx(ErrorKind::Option, "the scene's tf-text");
    }
    let range = value_range(vol);
    if let Some(tail) = auto_tail(&cli.tf)? {
        let window = auto_window(vol, index, tail)?;
        return match TransferFunction::preset("auto", window) {
            Some(tf) => Ok(Tf::OneD(tf)),
            None => Err(Error::option("the auto preset")),
        };
    }
    if cli.tf == "ct" && !looks_like_hounsfield(range) {
        notes.push(format!(
            "--tf ct expects Hounsfield units (air -1000, water 0, bone 300 and up), \
             but the data span {}..{}; try --tf auto",
            range.0, range.1
        ));
    }
    // The steepest a one-voxel jump across the whole range can be.
    let max_gradient = (range.1 - range.0) / vol.meta.min_spacing();
    if let Some(tf) = Tf::preset(&cli.tf, range, max_gradient) {
        return Ok(tf);
    }
    let path = Path::new(&cli.tf);
    let text = std::fs::read_to_string(path)
        .kind_ctx(
            ErrorKind::File,
            format!(
                "{}: not a preset ({}) and not a readable file",
                cli.tf,
                PRESETS.join(", ")
            ),
        )
        .map_err(Error::named)?;
    parse_any(&text)
        .kind_ctx(ErrorKind::File, &cli.tf)
        .map_err(Error::named)
}

/// The tail percentile of `--tf auto` or `auto:P`; `None` for other names.
fn auto_tail(name: &str) -> Result<Option<f64>> {
    if name == "auto" {
        return Ok(Some(AUTO_TAIL_PERCENT));
    }
    let Some(p) = name.strip_prefix("auto:") else {
        return Ok(None);
    };
    match p.parse::<f64>() {
        Ok(p) if (0.0..50.0).contains(&p) => Ok(Some(p)),
        _ => Err(Error::usage(format!(
            "--tf auto:{}: the auto percentile must be a number in 0..50",
            volcore::text::excerpt(p)
        ))),
    }
}

/// The `auto` window: the `tail`-th and (100 − `tail`)-th percentiles of
/// the index's histogram (built here when rendering without an index); the
/// whole value range when they coincide (one value) or nothing is binned.
fn auto_window(vol: &Volume, index: Option<&MinMaxIndex>, tail: f64) -> Result<(f32, f32)> {
    let built;
    let ix = match index {
        Some(ix) => ix,
        None => {
            built = MinMaxIndex::build_volume(vol, &BuildOptions::default(), 0)
                .kind_ctx(ErrorKind::File, "the histogram for --tf auto")?;
            &built
        }
    };
    let h = ix.histogram();
    let q = tail / 100.0;
    Ok(match (h.quantile(q), h.quantile(1.0 - q)) {
        (Some(lo), Some(hi)) if hi > lo => (lo as f32, hi as f32),
        _ => value_range(vol),
    })
}

/// `--up patient`: the renderer's world direction (voxel index × spacing)
/// that the volume's direction matrix maps to superior (+z in LPS).
fn patient_up(vol: &Volume) -> Result<Vec3> {
    let g = &vol.meta.geometry;
    let d = DMat3::from_cols(
        DVec3::from(g.axis(0)),
        DVec3::from(g.axis(1)),
        DVec3::from(g.axis(2)),
    );
    let det = d.determinant().abs();
    if det.is_nan() || det <= 1e-9 {
        return Err(Error::option(
            "--up patient: the volume's direction matrix is singular",
        ));
    }
    Ok((d.inverse() * DVec3::Z).as_vec3())
}

/// The camera, the point it looks at, and the orbit that placed it (when
/// no `--eye` did).
fn camera(cli: &Options, vol: &Volume) -> Result<(Camera, Vec3, Option<Vec3>)> {
    let hi = Vec3::from(vol.meta.world_extent());
    let Some(diagonal64) = vol.meta.world_diagonal() else {
        let (d, s) = (vol.dims(), vol.meta.spacing);
        return Err(Error::option(format!(
            "the volume's extent (dims {d} x spacing {},{},{}) is too large for f32 world coordinates",
            s[0],
            s[1],
            s[2]
        )));
    };
    let centre = hi * 0.5;
    // The default framing sees 1.8 diagonals, at any scale; glam's length
    // where it neither overflows nor underflows, f64 elsewhere, and 1 for a
    // single voxel (no diagonal).
    let diagonal = match hi.length() {
        l if l.is_normal() => l,
        _ if diagonal64 > 0.0 => diagonal64 as f32,
        _ => 1.0,
    };
    let up = match cli.up {
        UpArg::Vector(v) => v,
        UpArg::Patient => patient_up(vol)?,
    };
    let projection = match cli.ortho_height.or(cli.ortho) {
        Some(h) if h > 0.0 => Projection::Orthographic(h),
        Some(_) => Projection::Orthographic(diagonal * 1.05),
        None => Projection::Perspective(cli.fov),
    };
    let (w, h) = cli.size;
    let target = cli.look_at.unwrap_or(centre);
    let (cam, orbit) = match cli.eye {
        Some(eye) => (Camera::look_at(eye, target, up, projection, w, h), None),
        None => {
            let o = cli.orbit.unwrap_or(Vec3::new(30.0, 20.0, 1.8 * diagonal));
            let cam = Camera::orbit_up(target, o.x, o.y, o.z, up, projection, w, h);
            (cam, Some(o))
        }
    };
    Ok((cam.map_err(Error::from_render)?, target, orbit))
}

/// The step when none is given: half the smallest voxel spacing, unless
/// the frame's checks would refuse it for this volume: more samples per
/// ray across its diagonal than the limit, or finer than f32 positions
/// resolve across it. Then the finest step they accept, with a note
/// saying so (in the ray caster's modes: the path tracer takes no step).
/// So the default is always feasible; a step the user gives may still be
/// refused.
fn default_step(cli: &Options, vol: &Volume, notes: &mut Vec<String>) -> f32 {
    let half = 0.5 * vol.meta.min_spacing();
    let Some(finest) = volrender::frame::check::finest_step(vol) else {
        // No step is feasible: the frame's check says why.
        return half;
    };
    // A NaN `half` compares false: the finest step then too.
    if half >= finest {
        return half;
    }
    if cli.mode != ModeArg::Path {
        notes.push(format!(
            "the default step {half:?} (half the smallest voxel spacing) is finer than a frame \
             of this volume allows (at most {:e} samples per ray, positions that f32 \
             resolves): step {finest:?} instead",
            volrender::frame::MAX_SAMPLES_PER_RAY
        ));
    }
    finest
}

/// `--mode iso` without `--iso`: the middle of the value range, or of the
/// finite samples' range (the index histogram's) when the range has an
/// infinity.
fn default_iso(vol: &Volume, index: Option<&MinMaxIndex>) -> Result<f32> {
    let r = vol.meta.range;
    let mid = |lo: f64, hi: f64| ((lo + hi) * 0.5) as f32;
    if r.min.is_finite() && r.max.is_finite() {
        return Ok(mid(r.min, r.max));
    }
    match index.map(|ix| ix.histogram()) {
        Some(h) if h.lo().is_finite() && h.hi().is_finite() && h.total() > 0 => {
            Ok(mid(h.lo(), h.hi()))
        }
        Some(_) => Err(Error::option(
            "--mode iso: the volume has no finite samples; give --iso",
        )),
        None => Err(Error::option(format!(
            "--mode iso: the value range {}..{} is not finite and without an index (--no-ess) \
             its finite part is unknown; give --iso",
            r.min, r.max
        ))),
    }
}

/// The ray caster's settings with this `step` (in path mode, its
/// defaults: the path tracer reads [`crate::path::settings`]).
fn settings(
    cli: &Options,
    vol: &Volume,
    index: Option<&MinMaxIndex>,
    step: f32,
) -> Result<RenderSettings> {
    let mode = match cli.mode {
        ModeArg::Dvr => Mode::Dvr,
        ModeArg::Mip => Mode::Mip,
        ModeArg::Minip => Mode::Minip,
        ModeArg::Xray => Mode::XraySum,
        ModeArg::XrayMean => Mode::XrayMean,
        ModeArg::Iso => Mode::Iso(match cli.iso {
            Some(v) => v,
            None => default_iso(vol, index)?,
        }),
        // The path tracer reads its own settings (crate::path); the ray
        // caster's stay at their defaults and unused.
        ModeArg::Path => Mode::Dvr,
    };
    if cli.mode == ModeArg::Path
        && (cli.shadows.is_some() || cli.ao.is_some() || cli.ao_field.is_some())
    {
        return Err(Error::option("--shadows, --ao and --ao-field are the ray caster's effects: the path tracer casts its own shadow rays and scatters light"));
    }
    if cli.preintegrated && cli.mode != ModeArg::Dvr {
        return Err(Error::usage(
            "--preintegrated is for --mode dvr: the other modes classify no segments \
             through a transfer function",
        ));
    }
    if cli.preintegrated && cli.interp != InterpArg::Trilinear {
        return Err(Error::usage(
            "--preintegrated needs --interp trilinear: it assumes values vary linearly \
             between samples",
        ));
    }
    if cli.budget.is_some() && cli.mode == ModeArg::Path {
        return Err(Error::usage(
            "--budget is the ray caster's frame time: path tracing spends its time with \
             --seconds S",
        ));
    }
    if cli.adaptive.is_some() && cli.mode != ModeArg::Dvr {
        return Err(Error::usage(
            "--adaptive is for --mode dvr: the other modes integrate no transfer function \
             over steps",
        ));
    }
    if cli.adaptive.is_some() && cli.preintegrated {
        return Err(Error::usage(
            "--adaptive and --preintegrated do not combine: a pre-integrated segment is one \
             step long",
        ));
    }
    if cli.iso.is_some() && cli.mode != ModeArg::Iso {
        return Err(Error::option("--iso needs --mode iso"));
    }
    let lights = match (cli.light, &cli.lights) {
        (Some(l), _) => match Light::directional(l) {
            Some(light) => vec![light],
            None => return Err(Error::option("--light must not be the zero vector")),
        },
        (None, Some(lights)) => lights
            .iter()
            .enumerate()
            .map(|(i, l)| {
                l.light()
                    .map_err(|e| Error::option(format!("lights[{i}]: {e}")))
            })
            .collect::<Result<_>>()?,
        (None, None) => vec![Light::HEADLIGHT],
    };
    let shadows = match &cli.shadows {
        None => None,
        Some(name) => Some(volrender::Shadows {
            method: crate::parse::shadow_method(name)
                .map_err(|e| Error::usage(format!("--shadows {e}")))?,
            step: cli.shadow_step,
        }),
    };
    if cli.shadow_step.is_some() && shadows.is_none() {
        return Err(Error::option("--shadow-step needs --shadows"));
    }
    let ao_of = |flag: &str, spec: &str, method: fn(u32) -> volrender::AoMethod| {
        crate::parse::ao_spec(spec)
            .map(|(n, radius)| volrender::Ao {
                method: method(n),
                radius,
                seed: 0,
            })
            .map_err(|e| Error::usage(format!("{flag} {e}")))
    };
    // clap refuses --ao with --ao-field, and --ao-field-cell without
    // --ao-field, wherever the options come from.
    let ao = match (&cli.ao, &cli.ao_field) {
        (Some(s), _) => Some(ao_of("--ao", s, |n| volrender::AoMethod::Rays { n })?),
        (None, Some(s)) => {
            let mut ao = ao_of("--ao-field", s, |k| volrender::AoMethod::Field {
                k,
                cell: volrender::effects::ao::DEFAULT_AO_FIELD_CELL,
            })?;
            if let (volrender::AoMethod::Field { cell, .. }, Some(c)) =
                (&mut ao.method, cli.ao_field_cell)
            {
                *cell = c;
            }
            Some(ao)
        }
        (None, None) => None,
    };
    let defaults = Lighting::default();
    Ok(RenderSettings {
        mode,
        step,
        preintegrated: cli.preintegrated,
        adaptive: cli.adaptive,
        interp: match cli.interp {
            InterpArg::Nearest => Interp::Nearest,
            InterpArg::Trilinear => Interp::Trilinear,
        },
        gradient: match cli.gradient {
            GradientArg::Central => GradientMethod::Central,
            GradientArg::Analytic => GradientMethod::Analytic,
        },
        // Shadows and AO shade: they turn shading on (the plan notes it).
        shading: cli.shading == ShadingArg::Phong || shadows.is_some() || ao.is_some(),
        lighting: Lighting {
            lights,
            ambient: cli.ambient.unwrap_or(defaults.ambient),
            model: defaults.model,
        },
        ert: (!cli.no_ert).then_some(cli.ert),
        ess: !cli.no_ess,
        tile: cli.tile,
        background: (cli.background.unwrap_or(Vec3::ZERO) / 255.0).to_array(),
        shadows,
        ao,
        ..Default::default()
    })
}
