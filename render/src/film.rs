//! The film: per-pixel accumulation of what rays bring back, and its
//! resolution into a displayable frame.
//!
//! Samples are summed per pixel in f64 (a ray caster adds one per pixel; a
//! Monte Carlo integrator adds many, always in sample-index order, so the
//! sums do not depend on the thread count). Resolving divides by the
//! count, maps the mode's scalar to grey where the mode is a projection
//! (MIP, MinIP, X-ray), and composites over the background. The result
//! stays linear light; [`Frame::srgb8`] encodes it for 8-bit output.

use crate::integrator::RayResult;
use glam::Vec3;
use std::ops::Range;

/// Which per-pixel fields of a film travel between processes
/// ([`Film::encode_rows`]): the ray count and sample count always, the
/// others when the composite rule reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fields {
    /// Premultiplied colour, as 4 × f32: exact for films of at most one
    /// ray per pixel (the ray caster's: each channel is one f32 added to
    /// zero); a path tracer's sums would be rounded.
    pub colour: bool,
    /// The mode's value (f64: an X-ray sum can pass f32's range).
    pub value: bool,
    /// The depth (f32).
    pub depth: bool,
}

impl Fields {
    /// Every field.
    pub const ALL: Fields = Fields {
        colour: true,
        value: true,
        depth: true,
    };

    /// The fields `how` reads (the others stay empty after compositing).
    pub fn for_composite(how: Composite) -> Fields {
        let (colour, value, depth) = match how {
            Composite::Over => (true, false, false),
            Composite::FirstHit => (true, true, true),
            Composite::Max | Composite::Min => (false, true, true),
            Composite::Sum => (false, true, false),
        };
        Fields {
            colour,
            value,
            depth,
        }
    }

    /// Bytes per pixel: ray count and sample count (u32 each), and the
    /// chosen fields.
    pub fn pixel_bytes(self) -> usize {
        8 + 16 * self.colour as usize + 8 * self.value as usize + 4 * self.depth as usize
    }
}

/// Counts and times for one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Rays traced that met the volume (rays of culled pixel blocks are
    /// not traced).
    pub rays: u64,
    /// Pixel blocks left untraced because their rays could meet no cell
    /// the skipping rule keeps (DVR with skipping; see
    /// [`crate::accel::cull`]).
    pub culled_blocks: u64,
    /// Samples taken (interpolations of the volume, bisection included).
    pub samples: u64,
    /// Jumps over empty cells.
    pub skips: u64,
    /// Seconds spent rendering.
    pub render_s: f64,
    /// What the effects did (zero when they are off).
    pub effects: crate::effects::EffectStats,
}

/// How a pixel's accumulated result becomes a colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Display {
    /// The integrator's own colour (DVR, iso).
    Colour,
    /// The mode's scalar as grey from `lo` (black) to `hi` (white): MIP
    /// and MinIP over the volume's value range.
    Grey {
        /// Value shown black.
        lo: f32,
        /// Value shown white.
        hi: f32,
    },
    /// The scalar as grey from 0 to the frame's largest finite value
    /// (X-ray).
    GreyToLargest,
}

/// How the films of consecutive shares of the same rays combine, front to
/// back ([`Film::composite`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Composite {
    /// Premultiplied colour, front over back (DVR).
    Over,
    /// The front-most share that hit (iso-surfaces).
    FirstHit,
    /// The largest value, the front-most on ties (MIP).
    Max,
    /// The smallest value, the front-most on ties (MinIP).
    Min,
    /// The sum of the values (X-ray).
    Sum,
}

/// One pixel of a film.
#[derive(Clone, Copy, Debug)]
struct Px {
    rgba: [f64; 4],
    count: u32,
    value: f64,
    depth: f32,
    samples: u32,
}

impl Px {
    /// Nothing yet: what front-to-back joining starts from.
    const START: Px = Px {
        rgba: [0.0; 4],
        count: 0,
        value: f64::NAN,
        depth: f32::NAN,
        samples: 0,
    };

