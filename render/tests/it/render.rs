//! Renderer correctness: closed forms, exactness of the optimisations,
//! determinism, and the hard cases.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{
    BoxScene, NoiseKind, NoiseScene, Scene, SceneSource, ShapesScene, SphereScene,
};
use volcore::{Dims, Sample, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::tf::{TfPoint, TransferFunction};
use volrender::{render, Camera, Frame, GradientMethod, Interp, Mode, Projection, RenderSettings};

fn volume<T: Sample + volcore::volume::OpenSample>(scene: &dyn Scene) -> Volume {
    Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<T>::new(scene))).unwrap()
}

fn index(v: &Volume) -> MinMaxIndex {
    MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap()
}

fn constant_tf(alpha: f32) -> TransferFunction {
    let p = |value| TfPoint {
        value,
        rgb: [1.0; 3],
        alpha,
    };
    TransferFunction {
        points: vec![p(0.0), p(255.0)],
        ranges: vec![],
        domain: Some((0.0, 255.0)),
        reference_step: 1.0,
    }
}

fn bits(f: &Frame) -> Vec<u32> {
    f.rgba
        .iter()
        .flat_map(|p| p.map(f32::to_bits))
        .chain(f.value.iter().flat_map(|v| {
            let b = v.to_bits();
            [b as u32, (b >> 32) as u32]
        }))
        .collect()
}

fn assert_finite(f: &Frame, what: &str) {
    assert!(
        f.rgba.iter().flatten().all(|c| c.is_finite()),
        "{what}: non-finite pixel"
    );
}

fn orbit(v: &Volume, az: f32, el: f32, w: u32) -> Camera {
    let d = v.dims().as_array();
    let c = Vec3::new((d[0] - 1) as f32, (d[1] - 1) as f32, (d[2] - 1) as f32) * 0.5;
    Camera::orbit(
        c,
        az,
        el,
        c.length() * 3.0 + 5.0,
        Projection::Perspective(40.0),
        w,
        w,
    )
    .unwrap()
}

/// The frame rendered with empty-space skipping as `s` asks, and without.
fn with_and_without_skipping(
    v: &Volume,
    ix: &MinMaxIndex,
    tf: &TransferFunction,
    cam: &Camera,
    s: &RenderSettings,
) -> (Frame, Frame) {
    let on = render(v, Some(ix), Some(tf), cam, s).unwrap();
    let no_skipping = RenderSettings {
        ess: false,
        ..s.clone()
    };
    let off = render(v, Some(ix), Some(tf), cam, &no_skipping).unwrap();
    (on, off)
}

#[test]
fn constant_box_matches_beer_lambert_and_xray_matches_path_length() {
    let v = volume::<u8>(&BoxScene::new(Dims::new(32, 32, 32).unwrap(), 0, 100.0));
    let tf = constant_tf(0.02);
    let cam = Camera::look_at(
        Vec3::new(20.0, 40.0, 70.0),
        Vec3::splat(15.5),
        Vec3::Y,
        Projection::Perspective(50.0),
        48,
        48,
    )
    .unwrap();
    let step = 0.05;
    let s = RenderSettings {
        step,
        ert: None,
        ..Default::default()
    };
    let dvr = render(&v, None, Some(&tf), &cam, &s).unwrap();
    let xs = RenderSettings {
        mode: Mode::XraySum,
        step,
        ..Default::default()
    };
    let xray = render(&v, None, None, &cam, &xs).unwrap();
    let mut hits = 0;
    for y in 0..48 {
        for x in 0..48 {
            let ray = cam.ray(x, y).rounded();
            let Some((t0, t1)) = volrender::ray::intersect_box(&ray, Vec3::ZERO, Vec3::splat(31.0))
            else {
                continue;
            };
            let len = t1 - t0;
            let i = (y * 48 + x) as usize;
            let want = 1.0 - 0.98f32.powf(len);
            // A Riemann sum of step dt is off by at most one step's worth.
            assert!(
                (dvr.rgba[i][3] - want).abs() <= 0.021 * step + 1e-5,
                "alpha {} vs {want} (len {len})",
                dvr.rgba[i][3]
            );
            assert!((dvr.rgba[i][0] - dvr.rgba[i][3]).abs() < 1e-5);
            assert!(
                (xray.value[i] as f32 - 100.0 * len).abs() <= 100.0 * step + 1e-2,
                "xray {} vs {}",
                xray.value[i],
                100.0 * len
            );
            hits += 1;
        }
    }
    assert!(hits > 500);
}

