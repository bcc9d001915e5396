//! volrender: a tiled, parallel CPU ray caster over volcore volumes.
//!
//! A frame is a [`Camera`], a [`RenderSettings`] (mode, step, interpolation,
//! gradient, shading, early termination, empty-space skipping) and, for the
//! modes that need one, a [`TransferFunction`]. [`render`] picks one
//! monomorphised inner loop for that combination once per frame and runs it
//! for every pixel, tile by tile on all threads. Every pixel is computed on
//! its own from its own ray, so the image does not depend on the thread
//! count or the tile order.
//!
//! Conventions (VTK's image data): voxel `(i, j, k)` sits at world position
//! `(i·sx, j·sy, k·sz)` and the volume's box is `[0, (dims − 1)·spacing]`.
//! Samples along a ray lie at `t = k·step` from the ray's origin for whole
//! `k`, a grid fixed by the ray alone, so skipping and tiling never move a
//! sample.

pub mod camera;
pub mod error;
pub mod frame;
pub mod integrate;
pub mod light;
pub mod ray;
pub mod skip;
pub mod tf;

pub use camera::{Camera, Projection};
pub use error::RenderError;
pub use frame::{render, Frame, FrameStats, RenderSettings};
pub use integrate::{GradientMethod, Interp, Mode};
pub use light::Lighting;
pub use tf::TransferFunction;