    /// Join `f`, the share behind what was joined so far, by `how`.
    #[inline]
    fn join(&mut self, f: &Px, how: Composite) {
        self.count = self.count.max(f.count);
        self.samples += f.samples;
        let n = f.count.max(1) as f64;
        let c = f.rgba.map(|c| c / n);
        let v = f.value;
        match how {
            Composite::Over => {
                let keep = 1.0 - self.rgba[3];
                for (a, b) in self.rgba.iter_mut().zip(c) {
                    *a += keep * b;
                }
            }
            Composite::FirstHit => {
                if self.value.is_nan() && !v.is_nan() {
                    (self.rgba, self.value, self.depth) = (c, v, f.depth);
                }
            }
            Composite::Max | Composite::Min => {
                let beats = match how {
                    Composite::Max => v > self.value,
                    _ => v < self.value,
                };
                if !v.is_nan() && (self.value.is_nan() || beats) {
                    (self.value, self.depth) = (v, f.depth);
                }
            }
            Composite::Sum => {
                if !v.is_nan() {
                    self.value = if self.value.is_nan() {
                        v
                    } else {
                        self.value + v
                    };
                }
            }
        }
    }

    /// Write the record of `fields` (see [`Film::encode_rows`]).
    #[inline]
    fn write(&self, rec: &mut [u8], fields: Fields) {
        rec[0..4].copy_from_slice(&self.count.to_le_bytes());
        rec[4..8].copy_from_slice(&self.samples.to_le_bytes());
        let mut at = 8;
        if fields.colour {
            for c in self.rgba {
                rec[at..at + 4].copy_from_slice(&(c as f32).to_le_bytes());
                at += 4;
            }
        }
        if fields.value {
            rec[at..at + 8].copy_from_slice(&self.value.to_le_bytes());
            at += 8;
        }
        if fields.depth {
            rec[at..at + 4].copy_from_slice(&self.depth.to_le_bytes());
        }
    }

    /// Read a record of `fields`; the fields left out are empty.
    #[inline]
    fn read(rec: &[u8], fields: Fields) -> Px {
        let u32_at =
            |at: usize| u32::from_le_bytes([rec[at], rec[at + 1], rec[at + 2], rec[at + 3]]);
        let mut px = Px {
            count: u32_at(0),
            samples: u32_at(4),
            ..Px::START
        };
        let mut at = 8;
        if fields.colour {
            px.rgba = std::array::from_fn(|c| f64::from(f32::from_bits(u32_at(at + 4 * c))));
            at += 16;
        }
        if fields.value {
            px.value = f64::from_bits(u64::from(u32_at(at)) | u64::from(u32_at(at + 4)) << 32);
            at += 8;
        }
        if fields.depth {
            px.depth = f32::from_bits(u32_at(at));
        }
        px
    }
}

/// Per-pixel sums (see the module docs).
#[derive(Clone, Debug)]
pub struct Film {
    width: u32,
    height: u32,
    rgba: Vec<[f64; 4]>,
    count: Vec<u32>,
    value: Vec<f64>,
    depth: Vec<f32>,
    samples: Vec<u32>,
    stats: FrameStats,
}