/// The length of the ray `origin + t·dir` (f64 origin, f32 direction as the
/// camera makes it) inside the box `[0, hi]`, worked out in f64.
fn chord(origin: glam::DVec3, dir: Vec3, hi: f64) -> f64 {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (o, d) = (origin[a], f64::from(dir[a]));
        if d == 0.0 {
            if o < 0.0 || o > hi {
                return 0.0;
            }
            continue;
        }
        let (p, q) = ((0.0 - o) / d, (hi - o) / d);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t1 - t0).max(0.0)
}

/// Issue 43, item 3: where a ray enters the volume does not depend on how
/// far its eye is. X-ray sums and DVR opacity through a constant box match
/// each ray's chord (worked out in f64 from the camera's own ray) within
/// one step, for orthographic and perspective eyes from 60 to 1e9 units
/// away (1e7 and farther were refused as "too far" before); the MIP of a
/// sphere seen from 1e9 away finds its peak as the near view does.
#[test]
fn far_cameras_render_what_near_cameras_on_the_same_rays_render() {
    let v = volume::<u8>(&BoxScene::new(Dims::new(32, 32, 32).unwrap(), 0, 100.0));
    let tf = constant_tf(0.02);
    let step = 0.05;
    let centre = Vec3::splat(15.5);
    let forward = Vec3::new(-0.6, -0.5, -0.7).normalize();
    for distance in [60.0f32, 1e4, 1e7, 1e9] {
        for proj in [
            Projection::Orthographic(40.0),
            Projection::Perspective(2.0 * (25.0 / distance).atan().to_degrees()),
        ] {
            let eye = centre - forward * distance;
            let cam = Camera::look_at(eye, centre, Vec3::Y, proj, 40, 40).unwrap();
            let xs = RenderSettings {
                mode: Mode::XraySum,
                step,
                ..Default::default()
            };
            let xray = render(&v, None, None, &cam, &xs).unwrap();
            let dvr = render(
                &v,
                None,
                Some(&tf),
                &cam,
                &RenderSettings {
                    step,
                    ert: None,
                    ..Default::default()
                },
            )
            .unwrap();
            let mut hits = 0;
            for y in 0..40 {
                for x in 0..40 {
                    let r = cam.ray(x, y);
                    let len = chord(r.origin, r.dir, 31.0);
                    let i = (y * 40 + x) as usize;
                    let got = if xray.value[i].is_nan() {
                        0.0
                    } else {
                        xray.value[i]
                    };
                    // A Riemann sum of step dt is off by at most one step's
                    // worth (plus f32 positions the size of the box).
                    let what = format!("{proj:?} at {distance}: pixel {x},{y}");
                    assert!(
                        (got - 100.0 * len).abs() <= 100.0 * f64::from(step) + 1e-2,
                        "{what}: xray {got} vs {}",
                        100.0 * len
                    );
                    let want = 1.0 - 0.98f64.powf(len);
                    assert!(
                        (f64::from(dvr.rgba[i][3]) - want).abs() <= 0.021 * f64::from(step) + 1e-5,
                        "{what}: alpha {} vs {want}",
                        dvr.rgba[i][3]
                    );
                    hits += usize::from(len > 1.0);
                }
            }
            assert!(
                hits > 400,
                "{proj:?} at {distance}: {hits} rays through the box"
            );
        }
    }

    // MIP and its depth: the sphere's peak, at the eye's distance less the
    // radius, from near and from 1e9 away.
    let scene = SphereScene::new(Dims::new(33, 33, 33).unwrap(), 14.0, 200.0);
    let v = volume::<f32>(&scene);
    for distance in [50.0f32, 1e9] {
        let cam = Camera::look_at(
            Vec3::new(16.0, 16.0, -distance),
            Vec3::splat(16.0),
            Vec3::Y,
            Projection::Orthographic(33.0),
            33,
            33,
        )
        .unwrap();
        let s = RenderSettings {
            mode: Mode::Mip,
            step: 0.01,
            ..Default::default()
        };
        let mip = render(&v, None, None, &cam, &s).unwrap();
        let peak = mip.value[16 * 33 + 16] as f32;
        assert!(
            (peak - 200.0).abs() < 0.2,
            "MIP at centre {peak} from {distance}"
        );
        let depth = f64::from(mip.depth[16 * 33 + 16]);
        let want = f64::from(distance) + 16.0;
        assert!(
            (depth - want).abs() <= 1.0 + want * 1e-7,
            "depth {depth} from {distance}, want {want}"
        );
    }
}

