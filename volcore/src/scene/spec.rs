//! Which procedural scene to make and its parameters: vol-gen's scene
//! options (with the `clap` feature, its command-line definition), their
//! checks and the scene they build. One definition for vol-gen and any
//! other caller (the Python package's `generate`).

use super::{
    BoxScene, NoiseKind, NoiseScene, PhantomScene, RampScene, Scene, ShapesScene, SolidScene,
    SphereScene, SpheresScene, WavesScene,
};
use crate::dims::Dims;
use crate::sample::SampleType;

/// The scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SceneName {
    /// The thesis test scene: random cuboids and ellipsoids, values value±10.
    Shapes,
    /// Soft ellipsoids with smooth falloff and varying peaks.
    Spheres,
    /// Fractal value or gradient noise.
    Noise,
    /// Constant value with a 5-voxel border of zeros.
    Solid,
    /// Analytic: constant-density box (--margin empty voxels around it).
    Box,
    /// Analytic: linear ramp from 0 to --value along --axis.
    Ramp,
    /// Analytic: one sphere, value·max(0, 1 − r/radius), at the centre.
    Sphere,
    /// CT-like head in Hounsfield units (air −1000, brain 35, bone 1100)
    /// with partial-volume edges and noise; i16 unless --type f32.
    Phantom,
    /// Analytic, band-limited: 5 plane waves of wavelengths 40 to 4
    /// voxels (directions and phases from --seed), values 0..--value;
    /// for resampling studies (write --type f32).
    Waves,
}

impl SceneName {
    /// The name on the command line (`shapes`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SceneName::Shapes => "shapes",
            SceneName::Spheres => "spheres",
            SceneName::Noise => "noise",
            SceneName::Solid => "solid",
            SceneName::Box => "box",
            SceneName::Ramp => "ramp",
            SceneName::Sphere => "sphere",
            SceneName::Phantom => "phantom",
            SceneName::Waves => "waves",
        }
    }
}

/// An axis of the volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
    /// z.
    Z,
}

/// The kind of lattice noise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum NoiseArg {
    /// Value noise.
    Value,
    /// Gradient noise.
    Gradient,
}

/// The most objects a shapes or spheres scene takes (each is tested for
/// every row it may cross).
pub const MAX_COUNT: usize = 100_000;

/// A scene and its parameters (vol-gen's options besides the output's).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct SceneSpec {
    /// Which scene to generate.
    #[cfg_attr(feature = "clap", arg(value_enum))]
    pub scene: SceneName,
    /// Random seed; the same seed gives the same volume.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub seed: u64,
    /// shapes/spheres: number of objects (0-100000).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 70, value_parser = clap::value_parser!(u64).range(0..=MAX_COUNT as u64)))]
    pub count: u64,
    /// shapes: nominal object size in voxels; spheres: nominal semi-axis
    /// (1-4294967295).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 70, value_parser = clap::value_parser!(u64).range(1..=u32::MAX as u64)))]
    pub size: u64,
    /// Peak or inside value, within the sample type's range (0-255 for u8,
    /// 0-65535 for u16, -32768-32767 for i16, finite for f32; default: 100
    /// for shapes, solid and box, 255 otherwise).
    #[cfg_attr(feature = "clap", arg(long, allow_hyphen_values = true))]
    pub value: Option<f32>,

    /// noise: kind of lattice noise.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "gradient"))]
    pub noise: NoiseArg,
    /// noise: lattice period of the first octave, in voxels (at least 1,
    /// finite).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 64.0, value_parser = period))]
    pub period: f64,
    /// noise: number of octaves (1-16).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=16)))]
    pub octaves: u32,
    /// box: empty voxels between the box and each face (less than half of
    /// the smallest dimension, so that the box is not empty).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0))]
    pub margin: u64,

    /// ramp: the axis the value grows along.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "x"))]
    pub axis: Axis,
    /// sphere: outer radius in voxels, positive and finite (default: half
    /// the smallest dimension).
    #[cfg_attr(feature = "clap", arg(long, value_parser = positive_f32))]
    pub radius: Option<f32>,

    /// sphere: a solid sphere of the full value whose surface is a linear
    /// ramp this many voxels wide, centred on the radius (instead of the
    /// cone-shaped radial profile): gradients are zero inside and outside
    /// and value/edge per voxel in the shell (positive and finite).
    #[cfg_attr(feature = "clap", arg(long, value_parser = positive_f32))]
    pub edge: Option<f32>,
}

