//! The path tracer against closed forms, and its hard cases: a white
//! furnace, pure absorption in a homogeneous box, empty and extreme media,
//! NaN voxels, extreme anisotropy, a camera inside the volume; bit
//! identity across thread counts and resumed renders; the majorant grid
//! against one global majorant.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{SceneSource, ShapesScene};
use volcore::{Dims, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::film::PathFilm;
use volrender::path::{
    Budget, EnvMap, MajorantMode, MediumSpec, PathCounters, PathLights, PathSettings, PathTracer,
    SamplerKind, Transmittance,
};
use volrender::{Camera, Light, Projection};

fn index(v: &Volume) -> MinMaxIndex {
    MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap()
}

fn settings(scale: f32, albedo: f32, lights: PathLights) -> PathSettings {
    PathSettings {
        medium: MediumSpec::Density {
            scale,
            albedo: Vec3::splat(albedo),
        },
        bounces: 8,
        g: 0.0,
        hybrid: None,
        majorant: MajorantMode::Grid,
        lights,
        background: None,
        seed: 1,
        sampler: SamplerKind::default(),
        transmittance: Transmittance::default(),
    }
}

fn env(l: f32) -> PathLights {
    PathLights {
        env: Vec3::splat(l),
        ..Default::default()
    }
}

fn sun_and_env() -> PathLights {
    PathLights {
        lights: vec![Light::Directional {
            towards: -Vec3::new(-1.0, -1.2, 0.4).normalize(),
            radiance: Vec3::splat(4.0),
        }],
        env: Vec3::splat(0.1),
        env_map: None,
    }
}

/// `spp` samples per pixel in one pass.
fn render(
    v: &Volume,
    ix: &MinMaxIndex,
    cam: &Camera,
    s: &PathSettings,
    spp: u64,
) -> (PathFilm, PathCounters) {
    let pt = PathTracer::new(v, ix, cam, s).unwrap();
    let mut acc = PathFilm::new(cam.width(), cam.height(), pt.key(0));
    let n = pt.pass(&mut acc, spp).unwrap();
    (acc, n)
}

/// The empty-space shortcuts change no sample: jumping across blocks of
/// empty macrocells, and taking the camera samples of image blocks whose
/// rays meet only empty cells as the background. On a sparse volume with
/// several bounces (camera, shadow and continuation rays in every octant),
/// under a sun and a constant environment and under a sky map (what a
/// culled sample sees then depends on its direction), and for a medium
/// that only absorbs, the film is the same bit for bit with and without
/// them, as is every counter but the empty crossings and the culled
/// samples.
#[test]
fn empty_space_shortcuts_change_no_sample() {
    let dims = Dims::new(72, 64, 56).unwrap();
    let scene = ShapesScene::new(dims, 5, 6, 10, 200.0);
    let v = Volume::from_samples(dims, pack_sliced(&SceneSource::<u8>::new(&scene))).unwrap();
    let ix = index(&v);
    let cam = outside(64.0, 48);
    let cases = [
        settings(2.0, 0.8, sun_and_env()),
        settings(2.0, 0.8, map_lights(sky_map(32, 16))),
        settings(2.0, 0.0, env(0.7)),
    ];
    for (k, mut s) in cases.into_iter().enumerate() {
        s.bounces = 6;
        let run = |shortcuts: bool| {
            let pt = PathTracer::new(&v, &ix, &cam, &s).unwrap();
            let pt = if shortcuts {
                pt
            } else {
                pt.without_shortcuts()
            };
            let mut acc = PathFilm::new(cam.width(), cam.height(), pt.key(0));
            let n = pt.pass(&mut acc, 16).unwrap();
            (acc, n)
        };
        let (a, na) = run(true);
        let (b, nb) = run(false);
        assert!(a == b, "case {k}: the films differ");
        assert!(
            na.empty_jumps > 1000 && nb.empty_jumps == 0,
            "case {k}: {na:?}"
        );
        assert!(
            na.empty_cells * 3 < nb.empty_cells,
            "case {k}: {na:?} {nb:?}"
        );
        assert!(
            na.culled_paths * 4 > na.paths && nb.culled_paths == 0,
            "case {k}: {na:?}"
        );
        let strip = |n: PathCounters| PathCounters {
            empty_cells: 0,
            empty_jumps: 0,
            culled_paths: 0,
            ..n
        };
        assert_eq!(strip(na), strip(nb), "case {k}");
        if k < 2 {
            assert!(na.scatter_events > 1000 && na.shadow_rays > 1000, "{na:?}");
        }
    }
}

/// The image mean and its standard error (pixels independent).
fn image_mean(acc: &PathFilm) -> (f64, f64) {
    let rgb = acc.mean_rgb();
    let n = (rgb.len() / 3) as f64;
    let mean = rgb
        .chunks(3)
        .map(|c| volrender::film::luminance(c[0] as f64, c[1] as f64, c[2] as f64))
        .sum::<f64>()
        / n;
    let se2: f64 = acc
        .standard_errors()
        .iter()
        .map(|&e| (e as f64).powi(2))
        .sum();
    (mean, se2.sqrt() / n)
}

fn constant(dims: Dims, value: u8) -> Volume {
    Volume::from_samples(dims, vec![value; dims.count() as usize]).unwrap()
}

fn shapes(d: u64) -> Volume {
    let dims = Dims::new(d, d, d).unwrap();
    let scene = ShapesScene::new(dims, 3, 10, d / 4, 200.0);
    Volume::from_samples(dims, pack_sliced(&SceneSource::<u8>::new(&scene))).unwrap()
}

fn outside(d: f32, w: u32) -> Camera {
    Camera::look_at(
        Vec3::new(2.2 * d, 1.6 * d, 2.6 * d),
        Vec3::splat(d * 0.5),
        Vec3::Y,
        Projection::Perspective(40.0),
        w,
        w,
    )
    .unwrap()
}

/// Albedo 1 under a constant environment of 1: every path carries
/// exactly the environment back, whatever the density and the phase.
#[test]
fn white_furnace_returns_the_environment() {
    let v = shapes(40);
    let ix = index(&v);
    let cam = outside(40.0, 24);
    for g in [0.0, 0.8, -0.999, 0.999] {
        let mut s = settings(2.0, 1.0, env(1.0));
        s.g = g;
        s.bounces = 10_000;
        let (acc, n) = render(&v, &ix, &cam, &s, 8);
        assert!(n.scatter_events > 1000, "g {g}: {n:?}");
        for c in acc.mean_rgb() {
            assert!((c - 1.0).abs() < 1e-6, "g {g}: pixel {c}");
        }
        assert_eq!(n.non_finite + n.truncated, 0);
    }
}

/// Albedo 0 in a homogeneous box seen along an axis by an orthographic
/// camera: every ray crosses the same length L, every pixel's expectation
/// is exp(−σL). Ratio tracking, with the grid and the global majorant.
#[test]
fn absorption_matches_beer_lambert() {
    let dims = Dims::new(24, 20, 32).unwrap();
    let v = constant(dims, 255);
    let ix = index(&v);
    let cam = Camera::look_at(
        Vec3::new(11.5, 9.5, 100.0),
        Vec3::new(11.5, 9.5, 0.0),
        Vec3::Y,
        Projection::Orthographic(15.0),
        16,
        16,
    )
    .unwrap();
    let expect = (-0.05f64 * 31.0).exp();
    for (mode, tr) in [
        (MajorantMode::Grid, Transmittance::Residual),
        (MajorantMode::Grid, Transmittance::Ratio),
        (MajorantMode::Global, Transmittance::Residual),
    ] {
        let mut s = settings(0.05, 0.0, env(1.0));
        s.majorant = mode;
        s.transmittance = tr;
        let (acc, n) = render(&v, &ix, &cam, &s, 64);
        let (mean, se) = image_mean(&acc);
        // Residual tracking integrates a constant medium in closed form
        // (to f32 rounding: hence the 1e-6).
        assert!(
            (mean - expect).abs() < 4.0 * se + 1e-6,
            "{mode:?} {tr:?}: {mean} vs {expect} (se {se})"
        );
        assert!(se < 0.02 * expect, "{mode:?} {tr:?}: se {se}");
        // No scattering code ran.
        assert_eq!((n.scatter_events, n.bounce_rays), (0, 0), "{n:?}");
    }
}

/// Issue 43, item 1: a macrocell at the extinction cap (here from one
/// +inf voxel in a corner) is tracked voxel cell by voxel cell, each under
/// its own eight values' bound. Rays through the rest of that cell see the
/// ordinary medium: Beer-Lambert holds as without the speck, with a few
/// null collisions per path instead of a million per unit, and no lookup
/// at the cap.
#[test]
fn absorption_beside_an_infinite_voxel_matches_beer_lambert() {
    let dims = Dims::new(24, 20, 32).unwrap();
    let mut samples = vec![0.05f32; dims.count() as usize];
    // Voxel (1, 1, 12): in macrocell (0, 0, 1), which the rays of the
    // image's lower left cross away from the speck's voxel cells.
    samples[(12 * 20 + 1) * 24 + 1] = f32::INFINITY;
    let v = Volume::from_samples(dims, samples).unwrap();
    let ix = index(&v);
    let cam = Camera::look_at(
        Vec3::new(11.5, 9.5, 100.0),
        Vec3::new(11.5, 9.5, 0.0),
        Vec3::Y,
        Projection::Orthographic(15.0),
        16,
        16,
    )
    .unwrap();
    let expect = (-0.05f64 * 31.0).exp();
    let (acc, n) = render(&v, &ix, &cam, &settings(1.0, 0.0, env(1.0)), 64);
    let (mean, se) = image_mean(&acc);
    assert!(
        (mean - expect).abs() < 4.0 * se + 1e-9,
        "{mean} vs {expect} (se {se})"
    );
    assert!(n.voxel_cells > 1000, "{n:?}");
    assert_eq!((n.capped, n.truncated), (0, 0), "{n:?}");
    assert!(n.null_collisions < 10 * n.paths, "{n:?}");
}

/// Nothing to scatter or absorb: every pixel is the background exactly,
/// no density is looked up and no shadow ray cast (every camera sample is
/// known without tracing: no block of the image sees a cell with
/// extinction).
#[test]
fn an_empty_medium_shows_the_background_exactly() {
    let v = constant(Dims::new(20, 20, 20).unwrap(), 0);
    let ix = index(&v);
    let cam = outside(20.0, 12);
    let (acc, n) = render(&v, &ix, &cam, &settings(1.0, 0.8, sun_and_env()), 4);
    assert!(acc.mean_rgb().iter().all(|&c| c == 0.1f32));
    assert_eq!(
        (n.density_lookups, n.shadow_rays, n.majorant_cells),
        (0, 0, 0)
    );
    assert_eq!(n.culled_paths, n.paths, "{n:?}");
    let mut s = settings(1.0, 0.8, sun_and_env());
    s.background = Some(Vec3::new(0.0, 0.5, 1.0));
    let (acc, _) = render(&v, &ix, &cam, &s, 2);
    assert!(acc.mean_rgb().chunks(3).all(|c| c == [0.0, 0.5, 1.0]));
}

/// The same image, bit for bit, on 1, 2 and 7 threads; and 5 + 3 samples
/// resumed through a state file equal 8 at once.
#[test]
fn images_are_bit_identical_across_threads_and_resumes() {
    let v = shapes(40);
    let ix = index(&v);
    let cam = outside(40.0, 20);
    for sampler in [SamplerKind::Sobol, SamplerKind::Hash] {
        let mut s = settings(0.5, 0.8, sun_and_env());
        s.sampler = sampler;
        bit_identical_across_threads_and_resumes(&v, &ix, &cam, &s);
    }
    // The two samplers draw different numbers.
    let mut h = settings(0.5, 0.8, sun_and_env());
    h.sampler = SamplerKind::Hash;
    assert_ne!(render(&v, &ix, &cam, &h, 2).0, {
        h.sampler = SamplerKind::Sobol;
        render(&v, &ix, &cam, &h, 2).0
    });
}

fn bit_identical_across_threads_and_resumes(
    v: &Volume,
    ix: &MinMaxIndex,
    cam: &Camera,
    s: &PathSettings,
) {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(v, ix, cam, s, 8))
    };
    let (one, n1) = run(1);
    for t in [2, 7] {
        let (other, n) = run(t);
        assert_eq!(other, one, "{t} threads");
        assert_eq!(n, n1);
    }
    let pt = PathTracer::new(v, ix, cam, s).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("s.state");
    let mut a = PathFilm::new(20, 20, pt.key(0));
    pt.render(
        &mut a,
        &Budget {
            spp: Some(5),
            ..Default::default()
        },
        |_, _| {},
    )
    .unwrap();
    a.write_to(&mut std::fs::File::create(&state).unwrap())
        .unwrap();
    let mut b = PathFilm::load(&state, 20, 20, pt.key(0)).unwrap();
    pt.pass(&mut b, 3).unwrap();
    assert_eq!(b, one);
    // Another scene's key is refused.
    let other = settings(0.6, 0.8, sun_and_env());
    let key = PathTracer::new(v, ix, cam, &other).unwrap().key(0);
    assert_ne!(key, pt.key(0));
    assert!(PathFilm::load(&state, 20, 20, key).is_err());
}

