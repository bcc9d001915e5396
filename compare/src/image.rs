//! Images in memory, and loading them from PNG, PFM and OpenEXR files.

use crate::error::{Error, Result};
use image::DynamicImage;
use std::path::Path;

/// How the samples of an image were stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Depth {
    /// 8-bit integers, 0..=255.
    U8,
    /// 16-bit integers, 0..=65535.
    U16,
    /// 32-bit floats (PFM, OpenEXR).
    F32,
}

impl Depth {
    /// The data range of integer depths (255, 65535); `None` for floats.
    pub fn peak(self) -> Option<f64> {
        match self {
            Depth::U8 => Some(255.0),
            Depth::U16 => Some(65535.0),
            Depth::F32 => None,
        }
    }

    /// A short name: `8-bit`, `16-bit`, `float`.
    pub fn name(self) -> &'static str {
        match self {
            Depth::U8 => "8-bit",
            Depth::U16 => "16-bit",
            Depth::F32 => "float",
        }
    }
}

/// An image: interleaved samples, rows from the top down, colour channels
/// (1 grey or 3 RGB) followed by an optional alpha channel. Samples are
/// held as `f32`, which is exact for 8 and 16-bit integers.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Colour channels: 1 (grey) or 3 (RGB).
    pub color: usize,
    /// Whether an alpha channel follows the colour channels.
    pub alpha: bool,
    /// How the samples were stored.
    pub depth: Depth,
    /// `width × height × channels()` samples.
    pub samples: Vec<f32>,
}

impl Image {
    /// An image from its parts; checks the channel count and the number of
    /// samples.
    pub fn new(
        width: u32,
        height: u32,
        color: usize,
        alpha: bool,
        depth: Depth,
        samples: Vec<f32>,
    ) -> Result<Image> {
        if color != 1 && color != 3 {
            return Err(Error::invalid(format!(
                "an image has 1 or 3 colour channels, not {color}"
            )));
        }
        let channels = color + alpha as usize;
        let want = (width as u64)
            .checked_mul(height as u64)
            .and_then(|p| p.checked_mul(channels as u64));
        if width == 0 || height == 0 || want != Some(samples.len() as u64) {
            return Err(Error::invalid(format!(
                "{} samples do not make a {width}x{height} image with {channels} channel(s)",
                samples.len()
            )));
        }
        Ok(Image {
            width,
            height,
            color,
            alpha,
            depth,
            samples,
        })
    }

    /// Samples per pixel: colour channels plus alpha.
    pub fn channels(&self) -> usize {
        self.color + self.alpha as usize
    }

    /// Pixel count.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The channels' names, in sample order: `Y` or `R G B`, then `A`.
    pub fn channel_names(&self) -> &'static [&'static str] {
        match (self.color, self.alpha) {
            (1, false) => &["Y"],
            (1, true) => &["Y", "A"],
            (_, false) => &["R", "G", "B"],
            (_, true) => &["R", "G", "B", "A"],
        }
    }

    /// A short description of the pixel format, e.g. `8-bit RGBA`.
    pub fn format_name(&self) -> String {
        let layout = match (self.color, self.alpha) {
            (1, false) => "grey",
            (1, true) => "grey+alpha",
            (_, false) => "RGB",
            (_, true) => "RGBA",
        };
        format!("{} {layout}", self.depth.name())
    }

    /// Convert a decoded [`DynamicImage`], keeping its depth and channels.
    pub fn from_dynamic(img: DynamicImage) -> Result<Image> {
        let (w, h) = (img.width(), img.height());
        fn widen<T: Copy + Into<f32>>(v: &[T]) -> Vec<f32> {
            v.iter().map(|&s| s.into()).collect()
        }
        let (color, alpha, depth, samples) = match img {
            DynamicImage::ImageLuma8(b) => (1, false, Depth::U8, widen(b.as_raw())),
            DynamicImage::ImageLumaA8(b) => (1, true, Depth::U8, widen(b.as_raw())),
            DynamicImage::ImageRgb8(b) => (3, false, Depth::U8, widen(b.as_raw())),
            DynamicImage::ImageRgba8(b) => (3, true, Depth::U8, widen(b.as_raw())),
            DynamicImage::ImageLuma16(b) => (1, false, Depth::U16, widen(b.as_raw())),
            DynamicImage::ImageLumaA16(b) => (1, true, Depth::U16, widen(b.as_raw())),
            DynamicImage::ImageRgb16(b) => (3, false, Depth::U16, widen(b.as_raw())),
            DynamicImage::ImageRgba16(b) => (3, true, Depth::U16, widen(b.as_raw())),
            DynamicImage::ImageRgb32F(b) => (3, false, Depth::F32, b.into_raw()),
            DynamicImage::ImageRgba32F(b) => (3, true, Depth::F32, b.into_raw()),
            other => {
                return Err(Error::invalid(format!(
                    "unsupported pixel format {:?}",
                    other.color()
                )))
            }
        };
        Image::new(w, h, color, alpha, depth, samples)
    }
}

