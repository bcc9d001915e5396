//! Tests of the resampling stage, through a tiny driver that hands each
//! output slice exactly the input slices `needs` names.

use super::*;
use crate::stage::Slab;
use volcore::{Dims, Geometry};

fn grid(n: [u64; 3], s: [f64; 3], g: Geometry) -> Grid {
    Grid {
        dims: Dims::new(n[0], n[1], n[2]).unwrap(),
        spacing: s,
        geometry: g,
    }
}

fn rotated(origin: [f64; 3]) -> Geometry {
    // A rotation about a skew axis (orthonormal columns).
    let (a, b) = (0.3f64, 0.5f64);
    let rz = [
        [a.cos(), -a.sin(), 0.0],
        [a.sin(), a.cos(), 0.0],
        [0.0, 0.0, 1.0],
    ];
    let rx = [
        [1.0, 0.0, 0.0],
        [0.0, b.cos(), -b.sin()],
        [0.0, b.sin(), b.cos()],
    ];
    let m: [[f64; 3]; 3] =
        std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| rz[r][k] * rx[k][c]).sum()));
    let axes = std::array::from_fn(|c| [m[0][c], m[1][c], m[2][c]]);
    Geometry::from_axes(origin, axes).unwrap()
}

/// The volume as z slices, from a function of the voxel index.
fn volume(g: &Grid, mut f: impl FnMut(usize, usize, usize) -> f32) -> Vec<Vec<f32>> {
    let [nx, ny, nz] = g.dims.as_array().map(|v| v as usize);
    let mut v = Vec::with_capacity(nz);
    for k in 0..nz {
        let mut s = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                s.push(f(i, j, k));
            }
        }
        v.push(s);
    }
    v
}

/// Runs a stage slice by slice, each from only the slices it needs.
fn drive(st: &dyn Stage, input: &Grid, vol: &[Vec<f32>]) -> Vec<Vec<f32>> {
    let out = st.output();
    let n = out.dims.slice_len() as usize;
    (0..out.dims.z)
        .map(|z| {
            let r = st.needs(z..z + 1);
            assert!(r.end <= input.dims.z && r.start < r.end, "{r:?}");
            assert!(r.end - r.start <= st.window(), "{r:?} > {}", st.window());
            let refs = vol[r.start as usize..r.end as usize]
                .iter()
                .map(|v| v.as_slice())
                .collect();
            let slab = Slab::new(r.start, input.dims, refs);
            let mut o = vec![f32::NAN; n];
            st.run(z, &slab, &mut o).unwrap();
            o
        })
        .collect()
}

fn resample(
    input: &Grid,
    vol: &[Vec<f32>],
    out: Grid,
    k: Kernel,
    aa: bool,
) -> (Resample, Vec<Vec<f32>>) {
    let st = Resample::new(*input, out, k, aa, -7.0).unwrap().unwrap();
    let v = drive(&st, input, vol);
    (st, v)
}

/// Output voxels (index, continuous input index) at least `margin` input
/// voxels inside the input on every axis.
fn interior(input: &Grid, out: &Grid, margin: f64) -> Vec<([usize; 3], [f64; 3])> {
    let n = input.dims.as_array().map(|v| v as f64);
    let d = out.dims.as_array();
    let mut v = Vec::new();
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                let c = input.index(out.world([i as f64, j as f64, k as f64]));
                if (0..3).all(|a| c[a] >= margin && c[a] <= n[a] - 1.0 - margin) {
                    v.push(([i as usize, j as usize, k as usize], c));
                }
            }
        }
    }
    v
}

fn at(vol: &[Vec<f32>], g: &Grid, ijk: [usize; 3]) -> f32 {
    vol[ijk[2]][ijk[1] * g.dims.x as usize + ijk[0]]
}

