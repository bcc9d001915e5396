//! The library as a Python package or a viewer calls it: options from
//! name/value pairs are the command line's, unknown names are refused by
//! name, errors say what kind they are, and a raised flag cancels.

use serde_json::{json, Value};
use std::path::Path;
use volcore::region::pack_sliced;
use volcore::scene::{Scene as _, SceneSource, ShapesScene};
use volcore::{Dims, Volume};
use volscene::{render, Cancel, ErrorKind, Image, Plan, Request, Source};

/// 48 × 40 × 44 voxels of 12 shapes.
fn shapes() -> Volume {
    let scene = ShapesScene::new(Dims::new(48, 40, 44).unwrap(), 2, 12, 14, 100.0);
    Volume::from_samples(scene.dims(), pack_sliced(&SceneSource::<u8>::new(&scene))).unwrap()
}

/// The volume opened as `request` says, its plan, and the image's bits.
fn render_bits(request: &Request) -> (Plan, Vec<u32>) {
    let options = request.options();
    let source = Source::from_volume(options, shapes(), Path::new("shapes.vvol")).unwrap();
    let plan = Plan::for_source(options, &source).unwrap();
    let r = render(options, &source, &plan, &Cancel::new(), |_| {}).unwrap();
    let bits = r.linear_rgb().iter().map(|v| v.to_bits()).collect();
    (plan, bits)
}

fn pairs(v: Value) -> Request {
    let Value::Object(map) = v else { panic!() };
    Request::from_pairs(map).unwrap()
}

#[test]
fn pairs_are_the_command_line_by_the_same_names() {
    let args = [
        "shapes.vvol",
        "--tf",
        "shapes",
        "--size",
        "40x36",
        "--look-at",
        "20,18,-3.5",
        "--orbit",
        "30,20,120",
        "--shading",
        "phong",
        "--light",
        "1,2,3",
        "--shadows",
        "grid:4",
        "--no-ert",
        "--ortho=90",
    ];
    let cli = Request::parse(args).unwrap();
    // Python's spelling (look_at) and the scene file's (no-ert) alike.
    let kw = pairs(json!({
        "volume": "shapes.vvol",
        "tf": "shapes",
        "size": [40, 36],
        "look_at": [20, 18, -3.5],
        "orbit": [30, 20, 120],
        "shading": "phong",
        "light": [1, 2, 3],
        "shadows": "grid:4",
        "no-ert": true,
        "ortho": 90,
        "iso": null,
    }));
    let (a, bits_a) = render_bits(&cli);
    let (b, bits_b) = render_bits(&kw);
    assert_eq!(a.scene, b.scene);
    assert_eq!(a.camera, b.camera);
    assert_eq!(format!("{:?}", a.settings), format!("{:?}", b.settings));
    assert_eq!(a.resolved, b.resolved);
    assert_eq!(bits_a, bits_b);
    assert!(bits_a.iter().any(|&b| b != 0), "the frame shows something");
    assert!(kw.is_given("look_at") && !kw.is_given("fov"));
}

#[test]
fn path_tracing_pairs_are_the_command_line_too() {
    let cli = Request::parse([
        "shapes.vvol",
        "--mode",
        "path",
        "--size",
        "24x20",
        "--density-scale",
        "0.05",
        "--sun=-1,-1.2,0.4:4",
        "--sun",
        "0,-1,0",
        "--spp",
        "4",
        "--g",
        "-0.3",
    ])
    .unwrap();
    let kw = pairs(json!({
        "volume": "shapes.vvol",
        "mode": "path",
        "size": "24x20",
        "density_scale": 0.05,
        "sun": ["-1,-1.2,0.4:4", "0,-1,0"],
        "spp": 4,
        "g": -0.3,
    }));
    let (a, bits_a) = render_bits(&cli);
    let (b, bits_b) = render_bits(&kw);
    assert_eq!(a.scene, b.scene);
    assert_eq!(a.path, b.path);
    assert_eq!(bits_a, bits_b);
}

#[test]
fn scene_only_keys_and_the_effective_scene_read_back() {
    let kw = pairs(json!({
        "volume": "shapes.vvol",
        "tf_text": "domain 0 255\npoint 0 0 0 0 0\npoint 255 255 255 255 1\n",
        "lights": [{"type": "directional", "direction": [0, -1, 0]}],
        "size": [16, 16],
    }));
    let (plan, bits) = render_bits(&kw);
    // The effective scene, as a viewer holds it, makes the same render.
    let Value::Object(map) = serde_json::to_value(&plan.scene).unwrap() else {
        panic!()
    };
    let again = Request::from_pairs(map).unwrap();
    let (plan2, bits2) = render_bits(&again);
    assert_eq!(plan.scene, plan2.scene);
    assert_eq!(bits, bits2);
}

