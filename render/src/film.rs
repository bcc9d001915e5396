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
    /// Wall seconds of the frame: its set-up (classifier tables, skipping
    /// flags, culling, light and occlusion grids) and its rays; not the
    /// AO field, built once per transfer function (its own figure).
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

    /// Whether the pixel holds nothing a composite or a frame reads: no
    /// samples, no colour, no value and no depth (what an untraced or
    /// empty ray leaves, whatever its ray count).
    #[inline]
    fn carries_nothing(&self) -> bool {
        self.samples == 0
            && self.rgba.iter().all(|c| c.to_bits() == 0)
            && self.value.is_nan()
            && self.depth.is_nan()
    }

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

/// A stream of pixel records ([`Film::encode_rows`]), checked.
struct Stream<'a> {
    /// One bit per pixel: whether it has a record.
    bits: &'a [u8],
    /// The records, in pixel order.
    records: &'a [u8],
    /// Bytes per record.
    size: usize,
}

impl<'a> Stream<'a> {
    /// `bytes` as a stream of `pixels` pixels of `fields`, or `None` when
    /// its length is not that of the records its bitmap announces, or a
    /// padding bit is set.
    fn parse(bytes: &'a [u8], pixels: usize, fields: Fields) -> Option<Stream<'a>> {
        let (bits, records) = bytes.split_at_checked(pixels.div_ceil(8))?;
        let pad = pixels % 8;
        if pad != 0 && bits.last().is_some_and(|&b| b >> pad != 0) {
            return None;
        }
        let present: usize = bits.iter().map(|b| b.count_ones() as usize).sum();
        let size = fields.pixel_bytes();
        (present.checked_mul(size)? == records.len()).then_some(Stream {
            bits,
            records,
            size,
        })
    }
}

/// The indices of the set bits of `bits` (least significant bit first),
/// in order.
fn ones(bits: &[u8]) -> impl Iterator<Item = usize> + '_ {
    bits.iter().enumerate().flat_map(|(i, &byte)| {
        let mut b = byte;
        std::iter::from_fn(move || {
            (b != 0).then(|| {
                let bit = b.trailing_zeros() as usize;
                b &= b - 1;
                i * 8 + bit
            })
        })
    })
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

    /// A film of `width × height` pixels, each of which has had one ray
    /// that met nothing (what [`Film::add`] of an empty result to every
    /// pixel of a new film makes): a ray caster's film before the rays
    /// that meet something are put in ([`Film::put_ray`]).
    pub fn one_empty_ray_each(width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        film.count.fill(1);
        film
    }