#[test]
fn same_grid_adds_no_stage() {
    let g = grid([4, 5, 6], [0.5, 0.7, 2.0], rotated([1.0, 2.0, 3.0]));
    for k in Kernel::ALL {
        for aa in [false, true] {
            assert!(Resample::new(g, g, k, aa, 0.0).unwrap().is_none());
        }
    }
}

#[test]
fn ramps_are_reproduced_at_several_scales() {
    let g = grid([40, 36, 34], [0.5, 0.7, 2.0], rotated([1.0, -2.0, 3.0]));
    let ramp = |c: [f64; 3]| (0.3 * c[0] - 0.2 * c[1] + 0.1 * c[2] + 5.0) as f32;
    let vol = volume(&g, |i, j, k| ramp([i as f64, j as f64, k as f64]));
    for spec in [
        ResampleSpec::Spacing([0.35, 1.1, 1.3]),
        ResampleSpec::Spacing([1.0, 1.4, 4.0]),
        ResampleSpec::Dims([23, 50, 29]),
    ] {
        let out = target_grid(&g, &spec).unwrap();
        for k in [Kernel::Linear, Kernel::Cubic, Kernel::BSpline3] {
            let (st, v) = resample(&g, &vol, out, k, false);
            assert!(st.is_separable());
            let pts = interior(&g, &out, k.radius() + 1.0);
            assert!(!pts.is_empty(), "{k} {spec:?}");
            for (u, c) in pts {
                let (got, want) = (at(&v, &out, u), ramp(c));
                assert!(
                    (got - want).abs() < 2e-4,
                    "{k} {spec:?} {u:?}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn antialiased_linear_reproduces_ramps_at_integer_scales() {
    let g = grid([40, 30, 24], [0.5, 0.5, 1.0], Geometry::IDENTITY);
    let ramp = |c: [f64; 3]| (0.3 * c[0] - 0.2 * c[1] + 0.1 * c[2] + 5.0) as f32;
    let vol = volume(&g, |i, j, k| ramp([i as f64, j as f64, k as f64]));
    let out = target_grid(&g, &ResampleSpec::Spacing([1.0, 1.5, 3.0])).unwrap();
    for k in [Kernel::Linear, Kernel::Cubic] {
        let (_, v) = resample(&g, &vol, out, k, true);
        for (u, c) in interior(&g, &out, 3.0 * k.radius() + 1.0) {
            let (got, want) = (at(&v, &out, u), ramp(c));
            assert!((got - want).abs() < 2e-4, "{k} {u:?}: {got} vs {want}");
        }
    }
}

#[test]
fn separable_equals_general_on_an_axis_aligned_grid() {
    let g = grid([21, 17, 15], [0.5, 0.7, 2.0], rotated([1.0, -2.0, 3.0]));
    let mut rng = fastrand::Rng::with_seed(5);
    let vol = volume(&g, |_, _, _| rng.f32() * 10.0 - 3.0);
    for spec in [
        ResampleSpec::Spacing([0.35, 1.3, 1.15]),
        ResampleSpec::Dims([9, 30, 40]),
    ] {
        let out = target_grid(&g, &spec).unwrap();
        // Nudge the output by a hair of rotation so the general path runs.
        let mut tilted = out;
        tilted.geometry.direction[0][1] += 1e-8;
        for k in [
            Kernel::Nearest,
            Kernel::Linear,
            Kernel::Cubic,
            Kernel::BSpline3,
            Kernel::Lanczos3,
        ] {
            for aa in [false, true] {
                let (s1, a) = resample(&g, &vol, out, k, aa);
                let (s2, b) = resample(&g, &vol, tilted, k, aa);
                assert!(s1.is_separable() && !s2.is_separable());
                let d = out.dims.as_array().map(|v| v as usize);
                for (i, (x, y)) in a.iter().flatten().zip(b.iter().flatten()).enumerate() {
                    let u = [i % d[0], i / d[0] % d[1], i / d[0] / d[1]];
                    assert!(
                        (x - y).abs() < 1e-5 * 10.0,
                        "{k} {aa} {spec:?} {u:?}: {x} vs {y}"
                    );
                }
            }
        }
    }
}

#[test]
fn nyquist_checkerboard_is_removed_by_antialiasing() {
    // 65 voxels at spacing 1 to spacing 2: 33 voxels centred on input
    // voxels 0, 2, .., 64, where a non-widened kernel picks ±1. (With an
    // even count the centres fall half-way, where any symmetric kernel
    // averages the checkerboard to 0 with or without antialiasing.)
    let g = grid([65, 65, 65], [1.0; 3], Geometry::IDENTITY);
    let vol = volume(&g, |i, j, k| if (i + j + k) % 2 == 0 { 1.0 } else { -1.0 });
    let out = target_grid(&g, &ResampleSpec::Spacing([2.0; 3])).unwrap();
    assert_eq!(out.dims.as_array(), [33, 33, 33]);
    for k in [
        Kernel::Linear,
        Kernel::Cubic,
        Kernel::BSpline3,
        Kernel::Lanczos3,
    ] {
        let (_, with) = resample(&g, &vol, out, k, true);
        let (_, without) = resample(&g, &vol, out, k, false);
        let mut worst_aliased = 0.0f32;
        for (u, _) in interior(&g, &out, 2.0 * k.radius() + 1.0) {
            assert!(
                at(&with, &out, u).abs() < 0.05,
                "{k} {u:?}: {}",
                at(&with, &out, u)
            );
            worst_aliased = worst_aliased.max(at(&without, &out, u).abs());
        }
        assert!(worst_aliased > 0.9, "{k}: {worst_aliased}");
    }
}

#[test]
fn labels_survive_upsampling_and_downsampling_back() {
    let g = grid([9, 8, 7], [0.8, 1.0, 1.5], rotated([0.0; 3]));
    let mut rng = fastrand::Rng::with_seed(9);
    let vol = volume(&g, |_, _, _| rng.u8(0..6) as f32 * 10.0);
    let up = target_grid(&g, &ResampleSpec::Spacing([0.4, 0.5, 0.75])).unwrap();
    assert_eq!(up.dims.as_array(), [18, 16, 14]);
    let (_, v_up) = resample(&g, &vol, up, Kernel::Label, true);
    let (_, back) = resample(&up, &v_up, g, Kernel::Label, true);
    assert_eq!(back, vol);
}

#[test]
fn label_takes_the_majority_of_the_covered_box() {
    let g = grid([4, 2, 2], [1.0; 3], Geometry::IDENTITY);
    // x pairs (0,1) and (2,3); each 2x2x2 box has labels 3 and 5.
    let vol = volume(&g, |i, j, k| match (i / 2, (i + j + k) % 4) {
        (0, 0) => 5.0,
        (0, _) => 3.0,
        (_, 0 | 1) => 5.0,
        _ => 3.0,
    });
    let out = target_grid(&g, &ResampleSpec::Dims([2, 1, 1])).unwrap();
    let (_, v) = resample(&g, &vol, out, Kernel::Label, true);
    // Box 0: 3 appears 6 times; box 1: a tie 4:4 goes to 3.
    assert_eq!(v[0], vec![3.0, 3.0]);
}

#[test]
fn bspline3_interpolates_the_samples() {
    let g = grid([30, 28, 30], [0.5, 0.7, 2.0], rotated([1.0, -2.0, 3.0]));
    let mut rng = fastrand::Rng::with_seed(3);
    let vol = volume(&g, |_, _, _| rng.f32());
    let mut out = g;
    out.geometry.origin = g.world([3.0, -2.0, 1.0]);
    let (_, v) = resample(&g, &vol, out, Kernel::BSpline3, true);
    for k in 0..29 {
        for j in 2..28 {
            for i in 0..27 {
                let (got, want) = (at(&v, &out, [i, j, k]), at(&vol, &g, [i + 3, j - 2, k + 1]));
                assert!((got - want).abs() < 1e-5, "{i},{j},{k}: {got} vs {want}");
            }
        }
    }
}

#[test]
fn target_grid_keeps_the_box_centre() {
    let g = grid([10, 7, 5], [0.5, 0.9, 2.5], rotated([4.0, -1.0, 2.0]));
    let centre = |g: &Grid| g.world(g.dims.as_array().map(|n| (n as f64 - 1.0) / 2.0));
    let c0 = centre(&g);
    let s = target_grid(&g, &ResampleSpec::Spacing([1.0, 1.0, 1.0])).unwrap();
    assert_eq!(s.dims.as_array(), [5, 6, 13]); // round(5), round(6.3), round(12.5)
    assert_eq!(s.spacing, [1.0; 3]);
    assert_eq!(s.geometry.direction, g.geometry.direction);
    let d = target_grid(&g, &ResampleSpec::Dims([3, 4, 20])).unwrap();
    assert_eq!(d.spacing, [5.0 / 3.0, 6.3 / 4.0, 12.5 / 20.0]);
    for o in [s, d] {
        let c = centre(&o);
        for a in 0..3 {
            assert!((c[a] - c0[a]).abs() < 1e-12, "{c:?} vs {c0:?}");
        }
    }
    // The formula: origin + D·((n−1)s − (n'−1)s')/2.
    let shift = [
        (9.0 * 0.5 - 4.0) / 2.0,
        (6.0 * 0.9 - 5.0) / 2.0,
        (4.0 * 2.5 - 12.0) / 2.0,
    ];
    let want = g.world([shift[0] / 0.5, shift[1] / 0.9, shift[2] / 2.5]);
    for (o, w) in s.geometry.origin.iter().zip(want) {
        assert!((o - w).abs() < 1e-12, "{o} vs {w}");
    }
}

#[test]
fn outside_voxels_get_the_background_and_itk_edges_hold() {
    let g = grid([6, 5, 4], [1.0; 3], Geometry::IDENTITY);
    let vol = volume(&g, |i, j, k| (i + 10 * j + 100 * k) as f32);
    // Output x centres at input x = -1, -0.5, 0, 0.5, .., 5.5: -1 and 5.5
    // are outside (ITK: -0.5 <= c < n - 0.5); 0.5 rounds up to 1.
    let mut out = grid([14, 5, 4], [0.5, 1.0, 1.0], Geometry::IDENTITY);
    out.geometry.origin = [-1.0, 0.0, 0.0];
    let mut tilted = out;
    tilted.geometry.direction[1][0] += 1e-9;
    tilted.geometry.direction[0][1] -= 1e-9;
    for o in [out, tilted] {
        let (_, v) = resample(&g, &vol, o, Kernel::Nearest, true);
        let row: Vec<f32> = v[2][2 * 14..3 * 14].to_vec();
        let want = [
            -7.0, 220.0, 220.0, 221.0, 221.0, 222.0, 222.0, 223.0, 223.0, 224.0, 224.0, 225.0,
            225.0, -7.0,
        ];
        assert_eq!(row, want);
        let (_, v) = resample(&g, &vol, o, Kernel::Linear, false);
        let row: Vec<f32> = v[2][2 * 14..3 * 14].to_vec();
        let want = [
            -7.0, 220.0, 220.0, 220.5, 221.0, 221.5, 222.0, 222.5, 223.0, 223.5, 224.0, 224.5,
            225.0, -7.0,
        ];
        for (a, b) in row.iter().zip(want) {
            assert!((a - b).abs() < 1e-4, "{row:?}");
        }
    }
    // A grid entirely beside the input is all background.
    let mut far = g;
    far.geometry.origin = [100.0, 0.0, 0.0];
    let (_, v) = resample(&g, &vol, far, Kernel::Cubic, true);
    assert!(v.iter().flatten().all(|&x| x == -7.0));
}

/// ITK's linear interpolation, written out: clamp the taps, weights
/// `1 − f` and `f`, in f64.
fn itk_linear(vol: &[Vec<f32>], g: &Grid, c: [f64; 3]) -> f64 {
    let n = g.dims.as_array().map(|v| v as i64);
    let b: [i64; 3] = std::array::from_fn(|a| c[a].floor() as i64);
    let mut acc = 0.0;
    for corner in 0..8 {
        let mut w = 1.0;
        let mut ijk = [0usize; 3];
        for a in 0..3 {
            let up = (corner >> a) & 1 == 1;
            let f = c[a] - b[a] as f64;
            w *= if up { f } else { 1.0 - f };
            ijk[a] = (b[a] + up as i64).clamp(0, n[a] - 1) as usize;
        }
        acc += w * at(vol, g, ijk) as f64;
    }
    acc
}

#[test]
fn rotated_linear_and_nearest_follow_itk() {
    let g = grid([16, 14, 12], [0.5, 0.7, 2.0], rotated([1.0, -2.0, 3.0]));
    let mut rng = fastrand::Rng::with_seed(11);
    let vol = volume(&g, |_, _, _| rng.f32() * 100.0);
    // An output grid rotated against the input, anisotropic, overlapping.
    let mut out = grid([15, 13, 11], [0.6, 0.8, 1.1], Geometry::IDENTITY);
    out.geometry.origin = g.world([-1.0, 1.0, 2.0]);
    for (k, aa) in [(Kernel::Linear, false), (Kernel::Nearest, true)] {
        let (st, v) = resample(&g, &vol, out, k, aa);
        assert!(!st.is_separable());
        let mut checked = 0;
        let n = g.dims.as_array();
        for kk in 0..11 {
            for j in 0..13 {
                for i in 0..15 {
                    let c = g.index(out.world([i as f64, j as f64, kk as f64]));
                    let got = at(&v, &out, [i, j, kk]) as f64;
                    if !(0..3).all(|a| inside(c[a], n[a])) {
                        assert_eq!(got, -7.0);
                        continue;
                    }
                    checked += 1;
                    let want = if k == Kernel::Linear {
                        itk_linear(&vol, &g, c)
                    } else {
                        let ijk = std::array::from_fn(|a| (c[a] + 0.5).floor() as usize);
                        at(&vol, &g, ijk) as f64
                    };
                    assert!(
                        (got - want).abs() < 1e-4 * 100.0,
                        "{k} {i},{j},{kk}: {got} vs {want}"
                    );
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }
}

#[test]
fn rotated_needs_are_a_window_that_moves_up() {
    let g = grid([40, 40, 60], [1.0; 3], Geometry::IDENTITY);
    let out = grid([30, 30, 50], [1.0; 3], rotated([5.0, 5.0, 5.0]));
    let st = Resample::new(g, out, Kernel::Linear, true, 0.0)
        .unwrap()
        .unwrap();
    let mut last = st.needs(0..1);
    for z in 1..50 {
        let r = st.needs(z..z + 1);
        assert!(r.start >= last.start && r.end >= last.end);
        assert!(r.end - r.start <= st.window());
        last = r;
    }
    assert!(st.window() < 60, "{}", st.window());
    // A reversed z reads everything.
    let mut flipped = g;
    flipped.geometry.direction[2][2] = -1.0;
    let st = Resample::new(g, flipped, Kernel::Linear, true, 0.0)
        .unwrap()
        .unwrap();
    assert_eq!(st.window(), 60);
    assert_eq!(st.needs(3..4), 0..60);
}

#[test]
fn a_chain_gives_what_the_driver_gives() {
    use crate::chain::{Chain, Source};
    let g = grid([20, 18, 16], [0.5, 0.7, 2.0], rotated([1.0, -2.0, 3.0]));
    let mut rng = fastrand::Rng::with_seed(21);
    let vol = volume(&g, |_, _, _| rng.f32());
    let mut out = grid([12, 14, 17], [0.9, 0.8, 1.1], Geometry::IDENTITY);
    out.geometry.origin = g.world([2.0, 1.0, 1.0]);
    for k in [Kernel::Linear, Kernel::Cubic, Kernel::Label] {
        let (st, want) = resample(&g, &vol, out, k, true);
        let source: Source<'_, String> =
            Box::new(|zs: Range<u64>| Ok(zs.map(|z| vol[z as usize].clone()).collect()));
        let mut chain = Chain::new(g, source, vec![Box::new(st)], &std::env::temp_dir());
        for z0 in (0..17).step_by(5) {
            let zs = z0..(z0 + 5).min(17);
            let s = chain.slices(zs.clone()).unwrap();
            for z in zs {
                assert_eq!(s.slice(z), want[z as usize].as_slice(), "{k} {z}");
            }
        }
    }
}

/// Linear 512×512×300 at 0.5,0.5,2 to spacing 1 through a Chain (run:
/// `cargo test --release -p volprep bench_linear -- --ignored --nocapture`).
#[test]
#[ignore]
fn bench_linear_512x512x300_to_1mm() {
    use crate::chain::{Chain, Source};
    use std::time::Instant;
    let g = grid([512, 512, 300], [0.5, 0.5, 2.0], Geometry::IDENTITY);
    let vol = volume(&g, |i, j, k| ((i * 7 + j * 3 + k * 5) % 1000) as f32);
    let out = target_grid(&g, &ResampleSpec::Spacing([1.0; 3])).unwrap();
    // The first run has no stage: the cost of the source (copying the
    // input slices), which the other runs include.
    // Last, the same output grid rotated about its centre (the general
    // path).
    let mut tilted = out;
    tilted.geometry = rotated([0.0; 3]);
    let c_in = g.world(g.dims.as_array().map(|n| (n as f64 - 1.0) / 2.0));
    let c_out = tilted.world(tilted.dims.as_array().map(|n| (n as f64 - 1.0) / 2.0));
    for (o, (a, b)) in tilted
        .geometry
        .origin
        .iter_mut()
        .zip(c_in.iter().zip(c_out))
    {
        *o += a - b;
    }
    let runs = [
        (None, out),
        (Some(true), out),
        (Some(false), out),
        (Some(true), out),
        (Some(false), out),
        (None, out),
        (Some(true), tilted),
        (Some(false), tilted),
    ];
    for (aa, target) in runs {
        let stages: Vec<Box<dyn Stage>> = match aa {
            Some(aa) => vec![Box::new(
                Resample::new(g, target, Kernel::Linear, aa, 0.0)
                    .unwrap()
                    .unwrap(),
            )],
            None => vec![],
        };
        let rot = target.geometry.direction != g.geometry.direction;
        let source: Source<'_, String> =
            Box::new(|zs: Range<u64>| Ok(zs.map(|z| vol[z as usize].clone()).collect()));
        let mut chain = Chain::new(g, source, stages, &std::env::temp_dir());
        let out = chain.output();
        let t = Instant::now();
        let mut sum = 0.0f64;
        let nz = out.dims.z;
        let mut z = 0;
        while z < nz {
            let e = (z + 16).min(nz);
            let s = chain.slices(z..e).unwrap();
            for zz in z..e {
                sum += s.slice(zz)[1000] as f64;
            }
            z = e;
        }
        let dt = t.elapsed().as_secs_f64();
        let mv = out.dims.count() as f64 / 1e6;
        println!(
            "linear antialias={aa:?} rotated={rot}: {} -> {}: {dt:.3} s, {:.0} Mvoxel/s out ({} threads) [{sum}]",
            g.dims,
            out.dims,
            mv / dt,
            rayon::current_num_threads()
        );
    }
}
