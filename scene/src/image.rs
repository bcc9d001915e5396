//! The pictures a render yields: its linear float image, the 8-bit sRGB
//! one for display (the ray caster's coverage alpha, the path tracer's
//! exposure and tone map), and the heat maps (samples per pixel, standard
//! error).

use crate::choices::TonemapArg;
use crate::error::{chain, Error, Result};
use crate::options::Options;
use crate::render::{Image, Rendered};
use std::path::Path;
use volformats::image::{write_exr, write_heatmap, write_pfm, write_png8};

impl Rendered {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        match &self.image {
            Image::Frame(f) => f.width,
            Image::Path(t) => t.acc.width(),
        }
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        match &self.image {
            Image::Frame(f) => f.height,
            Image::Path(t) => t.acc.height(),
        }
    }

    /// The linear image, RGB floats row by row from the top (what `--hdr`
    /// writes): the ray caster's frame composited over the background, or
    /// the path tracer's mean radiance.
    pub fn linear_rgb(&self) -> Vec<f32> {
        match &self.image {
            Image::Frame(f) => f.linear_rgb(),
            Image::Path(t) => t.acc.mean_rgb(),
        }
    }

    /// The 8-bit sRGB image the PNG holds and its channel count: RGBA
    /// with coverage alpha under `--alpha` (ray casting), else RGB; path
    /// tracing scaled by `--exposure` and tone mapped by `--tonemap`.
    pub fn display8(&self, options: &Options) -> (usize, Vec<u8>) {
        match &self.image {
            Image::Frame(f) => {
                let channels = if options.alpha { 4 } else { 3 };
                (channels, f.srgb8(options.alpha))
            }
            Image::Path(t) => {
                let png = t
                    .acc
                    .mean_rgb()
                    .iter()
                    .map(|&c| volrender::film::srgb8(tonemap(c, options.exposure, options.tonemap)))
                    .collect();
                (3, png)
            }
        }
    }

    /// Write the files the options name: the PNG at `output` (when
    /// given), and the float image (`--hdr`: PFM, or OpenEXR for a
    /// path-traced `.exr`) and heat maps (`--heatmap`, `--variance`) when
    /// asked for. An error names the file.
    pub fn write_files(&self, options: &Options, output: Option<&Path>) -> Result<()> {
        let (w, h) = (self.width(), self.height());
        let at = |p: &Path| {
            let name = p.display().to_string();
            move |e: volformats::Error| Error::file(format!("{name}: {}", chain(&e)))
        };
        if let Some(output) = output {
            let (channels, png) = self.display8(options);
            write_png8(output, w, h, channels, &png).map_err(at(output))?;
        }
        if let Some(p) = &options.hdr {
            let rgb = self.linear_rgb();
            let exr = matches!(self.image, Image::Path(_))
                && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            if exr {
                write_exr(p, w, h, &rgb)
            } else {
                write_pfm(p, w, h, &rgb)
            }
            .map_err(at(p))?;
        }
        if let (Some(p), Some(counts)) = (&options.heatmap, self.sample_counts()) {
            write_heatmap(p, &counts, w, h).map_err(at(p))?;
        }
        if let (Some(p), Some(errors)) = (&options.variance, self.standard_errors()) {
            write_heatmap(p, &errors, w, h).map_err(at(p))?;
        }
        Ok(())
    }

    /// Samples per pixel (ray casting, for `--heatmap`); `None` for a
    /// path-traced render.
    pub fn sample_counts(&self) -> Option<Vec<f32>> {
        match &self.image {
            Image::Frame(f) => Some(f.sample_counts()),
            Image::Path(_) => None,
        }
    }

    /// Each pixel's standard error (path tracing, for `--variance`);
    /// `None` for a ray-cast frame.
    pub fn standard_errors(&self) -> Option<Vec<f32>> {
        match &self.image {
            Image::Frame(_) => None,
            Image::Path(t) => Some(t.acc.standard_errors()),
        }
    }
}

/// Linear radiance to a display value in [0, 1]: scaled by `exposure`,
/// then mapped by `how`.
pub fn tonemap(c: f32, exposure: f32, how: TonemapArg) -> f32 {
    let x = (c * exposure).max(0.0);
    let y = match how {
        TonemapArg::Clamp => x,
        TonemapArg::Reinhard => x / (1.0 + x),
        TonemapArg::Aces => (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14),
    };
    if y.is_nan() {
        0.0
    } else {
        y.clamp(0.0, 1.0)
    }
}
