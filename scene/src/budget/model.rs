//! What a ray-cast frame is expected to cost and how far it is expected
//! to be from the exact image, as functions of its step and image scale:
//! fitted to a few probe frames of the same view.
//!
//! Cost: `fixed + per_unit × pixels × (2 + samples per pixel)`, the
//! samples per pixel scaling as 1/step (the march takes one sample per
//! step along the same busy length), plus the upsampling's cost per
//! output pixel. A unit costs less the denser the rays: neighbouring rays
//! share cache lines (a CT head's samples cost 50 ns at 48² and 22 ns at
//! 256² on two cores), so the cost per unit is measured at the probes'
//! scale and at full resolution (the centre probe) and interpolated
//! between them in log scale. Error (mean squared error of the 8-bit sRGB image):
//! the step's error `C·step^p` (p fitted to three steps an octave apart,
//! the errors of two steps taken as uncorrelated) plus the scale's,
//! measured as what a full-resolution crop loses when sampled 2x, 4x and
//! 8x more coarsely and upsampled back, in proportion to the volume's
//! coverage of the crop and of the whole image.

/// One probe frame's figures.
#[derive(Clone, Debug)]
pub struct ProbeFrame {
    /// Its step, world units.
    pub step: f64,
    /// Its pixels.
    pub pixels: f64,
    /// Samples its rays took.
    pub samples: f64,
    /// Its wall time, seconds.
    pub seconds: f64,
    /// Its 8-bit sRGB pixels as floats, RGB.
    pub srgb: Vec<f32>,
    /// The fraction of its pixels the volume covers (coverage alpha).
    pub coverage: f64,
}

/// The cost of a frame at a step and pixel count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Seconds every frame costs whatever its size and step (set-up:
    /// tables, skipping flags, culling, threads).
    pub fixed_s: f64,
    /// Seconds per sample at the probes' scale.
    pub per_sample_s: f64,
    /// The probes' image scale (each side times this).
    pub probe_scale: f64,
    /// The cost per sample at full resolution over that at the probes'
    /// scale (rays closer together share more cache lines).
    pub dense_factor: f64,
    /// Samples per pixel at `at_step`.
    pub samples_per_pixel: f64,
    /// The step `samples_per_pixel` was measured at.
    pub at_step: f64,
    /// Seconds per output pixel of upsampling.
    pub upsample_s: f64,
}

/// What upsampling a frame costs per output pixel, in samples (a 512²
/// frame took 8.7 ms where a sample took 33 ns of the frame's wall time
/// on two cores: about half a sample per pixel, rounded up).
pub const UPSAMPLE_SAMPLES: f64 = 0.5;

/// What a ray costs before its samples, in samples (its camera ray, box
/// clipping, first cell and pixel write).
pub const RAY_SAMPLES: f64 = 2.0;

/// The least cost per sample the model assumes (guards probes timed at
/// zero).
const MIN_PER_SAMPLE_S: f64 = 1e-11;

/// The range the density factor is kept in: denser rays never cost more
/// per sample (a centre that costs more per sample holds costlier
/// content, such as more shaded samples, not denser rays), nor were they
/// measured to cost less than a third.
const DENSE_FACTOR: (f64, f64) = (0.25, 1.0);

impl CostModel {
    /// The model fitted to `probes` (of one size, at different steps,
    /// rendered at `probe_scale` of each side) and to `dense`, a frame at
    /// full resolution: the cost per sample is the slope of time over
    /// samples, within a factor of 4 of the mean time per sample (a slope
    /// of noisy timings can be anything); what the slope leaves at zero
    /// samples, less the rays' share, is the fixed cost; the density
    /// factor is `dense`'s time per unit over the probe's nearest in step.
    pub fn fit(probes: &[ProbeFrame], probe_scale: f64, dense: &ProbeFrame) -> CostModel {
        let n = probes.len().max(1) as f64;
        let mean = |f: &dyn Fn(&ProbeFrame) -> f64| probes.iter().map(f).sum::<f64>() / n;
        let units = |p: &ProbeFrame| p.samples + RAY_SAMPLES * p.pixels;
        let (mu, mt) = (mean(&units), mean(&|p| p.seconds));
        let cov = mean(&|p| (units(p) - mu) * (p.seconds - mt));
        let var = mean(&|p| (units(p) - mu).powi(2));
        let average = if mu > 0.0 { mt / mu } else { 0.0 };
        let slope = if var > 0.0 { cov / var } else { average };
        let per_sample_s = slope
            .clamp(average / 4.0, average * 4.0)
            .max(MIN_PER_SAMPLE_S);
        let fixed_s = (mt - per_sample_s * mu).max(0.0);
        // The finest probe's samples: the busy length per pixel.
        let finest = probes
            .iter()
            .min_by(|a, b| a.step.total_cmp(&b.step))
            .filter(|p| p.pixels > 0.0 && p.step > 0.0);
        let (samples_per_pixel, at_step) = match finest {
            Some(p) => (p.samples / p.pixels, p.step),
            None => (0.0, 1.0),
        };
        let per_unit = |p: &ProbeFrame| {
            let u = units(p);
            (u > 0.0).then(|| (p.seconds - fixed_s).max(0.0) / u)
        };
        let nearest = probes.iter().min_by(|a, b| {
            (a.step.ln() - dense.step.ln())
                .abs()
                .total_cmp(&(b.step.ln() - dense.step.ln()).abs())
        });
        let dense_factor = match (nearest.and_then(per_unit), per_unit(dense)) {
            (Some(sparse), Some(dense)) if sparse > 0.0 && dense > 0.0 => {
                (dense / sparse).clamp(DENSE_FACTOR.0, DENSE_FACTOR.1)
            }
            _ => 1.0,
        };
        CostModel {
            fixed_s,
            per_sample_s,
            probe_scale: probe_scale.clamp(1e-3, 1.0),
            dense_factor,
            samples_per_pixel,
            at_step,
            upsample_s: UPSAMPLE_SAMPLES * per_sample_s,
        }
    }

