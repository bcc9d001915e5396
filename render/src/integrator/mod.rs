//! The integrators: what happens along one ray, per mode.
//!
//! Each integrator is a type ([`Dvr`], [`Mip`], [`Xray`], [`Iso`]) that
//! owns its configuration and is generic only over the choices that change
//! its inner loop's memory reads or arithmetic (gradient method,
//! classifier, shading, MIP or MinIP), each a small type; the rest
//! (reconstruction, early termination, skipping on or off, the lights,
//! shadows and occlusion) are values checked per ray or per sample taken
//! one by one. Each
//! integrator's frame set-up ([`crate::frame`]) picks its types once per
//! frame; a choice that is off costs nothing but that check: with shading
//! off no gradient is computed, and MIP, MinIP and X-ray never touch a
//! transfer function. They all walk the ray's samples with one loop,
//! [`crate::trace::march::march`].

pub mod dvr;
pub mod iso;
pub mod mip;
pub mod xray;

pub use crate::trace::reconstruct::{Analytic, Central, Gradient, NoGradient};
pub use crate::trace::{FrameGeometry, Integrator, RayResult, Span};
pub use dvr::shading::{Phong, Shading, Unshaded};
pub use dvr::Dvr;
pub use iso::Iso;
pub use mip::{Maximum, Minimum, Mip};
pub use xray::Xray;
