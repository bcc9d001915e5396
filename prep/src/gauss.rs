//! `--smooth gauss:SIGMA`: separable Gaussian smoothing with σ in the
//! grid's physical unit, per axis.
//!
//! - **σ per axis**: σ is physical (mm, µm, ...); along axis `a` the
//!   filter works in voxels, σ_a / spacing_a, so anisotropic spacing is
//!   smoothed isotropically in space. σ = 0 on an axis leaves that axis
//!   alone.
//! - **Truncation**: the kernel along axis `a` has radius
//!   `r_a = ceil(4·σ_a/s_a)` voxels (at least 4σ), or 4 voxels when
//!   σ_a/s_a is below one voxel (so the fitted kernel below has room).
//!   A Gaussian truncated at ±4σ loses erfc(4/√2) ≈ 6.3e-5 of its mass
//!   (the kernel is renormalised to sum 1, so a constant stays constant).
//! - **Weights**: the response to a sinusoid of wavelength λ should be
//!   the continuous Gaussian's, exp(−2π²σ²/λ²).
//!   - σ_a/s_a ≥ 1 voxel: the sampled Gaussian exp(−n²/2σ²) normalised
//!     to sum 1. Its response differs from exp(−σ²ω²/2) by the aliased
//!     copies of the Gaussian's spectrum, ≤ 2e-4 for wavelengths of 3
//!     voxels or more at σ = 1 voxel and ≤ 6e-5 from σ = 1.2 voxels on
//!     (the truncation's share), e^(−σ²π²/2) at the Nyquist limit.
//!   - σ_a/s_a < 1 voxel: the sampled Gaussian is far off there (1e-2 at
//!     λ = 8 voxels for σ = 0.5 voxel: its spectrum overlaps its alias),
//!     and so is the discrete Gaussian of modified Bessel functions
//!     (ITK's DiscreteGaussian), whose response is exp(−σ²(1 − cos ω)),
//!     not exp(−σ²ω²/2). So the 9 weights are the least-squares fit of
//!     exp(−σ²ω²/2) over ω ∈ [0, 2π/3] (wavelengths of 3 voxels or
//!     more), with sum 1: within 2.5e-4 of the continuous response there
//!     for every σ < 1 voxel (9e-4 for λ ≥ 2.4 voxels; near Nyquist it
//!     passes more than the Gaussian, e.g. 0.38 instead of 0.29 at
//!     σ = 0.5 voxel). The fitted kernel may hold small negative weights
//!     (at most about 1% of the total), so a step can overshoot by as
//!     much.
//! - **Borders**: replicate (indices clamped, ITK's ZeroFluxNeumann), the
//!   rule of every stage.
//! - **Order and precision**: z first over the `2·r_z + 1` slices around
//!   the output slice, then y and x within the slice; f32 samples, f32
//!   weights computed in f64.

use crate::grid::Grid;
use crate::stage::{Slab, Stage, SLAB_BUDGET};
use std::ops::Range;

/// The largest σ in voxels along one axis: past it a kernel of
/// `8σ + 1` taps per voxel would be meaningless and slow.
pub const MAX_SIGMA_VOXELS: f64 = 1000.0;

/// Parse `gauss:SIGMA` or `gauss:SX,SY,SZ` (σ in the output grid's
/// physical unit, per axis). Refuses negative, NaN or infinite σ and an
/// all-zero σ; σ = 0 on one axis means no smoothing along it.
pub fn parse_gauss(s: &str) -> Result<[f64; 3], String> {
    let Some(rest) = s.strip_prefix("gauss:") else {
        return Err(format!(
            "--smooth {s}: expected gauss:SIGMA or gauss:SX,SY,SZ (sigma in the grid's unit)"
        ));
    };
    let parts: Vec<&str> = rest.split(',').map(str::trim).collect();
    let parsed: Result<Vec<f64>, String> = parts
        .iter()
        .map(|p| {
            p.parse::<f64>()
                .map_err(|_| format!("--smooth {s}: {p:?} is not a number"))
        })
        .collect();
    let v = parsed?;
    let sigma = match v.as_slice() {
        [a] => [*a; 3],
        [x, y, z] => [*x, *y, *z],
        _ => {
            return Err(format!(
                "--smooth {s}: give one sigma or three (gauss:SIGMA or gauss:SX,SY,SZ)"
            ))
        }
    };
    check_sigma(&sigma).map_err(|e| format!("--smooth {s}: {e}"))?;
    Ok(sigma)
}