    /// Seconds per sample of a frame rendered at `scale` of each side:
    /// the probes' cost at their scale or below, `dense_factor` times it
    /// at full resolution, geometric in between.
    pub fn per_sample_at(&self, scale: f64) -> f64 {
        let span = -self.probe_scale.ln();
        // A NaN scale is not above the probes' either.
        if scale.is_nan() || scale <= self.probe_scale || span <= 0.0 {
            return self.per_sample_s;
        }
        let t = (scale.min(1.0) / self.probe_scale).ln() / span;
        self.per_sample_s * self.dense_factor.powf(t)
    }

    /// Expected samples per pixel at `step`.
    pub fn samples_per_pixel(&self, step: f64) -> f64 {
        if step > 0.0 {
            self.samples_per_pixel * self.at_step / step
        } else {
            f64::INFINITY
        }
    }

    /// Expected seconds of a frame at `step` with `pixels` rendered at
    /// `scale` of each side and `upsampled` output pixels (0 when it is
    /// not upsampled).
    pub fn seconds(&self, step: f64, pixels: f64, scale: f64, upsampled: f64) -> f64 {
        self.fixed_s
            + self.per_sample_at(scale) * pixels * (RAY_SAMPLES + self.samples_per_pixel(step))
            + self.upsample_s * upsampled
    }

    /// Calibrate by a frame rendered at `step` with `pixels` pixels at
    /// `scale` that took `samples` samples and `seconds`: the samples per
    /// pixel become the frame's, and the cost per sample moves halfway
    /// (geometrically) to the frame's (a frame timed once is noisy), the
    /// density factor kept.
    pub fn observe(&mut self, step: f64, pixels: f64, scale: f64, samples: f64, seconds: f64) {
        if !(pixels > 0.0 && step > 0.0 && seconds.is_finite()) {
            return;
        }
        self.samples_per_pixel = samples / pixels;
        self.at_step = step;
        let units = samples + RAY_SAMPLES * pixels;
        let measured = ((seconds - self.fixed_s).max(0.0) / units).max(MIN_PER_SAMPLE_S);
        let expected = self.per_sample_at(scale).max(MIN_PER_SAMPLE_S);
        self.per_sample_s = (self.per_sample_s * self.per_sample_s * measured / expected)
            .sqrt()
            .max(MIN_PER_SAMPLE_S);
    }
}

/// The expected squared error of a frame against the exact image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorModel {
    /// `C²` of the step's error `C·step^p`.
    pub step_c2: f64,
    /// `p`.
    pub order: f64,
    /// The squared error of rendering 2, 4 and 8 times smaller and
    /// upsampling, measured on a full-resolution crop.
    pub scale_mse: [f64; 3],
}

/// The range the fitted step order is kept in (first order for a
/// Riemann sum of optical depth; noise at the voxel scale lowers it,
/// smooth data raises it).
const ORDER: (f64, f64) = (0.5, 2.0);

