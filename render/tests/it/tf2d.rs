//! Two-dimensional transfer functions: equivalence with 1D where they are
//! flat along the gradient axis, a boundary shell where the closed form
//! puts it, and exact skipping.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{NoiseKind, NoiseScene, Scene, SceneSource, ShapesScene, SphereScene};
use volcore::{Dims, Sample, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::tf::parse::parse_any;
use volrender::tf::{Tf, TransferFunction, TransferFunction2d};
use volrender::{render_tf, Camera, Frame, GradientMethod, Interp, Projection, RenderSettings};

fn volume<T: Sample + volcore::volume::OpenSample>(scene: &dyn Scene) -> Volume {
    Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<T>::new(scene))).unwrap()
}

fn index(v: &Volume) -> MinMaxIndex {
    MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap()
}

fn image_bits(f: &Frame) -> Vec<u32> {
    f.rgba.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

fn orbit(v: &Volume, az: f32, el: f32, w: u32) -> Camera {
    let c = Vec3::from(v.meta.world_extent()) * 0.5;
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

/// Every option that changes the DVR loop.
fn variants() -> Vec<RenderSettings> {
    let mut out = Vec::new();
    for shading in [false, true] {
        for gradient in [GradientMethod::Central, GradientMethod::Analytic] {
            for interp in [Interp::Trilinear, Interp::Nearest] {
                for ert in [Some(0.95), None] {
                    out.push(RenderSettings {
                        step: 0.4,
                        shading,
                        gradient,
                        interp,
                        ert,
                        ..Default::default()
                    });
                }
            }
        }
    }
    out
}

fn shapes() -> Volume {
    volume::<u8>(&ShapesScene::new(
        Dims::new(80, 72, 64).unwrap(),
        4,
        20,
        20,
        100.0,
    ))
}

/// A 2D function that is the 1D one at every gradient magnitude, and a 2D
/// function whose rectangles span the whole gradient axis with the 1D
/// ranges' colours: both render exactly the 1D image, in every variant,
/// with and without skipping.
#[test]
fn flat_along_the_gradient_axis_renders_as_1d() {
    let v = shapes();
    let ix = index(&v);
    let one = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let layered = Tf::TwoD(TransferFunction2d::from_1d(one.clone(), Some((0.0, 90.0))));
    let rects = parse_any(
        "domain 0 255\ngradient-domain 0 200\n\
         rect 85 95 0 1e30 255 0 0 0.02\n\
         rect 95 100 0 1e30 0 0 255 0.3\n\
         rect 100 115 0 1e30 0 255 0 0.6\n",
    )
    .unwrap();
    assert!(matches!(rects, Tf::TwoD(_)));
    let one = Tf::OneD(one);
    let cam = orbit(&v, 40.0, 25.0, 56);
    for s in variants() {
        for ess in [true, false] {
            let s = RenderSettings { ess, ..s.clone() };
            let want = image_bits(&render_tf(&v, Some(&ix), Some(&one), &cam, &s).unwrap());
            for two in [&layered, &rects] {
                let got = render_tf(&v, Some(&ix), Some(two), &cam, &s).unwrap();
                assert_eq!(image_bits(&got), want, "{s:?}");
            }
        }
    }
}

/// The boundary preset on a solid sphere whose surface is a linear ramp of
/// width W around radius R: the gradient is nonzero only in the shell
/// `R ± W/2`, so the interior and the outside are transparent. Rays that
/// pass outside the shell stay empty; a ray through the centre crosses the
/// shell twice, square on; a ray that grazes the inside of the shell runs
/// along it for far longer and so is far more opaque (limb brightening,
/// the mark of a hollow shell: a solid ball is most opaque at its centre).
/// With a 1D function that makes every nonzero value opaque the profile is
/// the reverse.
#[test]
fn boundary_preset_lights_a_shell_at_the_radius() {
    let (n, r, w) = (65u64, 24.0f32, 4.0f32);
    let scene = SphereScene::with_edge(Dims::new(n, n, n).unwrap(), r, 200.0, w);
    let v = volume::<f32>(&scene);
    let ix = index(&v);
    let c = (n - 1) as f32 / 2.0;
    // Orthographic along z, one pixel per voxel, pixel x centred on
    // x = c + (x - 32).
    let cam = Camera::look_at(
        Vec3::new(c, c, -100.0),
        Vec3::splat(c),
        Vec3::Y,
        Projection::Orthographic(65.0),
        65,
        65,
    )
    .unwrap();
    // A gradient domain well past the shell's 50 per voxel keeps the
    // opacity low enough that a grazing ray does not saturate.
    let boundary = Tf::preset("boundary", (0.0, 200.0), 800.0).unwrap();
    let solid = parse_any("point 0 255 255 255 0\npoint 1 255 255 255 0.3\n").unwrap();
    for gradient in [GradientMethod::Central, GradientMethod::Analytic] {
        let s = RenderSettings {
            step: 0.1,
            ert: None,
            gradient,
            ..Default::default()
        };
        let f = render_tf(&v, Some(&ix), Some(&boundary), &cam, &s).unwrap();
        let alpha = |b: i64| f.rgba[(32 * 65 + 32 + b) as usize][3];
        // Optical depth along a ray at distance b from the centre is the
        // opacity's rate times the ray's length inside the shell, so its
        // ratio between two rays is the ratio of their chord lengths.
        let depth = |b: i64| -(1.0 - alpha(b) as f64).ln();
        let chord = |rad: f64, b: f64| 2.0 * (rad * rad - b * b).max(0.0).sqrt();
        let (inner, outer) = ((r - 0.5 * w) as f64, (r + 0.5 * w) as f64);
        let length = |b: i64| chord(outer, b as f64) - chord(inner, b as f64);
        assert!(alpha(0) > 0.05, "{gradient:?}: centre alpha {}", alpha(0));
        for b in [12, 21] {
            let (got, want) = (depth(b) / depth(0), length(b) / length(0));
            assert!(
                (got / want - 1.0).abs() < 0.25,
                "{gradient:?}: depth ratio {got:.3} at {b} voxels from the centre, shell geometry gives {want:.3}"
            );
        }
        // A ray grazing the inside of the shell is far more opaque than
        // one through the centre (twice the path here).
        assert!(depth(21) > 1.8 * depth(0));
        // Outside the shell (plus a voxel for the gradient's reach) and
        // its interpolation footprint: nothing.
        for b in ((r + 0.5 * w).ceil() as i64 + 2)..=32 {
            assert_eq!(alpha(b), 0.0, "{gradient:?}: pixel {b} from the centre");
        }
        // The same rays with a 1D function: most opaque at the centre.
        let f1 = render_tf(&v, Some(&ix), Some(&solid), &cam, &s).unwrap();
        let a1 = |b: i64| f1.rgba[(32 * 65 + 32 + b) as usize][3];
        assert!(a1(0) > a1(21), "1D: centre {} vs {}", a1(0), a1(21));
    }
}

/// Skipping with a 2D function is exact (every option, a sparse scene and
/// a dense noise volume with a 2D function that leaves low gradients
/// transparent), saves samples where there is empty space, and the image
/// does not depend on the thread count or the tile size.
#[test]
fn skipping_and_threads_leave_2d_images_unchanged() {
    // Sparse: a few shapes with wide empty gaps between them.
    let v = volume::<u8>(&ShapesScene::new(
        Dims::new(112, 96, 80).unwrap(),
        3,
        6,
        16,
        100.0,
    ));
    let ix = index(&v);
    let noise = volume::<f32>(&NoiseScene::new(
        Dims::new(48, 40, 36).unwrap(),
        6,
        NoiseKind::Gradient,
        10.0,
        3,
        255.0,
    ));
    let nix = index(&noise);
    let boundary = Tf::preset("boundary", (0.0, 255.0), 255.0).unwrap();
    let steep = parse_any(
        "gradient-domain 0 60\nrect -255 255 20 1e30 255 200 120 0.4\nblob 150 10 30 5 90 160 255 0.5\n",
    )
    .unwrap();
    for (vol, ix, tf, sparse) in [(&v, &ix, &boundary, true), (&noise, &nix, &steep, false)] {
        let cam = orbit(vol, 30.0, 20.0, 48);
        for s in variants() {
            let on = render_tf(vol, Some(ix), Some(tf), &cam, &s).unwrap();
            let off = render_tf(
                vol,
                Some(ix),
                Some(tf),
                &cam,
                &RenderSettings {
                    ess: false,
                    ..s.clone()
                },
            )
            .unwrap();
            assert_eq!(image_bits(&on), image_bits(&off), "{s:?}");
            assert!(on.stats.samples <= off.stats.samples);
            if sparse {
                assert!(
                    on.stats.samples < off.stats.samples / 2,
                    "skipping saved little: {} vs {}",
                    on.stats.samples,
                    off.stats.samples
                );
            }
        }
        let s = RenderSettings {
            shading: true,
            step: 0.4,
            ..Default::default()
        };
        let frames: Vec<Vec<u32>> = [(1, 16), (2, 7), (7, 5)]
            .iter()
            .map(|&(n, tile)| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .unwrap();
                let s = RenderSettings { tile, ..s.clone() };
                pool.install(|| image_bits(&render_tf(vol, Some(ix), Some(tf), &cam, &s).unwrap()))
            })
            .collect();
        assert!(frames.windows(2).all(|w| w[0] == w[1]));
    }
}
