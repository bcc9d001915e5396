//! vol-render's bounds and numbers: rays, frames and allocations are
//! bounded; extreme values, camera vectors, spacings and directions give
//! finite, framed images.

use super::*;

/// vol-render on `vol` writing `dir/name.png`, with `args`.
fn render_cmd(dir: &Path, vol: &Path, name: &str, args: &[&str]) -> Command {
    let mut c = bin("vol-render");
    c.arg(vol)
        .arg("-o")
        .arg(dir.join(format!("{name}.png")))
        .arg("-q")
        .args(args);
    if !args.contains(&"--size") {
        c.args(["--size", "24x24"]);
    }
    c
}

/// Render and return the linear float image (grey: the red channel).
fn render_hdr(dir: &Path, vol: &Path, name: &str, args: &[&str]) -> Vec<f32> {
    let hdr = dir.join(format!("{name}.pfm"));
    ok(render_cmd(dir, vol, name, args).arg("--hdr").arg(&hdr));
    volcompare::pfm::read_pfm(&hdr)
        .unwrap()
        .samples
        .chunks(3)
        .map(|p| p[0])
        .collect()
}

fn args(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

fn png_bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(format!("{name}.png"))).unwrap()
}

/// Bug: a spacing or step could make vol-render spin on endless rays (issue 14, bf1eac0).
/// Since issue 43 such a spacing's default step is coarsened to the finest
/// the limits allow (a note says so); a step the user gives is refused.
#[test]
fn render_spacing_or_step_that_implies_endless_rays_is_bounded() {
    let d = tmp();
    let v = gen(
        d.path(),
        "thin.vvol",
        &["solid", "--dims", "8,8,8", "--spacing", "1,1.1754944e-38,1"],
    );
    let bounded = |vol: &Path, name: &str| {
        let out = run_within(
            &mut render_cmd(d.path(), vol, name, &["--json"]),
            Duration::from_secs(30),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        let j = json(&String::from_utf8_lossy(&out.stdout));
        // The default framing is 1.8 diagonals from the centre.
        let step = j["scene"]["step"].as_f64().unwrap();
        let diagonal = j["scene"]["orbit"][2].as_f64().unwrap() / 1.8;
        assert!(diagonal / step <= 1e7, "step {step}, diagonal {diagonal}");
    };
    bounded(&v, "a");
    // A thesis .vol whose spacing field is damaged (1e-30 on y).
    let good = std::fs::read(gen(d.path(), "a.vol", &["solid", "--dims", "8,8,8"])).unwrap();
    let mut b = good.clone();
    b[16..20].copy_from_slice(&1e-30f32.to_le_bytes());
    let bad = d.path().join("bad.vol");
    std::fs::write(&bad, &b).unwrap();
    bounded(&bad, "b");
    // An explicit step that implies too many samples per ray.
    let line = fails(
        &mut render_cmd(d.path(), &v, "c", &["--step", "5e-7"]),
        "samples per ray",
    );
    assert!(line.contains("thin.vvol"), "{line}");
    let line = fails(
        &mut render_cmd(d.path(), &bad, "d", &["--step", "1e-7"]),
        "samples per ray",
    );
    assert!(line.contains("bad.vol"), "{line}");
}

/// Bug: infinities or ±FLT_MAX gave NaN or black MIP/MinIP images (issue 14, ea4de32).
#[test]
fn render_mip_and_minip_with_infinities_and_flt_max_are_finite() {
    let d = tmp();
    // The front half of the volume at one extreme, the back half at the
    // other; nearest samples (a trilinear blend of -inf and inf is NaN).
    let n = 8 * 8 * 8;
    for (lo, hi) in [
        (f32::NEG_INFINITY, f32::INFINITY),
        (-f32::MAX, f32::MAX),
        (0.0, f32::INFINITY),
    ] {
        let v: Vec<f32> = (0..n).map(|i| if i / 64 < 4 { lo } else { hi }).collect();
        let vol = raw_f32(d.path(), &format!("ext{lo}"), [8, 8, 8], &v);
        for mode in ["mip", "minip"] {
            let img = render_hdr(
                d.path(),
                &vol,
                mode,
                &[
                    "--mode",
                    mode,
                    "--interp",
                    "nearest",
                    "--eye",
                    "3.5,3.5,40",
                    "--look-at",
                    "3.5,3.5,0",
                ],
            );
            assert!(
                img.iter().all(|g| g.is_finite()),
                "{mode} {lo}..{hi}: {img:?}"
            );
            // Every ray through the volume meets both halves: MIP shows
            // white, MinIP black, at the centre.
            let c = img[12 * 24 + 12];
            let want = if mode == "mip" { 1.0 } else { 0.0 };
            assert_eq!(c, want, "{mode} {lo}..{hi}");
        }
    }
}

/// Bug: with trilinear reconstruction a sample between an infinite voxel
/// and a finite one was NaN (`inf - inf` in the blend) and skipped, so a
/// ray past +inf was not white in MIP nor past -inf black in MinIP
/// (issue 43, item 5).
#[test]
fn render_mip_and_minip_trilinear_rays_past_an_infinite_voxel_reach_it() {
    let d = tmp();
    // A ramp along x, one infinite voxel at (4, 4, 4).
    let (n, at) = (8usize, 4 + 4 * 8 + 4 * 64);
    for (mode, inf, want) in [
        ("mip", f32::INFINITY, 1.0),
        ("minip", f32::NEG_INFINITY, 0.0),
    ] {
        let mut v: Vec<f32> = (0..n * n * n).map(|i| (i % n) as f32 / 8.0).collect();
        v[at] = inf;
        let vol = raw_f32(d.path(), mode, [8, 8, 8], &v);
        // Close enough that the volume fills the frame: the four centre
        // pixels' rays pass at x, y in (4, 5), where the voxel is their
        // cells' first corner and the plain blend's `inf + (b - inf)·t`
        // is NaN at every sample.
        let look = [
            "--mode",
            mode,
            "--eye",
            "4.5,4.5,12",
            "--look-at",
            "4.5,4.5,0",
        ];
        let img = render_hdr(d.path(), &vol, mode, &look);
        assert!(img.iter().all(|g| g.is_finite()), "{mode}: {img:?}");
        // The centre ray crosses the cells around the voxel: it reaches
        // the infinity.
        assert_eq!(img[12 * 24 + 12], want, "{mode}");
        // A ray far from it does not.
        assert_ne!(img[2 * 24 + 2], want, "{mode}");
    }
    // Halves at opposite extremes, as in the nearest-sample case above:
    // trilinear samples inside either half keep its value.
    let v: Vec<f32> = (0..n * n * n)
        .map(|i| {
            if i / 64 < 4 {
                f32::NEG_INFINITY
            } else {
                f32::INFINITY
            }
        })
        .collect();
    let vol = raw_f32(d.path(), "halves", [8, 8, 8], &v);
    for (mode, want) in [("mip", 1.0), ("minip", 0.0)] {
        let look = [
            "--mode",
            mode,
            "--eye",
            "3.5,3.5,40",
            "--look-at",
            "3.5,3.5,0",
        ];
        let img = render_hdr(d.path(), &vol, &format!("h{mode}"), &look);
        assert!(img.iter().all(|g| g.is_finite()), "{mode}: {img:?}");
        assert_eq!(img[12 * 24 + 12], want, "{mode}");
    }
}

/// Bug: path tracing of an f32 volume of +inf never ended: its samples
/// blended to NaN (`inf - inf`), extinction 0, under majorants at the cap,
/// so every tentative collision was a null one, a million per unit per
/// ray (issue 43, item 1).
#[test]
fn render_path_tracing_of_an_infinite_medium_ends_opaque() {
    let d = tmp();
    let n = 8 * 8 * 8;
    let cases: [(&str, Vec<f32>); 3] = [
        ("inf", vec![f32::INFINITY; n]),
        ("max", vec![f32::MAX; n]),
        ("ninf", vec![f32::NEG_INFINITY; n]),
    ];
    for (name, v) in cases {
        let vol = raw_f32(d.path(), name, [8, 8, 8], &v);
        let hdr = d.path().join(format!("{name}.pfm"));
        let mut cmd = render_cmd(
            d.path(),
            &vol,
            name,
            &["--mode", "path", "--density-scale", "1", "--spp", "4"],
        );
        cmd.arg("--hdr").arg(&hdr);
        let out = run_within(&mut cmd, Duration::from_secs(30));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {err}");
        let img = volcompare::pfm::read_pfm(&hdr).unwrap().samples;
        assert!(img.iter().all(|g| g.is_finite()), "{name}");
    }
}

/// Bug: a macrocell that mixed extinction at the cap (+inf, FLT_MAX, or a
/// 1e30 density scale) with empty space took a million null collisions
/// per unit of its empty part, so such a frame ran for minutes (issue 43,
/// item 1). Capped macrocells are now tracked voxel cell by voxel cell:
/// a few null collisions per path, and the JSON counts the capped lookups.
#[test]
fn render_path_tracing_of_opaque_specks_in_empty_space_stays_fast() {
    let d = tmp();
    let dims = [32u64, 32, 32];
    let speck = |value: f32| -> Vec<f32> {
        (0..32 * 32 * 32)
            .map(|i: u64| {
                let (x, y, z) = (i % 32, i / 32 % 32, i / 1024);
                // One voxel in every macrocell of 8^3, off its centre.
                if x % 8 == 3 && y % 8 == 5 && z % 8 == 2 {
                    value
                } else {
                    0.0
                }
            })
            .collect()
    };
    for (name, value, scale) in [
        ("inf", f32::INFINITY, "1"),
        ("max", f32::MAX, "1"),
        ("scaled", 1.0, "1e30"),
        ("denormal", 1e-40, "1e30"),
    ] {
        let vol = raw_f32(d.path(), name, dims, &speck(value));
        let mut cmd = render_cmd(
            d.path(),
            &vol,
            name,
            &[
                "--mode",
                "path",
                "--density-scale",
                scale,
                "--spp",
                "4",
                "--env",
                "1",
                "--json",
            ],
        );
        let out = run_within(&mut cmd, Duration::from_secs(60));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {err}");
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let count = |k: &str| {
            j[k].as_u64()
                .unwrap_or_else(|| panic!("{name}: no {k} in {j}"))
        };
        let (paths, nulls) = (count("paths"), count("null_collisions"));
        assert!(
            nulls < 100 * paths,
            "{name}: {nulls} null collisions for {paths} paths"
        );
        assert_eq!(count("truncated"), 0, "{name}");
        if name == "denormal" {
            // 1e-40 x 1e30: an ordinary thin medium, nowhere at the cap.
            assert_eq!((count("capped"), count("voxel_cells")), (0, 0), "{name}");
        } else {
            assert!(
                count("capped") > 0 && count("voxel_cells") > 0,
                "{name}: {j}"
            );
        }
    }
}

/// Bug: extreme f32 values gave NaN or black X-ray images (issue 14, ea4de32).
#[test]
fn render_xray_of_a_1e38_cube_is_not_black() {
    let d = tmp();
    let vol = raw_f32(d.path(), "big", [16, 16, 16], &[1e38; 4096]);
    let img = render_hdr(d.path(), &vol, "x", &["--mode", "xray"]);
    assert!(img.iter().all(|g| g.is_finite()));
    let top = img.iter().cloned().fold(0.0f32, f32::max);
    assert!(top > 0.99, "brightest pixel {top}");
    // The ordinary scale gives the same picture (the sum only scales).
    let small = raw_f32(d.path(), "one", [16, 16, 16], &[1.0; 4096]);
    let one = render_hdr(d.path(), &small, "y", &["--mode", "xray"]);
    for (a, b) in img.iter().zip(&one) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
}

/// Bug: an eye 1e7 units from a small volume was refused as "too far" for f32
/// positions (issue 43, item 3); rays from far eyes now start near the box.
#[test]
fn render_huge_and_tiny_camera_vectors_keep_their_direction() {
    let d = tmp();
    let v = gen(
        d.path(),
        "s.vvol",
        &[
            "shapes", "--dims", "24,24,24", "--count", "6", "--size", "6",
        ],
    );
    let r = |name: &str, args: &[&str]| {
        ok(&mut render_cmd(d.path(), &v, name, args));
        png_bytes(d.path(), name)
    };
    let eye = [
        "--eye",
        "40,30,50",
        "--look-at",
        "12,12,12",
        "--tf",
        "shapes",
    ];
    let up1 = r("up1", &[&eye[..], &["--up=1,1,0"]].concat());
    assert_eq!(r("up30", &[&eye[..], &["--up=1e30,1e30,0"]].concat()), up1);
    assert_eq!(
        r("up-25", &[&eye[..], &["--up=1e-25,1e-25,0"]].concat()),
        up1
    );
    let phong = [&eye[..], &["--shading", "phong"]].concat();
    let l1 = r("l1", &[&phong[..], &["--light=1,1,1"]].concat());
    assert_eq!(
        r("l30", &[&phong[..], &["--light=1e30,1e30,1e30"]].concat()),
        l1
    );
    let lx = r("lx", &[&phong[..], &["--light=1,0,0"]].concat());
    assert_eq!(
        r("l-25", &[&phong[..], &["--light=1e-25,0,0"]].concat()),
        lx
    );
    // Issue 43, item 3: an eye far from the volume renders (it was refused
    // as "too far" for f32 positions): orthographic along z from 1e7 away
    // gives the picture of the same rays from 100 away; a perspective eye
    // 1e20 away renders too (the volume is then under a pixel).
    let view = |z: &str| {
        [
            "--eye".to_string(),
            format!("12,12,{z}"),
            "--look-at".into(),
            "12,12,12".into(),
            "--ortho=30".into(),
            "--tf".into(),
            "shapes".into(),
        ]
    };
    let (near, far) = (view("100"), view("1e7"));
    let near = render_hdr(d.path(), &v, "near", &args(&near));
    let far = render_hdr(d.path(), &v, "far", &args(&far));
    assert!(
        near.iter().any(|&g| g > 0.0),
        "the near view sees the shapes"
    );
    for (a, b) in near.iter().zip(&far) {
        assert!((a - b).abs() < 1e-4, "near {a} vs far {b}");
    }
    ok(&mut render_cmd(
        d.path(),
        &v,
        "farthest",
        &["--eye=1e20,1e20,1e20", "--look-at", "12,12,12"],
    ));
    fails(
        &mut render_cmd(d.path(), &v, "same", &["--eye=3,3,3", "--look-at", "3,3,3"]),
        "same point",
    );
}

/// Bug: --orbit ignored --up (issue 14, 2aca2eb).
#[test]
fn render_orbit_turns_around_up() {
    let d = tmp();
    let v = gen(
        d.path(),
        "s.vvol",
        &[
            "shapes", "--dims", "24,24,24", "--count", "6", "--size", "6",
        ],
    );
    let r = |name: &str, args: &[&str]| {
        ok(&mut render_cmd(
            d.path(),
            &v,
            name,
            &[&["--tf", "shapes"][..], args].concat(),
        ));
        png_bytes(d.path(), name)
    };
    // Azimuth 0, elevation 0 puts the eye on the +z side whatever up is
    // (for up = x): exactly --eye there with that up.
    let orbit = r("o", &["--orbit", "0,0,60", "--up", "1,0,0"]);
    let eye = r(
        "e",
        &[
            "--eye",
            "11.5,11.5,71.5",
            "--look-at",
            "11.5,11.5,11.5",
            "--up",
            "1,0,0",
        ],
    );
    assert_eq!(orbit, eye, "--orbit ignored --up");
    assert_ne!(orbit, r("y", &["--orbit", "0,0,60"]));
    // Same framing, different up: different images.
    assert_ne!(
        r("z", &["--orbit", "30,20,60", "--up", "0,0,1"]),
        r("w", &["--orbit", "30,20,60"])
    );
}

#[test]
fn render_up_patient_follows_the_direction_matrix() {
    let d = tmp();
    let data: Vec<u8> = (0..8 * 8 * 8).map(|i| ((i * 37) % 251) as u8).collect();
    // Index axis y points superior: the patient's up is +y in the
    // renderer's world; with the identity geometry it is +z.
    let coronal = nrrd(
        d.path(),
        "cor.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\nspace: left-posterior-superior\nspace directions: (1,0,0) (0,0,1) (0,1,0)\nspace origin: (0,0,0)\n\n",
        &data,
    );
    let plain = nrrd(
        d.path(),
        "ax.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n\n",
        &data,
    );
    let r = |vol: &Path, name: &str, up: &str| {
        ok(&mut render_cmd(
            d.path(),
            vol,
            name,
            &["--orbit", "30,20,30", "--up", up],
        ));
        png_bytes(d.path(), name)
    };
    assert_eq!(r(&coronal, "cp", "patient"), r(&coronal, "cy", "0,1,0"));
    assert_eq!(r(&plain, "pp", "patient"), r(&plain, "pz", "0,0,1"));
    assert_ne!(r(&plain, "pp2", "patient"), r(&plain, "py", "0,1,0"));
}

/// Bug: default framing took a diagonal of at least 1: tiny at spacing 1e-3 (issue 14, 2aca2eb).
#[test]
fn render_default_framing_at_spacing_1e_3_shows_the_volume() {
    let d = tmp();
    let v = gen(
        d.path(),
        "mm.vvol",
        &[
            "solid",
            "--dims",
            "16,16,16",
            "--spacing",
            "0.001,0.001,0.001",
        ],
    );
    let img = render_hdr(d.path(), &v, "a", &["--mode", "mip"]);
    assert!(
        img[12 * 24 + 12] > 0.5,
        "centre pixel {}",
        img[12 * 24 + 12]
    );
    let huge = gen(
        d.path(),
        "huge.vvol",
        &[
            "solid",
            "--dims",
            "16,16,16",
            "--spacing",
            "3.4e38,3.4e38,3.4e38",
        ],
    );
    let line = fails(&mut render_cmd(d.path(), &huge, "b", &[]), "too large");
    assert!(
        line.contains("huge.vvol") && !line.contains("orbit distance"),
        "{line}"
    );
}

/// Bug: the default iso was the midpoint of a range with infinities (issue 14, 2aca2eb).
#[test]
fn render_iso_default_on_an_infinite_range_is_finite_or_refused_clearly() {
    let d = tmp();
    let mut v = vec![10.0f32; 512];
    v[0] = f32::INFINITY;
    v[1] = f32::NEG_INFINITY;
    for (i, x) in v.iter_mut().enumerate().skip(2) {
        *x = (i % 8) as f32 * 10.0;
    }
    let vol = raw_f32(d.path(), "inf", [8, 8, 8], &v);
    // The midpoint of the finite samples (0..70): 35.
    let out = run(&mut render_cmd(d.path(), &vol, "a", &["--mode", "iso"]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let img = render_hdr(d.path(), &vol, "a", &["--mode", "iso"]);
    assert!(img.iter().any(|&g| g > 0.0) && img.iter().all(|g| g.is_finite()));
    // Without an index the finite range is unknown: refused with the reason.
    let line = fails(
        &mut render_cmd(d.path(), &vol, "b", &["--mode", "iso", "--no-ess"]),
        "give --iso",
    );
    assert!(!line.contains("must be finite"), "{line}");
}

/// Bug: a huge --size or --tile could abort vol-render on its buffers (issue 14, bf1eac0).
#[test]
fn render_tile_and_size_allocations_are_bounded() {
    let d = tmp();
    let v = gen(d.path(), "s.vvol", &["solid", "--dims", "8,8,8"]);
    ok(&mut render_cmd(
        d.path(),
        &v,
        "a",
        &["--tile", "4", "--size", "16x16"],
    ));
    let want = png_bytes(d.path(), "a");
    let out = run_within(
        &mut render_cmd(d.path(), &v, "b", &["--tile", "100000", "--size", "16x16"]),
        Duration::from_secs(30),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(png_bytes(d.path(), "b"), want);
    // The widest allowed image, one row: within the budget, so it renders.
    ok(&mut render_cmd(
        d.path(),
        &v,
        "w",
        &["--size", "32768x1", "--tile", "32768"],
    ));
    let out = run_within(
        &mut render_cmd(d.path(), &v, "c", &["--size", "32768x32768"]),
        Duration::from_secs(30),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.lines().count() == 1, "{err}");
    assert!(
        err.contains("budget") && !err.contains("allocation"),
        "{err}"
    );
    assert!(!d.path().join("c.png").exists());
}

/// Bug: a scene file without `volume` gave "no volume" without naming the scene file (issue 43).
#[test]
fn render_scene_file_without_a_volume_is_named() {
    let d = tmp();
    let scene = d.path().join("novol.toml");
    for text in ["", "tf = \"shapes\"\n"] {
        std::fs::write(&scene, text).unwrap();
        let line = fails(
            bin("vol-render")
                .arg("--scene")
                .arg(&scene)
                .arg("-o")
                .arg(d.path().join("x.png")),
            "novol.toml",
        );
        assert!(line.contains("no volume"), "{line}");
        assert!(!d.path().join("x.png").exists());
    }
}

/// Bug: `domain -3.4e38 3.4e38` in a TF file was blamed on the volume as a bad index table (issue 43).
#[test]
fn render_tf_domain_wider_than_f32_names_the_tf_file() {
    let d = tmp();
    let v = gen(d.path(), "vol.vvol", &["solid", "--dims", "8,8,8"]);
    let tf = d.path().join("wide.tf");
    for (text, mode) in [
        ("domain -3.4e38 3.4e38\npoint 0 255 255 255 0.5\n", "dvr"),
        ("domain -3.4e38 3.4e38\npoint 0 255 255 255 0.5\n", "path"),
        (
            "domain -3e38 3e38\ngradient-domain 0 10\nrect 0 1 0 1 255 255 255 0.5\n",
            "dvr",
        ),
    ] {
        std::fs::write(&tf, text).unwrap();
        let line = fails(
            &mut render_cmd(
                d.path(),
                &v,
                "x",
                &["--tf", tf.to_str().unwrap(), "--mode", mode],
            ),
            "wide.tf",
        );
        // The TF file is the input at fault: named first, the volume not at all.
        assert!(
            line.starts_with("vol-render: ") && line.contains("domain"),
            "{line}"
        );
        assert!(
            !line.contains("vol.vvol") && !line.contains("index"),
            "{line}"
        );
        assert!(!d.path().join("x.png").exists());
    }
}

/// Bug: at spacing 1000,1,0.001 the default step (half the smallest
/// spacing) implied more samples per ray than the limit, so a render given
/// no step was refused (issue 43).
#[test]
fn render_default_step_is_always_feasible() {
    let d = tmp();
    let v = gen(
        d.path(),
        "flat.vvol",
        &["sphere", "--dims", "8,8,8", "--spacing", "1000,1,0.001"],
    );
    // No step given: the render succeeds, and a note says which step.
    let out = run_within(
        bin("vol-render")
            .arg(&v)
            .arg("-o")
            .arg(d.path().join("a.png"))
            .args(["--size", "24x24"]),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("flat.vvol") && err.contains("default step"),
        "{err}"
    );
    // The step chosen is what the effective scene records, and that scene
    // renders the same image.
    let scene = ok(bin("vol-render").arg(&v).arg("--print-scene"));
    let s = d.path().join("s.toml");
    std::fs::write(&s, &scene).unwrap();
    ok(&mut render_cmd(
        d.path(),
        &v,
        "b",
        &["--scene", s.to_str().unwrap()],
    ));
    ok(&mut render_cmd(d.path(), &v, "c", &[]));
    assert_eq!(png_bytes(d.path(), "b"), png_bytes(d.path(), "c"));
    // A step the user gives is theirs: one beyond the limit is refused.
    fails(
        &mut render_cmd(d.path(), &v, "e", &["--step", "0.0005"]),
        "samples per ray",
    );
}

/// Bug: `--print-scene` printed a directional light's direction
/// normalised; read back it was normalised again, its last bits changed
/// and the render differed in 1.7% of pixels (issue 43).
#[test]
fn render_printed_scene_repeats_the_render_bit_for_bit() {
    let d = tmp();
    let v = gen(
        d.path(),
        "s.vvol",
        &[
            "shapes", "--dims", "32,28,24", "--count", "6", "--size", "10", "--seed", "5",
        ],
    );
    let lights = d.path().join("lights.toml");
    std::fs::write(
        &lights,
        "[[lights]]\ntype = \"directional\"\ndirection = [-1, -2, -0.7]\n\
         colour = [1, 0.9, 0.7]\nintensity = 0.8\n\
         [[lights]]\ntype = \"point\"\nposition = [40, -10, 30]\nintensity = 900\n\
         [[lights]]\ntype = \"headlight\"\ncolour = 0.3\n\
         [[lights]]\ntype = \"directional\"\ndirection = [0.3, 1e-3, -3]\n",
    )
    .unwrap();
    let l = lights.to_str().unwrap();
    let cases: &[&[&str]] = &[
        &["--tf", "shapes", "--light=-1,-2,-1", "--shadows", "ray"],
        &["--tf", "shapes", "--light=0.1,-0.7,3", "--shading", "phong"],
        &["--tf", "shapes", "--scene", l, "--shadows", "grid:2"],
        &[
            "--tf",
            "shapes",
            "--scene",
            l,
            "--ao",
            "4:6",
            "--ambient",
            "0.3,0.2,0.1",
        ],
        &[
            "--mode",
            "iso",
            "--light=-1,-2,-1",
            "--eye",
            "-40,31,27",
            "--look-at",
            "15,13,11",
            "--up",
            "0.1,1,0.2",
            "--fov",
            "33",
        ],
        &["--mode", "iso", "--scene", l, "--ao-field", "8", "--ortho"],
        &["--mode", "mip", "--orbit", "20,-30,90", "--step", "0.37"],
        &[
            "--tf",
            "shapes",
            "--shading",
            "phong",
            "--gradient",
            "analytic",
            "--interp",
            "nearest",
            "--light=-3,-1,-2",
            "--shadows",
            "ray",
            "--shadow-step",
            "0.7",
        ],
        &[
            "--mode",
            "path",
            "--density-scale",
            "0.2",
            "--albedo",
            "0.7,0.8,0.9",
            "--sun=-1,-1.2,0.4:4",
            "--sun=0.3,-2,-0.1:1.5",
            "--env",
            "0.1",
            "--spp",
            "2",
        ],
        &[
            "--mode",
            "path",
            "--tf",
            "shapes",
            "--light=-1,-2,-1",
            "--spp",
            "2",
            "--seed",
            "9",
        ],
        &[
            "--mode", "path", "--tf", "shapes", "--scene", l, "--spp", "2",
        ],
    ];
    for (i, args) in cases.iter().enumerate() {
        let scene = ok(render_cmd(d.path(), &v, "p", args).arg("--print-scene"));
        let s = d.path().join(format!("{i}.toml"));
        std::fs::write(&s, &scene).unwrap();
        let a = render_hdr(d.path(), &v, &format!("a{i}"), args);
        let b = render_hdr(
            d.path(),
            &v,
            &format!("b{i}"),
            &["--scene", s.to_str().unwrap()],
        );
        let pfm = |n: &str| std::fs::read(d.path().join(format!("{n}{i}.pfm"))).unwrap();
        assert!(
            pfm("a") == pfm("b")
                && png_bytes(d.path(), &format!("a{i}")) == png_bytes(d.path(), &format!("b{i}")),
            "case {i} {args:?}: {} of {} grey values differ\n{scene}",
            a.iter().zip(&b).filter(|(x, y)| x != y).count(),
            a.len()
        );
    }
}
