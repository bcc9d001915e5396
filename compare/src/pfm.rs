//! PFM, the portable float map: a text header and raw 32-bit floats.
//!
//! The header is three whitespace-separated fields and then exactly one
//! whitespace byte before the samples:
//!
//! ```text
//! PF            "PF" for RGB, "Pf" for one grey channel
//! 640 480       width and height
//! -1.0          scale: negative means little-endian samples, positive big
//! ```
//!
//! Samples are interleaved per pixel and the rows run from the **bottom**
//! of the image to the top. The scale's magnitude carries no meaning here:
//! it is read and ignored, and written as 1.
//!
//! In memory, [`Image`]s and the slices these functions take are rows from
//! the top down, as for every other format; the flip happens here.

use crate::error::{Error, Result};
use crate::image::{Depth, Image};
use std::path::Path;
use volcore::text::excerpt;
pub use volformats::image::pfm::{encode_pfm, write_pfm, write_pfm_channels};

/// Read a PFM file.
pub fn read_pfm(path: &Path) -> Result<Image> {
    let bytes = std::fs::read(path)?;
    decode_pfm(&bytes)
}

/// Decode a PFM file held in memory.
pub fn decode_pfm(bytes: &[u8]) -> Result<Image> {
    let mut pos = 0;
    let magic = token(bytes, &mut pos).ok_or_else(|| Error::invalid("PFM: empty file"))?;
    let channels = match magic {
        b"PF" => 3,
        b"Pf" => 1,
        _ => return Err(Error::invalid("not a PFM file (expected PF or Pf)")),
    };
    let mut field = |what: &str| {
        token(bytes, &mut pos)
            .and_then(|t| std::str::from_utf8(t).ok())
            .ok_or_else(|| Error::invalid(format!("PFM: header ends before the {what}")))
    };
    let (w, h, s) = (field("width")?, field("height")?, field("scale")?);
    let width: u32 = w.parse().map_err(|_| {
        Error::invalid(format!("PFM: width '{}' is not a whole number", excerpt(w)))
    })?;
    let height: u32 = h.parse().map_err(|_| {
        Error::invalid(format!(
            "PFM: height '{}' is not a whole number",
            excerpt(h)
        ))
    })?;
    let scale: f64 = s
        .parse()
        .map_err(|_| Error::invalid(format!("PFM: scale '{}' is not a number", excerpt(s))))?;
    if width == 0 || height == 0 {
        return Err(Error::invalid(format!("PFM: zero size {width}x{height}")));
    }
    if !scale.is_finite() || scale == 0.0 {
        return Err(Error::invalid(format!(
            "PFM: scale {s} must be finite and non-zero"
        )));
    }
    // Exactly one whitespace byte separates the header from the samples.
    match bytes.get(pos) {
        Some(c) if c.is_ascii_whitespace() => pos += 1,
        _ => return Err(Error::invalid("PFM: header ends before the samples")),
    }
    let little = scale < 0.0;
    let row = width as u64 * channels as u64;
    let expected = row.checked_mul(height as u64 * 4);
    let have = (bytes.len() - pos) as u64;
    if Some(have) != expected {
        let expected = expected.map_or("more than 2^64".to_string(), |e| e.to_string());
        return Err(Error::invalid(format!(
            "PFM: file has {have} bytes of samples, expected {expected} for {width}x{height} with {channels} channel(s)"
        )));
    }
    let row = row as usize;
    let data = &bytes[pos..];
    let mut samples = vec![0f32; row * height as usize];
    for (file_row, src) in data.chunks_exact(row * 4).enumerate() {
        let y = height as usize - 1 - file_row;
        let dst = &mut samples[y * row..(y + 1) * row];
        for (d, b) in dst.iter_mut().zip(src.chunks_exact(4)) {
            let b = [b[0], b[1], b[2], b[3]];
            *d = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Image::new(width, height, channels, false, Depth::F32, samples)
}

/// The next whitespace-separated token at or after `*pos`.
fn token<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let start = *pos;
    while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    (*pos > start).then(|| &bytes[start..*pos])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_rgb_and_grey_keeps_rows_top_down() {
        let dir = tempfile::tempdir().unwrap();
        let rgb: Vec<f32> = (0..4 * 3 * 3).map(|i| i as f32 * 0.25 - 1.5).collect();
        let p = dir.path().join("c.pfm");
        write_pfm(&p, 4, 3, &rgb).unwrap();
        let img = read_pfm(&p).unwrap();
        assert_eq!(
            (img.width, img.height, img.color, img.alpha),
            (4, 3, 3, false)
        );
        assert_eq!(img.depth, Depth::F32);
        assert_eq!(img.samples, rgb);
        // The bottom row comes first in the file.
        let bytes = std::fs::read(&p).unwrap();
        let header = b"PF\n4 3\n-1.0\n".len();
        assert_eq!(
            f32::from_le_bytes(bytes[header..header + 4].try_into().unwrap()),
            rgb[2 * 4 * 3]
        );

        let grey = vec![0.5, f32::NAN, -0.0, f32::INFINITY, 1e-30, 3.0];
        let p = dir.path().join("g.pfm");
        write_pfm_channels(&p, 2, 3, 1, &grey).unwrap();
        let img = read_pfm(&p).unwrap();
        assert_eq!((img.width, img.height, img.color), (2, 3, 1));
        let back: Vec<u32> = img.samples.iter().map(|v| v.to_bits()).collect();
        let want: Vec<u32> = grey.iter().map(|v| v.to_bits()).collect();
        assert_eq!(back, want);
    }

    #[test]
    fn big_endian_and_loose_whitespace_read() {
        let mut f = b"Pf  2\t1\r\n  1.0\n".to_vec();
        f.extend_from_slice(&1.5f32.to_be_bytes());
        f.extend_from_slice(&(-2.0f32).to_be_bytes());
        let img = decode_pfm(&f).unwrap();
        assert_eq!(img.samples, vec![1.5, -2.0]);
    }

    #[test]
    fn malformed_files_are_rejected() {
        let ok = |v: &[u8]| decode_pfm(v).map(|_| ());
        assert!(ok(b"").is_err());
        assert!(ok(b"P6\n1 1\n255\n\0\0\0").is_err());
        assert!(ok(b"PF\n1 1\n").is_err());
        assert!(ok(b"PF\n0 1\n-1\n").is_err());
        assert!(ok(b"PF\nx 1\n-1\n").is_err());
        assert!(ok(b"Pf\n1 1\n0\n\0\0\0\0").is_err());
        assert!(ok(b"Pf\n1 1\nnan\n\0\0\0\0").is_err());
        // Short and long sample data.
        assert!(ok(b"Pf\n1 1\n-1\n\0\0\0").is_err());
        assert!(ok(b"Pf\n1 1\n-1\n\0\0\0\0\0").is_err());
        assert!(ok(b"Pf\n1 1\n-1\n\0\0\0\0").is_ok());
        // A header that claims more than any file holds does not allocate.
        assert!(ok(b"PF\n4294967295 4294967295\n-1\n\0\0\0\0").is_err());
        let mut v = Vec::new();
        assert!(encode_pfm(&mut v, 2, 2, 3, &[0.0; 11]).is_err());
        assert!(encode_pfm(&mut v, 1, 1, 4, &[0.0; 4]).is_err());
    }
}
