//! 8-bit PNG writing (through the `image` crate's encoder).

use crate::error::{Error, Result};
use crate::output::AtomicFile;
use image::ImageEncoder;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Encode an 8-bit PNG to `out`: `channels` is 1 (grey), 2 (grey-alpha),
/// 3 (RGB) or 4 (RGBA); `data` holds `width × height × channels` bytes,
/// interleaved, rows from the top down.
pub fn encode_png8(
    out: impl Write,
    width: u32,
    height: u32,
    channels: usize,
    data: &[u8],
) -> Result<()> {
    use image::ExtendedColorType as C;
    let color = match channels {
        1 => C::L8,
        2 => C::La8,
        3 => C::Rgb8,
        4 => C::Rgba8,
        _ => {
            return Err(Error::invalid(format!(
                "an 8-bit PNG has 1 to 4 channels, not {channels}"
            )))
        }
    };
    let want = (width as u64) * (height as u64) * channels as u64;
    if width == 0 || height == 0 || want != data.len() as u64 {
        return Err(Error::invalid(format!(
            "{} bytes do not make a {width}x{height} image with {channels} channel(s)",
            data.len()
        )));
    }
    image::codecs::png::PngEncoder::new(out)
        .write_image(data, width, height, color)
        .map_err(|e| match e {
            image::ImageError::IoError(io) => Error::Io(io),
            other => Error::invalid(other.to_string()),
        })
}

/// Write an 8-bit PNG at `path` (see [`encode_png8`] for the arguments).
/// The file appears only when complete: it is written under a temporary
/// name and renamed into place.
pub fn write_png8(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    data: &[u8],
) -> Result<()> {
    let mut file = AtomicFile::create(path)?;
    {
        let mut w = BufWriter::new(file.file());
        encode_png8(&mut w, width, height, channels, data)?;
        w.flush()?;
    }
    file.commit()?;
    Ok(())
}