#[test]
fn mip_of_a_sphere_finds_its_peak_and_iso_lands_on_the_radius() {
    let scene = SphereScene::new(Dims::new(33, 33, 33).unwrap(), 14.0, 200.0);
    let v = volume::<f32>(&scene);
    let ix = index(&v);
    // Orthographic along z, pixel 16 centred on x = y = 16.
    let cam = Camera::look_at(
        Vec3::new(16.0, 16.0, -50.0),
        Vec3::splat(16.0),
        Vec3::Y,
        Projection::Orthographic(33.0),
        33,
        33,
    )
    .unwrap();
    let s = RenderSettings {
        mode: Mode::Mip,
        step: 0.01,
        ..Default::default()
    };
    let mip = render(&v, Some(&ix), None, &cam, &s).unwrap();
    let centre = mip.value[16 * 33 + 16] as f32;
    assert!((centre - 200.0).abs() < 0.2, "MIP at centre {centre}");
    assert!(mip
        .value
        .iter()
        .filter(|v| v.is_finite())
        .all(|&v| v <= 200.0));

    let cam = Camera::look_at(
        Vec3::new(40.0, 30.0, -30.0),
        Vec3::splat(16.0),
        Vec3::Y,
        Projection::Perspective(30.0),
        40,
        40,
    )
    .unwrap();
    for grad in [GradientMethod::Central, GradientMethod::Analytic] {
        let s = RenderSettings {
            mode: Mode::Iso(100.0),
            step: 0.25,
            gradient: grad,
            ..Default::default()
        };
        let iso = render(&v, Some(&ix), None, &cam, &s).unwrap();
        let mut hits = 0;
        for (i, &t) in iso.depth.iter().enumerate() {
            if t.is_nan() {
                continue;
            }
            let ray = cam.ray(i as u32 % 40, i as u32 / 40).rounded();
            let r = (ray.origin + ray.dir * t - Vec3::splat(16.0)).length();
            assert!((r - 7.0).abs() < 0.1, "hit at radius {r}, want 7");
            hits += 1;
        }
        assert!(hits > 100, "{hits} hits");
        assert_finite(&iso, "iso");
    }
}

fn shapes_scene() -> (Volume, MinMaxIndex) {
    let v = volume::<u8>(&ShapesScene::new(
        Dims::new(96, 80, 72).unwrap(),
        2,
        25,
        24,
        100.0,
    ));
    let ix = index(&v);
    (v, ix)
}