    /// Put the result of pixel `(x, y)`'s one ray into a film from
    /// [`Film::one_empty_ray_each`]: the pixel becomes what [`Film::add`]
    /// of `r` to a new film's pixel makes (the ray is not counted twice).
    #[inline]
    pub fn put_ray(&mut self, x: u32, y: u32, r: &RayResult) {
        let p = (y * self.width + x) as usize;
        self.count[p] = 0;
        self.add(x, y, r);
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

    /// Append the pixels of rows `rows` to `out` as one stream: how a
    /// share's film travels between processes. The stream is a bitmap of
    /// one bit per pixel (row order, least significant bit first, padded
    /// to a byte) saying which pixels carry anything, then one record of
    /// [`Fields::pixel_bytes`] little-endian bytes per such pixel (ray
    /// count, sample count, then the chosen fields; the totals are not
    /// included). A pixel that carries nothing (no samples, no colour, no
    /// value, no depth) is only its bit: it comes back as a pixel no ray
    /// reached, which resolves to the same frame and composites to the
    /// same pixel. Most of a share's pixels are such, so the stream is
    /// mostly the records of the pixels that matter.
    pub fn encode_rows(&self, rows: Range<u32>, fields: Fields, out: &mut Vec<u8>) {
        let w = self.width as usize;
        let px = (rows.start as usize * w).min(self.count.len())
            ..(rows.end as usize * w).min(self.count.len());
        let size = fields.pixel_bytes();
        let bits = out.len();
        out.resize(bits + px.len().div_ceil(8), 0);
        for (i, p) in px.enumerate() {
            let px = self.px(p);
            if px.carries_nothing() {
                continue;
            }
            out[bits + i / 8] |= 1 << (i % 8);
            let at = out.len();
            out.resize(at + size, 0);
            px.write(&mut out[at..], fields);
        }
    }

    /// Put the pixels of rows `rows` that a stream [`Film::encode_rows`]
    /// wrote with `fields` carries into this film, whose rows `rows` are
    /// still as [`Film::new`] made them (the pixels the stream leaves out
    /// stay so; the fields left out come back empty). `None`, with the
    /// film unchanged, when the rows are not the film's or the bytes are
    /// not such a stream of that many pixels.
    pub fn decode_rows(&mut self, rows: Range<u32>, fields: Fields, bytes: &[u8]) -> Option<()> {
        if rows.start > rows.end || rows.end > self.height {
            return None;
        }
        let w = self.width as usize;
        let first = rows.start as usize * w;
        let stream = Stream::parse(bytes, rows.len() * w, fields)?;
        for (i, rec) in ones(stream.bits).zip(stream.records.chunks_exact(stream.size)) {
            debug_assert!(self.px(first + i).carries_nothing(), "rows not empty");
            self.set(first + i, &Px::read(rec, fields));
        }
        Some(())
    }

    /// Composite the streams of the same `pixels` pixels from several
    /// films ([`Film::encode_rows`] with `fields`), given front to back,
    /// into one stream appended to `out`: [`Film::composite`] without the
    /// films (no film is built for what only passes through). `None` when
    /// a part is not such a stream.
    pub fn composite_records(
        front_to_back: &[&[u8]],
        pixels: usize,
        fields: Fields,
        how: Composite,
        out: &mut Vec<u8>,
    ) -> Option<()> {
        let size = fields.pixel_bytes();
        let streams = front_to_back
            .iter()
            .map(|b| Stream::parse(b, pixels, fields))
            .collect::<Option<Vec<_>>>()?;
        // Per part, the next record to read.
        let mut next = vec![0usize; streams.len()];
        let bits = out.len();
        out.resize(bits + pixels.div_ceil(8), 0);
        for byte in 0..pixels.div_ceil(8) {
            let mut any = streams.iter().fold(0u8, |a, s| a | s.bits[byte]);
            while any != 0 {
                let bit = any.trailing_zeros();
                any &= any - 1;
                let mut acc = Px::START;
                for (s, at) in streams.iter().zip(&mut next) {
                    if s.bits[byte] >> bit & 1 == 1 {
                        acc.join(&Px::read(&s.records[*at * size..][..size], fields), how);
                        *at += 1;
                    }
                }
                if acc.carries_nothing() {
                    continue;
                }
                out[bits + byte] |= 1 << bit;
                let at = out.len();
                out.resize(at + size, 0);
                acc.write(&mut out[at..], fields);
            }
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
    /// (their build time is part of the frame's wall time: they are built
    /// once per frame); and the AO field's, which is reported beside the
    /// frame's time (it is built once per transfer function).
    pub fn add_grid_stats(&mut self, s: &crate::effects::EffectStats) {
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
        let mut back = Film::new(w, h);
        for rows in [0..2, 2..2, 2..5] {
            let mut bytes = Vec::new();
            f.encode_rows(rows.clone(), fields, &mut bytes);
            let n = rows.len() * w as usize;
            let present = (rows.start..rows.end)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| (x + y) % 3 != 0)
                .count();
            assert_eq!(bytes.len(), n.div_ceil(8) + present * fields.pixel_bytes());
            // The wrong number of rows, a record short, a stray bit.
            let mut g = Film::new(w, h);
            let longer = rows.start..rows.end + 1;
            assert!(g.decode_rows(longer, fields, &bytes).is_none());
            if present > 0 {
                let short = &bytes[..bytes.len() - 1];
                assert!(g.decode_rows(rows.clone(), fields, short).is_none());
            }
            if !n.is_multiple_of(8) {
                let mut stray = bytes.clone();
                stray[n.div_ceil(8) - 1] |= 0x80;
                assert!(g.decode_rows(rows.clone(), fields, &stray).is_none());
            }
            back.decode_rows(rows, fields, &bytes).unwrap();
        }
        assert!(back.decode_rows(4..6, fields, &[]).is_none());
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
            let n = (w * h) as usize;
            let mut bytes = Vec::new();
            f.encode_rows(0..h, fields, &mut bytes);
            let mut g = Film::new(w, h);
            g.decode_rows(0..h, fields, &bytes).unwrap();
            let (a, b) = (Film::composite(&[&f], how), Film::composite(&[&g], how));
            assert_eq!(bits(&a), bits(&b), "{how:?}");
            // Compositing records is compositing films: a film over itself.
            let mut joined = Vec::new();
            Film::composite_records(&[&bytes, &bytes], n, fields, how, &mut joined).unwrap();
            let mut from_records = Film::new(w, h);
            from_records.decode_rows(0..h, fields, &joined).unwrap();
            let mut again = Vec::new();
            Film::composite(&[&g, &g], how).encode_rows(0..h, fields, &mut again);
            assert_eq!(joined, again, "{how:?}");
            let cut = &bytes[..bytes.len() - 1];
            assert!(Film::composite_records(&[&bytes, cut], n, fields, how, &mut joined).is_none());
            assert!(
                Film::composite_records(&[&bytes, &bytes], n + 8, fields, how, &mut joined)
                    .is_none()
            );
        }
    }

    /// Putting the rays that met something into a film of empty rays is
    /// adding every pixel's one ray to a new film.
    #[test]
    fn putting_rays_into_empty_rays_is_adding_every_ray() {
        let r = |x: u32| RayResult {
            rgba: [-0.0, 0.25 * x as f32, 0.5, 0.75],
            value: f64::from(x),
            depth: 2.0,
            samples: 3 + x,
            skips: 1,
            ..RayResult::empty()
        };
        let (mut added, mut put) = (Film::new(5, 2), Film::one_empty_ray_each(5, 2));
        for y in 0..2 {
            for x in 0..5 {
                let met = (x + y) % 2 == 0;
                added.add(x, y, &if met { r(x) } else { RayResult::empty() });
                if met {
                    put.put_ray(x, y, &r(x));
                }
            }
        }
        let all = |f: &Film| {
            let bits: Vec<u64> = f
                .rgba
                .iter()
                .flat_map(|p| p.map(f64::to_bits))
                .chain(f.value.iter().map(|v| v.to_bits()))
                .chain(f.depth.iter().map(|d| u64::from(d.to_bits())))
                .chain(f.count.iter().chain(&f.samples).map(|&c| u64::from(c)))
                .collect();
            (bits, f.stats)
        };
        assert_eq!(all(&put), all(&added));
    }

    /// A pixel whose ray brought nothing travels as its bit alone and
    /// resolves, and composites, as it was.
    #[test]
    fn empty_rays_travel_as_bits() {
        let mut f = Film::new(16, 2);
        for y in 0..2 {
            for x in 0..16 {
                let r = if x == 5 && y == 1 {
                    RayResult {
                        rgba: [0.5, 0.25, 0.0, 0.75],
                        value: 3.0,
                        depth: 2.0,
                        samples: 4,
                        ..RayResult::empty()
                    }
                } else {
                    RayResult::empty()
                };
                f.add(x, y, &r);
            }
        }
        let fields = Fields::ALL;
        let mut bytes = Vec::new();
        f.encode_rows(0..2, fields, &mut bytes);
        assert_eq!(bytes.len(), 4 + fields.pixel_bytes());
        let mut g = Film::new(16, 2);
        g.decode_rows(0..2, fields, &bytes).unwrap();
        let frame = |f: &Film| {
            let r = f.resolve(Display::Colour, Vec3::new(0.1, 0.2, 0.3));
            (r.rgba, r.samples)
        };
        assert_eq!(frame(&g), frame(&f));
        for how in [Composite::Over, Composite::Max, Composite::Sum] {
            let (a, b) = (
                Film::composite(&[&f, &f], how),
                Film::composite(&[&g, &g], how),
            );
            let show = |x: &Film| {
                x.resolve(Display::Grey { lo: 0.0, hi: 9.0 }, Vec3::ZERO)
                    .rgba
            };
            assert_eq!(show(&a), show(&b), "{how:?}");
        }
    }
}