/// Why `sigma` is no Gaussian's σ, if it is not.
fn check_sigma(sigma: &[f64; 3]) -> Result<(), String> {
    if let Some(v) = sigma.iter().find(|v| !v.is_finite() || **v < 0.0) {
        return Err(format!(
            "sigma {v} must be a finite number, 0 or more (0: no smoothing along that axis)"
        ));
    }
    if sigma.iter().all(|&v| v == 0.0) {
        return Err("sigma is 0 along every axis, which smooths nothing".into());
    }
    Ok(())
}

/// Separable Gaussian smoothing of one grid (the output grid is the
/// input's). See the module doc for the truncation, weights and border.
pub struct Gauss {
    grid: Grid,
    sigma: [f64; 3],
    radius: [u64; 3],
    /// Weights per axis, `2·r + 1` each, summing to 1.
    weights: [Vec<f32>; 3],
}

impl Gauss {
    /// Smoothing of `input` with σ per axis in the grid's physical unit.
    /// Refuses a bad σ or spacing, a σ past [`MAX_SIGMA_VOXELS`] voxels,
    /// and a z window whose slices would not fit half of
    /// [`SLAB_BUDGET`].
    pub fn new(input: Grid, sigma: [f64; 3]) -> Result<Gauss, String> {
        let flag = || format!("--smooth gauss:{},{},{}", sigma[0], sigma[1], sigma[2]);
        check_sigma(&sigma).map_err(|e| format!("{}: {e}", flag()))?;
        let mut radius = [0u64; 3];
        let mut weights: [Vec<f32>; 3] = [vec![1.0], vec![1.0], vec![1.0]];
        for a in 0..3 {
            let s = input.spacing[a];
            if !(s.is_finite() && s > 0.0) {
                return Err(format!(
                    "{}: the grid's spacing {s} along {} is not a positive number",
                    flag(),
                    ["x", "y", "z"][a]
                ));
            }
            let sv = sigma[a] / s;
            if sv > MAX_SIGMA_VOXELS {
                return Err(format!(
                    "{}: sigma along {} is {sv:.0} voxels, more than the {MAX_SIGMA_VOXELS} voxels allowed",
                    flag(),
                    ["x", "y", "z"][a]
                ));
            }
            let (r, w) = kernel(sv);
            radius[a] = r;
            weights[a] = w.iter().map(|&v| v as f32).collect();
        }
        let g = Gauss {
            grid: input,
            sigma,
            radius,
            weights,
        };
        let slice_bytes = input.dims.slice_len().saturating_mul(4);
        let bytes = g.window().saturating_mul(slice_bytes);
        if bytes > SLAB_BUDGET / 2 {
            return Err(format!(
                "{}: a window of {} slices of {}x{} f32 ({} MB) does not fit the {} GiB slab budget",
                flag(),
                g.window(),
                input.dims.x,
                input.dims.y,
                bytes / 1_000_000,
                SLAB_BUDGET >> 30
            ));
        }
        Ok(g)
    }

    /// The kernel's radius in voxels per axis (0: no smoothing along it).
    pub fn radius(&self) -> [u64; 3] {
        self.radius
    }

    /// σ per axis in the grid's unit.
    pub fn sigma(&self) -> [f64; 3] {
        self.sigma
    }

    /// The weights along axis `a` (`2·radius[a] + 1`, summing to 1).
    pub fn weights(&self, a: usize) -> &[f32] {
        &self.weights[a]
    }
}

/// Radius and weights (f64, sum 1) of the kernel for σ of `sv` voxels.
fn kernel(sv: f64) -> (u64, Vec<f64>) {
    if sv <= 0.0 {
        return (0, vec![1.0]);
    }
    if sv < 1.0 {
        return (4, fitted(sv, 4));
    }
    let r = (4.0 * sv).ceil() as u64;
    let w: Vec<f64> = (-(r as i64)..=r as i64)
        .map(|n| (-((n * n) as f64) / (2.0 * sv * sv)).exp())
        .collect();
    let sum: f64 = w.iter().sum();
    (r, w.into_iter().map(|v| v / sum).collect())
}

