//! volrender: a tiled, parallel CPU ray caster over volcore volumes.
//!
//! A frame is a [`Camera`], [`RenderSettings`] (mode, step,
//! interpolation, gradient, shading, early termination, empty-space
//! skipping) and, for the modes that need one, a transfer function
//! ([`tf`]). [`render`] ([`frame`]) checks the settings, lets the mode's
//! set-up choose one concrete integrator type ([`integrator`]), and runs it for
//! every pixel, tile by tile on all threads ([`tiles`]), into a
//! [`film::Film`] that resolves to a [`Frame`]. Every pixel is computed on
//! its own from its own ray, so the image does not depend on the thread
//! count or the tile order.
//!
//! The pieces, after pbrt's split: [`camera`] and [`ray`]; [`sampler`]
//! (hashed random numbers for Monte Carlo work); [`film`] (one per
//! pipeline: the ray caster's, the path tracer's); [`light`] and
//! [`shade`] (Blinn-Phong); [`tf`] (transfer functions as written) and
//! [`classify`] (their per-frame tables); [`accel`] (macrocell skipping
//! rules, DDA segments and majorants over the index); [`trace`] (what
//! one ray's trace is: the march loop, reconstruction, the frame's sample
//! placement); [`effects`] (shadows by shadow rays or light grids, ambient
//! occlusion, only when a frame asks); [`integrator`] (DVR, MIP/MinIP,
//! X-ray, iso over one march loop); [`frame`] (per-frame set-up: checks,
//! effect grids, the mode's integrator, the tiles);
//! [`path`] (Monte Carlo volumetric path tracing over the majorant grid).
//!
//! Conventions (VTK's image data): voxel `(i, j, k)` sits at world position
//! `(i·sx, j·sy, k·sz)` and the volume's box is `[0, (dims − 1)·spacing]`.
//! Samples along a ray lie at `t = k·step` from the ray's origin for whole
//! `k`, a grid fixed by the ray alone, so skipping and tiling never move a
//! sample.

pub mod accel;
pub mod camera;
pub mod classify;
pub mod distributed;
pub mod effects;
pub mod error;
pub mod film;
pub mod frame;
pub mod integrator;
pub mod lanes;
pub mod light;
pub mod path;
pub mod ray;
pub mod sampler;
pub mod settings;
pub mod shade;
pub mod tf;
pub mod tiles;
pub mod trace;

pub use camera::{Camera, Projection};
pub use error::RenderError;
pub use film::{EffectStats, Frame, FrameStats};
pub use frame::{render, render_tf};
pub use light::Light;
pub use settings::{
    Ao, AoMethod, Cancel, GradientMethod, Interp, Mode, RenderSettings, ShadowMethod, Shadows,
};
pub use shade::{BlinnPhong, Lighting};
pub use tf::{Tf, TransferFunction};
