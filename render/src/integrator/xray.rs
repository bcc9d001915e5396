//! X-ray: the line integral, or the mean, of the value along the ray.

use crate::accel::FixedCells;
use crate::ray::Ray;
use crate::trace::march::{march, Flow, RayMarch, RaySteps};
use crate::trace::{FrameGeometry, Integrator, RayResult, Span};
use glam::Vec3;
use volcore::Cursor;

/// What an X-ray pixel reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum XrayOutput {
    /// The line integral: the sum of `value × step` (value·world units).
    Sum,
    /// The mean sample value.
    Mean,
}

/// X-ray projection (see [`XrayOutput`]). NaN samples count as 0; with
/// skipping on, cells holding only zeros are skipped (their samples
/// counted, so the mean stays exact). Accumulates in f64.
pub struct Xray<'a> {
    geom: FrameGeometry,
    skip: Option<&'a FixedCells<'a>>,
    output: XrayOutput,
}

impl<'a> Xray<'a> {
    /// The integrator, skipping the zero cells of `skip` when given.
    pub fn new(geom: FrameGeometry, skip: Option<&'a FixedCells<'a>>, output: XrayOutput) -> Self {
        Xray { geom, skip, output }
    }
}

impl Integrator for Xray<'_> {
    fn trace<C: Cursor>(&self, cur: &mut C, ray: &Ray, _pixel: [u32; 2], span: Span) -> RayResult {
        let steps = RaySteps::for_span(&self.geom, ray, span);
        let mut st = XrayRay {
            xray: self,
            sum: 0.0,
            count: 0,
            samples: 0,
        };
        let skips = march(&mut st, &self.skip, cur, &steps);
        // Kept in f64: a sum of values near f32's largest overflows f32.
        // Rounded through f32 where it fits, so ordinary frames are
        // exactly what an f32 result gave.
        let value = if st.count == 0 {
            f64::NAN
        } else {
            let v = match self.output {
                XrayOutput::Mean => st.sum / st.count as f64,
                XrayOutput::Sum => st.sum * steps.step,
            };
            let v32 = v as f32;
            if v32.is_finite() {
                v32 as f64
            } else {
                v
            }
        };
        RayResult {
            value,
            samples: st.samples,
            skips,
            ..RayResult::empty()
        }
    }
}

struct XrayRay<'x, 'a> {
    xray: &'x Xray<'a>,
    sum: f64,
    count: i64,
    samples: u32,
}

impl RayMarch for XrayRay<'_, '_> {
    type Query = ();
    const CACHE_BUSY: bool = false;

    #[inline(always)]
    fn query(&self) {}

    #[inline(always)]
    fn skipped<C: Cursor>(&mut self, _: &mut C, from: i64, to: i64, _: &RaySteps) -> Flow {
        self.count += to - from;
        Flow::Next
    }

    #[inline(always)]
    fn sample<C: Cursor>(
        &mut self,
        cur: &mut C,
        _: i64,
        _: f32,
        p: Vec3,
        _: Option<usize>,
    ) -> Flow {
        let geom = &self.xray.geom;
        let v = geom.interp.value(&geom.locator, cur, p);
        self.samples += 1;
        if !v.is_nan() {
            self.sum += v as f64;
        }
        self.count += 1;
        Flow::Next
    }
}