/// Parse a noise period: a number of voxels of at least 1.
pub fn period(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 1.0 => Ok(v),
        _ => Err(format!("'{s}' is not a number of voxels of at least 1")),
    }
}

/// Parse a positive finite number.
pub fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive finite number")),
    }
}

impl SceneSpec {
    /// The sample type written: `asked`, else the scene's own (i16 for
    /// the phantom, u8 otherwise).
    pub fn sample_type(&self, asked: Option<SampleType>) -> SampleType {
        match (asked, self.scene) {
            (Some(t), _) => t,
            (None, SceneName::Phantom) => SampleType::I16,
            (None, _) => SampleType::U8,
        }
    }

    /// The checks that need more than one option: the value against the
    /// sample type `t`, the margin against the dimensions.
    pub fn validate(&self, t: SampleType, dims: Dims) -> Result<(), String> {
        if let Some(v) = self.value {
            let fits = match t.integer_range() {
                Some((lo, hi)) => (lo..=hi).contains(&(v as f64)),
                None => v.is_finite(),
            };
            if !fits {
                let range = match t.integer_range() {
                    Some((lo, hi)) => format!("{lo}..={hi}"),
                    None => "a finite number".to_string(),
                };
                return Err(format!(
                    "--value {v} does not fit {t} samples (use {range}, or another --type)"
                ));
            }
        }
        if matches!(self.scene, SceneName::Phantom) && matches!(t, SampleType::U8 | SampleType::U16)
        {
            return Err(format!(
                "phantom writes Hounsfield units (-1000 to 1300), which {t} cannot hold: use --type i16 or f32"
            ));
        }
        let smallest = dims.x.min(dims.y).min(dims.z);
        if matches!(self.scene, SceneName::Box) && self.margin.saturating_mul(2) >= smallest {
            return Err(format!(
                "--margin {} leaves no box inside {}x{}x{} voxels (it must be below half of {smallest})",
                self.margin, dims.x, dims.y, dims.z
            ));
        }
        Ok(())
    }

    /// The scene of `dims` voxels.
    pub fn build(&self, dims: Dims) -> Box<dyn Scene> {
        let value = |d: f32| self.value.unwrap_or(d);
        match self.scene {
            SceneName::Shapes => Box::new(ShapesScene::new(
                dims,
                self.seed,
                self.count as usize,
                self.size,
                value(100.0),
            )),
            SceneName::Spheres => Box::new(SpheresScene::new(
                dims,
                self.seed,
                self.count as usize,
                self.size,
                value(255.0),
            )),
            SceneName::Noise => Box::new(NoiseScene::new(
                dims,
                self.seed,
                match self.noise {
                    NoiseArg::Value => NoiseKind::Value,
                    NoiseArg::Gradient => NoiseKind::Gradient,
                },
                self.period,
                self.octaves,
                value(255.0),
            )),
            SceneName::Solid => Box::new(SolidScene::new(dims, value(100.0))),
            SceneName::Box => Box::new(BoxScene::new(dims, self.margin, value(100.0))),
            SceneName::Ramp => Box::new(RampScene::new(dims, self.axis as usize, value(255.0))),
            SceneName::Sphere => {
                let smallest = dims.x.min(dims.y).min(dims.z) as f32;
                let r = self.radius.unwrap_or(smallest / 2.0);
                match self.edge {
                    Some(e) => Box::new(SphereScene::with_edge(dims, r, value(255.0), e)),
                    None => Box::new(SphereScene::new(dims, r, value(255.0))),
                }
            }
            SceneName::Phantom => Box::new(PhantomScene::new(dims, self.seed)),
            SceneName::Waves => Box::new(WavesScene::new(dims, self.seed, value(255.0))),
        }
    }
}
