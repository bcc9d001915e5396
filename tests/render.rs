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
