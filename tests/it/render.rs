//! End to end: vol-render through files.

use crate::common::*;
use std::path::{Path, PathBuf};

fn gen(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let p = dir.join(name);
    ok(tool("vol-gen").args(args).arg("-o").arg(&p).arg("--quiet"));
    p
}

fn render_json(vol: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    json(&ok(tool("vol-render")
        .arg(vol)
        .arg("-o")
        .arg(out)
        .args(["--size", "64x48", "--json"])
        .args(extra)))
}

#[test]
fn renders_every_mode_and_reports_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "s.vvol",
        &[
            "shapes", "--dims", "64,64,64", "--count", "10", "--size", "16", "--seed", "2",
        ],
    );
    for (i, extra) in [
        vec!["--tf", "shapes", "--shading", "phong"],
        vec![
            "--tf",
            "shapes",
            "--shading",
            "phong",
            "--gradient",
            "analytic",
            "--interp",
            "nearest",
        ],
        vec!["--mode", "mip", "--ortho"],
        vec!["--mode", "minip"],
        vec!["--mode", "xray"],
        vec!["--mode", "xray-mean"],
        vec!["--mode", "iso", "--iso", "95"],
    ]
    .into_iter()
    .enumerate()
    {
        let out = d.join(format!("{i}.png"));
        let v = render_json(&vol, &out, &extra);
        for key in [
            "width", "height", "threads", "samples", "load_s", "index_s", "render_s",
        ] {
            assert!(!v[key].is_null(), "{extra:?}: missing {key}");
        }
        assert_eq!(
            (v["width"].as_u64(), v["height"].as_u64()),
            (Some(64), Some(48))
        );
        assert!(v["samples"].as_u64().unwrap() > 0, "{extra:?}");
        let png = std::fs::read(&out).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
    assert!(leftovers(d).is_empty());
}

#[test]
fn image_is_identical_across_threads_skipping_layouts_and_index_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = [
        "shapes", "--dims", "70,60,50", "--count", "12", "--size", "18", "--seed", "3",
    ];
    let sliced = gen(d, "s.vvol", &args);
    // The thesis's sliced .vol (z fastest), sampled in place.
    let thesis = gen(d, "t.vol", &args);
    let zstd = gen(
        d,
        "z.vvol",
        &[&args[..], &["--layout", "bricked:16", "--compress", "zstd"]].concat(),
    );
    ok(tool("vol-index").arg(&sliced).arg("--quiet"));
    let base = [
        "--tf",
        "shapes",
        "--shading",
        "phong",
        "--orbit",
        "40,25,200",
    ];
    let mut images = Vec::new();
    for (i, (vol, extra)) in [
        (&sliced, vec!["--threads", "1"]),
        (&sliced, vec!["--threads", "2", "--tile", "5"]),
        (&sliced, vec!["--no-ess"]),
        (&sliced, vec!["--in-memory"]),
        (&zstd, vec![]),
        (&thesis, vec![]),
        (&thesis, vec!["--no-ess", "--threads", "1"]),
    ]
    .into_iter()
    .enumerate()
    {
        let out = d.join(format!("{i}.png"));
        let hdr = d.join(format!("{i}.pfm"));
        let mut c = tool("vol-render");
        c.arg(vol)
            .arg("-o")
            .arg(&out)
            .arg("--hdr")
            .arg(&hdr)
            .args(["--size", "40x40"])
            .args(base)
            .args(&extra);
        if i == 0 {
            c.arg("--index").arg(d.join("s.vvol.vidx"));
        }
        ok(&mut c);
        images.push(std::fs::read(&hdr).unwrap());
    }
    assert!(images.windows(2).all(|w| w[0] == w[1]));
}

