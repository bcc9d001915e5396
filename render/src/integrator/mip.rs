//! Maximum and minimum intensity projection.

use super::march::{march, Flow, RayMarch, RaySteps};
use super::reconstruct::Reconstruct;
use super::{FrameGeometry, Integrator, RayResult, Span};
use crate::accel::Accel;
use crate::ray::Ray;
use glam::Vec3;
use std::marker::PhantomData;
use volcore::Cursor;

/// Which extreme a projection keeps.
pub trait Extreme: Copy + Send + Sync + 'static {
    /// The value before any sample.
    const START: f32;
    /// Whether `v` beats `best`.
    fn beats(v: f32, best: f32) -> bool;
    /// Whether `best` has reached the volume's extreme `extreme`.
    fn reached(best: f32, extreme: f32) -> bool;
}

/// Keep the largest value (MIP).
#[derive(Clone, Copy, Debug, Default)]
pub struct Maximum;

/// Keep the smallest value (MinIP).
#[derive(Clone, Copy, Debug, Default)]
pub struct Minimum;

impl Extreme for Maximum {
    const START: f32 = f32::NEG_INFINITY;
    #[inline(always)]
    fn beats(v: f32, best: f32) -> bool {
        v > best
    }
    #[inline(always)]
    fn reached(best: f32, extreme: f32) -> bool {
        best >= extreme
    }
}

impl Extreme for Minimum {
    const START: f32 = f32::INFINITY;
    #[inline(always)]
    fn beats(v: f32, best: f32) -> bool {
        v < best
    }
    #[inline(always)]
    fn reached(best: f32, extreme: f32) -> bool {
        best <= extreme
    }
}

/// The extreme sample value along the ray (`D` says which); NaN samples
/// are ignored. With `stop_at_extreme`, a ray stops once its running value
/// reaches the volume's own extreme (nothing can beat it; checked only
/// when the value improves). `A` skips cells whose range cannot beat the
/// running value.
pub struct Mip<R, D, A> {
    geom: FrameGeometry,
    accel: A,
    stop_at_extreme: bool,
    extreme: f32,
    _choices: PhantomData<(R, D)>,
}

impl<R, D, A> Mip<R, D, A> {
    /// The integrator; `extreme` is the volume's largest (MIP) or smallest
    /// (MinIP) value.
    pub fn new(geom: FrameGeometry, accel: A, stop_at_extreme: bool, extreme: f32) -> Self {
        Mip {
            geom,
            accel,
            stop_at_extreme,
            extreme,
            _choices: PhantomData,
        }
    }
}

impl<R: Reconstruct, D: Extreme, A: Accel<f32>> Integrator for Mip<R, D, A> {
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, _pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = MipRay::<R, D, A> {
            mip: self,
            best: D::START,
            depth: f32::NAN,
            samples: 0,
        };
        let skips = march(&mut st, &self.accel, cur, &steps);
        RayResult {
            // An infinite sample is a value like any other (it shows white
            // in MIP, black in MinIP); only no sample at all is no value.
            value: if st.best != D::START {
                st.best as f64
            } else {
                f64::NAN
            },
            depth: st.depth,
            samples: st.samples,
            skips,
            ..RayResult::empty()
        }
    }
}

struct MipRay<'m, R, D, A> {
    mip: &'m Mip<R, D, A>,
    best: f32,
    depth: f32,
    samples: u32,
}

impl<R: Reconstruct, D: Extreme, A> RayMarch for MipRay<'_, R, D, A> {
    type Query = f32;
    const CACHE_BUSY: bool = false;

    #[inline(always)]
    fn query(&self) -> f32 {
        self.best
    }

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        _: i64,
        t: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let v = R::value(&self.mip.geom.locator, cur, p);
        self.samples += 1;
        if D::beats(v, self.best) {
            self.best = v;
            self.depth = t;
            if self.mip.stop_at_extreme && D::reached(self.best, self.mip.extreme) {
                return Flow::Stop;
            }
        }
        Flow::Next
    }
}
