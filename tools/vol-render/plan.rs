//! The parsed command line resolved against the volume: the camera, the
//! render settings and the transfer function a frame needs, with every
//! default filled in from the volume's size, spacing and value range.

use crate::args::{Cli, GradientArg, InterpArg, ModeArg, ShadingArg};
use crate::scene::Resolved;
use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::path::Path;
use volcore::Volume;
use volrender::tf::{parse::parse_any, Tf, PRESETS};
use volrender::{
    Camera, GradientMethod, Interp, Light, Lighting, Mode, Projection, RenderSettings,
};

/// What one frame of `vol-render` is: everything but the volume and its
/// index.
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
}

impl Plan {
    /// Resolve `cli` for `vol`.
    pub fn new(cli: &Cli, vol: &Volume) -> Result<Plan> {
        let tf = match cli.mode {
            ModeArg::Dvr => Some(transfer_function(cli, vol)?),
            _ => None,
        };
        let (camera, look_at, orbit) = camera(cli, vol)?;
        let settings = settings(cli, vol)?;
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
        };
        Ok(Plan {
            camera,
            settings,
            tf,
            resolved,
        })
    }
}

/// The volume's value range as f32, `(0, 1)` when it is unknown.
fn value_range(vol: &Volume) -> (f32, f32) {
    (vol.meta.range.min as f32, vol.meta.range.max as f32)
}

/// `--tf`: a preset by name, else a file (1D or 2D); or the scene file's
/// `tf-text`.
fn transfer_function(cli: &Cli, vol: &Volume) -> Result<Tf> {
    if let Some(text) = &cli.tf_text {
        return parse_any(text).context("the scene's tf-text");
    }
    let range = value_range(vol);
    // The steepest a one-voxel jump across the whole range can be.
    let max_gradient = (range.1 - range.0) / vol.meta.min_spacing();
    if let Some(tf) = Tf::preset(&cli.tf, range, max_gradient) {
        return Ok(tf);
    }
    let path = Path::new(&cli.tf);
    let text = std::fs::read_to_string(path).with_context(|| {
        format!(
            "{}: not a preset ({}) and not a readable file",
            cli.tf,
            PRESETS.join(", ")
        )
    })?;
    parse_any(&text).with_context(|| cli.tf.clone())
}

/// The camera, the point it looks at, and the orbit that placed it (when
/// no `--eye` did).
fn camera(cli: &Cli, vol: &Volume) -> Result<(Camera, Vec3, Option<Vec3>)> {
    let hi = Vec3::from(vol.meta.world_extent());
    let centre = hi * 0.5;
    let diagonal = hi.length().max(1.0);
    let projection = match cli.ortho {
        Some(h) if h > 0.0 => Projection::Orthographic(h),
        Some(_) => Projection::Orthographic(diagonal * 1.05),
        None => Projection::Perspective(cli.fov),
    };
    let (w, h) = cli.size;
    let target = cli.look_at.unwrap_or(centre);
    let orbit = match (cli.eye, cli.orbit) {
        (Some(_), _) => None,
        (None, Some(o)) => Some(o),
        (None, None) => Some(Vec3::new(30.0, 20.0, 1.8 * diagonal)),
    };
    let cam = match (cli.eye, orbit) {
        (Some(eye), _) => Camera::look_at(eye, target, cli.up, projection, w, h),
        (None, Some(o)) => Camera::orbit(target, o.x, o.y, o.z, projection, w, h),
        (None, None) => unreachable!("an orbit is chosen whenever no eye is given"),
    };
    Ok((cam?, target, orbit))
}

fn settings(cli: &Cli, vol: &Volume) -> Result<RenderSettings> {
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
    let lights = match (cli.light, &cli.lights) {
        (Some(l), _) => match Light::directional(l) {
            Some(light) => vec![light],
            None => bail!("--light must not be the zero vector"),
        },
        (None, Some(lights)) => lights
            .iter()
            .enumerate()
            .map(|(i, l)| l.light().map_err(|e| anyhow::anyhow!("lights[{i}]: {e}")))
            .collect::<Result<_>>()?,
        (None, None) => vec![Light::HEADLIGHT],
    };
    let defaults = Lighting::default();
    Ok(RenderSettings {
        mode,
        step: cli.step.unwrap_or(0.5 * vol.meta.min_spacing()),
        interp: match cli.interp {
            InterpArg::Nearest => Interp::Nearest,
            InterpArg::Trilinear => Interp::Trilinear,
        },
        gradient: match cli.gradient {
            GradientArg::Central => GradientMethod::Central,
            GradientArg::Analytic => GradientMethod::Analytic,
        },
        shading: cli.shading == ShadingArg::Phong,
        lighting: Lighting {
            lights,
            ambient: cli.ambient.unwrap_or(defaults.ambient),
            model: defaults.model,
        },
        ert: (!cli.no_ert).then_some(cli.ert),
        ess: !cli.no_ess,
        tile: cli.tile,
        background: (cli.background / 255.0).to_array(),
        ..Default::default()
    })
}
