//! The choices among named values that the command line and the scene
//! file share (`--mode`, `--interp`, `--shading`, `--gradient`, `--up`,
//! `--tonemap`), with their names in both.

use clap::ValueEnum;
use glam::Vec3;
use serde::Serialize;

/// `--mode`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModeArg {
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
    /// Monte Carlo volumetric path tracing (delta tracking over the
    /// majorant grid, next-event estimation, progressive).
    Path,
}

/// `--interp`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum InterpArg {
    /// The nearest voxel.
    Nearest,
    /// Trilinear interpolation.
    Trilinear,
}

/// `--shading`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShadingArg {
    /// Classified colour as is.
    None,
    /// Blinn-Phong with the light.
    Phong,
}

/// `--gradient`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GradientArg {
    /// Central differences.
    Central,
    /// The analytic gradient of the trilinear cell.
    Analytic,
}

/// `--up`: a vector, or the patient's superior direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UpArg {
    /// This vector (any nonzero length).
    Vector(Vec3),
    /// The data's superior direction, from its geometry.
    Patient,
}

/// As `--up` reads it back: `[x, y, z]` or `"patient"`.
impl Serialize for UpArg {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            UpArg::Vector(v) => v.serialize(s),
            UpArg::Patient => s.serialize_str("patient"),
        }
    }
}

/// `--tonemap`: how linear radiance becomes the PNG's display values.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TonemapArg {
    /// Clamp to [0, 1].
    Clamp,
    /// Reinhard: x / (1 + x).
    Reinhard,
    /// The ACES filmic curve (Narkowicz's fit).
    Aces,
}
