//! `--mode path`: the path tracer's options resolved into its settings
//! (the medium, the lights, the environment) and its budget of samples,
//! time or error; the options only it reads are refused in other modes.

use crate::error::{Error, ErrorKind, Kind, Result};
use crate::options::Options;
use crate::parse::sun_spec;
use glam::Vec3;
use std::path::Path;
use volrender::classify::srgb_to_linear;
use volrender::path::{
    Budget, EnvMap, MajorantMode, MediumSpec, PathLights, PathSettings, SamplerKind, Transmittance,
};
use volrender::tf::Tf;
use volrender::Light;

/// Samples per pixel when no budget is given.
pub const DEFAULT_SPP: u64 = 64;

/// Options only the path tracer reads, refused in other modes (those with
/// defaults cannot be told from unset and are ignored there).
pub fn refuse_path_options(cli: &Options) -> Result<()> {
    let given = [
        ("--spp", cli.spp.is_some()),
        ("--seconds", cli.seconds.is_some()),
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
        Some((flag, _)) => Err(Error::usage(format!("{flag} needs --mode path"))),
        None => Ok(()),
    }
}

/// The path tracer's settings and budget from the command line (`--sun`
/// gives directional lights, after which come the scene file's lights,
/// but the headlight, which has no place in a path-traced scene).
pub fn settings(
    cli: &Options,
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
                return Err(Error::option("--albedo is for --density-scale: with a transfer function the albedo is its colour"));
            }
            MediumSpec::Table(t.clone())
        }
        (None, Some(Tf::TwoD(_))) => return Err(Error::option(
            "--mode path takes a 1D transfer function (its medium has no gradient), or --density-scale"
        )),
        (None, None) => {
            return Err(Error::option(
                "--mode path needs a transfer function or --density-scale",
            ))
        }
    };
    // Suns first, then the lights (the order the estimator sums them in).
    let mut path_lights = Vec::new();
    for s in &cli.sun {
        let (dir, e) = sun_spec(s).map_err(|e| Error::usage(format!("--sun {e}")))?;
        let Some(travel) = volrender::ray::unit(dir) else {
            return Err(Error::option(format!(
                "--sun {s}: the direction must be finite and not zero"
            )));
        };
        path_lights.push(Light::Directional {
            towards: -travel,
            radiance: Vec3::splat(e),
        });
    }
    // Lights from --light or the scene file; the default headlight is
    // not one the user asked for.
    if cli.light.is_some() || cli.lights.is_some() {
        for l in lights {
            match *l {
                Light::Directional { .. } | Light::Point { .. } => path_lights.push(*l),
                Light::Headlight { .. } => {
                    notes.push("the headlight does not light a path-traced scene".into())
                }
            }
        }
    }
    let env_map = match &cli.env_map {
        Some(p) => {
            if cli.env.is_some() {
                return Err(Error::option("give --env or --env-map, not both"));
            }
            Some(std::sync::Arc::new(load_env_map(p).map_err(Error::named)?))
        }
        None => None,
    };
    let env = cli
        .env
        .unwrap_or(if path_lights.is_empty() && env_map.is_none() {
            Vec3::ONE
        } else {
            Vec3::ZERO
        });
    let majorant = match cli.majorant.as_str() {
        "grid" => MajorantMode::Grid,
        "global" => MajorantMode::Global,
        other => {
            return Err(Error::option(format!(
                "majorant `{}`: expected grid or global",
                volcore::text::clip(&volcore::text::escape(other), 40)
            )))
        }
    };
    let sampler = SamplerKind::from_name(&cli.sampler).ok_or_else(|| {
        Error::option(format!(
            "sampler `{}`: expected sobol or hash",
            volcore::text::clip(&volcore::text::escape(&cli.sampler), 40)
        ))
    })?;
    let transmittance = Transmittance::from_name(&cli.transmittance).ok_or_else(|| {
        Error::option(format!(
            "transmittance `{}`: expected residual or ratio",
            volcore::text::clip(&volcore::text::escape(&cli.transmittance), 40)
        ))
    })?;
    if let Some(t) = cli.seconds {
        if !(t.is_finite() && t >= 0.0) {
            return Err(Error::option(format!(
                "--seconds {t} must be a number of seconds >= 0"
            )));
        }
    }
    if let Some(e) = cli.until_error {
        if !(e.is_finite() && e > 0.0) {
            return Err(Error::option(format!(
                "--until-error {e} must be a number above 0"
            )));
        }
    }
    if cli.spp == Some(0) {
        return Err(Error::option("--spp must be at least 1"));
    }
    if cli.repeat > 1 {
        return Err(Error::option(
            "--repeat times the ray caster's frames; a path-traced render is timed by its budget \
             (--spp, --seconds or --until-error; render_s in --json)",
        ));
    }
    if !(cli.exposure.is_finite() && cli.exposure >= 0.0) {
        return Err(Error::option(format!(
            "--exposure {} must be a finite number >= 0",
            cli.exposure
        )));
    }
    let budget = Budget {
        spp: cli
            .spp
            .or((cli.seconds.is_none() && cli.until_error.is_none()).then_some(DEFAULT_SPP)),
        seconds: cli.seconds,
        until_error: cli.until_error,
    };
    let hybrid = match cli.hybrid.as_deref() {
        None | Some("off") => None,
        Some(text) => match text.parse::<f32>() {
            Ok(s) if s.is_finite() && s > 0.0 => Some(s),
            _ => {
                return Err(Error::option(format!(
                    "--hybrid `{}`: expected off or a gradient scale above 0",
                    volcore::text::clip(&volcore::text::escape(text), 40)
                )))
            }
        },
    };
    let settings = PathSettings {
        medium,
        bounces: cli.bounces,
        g: cli.g,
        hybrid,
        majorant,
        lights: PathLights {
            lights: path_lights,
            env,
            env_map,
        },
        background: cli
            .background
            .map(|b| (b / 255.0).to_array().map(srgb_to_linear).into()),
        seed: cli.seed,
        sampler,
        transmittance,
    };
    Ok((settings, budget))
}

/// Read an equirectangular environment map: a linear float image (PFM or
/// OpenEXR; grey maps are spread over RGB, alpha is ignored). Public for
/// the `envmap` fuzz target, which loads maps the way `--env-map` does.
pub fn load_env_map(p: &Path) -> Result<EnvMap> {
    let name = p.display();
    match volcompare::image::image_extension(p) {
        Some("pfm" | "exr") => {}
        _ => {
            return Err(Error::file(format!(
                "{name}: an environment map must be a linear .pfm or .exr image"
            )))
        }
    }
    let img = volcompare::image::Image::load(p)
        .kind_ctx(ErrorKind::File, format_args!("{name}: cannot read"))?;
    let ch = img.channels();
    let rgb: Vec<f32> = img
        .samples
        .chunks_exact(ch)
        .flat_map(|s| match img.color {
            1 => [s[0]; 3],
            _ => [s[0], s[1], s[2]],
        })
        .collect();
    EnvMap::new(img.width, img.height, &rgb).map_err(|e| Error::file(format!("{name}: {e}")))
}
