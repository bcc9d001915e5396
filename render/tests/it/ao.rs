//! Ambient occlusion: closed forms, determinism, costs that are zero when
//! off, and hard cases.

use crate::common::{orbit_camera, shapes};
use glam::Vec3;
use volcore::{Cursor, Dims, Volume, VolumeVisitor, VoxelSource};
use volrender::effects::ao::{AoField, AoLookup, AoSource, Spiral};
use volrender::effects::occlusion_grid::{Intervals, OcclusionGrid};
use volrender::effects::{Occluder, RayEffects};
use volrender::sampler::HashSampler;
use volrender::tf::TransferFunction;
use volrender::{
    render, Ao, AoMethod, Frame, Light, Lighting, Mode, RenderSettings, ShadowMethod, Shadows,
};

/// A medium of one optical depth per `STEP` everywhere, or only at and
/// above `z_from`.
struct Medium {
    depth: f32,
    z_from: f32,
}

const STEP: f32 = 0.5;

impl Occluder for Medium {
    type Query = ();
    fn depth<C: Cursor>(&self, _: &mut C, p: Vec3, _: ()) -> f32 {
        if p.z >= self.z_from {
            self.depth
        } else {
            0.0
        }
    }
}

/// A medium whose optical depth per `STEP` varies smoothly from place to
/// place, from clear to `peak`.
struct Wavy {
    peak: f32,
}

impl Occluder for Wavy {
    type Query = ();
    fn depth<C: Cursor>(&self, _: &mut C, p: Vec3, _: ()) -> f32 {
        let w = (0.31 * p.x).sin() * (0.17 * p.y + 1.0).cos() + (0.23 * p.z).sin();
        self.peak * (0.5 * w).clamp(0.0, 1.0)
    }
}

struct BuildGrid<'a, O>(&'a O);

impl<O: Occluder<Query = ()>> VolumeVisitor for BuildGrid<'_, O> {
    type Output = OcclusionGrid;
    fn visit<S: VoxelSource>(self, src: &S) -> OcclusionGrid {
        OcclusionGrid::build(src, self.0, (), [1.0; 3], STEP, u64::MAX, None).unwrap()
    }
}

const N: usize = 64;

fn grid(sigma: f32, z_from: f32) -> OcclusionGrid {
    let d = Dims::new(N as u64, N as u64, N as u64).unwrap();
    let v = Volume::from_samples(d, vec![0u8; N * N * N]).unwrap();
    v.visit(BuildGrid(&Medium {
        depth: sigma * STEP,
        z_from,
    }))
}

fn hi() -> Vec3 {
    Vec3::splat((N - 1) as f32)
}

/// Occlusion at `p` with normal `n` by `count` rays up to `radius`.
fn by_rays(g: &OcclusionGrid, radius: f32, count: u32, p: Vec3, n: Option<Vec3>) -> f32 {
    let iv = Intervals::new(radius, 2.0, 4.0);
    let spiral = Spiral::new(count);
    let lookup = AoLookup::Rays {
        spiral: &spiral,
        intervals: &iv,
        sampler: HashSampler::new(3),
    };
    let src = AoSource::new(g, lookup, hi(), 4.0);
    let mut fx = RayEffects::default();
    let a = src.occlusion(p, n, [5, 9], 2, &mut fx);
    assert_eq!(fx.ao_rays, count);
    a
}

/// Occlusion at `p` with normal `n` from a field of `k` directions at
/// points 8 voxels apart.
fn by_field(g: &OcclusionGrid, radius: f32, k: u32, p: Vec3, n: Option<Vec3>) -> f32 {
    by_field_cell(g, radius, k, 8, p, n)
}