/// The majorant grid changes the cost, not the expectation: the image
/// means under the grid and under one global majorant agree within their
/// standard errors, and on a sparse volume the grid looks up far fewer
/// densities.
#[test]
fn grid_and_global_majorants_agree() {
    let v = shapes(48);
    let ix = index(&v);
    let cam = outside(48.0, 24);
    let mut s = settings(2.0, 0.8, sun_and_env());
    s.bounces = 4;
    let (grid, ng) = render(&v, &ix, &cam, &s, 64);
    s.majorant = MajorantMode::Global;
    s.seed = 2;
    let (global, nl) = render(&v, &ix, &cam, &s, 64);
    let (mg, sg) = image_mean(&grid);
    let (ml, sl) = image_mean(&global);
    assert!(
        (mg - ml).abs() < 4.0 * (sg * sg + sl * sl).sqrt(),
        "grid {mg} ± {sg}, global {ml} ± {sl}"
    );
    assert!(mg > 0.01, "{mg}");
    assert!(ng.empty_cells > 0 && nl.empty_cells == 0);
    assert!(
        ng.density_lookups * 2 < nl.density_lookups,
        "{} vs {}",
        ng.density_lookups,
        nl.density_lookups
    );
}

/// Hard cases stay finite and terminate: a huge extinction, a sun along
/// the view direction, a camera inside the volume, NaN voxels.
#[test]
fn hard_cases_stay_finite() {
    let v = shapes(32);
    let ix = index(&v);
    let cam = outside(32.0, 8);
    // 1e6 per voxel at the top value.
    let (acc, n) = render(&v, &ix, &cam, &settings(1e6, 0.8, sun_and_env()), 2);
    assert!(acc.mean_rgb().iter().all(|c| c.is_finite()));
    assert_eq!(n.non_finite, 0);
    // The sun travelling along the view direction, and straight at it.
    for sign in [1.0, -1.0] {
        let mut l = sun_and_env();
        l.lights[0] = Light::Directional {
            towards: -cam.forward() * sign,
            radiance: Vec3::splat(4.0),
        };
        let (acc, n) = render(&v, &ix, &cam, &settings(0.5, 0.8, l), 4);
        assert!(acc.mean_rgb().iter().all(|c| c.is_finite() && *c >= 0.0));
        assert!(n.shadow_rays > 0);
    }
    // The eye inside the volume.
    let inside = Camera::look_at(
        Vec3::splat(16.0),
        Vec3::new(31.0, 16.0, 16.0),
        Vec3::Y,
        Projection::Perspective(90.0),
        8,
        8,
    )
    .unwrap();
    let (acc, n) = render(&v, &ix, &inside, &settings(0.5, 0.8, sun_and_env()), 4);
    assert!(acc.mean_rgb().iter().all(|c| c.is_finite()));
    assert!(n.real_collisions > 0);
    // NaN voxels count as empty space.
    let dims = Dims::new(16, 16, 16).unwrap();
    let mut vals: Vec<f32> = (0..dims.count()).map(|i| (i % 7) as f32 * 0.1).collect();
    for i in (0..vals.len()).step_by(5) {
        vals[i] = f32::NAN;
    }
    let nan = Volume::from_samples(dims, vals).unwrap();
    let nix = index(&nan);
    let (acc, n) = render(
        &nan,
        &nix,
        &outside(16.0, 8),
        &settings(1.0, 0.9, sun_and_env()),
        8,
    );
    assert!(acc.mean_rgb().iter().all(|c| c.is_finite()));
    assert_eq!(n.non_finite, 0);
}

