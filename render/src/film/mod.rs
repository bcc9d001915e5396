//! Films: what a frame's samples are added into, one per pipeline, side
//! by side (after pbrt-v4, whose films share no storage: each holds what
//! its pipeline needs).
//!
//! - [`ray`]: the ray-casting modes' film (DVR, MIP/MinIP, X-ray, iso),
//!   one ray's result per pixel in f64 sums with a ray count, joined front
//!   to back across ranks, resolved by the mode's [`Display`] into a
//!   [`Frame`].
//! - [`path`]: the path tracer's film, resumable per-pixel f64 sums of
//!   radiance and squared luminance over any number of passes, saved to
//!   and continued from a state file.
//!
//! Neither holds the other's data: the ray caster takes one sample per
//! pixel and needs depth, value and alpha; the path tracer takes many
//! and needs their variance and a state that outlives the process.

pub mod path;
pub mod ray;

pub use path::{luminance, PathFilm};
pub(crate) use ray::Px;
pub use ray::{srgb8, Display, EffectStats, Film, Frame, FrameStats};
