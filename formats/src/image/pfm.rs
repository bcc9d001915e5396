//! PFM (portable float map) writing: linear float images, grey or RGB,
//! little-endian. The reader is in `volcompare`, beside the other image
//! loaders.

use crate::error::{Error, Result};
use crate::output::AtomicFile;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Encode a PFM image to `out`: `channels` is 1 (grey, `Pf`) or 3 (RGB,
/// `PF`), `data` holds `width × height × channels` interleaved samples with
/// rows from the top down. Written little-endian (scale −1).
pub fn encode_pfm(
    out: &mut impl Write,
    width: u32,
    height: u32,
    channels: usize,
    data: &[f32],
) -> Result<()> {
    let magic = match channels {
        1 => "Pf",
        3 => "PF",
        _ => {
            return Err(Error::invalid(format!(
                "PFM holds 1 or 3 channels, not {channels}"
            )))
        }
    };
    let row = width as usize * channels;
    if width == 0 || height == 0 || data.len() != row * height as usize {
        return Err(Error::invalid(format!(
            "PFM: {} samples do not make a {width}x{height} image with {channels} channel(s)",
            data.len()
        )));
    }
    write!(out, "{magic}\n{width} {height}\n-1.0\n")?;
    let mut buf = Vec::with_capacity(row * 4);
    for src in data.chunks_exact(row).rev() {
        buf.clear();
        for v in src {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        out.write_all(&buf)?;
    }
    Ok(())
}

/// Write an RGB float image as PFM at `path`: `rgb` holds
/// `width × height × 3` samples, interleaved, rows from the top down (the
/// order a renderer fills its framebuffer in). The file appears only when
/// complete.
pub fn write_pfm(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<()> {
    write_pfm_channels(path, width, height, 3, rgb)
}

/// Write a grey (`channels` = 1) or RGB (`channels` = 3) float image as PFM
/// at `path`; see [`encode_pfm`] for the sample order.
pub fn write_pfm_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: usize,
    data: &[f32],
) -> Result<()> {
    let mut file = AtomicFile::create(path)?;
    {
        let mut w = BufWriter::new(file.file());
        encode_pfm(&mut w, width, height, channels, data)?;
        w.flush()?;
    }
    file.commit()?;
    Ok(())
}
