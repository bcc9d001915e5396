//! Image files the tools write: 8-bit PNG ([`png`]), linear float PFM
//! ([`pfm`]) and OpenEXR ([`exr`]), and heat maps with a colour scale ([`heatmap`]). Every writer
//! goes through [`crate::output::AtomicFile`], so a file appears only when
//! complete.

pub mod exr;
pub mod heatmap;
pub mod pfm;
pub mod png;

pub use exr::write_exr;
pub use heatmap::{render_heatmap, write_heatmap, HeatMap};
pub use pfm::{encode_pfm, write_pfm, write_pfm_channels};
pub use png::{encode_png8, write_png8};
