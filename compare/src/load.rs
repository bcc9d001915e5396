//! Loading an image file by its extension, through the reader of its
//! format: PFM ([`crate::pfm`]), PNG and OpenEXR (the `image` crate).

use crate::error::{Error, Result};
use crate::image::{image_extension, Image, MAX_EXPANSION};
use crate::pfm::read_pfm;
use image::DynamicImage;
use std::path::Path;

impl Image {
    /// Load an image by its extension: `.png` (8 or 16-bit; grey,
    /// grey-alpha, RGB, RGBA; palettes and lower bit depths are expanded to
    /// 8 bits), `.pfm`, `.exr` (read as 32-bit float RGB or RGBA).
    pub fn load(path: &Path) -> Result<Image> {
        match image_extension(path) {
            Some("pfm") => read_pfm(path),
            Some("png") => decode_with(path, image::ImageFormat::Png),
            Some("exr") => decode_with(path, image::ImageFormat::OpenExr),
            _ => Err(Error::invalid(
                "unknown image type (expected .png, .pfm or .exr)",
            )),
        }
    }
}

/// Decode the PNG or OpenEXR file at `path` (`format`) into an [`Image`],
/// refusing a header that claims more than [`MAX_EXPANSION`] times the
/// file's size.
fn decode_with(path: &Path, format: image::ImageFormat) -> Result<Image> {
    use image::ImageDecoder;
    let err = |e: image::ImageError| match e {
        image::ImageError::IoError(io) => Error::Io(io),
        other => Error::invalid(volcore::text::clip(&other.to_string(), 200)),
    };
    let file = std::fs::File::open(path)?;
    let file_len = file.metadata()?.len();
    let reader = image::ImageReader::with_format(std::io::BufReader::new(file), format);
    let decoder = reader.into_decoder().map_err(err)?;
    // Checked before the decoder allocates the image (and, for OpenEXR,
    // fills it).
    let (w, h) = decoder.dimensions();
    let bytes = decoder.total_bytes();
    if bytes > file_len.max(1).saturating_mul(MAX_EXPANSION) {
        return Err(Error::invalid(format!(
            "the header describes a {w}x{h} image of {bytes} bytes, more than a file of {file_len} bytes can hold even compressed (damaged header?)"
        )));
    }
    let mut limits = image::Limits::default();
    limits.reserve(bytes).map_err(err)?;
    Image::from_dynamic(DynamicImage::from_decoder(decoder).map_err(err)?)
}