/// The same with points `cell` voxels apart.
fn by_field_cell(
    g: &OcclusionGrid,
    radius: f32,
    k: u32,
    cell: u32,
    p: Vec3,
    n: Option<Vec3>,
) -> f32 {
    let iv = Intervals::new(radius, 2.0, 4.0);
    let f = AoField::build(g, &iv, [N; 3], [1.0; 3], k, cell, u64::MAX).unwrap();
    assert_eq!(f.cell(), cell);
    let src = AoSource::new(g, AoLookup::Field(&f), hi(), 4.0);
    let mut fx = RayEffects::default();
    let a = src.occlusion(p, n, [0, 0], 0, &mut fx);
    assert_eq!(fx.ao_rays, 0, "a field casts no rays");
    a
}

fn normals() -> [Option<Vec3>; 4] {
    [
        Some(Vec3::X),
        Some(Vec3::new(0.48, -0.6, 0.64)),
        Some(Vec3::NEG_Z),
        None,
    ]
}

#[test]
fn a_homogeneous_medium_occludes_by_exp_minus_sigma_r_for_any_n() {
    let sigma = 0.05;
    let g = grid(sigma, f32::NEG_INFINITY);
    let centre = Vec3::splat(31.5);
    for radius in [20.0f32, 7.5, 1.0] {
        let want = (-sigma * radius).exp();
        for n in normals() {
            for count in [1, 8, 64] {
                let a = by_rays(&g, radius, count, centre, n);
                assert!(
                    (a - want).abs() <= want * 1e-5,
                    "R {radius}, N {count}, {n:?}: {a} vs {want}"
                );
            }
            for k in [1, 16, 64] {
                let a = by_field(&g, radius, k, centre, n);
                // The field keeps the mean over its directions exactly.
                assert!(
                    (a - want).abs() <= want * 1e-5,
                    "R {radius}, K {k}, {n:?}: {a} vs {want}"
                );
            }
            // At other spacings of its points (up to 16: at 64 the points
            // sit on the box's faces, where the medium ends within R).
            for cell in [1, 3, 4, 16] {
                let a = by_field_cell(&g, radius, 16, cell, centre, n);
                assert!(
                    (a - want).abs() <= want * 1e-5,
                    "R {radius}, cell {cell}, {n:?}: {a} vs {want}"
                );
            }
        }
    }
}

#[test]
fn an_empty_neighbourhood_and_a_zero_radius_give_one() {
    let empty = grid(0.0, f32::NEG_INFINITY);
    let dense = grid(1e3, f32::NEG_INFINITY);
    let centre = Vec3::splat(31.5);
    for n in normals() {
        assert_eq!(by_rays(&empty, 20.0, 8, centre, n), 1.0);
        assert_eq!(by_field(&empty, 20.0, 32, centre, n), 1.0);
        assert_eq!(by_rays(&dense, 0.0, 8, centre, n), 1.0, "R = 0");
        assert_eq!(by_field(&dense, 0.0, 32, centre, n), 1.0, "R = 0");
    }
}

#[test]
fn dense_media_occlude_fully_and_never_give_nan() {
    let centre = Vec3::splat(31.5);
    for depth in [1e3, f32::INFINITY, f32::MAX, f32::NAN] {
        let g = grid(depth, f32::NEG_INFINITY);
        for n in normals() {
            let a = by_rays(&g, 20.0, 4, centre, n);
            let f = by_field(&g, 20.0, 16, centre, n);
            if depth.is_nan() {
                // A NaN depth counts as clear, never as NaN.
                assert_eq!((a, f), (1.0, 1.0));
            } else {
                assert_eq!((a, f), (0.0, 0.0), "depth {depth}, {n:?}");
            }
        }
    }
}

