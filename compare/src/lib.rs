//! volcompare: how far apart two images or two volumes are.
//!
//! - [`image`]: loading PNG (8 and 16-bit; gray, gray-alpha, RGB, RGBA),
//!   PFM and OpenEXR images into one [`Image`] type.
//! - [`pfm`]: the PFM float image reader (the writer is
//!   `volformats::image::pfm`, re-exported here).
//! - [`metrics`]: the accumulator behind every figure, and [`Metrics`]
//!   (MSE, PSNR, maximum absolute error, differing elements).
//! - [`compare`]: [`compare_images`] and [`compare_volumes`].
//! - [`heatmap`]: heat maps with a colour scale bar, and [`write_png8`]
//!   (both from `volformats::image`, where the image writers live).
//!
//! # Conventions
//!
//! Every sum is accumulated in `f64`. The mean squared error is pooled over
//! all compared values: MSE = Σ (a − b)² / N with N = pixels × channels
//! (alpha is compared only when asked for). PSNR = 10 · log10(peak² / MSE),
//! where the peak is the data range: 255 for 8-bit, 65535 for 16-bit, 1.0
//! for float images, unless a range is given. Identical inputs give
//! PSNR = +∞. For 8-bit images this is exactly scikit-image's
//! `peak_signal_noise_ratio`: the squared differences are integers, so their
//! `f64` sum is exact whatever the summation order.
//!
//! Output files are written through [`volformats::output::AtomicFile`]:
//! under a temporary name, renamed into place only when complete.

pub mod compare;
pub mod error;
pub mod image;
mod load;
pub mod metrics;
pub mod pfm;

pub use compare::{
    compare_images, compare_volumes, ImageComparison, ImageOptions, PeakSource, VolumeComparison,
    VolumeOptions,
};
pub use error::{Error, Result};
pub use image::{Depth, Image};
pub use metrics::{psnr, Accumulator, Metrics};
pub use pfm::{read_pfm, write_pfm};
pub use volformats::image::heatmap;
pub use volformats::image::{write_heatmap, write_png8};