/// Pixel blocks whose rays can meet only transparent cells are not
/// traced: the image is the one rendered without skipping, bit for bit,
/// and `--json` counts the culled blocks (and fewer rays).
#[test]
fn blocks_that_can_see_nothing_are_culled_without_changing_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "few.vvol",
        &[
            "shapes", "--dims", "64,64,64", "--count", "3", "--size", "10", "--seed", "5",
        ],
    );
    let base = [
        "--tf",
        "shapes",
        "--shading",
        "phong",
        "--tile",
        "4",
        "--orbit",
        "40,25,200",
    ];
    let render = |name: &str, extra: &[&str]| {
        let hdr = d.join(format!("{name}.pfm"));
        let hdr_arg = ["--hdr", hdr.to_str().unwrap()];
        let v = render_json(
            &vol,
            &d.join(format!("{name}.png")),
            &[&base[..], &hdr_arg, extra].concat(),
        );
        (v, std::fs::read(&hdr).unwrap())
    };
    let (culled, a) = render("culled", &[]);
    let (plain, b) = render("plain", &["--no-ess"]);
    let n = |v: &serde_json::Value, k: &str| v[k].as_u64().unwrap();
    assert!(n(&culled, "culled_blocks") > 0, "{culled}");
    assert_eq!(n(&plain, "culled_blocks"), 0);
    assert!(n(&culled, "rays") < n(&plain, "rays"));
    assert!(a == b, "culling changed the image");
}

#[test]
fn heat_map_and_hdr_outputs_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "n.vvol",
        &["noise", "--dims", "40,40,40", "--period", "10"],
    );
    let heat = d.join("heat.png");
    let hdr = d.join("img.pfm");
    ok(tool("vol-render")
        .arg(&vol)
        .arg("-o")
        .arg(d.join("a.png"))
        .arg("--heatmap")
        .arg(&heat)
        .arg("--hdr")
        .arg(&hdr)
        .args(["--size", "30x20"]));
    assert_eq!(&std::fs::read(&heat).unwrap()[1..4], b"PNG");
    let pfm = std::fs::read(&hdr).unwrap();
    assert!(pfm.starts_with(b"PF\n30 20\n"));
}

#[test]
fn bad_input_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "s.vvol",
        &[
            "shapes", "--dims", "32,32,32", "--count", "4", "--size", "8",
        ],
    );
    let out = d.join("out.png");
    let r = |extra: &[&str]| {
        let mut c = tool("vol-render");
        c.arg(&vol).arg("-o").arg(&out).args(extra);
        c
    };
    fails(&mut r(&["--step", "0"]), "step");
    fails(&mut r(&["--step", "-1"]), "step");
    fails(&mut r(&["--fov", "180"]), "field of view");
    fails(
        &mut r(&["--eye", "16,16,16", "--look-at", "16,16,16"]),
        "same point",
    );
    fails(&mut r(&["--tf", "no-such-preset"]), "not a preset");
    std::fs::write(d.join("bad.tf"), "range 10 5 0 0 0 1\n").unwrap();
    fails(
        &mut r(&["--tf", d.join("bad.tf").to_str().unwrap()]),
        "line 1",
    );
    fails(&mut r(&["--iso", "3"]), "--mode iso");
    // An index of another volume is refused.
    let other = gen(
        d,
        "o.vvol",
        &[
            "shapes", "--dims", "32,32,32", "--count", "4", "--size", "8", "--seed", "9",
        ],
    );
    ok(tool("vol-index").arg(&other).arg("--quiet"));
    fails(
        &mut r(&["--index", d.join("o.vvol.vidx").to_str().unwrap()]),
        "o.vvol.vidx",
    );
    assert!(!out.exists());
    let trunc = d.join("t.vvol");
    std::fs::write(&trunc, &std::fs::read(&vol).unwrap()[..1000]).unwrap();
    fails(tool("vol-render").arg(&trunc).arg("-o").arg(&out), "t.vvol");
    assert!(!out.exists());
    assert!(leftovers(d).is_empty());
}

/// FNV-1a of some bytes.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// FNV-1a of a PNG's decoded samples (independent of the PNG encoder's
/// compression settings).
fn png_hash(p: &Path) -> u64 {
    let img = volcompare::image::Image::load(p).unwrap();
    let bytes: Vec<u8> = img.samples.iter().map(|&s| s as u8).collect();
    fnv(&bytes) ^ ((img.width as u64) << 32 | img.height as u64) ^ img.channels() as u64
}