impl Film {
    /// An empty film of `width × height` pixels.
    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            rgba: vec![[0.0; 4]; n],
            count: vec![0; n],
            value: vec![f64::NAN; n],
            depth: vec![f32::NAN; n],
            samples: vec![0; n],
            stats: FrameStats::default(),
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Add one ray's result to pixel `(x, y)` (row 0 at the top). The
    /// mode's scalar and depth are the last ray's.
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, r: &RayResult) {
        let p = (y * self.width + x) as usize;
        for (s, c) in self.rgba[p].iter_mut().zip(r.rgba) {
            *s += c as f64;
        }
        self.count[p] += 1;
        self.value[p] = r.value;
        self.depth[p] = r.depth;
        self.samples[p] += r.samples;
        self.stats.rays += (r.samples > 0 || r.skips > 0) as u64;
        self.stats.samples += r.samples as u64;
        self.stats.skips += r.skips as u64;
        self.stats.effects.shadow_rays += r.effects.shadow_rays as u64;
        self.stats.effects.shadow_samples += r.effects.shadow_samples;
        self.stats.effects.ao_rays += r.effects.ao_rays as u64;
        self.stats.effects.ao_samples += r.effects.ao_samples;
    }

    /// The film of whole rays from the films of their consecutive shares
    /// (see [`crate::distributed`]), given front to back, combined per
    /// pixel by `how`. Totals add up; the render time is the slowest
    /// share's.
    pub fn composite(front_to_back: &[&Film], how: Composite) -> Film {
        let Some(first) = front_to_back.first() else {
            return Film::new(0, 0);
        };
        let mut out = Film::new(first.width, first.height);
        for f in front_to_back {
            let s = &mut out.stats;
            s.rays += f.stats.rays;
            s.samples += f.stats.samples;
            s.skips += f.stats.skips;
            s.culled_blocks += f.stats.culled_blocks;
            s.render_s = s.render_s.max(f.stats.render_s);
        }
        for p in 0..out.rgba.len() {
            let mut acc = Px::START;
            for f in front_to_back {
                acc.join(&f.px(p), how);
            }
            out.set(p, &acc);
        }
        out
    }

    /// Append the pixels of rows `rows` to `out`, one record of
    /// [`Fields::pixel_bytes`] little-endian bytes per pixel (ray count,
    /// sample count, then the chosen fields; the totals are not
    /// included): how a share's film travels between processes. Records
    /// of consecutive rows concatenated are the records of those rows.
    pub fn encode_rows(&self, rows: Range<u32>, fields: Fields, out: &mut Vec<u8>) {
        let w = self.width as usize;
        let px = (rows.start as usize * w).min(self.count.len())
            ..(rows.end as usize * w).min(self.count.len());
        let size = fields.pixel_bytes();
        let start = out.len();
        out.resize(start + px.len() * size, 0);
        for (rec, p) in out[start..].chunks_exact_mut(size).zip(px) {
            self.px(p).write(rec, fields);
        }
    }

    /// The film of `width × rows` pixels that [`Film::encode_rows`] wrote
    /// as `bytes` with `fields` (the fields left out are empty), or `None`
    /// when the length is not that of such a film.
    pub fn decode_rows(width: u32, rows: u32, fields: Fields, bytes: &[u8]) -> Option<Film> {
        let n = (width as usize).checked_mul(rows as usize)?;
        let size = fields.pixel_bytes();
        if bytes.len() != n.checked_mul(size)? {
            return None;
        }
        let mut film = Film::new(width, rows);
        for (p, rec) in bytes.chunks_exact(size).enumerate() {
            film.set(p, &Px::read(rec, fields));
        }
        Some(film)
    }

    /// Composite the records of the same pixels from several films
    /// ([`Film::encode_rows`] with `fields`), given front to back, into
    /// records appended to `out`: [`Film::composite`] without the films
    /// (no film is built for what only passes through). `None` when the
    /// parts differ in length or are not whole records.
    pub fn composite_records(
        front_to_back: &[&[u8]],
        fields: Fields,
        how: Composite,
        out: &mut Vec<u8>,
    ) -> Option<()> {
        let size = fields.pixel_bytes();
        let len = front_to_back.first().map_or(0, |p| p.len());
        if !len.is_multiple_of(size) || front_to_back.iter().any(|p| p.len() != len) {
            return None;
        }
        let start = out.len();
        out.resize(start + len, 0);
        for (i, rec) in out[start..].chunks_exact_mut(size).enumerate() {
            let mut acc = Px::START;
            for part in front_to_back {
                acc.join(&Px::read(&part[i * size..][..size], fields), how);
            }
            acc.write(rec, fields);
        }
        Some(())
    }

    /// Pixel `p`'s fields.
    #[inline]
    fn px(&self, p: usize) -> Px {
        Px {
            rgba: self.rgba[p],
            count: self.count[p],
            value: self.value[p],
            depth: self.depth[p],
            samples: self.samples[p],
        }
    }

    /// Set pixel `p`'s fields.
    #[inline]
    fn set(&mut self, p: usize, px: &Px) {
        self.rgba[p] = px.rgba;
        self.count[p] = px.count;
        self.value[p] = px.value;
        self.depth[p] = px.depth;
        self.samples[p] = px.samples;
    }

    /// Replace the totals (a data-parallel frame's are the ranks').
    pub fn set_stats(&mut self, stats: FrameStats) {
        self.stats = stats;
    }

    /// The totals so far.
    pub fn stats(&self) -> FrameStats {
        self.stats
    }

    /// Add what building the frame's light grids and occlusion grid cost
    /// (their build time counts as render time: it is spent once per
    /// frame); and the AO field's, which is reported beside the frame's
    /// time (it is built once per transfer function).
    pub fn add_grid_stats(&mut self, s: &crate::effects::EffectStats) {
        self.stats.render_s += s.shadow_grid_s + s.ao_grid_s;
        let e = &mut self.stats.effects;
        e.shadow_grids += s.shadow_grids;
        e.shadow_grid_s += s.shadow_grid_s;
        e.shadow_grid_bytes += s.shadow_grid_bytes;
        e.shadow_grid_samples += s.shadow_grid_samples;
        e.ao_grid_s += s.ao_grid_s;
        e.ao_grid_bytes += s.ao_grid_bytes;
        e.ao_grid_samples += s.ao_grid_samples;
        e.ao_field_s += s.ao_field_s;
        e.ao_field_bytes += s.ao_field_bytes;
        e.ao_field_samples += s.ao_field_samples;
    }

    /// Record the time spent rendering into the film.
    pub fn set_render_seconds(&mut self, s: f64) {
        self.stats.render_s = s;
    }

    /// Record the pixel blocks culled before tracing.
    pub fn set_culled_blocks(&mut self, n: u64) {
        self.stats.culled_blocks = n;
    }

    /// The frame: mean colour per pixel, mapped by `display`, over the
    /// linear `background`.
    pub fn resolve(&self, display: Display, background: Vec3) -> Frame {
        let mut rgba: Vec<[f32; 4]> = self
            .rgba
            .iter()
            .zip(&self.count)
            .map(|(s, &n)| {
                if n == 0 {
                    [0.0; 4]
                } else {
                    s.map(|c| (c / n as f64) as f32)
                }
            })
            .collect();
        let grey = |g: f32| [g, g, g, 1.0];
        match display {
            Display::Colour => {}
            Display::Grey { lo, hi } => {
                let span = hi - lo;
                if lo.is_finite() && span.is_finite() {
                    for (px, &v) in rgba.iter_mut().zip(&self.value) {
                        if !v.is_nan() {
                            let v = v as f32;
                            let g = if span > 0.0 { (v - lo) / span } else { 1.0 };
                            *px = grey(g.clamp(0.0, 1.0));
                        }
                    }
                } else {
                    // A range with infinities, or one whose span overflows
                    // f32: map in f64 over its finite part (±inf go to the
                    // ends), never computing inf − inf.
                    let lo = (lo as f64).max(-f32::MAX as f64);
                    let hi = (hi as f64).min(f32::MAX as f64);
                    let span = hi - lo;
                    for (px, &v) in rgba.iter_mut().zip(&self.value) {
                        if !v.is_nan() {
                            let g = if span > 0.0 { (v - lo) / span } else { 1.0 };
                            *px = grey(g.clamp(0.0, 1.0) as f32);
                        }
                    }
                }
            }
            Display::GreyToLargest => {
                let top = self
                    .value
                    .iter()
                    .cloned()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, f64::max);
                let top32 = top as f32;
                for (px, &v) in rgba.iter_mut().zip(&self.value) {
                    if v.is_finite() {
                        // In f32 where every value fits (as before values
                        // could pass f32's range), in f64 otherwise.
                        let g = if top32.is_finite() {
                            if top32 > 0.0 {
                                v as f32 / top32
                            } else {
                                0.0
                            }
                        } else {
                            (v / top) as f32
                        };
                        *px = grey(g.clamp(0.0, 1.0));
                    }
                }
            }
        }
        for px in rgba.iter_mut() {
            let a = px[3];
            for c in 0..3 {
                px[c] += (1.0 - a) * background[c];
            }
        }
        Frame {
            width: self.width,
            height: self.height,
            rgba,
            value: self.value.clone(),
            depth: self.depth.clone(),
            samples: self.samples.clone(),
            stats: self.stats,
        }
    }
}