/// The symmetric kernel of radius `r` whose response
/// `h0 + 2 Σ h_k cos kω` is the least-squares fit of exp(−σ²ω²/2) over
/// ω ∈ [0, 2π/3], with `h0 + 2 Σ h_k = 1` (the response at ω = 0 is 1).
fn fitted(sv: f64, r: usize) -> Vec<f64> {
    // Unknowns h_1..h_r; H(ω) − 1 = Σ h_k · 2(cos kω − 1).
    let m = 2048;
    let top = 2.0 * std::f64::consts::PI / 3.0;
    let mut ata = vec![vec![0.0f64; r]; r];
    let mut atb = vec![0.0f64; r];
    for i in 0..m {
        let w = top * (i as f64 + 0.5) / m as f64;
        let t = (-sv * sv * w * w / 2.0).exp() - 1.0;
        let row: Vec<f64> = (1..=r)
            .map(|k| 2.0 * ((k as f64 * w).cos() - 1.0))
            .collect();
        for p in 0..r {
            atb[p] += row[p] * t;
            for q in 0..r {
                ata[p][q] += row[p] * row[q];
            }
        }
    }
    let h = solve(ata, atb);
    let h0 = 1.0 - 2.0 * h.iter().sum::<f64>();
    let mut out: Vec<f64> = h.iter().rev().copied().collect();
    out.push(h0);
    out.extend(h.iter().copied());
    out
}

/// `A x = b` by Gaussian elimination with partial pivoting (small, well
/// posed systems; a zero pivot gives 0 for that unknown).
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        b.swap(c, p);
        let d = a[c][c];
        if d.abs() < 1e-300 {
            continue;
        }
        let pivot = a[c].clone();
        for i in c + 1..n {
            let f = a[i][c] / d;
            for (v, &p) in a[i][c..].iter_mut().zip(&pivot[c..]) {
                *v -= f * p;
            }
            b[i] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for c in (0..n).rev() {
        let d = a[c][c];
        if d.abs() < 1e-300 {
            continue;
        }
        let s: f64 = (c + 1..n).map(|j| a[c][j] * x[j]).sum();
        x[c] = (b[c] - s) / d;
    }
    x
}

impl Stage for Gauss {
    fn name(&self) -> &str {
        "gauss"
    }

