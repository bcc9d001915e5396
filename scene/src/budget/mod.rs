//! A frame-time budget for the ray caster (`--budget SECONDS`): the step
//! and the image scale (rendered smaller, then upsampled) with the best
//! expected PSNR whose expected time fits, from a cost and an error model
//! ([`model`]) fitted to three small probe frames of the view
//! ([`probe`]); vol-view keeps the model between previews and calibrates
//! its cost by each frame it renders.

pub mod model;
pub mod probe;
pub mod resize;

pub use model::{CostModel, ErrorModel};
pub use probe::{probe, Probed};

/// The multiples of the base step a budget chooses among.
pub const STEP_FACTORS: [f64; 11] = [
    0.25, 0.354, 0.5, 0.707, 1.0, 1.414, 2.0, 2.83, 4.0, 5.66, 8.0,
];
/// The image scales a budget chooses among (each side times this).
pub const SCALES: [f64; 11] = [
    1.0, 0.841, 0.707, 0.595, 0.5, 0.42, 0.354, 0.297, 0.25, 0.177, 0.125,
];
/// The fewest pixels a side is rendered with.
pub const MIN_SIDE: u32 = 8;

/// A view's models: what a frame costs and how far it is from exact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// Seconds.
    pub cost: CostModel,
    /// Squared error of the 8-bit image.
    pub error: ErrorModel,
}

/// The setting a budget picked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// The step, world units.
    pub step: f64,
    /// The step over the base step.
    pub step_factor: f64,
    /// The image scale.
    pub scale: f64,
    /// The size rendered.
    pub width: u32,
    /// The size rendered.
    pub height: u32,
    /// Expected seconds of the frame (with its upsampling).
    pub expected_s: f64,
    /// Expected squared error of the 8-bit image.
    pub expected_mse: f64,
    /// Whether the expected time fits the seconds available (when not,
    /// this is the cheapest setting).
    pub fits: bool,
}

impl Choice {
    /// The expected PSNR, dB (`None` when no error is expected).
    pub fn expected_psnr(&self) -> Option<f64> {
        model::psnr(self.expected_mse)
    }
}

/// The side `side` becomes at `scale` (at least [`MIN_SIDE`], at most
/// `side`).
pub fn scaled(side: u32, scale: f64) -> u32 {
    let s = (f64::from(side) * scale).round();
    (s as u32).clamp(MIN_SIDE.min(side), side)
}

/// The setting of least expected error whose expected time fits
/// `seconds` for an image of `size` at multiples of `base_step`; the
/// cheapest setting when none fits. Ties go to the faster.
pub fn choose(model: &Model, base_step: f64, size: (u32, u32), seconds: f64) -> Choice {
    let full = f64::from(size.0) * f64::from(size.1);
    let mut best: Option<Choice> = None;
    let mut cheapest: Option<Choice> = None;
    for &f in &STEP_FACTORS {
        for &k in &SCALES {
            let (w, h) = (scaled(size.0, k), scaled(size.1, k));
            let pixels = f64::from(w) * f64::from(h);
            let upsampled = if (w, h) == size { 0.0 } else { full };
            let step = base_step * f;
            let c = Choice {
                step,
                step_factor: f,
                scale: (pixels / full).sqrt(),
                width: w,
                height: h,
                expected_s: model
                    .cost
                    .seconds(step, pixels, (pixels / full).sqrt(), upsampled),
                expected_mse: model.error.mse(step, (pixels / full).sqrt()),
                fits: true,
            };
            if cheapest.is_none_or(|b| c.expected_s < b.expected_s) {
                cheapest = Some(c);
            }
            let better = |b: &Choice| {
                c.expected_mse < b.expected_mse
                    || (c.expected_mse == b.expected_mse && c.expected_s < b.expected_s)
            };
            if c.expected_s <= seconds && best.as_ref().is_none_or(better) {
                best = Some(c);
            }
        }
    }
    match (best, cheapest) {
        (Some(b), _) => b,
        (None, Some(c)) => Choice { fits: false, ..c },
        // The lists are not empty.
        (None, None) => Choice {
            step: base_step,
            step_factor: 1.0,
            scale: 1.0,
            width: size.0,
            height: size.1,
            expected_s: f64::INFINITY,
            expected_mse: 0.0,
            fits: false,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> Model {
        Model {
            cost: CostModel {
                fixed_s: 0.001,
                per_sample_s: 1e-8,
                probe_scale: 1.0 / 6.0,
                dense_factor: 0.5,
                samples_per_pixel: 400.0,
                at_step: 0.5,
                upsample_s: 1e-9,
            },
            error: ErrorModel {
                step_c2: 100.0,
                order: 1.0,
                scale_mse: [20.0, 60.0, 150.0],
            },
        }
    }

    #[test]
    fn a_larger_budget_buys_less_error_and_stays_inside() {
        let m = model();
        let mut last = f64::INFINITY;
        for budget in [0.01, 0.03, 0.1, 0.3, 1.0, 3.0] {
            let c = choose(&m, 0.5, (512, 512), budget);
            assert!(c.fits, "{budget}: {c:?}");
            assert!(c.expected_s <= budget, "{budget}: {c:?}");
            assert!(c.expected_mse <= last, "{budget}: {c:?}");
            last = c.expected_mse;
        }
        // Enough for everything: the finest step at full size.
        let c = choose(&m, 0.5, (512, 512), 1e9);
        assert_eq!((c.step_factor, c.width, c.height), (0.25, 512, 512));
    }

    #[test]
    fn too_small_a_budget_gives_the_cheapest() {
        let c = choose(&model(), 0.5, (512, 256), 1e-6);
        assert!(!c.fits);
        assert_eq!((c.step_factor, c.width, c.height), (8.0, 64, 32));
        assert_eq!(scaled(20, 0.125), 8);
        assert_eq!(scaled(4, 0.125), 4);
    }
}
