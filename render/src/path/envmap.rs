//! An environment map: radiance arriving from every direction, read from
//! an equirectangular (latitude-longitude) image, and importance-sampled
//! in proportion to its luminance for next-event estimation.
//!
//! Orientation: +y is up. Row 0 of the image is the zenith (+y), the last
//! row the nadir; the column coordinate `u = φ / 2π` runs with the azimuth
//! `φ = atan2(z, x)`, so the image's left edge looks along +x, a quarter
//! of the way along +z, half-way along −x. The radiance is constant over
//! each texel (nearest lookup), so the sampling density matches it
//! exactly: a direction's density is its texel's share of
//! `luminance × sin θ` (θ the polar angle at the row's centre), spread
//! uniformly over the texel in (u, v) and turned into a density per
//! steradian by the Jacobian `2π² sin θ`.
//!
//! The distribution is a marginal over rows and a conditional over
//! columns, both cumulative in f64 (a 8k × 4k map keeps its smallest
//! texels' probabilities).

use crate::error::RenderError;
use crate::film::luminance;
use glam::Vec3;
use std::f64::consts::PI;
use std::fmt;

/// Texels an environment map may hold (a 16k × 8k map).
pub const MAX_TEXELS: u64 = 1 << 27;

/// An equirectangular environment map with its sampling distribution.
#[derive(Clone)]
pub struct EnvMap {
    width: u32,
    height: u32,
    /// Radiance per texel, linear RGB, rows from the zenith down.
    texels: Vec<Vec3>,
    /// Cumulative row probabilities: `height + 1` entries from 0 to 1.
    rows: Vec<f64>,
    /// Per row, cumulative column probabilities within the row:
    /// `width + 1` entries each, from 0 to 1 (all 0 for an empty row).
    cols: Vec<f64>,
    /// Sum of `luminance × sin θ` over all texels (0: nothing to sample).
    total: f64,
    /// A hash of the size and every texel's bits.
    hash: u64,
}

/// A direction drawn from the map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// Unit direction toward the environment.
    pub dir: Vec3,
    /// Radiance arriving from it.
    pub radiance: Vec3,
    /// Its density per steradian (> 0).
    pub pdf: f32,
}

impl fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // The texels by their hash: scene keys print settings with `{:?}`.
        write!(
            f,
            "EnvMap {{ {}x{}, hash {:016x} }}",
            self.width, self.height, self.hash
        )
    }
}

impl PartialEq for EnvMap {
    fn eq(&self, o: &EnvMap) -> bool {
        self.width == o.width && self.height == o.height && self.texels == o.texels
    }
}

impl EnvMap {
    /// A map from `width × height` interleaved RGB samples, rows from the
    /// zenith down. Refuses an empty or oversized image and any sample
    /// that is negative or not finite (naming the texel).
    pub fn new(width: u32, height: u32, rgb: &[f32]) -> Result<EnvMap, RenderError> {
        let n = u64::from(width) * u64::from(height);
        if n == 0 || n > MAX_TEXELS {
            return Err(RenderError::Setting(format!(
                "an environment map of {width}x{height} texels (1 to {MAX_TEXELS} allowed)"
            )));
        }
        if rgb.len() as u64 != n * 3 {
            return Err(RenderError::Setting(format!(
                "{} samples do not make a {width}x{height} RGB environment map",
                rgb.len()
            )));
        }
        let (w, h) = (width as usize, height as usize);
        let mut texels = Vec::with_capacity(w * h);
        for (i, c) in rgb.chunks_exact(3).enumerate() {
            let t = Vec3::new(c[0], c[1], c[2]);
            if !t.is_finite() || t.min_element() < 0.0 {
                return Err(RenderError::Setting(format!(
                    "environment map texel ({}, {}) is {} {} {}: radiance must be finite and not negative",
                    i % w,
                    i / w,
                    c[0],
                    c[1],
                    c[2]
                )));
            }
            texels.push(t);
        }
        let mut rows = Vec::with_capacity(h + 1);
        let mut cols = Vec::with_capacity(h * (w + 1));
        rows.push(0.0);
        let mut total = 0.0;
        for r in 0..h {
            let sin = (PI * (r as f64 + 0.5) / h as f64).sin();
            let start = cols.len();
            let mut sum = 0.0;
            cols.push(0.0);
            for t in &texels[r * w..(r + 1) * w] {
                sum += luminance(t.x as f64, t.y as f64, t.z as f64) * sin;
                cols.push(sum);
            }
            if sum > 0.0 {
                for c in &mut cols[start..] {
                    *c /= sum;
                }
            }
            total += sum;
            rows.push(total);
        }
        if total > 0.0 {
            for r in &mut rows {
                *r /= total;
            }
        }
        // FNV-1a over the size and the texels' bits, then a finaliser.
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let words = [width, height]
            .into_iter()
            .chain(rgb.iter().map(|v| v.to_bits()));
        for word in words {
            hash = (hash ^ u64::from(word)).wrapping_mul(0x0100_0000_01b3);
        }
        Ok(EnvMap {
            width,
            height,
            texels,
            rows,
            cols,
            total,
            hash: crate::sampler::mix(hash),
        })
    }