/// A rendered frame: per-pixel results, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB composited over the background, and coverage alpha.
    pub rgba: Vec<[f32; 4]>,
    /// The mode's scalar per pixel (see [`RayResult::value`]).
    pub value: Vec<f64>,
    /// Ray parameter of the iso hit or MIP extreme (NaN when none).
    pub depth: Vec<f32>,
    /// Samples taken per pixel.
    pub samples: Vec<u32>,
    /// Totals.
    pub stats: FrameStats,
}

impl Frame {
    /// 8-bit sRGB pixels, rows from the top: RGB, or RGBA with the
    /// coverage alpha when `alpha`.
    pub fn srgb8(&self, alpha: bool) -> Vec<u8> {
        let channels = if alpha { 4 } else { 3 };
        let mut data = Vec::with_capacity(self.rgba.len() * channels);
        for px in &self.rgba {
            data.extend([srgb8(px[0]), srgb8(px[1]), srgb8(px[2])]);
            if alpha {
                data.push((px[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
            }
        }
        data
    }

    /// Linear RGB per pixel, rows from the top (for float image files).
    pub fn linear_rgb(&self) -> Vec<f32> {
        self.rgba
            .iter()
            .flat_map(|px| [px[0], px[1], px[2]])
            .collect()
    }

    /// Samples per pixel as floats (for a heat map).
    pub fn sample_counts(&self) -> Vec<f32> {
        self.samples.iter().map(|&s| s as f32).collect()
    }
}

/// Linear light to an 8-bit sRGB code (clamped; NaN gives 0).
pub fn srgb8(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_codes_at_the_ends_and_the_middle() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(2.0), 255);
        assert_eq!(srgb8(-1.0), 0);
        assert_eq!(srgb8(f32::NAN), 0);
        // Linear 0.216 is sRGB 0.502.
        assert_eq!(srgb8(0.2159), 128);
    }

    #[test]
    fn grey_display_of_infinite_and_overflowing_ranges_is_finite() {
        let r = |v: f64| RayResult {
            value: v,
            samples: 1,
            ..RayResult::empty()
        };
        let values = [f64::INFINITY, f64::NEG_INFINITY, 3.4e38, -3.4e38, 0.0];
        for (lo, hi) in [
            (f32::NEG_INFINITY, f32::INFINITY),
            (-3.4e38, 3.4e38),
            (0.0, f32::INFINITY),
            (f32::NEG_INFINITY, 0.0),
        ] {
            let mut f = Film::new(values.len() as u32, 1);
            for (x, &v) in values.iter().enumerate() {
                f.add(x as u32, 0, &r(v));
            }
            let fr = f.resolve(Display::Grey { lo, hi }, Vec3::ZERO);
            let g: Vec<f32> = fr.rgba.iter().map(|p| p[0]).collect();
            assert!(g.iter().all(|v| v.is_finite()), "{lo}..{hi}: {g:?}");
            assert_eq!((g[0], g[1]), (1.0, 0.0), "{lo}..{hi}");
            assert!(g[2] >= g[4] && g[4] >= g[3], "{lo}..{hi}: {g:?}");
        }
        // Largest-value grey past f32's range (an X-ray sum).
        let mut f = Film::new(2, 1);
        f.add(0, 0, &r(1e39));
        f.add(1, 0, &r(5e38));
        let fr = f.resolve(Display::GreyToLargest, Vec3::ZERO);
        assert_eq!((fr.rgba[0][0], fr.rgba[1][0]), (1.0, 0.5));
    }

    #[test]
    fn many_samples_average_and_one_sample_is_exact() {
        let mut f = Film::new(2, 1);
        let r = |v: f32| RayResult {
            rgba: [v, v, v, 1.0],
            samples: 1,
            ..RayResult::empty()
        };
        f.add(0, 0, &r(0.1));
        for i in 0..1000 {
            f.add(1, 0, &r(if i % 2 == 0 { 0.25 } else { 0.75 }));
        }
        let fr = f.resolve(Display::Colour, Vec3::ZERO);
        assert_eq!(fr.rgba[0][0], 0.1);
        assert_eq!(fr.rgba[1][0], 0.5);
        assert_eq!(fr.samples, vec![1, 1000]);
        assert_eq!(fr.stats.rays, 1001);
    }

    #[test]
    fn rows_travel_as_bytes_and_come_back_bit_for_bit() {
        let (w, h) = (7u32, 5u32);
        let mut f = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                if (x + y) % 3 == 0 {
                    continue; // some pixels stay empty (NaN value and depth)
                }
                let v = (x * 10 + y) as f32 * 0.37;
                f.add(
                    x,
                    y,
                    &RayResult {
                        rgba: [v, v * 0.5, 0.1, 0.9],
                        value: f64::from(v) * 1e-3,
                        depth: v + 1.0,
                        samples: x + y,
                        ..RayResult::empty()
                    },
                );
            }
        }
        let fields = Fields::ALL;
        let mut all = Vec::new();
        for rows in [0..2, 2..2, 2..5] {
            let mut bytes = Vec::new();
            f.encode_rows(rows.clone(), fields, &mut bytes);
            let n = (rows.len() as u32 * w) as usize;
            assert_eq!(bytes.len(), n * fields.pixel_bytes());
            assert!(Film::decode_rows(w, rows.len() as u32 + 1, fields, &bytes).is_none());
            all.extend_from_slice(&bytes);
        }
        let back = Film::decode_rows(w, h, fields, &all).unwrap();
        let bits = |f: &Film| -> Vec<u64> {
            f.rgba
                .iter()
                .flat_map(|p| p.map(f64::to_bits))
                .chain(f.value.iter().map(|v| v.to_bits()))
                .chain(f.depth.iter().map(|d| u64::from(d.to_bits())))
                .chain(f.count.iter().chain(&f.samples).map(|&c| u64::from(c)))
                .collect()
        };
        assert_eq!((back.width, back.height), (w, h));
        assert_eq!(bits(&back), bits(&f));
        // Only what a composite reads: the rest comes back empty, and the
        // composite of the decoded film is the composite of the film.
        for how in [
            Composite::Over,
            Composite::FirstHit,
            Composite::Max,
            Composite::Min,
            Composite::Sum,
        ] {
            let fields = Fields::for_composite(how);
            let mut bytes = Vec::new();
            f.encode_rows(0..h, fields, &mut bytes);
            assert_eq!(bytes.len(), (w * h) as usize * fields.pixel_bytes());
            let g = Film::decode_rows(w, h, fields, &bytes).unwrap();
            let (a, b) = (Film::composite(&[&f], how), Film::composite(&[&g], how));
            assert_eq!(bits(&a), bits(&b), "{how:?}");
            // Compositing records is compositing films: a film over itself.
            let mut joined = Vec::new();
            Film::composite_records(&[&bytes, &bytes], fields, how, &mut joined).unwrap();
            let from_records = Film::decode_rows(w, h, fields, &joined).unwrap();
            let mut again = Vec::new();
            Film::composite(&[&g, &g], how).encode_rows(0..h, fields, &mut again);
            let from_films = Film::decode_rows(w, h, fields, &again).unwrap();
            assert_eq!(bits(&from_records), bits(&from_films), "{how:?}");
            assert!(
                Film::composite_records(&[&bytes, &bytes[1..]], fields, how, &mut joined).is_none()
            );
        }
    }
}
