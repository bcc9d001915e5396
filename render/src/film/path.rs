//! The path tracer's film: per-pixel sums of a progressive render, in
//! f64: radiance (r, g, b) and the luminance's square, added sample by
//! sample in sample order, so a pixel's sums depend only on its samples
//! (not on threads, tiles or how the samples were split into passes). Saved to and loaded from a state
//! file, a render continues where it stopped: 64 samples and 64 more give
//! the same bits as 128 at once.
//!
//! State file (little endian): `VKPATH01`, the scene key (u64), width and
//! height (u32), samples per pixel so far (u64), then per pixel four f64.

use std::io::{Read, Write};
use std::path::Path;

const MAGIC: &[u8; 8] = b"VKPATH01";
const HEADER: u64 = 8 + 8 + 4 + 4 + 8;

/// Rec. 709 luminance of linear RGB.
#[inline(always)]
pub fn luminance(r: f64, g: f64, b: f64) -> f64 {
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// The path tracer's film: the sums of a progressive render (see the
/// module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PathFilm {
    width: u32,
    height: u32,
    key: u64,
    spp: u64,
    /// `[Σr, Σg, Σb, ΣY²]` per pixel, rows top to bottom.
    sums: Vec<[f64; 4]>,
}

impl PathFilm {
    /// Empty sums for a `width × height` image of the scene with `key`.
    pub fn new(width: u32, height: u32, key: u64) -> PathFilm {
        PathFilm {
            width,
            height,
            key,
            spp: 0,
            sums: vec![[0.0; 4]; width as usize * height as usize],
        }
    }

    /// Image width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Samples per pixel so far.
    pub fn spp(&self) -> u64 {
        self.spp
    }

    /// The scene key the sums belong to.
    pub fn key(&self) -> u64 {
        self.key
    }

    /// The rows of sums, for a pass to add to, and the sample count the
    /// pass starts at; call [`PathFilm::finish_pass`] after.
    pub(crate) fn rows_mut(&mut self) -> (&mut [[f64; 4]], u64) {
        (&mut self.sums, self.spp)
    }

    /// Count `spp` more samples per pixel (every pixel got them).
    pub(crate) fn finish_pass(&mut self, spp: u64) {
        self.spp += spp;
    }

    /// The mean radiance per pixel, linear RGB (zeros before any sample).
    pub fn mean_rgb(&self) -> Vec<f32> {
        let inv = if self.spp > 0 {
            1.0 / self.spp as f64
        } else {
            0.0
        };
        self.sums
            .iter()
            .flat_map(|s| [s[0], s[1], s[2]].map(|c| (c * inv) as f32))
            .collect()
    }

    /// Per pixel, the standard error of the mean luminance (0 before two
    /// samples).
    pub fn standard_errors(&self) -> Vec<f32> {
        self.sums
            .iter()
            .map(|s| {
                self.pixel_error(s)
                    .map_or(0.0, |(se2, _)| se2.sqrt() as f32)
            })
            .collect()
    }

    /// `(squared standard error of the mean luminance, mean luminance)`.
    fn pixel_error(&self, s: &[f64; 4]) -> Option<(f64, f64)> {
        if self.spp < 2 {
            return None;
        }
        let n = self.spp as f64;
        let sy = luminance(s[0], s[1], s[2]);
        let mean = sy / n;
        let var = ((s[3] - sy * mean) / (n - 1.0)).max(0.0);
        Some((var / n, mean))
    }

    /// The relative standard error of the image: over lit pixels (mean
    /// luminance above 0), the root mean squared standard error of the
    /// pixel means divided by their mean. `None` before two samples or
    /// when no pixel is lit.
    pub fn relative_error(&self) -> Option<f64> {
        let (mut se2, mut mean, mut lit) = (0.0f64, 0.0f64, 0u64);
        for s in &self.sums {
            let (e, m) = self.pixel_error(s)?;
            if m > 0.0 {
                se2 += e;
                mean += m;
                lit += 1;
            }
        }
        (lit > 0 && mean > 0.0).then(|| (se2 / lit as f64).sqrt() / (mean / lit as f64))
    }

