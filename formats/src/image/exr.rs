//! Linear float images as OpenEXR (through the `image` crate's encoder),
//! written atomically like every other image.

use crate::error::{Error, Result};
use crate::output::AtomicFile;
use image::codecs::openexr::OpenExrEncoder;
use image::{ExtendedColorType, ImageEncoder};
use std::io::{BufWriter, Write};
use std::path::Path;

/// Write an RGB float image as OpenEXR at `path`: `rgb` holds
/// `width × height × 3` samples, interleaved, rows from the top down. The
/// file appears only when complete.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<()> {
    let n = width as usize * height as usize * 3;
    if rgb.len() != n {
        return Err(Error::invalid(format!(
            "{} samples for a {width}x{height} RGB image (expected {n})",
            rgb.len()
        )));
    }
    let bytes: Vec<u8> = rgb.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut file = AtomicFile::create(path)?;
    {
        let mut w = BufWriter::new(file.file());
        OpenExrEncoder::new(&mut w)
            .write_image(&bytes, width, height, ExtendedColorType::Rgb32F)
            .map_err(|e| Error::invalid(format!("cannot encode OpenEXR: {e}")))?;
        w.flush()?;
    }
    file.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trips_through_the_decoder() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.exr");
        let rgb: Vec<f32> = (0..4 * 3 * 3).map(|i| i as f32 * 0.25 - 1.0).collect();
        write_exr(&p, 4, 3, &rgb).unwrap();
        let img = image::open(&p).unwrap().into_rgb32f();
        assert_eq!((img.width(), img.height()), (4, 3));
        assert_eq!(img.as_raw(), &rgb);
        assert!(write_exr(&p, 5, 3, &rgb).is_err());
    }
}
