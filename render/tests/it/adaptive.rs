//! Adaptive steps (`RenderSettings::adaptive`): closed form where the
//! transfer function is constant, the step alone at a tolerance too tight
//! for any stride, an error that follows the tolerance, and refusals.
//! Their exactness across skipping, threads, tiles and layouts is checked
//! with every mode in `render.rs`.

use glam::Vec3;
use volcore::region::pack_sliced;
use volcore::scene::{BoxScene, NoiseKind, NoiseScene, Scene, SceneSource, ShapesScene};
use volcore::{Dims, Sample, Volume};
use volindex::{BuildOptions, MinMaxIndex};
use volrender::tf::{parse, TfPoint};
use volrender::{render, render_tf, Camera, Frame, Mode, Projection, RenderSettings};
use volrender::{Tf, TransferFunction};

fn volume<T: Sample + volcore::volume::OpenSample>(scene: &dyn Scene) -> Volume {
    Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<T>::new(scene))).unwrap()
}

fn index(v: &Volume) -> MinMaxIndex {
    MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap()
}

fn camera(v: &Volume, w: u32) -> Camera {
    let d = v.dims().as_array();
    let c = Vec3::new((d[0] - 1) as f32, (d[1] - 1) as f32, (d[2] - 1) as f32) * 0.5;
    Camera::orbit(
        c,
        30.0,
        20.0,
        c.length() * 3.0,
        Projection::Perspective(40.0),
        w,
        w,
    )
    .unwrap()
}

/// Root-mean-square difference of two frames' colour and opacity.
fn rms(a: &Frame, b: &Frame) -> f64 {
    let n = a.rgba.len() * 4;
    let sum: f64 = a
        .rgba
        .iter()
        .flatten()
        .zip(b.rgba.iter().flatten())
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum();
    (sum / n as f64).sqrt()
}

/// A box of value 100 in zeros, through a transfer function constant over
/// every value: each cell's classification varies by nothing, so samples
/// stand for the longest strides and the stretched opacity
/// `1 − (1 − α)^n` is the segment's closed form. The frame equals the
/// one-sample-per-step frame to rounding, with a fraction of its samples.
#[test]
fn a_constant_transfer_function_takes_long_strides_in_closed_form() {
    let v = volume::<u8>(&BoxScene::new(Dims::new(40, 36, 32).unwrap(), 0, 100.0));
    let ix = index(&v);
    let p = |value| TfPoint {
        value,
        rgb: [1.0, 0.5, 0.25],
        alpha: 0.03,
    };
    let tf = TransferFunction {
        points: vec![p(0.0), p(255.0)],
        ranges: vec![],
        domain: Some((0.0, 255.0)),
        reference_step: 1.0,
    };
    let cam = camera(&v, 48);
    let base = RenderSettings {
        step: 0.05,
        ert: None,
        ..Default::default()
    };
    let plain = render(&v, Some(&ix), Some(&tf), &cam, &base).unwrap();
    let adaptive = RenderSettings {
        adaptive: Some(1e-6),
        ..base
    };
    let strided = render(&v, Some(&ix), Some(&tf), &cam, &adaptive).unwrap();
    for (a, b) in plain.rgba.iter().zip(&strided.rgba) {
        for c in 0..4 {
            assert!((a[c] - b[c]).abs() < 2e-5, "{a:?} vs {b:?}");
        }
    }
    assert!(plain.rgba.iter().any(|p| p[3] > 0.5), "the box shows");
    assert!(
        strided.stats.samples * 20 < plain.stats.samples,
        "{} samples strided vs {} plain",
        strided.stats.samples,
        plain.stats.samples
    );
}

/// At a tolerance no cell's variation meets, every stride is one step:
/// the frame is the plain frame bit for bit, shaded or not.
#[test]
fn a_tolerance_too_tight_for_any_stride_is_the_step_alone() {
    let v = volume::<u8>(&ShapesScene::new(
        Dims::new(64, 56, 48).unwrap(),
        2,
        20,
        16,
        100.0,
    ));
    let ix = index(&v);
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = camera(&v, 48);
    for shading in [false, true] {
        let base = RenderSettings {
            step: 0.3,
            shading,
            ..Default::default()
        };
        let plain = render(&v, Some(&ix), Some(&tf), &cam, &base).unwrap();
        let tight = RenderSettings {
            adaptive: Some(1e-30),
            ..base
        };
        let f = render(&v, Some(&ix), Some(&tf), &cam, &tight).unwrap();
        assert_eq!(f.rgba, plain.rgba, "shading {shading}");
        assert_eq!(f.stats.samples, plain.stats.samples);
    }
}

