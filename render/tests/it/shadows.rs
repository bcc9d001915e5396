//! Shadows: closed forms, determinism, costs that are zero when off, and
//! hard cases.

use crate::common::{orbit_camera, shapes};
use glam::Vec3;
use volcore::{Dims, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::tf::{TfRange, TransferFunction};
use volrender::{
    render, Camera, Frame, Interp, Light, Lighting, Mode, Projection, RenderSettings, ShadowMethod,
    Shadows,
};

/// Opacity of the occluding slab per unit length.
const SLAB_ALPHA: f32 = 0.1;

/// 24 × 24 × 64 voxels: a receiver layer (value 100) at z 8..=15 and,
/// when `occluder`, a slab (value 200, `SLAB_ALPHA` per unit) at z
/// 40..=49: ten units thick.
fn slab_volume(occluder: bool) -> Volume {
    let d = Dims::new(24, 24, 64).unwrap();
    let mut v = vec![0u8; 24 * 24 * 64];
    for z in 0..64 {
        let value = match z {
            8..=15 => 100,
            40..=49 if occluder => 200,
            _ => 0,
        };
        v[z * 576..(z + 1) * 576].fill(value);
    }
    Volume::from_samples(d, v).unwrap()
}

fn slab_tf(slab_alpha: f32) -> TransferFunction {
    TransferFunction {
        points: vec![],
        ranges: vec![
            TfRange {
                lo: 50.0,
                hi: 150.0,
                rgb: [1.0, 1.0, 1.0],
                alpha: 0.02,
            },
            TfRange {
                lo: 150.0,
                hi: 256.0,
                rgb: [1.0, 1.0, 1.0],
                alpha: slab_alpha,
            },
        ],
        domain: Some((0.0, 255.0)),
        reference_step: 1.0,
    }
}

/// Looking along +x at the receiver, orthographic, so every ray keeps its
/// height; one light from +z, no ambient term.
fn side_camera() -> Camera {
    Camera::look_at(
        Vec3::new(-40.0, 11.5, 11.5),
        Vec3::new(11.5, 11.5, 11.5),
        Vec3::Z,
        Projection::Orthographic(12.0),
        24,
        24,
    )
    .unwrap()
}

fn lit_from_above(shadows: Option<Shadows>, step: f32) -> RenderSettings {
    RenderSettings {
        mode: Mode::Dvr,
        step,
        interp: Interp::Nearest,
        shading: true,
        lighting: Lighting {
            lights: vec![Light::Directional {
                towards: Vec3::Z,
                radiance: Vec3::ONE,
            }],
            ambient: Vec3::ZERO,
            ..Default::default()
        },
        ert: None,
        shadows,
        ..Default::default()
    }
}

fn frame(v: &Volume, tf: &TransferFunction, s: &RenderSettings) -> Frame {
    let ix = MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap();
    render(v, Some(&ix), Some(tf), &side_camera(), s).unwrap()
}

/// Per lit pixel, the light reaching the receiver with the slab over the
/// light without it: ln of the ratio of the two frames' colours.
fn log_ratios(shadows: Shadows, step: f32) -> Vec<f64> {
    let tf = slab_tf(SLAB_ALPHA);
    let s = lit_from_above(Some(shadows), step);
    let with = frame(&slab_volume(true), &tf, &s);
    let without = frame(&slab_volume(false), &tf, &s);
    let mut out = Vec::new();
    for (a, b) in with.rgba.iter().zip(&without.rgba) {
        assert!(a.iter().all(|c| c.is_finite()));
        if b[0] > 1e-6 {
            out.push((a[0] as f64 / b[0] as f64).ln());
        }
    }
    assert!(out.len() > 50, "the receiver shows in {} pixels", out.len());
    out
}

/// Optical depth of the ten-unit slab: `−10 · ln(1 − α)`.
fn slab_depth() -> f64 {
    -10.0 * (1.0 - SLAB_ALPHA as f64).ln()
}

#[test]
fn shadow_rays_through_a_slab_pass_exp_minus_sigma_d() {
    // Stated bound: one shadow step's optical depth (a step more or less of
    // the slab is sampled, by where the shaded point sits).
    let sigma = slab_depth() / 10.0;
    for step in [1.0f32, 0.25] {
        let shadows = Shadows {
            method: ShadowMethod::Ray,
            step: Some(step),
        };
        for r in log_ratios(shadows, 0.5) {
            let err = (r + slab_depth()).abs();
            assert!(
                err <= sigma * step as f64 * 1.001 + 1e-4,
                "shadow step {step}: ln T = {r}, want {} within {}",
                -slab_depth(),
                sigma * step as f64
            );
        }
    }
}

#[test]
fn light_grids_through_a_slab_pass_exp_minus_sigma_d() {
    // Stated tolerance: one grid cell's optical depth.
    let sigma = slab_depth() / 10.0;
    for divisor in [1u32, 2, 4] {
        let shadows = Shadows {
            method: ShadowMethod::Grid { divisor },
            step: None,
        };
        for r in log_ratios(shadows, 0.5) {
            let err = (r + slab_depth()).abs();
            assert!(
                err <= sigma * divisor as f64 + 1e-4,
                "divisor {divisor}: ln T = {r}, want {}",
                -slab_depth()
            );
        }
    }
}

#[test]
fn an_opaque_slab_blocks_all_light_and_nothing_is_nan() {
    let tf = slab_tf(1.0);
    for method in [ShadowMethod::Ray, ShadowMethod::Grid { divisor: 2 }] {
        let s = lit_from_above(Some(Shadows { method, step: None }), 0.5);
        let f = frame(&slab_volume(true), &tf, &s);
        // The receiver is black (no ambient, no light); the slab itself,
        // seen from the side, is lit on its top rows only.
        for p in &f.rgba {
            assert!(p.iter().all(|c| c.is_finite() && *c >= 0.0), "{p:?}");
        }
        let lit_receiver = f
            .rgba
            .iter()
            .zip(&f.depth)
            .filter(|(p, _)| p[3] > 0.0 && p[0] > 0.0)
            .count();
        let without = frame(&slab_volume(false), &tf, &s);
        let visible = without.rgba.iter().filter(|p| p[0] > 0.0).count();
        assert!(visible > 50 && lit_receiver < visible, "{method:?}");
    }
}

/// Two directional lights and a point light inside the volume.
fn three_lights() -> Lighting {
    Lighting {
        lights: vec![
            Light::directional(Vec3::new(1.0, 2.0, 3.0)).unwrap(),
            Light::Directional {
                towards: Vec3::new(0.0, 0.0, -1.0),
                radiance: Vec3::new(0.5, 0.4, 0.3),
            },
            Light::Point {
                position: Vec3::new(20.0, 21.0, 19.0),
                intensity: Vec3::splat(300.0),
            },
        ],
        ..Default::default()
    }
}

fn shadow_settings() -> Vec<(String, RenderSettings)> {
    let tf_modes = [("dvr", Mode::Dvr), ("iso", Mode::Iso(90.0))];
    let methods = [
        ShadowMethod::Ray,
        ShadowMethod::Grid { divisor: 1 },
        ShadowMethod::Grid { divisor: 4 },
    ];
    let mut out = Vec::new();
    for (name, mode) in tf_modes {
        for method in methods {
            out.push((
                format!("{name} {method:?}"),
                RenderSettings {
                    mode,
                    step: 0.4,
                    shading: true,
                    lighting: three_lights(),
                    shadows: Some(Shadows {
                        method,
                        step: Some(0.7),
                    }),
                    ..Default::default()
                },
            ));
        }
    }
    out
}

#[test]
fn shadowed_frames_are_identical_across_threads_tiles_and_skipping() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = orbit_camera();
    for (name, s) in shadow_settings() {
        let reference = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
        let e = reference.stats.effects;
        assert!(e.shadow_rays > 0, "{name}: the point light casts rays");
        if !name.contains("Ray") {
            assert_eq!(e.shadow_grids, 2, "{name}: a grid per directional light");
            assert!(e.shadow_grid_bytes > 0);
        }
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
                    let f = pool.install(|| render(&v, Some(&ix), Some(&tf), &cam, &s2).unwrap());
                    assert!(
                        f.rgba == reference.rgba,
                        "{name}: {threads} threads, tile {tile}, skipping {ess} differ"
                    );
                    if !ess {
                        // Skipping only saves samples.
                        assert!(f.stats.effects.shadow_samples >= e.shadow_samples);
                    }
                }
            }
        }
        assert!(reference.rgba.iter().flatten().all(|c| c.is_finite()));
    }
}