/// The tool's output files, hashed as recorded before the renderer was
/// restructured: 8-bit sRGB PNG (with and without alpha), the linear PFM
/// and the samples-per-pixel heat map, for every mode. Set GOLDEN_PRINT to
/// print the current hashes instead of checking them.
#[test]
fn output_files_are_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "s.vvol",
        &[
            "shapes", "--dims", "64,64,64", "--count", "10", "--size", "16", "--seed", "2",
        ],
    );
    let cases: [(&str, &[&str], [u64; 3]); 7] = [
        (
            "dvr",
            &[
                "--tf",
                "shapes",
                "--shading",
                "phong",
                "--alpha",
                "--background",
                "40,80,120",
            ],
            [
                0x0385_960c_1adc_3dfa,
                0x902d_4da0_8505_9443,
                0xb455_37e6_fb8d_cf18,
            ],
        ),
        (
            "dvr-grey",
            &["--tf", "grey", "--light", "1,2,3"],
            [
                0x4bdb_a7fc_0e5c_fa47,
                0x2b65_3248_1160_9b48,
                0x58da_3378_a746_8b72,
            ],
        ),
        (
            "mip",
            &["--mode", "mip", "--ortho"],
            [
                0xa57b_1dc8_2b5b_2a84,
                0x9ed5_db42_3ecf_5615,
                0xb0ea_c2ac_2d05_96fa,
            ],
        ),
        (
            "minip",
            &["--mode", "minip"],
            [
                0xf3fb_6a2d_eb5a_f316,
                0xe1b7_6c14_dbf9_4e63,
                0xec72_139b_4996_a812,
            ],
        ),
        (
            "xray",
            &["--mode", "xray"],
            [
                0x9904_d2c8_bc80_d38b,
                0x9099_83fa_02c7_6731,
                0xde95_f998_3586_29ad,
            ],
        ),
        (
            "xray-mean",
            &["--mode", "xray-mean"],
            [
                0x9d77_ff85_0cf3_b480,
                0x6df4_ac06_74bf_fc44,
                0xde95_f998_3586_29ad,
            ],
        ),
        (
            "iso",
            &["--mode", "iso", "--iso", "95"],
            [
                0x63a9_b557_1401_62bc,
                0xa7e0_9064_7468_4774,
                0x6be2_2145_cb0e_f237,
            ],
        ),
    ];
    let print = std::env::var_os("GOLDEN_PRINT").is_some();
    for (name, extra, want) in cases {
        let (png, pfm, heat) = (
            d.join(format!("{name}.png")),
            d.join(format!("{name}.pfm")),
            d.join(format!("{name}-heat.png")),
        );
        ok(tool("vol-render")
            .arg(&vol)
            .arg("-o")
            .arg(&png)
            .arg("--hdr")
            .arg(&pfm)
            .arg("--heatmap")
            .arg(&heat)
            .args(["--size", "64x48", "--quiet", "--step", "0.3"])
            .args(extra));
        let got = [
            png_hash(&png),
            fnv(&std::fs::read(&pfm).unwrap()),
            png_hash(&heat),
        ];
        if print {
            println!("{name}: {got:#018x?}");
        } else {
            assert_eq!(got, want, "{name}: png, pfm, heat map");
        }
    }
}