#[test]
fn rays_marched_in_lanes_match_rays_marched_one_by_one() {
    let d = Dims::new(N as u64, N as u64, N as u64).unwrap();
    let v = Volume::from_samples(d, vec![0u8; N * N * N]).unwrap();
    let s = HashSampler::new(11);
    for peak in [0.02, 0.5, 40.0] {
        let g = v.visit(BuildGrid(&Wavy { peak }));
        for radius in [0.0, 3.0, 20.0, 300.0] {
            let iv = Intervals::new(radius, 2.0, 4.0);
            let (mut cut, mut left, mut compared) = (0, 0, 0);
            for k in 0..400u64 {
                let mut r = s.pixel(k as u32, 1, 0);
                let mut u = || r.next_2d();
                // Origins inside the box and a little past its faces.
                let (a, b) = u();
                let (c, _) = u();
                let origin = Vec3::new(a, b, c) * 70.0 - 3.0;
                let mut dirs = [[0f32; 8]; 3];
                let mut want = Vec::new();
                for lane in 0..8 {
                    let (a, b) = u();
                    let z = 1.0 - 2.0 * a;
                    let rr = (1.0 - z * z).max(0.0).sqrt();
                    let phi = 2.0 * std::f32::consts::PI * b;
                    // Some axis-parallel directions too.
                    let dir = match (k + lane) % 9 {
                        0 => Vec3::X,
                        1 => Vec3::NEG_Y,
                        _ => Vec3::new(rr * phi.cos(), rr * phi.sin(), z),
                    };
                    for (axis, v) in dir.to_array().into_iter().enumerate() {
                        dirs[axis][lane as usize] = v;
                    }
                    want.push(iv.transmittance(&g, origin, dir, hi()));
                }
                let count = 1 + (k % 8) as usize;
                let Some((got, taken)) = iv.transmittance8(&g, origin, &dirs, count, hi()) else {
                    assert!(!volcore::lanes::avx2_available());
                    return;
                };
                for lane in 0..8 {
                    if lane < count {
                        assert_eq!(
                            got[lane].to_bits(),
                            want[lane].0.to_bits(),
                            "peak {peak}, R {radius}, ray {k}, lane {lane}"
                        );
                        cut += usize::from(got[lane] == 0.0);
                        left += usize::from(want[lane].1 < iv.len() as u32);
                        compared += 1;
                    } else {
                        assert_eq!(got[lane], 1.0);
                    }
                }
                let all: u64 = want[..count].iter().map(|w| w.1 as u64).sum();
                assert_eq!(taken, all, "peak {peak}, R {radius}, ray {k}");
            }
            assert!(compared > 1000);
            // The dense medium cuts rays off, and long rays leave the box.
            if peak > 10.0 && radius > 10.0 {
                assert!(cut > 100, "peak {peak}, R {radius}: {cut} cut off");
            }
            if radius > 100.0 {
                assert!(left > 100, "R {radius}: {left} left the box");
            }
        }
    }
}

/// Where the volume's last voxel is a lattice point on every level (65
/// voxels: 16 cells of 4, 8 of 8, ...), rays along the box's far faces
/// and from its far corner read the lattice's last points, whose two
/// corners along x are one point: lanes read them as one by one does.
#[test]
fn rays_along_the_far_faces_read_the_last_points_as_one_by_one() {
    const M: usize = 65;
    let d = Dims::new(M as u64, M as u64, M as u64).unwrap();
    let v = Volume::from_samples(d, vec![0u8; M * M * M]).unwrap();
    let g = v.visit(BuildGrid(&Wavy { peak: 0.7 }));
    let top = Vec3::splat((M - 1) as f32);
    let iv = Intervals::new(200.0, 2.0, 4.0);
    let s = HashSampler::new(3);
    let mut compared = 0;
    for k in 0..200u64 {
        let mut r = s.pixel(k as u32, 2, 0);
        let mut u = || r.next_2d();
        let (a, b) = u();
        // On the far x face, on the far x and y edge, or at the corner.
        let origin = match k % 3 {
            0 => Vec3::new(top.x, a * top.y, b * top.z),
            1 => Vec3::new(top.x, top.y, a * top.z),
            _ => top,
        };
        let mut dirs = [[0f32; 8]; 3];
        let mut want = Vec::new();
        // Along the faces, and inward.
        let along: Vec<Vec3> = (0..8)
            .map(|lane| {
                let (a, b) = u();
                match lane {
                    0 => Vec3::NEG_Y,
                    1 => Vec3::NEG_Z,
                    2 => Vec3::new(0.0, -a, -b).normalize_or(Vec3::NEG_Y),
                    _ => Vec3::new(-a - 0.1, -b, a - 1.0).normalize(),
                }
            })
            .collect();
        for (lane, &dir) in along.iter().enumerate() {
            for (axis, v) in dir.to_array().into_iter().enumerate() {
                dirs[axis][lane] = v;
            }
            want.push(iv.transmittance(&g, origin, dir, top).0);
        }
        let Some((got, _)) = iv.transmittance8(&g, origin, &dirs, 8, top) else {
            assert!(!volcore::lanes::avx2_available());
            return;
        };
        for lane in 0..8 {
            assert_eq!(
                got[lane].to_bits(),
                want[lane].to_bits(),
                "ray {k}, lane {lane}: {origin:?}"
            );
            compared += usize::from(want[lane] < 1.0);
        }
    }
    // Most rays meet some of the medium.
    assert!(compared > 800, "{compared}");
}

