//! A whole frame: settings, dispatch to one specialised loop, tiles in
//! parallel, and the per-pixel results.

use crate::camera::Camera;
use crate::error::RenderError;
use crate::integrate::{self, GradientMethod, Interp, Mode, RayCtx, RayResult};
use crate::light::Lighting;
use crate::ray::intersect_box;
use crate::skip::SkipGrid;
use crate::tf::{table::srgb_to_linear, TfTable, TransferFunction};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use volcore::{Cursor, Volume, VolumeVisitor, VoxelSource};
use volindex::{MajorantIndex, RangeMaxTable};

/// How to render a frame.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// What each ray computes.
    pub mode: Mode,
    /// Distance between samples along a ray, world units (> 0).
    pub step: f32,
    /// Reconstruction between voxels.
    pub interp: Interp,
    /// Gradient method for shading.
    pub gradient: GradientMethod,
    /// Blinn-Phong shading (DVR); iso surfaces are always shaded.
    pub shading: bool,
    /// Light and material.
    pub lighting: Lighting,
    /// Shade only where the world-space gradient is longer than this
    /// fraction of the volume's value range per world unit.
    pub gradient_threshold: f32,
    /// Early ray termination threshold for DVR (`None` = off).
    pub ert: Option<f32>,
    /// Empty-space skipping (needs an index).
    pub ess: bool,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Background colour, sRGB components in [0, 1].
    pub background: [f32; 3],
    /// Iso-surface colour, sRGB components in [0, 1].
    pub iso_colour: [f32; 3],
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Mode::Dvr,
            step: 0.5,
            interp: Interp::Trilinear,
            gradient: GradientMethod::Central,
            shading: false,
            lighting: Lighting::default(),
            gradient_threshold: 0.01,
            ert: Some(0.99),
            ess: true,
            tile: 16,
            background: [0.0; 3],
            iso_colour: [0.85, 0.85, 0.8],
        }
    }
}

/// Counts and times for one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Rays that met the volume.
    pub rays: u64,
    /// Samples taken (interpolations of the volume, bisection included).
    pub samples: u64,
    /// Jumps over empty cells.
    pub skips: u64,
    /// Seconds spent rendering.
    pub render_s: f64,
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
    pub value: Vec<f32>,
    /// Ray parameter of the iso hit or MIP extreme (NaN when none).
    pub depth: Vec<f32>,
    /// Samples taken per pixel.
    pub samples: Vec<u32>,
    /// Totals.
    pub stats: FrameStats,
}

fn check(settings: &RenderSettings, vol: &Volume) -> Result<(), RenderError> {
    let s = settings.step;
    if !(s.is_finite() && s > 0.0) {
        return Err(RenderError::Setting(format!(
            "step {s} must be a positive number"
        )));
    }
    let min_spacing = vol
        .meta
        .spacing
        .iter()
        .cloned()
        .fold(f32::INFINITY, f32::min);
    if s < min_spacing * 1e-4 {
        return Err(RenderError::Setting(format!(
            "step {s} is below 1e-4 of the voxel spacing: a frame would take billions of samples per ray"
        )));
    }
    if let Some(t) = settings.ert {
        if !(t > 0.0 && t <= 1.0) {
            return Err(RenderError::Setting(format!(
                "termination threshold {t} must be in (0, 1]"
            )));
        }
    }
    if settings.tile == 0 {
        return Err(RenderError::Setting("tile size must be at least 1".into()));
    }
    if let Mode::Iso(v) = settings.mode {
        if !v.is_finite() {
            return Err(RenderError::Setting("iso value must be finite".into()));
        }
    }
    Ok(())
}