/// 100,000 samples per pixel of a constant estimate: the f64 sums keep
/// the mean exact to 1e-9.
#[test]
fn long_accumulations_keep_the_mean() {
    let v = constant(Dims::new(8, 8, 8).unwrap(), 0);
    let ix = index(&v);
    let cam = outside(8.0, 4);
    let (acc, _) = render(&v, &ix, &cam, &settings(1.0, 0.5, env(0.3)), 100_000);
    for c in acc.mean_rgb() {
        assert!(((c as f64) / (0.3f32 as f64) - 1.0).abs() < 1e-9, "{c}");
    }
    assert_eq!(acc.spp(), 100_000);
}

/// A budget of time or error stops a render; none is refused.
#[test]
fn budgets_stop_renders() {
    let v = shapes(24);
    let ix = index(&v);
    let cam = outside(24.0, 8);
    let s = settings(0.5, 0.8, sun_and_env());
    let pt = PathTracer::new(&v, &ix, &cam, &s).unwrap();
    let mut acc = PathFilm::new(8, 8, pt.key(0));
    assert!(pt.render(&mut acc, &Budget::default(), |_, _| {}).is_err());
    let mut passes = 0;
    pt.render(
        &mut acc,
        &Budget {
            until_error: Some(0.05),
            ..Default::default()
        },
        |_, _| passes += 1,
    )
    .unwrap();
    assert!(acc.relative_error().unwrap() <= 0.05);
    assert!(passes > 1 && acc.spp() > 4, "{} spp", acc.spp());
    let before = acc.spp();
    pt.render(
        &mut acc,
        &Budget {
            seconds: Some(0.0),
            ..Default::default()
        },
        |_, _| {},
    )
    .unwrap();
    assert_eq!(acc.spp(), before + 1, "a zero time budget runs one pass");
}