    /// Texels per row.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Whether the map is black everywhere (nothing to sample).
    pub fn is_black(&self) -> bool {
        self.total <= 0.0
    }

    /// The texel (column, row) unit `dir` looks at.
    #[inline]
    fn texel_of(&self, dir: Vec3) -> (usize, usize) {
        let phi = (dir.z as f64).atan2(dir.x as f64);
        let mut u = phi / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        let v = (dir.y as f64).clamp(-1.0, 1.0).acos() / PI;
        let c = ((u * self.width as f64) as usize).min(self.width as usize - 1);
        let r = ((v * self.height as f64) as usize).min(self.height as usize - 1);
        (c, r)
    }

    /// Radiance arriving from unit direction `dir`.
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (c, r) = self.texel_of(dir);
        self.texels[r * self.width as usize + c]
    }

    /// The density per steradian with which [`EnvMap::sample`] draws unit
    /// `dir` (0 where the map is black or at the poles).
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        self.radiance_pdf(dir).1
    }

    /// [`EnvMap::radiance`] and [`EnvMap::pdf`] of `dir` from one texel
    /// lookup.
    #[inline]
    pub fn radiance_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        let (c, r) = self.texel_of(dir);
        let radiance = self.texels[r * self.width as usize + c];
        if self.total <= 0.0 {
            return (radiance, 0.0);
        }
        let sin = (1.0 - (dir.y as f64).clamp(-1.0, 1.0).powi(2)).sqrt();
        (radiance, self.density(c, r, sin))
    }

    /// Density per steradian inside texel (c, r) at polar sine `sin`.
    #[inline]
    fn density(&self, c: usize, r: usize, sin: f64) -> f32 {
        if sin <= 0.0 {
            return 0.0;
        }
        let w = self.width as usize;
        let p_row = self.rows[r + 1] - self.rows[r];
        let row = &self.cols[r * (w + 1)..(r + 1) * (w + 1)];
        let p_texel = p_row * (row[c + 1] - row[c]);
        let texels = self.width as f64 * self.height as f64;
        (p_texel * texels / (2.0 * PI * PI * sin)) as f32
    }

    /// A direction drawn in proportion to luminance (`u`, `v` in
    /// `[0, 1)`, clamped there); `None` when the map is black or the draw
    /// lands exactly on a pole. Its radiance and density are looked up
    /// from the direction as stored (f32), so they agree bit for bit with
    /// [`EnvMap::radiance`] and [`EnvMap::pdf`] (the weights of paths that
    /// escape in the same direction).
    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> Option<EnvSample> {
        if self.total <= 0.0 {
            return None;
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let below_one = 1.0 - f64::EPSILON;
        let (r, fr) = pick(&self.rows, (u as f64).clamp(0.0, below_one));
        let row = &self.cols[r * (w + 1)..(r + 1) * (w + 1)];
        let (c, fc) = pick(row, (v as f64).clamp(0.0, below_one));
        let theta = PI * (r as f64 + fr) / h as f64;
        let phi = 2.0 * PI * (c as f64 + fc) / w as f64;
        let (sin, cos) = theta.sin_cos();
        let dir = Vec3::new(
            (sin * phi.cos()) as f32,
            cos as f32,
            (sin * phi.sin()) as f32,
        );
        let (radiance, pdf) = self.radiance_pdf(dir);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(EnvSample { dir, radiance, pdf })
    }

    /// `∫ luminance dω` over the sphere, exactly for the piecewise
    /// constant map (each texel's luminance times its solid angle).
    pub fn luminance_integral(&self) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut sum = 0.0;
        for r in 0..h {
            let c0 = (PI * r as f64 / h as f64).cos();
            let c1 = (PI * (r + 1) as f64 / h as f64).cos();
            let solid = 2.0 * PI / w as f64 * (c0 - c1);
            for t in &self.texels[r * w..(r + 1) * w] {
                sum += luminance(t.x as f64, t.y as f64, t.z as f64) * solid;
            }
        }
        sum
    }
}