#[test]
fn field_lookups_in_lanes_match_lookups_one_by_one() {
    let d = Dims::new(N as u64, N as u64, N as u64).unwrap();
    let v = Volume::from_samples(d, vec![0u8; N * N * N]).unwrap();
    let g = v.visit(BuildGrid(&Wavy { peak: 0.5 }));
    let s = HashSampler::new(5);
    let mut compared = 0;
    for (k, cell) in [(16, 8), (32, 3), (1, 64)] {
        let iv = Intervals::new(20.0, 2.0, 4.0);
        let f = AoField::build(&g, &iv, [N; 3], [1.0; 3], k, cell, u64::MAX).unwrap();
        let src = AoSource::new(&g, AoLookup::Field(&f), hi(), 4.0);
        for round in 0..300u32 {
            let mut r = s.pixel(round, cell, 0);
            let mut p = [Vec3::ZERO; 8];
            let mut n = [None; 8];
            for i in 0..8 {
                let (a, b) = r.next_2d();
                let (c, e) = r.next_2d();
                // Points inside and past the faces; on grid points too.
                p[i] = match (round as usize + i) % 7 {
                    0 => Vec3::new(8.0, 16.0, 24.0),
                    1 => Vec3::new(f32::NAN, 3.0, 70.0),
                    _ => Vec3::new(a, b, c) * 72.0 - 4.0,
                };
                let z = 1.0 - 2.0 * e;
                let (u, _) = r.next_2d();
                let rr = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f32::consts::PI * u;
                n[i] = match (round as usize + 3 * i) % 5 {
                    0 => None,
                    1 => Some(Vec3::NEG_Z),
                    _ => Some(Vec3::new(rr * phi.cos(), rr * phi.sin(), z)),
                };
            }
            let mut pl = [[0f32; 8]; 3];
            let mut nl = [[0f32; 8]; 3];
            let mut lit = 0u8;
            for i in 0..8 {
                for a in 0..3 {
                    pl[a][i] = p[i][a];
                }
                if let Some(d) = n[i] {
                    lit |= 1 << i;
                    for a in 0..3 {
                        nl[a][i] = d[a];
                    }
                }
            }
            // Every lane, then some: the lanes left out take no part.
            let want = if round.is_multiple_of(2) {
                0xFF
            } else {
                (r.next_2d().0 * 256.0) as u8
            };
            let Some(got) = src.field8(&pl, &nl, lit, want) else {
                assert!(!volcore::lanes::avx2_available());
                return;
            };
            for i in (0..8).filter(|&i| want >> i & 1 == 1) {
                let mut fx = RayEffects::default();
                let want = src.occlusion(p[i], n[i], [0, 0], 0, &mut fx);
                assert_eq!(
                    got[i].to_bits(),
                    want.to_bits(),
                    "K {k}, cell {cell}, round {round}, lane {i}: {:?} {:?}",
                    p[i],
                    n[i]
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 3 * 300 * 6, "{compared} lanes compared");
}

#[test]
fn only_the_hemisphere_around_the_normal_counts() {
    // Occluders at z >= 40 only; the point sits at z 30.
    let g = grid(0.2, 40.0);
    let p = Vec3::new(31.5, 31.5, 30.0);
    let down = by_rays(&g, 30.0, 32, p, Some(Vec3::NEG_Z));
    let up = by_rays(&g, 30.0, 32, p, Some(Vec3::Z));
    let sphere = by_rays(&g, 30.0, 32, p, None);
    // Facing away, only the coarse levels' blur (a 16-voxel tent) reaches
    // the occluder.
    assert!(
        down > 0.97 && down <= 1.0,
        "facing away from the occluder: {down}"
    );
    assert!(up < 0.6, "facing it: {up}");
    assert!(up < sphere && sphere < down, "{up} {sphere} {down}");
    let fdown = by_field(&g, 30.0, 64, p, Some(Vec3::NEG_Z));
    let fup = by_field(&g, 30.0, 64, p, Some(Vec3::Z));
    assert!(fdown > 0.95, "{fdown}");
    assert!((fup - up).abs() < 0.25, "field {fup} vs rays {up}");
}

fn lighting() -> Lighting {
    Lighting {
        lights: vec![
            Light::directional(Vec3::new(1.0, 2.0, 3.0)).unwrap(),
            Light::Point {
                position: Vec3::new(20.0, 21.0, 19.0),
                intensity: Vec3::splat(300.0),
            },
        ],
        ambient: Vec3::splat(0.5),
        ..Default::default()
    }
}

fn settings(mode: Mode, ao: Option<Ao>, shadows: bool) -> RenderSettings {
    RenderSettings {
        mode,
        step: 0.4,
        shading: true,
        lighting: lighting(),
        shadows: shadows.then_some(Shadows {
            method: ShadowMethod::Grid { divisor: 2 },
            step: None,
        }),
        ao,
        ..Default::default()
    }
}

fn ao(method: AoMethod) -> Option<Ao> {
    Some(Ao {
        method,
        radius: Some(12.0),
        seed: 1,
    })
}

fn sum(f: &Frame) -> f64 {
    f.rgba.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum()
}

#[test]
fn occluded_frames_are_identical_across_threads_tiles_and_skipping() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = orbit_camera();
    for mode in [Mode::Dvr, Mode::Iso(90.0)] {
        for (method, shadows) in [
            (AoMethod::Rays { n: 4 }, false),
            (AoMethod::Rays { n: 3 }, true),
            (AoMethod::Field { k: 16, cell: 8 }, true),
            (AoMethod::Field { k: 8, cell: 3 }, false),
        ] {
            let s = settings(mode, ao(method), shadows);
            let name = format!("{mode:?} {method:?} shadows {shadows}");
            let reference = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
            let e = reference.stats.effects;
            match method {
                AoMethod::Rays { n } => {
                    assert!(
                        e.ao_rays > 0 && e.ao_rays.is_multiple_of(n as u64),
                        "{name}"
                    );
                    assert!(e.ao_samples > 0, "{name}");
                }
                AoMethod::Field { .. } => {
                    assert_eq!(e.ao_rays, 0, "{name}");
                    assert!(e.ao_field_bytes > 0 && e.ao_field_samples > 0, "{name}");
                }
            }
            assert!(e.ao_grid_bytes > 0, "{name}");
            for threads in [1, 2, 7] {
                for tile in [5, 16] {
                    for ess in [true, false] {
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap();
                        let s2 = RenderSettings {
                            tile,
                            ess,
                            ..s.clone()
                        };
                        let f =
                            pool.install(|| render(&v, Some(&ix), Some(&tf), &cam, &s2).unwrap());
                        assert!(
                            f.rgba == reference.rgba,
                            "{name}: {threads} threads, tile {tile}, skipping {ess} differ"
                        );
                    }
                }
            }
            assert!(reference.rgba.iter().flatten().all(|c| c.is_finite()));
        }
    }
}

#[test]
fn with_ao_off_no_occlusion_work_is_done_and_on_it_darkens() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    for mode in [Mode::Dvr, Mode::Iso(90.0)] {
        let off = render(
            &v,
            Some(&ix),
            Some(&tf),
            &orbit_camera(),
            &settings(mode, None, false),
        )
        .unwrap();
        assert_eq!(off.stats.effects, Default::default(), "{mode:?}");
        for method in [AoMethod::Rays { n: 8 }, AoMethod::Field { k: 32, cell: 8 }] {
            let on = render(
                &v,
                Some(&ix),
                Some(&tf),
                &orbit_camera(),
                &settings(mode, ao(method), false),
            )
            .unwrap();
            assert!(
                sum(&on) < sum(&off) * 0.995,
                "{mode:?} {method:?}: {} vs {}",
                sum(&on),
                sum(&off)
            );
            // Only the ambient term is occluded: never darker than the
            // frame without ambient light.
            let mut dark = settings(mode, None, false);
            dark.lighting.ambient = Vec3::ZERO;
            let no_ambient = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &dark).unwrap();
            assert!(sum(&on) > sum(&no_ambient), "{mode:?} {method:?}");
        }
    }
}