/// A 2D transfer function file and the boundary preset render through the
/// tool; malformed files (1D and 2D statements) are refused with one line
/// naming the file and the line.
#[test]
fn two_d_transfer_functions_and_malformed_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(
        d,
        "ball.vvol",
        &[
            "sphere", "--dims", "48,48,48", "--radius", "16", "--edge", "3",
        ],
    );
    let tf = d.join("shell.tf");
    std::fs::write(
        &tf,
        "# the sphere's shell: steep gradients at any value\ngradient-domain 0 120\nrect 1 255 20 1e30 255 200 120 0.5\n",
    )
    .unwrap();
    for (i, t) in [tf.to_str().unwrap(), "boundary"].iter().enumerate() {
        let out = d.join(format!("shell{i}.png"));
        let v = render_json(&vol, &out, &["--tf", t, "--shading", "phong"]);
        assert!(v["samples"].as_u64().unwrap() > 0);
        let img = volcompare::image::Image::load(&out).unwrap();
        assert!(img.samples.iter().any(|&s| s > 0.0), "{t}: black image");
    }
    for (text, line) in [
        ("rect 1 2 3\n", 1),
        ("point 0 0 0 0 0\nblob 1 2 0 3 0 0 0 1\n", 2),
        ("gradient-domain 5 1\nrect 1 2 3 4 0 0 0 1\n", 1),
        ("point 0 0 0 0 1\n\nrect 1 2 3 4 0 0 0 7\n", 3),
        ("wobble 1 2\n", 1),
    ] {
        let bad = d.join("bad.tf");
        std::fs::write(&bad, text).unwrap();
        let msg = fails(
            tool("vol-render")
                .arg(&vol)
                .arg("-o")
                .arg(d.join("x.png"))
                .arg("--tf")
                .arg(&bad),
            &format!("line {line}"),
        );
        assert!(msg.contains("bad.tf"), "{msg}");
        assert!(!d.join("x.png").exists());
    }
}

/// Run a tool and return its exit code, stdout and stderr.
fn outcome(cmd: &mut std::process::Command) -> (Option<i32>, String, String) {
    let o = run(cmd);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn ortho_without_a_value_does_not_swallow_the_next_argument() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "r.vvol", &["ramp", "--dims", "24,20,16"]);
    let png = |name: &str| d.join(name);
    // The volume right after --ortho is the volume, not the height.
    ok(tool("vol-render")
        .arg("--ortho")
        .arg(&vol)
        .arg("-o")
        .arg(png("a.png"))
        .args(["--size", "32x24", "-q"]));
    ok(tool("vol-render")
        .arg(&vol)
        .arg("--ortho")
        .arg("-o")
        .arg(png("b.png"))
        .args(["--size", "32x24", "-q"]));
    assert_eq!(png_hash(&png("a.png")), png_hash(&png("b.png")));
    // A height takes '=' or --ortho-height; both give the same image, and
    // not the fitted one.
    ok(tool("vol-render")
        .arg(&vol)
        .args(["--ortho=80", "--size", "32x24", "-q", "-o"])
        .arg(png("c.png")));
    ok(tool("vol-render")
        .arg(&vol)
        .args(["--ortho-height", "80", "--size", "32x24", "-q", "-o"])
        .arg(png("d.png")));
    assert_eq!(png_hash(&png("c.png")), png_hash(&png("d.png")));
    assert_ne!(png_hash(&png("a.png")), png_hash(&png("c.png")));
    // A bare value after --ortho is not taken as the height: a usage error.
    let mut c = tool("vol-render");
    c.arg(&vol).args(["--ortho", "80", "-o"]).arg(png("e.png"));
    fails(&mut c, "80");
    assert_eq!(c.status().unwrap().code(), Some(2));
    let mut c = tool("vol-render");
    c.arg(&vol)
        .args(["--ortho=80", "--ortho-height", "80", "-o"])
        .arg(png("e.png"));
    fails(&mut c, "--ortho");
    assert_eq!(c.status().unwrap().code(), Some(2));
    assert!(!png("e.png").exists());
}

#[test]
fn ct_preset_on_data_not_in_hounsfield_units_warns_once_with_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("ct.png");
    // u8 data, 0..255: one warning line naming the range and `auto`.
    let vol = gen(d, "r.vvol", &["ramp", "--dims", "24,20,16"]);
    let render = |vol: &Path, extra: &[&str]| {
        let mut c = tool("vol-render");
        c.arg(vol)
            .args(["--tf", "ct", "--size", "32x24", "-o"])
            .arg(&out)
            .args(extra);
        outcome(&mut c)
    };
    let (code, stdout, stderr) = render(&vol, &["--json"]);
    assert_eq!(code, Some(0), "{stderr}");
    json(&stdout);
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].starts_with("vol-render: ")
            && lines[0].contains("r.vvol")
            && lines[0].contains("Hounsfield")
            && lines[0].contains("span 0..")
            && lines[0].ends_with("try --tf auto"),
        "{stderr}"
    );
    // --quiet silences it; the render is the same.
    let (code, _, stderr) = render(&vol, &["--quiet"]);
    assert_eq!((code, stderr.as_str()), (Some(0), ""));
    // CT in Hounsfield units (a DICOM series rescaled to HU): no warning.
    let (code, _, stderr) = render(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/dicom_ct"),
        &["--json"],
    );
    assert_eq!((code, stderr.as_str()), (Some(0), ""));
}

