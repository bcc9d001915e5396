//! `--resample`: the input's samples on another grid.
//!
//! Each output voxel centre is mapped through world space to a continuous
//! input index `c` (in f64). When `c` lies outside the input's box on any
//! axis the voxel gets the background. The inside test is ITK's
//! (`ImageFunction::IsInsideBuffer`): `−0.5 <= c < n − 0.5`, half-open, so
//! a centre exactly on the last voxel's outer face is outside. Otherwise
//! the kernel ([`Kernel`]) is evaluated at `c`; taps outside `0 .. n` take
//! the edge voxel (replicate). With `nearest` (`floor(c + 0.5)`) and
//! `linear` without antialiasing this is what SimpleITK's
//! `ResampleImageFilter` computes (its linear interpolator also uses the
//! edge voxel for the half voxel past the last centre).
//!
//! Antialiasing (on by default): along an input axis where the output
//! samples more coarsely, the kernel `w` is widened to `w(x/σ)/σ` and the
//! weights normalised to sum 1, as teem's `unu resample` does; σ is the
//! output voxel's size along that input axis in input voxels: the norm of
//! the row of the index-to-index Jacobian, `σ_a = sqrt(Σ_b (R_ab·s'_b/s_a)²)`
//! with `R = D⁻¹·D'`. On an axis-aligned grid that is `s'_a/s_a`; on a
//! rotated grid with isotropic output spacing it is `s'/s_a` whatever the
//! rotation. Only σ > 1 widens; `nearest` and `label` are never widened
//! (`label` uses σ for the box it takes the majority of).
//!
//! Two paths. When the output's directions equal the input's the kernel
//! runs separably from per-axis weight tables (z first, folding the
//! needed input slices into one in-plane slice, then y, then x), reading
//! only the z support of each output slice. Otherwise (a rotated grid)
//! every voxel evaluates the tensor product; an output slice reads the z
//! range its preimage spans plus the kernel's reach, and the largest such
//! range is the stage's window (the chain copies the input to disk when
//! that is too big for the budget). On a rotated grid `bspline3` costs
//! 26³ taps per voxel (its prefilter is folded into the kernel): correct
//! but slow.

mod general;
mod kernel;
mod label;
mod separable;
mod spec;
#[cfg(test)]
mod tests;

pub use kernel::{Kernel, KERNEL_NAMES, PREFILTER_HALF};
pub use spec::{target_grid, ResampleSpec, MAX_OUTPUT_VOXELS};

use crate::grid::Grid;
use crate::stage::{Slab, Stage};
use kernel::AxisSampler;
use std::ops::Range;

/// ITK's inside test on one axis of `n` voxels: `−0.5 <= c < n − 0.5`
/// (NaN is outside).
#[inline]
pub(crate) fn inside(c: f64, n: u64) -> bool {
    c >= -0.5 && c < n as f64 - 0.5
}

/// Output index → continuous input index: `c = c0 + J·u`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Affine {
    c0: [f64; 3],
    /// `j[a][b]`: the change of input index a per output index b.
    j: [[f64; 3]; 3],
}

