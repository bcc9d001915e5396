//! Golden images: hashes of frames recorded from the renderer before its
//! restructuring, so that any change to what a frame holds (colour, the
//! mode's value, depth, samples per pixel) shows, bit for bit.
//!
//! The hash covers every pixel's RGBA, value and depth as raw f32 bits and
//! its sample count. The DVR frames with skipping were re-recorded once
//! when culled pixel blocks stopped taking the odd sample a ray takes in a
//! skipped cell within a rounding margin of its face: their RGBA, value
//! and depth hashed without sample counts were checked unchanged, frame by
//! frame, before and after. They were re-recorded again when skips
//! began to jump whole clear blocks of cells ahead of the ray (fewer such
//! odd samples), with the same check. To see the current hashes, and
//! beside them the hash without sample counts (after a deliberate change
//! of output), run `GOLDEN_PRINT=1 cargo test -p volrender --test it
//! golden:: -- --nocapture`.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{NoiseKind, NoiseScene, Scene, SceneSource, ShapesScene};
use volcore::{Dims, Sample, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::tf::TransferFunction;
use volrender::{render, Camera, Frame, GradientMethod, Interp, Mode, Projection, RenderSettings};

fn volume<T: Sample + volcore::volume::OpenSample>(scene: &dyn Scene) -> Volume {
    Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<T>::new(scene))).unwrap()
}

/// FNV-1a over the frame's pixels, in row order.
fn hash(f: &Frame) -> u64 {
    hash_with(f, true)
}

fn hash_with(f: &Frame, counts: bool) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |w: u32| {
        for b in w.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for i in 0..f.rgba.len() {
        for c in f.rgba[i] {
            eat(c.to_bits());
        }
        // Values are f64 since X-ray sums of huge values stay finite; every
        // frame here holds f32 values, hashed as before.
        eat((f.value[i] as f32).to_bits());
        eat(f.depth[i].to_bits());
        if counts {
            eat(f.samples[i]);
        }
    }
    h
}

fn check(name: &str, f: &Frame, want: u64) {
    let got = hash(f);
    if std::env::var_os("GOLDEN_PRINT").is_some() {
        println!(
            "{name}: 0x{got:016x} ({} samples), pixels 0x{:016x}",
            f.stats.samples,
            hash_with(f, false)
        );
        return;
    }
    assert_eq!(
        got, want,
        "{name}: frame hash 0x{got:016x}, recorded 0x{want:016x}"
    );
}

