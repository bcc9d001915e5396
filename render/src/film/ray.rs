//! The film of the ray-casting modes (DVR, MIP/MinIP, X-ray, iso): what
//! each pixel's ray brings back, and its resolution into a displayable
//! frame.
//!
//! A pixel holds its ray's result with sums in f64 and a ray count
//! ([`Film::put_ray`]: one ray per pixel; [`Film::add`] sums more, in the
//! order given, so the sums do not depend on the thread count; a
//! data-parallel frame joins its ranks' films front to back,
//! [`crate::distributed`]). Resolving divides by the count, maps the mode's
//! scalar to grey where the mode is a projection (MIP, MinIP, X-ray), and
//! composites over the background. The result stays linear light;
//! [`Frame::srgb8`] encodes it for 8-bit output. The path tracer adds its
//! samples to a film of its own ([`super::path`]).

use crate::trace::RayResult;
use glam::Vec3;

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
    /// Seconds building the DVR classifier's tables, and with adaptive
    /// steps the cells' strides (part of `render_s`): what a change of
    /// transfer function or step costs.
    pub table_s: f64,
    /// Their memory, bytes.
    pub table_bytes: u64,
    /// Wall seconds of the frame: its set-up (classifier tables, skipping
    /// flags, culling, light and occlusion grids) and its rays; not the
    /// AO field, built once per transfer function (its own figure).
    pub render_s: f64,
    /// What the effects did (zero when they are off).
    pub effects: EffectStats,
}

/// What the effects did in a frame (all zero when they are off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EffectStats {
    /// Shadow rays marched.
    pub shadow_rays: u64,
    /// Samples those shadow rays took.
    pub shadow_samples: u64,
    /// Light grids built.
    pub shadow_grids: u32,
    /// Seconds spent building them.
    pub shadow_grid_s: f64,
    /// Their memory, bytes.
    pub shadow_grid_bytes: u64,
    /// Samples their build took.
    pub shadow_grid_samples: u64,
    /// Occlusion rays marched (`--ao N`: N per shaded sample).
    pub ao_rays: u64,
    /// Grid reads those rays took.
    pub ao_samples: u64,
    /// Seconds spent building the occlusion grid.
    pub ao_grid_s: f64,
    /// Its memory, bytes.
    pub ao_grid_bytes: u64,
    /// Samples its build took.
    pub ao_grid_samples: u64,
    /// Seconds spent precomputing the AO field (`--ao-field K`; not
    /// counted in the frame's render time).
    pub ao_field_s: f64,
    /// The field's memory, bytes.
    pub ao_field_bytes: u64,
    /// Grid reads its build took.
    pub ao_field_samples: u64,
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

/// One pixel of a film, all its fields.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Px {
    pub(crate) rgba: [f64; 4],
    pub(crate) count: u32,
    pub(crate) value: f64,
    pub(crate) depth: f32,
    pub(crate) samples: u32,
}

impl Px {
    /// Nothing yet: what front-to-back joining starts from.
    pub(crate) const START: Px = Px {
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
    pub(crate) fn carries_nothing(&self) -> bool {
        self.samples == 0
            && self.rgba.iter().all(|c| c.to_bits() == 0)
            && self.value.is_nan()
            && self.depth.is_nan()
    }
}

/// Per-pixel sums (see the module docs).
#[derive(Clone, Debug)]
pub struct Film {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) rgba: Vec<[f64; 4]>,
    pub(crate) count: Vec<u32>,
    pub(crate) value: Vec<f64>,
    pub(crate) depth: Vec<f32>,
    pub(crate) samples: Vec<u32>,
    pub(crate) stats: FrameStats,
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

    /// Pixel `p`'s fields.
    #[inline]
    pub(crate) fn px(&self, p: usize) -> Px {
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
    pub(crate) fn set(&mut self, p: usize, px: &Px) {
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
    pub fn add_grid_stats(&mut self, s: &EffectStats) {
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

    /// Add to the classifier tables' build time and memory (the tables,
    /// then the adaptive steps' strides, each add theirs).
    pub fn add_table(&mut self, seconds: f64, bytes: u64) {
        self.stats.table_s += seconds;
        self.stats.table_bytes += bytes;
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
        use rayon::prelude::*;
        let channels = if alpha { 4 } else { 3 };
        let mut data = vec![0u8; self.rgba.len() * channels];
        // Rows in parallel: three powf per pixel cost a 512² frame
        // milliseconds on one core.
        let row = (self.width as usize).max(1);
        data.par_chunks_mut(row * channels)
            .zip(self.rgba.par_chunks(row))
            .for_each(|(out, px)| {
                for (o, p) in out.chunks_exact_mut(channels).zip(px) {
                    o[0] = srgb8(p[0]);
                    o[1] = srgb8(p[1]);
                    o[2] = srgb8(p[2]);
                    if alpha {
                        o[3] = (p[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
                    }
                }
            });
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
}