fn all_modes() -> Vec<RenderSettings> {
    let base = RenderSettings {
        step: 0.3,
        ..Default::default()
    };
    vec![
        RenderSettings {
            shading: true,
            ..base.clone()
        },
        RenderSettings {
            shading: true,
            gradient: GradientMethod::Analytic,
            interp: Interp::Nearest,
            ..base.clone()
        },
        // Pre-integrated: each sample composites the segment before it,
        // so a skip must take the segment into its first skipped sample
        // and read the front of the first sample after it.
        RenderSettings {
            preintegrated: true,
            ..base.clone()
        },
        RenderSettings {
            preintegrated: true,
            shading: true,
            gradient: GradientMethod::Analytic,
            ..base.clone()
        },
        // Steps of several voxels: a segment into a skipped cell starts
        // deep in a visible one.
        RenderSettings {
            preintegrated: true,
            step: 2.3,
            ert: None,
            ..base.clone()
        },
        // Adaptive steps: a sample in a busy cell stands for up to 64
        // steps. A visible cell's first sample must be the same with
        // skipping on or off, and a strided run of eight read in lanes
        // must be the samples one by one.
        RenderSettings {
            adaptive: Some(0.05),
            shading: true,
            ..base.clone()
        },
        RenderSettings {
            adaptive: Some(0.5),
            step: 0.1,
            ert: None,
            ..base.clone()
        },
        RenderSettings {
            adaptive: Some(0.2),
            interp: Interp::Nearest,
            shading: true,
            gradient: GradientMethod::Analytic,
            ..base.clone()
        },
        RenderSettings {
            mode: Mode::Mip,
            ..base.clone()
        },
        RenderSettings {
            mode: Mode::Minip,
            ..base.clone()
        },
        RenderSettings {
            mode: Mode::XraySum,
            ..base.clone()
        },
        RenderSettings {
            mode: Mode::XrayMean,
            interp: Interp::Nearest,
            ..base.clone()
        },
        RenderSettings {
            mode: Mode::Iso(95.0),
            ..base.clone()
        },
    ]
}

#[test]
fn skipping_never_changes_the_image() {
    let (v, ix) = shapes_scene();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let noise = volume::<f32>(&NoiseScene::new(
        Dims::new(50, 40, 45).unwrap(),
        3,
        NoiseKind::Gradient,
        12.0,
        3,
        255.0,
    ));
    let nix = index(&noise);
    // Transparent below 150, so the noise has empty cells to skip too.
    let upper =
        volrender::tf::parse::parse("point 150 0 0 0 0\npoint 220 255 200 100 0.5").unwrap();
    for (vol, ix, tf, sparse) in [(&v, &ix, &tf, true), (&noise, &nix, &upper, false)] {
        let cam = orbit(vol, 35.0, 25.0, 64);
        for s in all_modes() {
            let (on, off) = with_and_without_skipping(vol, ix, tf, &cam, &s);
            assert_eq!(bits(&on), bits(&off), "{:?} {:?}", s.mode, s.interp);
            assert!(on.stats.samples <= off.stats.samples);
            // (At steps of several voxels pre-integration takes a sample
            // into each skip and reads one back after it.)
            if s.mode == Mode::Dvr && sparse && s.step < 1.0 {
                assert!(
                    on.stats.samples < off.stats.samples / 2,
                    "skipping saved little: {} vs {}",
                    on.stats.samples,
                    off.stats.samples
                );
            }
        }
    }
}

/// The transparent cells and skipping distances a frame derives from its
/// transfer function are kept with the index for the next frame with the
/// same table: frames that alternate transfer functions and steps on one
/// index render what each renders on an index of its own, bit for bit,
/// and what they render without skipping.
#[test]
fn frames_sharing_an_index_keep_each_transfer_functions_cells() {
    let (v, ix) = shapes_scene();
    let shapes = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let upper =
        volrender::tf::parse::parse("point 150 0 0 0 0\npoint 220 255 200 100 0.5").unwrap();
    let lower = volrender::tf::parse::parse("point 0 255 255 255 0.3\npoint 60 0 0 0 0").unwrap();
    let cam = orbit(&v, 35.0, 25.0, 48);
    let dvr = |step: f32| RenderSettings {
        step,
        ..Default::default()
    };
    let mut seen = 0;
    for round in 0..2 {
        for (tf, step) in [(&shapes, 0.3), (&upper, 0.3), (&shapes, 0.7), (&lower, 0.3)] {
            let s = dvr(step);
            let shared = render(&v, Some(&ix), Some(tf), &cam, &s).unwrap();
            let own = render(&v, Some(&ix.clone()), Some(tf), &cam, &s).unwrap();
            assert_eq!(bits(&shared), bits(&own), "round {round}, step {step}");
            let (_, off) = with_and_without_skipping(&v, &ix, tf, &cam, &s);
            assert_eq!(bits(&shared), bits(&off), "round {round}, step {step}");
            assert!(shared.stats.samples < off.stats.samples);
            seen += 1;
        }
    }
    assert_eq!(seen, 8);
}