#[test]
fn different_seeds_give_different_noise_and_more_rays_less_of_it() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let with = |n: u32, seed: u64| {
        let mut s = settings(Mode::Dvr, ao(AoMethod::Rays { n }), false);
        if let Some(a) = s.ao.as_mut() {
            a.seed = seed;
        }
        render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s).unwrap()
    };
    let diff = |a: &Frame, b: &Frame| {
        a.rgba
            .iter()
            .zip(&b.rgba)
            .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs() as f64).sum::<f64>())
            .sum::<f64>()
    };
    let (a1, b1) = (with(1, 1), with(1, 2));
    let (a16, b16) = (with(16, 1), with(16, 2));
    assert!(diff(&a1, &b1) > 0.0);
    assert!(
        diff(&a16, &b16) < 0.5 * diff(&a1, &b1),
        "{} vs {}",
        diff(&a16, &b16),
        diff(&a1, &b1)
    );
}

#[test]
fn bad_ao_settings_are_refused() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cases = [
        (
            RenderSettings {
                shading: false,
                ..settings(Mode::Dvr, ao(AoMethod::Rays { n: 4 }), false)
            },
            "needs shading",
        ),
        (
            settings(Mode::Mip, ao(AoMethod::Rays { n: 4 }), false),
            "DVR and iso",
        ),
        (
            settings(Mode::Dvr, ao(AoMethod::Rays { n: 0 }), false),
            "must be 1 to",
        ),
        (
            settings(
                Mode::Dvr,
                ao(AoMethod::Field {
                    k: 100_000,
                    cell: 8,
                }),
                false,
            ),
            "must be 1 to",
        ),
        (
            settings(Mode::Dvr, ao(AoMethod::Field { k: 16, cell: 0 }), false),
            "cell 0 must be 1 to 64",
        ),
        (
            settings(Mode::Dvr, ao(AoMethod::Field { k: 16, cell: 65 }), false),
            "cell 65 must be 1 to 64",
        ),
        (
            settings(
                Mode::Dvr,
                Some(Ao {
                    method: AoMethod::Rays { n: 4 },
                    radius: Some(f32::NAN),
                    seed: 0,
                }),
                false,
            ),
            "radius",
        ),
    ];
    for (s, want) in cases {
        let e = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(want), "{msg}");
        assert!(!msg.contains('\n'));
    }
}