    /// The state as [`PathFilm::load`] reads it: a 32-byte header, then
    /// four little-endian f64 sums per pixel. (`vol-render --accumulate`
    /// writes it under a temporary name renamed into place when complete.)
    pub fn write_to(&self, w: &mut dyn Write) -> std::io::Result<()> {
        w.write_all(MAGIC)?;
        w.write_all(&self.key.to_le_bytes())?;
        w.write_all(&self.width.to_le_bytes())?;
        w.write_all(&self.height.to_le_bytes())?;
        w.write_all(&self.spp.to_le_bytes())?;
        for s in &self.sums {
            for v in s {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    }

    /// Read a state written by [`PathFilm::write_to`], refusing one of
    /// another scene (`key`) or image size.
    pub fn load(path: &Path, width: u32, height: u32, key: u64) -> Result<PathFilm, String> {
        let mut f = std::fs::File::open(path).map_err(|e| e.to_string())?;
        let len = f.metadata().map_err(|e| e.to_string())?.len();
        let mut head = [0u8; HEADER as usize];
        f.read_exact(&mut head)
            .map_err(|_| "too short for a path-tracing state file".to_string())?;
        if &head[..8] != MAGIC {
            return Err("not a path-tracing state file (no VKPATH01 header)".into());
        }
        let u64_at = |i: usize| u64::from_le_bytes(head[i..i + 8].try_into().unwrap_or([0; 8]));
        let u32_at = |i: usize| u32::from_le_bytes(head[i..i + 4].try_into().unwrap_or([0; 4]));
        let (k, w, h, spp) = (u64_at(8), u32_at(16), u32_at(20), u64_at(24));
        if (w, h) != (width, height) {
            return Err(format!(
                "holds a {w}x{h} image, not {width}x{height}: it is from another render"
            ));
        }
        if k != key {
            return Err(
                "was made for another scene or volume (its scene key differs): \
                 give a new state file, or the render it came from"
                    .into(),
            );
        }
        let pixels = u64::from(w) * u64::from(h);
        if len != HEADER + pixels * 32 {
            return Err(format!(
                "is {len} bytes, expected {} for {w}x{h}: truncated or damaged",
                HEADER + pixels * 32
            ));
        }
        let mut bytes = vec![0u8; (pixels * 32) as usize];
        f.read_exact(&mut bytes).map_err(|e| e.to_string())?;
        let sums: Vec<[f64; 4]> = bytes
            .chunks_exact(32)
            .map(|c| {
                std::array::from_fn(|i| {
                    f64::from_le_bytes(c[i * 8..i * 8 + 8].try_into().unwrap_or([0; 8]))
                })
            })
            .collect();
        if sums.iter().flatten().any(|v| !v.is_finite()) {
            return Err("holds non-finite sums: damaged".into());
        }
        Ok(PathFilm {
            width: w,
            height: h,
            key: k,
            spp,
            sums,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_files_round_trip_and_refuse_other_scenes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.state");
        let mut a = PathFilm::new(3, 2, 77);
        {
            let (rows, start) = a.rows_mut();
            assert_eq!(start, 0);
            for (i, s) in rows.iter_mut().enumerate() {
                *s = [i as f64, 0.5, 1e-300, 2.0];
            }
        }
        a.finish_pass(4);
        a.write_to(&mut std::fs::File::create(&p).unwrap()).unwrap();
        assert_eq!(PathFilm::load(&p, 3, 2, 77).unwrap(), a);
        assert!(PathFilm::load(&p, 3, 2, 78)
            .unwrap_err()
            .contains("another scene"));
        assert!(PathFilm::load(&p, 2, 3, 77).unwrap_err().contains("3x2"));
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 1]).unwrap();
        assert!(PathFilm::load(&p, 3, 2, 77)
            .unwrap_err()
            .contains("truncated"));
        std::fs::write(&p, b"VKPATH0").unwrap();
        assert!(PathFilm::load(&p, 3, 2, 77).is_err());
        std::fs::write(&p, [b'x'; 64]).unwrap();
        assert!(PathFilm::load(&p, 3, 2, 77).unwrap_err().contains("header"));
    }

    #[test]
    fn errors_pool_lit_pixels() {
        let mut a = PathFilm::new(2, 1, 0);
        assert_eq!(a.relative_error(), None);
        {
            let (rows, _) = a.rows_mut();
            // Pixel 0: samples of luminance 1 and 3 (grey); pixel 1 dark.
            rows[0] = [4.0, 4.0, 4.0, 10.0];
        }
        a.finish_pass(2);
        // Sample variance 2, standard error sqrt(2/2) = 1, mean 2.
        let e = a.relative_error().unwrap();
        assert!((e - 0.5).abs() < 1e-12, "{e}");
        assert_eq!(a.standard_errors()[1], 0.0);
        assert_eq!(a.mean_rgb()[..3], [2.0, 2.0, 2.0]);
    }
}