/// On smooth noise through a ramp, the error against a fine reference
/// grows with the tolerance and stays near the plain step's at a tight
/// one, with fewer samples; ignoring the cells' variation (a huge
/// tolerance: the longest strides everywhere) costs far more error.
#[test]
fn the_error_follows_the_tolerance() {
    let v = volume::<f32>(&NoiseScene::new(
        Dims::new(64, 64, 64).unwrap(),
        3,
        NoiseKind::Gradient,
        24.0,
        2,
        255.0,
    ));
    let ix = index(&v);
    let tf = parse::parse("point 100 0 0 0 0\npoint 160 255 160 60 0.3\npoint 255 255 255 255 0.8")
        .unwrap();
    let cam = camera(&v, 64);
    let at = |step: f32, adaptive: Option<f32>| {
        let s = RenderSettings {
            step,
            adaptive,
            ..Default::default()
        };
        render(&v, Some(&ix), Some(&tf), &cam, &s).unwrap()
    };
    let reference = at(0.02, None);
    let plain = at(0.2, None);
    let base = rms(&plain, &reference);
    let mut last = 0.0;
    let mut samples = plain.stats.samples;
    for tol in [0.001, 0.01, 0.1] {
        let f = at(0.2, Some(tol));
        let e = rms(&f, &reference);
        assert!(e >= last * 0.9, "tol {tol}: error {e} below {last}");
        assert!(f.stats.samples <= samples, "tol {tol}: more samples");
        (last, samples) = (e, f.stats.samples);
        if tol == 0.001 {
            assert!(
                e < base * 1.5 + 1e-4,
                "tol {tol}: error {e} vs the step's {base}"
            );
        }
    }
    assert!(
        samples * 2 < plain.stats.samples,
        "{samples} vs {}",
        plain.stats.samples
    );
    let blind = at(0.2, Some(1e9));
    assert!(
        rms(&blind, &reference) > 3.0 * base,
        "the longest strides everywhere show"
    );
}

/// Settings adaptive steps do not apply to are refused with the reason.
#[test]
fn adaptive_steps_are_refused_where_they_do_not_apply() {
    let v = volume::<u8>(&BoxScene::new(Dims::new(16, 16, 16).unwrap(), 0, 100.0));
    let ix = index(&v);
    let tf = TransferFunction::preset("shapes", (0.0, 255.0)).unwrap();
    let cam = camera(&v, 8);
    let adaptive = RenderSettings {
        adaptive: Some(0.01),
        ..Default::default()
    };
    let refused = |s: &RenderSettings, tf: Option<&Tf>, ix: Option<&MinMaxIndex>, why: &str| {
        let e = render_tf(&v, ix, tf, &cam, s).unwrap_err().to_string();
        assert!(e.contains(why), "{e}");
    };
    let one = Tf::OneD(tf.clone());
    for mode in [Mode::Mip, Mode::XraySum, Mode::Iso(50.0)] {
        let s = RenderSettings {
            mode,
            ..adaptive.clone()
        };
        refused(&s, Some(&one), Some(&ix), "adaptive steps are for DVR");
    }
    let pre = RenderSettings {
        preintegrated: true,
        ..adaptive.clone()
    };
    refused(&pre, Some(&one), Some(&ix), "do not combine");
    for tol in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let s = RenderSettings {
            adaptive: Some(tol),
            ..Default::default()
        };
        refused(&s, Some(&one), Some(&ix), "positive number");
    }
    refused(&adaptive, Some(&one), None, "need the volume's index");
    let two = Tf::preset("boundary", (0.0, 255.0), 50.0).unwrap();
    refused(&adaptive, Some(&two), Some(&ix), "1D transfer functions");
}

/// What the march told a ray: each sample taken as (index, steps it stands
/// for, ray parameter bits), and how many strided runs came in lanes.
#[derive(Default)]
struct Record {
    stretch: u32,
    taken: Vec<(i64, u32, u32)>,
    strided_runs: usize,
}

impl volrender::trace::march::RayMarch for Record {
    type Query = ();
    const CACHE_BUSY: bool = true;
    const BATCH: bool = true;
    fn query(&self) {}
    fn stretch(&mut self, n: u32) {
        self.stretch = n;
    }
    fn sample<C: volcore::Cursor>(
        &mut self,
        _: &mut C,
        k: i64,
        t: f32,
        _: Vec3,
        _: Option<usize>,
    ) -> volrender::trace::march::Flow {
        self.taken.push((k, self.stretch, t.to_bits()));
        volrender::trace::march::Flow::Next
    }
    fn sample8<C: volcore::Cursor>(
        &mut self,
        _: &mut C,
        k: i64,
        t: &[f32; 8],
        _: &[f32; 8],
        _: &volrender::trace::march::RaySteps,
    ) -> volrender::trace::march::Flow {
        self.strided_runs += usize::from(self.stretch > 1);
        for (i, t) in t.iter().enumerate() {
            self.taken.push((
                k + i as i64 * i64::from(self.stretch),
                self.stretch,
                t.to_bits(),
            ));
        }
        volrender::trace::march::Flow::Next
    }
}

/// A cursor that reads no runs in lanes: the march takes every sample
/// one by one.
struct OneByOne<C>(C);