#[test]
fn with_shadows_off_no_shadow_work_is_done() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    for mode in [Mode::Dvr, Mode::Iso(90.0)] {
        let s = RenderSettings {
            mode,
            shading: true,
            lighting: three_lights(),
            ..Default::default()
        };
        let f = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s).unwrap();
        assert_eq!(f.stats.effects, Default::default(), "{mode:?}");
        // And shadows darken: the same frame with them is no brighter
        // anywhere and darker somewhere.
        let s2 = RenderSettings {
            shadows: Some(Shadows {
                method: ShadowMethod::Ray,
                step: None,
            }),
            ..s
        };
        let g = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s2).unwrap();
        let sum = |f: &Frame| {
            f.rgba
                .iter()
                .map(|p| (p[0] + p[1] + p[2]) as f64)
                .sum::<f64>()
        };
        assert!(
            sum(&g) < sum(&f) * 0.999,
            "{mode:?}: {} vs {}",
            sum(&g),
            sum(&f)
        );
    }
}

#[test]
fn hard_lights_stay_finite() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let hi = Vec3::new(47.0, 39.0, 43.0);
    let cases: Vec<(&str, Light)> = vec![
        // Light along the view: the headlight.
        ("headlight", Light::HEADLIGHT),
        (
            "point inside",
            Light::Point {
                position: Vec3::new(24.0, 20.0, 22.0),
                intensity: Vec3::splat(100.0),
            },
        ),
        (
            "point on a face",
            Light::Point {
                position: Vec3::new(hi.x, 20.0, 22.0),
                intensity: Vec3::splat(100.0),
            },
        ),
        (
            "point on a corner",
            Light::Point {
                position: hi,
                intensity: Vec3::splat(1e30),
            },
        ),
        (
            "directional along an axis",
            Light::directional(Vec3::X).unwrap(),
        ),
        (
            "directional grazing",
            Light::directional(Vec3::new(1.0, 1e-7, 0.0)).unwrap(),
        ),
    ];
    for (name, light) in cases {
        for mode in [Mode::Dvr, Mode::Iso(90.0)] {
            for method in [ShadowMethod::Ray, ShadowMethod::Grid { divisor: 2 }] {
                let s = RenderSettings {
                    mode,
                    shading: true,
                    lighting: Lighting {
                        lights: vec![light],
                        ..Default::default()
                    },
                    shadows: Some(Shadows { method, step: None }),
                    ..Default::default()
                };
                let f = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s).unwrap();
                assert!(
                    f.rgba.iter().flatten().all(|c| c.is_finite()),
                    "{name}, {mode:?}, {method:?}"
                );
            }
        }
    }
}

