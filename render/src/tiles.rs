//! The tile loop: a frame's pixels, tile by tile on all threads, into a
//! film. It is compiled once: the frame's concrete integrator and the
//! volume's sample type and layout meet behind one trait object,
//! [`TileRenderer`], which traces the rays of one tile. Every pixel is
//! computed on its own from its own ray, so the image does not depend on
//! the thread count or the tile order.

use crate::accel::cull::BlockMask;
use crate::camera::Camera;
use crate::distributed::share::PixelRect;
use crate::distributed::ShareBox;
use crate::error::RenderError;
use crate::film::Film;
use crate::ray::Ray;
use crate::settings::Cancel;
use crate::trace::{Integrator, RayResult, Span};
use glam::Vec3;
use rayon::prelude::*;
use volcore::{Volume, VolumeVisitor, VoxelSource};

/// One ray of a tile: its pixel, the ray, and the samples to take.
#[derive(Clone, Copy, Debug)]
pub struct PixelRay {
    /// The pixel (column, row).
    pub pixel: [u32; 2],
    /// The camera ray through it.
    pub ray: Ray,
    /// Where it is inside the volume's box (or the share of it to take).
    pub span: Span,
    /// Where `ray` starts on the camera's ray through the pixel (0 but
    /// for eyes far from the volume: [`crate::ray::EyeRay::near`]); added
    /// to the depth traced along `ray`.
    pub start: f64,
}

/// Traces the rays of one tile with a frame's integrator over a volume:
/// the only code specialised per integrator and per sample source.
pub trait TileRenderer: Sync {
    /// Trace `rays` in order, appending each pixel's result to `out`.
    fn render_tile(&self, rays: &[PixelRay], out: &mut Vec<([u32; 2], RayResult)>);
}

/// An integrator over one sample source (one cursor per tile).
struct Bound<'a, S, I> {
    src: &'a S,
    integrator: &'a I,
}

impl<S: VoxelSource, I: Integrator> TileRenderer for Bound<'_, S, I> {
    fn render_tile(&self, rays: &[PixelRay], out: &mut Vec<([u32; 2], RayResult)>) {
        let mut cur = self.src.cursor();
        out.extend(rays.iter().map(|r| {
            let result = self.integrator.trace(&mut cur, &r.ray, r.pixel, r.span);
            (r.pixel, result)
        }));
    }
}

/// A frame's pixels and which of them to trace: everything the tile loop
/// needs but the integrator.
#[derive(Clone, Copy)]
pub struct Tiles<'a> {
    /// The camera (and the image size).
    pub camera: &'a Camera,
    /// Tile edge, pixels.
    pub tile: u32,
    /// The far corner of the volume's box.
    pub hi: Vec3,
    /// Which pixels' rays may take samples; the others are left empty,
    /// untraced.
    pub busy: Option<&'a BlockMask>,
    /// Take only the samples inside this box (a rank's share).
    pub share: Option<&'a ShareBox>,
    /// The only pixels whose rays can meet the share's box; the others are
    /// left empty, untraced.
    pub share_pixels: Option<PixelRect>,
    /// The frame's step (to find a share's samples).
    pub step: f32,
    /// Checked before each tile: once raised, the remaining tiles are left
    /// untraced and the frame is refused as cancelled.
    pub cancel: &'a Cancel,
}

impl Tiles<'_> {
    /// Trace every tile with `integrator` over `vol` into a film.
    pub fn render<I: Integrator>(&self, vol: &Volume, integrator: &I) -> Result<Film, RenderError> {
        struct Bind<'t, 'i, I> {
            tiles: &'t Tiles<'t>,
            integrator: &'i I,
        }
        impl<I: Integrator> VolumeVisitor for Bind<'_, '_, I> {
            type Output = Result<Film, RenderError>;
            fn visit<S: VoxelSource>(self, src: &S) -> Self::Output {
                let bound = Bound {
                    src,
                    integrator: self.integrator,
                };
                self.tiles.run(&bound)
            }
        }
        vol.visit(Bind {
            tiles: self,
            integrator,
        })
    }

    /// Trace every tile with `renderer`, in parallel.
    pub fn run(&self, renderer: &dyn TileRenderer) -> Result<Film, RenderError> {
        let (w, h) = (self.camera.width(), self.camera.height());
        let (tx, ty) = (w.div_ceil(self.tile), h.div_ceil(self.tile));
        // Per tile, the rays traced (pixel and result); the other pixels'
        // rays met nothing, and the film starts that way.
        let results: Vec<Vec<([u32; 2], RayResult)>> = (0..tx * ty)
            .into_par_iter()
            .map(|i| {
                let mut out = Vec::new();
                if self.cancel.is_cancelled() {
                    return out;
                }
                let rays = self.rays_of_tile(i % tx, i / tx);
                out.reserve(rays.len());
                renderer.render_tile(&rays, &mut out);
                debug_assert_eq!(rays.len(), out.len());
                for (ray, (_, r)) in rays.iter().zip(out.iter_mut()) {
                    if ray.start != 0.0 {
                        r.depth = (ray.start + f64::from(r.depth)) as f32;
                    }
                }
                out
            })
            .collect();
        if self.cancel.is_cancelled() {
            return Err(RenderError::Cancelled);
        }
        let mut film = Film::one_empty_ray_each(w, h);
        for ([x, y], r) in results.iter().flatten() {
            film.put_ray(*x, *y, r);
        }
        Ok(film)
    }

    /// The rays of tile `(tx, ty)` that may meet the volume (or the share's
    /// part of it), row by row.
    fn rays_of_tile(&self, tx: u32, ty: u32) -> Vec<PixelRay> {
        let (w, h) = (self.camera.width(), self.camera.height());
        let (x0, y0) = (tx * self.tile, ty * self.tile);
        let (x1, y1) = ((x0 + self.tile).min(w), (y0 + self.tile).min(h));
        let mut rays = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                if self.busy.is_some_and(|b| !b.may_see(x, y))
                    || self.share_pixels.is_some_and(|r| !r.contains(x, y))
                {
                    continue;
                }
                let Some((ray, start, t0, t1)) =
                    self.camera.ray(x, y).enter(Vec3::ZERO, self.hi, self.step)
                else {
                    continue;
                };
                let whole = Span::whole(t0, t1);
                let span = match self.share.map(|b| b.samples(&ray, whole, self.step)) {
                    None => whole,
                    Some(None) => continue,
                    Some(Some(k)) => Span {
                        share: Some(k),
                        ..whole
                    },
                };
                rays.push(PixelRay {
                    pixel: [x, y],
                    ray,
                    span,
                    start,
                });
            }
        }
        rays
    }
}