/// Skips end a margin before cell faces; far from the volume, ray
/// parameters are large and their rounding is coarse, so check that the
/// margin still covers it: a distant eye (t ≈ 4000 for a 96-voxel volume,
/// where an f32 ulp is 2.4e-4), a narrow field of view, a fine step.
#[test]
fn skipping_is_exact_from_far_away() {
    let (v, ix) = shapes_scene();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    for (az, el) in [(35.0, 25.0), (0.0, 0.0), (90.0, 45.0), (211.0, -33.0)] {
        let d = v.dims().as_array();
        let c = Vec3::new((d[0] - 1) as f32, (d[1] - 1) as f32, (d[2] - 1) as f32) * 0.5;
        let cam = Camera::orbit(c, az, el, 4000.0, Projection::Perspective(1.6), 96, 96).unwrap();
        // X-ray sums every sample, so a skipped sample that strayed past a
        // cell's face and picked up a sliver of a neighbour would show; its
        // mean counts skipped samples, so a jump past the ray's end that
        // counted samples beyond it would show too.
        for (mode, preintegrated, adaptive) in [
            (Mode::Dvr, false, None),
            (Mode::Dvr, true, None),
            (Mode::Dvr, false, Some(0.2)),
            (Mode::XraySum, false, None),
            (Mode::XrayMean, false, None),
        ] {
            let s = RenderSettings {
                mode,
                step: 0.1,
                shading: true,
                preintegrated,
                adaptive,
                ..Default::default()
            };
            let (on, off) = with_and_without_skipping(&v, &ix, &tf, &cam, &s);
            assert_eq!(
                bits(&on),
                bits(&off),
                "{mode:?} (pre-integrated: {preintegrated}, adaptive: {adaptive:?}) orbit {az}, {el}"
            );
            assert!(on.stats.skips > 0 && on.stats.samples < off.stats.samples);
        }
    }
}

#[test]
fn early_termination_stays_within_its_bound() {
    let (v, ix) = shapes_scene();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = orbit(&v, 10.0, 30.0, 64);
    for t in [0.9f32, 0.99] {
        let s = RenderSettings {
            step: 0.2,
            shading: true,
            ert: Some(t),
            ..Default::default()
        };
        let cut = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
        let full = render(
            &v,
            Some(&ix),
            Some(&tf),
            &cam,
            &RenderSettings { ert: None, ..s },
        )
        .unwrap();
        let worst = cut
            .rgba
            .iter()
            .zip(&full.rgba)
            .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs()))
            .fold(0.0f32, f32::max);
        assert!(
            worst <= (1.0 - t) + 1e-6,
            "threshold {t}: difference {worst}"
        );
        assert!(cut.stats.samples < full.stats.samples);
    }
}

#[test]
fn thread_count_does_not_change_the_image() {
    let (v, ix) = shapes_scene();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = orbit(&v, 200.0, -15.0, 50);
    for s in all_modes() {
        let frames: Vec<Vec<u32>> = [1, 2, 7]
            .iter()
            .map(|&n| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .unwrap();
                let s = RenderSettings {
                    tile: 7,
                    ..s.clone()
                };
                pool.install(|| bits(&render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap()))
            })
            .collect();
        assert!(frames.windows(2).all(|w| w[0] == w[1]), "{:?}", s.mode);
    }
}