impl ErrorModel {
    /// The model from three probes of one size at steps `s`, `2s`, `4s`
    /// (`fine`, `mid`, `coarse`) and the squared errors of 2x, 4x and 8x
    /// down-and-up sampling at full resolution (`scale_mse`).
    pub fn fit(
        fine: &ProbeFrame,
        mid: &ProbeFrame,
        coarse: &ProbeFrame,
        scale_mse: [f64; 3],
    ) -> ErrorModel {
        let d1 = mse(&fine.srgb, &mid.srgb);
        let d2 = mse(&mid.srgb, &coarse.srgb);
        // d2 / d1 = 2^(2p) when the error is C·step^p.
        let order = if d1 > 0.0 && d2 > 0.0 {
            ((d2 / d1).log2() / 2.0).clamp(ORDER.0, ORDER.1)
        } else {
            1.0
        };
        // A step moves the samples along each ray, so two steps' errors
        // are more alike in size than in sign: taken as uncorrelated,
        // d1 = C² s^(2p) (1 + 2^(2p)) with s the fine step.
        let spread = 1.0 + 2f64.powf(2.0 * order);
        let step_c2 = if fine.step > 0.0 {
            d1 / (fine.step.powf(2.0 * order) * spread)
        } else {
            0.0
        };
        // A coarser scale loses at least what a finer one does.
        let [e2, e4, e8] = scale_mse.map(|e| if e.is_finite() { e.max(0.0) } else { 0.0 });
        let e4 = e4.max(e2);
        ErrorModel {
            step_c2,
            order,
            scale_mse: [e2, e4, e8.max(e4)],
        }
    }

    /// Expected squared error of the step alone.
    pub fn step_mse(&self, step: f64) -> f64 {
        self.step_c2 * step.max(0.0).powf(2.0 * self.order)
    }

    /// Expected squared error of rendering at `scale` (of each side, at
    /// most 1) and upsampling: linear in octaves between the measured
    /// 2x, 4x and 8x (and none at 1), extended past 8x by the last slope.
    pub fn scale_mse(&self, scale: f64) -> f64 {
        if scale >= 1.0 {
            return 0.0;
        }
        let octaves = -scale.max(1e-3).log2();
        let [e2, e4, e8] = self.scale_mse;
        let points = [(0.0, 0.0), (1.0, e2), (2.0, e4), (3.0, e8)];
        let i = (octaves.floor() as usize).min(2);
        let ((x0, y0), (x1, y1)) = (points[i], points[i + 1]);
        y0 + (y1 - y0) * (octaves - x0) / (x1 - x0)
    }

    /// Expected squared error at `step` and `scale`.
    pub fn mse(&self, step: f64, scale: f64) -> f64 {
        self.step_mse(step) + self.scale_mse(scale)
    }
}

/// The mean squared difference of two equal-length pixel arrays (`0`
/// when they are empty or differ in length).
pub fn mse(a: &[f32], b: &[f32]) -> f64 {
    if a.is_empty() || a.len() != b.len() {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = f64::from(x) - f64::from(y);
            d * d
        })
        .sum();
    sum / a.len() as f64
}