    fn output(&self) -> Grid {
        self.grid
    }

    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        let nz = self.grid.dims.z;
        let r = self.radius[2];
        let lo = zs.start.saturating_sub(r).min(nz);
        let hi = zs.end.saturating_add(r).min(nz).max(lo);
        lo..hi
    }

    fn window(&self) -> u64 {
        (2 * self.radius[2] + 1).min(self.grid.dims.z)
    }

    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        let nx = self.grid.dims.x as usize;
        let ny = self.grid.dims.y as usize;
        let n = nx * ny;
        // z: out = Σ_k w_k · slice(z + k − r_z), clamped.
        let rz = self.radius[2] as i64;
        let wz = &self.weights[2];
        let slices: Vec<&[f32]> = (0..wz.len() as i64)
            .map(|k| input.slice_clamped(z as i64 + k - rz))
            .collect();
        let mut a = vec![0.0f32; n];
        for j in 0..ny {
            let row = &mut a[j * nx..(j + 1) * nx];
            for (s, &w) in slices.iter().zip(wz.iter()) {
                for (o, &v) in row.iter_mut().zip(&s[j * nx..(j + 1) * nx]) {
                    *o += w * v;
                }
            }
        }
        // y: out row j = Σ_k w_k · a row (j + k − r_y), clamped.
        let ry = self.radius[1] as i64;
        let wy = &self.weights[1];
        for j in 0..ny {
            let row = &mut out[j * nx..(j + 1) * nx];
            row.fill(0.0);
            for (k, &w) in wy.iter().enumerate() {
                let src = (j as i64 + k as i64 - ry).clamp(0, ny as i64 - 1) as usize;
                for (o, &v) in row.iter_mut().zip(&a[src * nx..(src + 1) * nx]) {
                    *o += w * v;
                }
            }
        }
        // x: each row padded by replicate, then Σ_k w_k · p[x + k].
        let rx = self.radius[0] as usize;
        let wx = &self.weights[0];
        if rx > 0 {
            let mut p = vec![0.0f32; nx + 2 * rx];
            for j in 0..ny {
                let row = &mut out[j * nx..(j + 1) * nx];
                p[..rx].fill(row[0]);
                p[rx..rx + nx].copy_from_slice(row);
                p[rx + nx..].fill(row[nx - 1]);
                row.fill(0.0);
                for (k, &w) in wx.iter().enumerate() {
                    for (o, &v) in row.iter_mut().zip(&p[k..k + nx]) {
                        *o += w * v;
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Chain, Source};
    use volcore::{Dims, Geometry};

    fn grid(d: [u64; 3], spacing: [f64; 3]) -> Grid {
        Grid {
            dims: Dims::new(d[0], d[1], d[2]).unwrap(),
            spacing,
            geometry: Geometry::IDENTITY,
        }
    }

    /// The whole output of `stage` over a source `f(x, y, z)`.
    fn run_all(g: Grid, stage: Box<dyn Stage>, f: &dyn Fn(u64, u64, u64) -> f32) -> Vec<f32> {
        let source: Source<'_, String> = Box::new(|zs: Range<u64>| {
            Ok(zs
                .map(|z| {
                    let mut s = Vec::with_capacity(g.slice_len());
                    for y in 0..g.dims.y {
                        for x in 0..g.dims.x {
                            s.push(f(x, y, z));
                        }
                    }
                    s
                })
                .collect())
        });
        let mut c = Chain::new(g, source, vec![stage], &std::env::temp_dir());
        let o = c.output();
        let mut out = Vec::new();
        let mut z = 0;
        while z < o.dims.z {
            let end = (z + 5).min(o.dims.z);
            let s = c.slices(z..end).unwrap();
            for k in z..end {
                out.extend_from_slice(s.slice(k));
            }
            z = end;
        }
        out
    }

    #[test]
    fn parse_accepts_one_or_three_and_refuses_the_rest() {
        assert_eq!(parse_gauss("gauss:1.5").unwrap(), [1.5; 3]);
        assert_eq!(parse_gauss("gauss:1,0,2").unwrap(), [1.0, 0.0, 2.0]);
        for bad in [
            "gauss:-1",
            "gauss:NaN",
            "gauss:inf",
            "gauss:0",
            "gauss:0,0,0",
            "gauss:1,2",
            "gauss:",
            "box:1",
            "gauss:a",
        ] {
            let e = parse_gauss(bad).unwrap_err();
            assert!(e.starts_with("--smooth "), "{bad}: {e}");
            assert!(!e.contains('\n'));
        }
    }

    #[test]
    fn radius_is_four_sigma_in_voxels_and_weights_sum_to_one() {
        let g = grid([8, 8, 8], [0.5, 0.7, 2.0]);
        let s = Gauss::new(g, [1.0, 1.0, 1.0]).unwrap();
        // 1/0.5 = 2 voxels -> 8; 1/0.7 = 1.43 -> 6; 1/2 = 0.5 -> fitted, 4.
        assert_eq!(s.radius(), [8, 6, 4]);
        for a in 0..3 {
            let w = s.weights(a);
            assert_eq!(w.len() as u64, 2 * s.radius()[a] + 1);
            let sum: f64 = w.iter().map(|&v| v as f64).sum();
            assert!((sum - 1.0).abs() < 1e-6, "{a}: {sum}");
        }
        let s = Gauss::new(g, [0.0, 0.0, 1.0]).unwrap();
        assert_eq!(s.radius(), [0, 0, 4]);
        assert_eq!(s.needs(0..1), 0..5);
        assert_eq!(s.needs(3..5), 0..8);
        assert_eq!(s.window(), 8);
    }

    #[test]
    fn refuses_a_window_over_the_budget() {
        let g = grid([8192, 8192, 4000], [1.0, 1.0, 1.0]);
        let e = Gauss::new(g, [0.0, 0.0, 10.0]).err().unwrap();
        assert!(e.contains("--smooth") && e.contains("1 GiB"), "{e}");
        assert!(Gauss::new(grid([4, 4, 4], [1.0; 3]), [1e6, 1.0, 1.0]).is_err());
    }

    #[test]
    fn a_constant_stays_constant() {
        let g = grid([13, 9, 11], [0.5, 0.7, 2.0]);
        let out = run_all(
            g,
            Box::new(Gauss::new(g, [1.5, 1.0, 1.0]).unwrap()),
            &|_, _, _| 1234.5,
        );
        for v in out {
            assert!((v - 1234.5).abs() <= 1234.5 * 2e-6, "{v}");
        }
    }

    /// A sinusoid of wavelength λ along one axis keeps exp(−2π²σ²/λ²) of
    /// its amplitude, to 1e-3 of it, away from the borders.
    fn sinusoid_along(axis: usize, sigma: f64, lambda: f64) -> f64 {
        let spacing = [0.5, 0.7, 2.0];
        let mut d = [12u64, 12, 12];
        // Long enough along the axis for the kernel and a few periods.
        d[axis] = 64;
        let g = grid(d, spacing);
        let stage = Gauss::new(g, [sigma; 3]).unwrap();
        let r = stage.radius();
        let phase = 0.3;
        let f = move |p: [u64; 3]| {
            let t = p[axis] as f64 * spacing[axis];
            (2.0 * std::f64::consts::PI * t / lambda + phase).sin() as f32
        };
        let out = run_all(g, Box::new(stage), &|x, y, z| f([x, y, z]));
        let keep = (-2.0 * std::f64::consts::PI.powi(2) * sigma * sigma / (lambda * lambda)).exp();
        let mut worst = 0.0f64;
        let (nx, ny) = (d[0], d[1]);
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    let p = [x, y, z];
                    if p[axis] < r[axis] || p[axis] + r[axis] >= d[axis] {
                        continue;
                    }
                    let want = keep * f(p) as f64;
                    let got = out[(x + nx * (y + ny * z)) as usize] as f64;
                    worst = worst.max((got - want).abs());
                }
            }
        }
        worst
    }

    #[test]
    fn a_sinusoid_keeps_the_gaussian_share_of_its_amplitude_along_each_axis() {
        // Spacing 0.5, 0.7, 2.0: σ = 1 is 2, 1.43 and 0.5 voxels; σ = 1.5
        // is 3, 2.14 and 0.75 voxels. Wavelengths from 3 voxels up.
        for sigma in [1.0, 1.5] {
            for (axis, lambdas) in [
                (0, [1.5, 3.0, 6.0]),
                (1, [2.1, 4.0, 9.0]),
                (2, [6.0, 10.0, 24.0]),
            ] {
                for lambda in lambdas {
                    let e = sinusoid_along(axis, sigma, lambda);
                    assert!(e < 1e-3, "axis {axis} sigma {sigma} lambda {lambda}: {e}");
                }
            }
        }
    }

    #[test]
    fn the_kernel_response_is_the_gaussian_s_for_small_and_large_sigma() {
        // Response of the weights against exp(−σ²ω²/2) for ω ≤ 2π/3.
        for sv in [0.1, 0.3, 0.5, 0.75, 0.99, 1.0, 1.2, 2.0, 5.0] {
            let (r, w) = kernel(sv);
            let mut worst = 0.0f64;
            for i in 0..=200 {
                let om = 2.0 * std::f64::consts::PI / 3.0 * i as f64 / 200.0;
                let h: f64 = w
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| v * ((k as f64 - r as f64) * om).cos())
                    .sum();
                worst = worst.max((h - (-sv * sv * om * om / 2.0).exp()).abs());
            }
            let bound = if sv < 1.0 { 2.5e-4 } else { 2e-4 };
            assert!(worst < bound, "sigma {sv} voxels: {worst}");
        }
    }

    #[test]
    fn sigma_zero_on_an_axis_leaves_it_alone() {
        // Smoothing along y only: a function of x and z passes unchanged.
        let g = grid([7, 6, 5], [1.0; 3]);
        let f = |x: u64, _: u64, z: u64| (x * 7 + z * z) as f32;
        let out = run_all(g, Box::new(Gauss::new(g, [0.0, 2.0, 0.0]).unwrap()), &f);
        for z in 0..5 {
            for y in 0..6 {
                for x in 0..7 {
                    let i = (x + 7 * (y + 6 * z)) as usize;
                    assert!((out[i] - f(x, y, z)).abs() < 1e-4);
                }
            }
        }
    }

    #[test]
    fn equals_the_direct_3d_convolution_with_replicated_borders() {
        let d = [9u64, 8, 7];
        let g = grid(d, [0.5, 0.7, 2.0]);
        let stage = Gauss::new(g, [0.8, 1.2, 1.0]).unwrap();
        let r = stage.radius().map(|v| v as i64);
        let w: Vec<Vec<f64>> = (0..3)
            .map(|a| stage.weights(a).iter().map(|&v| v as f64).collect())
            .collect();
        let mut rng = fastrand::Rng::with_seed(5);
        let v: Vec<f32> = (0..d[0] * d[1] * d[2]).map(|_| rng.f32() * 100.0).collect();
        let at = |x: i64, y: i64, z: i64| {
            let c = |p: i64, n: u64| p.clamp(0, n as i64 - 1) as u64;
            v[(c(x, d[0]) + d[0] * (c(y, d[1]) + d[1] * c(z, d[2]))) as usize] as f64
        };
        let out = run_all(g, Box::new(stage), &|x, y, z| {
            v[(x + d[0] * (y + d[1] * z)) as usize]
        });
        for z in 0..d[2] as i64 {
            for y in 0..d[1] as i64 {
                for x in 0..d[0] as i64 {
                    let mut want = 0.0;
                    for k in -r[2]..=r[2] {
                        for j in -r[1]..=r[1] {
                            for i in -r[0]..=r[0] {
                                want += w[0][(i + r[0]) as usize]
                                    * w[1][(j + r[1]) as usize]
                                    * w[2][(k + r[2]) as usize]
                                    * at(x + i, y + j, z + k);
                            }
                        }
                    }
                    let got = out[(x + d[0] as i64 * (y + d[1] as i64 * z)) as usize] as f64;
                    assert!((got - want).abs() < 1e-3, "{x},{y},{z}: {got} {want}");
                }
            }
        }
    }
}