/// Render one frame of `vol`. `tf` is needed for DVR (presets are in
/// [`TransferFunction::preset`]); `index` enables empty-space skipping when
/// `settings.ess` is on (it must belong to `vol`).
pub fn render(
    vol: &Volume,
    index: Option<&MajorantIndex>,
    tf: Option<&TransferFunction>,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<Frame, RenderError> {
    check(settings, vol)?;
    if let Some(ix) = index {
        if ix.dims() != vol.dims() {
            return Err(RenderError::Index(format!(
                "index is for {} but the volume is {}",
                ix.dims(),
                vol.dims()
            )));
        }
    }
    let range = if vol.meta.range.is_empty() {
        (0.0, 0.0)
    } else {
        (vol.meta.range.min as f32, vol.meta.range.max as f32)
    };
    let table = match (settings.mode, tf) {
        (Mode::Dvr, Some(tf)) => {
            let (lo, hi) = tf.domain.unwrap_or(range);
            let hi = if hi > lo { hi } else { lo + 1.0 };
            Some(TfTable::new(
                tf,
                lo,
                hi,
                TfTable::default_bins(lo, hi),
                settings.step,
            ))
        }
        (Mode::Dvr, None) => {
            return Err(RenderError::Setting("DVR needs a transfer function".into()))
        }
        _ => None,
    };
    let ess_index = if settings.ess { index } else { None };
    let skip = match (ess_index, settings.mode, &table) {
        (Some(ix), Mode::Dvr, Some(t)) => {
            let (lo, hi) = t.domain();
            let rmt = RangeMaxTable::from_bin_maxima(lo, hi, t.alphas())
                .map_err(|e| RenderError::Index(e.to_string()))?;
            Some(SkipGrid::transparent(ix, &rmt))
        }
        (Some(ix), Mode::XraySum | Mode::XrayMean, _) => Some(SkipGrid::zero(ix)),
        (Some(ix), Mode::Iso(v), _) => Some(SkipGrid::iso(ix, v)),
        (Some(ix), Mode::Mip | Mode::Minip, _) => Some(SkipGrid::ranges(ix)),
        _ => None,
    };
    let s = vol.meta.spacing;
    let value_span = (range.1 - range.0).max(f32::MIN_POSITIVE);
    let ctx = RayCtx {
        step: settings.step,
        inv_spacing: Vec3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2]),
        table: table.as_ref(),
        lighting: settings.lighting,
        gradient_threshold: settings.gradient_threshold * value_span,
        ert: settings.ert.unwrap_or(2.0),
        skip: skip.as_ref(),
        value_range: range,
        iso_colour: Vec3::from(settings.iso_colour.map(srgb_to_linear)),
        locator: volcore::grid::Locator::new(vol.dims()),
    };
    let d = vol.dims().as_array();
    let hi = Vec3::new(
        (d[0] - 1) as f32 * s[0],
        (d[1] - 1) as f32 * s[1],
        (d[2] - 1) as f32 * s[2],
    );
    let start = Instant::now();
    let job = Job {
        ctx: &ctx,
        camera,
        settings,
        hi,
    };
    let mut frame = vol.visit(job);
    frame.stats.render_s = start.elapsed().as_secs_f64();
    let bg = Vec3::from(settings.background.map(srgb_to_linear));
    finish(&mut frame, settings.mode, bg, range);
    Ok(frame)
}

/// Turn raw ray results into displayable linear colours over the background.
fn finish(frame: &mut Frame, mode: Mode, bg: Vec3, range: (f32, f32)) {
    let grey = |g: f32| [g, g, g, 1.0];
    match mode {
        Mode::Dvr | Mode::Iso(_) => {}
        Mode::Mip | Mode::Minip => {
            let span = range.1 - range.0;
            for (px, &v) in frame.rgba.iter_mut().zip(&frame.value) {
                if !v.is_nan() {
                    let g = if span > 0.0 {
                        (v - range.0) / span
                    } else {
                        1.0
                    };
                    *px = grey(g.clamp(0.0, 1.0));
                }
            }
        }
        Mode::XraySum | Mode::XrayMean => {
            let top = frame
                .value
                .iter()
                .cloned()
                .filter(|v| v.is_finite())
                .fold(0.0f32, f32::max);
            for (px, &v) in frame.rgba.iter_mut().zip(&frame.value) {
                if v.is_finite() {
                    let g = if top > 0.0 { v / top } else { 0.0 };
                    *px = grey(g.clamp(0.0, 1.0));
                }
            }
        }
    }
    for px in frame.rgba.iter_mut() {
        let a = px[3];
        for c in 0..3 {
            px[c] += (1.0 - a) * bg[c];
        }
    }
}

struct Job<'a> {
    ctx: &'a RayCtx<'a>,
    camera: &'a Camera,
    settings: &'a RenderSettings,
    hi: Vec3,
}

/// One specialised ray function, picked once per frame.
type RayFn<C> = fn(&RayCtx, &mut C, &crate::ray::Ray, f32, f32) -> RayResult;