#[test]
fn iso_surfaces_cast_hard_shadows() {
    // A floor (z < 8) and a block above it (z 24..=31, x 16..=31, all y);
    // light from +x+z at 45 degrees: the block's shadow falls on the floor
    // 16..24 units toward -x of its own footprint.
    let d = Dims::new(64, 16, 40).unwrap();
    let mut v = vec![0u8; 64 * 16 * 40];
    for z in 0..40usize {
        for y in 0..16usize {
            for x in 0..64usize {
                let inside = z < 8 || ((24..=31).contains(&z) && (16..=31).contains(&x));
                v[(z * 16 + y) * 64 + x] = if inside { 200 } else { 0 };
            }
        }
    }
    let vol = Volume::from_samples(d, v).unwrap();
    let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
    // Straight down, orthographic over the whole floor.
    let cam = Camera::look_at(
        Vec3::new(31.5, 7.5, 100.0),
        Vec3::new(31.5, 7.5, 0.0),
        Vec3::Y,
        Projection::Orthographic(64.0),
        64,
        64,
    )
    .unwrap();
    for method in [
        None,
        Some(ShadowMethod::Ray),
        Some(ShadowMethod::Grid { divisor: 1 }),
    ] {
        let s = RenderSettings {
            mode: Mode::Iso(100.0),
            lighting: Lighting {
                lights: vec![Light::directional(Vec3::new(1.0, 0.0, 1.0)).unwrap()],
                ..Default::default()
            },
            shadows: method.map(|method| Shadows { method, step: None }),
            ..Default::default()
        };
        let f = render(&vol, Some(&ix), None, &cam, &s).unwrap();
        // The middle row of pixels (y = 7.5), by world x.
        let row = 32usize;
        let at = |x: usize| f.rgba[row * 64 + x][0];
        // Floor in the block's shadow (x ≈ 4..=8: from the block's
        // bottom-left edge at x 16, z 24 down to the floor at z 8 is 16
        // units), and floor in the light (x ≈ 44).
        let (shadowed, lit) = (at(6), at(44));
        assert!(lit > 0.0 && shadowed > 0.0, "{method:?}");
        if method.is_none() {
            assert!(
                (shadowed - lit).abs() < 1e-6,
                "no shadows: the floor is even"
            );
        } else {
            // Ambient only (0.25 of the colour) against ambient + diffuse.
            assert!(shadowed < 0.5 * lit, "{method:?}: {shadowed} vs {lit}");
            // The floor away from the shadow is lit as without shadows.
            assert!(at(50) > 0.9 * lit, "{method:?}");
        }
    }
}

#[test]
fn bad_shadow_settings_are_refused() {
    let (v, ix) = shapes();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let ray = Some(Shadows {
        method: ShadowMethod::Ray,
        step: None,
    });
    let cases = [
        (
            RenderSettings {
                mode: Mode::Mip,
                shadows: ray,
                ..Default::default()
            },
            "DVR and iso",
        ),
        (
            RenderSettings {
                shading: false,
                shadows: ray,
                ..Default::default()
            },
            "need shading",
        ),
        (
            RenderSettings {
                shading: true,
                shadows: Some(Shadows {
                    method: ShadowMethod::Grid { divisor: 3 },
                    step: None,
                }),
                ..Default::default()
            },
            "1, 2 or 4",
        ),
        (
            RenderSettings {
                shading: true,
                shadows: Some(Shadows {
                    method: ShadowMethod::Ray,
                    step: Some(0.0),
                }),
                ..Default::default()
            },
            "shadow step 0",
        ),
    ];
    for (s, want) in cases {
        let e = render(&v, Some(&ix), Some(&tf), &orbit_camera(), &s).unwrap_err();
        assert!(e.to_string().contains(want), "{e}");
    }
}