/// The interval of cumulative table `cdf` (from 0 to 1) that `u` falls in,
/// skipping empty intervals, and `u`'s position inside it in `[0, 1)`.
#[inline]
fn pick(cdf: &[f64], u: f64) -> (usize, f64) {
    let last = cdf.len() - 2;
    // The last entry with cdf <= u, within [0, last].
    let i = (cdf.partition_point(|&c| c <= u).max(1) - 1).min(last);
    let width = cdf[i + 1] - cdf[i];
    let f = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON)
    } else {
        0.5
    };
    (i, f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::HashSampler;

    /// A sky: bright near the zenith, a small hot sun, a dim coloured
    /// ground.
    fn sky(w: u32, h: u32) -> EnvMap {
        let mut rgb = Vec::new();
        for r in 0..h {
            for c in 0..w {
                let t = if (r, c) == (h / 5, w / 3) {
                    [500.0, 450.0, 400.0]
                } else if r < h / 2 {
                    [0.3, 0.5, 1.0 + r as f32 * 0.01]
                } else {
                    [0.1, 0.05 * (c % 3) as f32, 0.0]
                };
                rgb.extend(t);
            }
        }
        EnvMap::new(w, h, &rgb).unwrap()
    }

    #[test]
    fn lookups_follow_the_documented_orientation() {
        let (w, h) = (8u32, 4u32);
        let mut rgb = vec![0.0f32; (w * h * 3) as usize];
        // Mark each texel with its index in the red channel.
        for i in 0..(w * h) as usize {
            rgb[i * 3] = i as f32;
        }
        let m = EnvMap::new(w, h, &rgb).unwrap();
        let at = |d: Vec3| m.radiance(d.normalize()).x as u32;
        assert_eq!(at(Vec3::Y) / w, 0, "zenith in the top row");
        assert_eq!(at(-Vec3::Y) / w, h - 1, "nadir in the bottom row");
        // Just above the horizon: row h/2 - 1; azimuth +x at column 0,
        // +z a quarter along, -x half-way, -z three quarters.
        let y = 0.05;
        assert_eq!(at(Vec3::new(1.0, y, 0.01)), (h / 2 - 1) * w);
        assert_eq!(at(Vec3::new(-0.01, y, 1.0)) % w, w / 4);
        assert_eq!(at(Vec3::new(-1.0, y, 0.01)) % w, w / 2 - 1);
        assert_eq!(at(Vec3::new(-1.0, y, -0.01)) % w, w / 2);
        assert_eq!(at(Vec3::new(0.01, y, -1.0)) % w, 3 * w / 4);
        assert_eq!(at(Vec3::new(1.0, y, -0.01)) % w, w - 1);
    }

    #[test]
    fn samples_carry_their_own_density_and_radiance() {
        let m = sky(64, 32);
        let s = HashSampler::new(3);
        for i in 0..20_000u64 {
            let mut p = s.pixel(0, 0, i);
            let (u, v) = p.next_2d();
            let Some(e) = m.sample(u, v) else { continue };
            assert!((e.dir.length() - 1.0).abs() < 1e-5);
            assert_eq!(e.radiance, m.radiance(e.dir), "sample {i}");
            assert_eq!(m.pdf(e.dir), e.pdf, "sample {i}");
            assert!(e.pdf > 0.0 && e.radiance.max_element() > 0.0);
        }
    }

    #[test]
    fn density_integrates_to_one_over_the_sphere() {
        let m = sky(32, 16);
        // Midpoint rule on a grid much finer than the texels.
        let (nt, np) = (2048usize, 1024usize);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let theta = PI * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let d = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    theta.cos() as f32,
                    (theta.sin() * phi.sin()) as f32,
                );
                sum += m.pdf(d) as f64 * theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
            }
        }
        assert!((sum - 1.0).abs() < 2e-3, "∫ pdf dω = {sum}");
    }

    #[test]
    fn importance_sampling_estimates_the_integral() {
        let m = sky(64, 32);
        let exact = m.luminance_integral();
        let s = HashSampler::new(11);
        let n = 100_000u64;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let mut p = s.pixel(1, 2, i);
            let (u, v) = p.next_2d();
            let x = m.sample(u, v).map_or(0.0, |e| {
                let l = e.radiance.as_dvec3();
                luminance(l.x, l.y, l.z) / e.pdf as f64
            });
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        assert!(
            (mean - exact).abs() < 4.0 * se + 1e-9 * exact,
            "{mean} vs {exact} (se {se})"
        );
        // Sampling by luminance × sin θ leaves only the sine's variation
        // within rows: the relative spread is small.
        assert!(se / exact < 2e-3, "relative standard error {}", se / exact);
    }

    #[test]
    fn black_maps_and_bad_texels() {
        let m = EnvMap::new(4, 2, &[0.0; 24]).unwrap();
        assert!(m.is_black());
        assert_eq!(m.sample(0.3, 0.7), None);
        assert_eq!(m.pdf(Vec3::Y), 0.0);
        assert_eq!(m.radiance(Vec3::X), Vec3::ZERO);
        let mut rgb = vec![1.0f32; 24];
        rgb[7] = f32::NAN;
        let e = EnvMap::new(4, 2, &rgb).unwrap_err().to_string();
        assert!(e.contains("texel (2, 0)"), "{e}");
        rgb[7] = -1.0;
        assert!(EnvMap::new(4, 2, &rgb).is_err());
        assert!(EnvMap::new(0, 2, &[]).is_err());
        assert!(EnvMap::new(4, 2, &[1.0; 23]).is_err());
    }

    #[test]
    fn one_lit_texel_is_all_that_is_drawn() {
        let (w, h) = (16u32, 8u32);
        let mut rgb = vec![0.0f32; (w * h * 3) as usize];
        let lit = (3 * w + 5) as usize;
        rgb[lit * 3 + 1] = 2.0;
        let m = EnvMap::new(w, h, &rgb).unwrap();
        let mut drawn = 0;
        for k in 0..1000 {
            let u = k as f32 / 1000.0;
            // Draws on a texel's very edge may round into its black
            // neighbour and are dropped; all others find the lit texel.
            if let Some(e) = m.sample(u, 1.0 - u - 1e-3) {
                assert_eq!(e.radiance, Vec3::new(0.0, 2.0, 0.0));
                drawn += 1;
            }
        }
        assert!(drawn >= 995, "{drawn} of 1000 drawn");
        // Draws outside [0, 1) are clamped into the table.
        for (u, v) in [(-1.0, 0.5), (0.5, 2.0), (f32::NAN, 0.3), (1.0, 1.0)] {
            if let Some(e) = m.sample(u, v) {
                assert_eq!(e.radiance, Vec3::new(0.0, 2.0, 0.0));
            }
        }
    }

    #[test]
    fn equal_maps_share_a_debug_text_and_differ_from_others() {
        let a = sky(8, 4);
        let b = sky(8, 4);
        let c = sky(8, 8);
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_ne!(format!("{a:?}"), format!("{c:?}"));
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