/// The demo's frame: the thesis scene at 256³, its transfer function,
/// Phong shading with central differences, step 0.2, 512×512, the eye on
/// the diagonal (as `scripts/demo.sh` renders it).
#[test]
fn demo_thesis_frame_is_unchanged() {
    let v = volume::<u8>(&ShapesScene::new(
        Dims::new(256, 256, 256).unwrap(),
        2,
        70,
        22,
        100.0,
    ));
    let ix = MinMaxIndex::build_volume(&v, &BuildOptions::default(), 0).unwrap();
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = Camera::look_at(
        Vec3::splat(352.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective(60.0),
        512,
        512,
    )
    .unwrap();
    let s = RenderSettings {
        step: 0.2,
        shading: true,
        ..Default::default()
    };
    let f = render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap();
    check("demo", &f, 0xc049_89cc_8730_c6e6);
}

fn modes() -> Vec<(&'static str, RenderSettings)> {
    let base = RenderSettings {
        step: 0.35,
        ..Default::default()
    };
    let with = |mode| RenderSettings {
        mode,
        ..base.clone()
    };
    vec![
        ("dvr", base.clone()),
        (
            "dvr-phong-central",
            RenderSettings {
                shading: true,
                ..base.clone()
            },
        ),
        (
            "dvr-phong-analytic-nearest-noert",
            RenderSettings {
                shading: true,
                gradient: GradientMethod::Analytic,
                interp: Interp::Nearest,
                ert: None,
                ..base.clone()
            },
        ),
        (
            "dvr-phong-analytic-noess",
            RenderSettings {
                shading: true,
                gradient: GradientMethod::Analytic,
                ess: false,
                ..base.clone()
            },
        ),
        ("mip", with(Mode::Mip)),
        (
            "mip-nearest-noert",
            RenderSettings {
                interp: Interp::Nearest,
                ert: None,
                ..with(Mode::Mip)
            },
        ),
        ("minip", with(Mode::Minip)),
        ("xray", with(Mode::XraySum)),
        (
            "xray-mean-nearest",
            RenderSettings {
                interp: Interp::Nearest,
                ..with(Mode::XrayMean)
            },
        ),
        ("iso-central", with(Mode::Iso(97.0))),
        (
            "iso-analytic-nearest",
            RenderSettings {
                gradient: GradientMethod::Analytic,
                interp: Interp::Nearest,
                ..with(Mode::Iso(97.0))
            },
        ),
        (
            "iso-noess",
            RenderSettings {
                ess: false,
                ..with(Mode::Iso(97.0))
            },
        ),
    ]
}

/// One frame per mode and per option, on a u8 scene with empty space and
/// on an f32 noise volume (every sample busy, negative values included).
#[test]
fn one_frame_per_mode_is_unchanged() {
    let shapes = volume::<u8>(&ShapesScene::new(
        Dims::new(96, 80, 72).unwrap(),
        5,
        30,
        20,
        100.0,
    ));
    let noise = volume::<f32>(&NoiseScene::new(
        Dims::new(60, 50, 40).unwrap(),
        4,
        NoiseKind::Gradient,
        14.0,
        3,
        180.0,
    ));
    let shapes_tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let noise_tf = volrender::tf::parse::parse(
        "domain -180 180\npoint 0 0 0 0 0\npoint 60 255 120 40 0.08\npoint 140 255 255 230 0.5",
    )
    .unwrap();
    let want: &[(&str, u64)] = &[
        ("shapes/dvr", 0xa965_697f_fb37_03f5),
        ("shapes/dvr-phong-central", 0x39fb_b5e4_56e7_2488),
        (
            "shapes/dvr-phong-analytic-nearest-noert",
            0xc9f3_7c59_1850_89e8,
        ),
        ("shapes/dvr-phong-analytic-noess", 0x3044_be60_ded1_c016),
        ("shapes/mip", 0x7afa_86d2_5f66_1143),
        ("shapes/mip-nearest-noert", 0x3437_d6e0_a3f7_6dbb),
        ("shapes/minip", 0x83f4_773f_076e_2f42),
        ("shapes/xray", 0x60af_19e3_0dc5_ad3b),
        ("shapes/xray-mean-nearest", 0xc072_423a_4822_33c7),
        ("shapes/iso-central", 0x395d_6611_9edf_4bcf),
        ("shapes/iso-analytic-nearest", 0xdd07_2af8_d3c5_17b5),
        ("shapes/iso-noess", 0x3fac_0858_2917_57a9),
        ("noise/dvr", 0x69d2_18a5_9c90_1b40),
        ("noise/dvr-phong-central", 0x88dd_e3e2_0fbd_1a71),
        (
            "noise/dvr-phong-analytic-nearest-noert",
            0xf3bb_d070_5de3_9513,
        ),
        ("noise/dvr-phong-analytic-noess", 0xca2e_894b_c2c7_fb24),
        ("noise/mip", 0x8ba1_efa7_fb24_bc89),
        ("noise/mip-nearest-noert", 0x45ef_24cc_0cc9_02ae),
        ("noise/minip", 0x9ed3_a190_b781_d5c4),
        ("noise/xray", 0x2d5a_4e25_a6a3_dbfd),
        ("noise/xray-mean-nearest", 0xb3e4_28e7_5d61_5fdf),
        ("noise/iso-central", 0x8e6c_d1e7_e40b_947f),
        ("noise/iso-analytic-nearest", 0xa309_8362_ee82_3b10),
        ("noise/iso-noess", 0xa17d_2130_6272_1b4d),
    ];
    let mut i = 0;
    for (scene, v, tf) in [
        ("shapes", &shapes, &shapes_tf),
        ("noise", &noise, &noise_tf),
    ] {
        let ix = MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap();
        let d = v.dims().as_array();
        let c = Vec3::new((d[0] - 1) as f32, (d[1] - 1) as f32, (d[2] - 1) as f32) * 0.5;
        let cam =
            Camera::orbit(c, 33.0, 21.0, 170.0, Projection::Perspective(40.0), 96, 80).unwrap();
        for (name, s) in modes() {
            let f = render(v, Some(&ix), Some(tf), &cam, &s).unwrap();
            let (label, h) = want[i];
            assert_eq!(label, format!("{scene}/{name}"));
            check(label, &f, h);
            i += 1;
        }
    }
}