#[test]
fn sliced_bricked_and_compressed_copies_render_identically() {
    use volcore::{BrickGeometry, Compression, Layout};
    use volformats::output::Sink;
    let dir = tempfile::tempdir().unwrap();
    let scene = ShapesScene::new(Dims::new(61, 47, 53).unwrap(), 7, 15, 18, 100.0);
    let src = SceneSource::<u8>::new(&scene);
    let g = BrickGeometry::new(scene.dims(), 16).unwrap();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let mut results = Vec::new();
    for (i, (l, c)) in [
        (Layout::Sliced, Compression::None),
        (Layout::Bricked(g), Compression::None),
        (Layout::Bricked(g), Compression::Zstd(3)),
    ]
    .into_iter()
    .enumerate()
    {
        let p = dir.path().join(format!("{i}.vvol"));
        let mut f = std::fs::File::create(&p).unwrap();
        let mut meta = volcore::VolumeMeta::sliced(scene.dims(), volcore::SampleType::U8);
        meta.layout = l;
        meta.compression = c;
        volformats::vvol::write(&src, meta, Sink::File(&mut f), &|_| {}).unwrap();
        drop(f);
        let v = volformats::vvol::open(&p, Default::default()).unwrap();
        let ix = index(&v);
        let cam = orbit(&v, 60.0, 10.0, 48);
        // The images, and what the effects counted (occlusion rays and
        // their reads, shadow rays and theirs: lanes take the same work).
        let frames: Vec<(Vec<u32>, [u64; 4])> = all_modes()
            .into_iter()
            .chain(batched_modes())
            .map(|s| {
                let f = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
                let e = f.stats.effects;
                let counts = [e.ao_rays, e.ao_samples, e.shadow_rays, e.shadow_samples];
                (bits(&f), counts)
            })
            .collect();
        results.push(frames);
    }
    assert!(results.windows(2).all(|w| w[0] == w[1]));
}

/// Settings whose samples bricked u8 volumes read eight at a time (where
/// the CPU has AVX2): DVR with neither optimisation (every sample in a
/// run), shadow rays in DVR and iso mode from a sun and a point light, at
/// steps that do and do not divide a voxel, and DVR under one sun with a
/// shadow grid, ambient occlusion by rays or by a field, or both (shaded
/// eight at a time), with and without skipping and early termination.
fn batched_modes() -> Vec<RenderSettings> {
    use volrender::{Ao, AoMethod, Light, Lighting, ShadowMethod, Shadows};
    let ao = |method| {
        Some(Ao {
            method,
            radius: Some(9.0),
            seed: 5,
        })
    };
    let lighting = Lighting {
        lights: vec![
            Light::directional(Vec3::new(1.0, 2.0, 0.5)).unwrap(),
            Light::Point {
                position: Vec3::new(30.0, 20.0, 25.0),
                intensity: Vec3::splat(400.0),
            },
        ],
        ..Default::default()
    };
    let shadows = |step| {
        Some(Shadows {
            method: ShadowMethod::Ray,
            step: Some(step),
        })
    };
    let sun = Lighting {
        lights: vec![Light::directional(Vec3::new(-1.0, 2.0, 0.5)).unwrap()],
        ..Default::default()
    };
    let grid = Some(Shadows {
        method: ShadowMethod::Grid { divisor: 2 },
        step: None,
    });
    vec![
        RenderSettings {
            step: 0.2,
            shading: true,
            ert: None,
            ess: false,
            ..Default::default()
        },
        // Strided runs of eight, shaded in lanes, with and without
        // skipping.
        RenderSettings {
            step: 0.1,
            shading: true,
            adaptive: Some(0.5),
            ert: None,
            ..Default::default()
        },
        RenderSettings {
            step: 0.1,
            shading: true,
            adaptive: Some(0.5),
            ess: false,
            lighting: sun.clone(),
            shadows: grid,
            ..Default::default()
        },
        RenderSettings {
            step: 0.2,
            shading: true,
            lighting: sun.clone(),
            shadows: grid,
            ..Default::default()
        },
        RenderSettings {
            step: 0.3,
            shading: true,
            lighting: sun.clone(),
            shadows: grid,
            ert: None,
            ess: false,
            ..Default::default()
        },
        // Early termination at a low opacity, so runs stop part way.
        RenderSettings {
            step: 0.2,
            shading: true,
            lighting: sun.clone(),
            ao: ao(AoMethod::Rays { n: 11 }),
            ert: Some(0.6),
            ..Default::default()
        },
        RenderSettings {
            step: 0.3,
            shading: true,
            lighting: sun.clone(),
            shadows: grid,
            ao: ao(AoMethod::Rays { n: 8 }),
            ert: None,
            ess: false,
            ..Default::default()
        },
        RenderSettings {
            step: 0.2,
            shading: true,
            lighting: sun.clone(),
            ao: ao(AoMethod::Field { k: 16, cell: 4 }),
            ert: Some(0.6),
            ..Default::default()
        },
        RenderSettings {
            step: 0.25,
            shading: true,
            lighting: sun.clone(),
            shadows: grid,
            ao: ao(AoMethod::Field { k: 16, cell: 3 }),
            ..Default::default()
        },
        RenderSettings {
            step: 0.25,
            shading: true,
            lighting: lighting.clone(),
            shadows: shadows(0.2),
            ..Default::default()
        },
        RenderSettings {
            step: 0.3,
            shading: true,
            preintegrated: true,
            lighting: sun,
            shadows: grid,
            ao: ao(AoMethod::Rays { n: 4 }),
            ert: Some(0.6),
            ..Default::default()
        },
        RenderSettings {
            mode: Mode::Iso(95.0),
            step: 0.3,
            shading: true,
            lighting,
            shadows: shadows(0.37),
            ..Default::default()
        },
    ]
}