/// Single scattering in a thin homogeneous slab under a sun, seen
/// straight down by an orthographic camera: at depth z the camera sees
/// σs·p(μ)·E·exp(−σt z)·exp(−σt z/μs) (the sun's path to depth z is
/// z/μs long), so the pixel's radiance is
/// σs·p(μ)·E·(1 − exp(−σt H k))/(σt k) with k = 1 + 1/μs. The grid and
/// the global majorant both match it within their standard errors.
#[test]
fn single_scattering_in_a_slab_matches_the_closed_form() {
    let dims = Dims::new(64, 64, 5).unwrap();
    let v = constant(dims, 255);
    let ix = index(&v);
    let cam = Camera::look_at(
        Vec3::new(31.5, 31.5, 100.0),
        Vec3::new(31.5, 31.5, 0.0),
        Vec3::Y,
        Projection::Orthographic(10.0),
        16,
        16,
    )
    .unwrap();
    let travel = Vec3::new(0.3, 0.0, -1.0).normalize();
    let (sigma_t, albedo, e, g, h) = (0.1f64, 0.8f64, 4.0f64, 0.4f32, 4.0f64);
    let mu_s = -travel.z as f64;
    let phase = volrender::path::phase::HenyeyGreenstein::new(g).eval(travel.z) as f64;
    let k = 1.0 + 1.0 / mu_s;
    let expect = sigma_t * albedo * phase * e * (1.0 - (-sigma_t * h * k).exp()) / (sigma_t * k);
    for (mode, seed) in [(MajorantMode::Grid, 3), (MajorantMode::Global, 4)] {
        let mut s = settings(
            0.1,
            0.8,
            PathLights {
                lights: vec![Light::Directional {
                    towards: -travel,
                    radiance: Vec3::splat(4.0),
                }],
                ..Default::default()
            },
        );
        s.bounces = 1;
        s.g = g;
        s.majorant = mode;
        s.seed = seed;
        let (acc, n) = render(&v, &ix, &cam, &s, 256);
        let (mean, se) = image_mean(&acc);
        assert!(
            (mean - expect).abs() < 4.0 * se,
            "{mode:?}: {mean} ± {se} vs {expect}"
        );
        assert!(se < 0.03 * expect, "{mode:?}: se {se} of {expect}");
        // One bounce, no environment: no continuation ray.
        assert_eq!(n.bounce_rays, 0);
        assert_eq!(n.shadow_rays, n.scatter_events);
    }
    // A point light far along the sun's direction, with the intensity
    // that gives the same irradiance at the slab, lights it the same.
    let far = 1e4f32;
    let mut s = settings(
        0.1,
        0.8,
        PathLights {
            lights: vec![Light::Point {
                position: Vec3::new(31.5, 31.5, 2.0) - travel * far,
                intensity: Vec3::splat(4.0 * far * far),
            }],
            ..Default::default()
        },
    );
    s.bounces = 1;
    s.g = g;
    s.seed = 5;
    let (acc, _) = render(&v, &ix, &cam, &s, 256);
    let (mean, se) = image_mean(&acc);
    assert!(
        (mean - expect).abs() < 4.0 * se + 2e-3 * expect,
        "point light: {mean} ± {se} vs {expect}"
    );
}