impl VolumeVisitor for Job<'_> {
    type Output = Frame;
    fn visit<S: VoxelSource>(self, src: &S) -> Frame {
        let f = pick::<S::Cursor<'_>>(self.settings, self.ctx.skip.is_some());
        let (w, h) = (self.camera.width(), self.camera.height());
        let tile = self.settings.tile;
        let (tx, ty) = (w.div_ceil(tile), h.div_ceil(tile));
        let iso = match self.settings.mode {
            Mode::Iso(v) => v,
            _ => 0.0,
        };
        let tiles: Vec<Vec<RayResult>> = (0..tx * ty)
            .into_par_iter()
            .map(|i| {
                let (x0, y0) = ((i % tx) * tile, (i / tx) * tile);
                let mut cur = src.cursor();
                let mut out = Vec::with_capacity((tile * tile) as usize);
                for y in y0..(y0 + tile).min(h) {
                    for x in x0..(x0 + tile).min(w) {
                        let ray = self.camera.ray(x, y);
                        let r = match intersect_box(&ray, Vec3::ZERO, self.hi) {
                            None => RayResult {
                                value: f32::NAN,
                                depth: f32::NAN,
                                ..Default::default()
                            },
                            Some((t0, t1)) => match f {
                                Picked::Ray(f) => f(self.ctx, &mut cur, &ray, t0, t1),
                                Picked::Iso(f) => f(self.ctx, &mut cur, &ray, t0, t1, iso),
                            },
                        };
                        out.push(r);
                    }
                }
                out
            })
            .collect();
        let n = (w * h) as usize;
        let mut frame = Frame {
            width: w,
            height: h,
            rgba: vec![[0.0; 4]; n],
            value: vec![f32::NAN; n],
            depth: vec![f32::NAN; n],
            samples: vec![0; n],
            stats: FrameStats::default(),
        };
        for (i, results) in tiles.iter().enumerate() {
            let (x0, y0) = ((i as u32 % tx) * tile, (i as u32 / tx) * tile);
            let tw = (x0 + tile).min(w) - x0;
            for (j, r) in results.iter().enumerate() {
                let (x, y) = (x0 + j as u32 % tw, y0 + j as u32 / tw);
                let p = (y * w + x) as usize;
                frame.rgba[p] = r.rgba;
                frame.value[p] = r.value;
                frame.depth[p] = r.depth;
                frame.samples[p] = r.samples;
                frame.stats.rays += (r.samples > 0 || r.skips > 0) as u64;
                frame.stats.samples += r.samples as u64;
                frame.stats.skips += r.skips as u64;
            }
        }
        frame
    }
}

#[derive(Clone, Copy)]
enum Picked<C> {
    Ray(RayFn<C>),
    Iso(fn(&RayCtx, &mut C, &crate::ray::Ray, f32, f32, f32) -> RayResult),
}

/// Choose the specialised loop for the settings, once per frame.
fn pick<C: Cursor>(s: &RenderSettings, ess: bool) -> Picked<C> {
    use integrate::{dvr, iso, mip, xray};
    let tri = s.interp == Interp::Trilinear;
    let analytic = s.gradient == GradientMethod::Analytic;
    let ert = s.ert.is_some();
    macro_rules! b {
        ($f:ident, [$($done:expr),*], ) => { $f::<C, $($done),*> };
        ($f:ident, [$($done:expr),*], $head:expr $(, $rest:expr)*) => {
            if $head { b!($f, [$($done,)* true], $($rest),*) } else { b!($f, [$($done,)* false], $($rest),*) }
        };
    }
    match s.mode {
        Mode::Dvr => Picked::Ray(b!(dvr, [], tri, s.shading, analytic, ess, ert)),
        Mode::Mip => Picked::Ray(if tri {
            b!(mip, [true, true], ess, ert)
        } else {
            b!(mip, [false, true], ess, ert)
        }),
        Mode::Minip => Picked::Ray(if tri {
            b!(mip, [true, false], ess, ert)
        } else {
            b!(mip, [false, false], ess, ert)
        }),
        Mode::XraySum => Picked::Ray(if tri {
            b!(xray, [true, false], ess)
        } else {
            b!(xray, [false, false], ess)
        }),
        Mode::XrayMean => Picked::Ray(if tri {
            b!(xray, [true, true], ess)
        } else {
            b!(xray, [false, true], ess)
        }),
        Mode::Iso(_) => Picked::Iso(b!(iso, [], tri, analytic, ess)),
    }
}
