//! What a frame is asked to be: the user's choices (mode, sampling,
//! shading, shadows, ambient occlusion), before each frame's set-up
//! ([`crate::frame`]) checks them and resolves them into the concrete
//! integrator it traces ([`crate::integrator`]).

use crate::shade::Lighting;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag that stops a frame (or a path-tracing render) early: the tile
/// loop checks it before each tile and the path tracer before each pass,
/// and the call then returns [`crate::RenderError::Cancelled`]. Clones
/// share the flag, so a caller keeps one and hands the other to the
/// frame (a viewer whose camera moved on, Ctrl-C in a script).
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A flag not yet raised.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Ask the work holding a clone of this flag to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called on this flag or a clone.
    #[inline]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// How shadows are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowMethod {
    /// A shadow ray per shaded sample and light, marched with skipping.
    Ray,
    /// A transmittance grid per directional light, one point every
    /// `divisor` voxels along each axis (1, 2 or 4); other lights fall
    /// back to shadow rays.
    Grid {
        /// Voxels per grid cell along each axis.
        divisor: u32,
    },
}

/// Shadow settings of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shadows {
    /// The method.
    pub method: ShadowMethod,
    /// Distance between shadow samples, world units (`None`: the frame's
    /// step).
    pub step: Option<f32>,
}

/// How ambient occlusion is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AoMethod {
    /// `n` random directions per shaded sample.
    Rays {
        /// Directions per shaded sample.
        n: u32,
    },
    /// A field of `k` fixed directions at points `cell` voxels apart,
    /// precomputed per frame.
    Field {
        /// Directions.
        k: u32,
        /// Voxels between the field's points (the speed knob: each halving
        /// takes eight times the memory and precomputation).
        cell: u32,
    },
}

/// Ambient occlusion settings of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ao {
    /// The method.
    pub method: AoMethod,
    /// How far occluders count, world units (`None`: a tenth of the
    /// volume's diagonal).
    pub radius: Option<f32>,
    /// Seed of the directions' sampler.
    pub seed: u64,
}

/// What a ray computes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Emission-absorption, front to back, through a transfer function.
    Dvr,
    /// Maximum intensity projection.
    Mip,
    /// Minimum intensity projection.
    Minip,
    /// X-ray: the integral of the value along the ray (value × length).
    XraySum,
    /// X-ray: the mean sample value along the ray.
    XrayMean,
    /// The first crossing of this iso value, refined by bisection, shaded.
    Iso(f32),
}

/// How values between voxels are reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interp {
    /// The nearest voxel.
    Nearest,
    /// Trilinear interpolation.
    Trilinear,
}

/// How gradients (for shading and for 2D classification) are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GradientMethod {
    /// Central differences of the interpolant (six more samples).
    Central,
    /// The exact gradient of the trilinear cell (no extra samples).
    Analytic,
}

/// How to render a frame.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// What each ray computes.
    pub mode: Mode,
    /// Distance between samples along a ray, world units (> 0).
    pub step: f32,
    /// Reconstruction between voxels.
    pub interp: Interp,
    /// DVR classifies each segment between consecutive samples from a
    /// pre-integrated table (1D transfer functions, trilinear values)
    /// instead of each sample alone.
    pub preintegrated: bool,
    /// DVR with adaptive steps: the error tolerated per unit length
    /// (optical depth) when a sample in a macrocell stands for several
    /// steps ([`crate::accel::strides`]); `None` for one sample per step.
    pub adaptive: Option<f32>,
    /// Gradient method for shading and 2D classification.
    pub gradient: GradientMethod,
    /// Blinn-Phong shading (DVR); iso surfaces are always shaded.
    pub shading: bool,
    /// Light and material.
    pub lighting: Lighting,
    /// Shade only where the world-space gradient is longer than this
    /// fraction of the volume's value range per world unit.
    pub gradient_threshold: f32,
    /// Early ray termination threshold for DVR, and whether MIP/MinIP stop
    /// at the volume's extreme (`None` = off).
    pub ert: Option<f32>,
    /// Empty-space skipping (needs an index).
    pub ess: bool,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Background colour, sRGB components in [0, 1].
    pub background: [f32; 3],
    /// Iso-surface colour, sRGB components in [0, 1].
    pub iso_colour: [f32; 3],
    /// Shadows toward every light (DVR with shading, and iso); `None`:
    /// off, and no shadow code runs.
    pub shadows: Option<Shadows>,
    /// Ambient occlusion (DVR with shading, and iso); `None`: off, and no
    /// occlusion code runs.
    pub ao: Option<Ao>,
    /// Stops the frame between tiles when raised (never, by default).
    pub cancel: Cancel,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Mode::Dvr,
            step: 0.5,
            interp: Interp::Trilinear,
            preintegrated: false,
            adaptive: None,
            gradient: GradientMethod::Central,
            shading: false,
            lighting: Lighting::default(),
            gradient_threshold: 0.01,
            ert: Some(0.99),
            ess: true,
            tile: 16,
            background: [0.0; 3],
            iso_colour: [0.85, 0.85, 0.8],
            shadows: None,
            ao: None,
            cancel: Cancel::default(),
        }
    }
}