/// A grey sky: a bright sun texel, a graded sky above the horizon, a dim
/// ground below; `w × h` texels.
fn sky_map(w: u32, h: u32) -> EnvMap {
    let mut rgb = Vec::new();
    for r in 0..h {
        for c in 0..w {
            let v = if (r, c) == (h / 6, w / 5) {
                2000.0
            } else if r < h / 2 {
                0.5 + r as f32 * 0.02
            } else {
                0.05
            };
            rgb.extend([v, v, v]);
        }
    }
    EnvMap::new(w, h, &rgb).unwrap()
}

fn map_lights(m: EnvMap) -> PathLights {
    PathLights {
        env_map: Some(std::sync::Arc::new(m)),
        ..Default::default()
    }
}

/// The white furnace under a constant environment map: the map's samples
/// and the escaping paths, weighted against each other, still carry
/// exactly the environment back in expectation.
#[test]
fn white_furnace_holds_under_a_constant_map() {
    let v = shapes(32);
    let ix = index(&v);
    let cam = outside(32.0, 16);
    let m = EnvMap::new(8, 4, &[1.0; 8 * 4 * 3]).unwrap();
    for g in [0.0, 0.9] {
        let mut s = settings(2.0, 1.0, map_lights(m.clone()));
        s.g = g;
        s.bounces = 64;
        let (acc, n) = render(&v, &ix, &cam, &s, 64);
        let (mean, se) = image_mean(&acc);
        assert!((mean - 1.0).abs() < 4.0 * se + 1e-6, "g {g}: {mean} ± {se}");
        assert!(se < 0.01, "g {g}: se {se}");
        assert!(n.shadow_rays > 1000, "the map is sampled: {n:?}");
        assert_eq!(n.non_finite + n.truncated, 0);
        assert!(acc.mean_rgb().iter().all(|c| c.is_finite()));
    }
}