impl<C: volcore::Cursor> volcore::Cursor for OneByOne<C> {
    fn dims(&self) -> Dims {
        self.0.dims()
    }
    fn voxel(&mut self, x: u64, y: u64, z: u64) -> f32 {
        self.0.voxel(x, y, z)
    }
    fn cell(&mut self, i: u64, j: u64, k: u64) -> [f32; 8] {
        self.0.cell(i, j, k)
    }
}

/// One march of `steps` under `accel`, reading runs in lanes where the
/// volume's cursor does (`lanes`) or one by one.
struct Walk<'a> {
    steps: &'a volrender::trace::march::RaySteps,
    accel: &'a volrender::accel::FixedCells<'a>,
    lanes: bool,
}

impl volcore::VolumeVisitor for Walk<'_> {
    type Output = Record;
    fn visit<S: volcore::VoxelSource>(self, src: &S) -> Record {
        use volrender::trace::march::march;
        let mut r = Record::default();
        let mut cur = src.cursor();
        if self.lanes {
            march(&mut r, &self.accel, &mut cur, self.steps);
        } else {
            march(&mut r, &self.accel, &mut OneByOne(cur), self.steps);
        }
        r
    }
}

/// The march with strides set cell by cell at random (some cells
/// transparent): for random rays, runs of eight in lanes take the samples
/// one by one takes, at the same parameters and stretches; without
/// skipping the stretches tile the ray exactly; with skipping, every
/// sample in a visible cell is taken as without. (Among 30 000 rays, some
/// have a sample that rounds into a cell the previous cell's exit says it
/// has not reached: without the per-sample look-up in transparent cells,
/// such a ray's strides start one sample apart with and without skipping.)
#[test]
fn strided_marches_agree_in_lanes_and_with_skipping() {
    use volcore::grid::Locator;
    use volrender::accel::strides::{LOOK_UP, MAX_STRIDE_LOG2};
    use volrender::accel::FixedCells;
    use volrender::trace::march::RaySteps;
    let v = volume::<u8>(&NoiseScene::new(
        Dims::new(72, 64, 56).unwrap(),
        1,
        NoiseKind::Gradient,
        20.0,
        1,
        255.0,
    ));
    let ix = index(&v);
    let level = &ix.levels()[0];
    let mut rng = fastrand::Rng::with_seed(11);
    let transparent: Vec<bool> = (0..level.len()).map(|_| rng.u8(..4) == 0).collect();
    let strides: Vec<u8> = transparent
        .iter()
        .map(|&t| {
            if t {
                LOOK_UP
            } else {
                rng.u8(..=MAX_STRIDE_LOG2)
            }
        })
        .collect();
    let flags: Vec<Vec<bool>> = ix
        .levels()
        .iter()
        .enumerate()
        .map(|(l, lv)| {
            if l == 0 {
                transparent.clone()
            } else {
                vec![false; lv.len()]
            }
        })
        .collect();
    let skipping = FixedCells::transparent(&ix, flags).with_strides(strides.clone());
    let walking = FixedCells::none(&ix).with_strides(strides);
    let dims = v.dims();
    let loc = Locator::new(dims);
    let hi = Vec3::new(71.0, 63.0, 55.0);
    let (mut rays, mut runs) = (0, 0);
    for _ in 0..30_000 {
        let dir = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
        let Some(dir) = dir.try_normalize() else {
            continue;
        };
        let origin = Vec3::splat(36.0) - dir * 150.0
            + Vec3::new(rng.f32() * 40.0 - 20.0, rng.f32() * 40.0 - 20.0, 0.0);
        let ray = volrender::ray::Ray { origin, dir };
        let Some((t0, t1)) = volrender::ray::intersect_box(&ray, Vec3::ZERO, hi) else {
            continue;
        };
        let step = [0.05, 0.13, 0.4][rays % 3];
        let steps = RaySteps::voxel_space(origin, dir, t0, t1, step, loc);
        if steps.k0 > steps.last {
            continue;
        }
        rays += 1;
        let walk = |accel: &FixedCells, lanes: bool| {
            v.visit(Walk {
                steps: &steps,
                accel,
                lanes,
            })
        };
        let (lanes, one) = (walk(&walking, true), walk(&walking, false));
        assert_eq!(lanes.taken, one.taken, "lanes and one by one differ");
        runs += lanes.strided_runs;
        let covered: i64 = one.taken.iter().map(|s| i64::from(s.1)).sum();
        assert_eq!(
            covered,
            steps.last - steps.k0 + 1,
            "the stretches tile the ray"
        );
        let visible = |r: &Record| -> Vec<(i64, u32, u32)> {
            r.taken
                .iter()
                .filter(|s| {
                    let p = steps.at(f32::from_bits(s.2));
                    let c = level.cell_of(p.to_array(), dims);
                    !transparent[level.index(c[0], c[1], c[2])]
                })
                .copied()
                .collect()
        };
        let skipped = walk(&skipping, true);
        assert_eq!(
            visible(&skipped),
            visible(&one),
            "skipping moved a visible sample"
        );
    }
    assert!(
        rays > 20_000 && runs > 1000,
        "{rays} rays, {runs} strided runs in lanes"
    );
}