/// `vol-index --json` percentile `key` of `vol`.
fn percentile(vol: &Path, key: &str) -> f64 {
    let j = json(&ok(tool("vol-index")
        .arg(vol)
        .args(["--stats", "--json", "--quiet"])));
    j["percentiles"][key].as_f64().unwrap()
}

#[test]
fn auto_preset_is_a_grey_ramp_windowed_from_the_histogram_percentiles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "n.vvol", &["noise", "--dims", "40,40,40", "--seed", "3"]);
    let render = |name: &str, extra: &[&str]| -> u64 {
        let p = d.join(name);
        ok(tool("vol-render")
            .arg(&vol)
            .args(["--size", "48x40", "-q", "-o"])
            .arg(&p)
            .args(extra));
        png_hash(&p)
    };
    // auto:1 is exactly the grey ramp from the 1st to the 99th percentile
    // of the histogram (vol-index reports the same percentiles).
    let (p1, p99) = (percentile(&vol, "p1"), percentile(&vol, "p99"));
    let range = json(&ok(tool("vol-info").arg(&vol).arg("--json")));
    let (min, max) = (
        range["min"].as_f64().unwrap(),
        range["max"].as_f64().unwrap(),
    );
    assert!(min < p1 && p1 < p99 && p99 < max, "{min} {p1} {p99} {max}");
    let tf = d.join("window.tf");
    std::fs::write(
        &tf,
        format!("domain {p1} {p99}\nstep 1\npoint {p1} 0 0 0 0\npoint {p99} 255 255 255 0.1\n"),
    )
    .unwrap();
    let by_file = render("file.png", &["--tf", tf.to_str().unwrap()]);
    assert_eq!(render("auto1.png", &["--tf", "auto:1"]), by_file);
    // The histogram is the same from a saved index or, without skipping,
    // from one built just for it.
    ok(tool("vol-index").arg(&vol).arg("--quiet"));
    let vidx = d.join("n.vvol.vidx");
    assert_eq!(
        render(
            "auto1i.png",
            &["--tf", "auto:1", "--index", vidx.to_str().unwrap()]
        ),
        by_file
    );
    assert_eq!(
        render("auto1n.png", &["--tf", "auto:1", "--no-ess"]),
        render("file_n.png", &["--tf", tf.to_str().unwrap(), "--no-ess"])
    );
    // Plain auto (0.5 %) windows narrower than grey's whole range.
    assert_ne!(
        render("auto.png", &["--tf", "auto"]),
        render("grey.png", &["--tf", "grey"])
    );
    assert_ne!(render("auto.png", &["--tf", "auto"]), by_file);
    // A percentile outside 0..50 is a usage error; --help lists the preset.
    let mut c = tool("vol-render");
    c.arg(&vol)
        .args(["--tf", "auto:50", "-o"])
        .arg(d.join("x.png"));
    fails(&mut c, "0..50");
    assert_eq!(c.status().unwrap().code(), Some(2));
    assert!(!d.join("x.png").exists());
    let help = ok(tool("vol-render").arg("--help"));
    assert!(help.contains("auto or auto:P"), "{help}");
}

#[test]
fn completions_and_man_page_come_from_the_command_line_definition() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let text = ok(tool("vol-render").args(["--completions", shell]));
        assert!(
            text.contains("vol-render") && text.contains("ortho-height"),
            "{shell}: {text}"
        );
    }
    let man = ok(tool("vol-render").arg("--man"));
    assert!(
        man.contains(".TH vol-render") && man.contains("ortho\\-height") && man.contains("auto"),
        "{man}"
    );
    // Both are exclusive: no volume needed, and nothing else allowed.
    let mut c = tool("vol-render");
    c.args(["--man", "--ortho"]);
    fails(&mut c, "--man");
    assert_eq!(c.status().unwrap().code(), Some(2));
}