/// An optically thin cube of isotropic scatterers under a sky with a
/// small, very bright sun: each pixel carries σs L (1/4π) ∫ Le dω, up to
/// the cube's own small attenuation. Dropping either multiple-importance
/// weight would double the sun's share; the map's sampling also keeps the
/// sun from leaving fireflies (the standard error stays small).
#[test]
fn single_scattering_under_a_sky_map_matches_the_thin_medium_limit() {
    let d = 16u64;
    let v = constant(Dims::new(d, d, d).unwrap(), 255);
    let ix = index(&v);
    let size = (d - 1) as f32;
    let cam = Camera::look_at(
        Vec3::new(size / 2.0, size / 2.0, 100.0),
        Vec3::new(size / 2.0, size / 2.0, 0.0),
        Vec3::Y,
        Projection::Orthographic(size * 0.8),
        32,
        32,
    )
    .unwrap();
    let map = sky_map(64, 32);
    let integral = map.luminance_integral();
    let sigma = 0.02 / size as f64;
    let mut s = settings(sigma as f32, 1.0, map_lights(map));
    s.bounces = 1;
    s.background = Some(Vec3::ZERO);
    let (acc, n) = render(&v, &ix, &cam, &s, 512);
    let (mean, se) = image_mean(&acc);
    let l = size as f64;
    let thin = (1.0 - (-sigma * l).exp()) * integral / (4.0 * std::f64::consts::PI);
    // Light reaching a scatterer crosses on average about half the cube.
    let attenuation = (-sigma * l * 0.5).exp();
    let expect = thin * attenuation;
    assert!(
        (mean - expect).abs() < 4.0 * se + 0.01 * expect,
        "{mean} ± {se} vs {expect}"
    );
    assert!(se < 0.02 * expect, "se {se} of {expect}");
    assert_eq!(n.non_finite + n.truncated, 0);
}