#[test]
fn an_unknown_name_is_refused_naming_it() {
    let e = Request::from_pairs([("fovv", json!(3))]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Usage);
    assert_eq!(e.to_string(), "unknown option `fovv`");
    // The skipped fields are not options either.
    let e = Request::from_pairs([("background_given", json!(true))]).unwrap_err();
    assert!(e.to_string().contains("background_given"), "{e}");
    let e = Request::from_pairs([("size", json!("wide"))]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Usage);
    assert!(e.to_string().contains("'wide' is not WxH"), "{e}");
    let e = Request::from_pairs([("no_ert", json!(3))]).unwrap_err();
    assert_eq!(e.to_string(), "option `no_ert`: expected true or false");
}

#[test]
fn errors_say_whether_an_option_or_a_file_is_wrong() {
    let source = |r: &Request| Source::from_volume(r.options(), shapes(), Path::new("v.vvol"));
    let r = pairs(json!({"iso": 3}));
    let e = Plan::for_source(r.options(), &source(&r).unwrap()).unwrap_err();
    assert_eq!(
        (e.kind(), e.message()),
        (ErrorKind::Option, "v.vvol: --iso needs --mode iso")
    );
    let r = pairs(json!({"tf": "/nonexistent/x.tf"}));
    let e = Plan::for_source(r.options(), &source(&r).unwrap()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::File);
    // The TF file is the input at fault: named, without the volume before it.
    assert!(
        e.message().starts_with("/nonexistent/x.tf: not a preset"),
        "{e}"
    );
    let e = Request::from_pairs([("shadows", json!("cone"))]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Usage);
    assert!(e.message().contains("expected ray, grid"), "{e}");
    let r = pairs(json!({"scene": "/nonexistent/s.toml"}));
    let e = r.with_scene_file().unwrap_err();
    assert_eq!(e.kind(), ErrorKind::File);
    let e =
        Request::from_pairs([("tf", json!("ct")), ("tf-text", json!("domain 0 1"))]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Usage);
}

#[test]
fn a_scene_file_fills_what_the_pairs_do_not_give() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.toml");
    std::fs::write(
        &file,
        "volume = \"v.vvol\"\nfov = 30\nsize = [8, 8]\nno-ess = true\n",
    )
    .unwrap();
    let r = Request::from_pairs([
        ("scene", json!(file.display().to_string())),
        ("size", json!([4, 2])),
        ("no_ess", json!(false)),
    ])
    .unwrap()
    .with_scene_file()
    .unwrap();
    let o = r.options();
    assert_eq!(o.size, (4, 2));
    assert_eq!(o.fov, 30.0);
    assert!(!o.no_ess, "a false given wins over the file's true");
    assert_eq!(r.volume().unwrap(), dir.path().join("v.vvol"));
}

#[test]
fn a_raised_flag_cancels_a_frame_and_path_tracing() {
    for mode in ["dvr", "path"] {
        let r = pairs(json!({"tf": "shapes", "mode": mode, "size": [32, 32], "spp": null}));
        let options = r.options();
        let source = Source::from_volume(options, shapes(), Path::new("v.vvol")).unwrap();
        let plan = Plan::for_source(options, &source).unwrap();
        let cancel = Cancel::new();
        cancel.cancel();
        let e = render(options, &source, &plan, &cancel, |_| {})
            .err()
            .unwrap();
        assert_eq!(e.kind(), ErrorKind::Cancelled, "{mode}");
        assert_eq!(e.message(), "v.vvol: cancelled");
    }
    // Raised between passes: the passes so far are not returned as done.
    let r = pairs(json!({"tf": "shapes", "mode": "path", "size": [16, 16], "spp": 64}));
    let options = r.options();
    let source = Source::from_volume(options, shapes(), Path::new("v.vvol")).unwrap();
    let plan = Plan::for_source(options, &source).unwrap();
    let cancel = Cancel::new();
    let mut passes = 0;
    let e = render(options, &source, &plan, &cancel, |_| {
        passes += 1;
        cancel.cancel();
    })
    .err()
    .unwrap();
    assert_eq!((e.kind(), passes), (ErrorKind::Cancelled, 1));
    // A flag never raised renders the image and its report.
    let r = render(options, &source, &plan, &Cancel::new(), |_| {}).unwrap();
    assert!(matches!(r.image, Image::Path(_)));
    let scene = serde_json::to_value(&plan.scene).unwrap();
    let cx = volscene::report::Context {
        options,
        volume: Path::new("v.vvol"),
        output: None,
        scene: &scene,
    };
    let report = r.report(&cx);
    assert_eq!(report.json["spp"], 64);
    assert_eq!(report.json["output"], Value::Null);
}