/// vol-render on `vol` with each case's arguments (and a small size,
/// writing `out`): one line holding the case's needle, exit 2, and
/// nothing written.
fn usage_errors(vol: &std::path::Path, out: &std::path::Path, cases: &[(&[&str], &str)]) {
    for (args, needle) in cases {
        let mut c = tool("vol-render");
        c.arg(vol)
            .args(["--size", "24x24", "-o"])
            .arg(out)
            .args(*args);
        fails(&mut c, needle);
        assert_eq!(c.status().unwrap().code(), Some(2), "{args:?}");
        assert!(!out.exists(), "{args:?}");
    }
}

/// `--preintegrated`: where it does not apply, one line and exit 2 with
/// nothing written; where it does, a frame whose --json states the
/// table's cost and whose printed scene reads back the flag.
#[test]
fn preintegration_is_refused_where_it_does_not_apply_and_costs_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "s.vvol", &["shapes", "--dims", "40,36,32"]);
    let out = d.join("x.png");
    usage_errors(
        &vol,
        &out,
        &[
            (&["--preintegrated", "--mode", "mip"], "--mode dvr"),
            (&["--preintegrated", "--mode", "xray"], "--mode dvr"),
            (
                &["--preintegrated", "--interp", "nearest", "--tf", "shapes"],
                "trilinear",
            ),
            (
                &["--preintegrated", "--tf", "boundary"],
                "1D transfer functions",
            ),
        ],
    );
    let report = |extra: &[&str]| {
        json(&ok(tool("vol-render")
            .arg(&vol)
            .args(["--tf", "shapes", "--size", "48x40", "--json", "-q", "-o"])
            .arg(&out)
            .args(extra)))
    };
    let pre = report(&["--preintegrated"]);
    let post = report(&[]);
    // u8 values: two bins per unit, 510 x 510 pairs (and the single and
    // half-step tables beside them).
    assert_eq!(pre["table_bytes"].as_u64(), Some(510 * 512 * 16));
    assert!(pre["table_s"].as_f64().unwrap() > 0.0);
    assert_eq!(post["table_bytes"].as_u64(), Some(1020 * 16));
    assert_eq!(pre["scene"]["preintegrated"], serde_json::json!(true));
    assert_eq!(post["scene"]["preintegrated"], serde_json::json!(false));
}

/// `--adaptive TOL`: refused with one line and exit 2 where it does not
/// apply or TOL is not a positive number; with `--no-ess` it still reads
/// the index (the same frame as with skipping), takes fewer samples than
/// the step alone, and the strides' cost is in the tables' figures.
#[test]
fn adaptive_steps_are_refused_where_they_do_not_apply_and_read_the_index() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "s.vvol", &["noise", "--dims", "48,40,36"]);
    let out = d.join("x.png");
    usage_errors(
        &vol,
        &out,
        &[
            (&["--adaptive", "0"], "positive number"),
            (&["--adaptive", "-1"], "positive number"),
            (&["--adaptive", "NaN"], "positive number"),
            (&["--adaptive", "inf"], "positive number"),
            (&["--adaptive", "0.01", "--mode", "mip"], "--mode dvr"),
            (&["--adaptive", "0.01", "--mode", "path"], "--mode dvr"),
            (&["--adaptive", "0.01", "--preintegrated"], "do not combine"),
            (
                &["--adaptive", "0.01", "--tf", "boundary"],
                "1D transfer functions",
            ),
        ],
    );
    // Empty below 110 (cells to skip), a ramp above.
    let tf = d.join("ramp.tf");
    std::fs::write(&tf, "point 110 0 0 0 0\npoint 200 250 200 150 0.4\n").unwrap();
    let report = |extra: &[&str]| {
        let r = json(&ok(tool("vol-render")
            .arg(&vol)
            .arg("--tf")
            .arg(&tf)
            .args(["--size", "48x40", "--step", "0.1", "--json", "-q", "-o"])
            .arg(&out)
            .args(extra)));
        (r, std::fs::read(&out).unwrap())
    };
    let samples_of = |r: &serde_json::Value| r["samples"].as_u64().unwrap();
    let (plain, _) = report(&[]);
    let (adaptive, image) = report(&["--adaptive", "0.05"]);
    let (walked, walked_image) = report(&["--adaptive", "0.05", "--no-ess"]);
    assert_eq!(image, walked_image, "skipping changed the adaptive frame");
    assert!(
        samples_of(&walked) > samples_of(&adaptive),
        "--no-ess skipped nothing"
    );
    assert!(
        samples_of(&adaptive) < samples_of(&plain),
        "{adaptive} vs {plain}"
    );
    // The strides: one byte per level-0 cell (6 x 5 x 5 of 8 voxels).
    assert_eq!(
        adaptive["table_bytes"].as_u64(),
        Some(plain["table_bytes"].as_u64().unwrap() + 6 * 5 * 5)
    );
    assert_eq!(adaptive["scene"]["adaptive"], serde_json::json!(0.05));
}