/// A map next to a constant environment is refused; a black map adds no
/// shadow rays.
#[test]
fn maps_are_checked_and_black_ones_cost_nothing() {
    let v = shapes(24);
    let ix = index(&v);
    let cam = outside(24.0, 8);
    let mut lights = map_lights(sky_map(8, 4));
    lights.env = Vec3::splat(0.5);
    let s = settings(1.0, 0.8, lights);
    assert!(PathTracer::new(&v, &ix, &cam, &s).is_err());
    let black = EnvMap::new(4, 2, &[0.0; 24]).unwrap();
    let s = settings(1.0, 0.8, map_lights(black));
    let (acc, n) = render(&v, &ix, &cam, &s, 4);
    assert_eq!(n.shadow_rays, 0);
    assert!(acc.mean_rgb().iter().all(|&c| c == 0.0));
}

/// The path tracer's frame memory is checked by the ray caster's check,
/// at its own bytes per pixel: the largest image is refused before any
/// buffer is made, one that fits is not.
#[test]
fn frames_past_the_memory_budget_are_refused() {
    let v = shapes(8);
    let ix = index(&v);
    let s = settings(1.0, 0.5, env(1.0));
    let e = PathTracer::new(&v, &ix, &outside(8.0, 1 << 15), &s)
        .err()
        .expect("a 32768x32768 path-traced frame is past the budget");
    let e = e.to_string();
    assert!(
        e.contains("path-traced frame")
            && e.contains("budget")
            && e.contains(&format!(
                "{} bytes per pixel",
                volrender::path::PATH_BYTES_PER_PIXEL
            )),
        "{e}"
    );
    assert!(PathTracer::new(&v, &ix, &outside(8.0, 4096), &s).is_ok());
}

/// Hybrid scattering: in a constant medium the gradient is zero, so no
/// event reflects off a surface and the image keeps its expectation; in
/// a volume of sharp spheres events do, and the surface (whose BRDF
/// conserves energy) never makes a white furnace brighter than its
/// environment.
#[test]
fn hybrid_scattering_follows_the_gradient_and_conserves_energy() {
    let v = constant(Dims::new(20, 20, 20).unwrap(), 200);
    let ix = index(&v);
    let cam = outside(20.0, 12);
    let mut off = settings(0.3, 0.8, sun_and_env());
    off.bounces = 4;
    let mut on = off.clone();
    on.hybrid = Some(1000.0);
    on.seed = 9;
    let (a, na) = render(&v, &ix, &cam, &off, 256);
    let (b, nb) = render(&v, &ix, &cam, &on, 256);
    assert_eq!(nb.surface_events, 0, "{nb:?}");
    assert_eq!(na.surface_events, 0);
    let ((ma, sa), (mb, sb)) = (image_mean(&a), image_mean(&b));
    assert!(
        (ma - mb).abs() < 4.0 * (sa * sa + sb * sb).sqrt(),
        "{ma} ± {sa} vs {mb} ± {sb}"
    );

    let v = shapes(40);
    let ix = index(&v);
    let cam = outside(40.0, 24);
    let mut s = settings(2.0, 1.0, env(1.0));
    s.bounces = 64;
    s.hybrid = Some(50.0);
    let (acc, n) = render(&v, &ix, &cam, &s, 32);
    assert!(
        n.surface_events > n.scatter_events / 20 && n.surface_events < n.scatter_events,
        "{n:?}"
    );
    assert_eq!(n.non_finite + n.truncated, 0);
    let (mean, se) = image_mean(&acc);
    assert!(mean <= 1.0 + 4.0 * se && mean > 0.7, "{mean} ± {se}");
    for c in acc.mean_rgb() {
        assert!(c.is_finite() && c >= 0.0);
    }
    // Bit for bit the same on another thread count.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let (again, _) = pool.install(|| render(&v, &ix, &cam, &s, 32));
    assert_eq!(acc.mean_rgb(), again.mean_rgb());
    // A scale that is not a number above 0 is refused.
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        s.hybrid = Some(bad);
        assert!(PathTracer::new(&v, &ix, &cam, &s).is_err(), "{bad}");
    }
}