#[test]
fn normals_in_lanes_match_normals_one_by_one() {
    use volrender::effects::{outward_normal, outward_normals8};
    let tiny = f32::MIN_POSITIVE / 8.0;
    let edge = [
        Vec3::ZERO,
        Vec3::new(-0.0, 0.0, -0.0),
        Vec3::new(f32::NAN, 1.0, 0.0),
        Vec3::new(1.0, f32::NAN, 2.0),
        Vec3::new(0.0, 0.0, f32::NAN),
        Vec3::new(f32::INFINITY, 1.0, 0.0),
        Vec3::new(1.0, f32::NEG_INFINITY, 0.0),
        Vec3::new(tiny, -tiny, 0.0),
        Vec3::new(f32::MAX, f32::MAX, -f32::MAX),
        Vec3::new(1e-30, 3e-31, -2e-30),
        Vec3::new(0.0, 0.0, -5.0),
        Vec3::new(3.0, -4.0, 12.0),
    ];
    let s = HashSampler::new(9);
    let mut checked = 0;
    for round in 0..400u32 {
        let mut r = s.pixel(round, 0, 0);
        let g: [Vec3; 8] = std::array::from_fn(|i| {
            let (a, b) = r.next_2d();
            let (c, e) = r.next_2d();
            if (round as usize + i).is_multiple_of(3) {
                edge[(round as usize * 8 + i) % edge.len()]
            } else {
                (Vec3::new(a, b, c) - 0.5) * 10f32.powf(e * 60.0 - 30.0)
            }
        });
        let lanes: [[f32; 8]; 3] = std::array::from_fn(|a| g.map(|v| v[a]));
        let (n, has) = outward_normals8(&lanes);
        for i in 0..8 {
            let want = outward_normal(g[i]);
            assert_eq!(has >> i & 1 == 1, want.is_some(), "{:?}", g[i]);
            if let Some(w) = want {
                for a in 0..3 {
                    assert_eq!(n[a][i].to_bits(), w[a].to_bits(), "{:?}", g[i]);
                }
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 400 * 8);
}

#[test]
fn batches_fed_in_runs_of_eight_match_batches_fed_one_by_one() {
    use volrender::effects::occlusion_grid::RayBatch;
    let d = Dims::new(N as u64, N as u64, N as u64).unwrap();
    let v = Volume::from_samples(d, vec![0u8; N * N * N]).unwrap();
    let g = v.visit(BuildGrid(&Wavy { peak: 0.5 }));
    let iv = Intervals::new(20.0, 2.0, 4.0);
    let s = HashSampler::new(3);
    for count in [1u32, 3, 8, 9, 16, 21] {
        let spiral = Spiral::new(count);
        for k in 0..200u64 {
            let (u1, u2) = s.pixel(k as u32, count, 0).next_2d();
            let origin = Vec3::new(u1, u2, 0.5) * 60.0;
            let n = (k % 3 != 0).then(|| Vec3::new(u2 - 0.5, 0.3, u1 - 0.5).normalize());
            let (mut one, mut runs) = (Vec::new(), Vec::new());
            // Odd rays find a ray waiting already: their runs then go one
            // by one.
            let waiting = k % 2 == 1;
            let mut a = RayBatch::new(&iv, &g, origin, hi());
            if waiting {
                a.push(Vec3::Z, &mut |t| one.push(t));
            }
            spiral.directions(n, u1, u2, |d| a.push(d, &mut |t| one.push(t)));
            a.flush(&mut |t| one.push(t));
            let mut b = RayBatch::new(&iv, &g, origin, hi());
            if waiting {
                b.push(Vec3::Z, &mut |t| runs.push(t));
            }
            spiral.directions8(n, u1, u2, |d, c| b.push8(d, c, &mut |t| runs.push(t)));
            b.flush(&mut |t| runs.push(t));
            assert_eq!(one.len(), count as usize + (k % 2) as usize);
            let bits = |v: &[f32]| v.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&one), bits(&runs), "N {count}, ray {k}");
            assert_eq!(a.taken, b.taken);
        }
    }
}