#[test]
fn hard_cases_give_finite_pixels() {
    let (v, ix) = shapes_scene();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let centre = Vec3::new(47.5, 39.5, 35.5);
    let p = Projection::Perspective(60.0);
    let cams = [
        // Looking straight down the up vector, and straight up.
        Camera::look_at(Vec3::new(47.5, 300.0, 35.5), centre, Vec3::Y, p, 32, 32).unwrap(),
        Camera::look_at(Vec3::new(47.5, -300.0, 35.5), centre, Vec3::Y, p, 32, 32).unwrap(),
        // From inside the volume, and with the volume partly behind.
        Camera::look_at(centre, centre + Vec3::X, Vec3::Y, p, 32, 32).unwrap(),
        Camera::look_at(
            Vec3::new(10.0, 10.0, 10.0),
            Vec3::new(-5.0, 12.0, 40.0),
            Vec3::Y,
            p,
            32,
            32,
        )
        .unwrap(),
        // Axis-parallel orthographic rays exactly on voxel planes and faces.
        Camera::look_at(
            Vec3::new(47.5, 39.5, -10.0),
            centre,
            Vec3::Y,
            Projection::Orthographic(79.0),
            96,
            80,
        )
        .unwrap(),
        Camera::look_at(
            Vec3::new(-10.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::Y,
            Projection::Orthographic(2.0),
            3,
            3,
        )
        .unwrap(),
        // Grazing along the top face.
        Camera::look_at(
            Vec3::new(-20.0, 79.0, 35.5),
            Vec3::new(0.0, 79.0, 35.5),
            Vec3::Y,
            Projection::Perspective(1.0),
            9,
            9,
        )
        .unwrap(),
    ];
    for (i, cam) in cams.iter().enumerate() {
        for s in all_modes() {
            for ess in [true, false] {
                let f = render(
                    &v,
                    Some(&ix),
                    Some(&tf),
                    cam,
                    &RenderSettings { ess, ..s.clone() },
                )
                .unwrap();
                assert_finite(&f, &format!("camera {i} {:?}", s.mode));
            }
        }
    }
    // Tiny and huge steps.
    let cam = orbit(&v, 20.0, 20.0, 16);
    for step in [0.002, 1000.0] {
        for s in all_modes() {
            let f = render(
                &v,
                Some(&ix),
                Some(&tf),
                &cam,
                &RenderSettings { step, ..s },
            )
            .unwrap();
            assert_finite(&f, &format!("step {step}"));
        }
    }
    // Zero, negative and NaN steps are refused.
    for step in [0.0, -1.0, f32::NAN, 1e-9] {
        let r = render(
            &v,
            Some(&ix),
            Some(&tf),
            &cam,
            &RenderSettings {
                step,
                ..Default::default()
            },
        );
        assert!(r.is_err(), "step {step} accepted");
    }
}

#[test]
fn degenerate_volumes_render() {
    let tf = constant_tf(0.5);
    for dims in [
        Dims::new(1, 1, 1).unwrap(),
        Dims::new(1, 9, 9).unwrap(),
        Dims::new(9, 1, 9).unwrap(),
    ] {
        let v = volume::<u8>(&BoxScene::new(dims, 0, 100.0));
        let ix = index(&v);
        let cam = Camera::look_at(
            Vec3::new(-5.0, 4.0, 3.0),
            Vec3::new(0.0, 4.0, 4.0),
            Vec3::Y,
            Projection::Perspective(60.0),
            16,
            16,
        )
        .unwrap();
        for s in all_modes() {
            let f = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
            assert_finite(&f, &format!("{dims} {:?}", s.mode));
        }
    }
}

#[test]
fn nan_samples_are_transparent_and_finite() {
    let d = Dims::new(20, 20, 20).unwrap();
    let mut samples: Vec<f32> =
        pack_sliced(&SceneSource::<f32>::new(&SphereScene::new(d, 9.0, 200.0)));
    for (i, s) in samples.iter_mut().enumerate() {
        if i % 7 == 0 {
            *s = f32::NAN;
        }
    }
    let v = Volume::from_samples(d, samples).unwrap();
    let ix = index(&v);
    let tf = TransferFunction::preset("grey", (0.0, 200.0)).unwrap();
    let cam = orbit(&v, 30.0, 30.0, 24);
    for s in all_modes() {
        let (on, off) = with_and_without_skipping(&v, &ix, &tf, &cam, &s);
        assert_finite(&on, "nan volume");
        assert_eq!(bits(&on), bits(&off), "{:?}", s.mode);
    }
}

/// The step `check::finest_step` gives (vol-render's default when half the
/// smallest spacing is too fine, issue 43) passes the frame's checks, and
/// the f32 below it does not: feasible, and as fine as feasible, from any
/// camera (where the eye is no longer limits the step).
#[test]
fn finest_step_is_the_finest_the_frame_checks_accept() {
    use volrender::frame::check;
    let scene = SphereScene::new(Dims::new(8, 8, 8).unwrap(), 3.0, 200.0);
    for spacing in [
        [1000.0, 1.0, 0.001],
        [1.0, 1.1754944e-38, 1.0],
        [3e-5, 7.0, 2e4],
        [1.0, 1.0, 1.0],
    ] {
        let mut v = volume::<u8>(&scene);
        v.meta.spacing = spacing;
        let hi = Vec3::from(v.meta.world_extent());
        let s = check::finest_step(&v).unwrap();
        let accepted = |step: f32| check::step("step", step, &v).is_ok();
        assert!(accepted(s), "{spacing:?}: {s}");
        assert!(!accepted(s.next_down()), "{spacing:?}: {s}");
        let settings = |step| RenderSettings {
            step,
            ..Default::default()
        };
        for distance in [1.8, 1e3, 1e9] {
            let cam = Camera::orbit(
                hi * 0.5,
                30.0,
                20.0,
                distance * hi.length(),
                Projection::Perspective(45.0),
                8,
                8,
            )
            .unwrap();
            assert!(
                check::frame(&settings(s), &v, &cam).is_ok(),
                "{spacing:?} at {distance}: {s}"
            );
            assert!(
                check::frame(&settings(s.next_down()), &v, &cam).is_err(),
                "{spacing:?} at {distance}: {s}"
            );
        }
    }
}