/// A white furnace (albedo 1, constant environment 1, bounces enough
/// that the cap never matters) for every scattering option: the phase
/// function, isotropic and anisotropic, and hybrid scattering from a few
/// surface events to a surface at nearly every sharp edge. No lobe may
/// absorb, so the image mean is 1 within Monte Carlo error; 1% is more
/// than eight standard errors at these sample counts (checked below).
#[test]
fn white_furnace_holds_for_every_scattering_option() {
    let v = shapes(40);
    let ix = index(&v);
    let cam = outside(40.0, 16);
    let options: [(f32, Option<f32>); 7] = [
        (0.0, None),
        (0.7, None),
        (-0.5, None),
        (0.0, Some(5.0)),
        (0.0, Some(20.0)),
        (0.6, Some(50.0)),
        (0.0, Some(1e6)),
    ];
    let (mut means, mut ok) = (Vec::new(), true);
    for (g, hybrid) in options {
        let mut s = settings(2.0, 1.0, env(1.0));
        s.g = g;
        s.hybrid = hybrid;
        s.bounces = 1000;
        let (acc, n) = render(&v, &ix, &cam, &s, 128);
        assert_eq!(n.non_finite + n.truncated, 0, "g {g}, hybrid {hybrid:?}");
        if hybrid.is_some() {
            assert!(n.surface_events > n.scatter_events / 50, "{n:?}");
        }
        let (mean, se) = image_mean(&acc);
        means.push(format!("g {g}, hybrid {hybrid:?}: {mean:.5} ± {se:.5}"));
        ok &= se < 0.01 / 8.0 && (mean - 1.0).abs() < 0.01;
    }
    assert!(ok, "{means:#?}");
}

/// Issue 54: residual ratio tracking is unbiased and, on a dense medium
/// whose extinction varies little inside a macrocell, has far less
/// variance than ratio tracking at fewer lookups. The medium ramps along
/// the view axis (σt = 0.05 × (0.5 + z / 63), exact under trilinear
/// interpolation), so every ray's transmittance is exp(−∫σt) =
/// exp(−0.05 × 63).
#[test]
fn residual_ratio_tracking_matches_the_closed_form_with_less_variance() {
    let dims = Dims::new(16, 16, 64).unwrap();
    let samples: Vec<f32> = (0..dims.count())
        .map(|i| 0.5 + (i / 256) as f32 / 63.0)
        .collect();
    let v = Volume::from_samples(dims, samples).unwrap();
    let ix = index(&v);
    let cam = Camera::look_at(
        Vec3::new(7.5, 7.5, 200.0),
        Vec3::new(7.5, 7.5, 0.0),
        Vec3::Y,
        Projection::Orthographic(10.0),
        12,
        12,
    )
    .unwrap();
    let expect = (-0.05f64 * 63.0).exp();
    let mut figures = Vec::new();
    for tr in [Transmittance::Residual, Transmittance::Ratio] {
        let mut s = settings(0.05, 0.0, env(1.0));
        s.transmittance = tr;
        let (acc, n) = render(&v, &ix, &cam, &s, 256);
        let (mean, se) = image_mean(&acc);
        assert!(
            (mean - expect).abs() < 4.0 * se + 1e-6,
            "{tr:?}: {mean} vs {expect} (se {se})"
        );
        figures.push((se, n.density_lookups));
    }
    eprintln!("(standard error, lookups): residual, ratio: {figures:?}");
    let [(res_se, res_lookups), (ratio_se, ratio_lookups)] = figures[..] else {
        unreachable!()
    };
    assert!(
        res_se * 4.0 < ratio_se,
        "standard errors: residual {res_se}, ratio {ratio_se}"
    );
    assert!(
        res_lookups * 3 < ratio_lookups,
        "lookups: residual {res_lookups}, ratio {ratio_lookups}"
    );
}
