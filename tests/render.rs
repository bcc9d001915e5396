//! End to end: vol-render through files.

mod common;
use common::*;
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
                0x3cff_e091_f193_4094,
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
                0xb951_095c_b819_b3bb,
            ],
        ),
        (
            "xray-mean",
            &["--mode", "xray-mean"],
            [
                0x9d77_ff85_0cf3_b480,
                0x6df4_ac06_74bf_fc44,
                0xb951_095c_b819_b3bb,
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