/// `--budget SECONDS`: refused with one line and exit 2 where it cannot
/// apply; where it does, the frame has the size asked for and --json
/// states the choice. A budget nothing fits gives the coarsest setting
/// with a note; one everything fits gives the finest, the same image as
/// that step alone.
#[test]
fn a_frame_budget_states_its_choice_and_keeps_the_size() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "s.vvol", &["shapes", "--dims", "96,96,96"]);
    let out = d.join("x.png");
    usage_errors(
        &vol,
        &out,
        &[
            (&["--budget", "0"], "positive number"),
            (&["--budget", "-1"], "positive number"),
            (&["--budget", "NaN"], "positive number"),
            (&["--budget", "inf"], "positive number"),
            (&["--budget", "1", "--mode", "path"], "--seconds"),
        ],
    );
    let run = |extra: &[&str]| {
        let mut c = tool("vol-render");
        c.arg(&vol)
            .args(["--tf", "shapes", "--size", "200x160", "--json", "-o"])
            .arg(&out)
            .args(extra);
        let report = json(&ok(&mut c));
        let png = volcompare::image::Image::load(&out).unwrap();
        assert_eq!((png.width, png.height), (200, 160), "{extra:?}");
        (report, png.samples)
    };
    // Nothing fits a nanosecond: the coarsest, said so.
    let (tight, _) = run(&["--budget", "1e-9"]);
    let b = &tight["budget"];
    assert_eq!(b["fits"], false, "{b}");
    assert_eq!(b["step_factor"], 8.0, "{b}");
    assert_eq!(
        (b["rendered_width"].as_u64(), b["rendered_height"].as_u64()),
        (Some(25), Some(20))
    );
    assert!(tight["width"] == 200 && tight["height"] == 160, "{tight}");
    let mut c = tool("vol-render");
    c.arg(&vol)
        .args([
            "--tf", "shapes", "--size", "200x160", "--budget", "1e-9", "-o",
        ])
        .arg(&out);
    let stderr = String::from_utf8(c.output().unwrap().stderr).unwrap();
    assert!(stderr.contains("below the coarsest"), "{stderr}");
    // Everything fits an hour: a quarter of the step at full size, the
    // image of that step alone.
    let (loose, image) = run(&["--budget", "3600"]);
    let b = &loose["budget"];
    assert_eq!(
        (b["fits"].as_bool(), b["step_factor"].as_f64()),
        (Some(true), Some(0.25)),
        "{b}"
    );
    assert_eq!(b["scale"], 1.0, "{b}");
    let base = b["base_step"].as_f64().unwrap();
    assert_eq!(base, 0.5, "half the voxel spacing");
    for key in ["expected_s", "measured_s", "probe_s"] {
        assert!(
            b[key].as_f64().is_some_and(|s| s > 0.0 && s.is_finite()),
            "{key}: {b}"
        );
    }
    assert!(
        b["expected_psnr"].as_f64().is_some_and(f64::is_finite),
        "{b}"
    );
    let (_, plain) = run(&["--step", "0.125"]);
    assert!(
        image == plain,
        "the finest choice differs from --step 0.125 alone"
    );
    assert_eq!(loose["scene"]["budget"], 3600.0);
}