#[test]
fn path_tracing_continues_from_earlier_passes_in_memory() {
    let request = pairs(json!({"mode": "path", "tf": "shapes", "size": [24, 20],
                               "orbit": [30, 20, 120], "env": 1, "spp": 3}));
    let options = request.options();
    let source = Source::from_volume(options, shapes(), Path::new("shapes.vvol")).unwrap();
    let plan = Plan::for_source(options, &source).unwrap();
    let at_once = render(options, &source, &plan, &Cancel::new(), |_| {}).unwrap();
    // Three passes of one sample, each continuing the last.
    let mut one = plan.clone();
    if let Some((_, b)) = one.path.as_mut() {
        b.spp = Some(1);
    }
    let mut acc = None;
    let mut last = None;
    for _ in 0..3 {
        let r = volscene::render_from(options, &source, &one, &Cancel::new(), acc, |_| {}).unwrap();
        let bits: Vec<u32> = r.linear_rgb().iter().map(|v| v.to_bits()).collect();
        last = Some(bits);
        acc = r.into_passes();
    }
    let want: Vec<u32> = at_once.linear_rgb().iter().map(|v| v.to_bits()).collect();
    assert_eq!(last.unwrap(), want);
    // Passes of another image size are refused; a ray-cast frame takes none.
    let other = pairs(json!({"mode": "path", "tf": "shapes", "size": [20, 20], "env": 1}));
    let oplan = Plan::for_source(other.options(), &source).unwrap();
    let e = volscene::render_from(
        other.options(),
        &source,
        &oplan,
        &Cancel::new(),
        acc,
        |_| {},
    )
    .err()
    .unwrap();
    assert!(e.message().contains("another scene or image size"), "{e}");
    let cast = pairs(json!({"tf": "shapes", "size": [20, 20]}));
    let cplan = Plan::for_source(cast.options(), &source).unwrap();
    let prior = render(options, &source, &plan, &Cancel::new(), |_| {})
        .unwrap()
        .into_passes();
    assert!(prior.is_some());
    let e = volscene::render_from(
        cast.options(),
        &source,
        &cplan,
        &Cancel::new(),
        prior,
        |_| {},
    );
    assert_eq!(e.err().unwrap().kind(), ErrorKind::Option);
}

/// Probes of a 512² view whose frames each take 2 ms of wall time and
/// report 0.1 ms: the probes' scale of each side, and the renders made.
fn probe_growth(limit_s: f64) -> (f64, usize) {
    let request = Request::parse(["shapes.vvol", "--tf", "shapes", "--size", "512x512"]).unwrap();
    let options = request.options();
    let source = Source::from_volume(options, shapes(), Path::new("shapes.vvol")).unwrap();
    let plan = Plan::for_source(options, &source).unwrap();
    let mut renders = 0;
    let probed = volscene::budget::probe(options, &plan, 0.5, limit_s, |o| {
        renders += 1;
        std::thread::sleep(std::time::Duration::from_millis(2));
        let n = (o.size.0 * o.size.1) as usize;
        let mut frame = volrender::Frame {
            width: o.size.0,
            height: o.size.1,
            rgba: vec![[0.5, 0.5, 0.5, 1.0]; n],
            value: vec![0.0; n],
            depth: vec![f32::NAN; n],
            samples: vec![4; n],
            stats: Default::default(),
        };
        frame.stats.samples = 4 * n as u64;
        frame.stats.render_s = 1e-4;
        Ok((frame, f64::from(o.step.unwrap_or(0.5))))
    })
    .unwrap();
    (probed.model.cost.probe_scale, renders)
}

#[test]
fn probes_grow_only_within_the_time_they_are_given() {
    // Unlimited, probes that seem to take 0.1 ms double their side up to
    // a third (twice a sixth; two thirds would pass a half), each fast
    // one run three times.
    let (scale, renders) = probe_growth(f64::INFINITY);
    assert!((scale - 1.0 / 3.0).abs() < 0.01, "{scale}");
    assert_eq!(renders, 3 + 3 * 4, "{renders}");
    // With no time to spare: the four smallest probes, once each.
    let (scale, renders) = probe_growth(1e-6);
    assert!((scale - 1.0 / 6.0).abs() < 0.01, "{scale}");
    assert_eq!(renders, 4);
}