impl Affine {
    fn between(input: &Grid, output: &Grid) -> Affine {
        let c0 = input.index(output.world([0.0; 3]));
        let j = std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                let mut u = [0.0; 3];
                u[b] = 1.0;
                input.index(output.world(u))[a] - c0[a]
            })
        });
        Affine { c0, j }
    }

    /// The continuous input index of output index `u`.
    #[inline]
    pub(crate) fn at(&self, u: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| {
            self.c0[a] + self.j[a][0] * u[0] + self.j[a][1] * u[1] + self.j[a][2] * u[2]
        })
    }

    /// The change of the input index per output index `b`.
    #[inline]
    pub(crate) fn column(&self, b: usize) -> [f64; 3] {
        [self.j[0][b], self.j[1][b], self.j[2][b]]
    }

    /// The output voxel's size along input axis `a`, in input voxels.
    fn scale(&self, a: usize) -> f64 {
        self.j[a].iter().map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// The input z slices each output slice reads, half-open.
pub(crate) struct ZNeed {
    ranges: Vec<(u64, u64)>,
}

impl ZNeed {
    pub(crate) fn new(ranges: Vec<(u64, u64)>) -> ZNeed {
        ZNeed { ranges }
    }

    /// Whether both ends never decrease with the output z (the chain's
    /// contract for `needs`).
    fn monotone(&self) -> bool {
        self.ranges
            .windows(2)
            .all(|w| w[1].0 >= w[0].0 && w[1].1 >= w[0].1)
    }

    /// The z range of an output slice whose voxels map to `cz` in
    /// `[cmin, cmax]`, reading `reach` input voxels around it (only
    /// inside voxels are evaluated, so `c` is clipped to the box first).
    fn around(cmin: f64, cmax: f64, reach: f64, nz: u64) -> (u64, u64) {
        let last = nz as i64 - 1;
        let lo = cmin.max(-0.5);
        let hi = cmax.min(nz as f64 - 0.5);
        let a = ((lo - reach).floor() as i64).clamp(0, last);
        let b = ((hi + reach).ceil() as i64).clamp(0, last).max(a);
        (a as u64, b as u64 + 1)
    }
}

/// The resampling stage: see the module documentation for the semantics.
pub struct Resample {
    input: Grid,
    output: Grid,
    kernel: Kernel,
    background: f32,
    plan: Plan,
    need: ZNeed,
    /// Every output slice reads the whole input (the z ranges move down
    /// as the output z moves up: a flipped or reversed z).
    whole: bool,
    window: u64,
}

enum Plan {
    Separable(separable::Separable),
    General(general::General),
    Label(label::Label),
}

impl Resample {
    /// A stage resampling `input` onto `output` with `kernel`, widening it
    /// when downsampling if `antialias`; voxels outside the input get
    /// `background`. `Ok(None)` when the grids are the same (the input is
    /// the output, bit for bit: add no stage). Refuses grids with a
    /// spacing that is not positive and finite.
    pub fn new(
        input: Grid,
        output: Grid,
        kernel: Kernel,
        antialias: bool,
        background: f32,
    ) -> Result<Option<Resample>, String> {
        for (what, g) in [("input", &input), ("output", &output)] {
            if g.spacing.iter().any(|s| !s.is_finite() || *s <= 0.0) {
                return Err(format!(
                    "resample: the {what} grid {} has a spacing that is not positive and finite",
                    g.describe()
                ));
            }
        }
        if output.same_as(&input) {
            return Ok(None);
        }
        let map = Affine::between(&input, &output);
        if map
            .c0
            .iter()
            .chain(map.j.iter().flatten())
            .any(|v| !v.is_finite())
        {
            return Err(format!(
                "resample: cannot map {} onto {}",
                output.describe(),
                input.describe()
            ));
        }
        let n_in = input.dims.as_array();
        let n_out = output.dims.as_array();
        let scale: [f64; 3] = std::array::from_fn(|a| map.scale(a));
        let sigma = scale.map(|s| if antialias { s } else { 1.0 });
        let samplers: [AxisSampler; 3] =
            std::array::from_fn(|a| AxisSampler::new(n_in[a], kernel, sigma[a]));
        let aligned = (0..3).all(|r| {
            (0..3).all(|c| {
                (input.geometry.direction[r][c] - output.geometry.direction[r][c]).abs() <= 1e-9
            })
        });
        let (plan, need) = if kernel == Kernel::Label || !aligned {
            // Per voxel: the z range of each output slice's preimage.
            let reach = if kernel == Kernel::Label {
                (scale[2] / 2.0).max(0.5)
            } else {
                samplers[2].reach()
            };
            let [nx, ny] = [n_out[0] as f64 - 1.0, n_out[1] as f64 - 1.0];
            let ranges = (0..n_out[2])
                .map(|z| {
                    let zf = z as f64;
                    let cz = [[0.0, 0.0], [nx, 0.0], [0.0, ny], [nx, ny]]
                        .map(|[x, y]| map.at([x, y, zf])[2]);
                    let lo = cz.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = cz.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    ZNeed::around(lo, hi, reach, n_in[2])
                })
                .collect();
            let plan = if kernel == Kernel::Label {
                Plan::Label(label::Label {
                    map,
                    sigma: scale,
                    n_in,
                })
            } else {
                Plan::General(general::General {
                    map,
                    s: samplers,
                    kernel,
                    n_in,
                })
            };
            (plan, ZNeed::new(ranges))
        } else {
            let c0 = map.c0;
            let step = [map.j[0][0], map.j[1][1], map.j[2][2]];
            let sep = separable::Separable::new(&samplers, n_out, n_in, c0, step);
            let need = sep.z_need();
            (Plan::Separable(sep), need)
        };
        let whole = !need.monotone();
        let window = if whole {
            input.dims.z
        } else {
            need.ranges.iter().map(|(a, b)| b - a).max().unwrap_or(1)
        };
        Ok(Some(Resample {
            input,
            output,
            kernel,
            background,
            plan,
            need,
            whole,
            window,
        }))
    }

    /// The kernel this stage uses.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The grid this stage reads.
    pub fn input(&self) -> Grid {
        self.input
    }

    /// Whether the separable (axis-aligned) path runs.
    pub fn is_separable(&self) -> bool {
        matches!(self.plan, Plan::Separable(_))
    }
}

impl Stage for Resample {
    fn name(&self) -> &str {
        "resample"
    }

    fn output(&self) -> Grid {
        self.output
    }

    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        if self.whole {
            return 0..self.input.dims.z;
        }
        let r = &self.need.ranges;
        let last = r.len() as u64 - 1;
        let a = zs.start.min(last) as usize;
        let b = zs.end.saturating_sub(1).clamp(zs.start.min(last), last) as usize;
        let lo = r[a..=b].iter().map(|p| p.0).min().unwrap_or(0);
        let hi = r[a..=b].iter().map(|p| p.1).max().unwrap_or(lo);
        lo..hi
    }

    fn window(&self) -> u64 {
        self.window
    }

    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let nx = self.output.dims.x as usize;
        let bg = self.background;
        match &self.plan {
            Plan::Separable(p) => p.run(z, input, out, nx, bg),
            Plan::General(p) => p.run(z, input, out, nx, bg),
            Plan::Label(p) => p.run(z, input, out, nx, bg),
        }
        Ok(())
    }
}