/// The lower-case extension if it names an image format this crate reads
/// (`png`, `pfm`, `exr`).
pub fn image_extension(path: &Path) -> Option<&'static str> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    ["png", "pfm", "exr"].into_iter().find(|e| *e == ext)
}

/// How many times larger than its whole file a decoded PNG or OpenEXR
/// image may be. Neither format's compression expands more (deflate, of
/// PNG and of EXR's ZIP, at most 1032:1; EXR's RLE 64:1; PIZ, PXR24 and
/// the B44 variants less); a header whose size claims more is damaged.
/// The same bound as TIFF pages (`volformats::tiff`).
pub const MAX_EXPANSION: u64 = 4096;

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, Luma, LumaA, Rgb, Rgba};

    #[test]
    fn png_depths_and_layouts_load_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let g16: ImageBuffer<Luma<u16>, Vec<u16>> =
            ImageBuffer::from_fn(3, 2, |x, y| Luma([(x * 30000 + y * 5000) as u16]));
        g16.save(&p).unwrap();
        let img = Image::load(&p).unwrap();
        assert_eq!((img.depth, img.color, img.alpha), (Depth::U16, 1, false));
        assert_eq!(img.samples[2], 60000.0);
        assert_eq!(img.samples[3], 5000.0);

        let la: ImageBuffer<LumaA<u8>, Vec<u8>> =
            ImageBuffer::from_fn(2, 2, |x, _| LumaA([x as u8 * 200, 7]));
        la.save(&p).unwrap();
        let img = Image::load(&p).unwrap();
        assert_eq!(img.format_name(), "8-bit grey+alpha");
        assert_eq!(
            img.samples,
            vec![0.0, 7.0, 200.0, 7.0, 0.0, 7.0, 200.0, 7.0]
        );

        let rgb16: ImageBuffer<Rgb<u16>, Vec<u16>> =
            ImageBuffer::from_fn(1, 1, |_, _| Rgb([1, 65535, 300]));
        rgb16.save(&p).unwrap();
        assert_eq!(Image::load(&p).unwrap().samples, vec![1.0, 65535.0, 300.0]);

        let rgba: ImageBuffer<Rgba<u8>, Vec<u8>> =
            ImageBuffer::from_fn(1, 1, |_, _| Rgba([1, 2, 3, 4]));
        rgba.save(&p).unwrap();
        let img = Image::load(&p).unwrap();
        assert_eq!(img.channel_names(), &["R", "G", "B", "A"]);
        assert_eq!(img.samples, vec![1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn exr_loads_as_float() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.exr");
        let buf: ImageBuffer<Rgb<f32>, Vec<f32>> =
            ImageBuffer::from_fn(2, 1, |x, _| Rgb([x as f32 + 0.25, -1.5, 1e-3]));
        DynamicImage::ImageRgb32F(buf).save(&p).unwrap();
        let img = Image::load(&p).unwrap();
        assert_eq!(img.depth, Depth::F32);
        assert_eq!(img.color, 3);
        assert_eq!(&img.samples[..3], &[0.25, -1.5, 1e-3]);
        assert_eq!(img.samples[3], 1.25);
    }

    #[test]
    fn bad_files_and_parts_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("junk.png");
        std::fs::write(&p, b"not a png at all").unwrap();
        assert!(matches!(Image::load(&p), Err(Error::Invalid(_))));
        assert!(matches!(
            Image::load(&dir.path().join("missing.png")),
            Err(Error::Io(_))
        ));
        assert!(Image::load(&dir.path().join("x.jpg")).is_err());
        assert!(Image::new(2, 2, 2, false, Depth::U8, vec![0.0; 8]).is_err());
        assert!(Image::new(2, 2, 3, false, Depth::U8, vec![0.0; 11]).is_err());
        assert!(Image::new(0, 2, 1, false, Depth::U8, vec![]).is_err());
    }
}