/// PSNR in dB of a squared error on 8-bit values (`None`: no error).
pub fn psnr(mse: f64) -> Option<f64> {
    (mse > 0.0).then(|| 10.0 * (255.0f64 * 255.0 / mse).log10())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probe(step: f64, value: f32, samples: f64, seconds: f64) -> ProbeFrame {
        ProbeFrame {
            step,
            pixels: 100.0,
            samples,
            seconds,
            srgb: vec![value; 300],
            coverage: 1.0,
        }
    }

    #[test]
    fn the_order_follows_the_probes() {
        // Errors 1·s², uncorrelated: steps 1 and 2 differ by √17 (errors
        // 1 and 4 at right angles), steps 2 and 4 by 4√17: values
        // (√17 / 3)·s² have those differences.
        let p: Vec<ProbeFrame> = [1.0, 2.0, 4.0]
            .iter()
            .map(|&s: &f64| probe(s, (17f64.sqrt() / 3.0 * s * s) as f32, 100.0, 0.01))
            .collect();
        let m = ErrorModel::fit(&p[0], &p[1], &p[2], [1.0, 3.0, 2.0]);
        assert!((m.order - 2.0).abs() < 1e-5, "{m:?}");
        assert!((m.step_mse(1.0) - 1.0).abs() < 1e-4, "{m:?}");
        assert!((m.step_mse(0.5) - 1.0 / 16.0).abs() < 1e-5);
        // The scale's errors as measured, monotone, linear in octaves.
        assert_eq!(m.scale_mse, [1.0, 3.0, 3.0]);
        assert_eq!(m.scale_mse(1.0), 0.0);
        assert!((m.scale_mse(0.5) - 1.0).abs() < 1e-12);
        assert!((m.scale_mse(0.25) - 3.0).abs() < 1e-12);
        assert!((m.scale_mse(0.5f64.powf(1.5)) - 2.0).abs() < 1e-12);
        assert!((m.scale_mse(0.0625) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn cost_grows_with_pixels_and_shrinks_with_the_step() {
        // 1 ms fixed, 1 µs per sample (a ray 2 samples): 100 rays.
        let t = |samples: f64| 0.001 + 1e-6 * (samples + 200.0);
        let p = [
            probe(1.0, 0.0, 1000.0, t(1000.0)),
            probe(2.0, 0.0, 500.0, t(500.0)),
            probe(4.0, 0.0, 250.0, t(250.0)),
        ];
        let c = CostModel::fit(&p, 1.0, &p[1]);
        assert!((c.per_sample_s - 1e-6).abs() < 1e-12, "{c:?}");
        assert_eq!(c.dense_factor, 1.0);
        assert!((c.fixed_s - 0.001).abs() < 1e-9, "{c:?}");
        assert!((c.samples_per_pixel(1.0) - 10.0).abs() < 1e-9);
        assert!((c.samples_per_pixel(4.0) - 2.5).abs() < 1e-9);
        assert!((c.seconds(1.0, 100.0, 1.0, 0.0) - t(1000.0)).abs() < 1e-9);
        assert!((c.seconds(0.5, 400.0, 1.0, 0.0) - (0.001 + 1e-6 * 8800.0)).abs() < 1e-9);
        // A frame twice as slow per sample moves the cost halfway.
        let mut d = c;
        d.observe(1.0, 100.0, 1.0, 1000.0, 0.001 + 4e-6 * 1200.0);
        assert!((d.per_sample_s - 2e-6).abs() < 1e-12, "{d:?}");
        d.observe(1.0, 0.0, 1.0, 0.0, f64::NAN);
        assert!((d.per_sample_s - 2e-6).abs() < 1e-12);
        // Timings that fall with more samples: the mean cost, no less.
        let q = [
            probe(1.0, 0.0, 1000.0, 0.001),
            probe(2.0, 0.0, 500.0, 0.002),
        ];
        let e = CostModel::fit(&q, 0.5, &q[0]);
        assert!(e.per_sample_s > 0.0 && e.per_sample_s.is_finite(), "{e:?}");
    }

    #[test]
    fn denser_rays_cost_less_per_sample_between_the_two_scales() {
        // Probes at a quarter of each side cost 1 µs per sample; the
        // full-resolution frame at step 2, 0.5 µs (and 1 ms fixed).
        let t = |samples: f64, per: f64| 0.001 + per * (samples + 200.0);
        let p = [
            probe(1.0, 0.0, 1000.0, t(1000.0, 1e-6)),
            probe(2.0, 0.0, 500.0, t(500.0, 1e-6)),
            probe(4.0, 0.0, 250.0, t(250.0, 1e-6)),
        ];
        let dense = probe(2.0, 0.0, 500.0, t(500.0, 0.5e-6));
        let c = CostModel::fit(&p, 0.25, &dense);
        assert!((c.dense_factor - 0.5).abs() < 1e-9, "{c:?}");
        assert!((c.per_sample_at(0.25) - 1e-6).abs() < 1e-15);
        assert!((c.per_sample_at(0.1) - 1e-6).abs() < 1e-15);
        assert!((c.per_sample_at(1.0) - 0.5e-6).abs() < 1e-15);
        assert!((c.per_sample_at(0.5) - 0.5f64.sqrt() * 1e-6).abs() < 1e-15);
        // A full frame as expected leaves the model as it is; one as slow
        // per sample as the probes moves it halfway there.
        let mut d = c;
        d.observe(1.0, 100.0, 1.0, 1000.0, 0.001 + 0.5e-6 * 1200.0);
        assert!((d.per_sample_s - 1e-6).abs() < 1e-12, "{d:?}");
        d.observe(1.0, 100.0, 1.0, 1000.0, 0.001 + 1e-6 * 1200.0);
        assert!(
            (d.per_sample_at(1.0) - 0.5f64.sqrt() * 1e-6).abs() < 1e-12,
            "{d:?}"
        );
        // A crop timed at nothing says nothing; one at ten times the
        // probes' cost is held to the range.
        let free = probe(2.0, 0.0, 500.0, 0.0);
        assert_eq!(CostModel::fit(&p, 0.25, &free).dense_factor, 1.0);
        let slow = probe(2.0, 0.0, 500.0, t(500.0, 1e-5));
        assert_eq!(CostModel::fit(&p, 0.25, &slow).dense_factor, DENSE_FACTOR.1);
    }

    #[test]
    fn flat_probes_expect_no_error() {
        let p: Vec<ProbeFrame> = [1.0, 2.0, 4.0]
            .iter()
            .map(|&s| probe(s, 7.0, 100.0, 0.01))
            .collect();
        let m = ErrorModel::fit(&p[0], &p[1], &p[2], [0.0; 3]);
        assert_eq!(m.mse(8.0, 0.125), 0.0);
        assert_eq!(psnr(0.0), None);
        assert!((psnr(255.0 * 255.0).unwrap_or(1.0)).abs() < 1e-12);
    }
}
