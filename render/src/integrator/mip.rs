//! Maximum and minimum intensity projection.

use crate::accel::{Accel, RunningMax, RunningMin};
use crate::ray::Ray;
use crate::trace::march::{march, Flow, RayMarch, RaySteps};
use crate::trace::{FrameGeometry, Integrator, RayResult, Span};
use glam::Vec3;
use std::marker::PhantomData;
use volcore::Cursor;
use volindex::MinMaxIndex;

/// Which extreme a projection keeps.
pub trait Extreme: Copy + Send + Sync + 'static {
    /// The skipping rule: cells whose range cannot beat the running value.
    type Skip<'a>: Accel<f32>;
    /// The rule over `index`.
    fn skip(index: &MinMaxIndex) -> Self::Skip<'_>;
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
    type Skip<'a> = RunningMax<'a>;
    fn skip(index: &MinMaxIndex) -> RunningMax<'_> {
        RunningMax::new(index)
    }
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
    type Skip<'a> = RunningMin<'a>;
    fn skip(index: &MinMaxIndex) -> RunningMin<'_> {
        RunningMin::new(index)
    }
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
/// when the value improves). With skipping on, cells whose range cannot
/// beat the running value are skipped ([`Extreme::Skip`]).
pub struct Mip<'a, D: Extreme> {
    geom: FrameGeometry,
    skip: Option<D::Skip<'a>>,
    stop_at_extreme: bool,
    extreme: f32,
    _extreme: PhantomData<D>,
}

impl<'a, D: Extreme> Mip<'a, D> {
    /// The integrator, skipping over `index` when given; `extreme` is the
    /// volume's largest (MIP) or smallest (MinIP) value.
    pub fn new(
        geom: FrameGeometry,
        index: Option<&'a MinMaxIndex>,
        stop_at_extreme: bool,
        extreme: f32,
    ) -> Self {
        Mip {
            geom,
            skip: index.map(D::skip),
            stop_at_extreme,
            extreme,
            _extreme: PhantomData,
        }
    }
}

impl<D: Extreme> Integrator for Mip<'_, D> {
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, _pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = MipRay::<D> {
            mip: self,
            best: D::START,
            depth: f32::NAN,
            samples: 0,
        };
        let skips = march(&mut st, &self.skip, cur, &steps);
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

struct MipRay<'m, 'a, D: Extreme> {
    mip: &'m Mip<'a, D>,
    best: f32,
    depth: f32,
    samples: u32,
}

impl<D: Extreme> RayMarch for MipRay<'_, '_, D> {
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
        let geom = &self.mip.geom;
        let mut v = geom.interp.value(&geom.locator, cur, p);
        // Next to an infinite (or ±FLT_MAX) voxel the blend overflows or
        // gives NaN (inf - inf): read the sample again by the extended
        // rule, so a ray past +inf shows white (MIP), past -inf black.
        // Integer samples never need it (the check compiles away).
        if !cur.finite() && !v.is_finite() {
            v = geom.interp.value_extended(&geom.locator, cur, p);
        }
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
