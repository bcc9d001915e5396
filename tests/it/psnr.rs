//! End to end: vol-psnr on images and volumes, its output and exit statuses.

use crate::common::*;
use std::path::{Path, PathBuf};
use volcompare::{write_pfm, write_png8};

/// An 8-bit RGB PNG of `w × h` whose samples come from `f(index)`.
fn png(dir: &Path, name: &str, w: u32, h: u32, f: impl Fn(usize) -> u8) -> PathBuf {
    let p = dir.join(name);
    let data: Vec<u8> = (0..(w * h * 3) as usize).map(f).collect();
    write_png8(&p, w, h, 3, &data).unwrap();
    p
}

fn gen(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    ok(tool("vol-gen")
        .args(args)
        .arg("-o")
        .arg(&out)
        .arg("--quiet"));
    out
}

fn status(cmd: &mut std::process::Command) -> i32 {
    run(cmd).status.code().unwrap_or(-1)
}

#[test]
fn identical_images_print_inf_and_json_null() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 16, 9, |i| (i * 7 % 256) as u8);
    let b = png(dir.path(), "b.png", 16, 9, |i| (i * 7 % 256) as u8);
    let text = ok(tool("vol-psnr").arg(&a).arg(&b));
    assert_eq!(text.trim(), "PSNR inf (identical)");
    let v = json(&ok(tool("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(v["psnr"], serde_json::Value::Null);
    assert_eq!(v["identical"], true);
    assert_eq!(v["mse"], 0.0);
    assert_eq!(v["max_abs"], 0.0);
    assert_eq!(v["differing"], 0);
}

#[test]
fn json_has_the_figures_and_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (20u32, 10u32);
    let a = png(dir.path(), "a.png", w, h, |i| (i % 200) as u8);
    // One value off by one.
    let b = png(dir.path(), "b.png", w, h, |i| {
        (i % 200) as u8 + (i == 31) as u8
    });
    let v = json(&ok(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--per-channel"])));
    for key in [
        "psnr",
        "identical",
        "mse",
        "max_abs",
        "differing",
        "differing_fraction",
        "peak",
        "width",
        "height",
        "channels",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    let n = 3.0 * (w * h) as f64;
    let want = 10.0 * (255f64.powi(2) * n).log10();
    assert!((v["psnr"].as_f64().unwrap() - want).abs() < 1e-9, "{v}");
    assert_eq!(v["identical"], false);
    assert_eq!(v["mse"].as_f64().unwrap(), 1.0 / n);
    assert_eq!(v["max_abs"], 1.0);
    assert_eq!(v["differing"], 1);
    assert_eq!(v["peak"], 255.0);
    assert_eq!(
        (v["width"].clone(), v["height"].clone()),
        (20.into(), 10.into())
    );
    assert_eq!(v["channels"], 3);
    let per = v["per_channel"].as_array().unwrap();
    assert_eq!(per.len(), 3);
    // Sample 31 is pixel 10's G value.
    assert_eq!(per[1]["channel"], "G");
    assert_eq!(per[1]["differing"], 1);
    assert_eq!(per[0]["psnr"], serde_json::Value::Null);

    let text = ok(tool("vol-psnr").arg(&a).arg(&b));
    assert_eq!(text.lines().count(), 1);
    assert!(
        text.starts_with(&format!(
            "PSNR {want:.2} dB  MSE 0.001667  max |d| 1  differing"
        )),
        "{text}"
    );
}

#[test]
fn min_psnr_sets_the_exit_status() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 8, 8, |i| (i % 100) as u8);
    // Constant offset 10: PSNR = 20·log10(25.5) = 28.13 dB.
    let b = png(dir.path(), "b.png", 8, 8, |i| (i % 100) as u8 + 10);
    ok(tool("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "28"]));
    let mut below = tool("vol-psnr");
    below.arg(&a).arg(&b).args(["--min-psnr", "30", "--quiet"]);
    let line = fails(&mut below, "below --min-psnr 30");
    assert!(line.contains("28.13"), "{line}");
    assert_eq!(status(&mut below), 4);
    let out = run(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--min-psnr", "30", "--json"]));
    assert_eq!(out.status.code(), Some(4));
    let v = json(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(v["passed"], false);
    // Identical inputs pass any threshold.
    ok(tool("vol-psnr").arg(&a).arg(&a).args(["--min-psnr", "inf"]));
}

#[test]
fn mismatches_unreadable_inputs_and_usage_have_distinct_statuses() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = png(d, "a.png", 8, 8, |_| 1);
    let small = png(d, "small.png", 8, 7, |_| 1);
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(&small);
    let line = fails(&mut c, "sizes differ");
    assert!(line.contains("8x8") && line.contains("8x7"), "{line}");
    assert_eq!(status(&mut c), 3);

    // Grey against RGB: a channel mismatch.
    let grey = d.join("grey.png");
    write_png8(&grey, 8, 8, 1, &[1; 64]).unwrap();
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(&grey);
    fails(&mut c, "channel counts differ");
    assert_eq!(status(&mut c), 3);

    // 8-bit PNG against a float PFM: different sample types.
    let pfm = d.join("a.pfm");
    write_pfm(&pfm, 8, 8, &[0.0; 192]).unwrap();
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(&pfm);
    fails(&mut c, "sample types differ");
    assert_eq!(status(&mut c), 3);

    // An image against a volume.
    let v = gen(d, "v.vvol", &["solid", "--dims", "8,8,8"]);
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(&v);
    fails(&mut c, "is a volume");
    assert_eq!(status(&mut c), 3);

    // Volumes of different dimensions.
    let v2 = gen(d, "v2.vvol", &["solid", "--dims", "8,8,9"]);
    let mut c = tool("vol-psnr");
    c.arg(&v).arg(&v2);
    fails(&mut c, "dimensions differ");
    assert_eq!(status(&mut c), 3);

    // Missing, malformed and unknown inputs: status 1, naming the file.
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(d.join("missing.png"));
    fails(&mut c, "missing.png");
    assert_eq!(status(&mut c), 1);
    std::fs::write(d.join("junk.png"), b"not a png").unwrap();
    let mut c = tool("vol-psnr");
    c.arg(d.join("junk.png")).arg(&a);
    fails(&mut c, "junk.png");
    assert_eq!(status(&mut c), 1);
    std::fs::write(d.join("short.pfm"), b"PF\n2 2\n-1\n\0\0").unwrap();
    let mut c = tool("vol-psnr");
    c.arg(d.join("short.pfm")).arg(&pfm);
    fails(&mut c, "short.pfm");
    assert_eq!(status(&mut c), 1);
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(d.join("x.jpg"));
    fails(&mut c, "unknown file type");
    assert_eq!(status(&mut c), 1);

    // Usage: clap's, and options that do not fit the inputs.
    assert_eq!(status(tool("vol-psnr").arg(&a)), 2);
    assert_eq!(
        status(tool("vol-psnr").arg(&a).arg(&a).args(["--range", "0"])),
        2
    );
    let mut c = tool("vol-psnr");
    c.arg(&v).arg(&v).arg("--luma");
    fails(&mut c, "images only");
    assert_eq!(status(&mut c), 2);
    let mut c = tool("vol-psnr");
    c.arg(&a).arg(&a).arg("--diff").arg(d.join("d.jpg"));
    fails(&mut c, ".png");
    assert_eq!(status(&mut c), 2);
    assert!(!d.join("d.jpg").exists());
    assert!(leftovers(d).is_empty());
}

#[test]
fn identical_volumes_across_formats() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "shapes", "--dims", "40,33,21", "--count", "6", "--size", "10", "--seed", "3",
    ];
    let a = gen(dir.path(), "a.vvol", &args);
    let with_layout: Vec<&str> = args
        .iter()
        .copied()
        .chain(["--layout", "bricked:8", "--compress", "zstd"])
        .collect();
    let b = gen(dir.path(), "b.vvol", &with_layout);
    let c = gen(dir.path(), "c.vol", &args);
    for other in [&b, &c] {
        let v = json(&ok(tool("vol-psnr").arg(&a).arg(other).arg("--json")));
        assert_eq!(v["identical"], true, "{v}");
        assert_eq!(v["psnr"], serde_json::Value::Null);
        assert_eq!(v["dims"], serde_json::json!([40, 33, 21]));
        assert_eq!(v["count"], 40 * 33 * 21);
        assert_eq!(v["peak"], 255.0);
    }
    assert_eq!(
        ok(tool("vol-psnr").arg(&a).arg(&c)).trim(),
        "PSNR inf (identical)"
    );
}

#[test]
fn volumes_with_different_seeds_have_a_finite_psnr_whatever_the_threads() {
    let dir = tempfile::tempdir().unwrap();
    let common = [
        "noise", "--dims", "48,40,36", "--type", "f32", "--value", "1",
    ];
    let a = gen(
        dir.path(),
        "a.vvol",
        &[&common[..], &["--seed", "1"]].concat(),
    );
    let b = gen(
        dir.path(),
        "b.vvol",
        &[&common[..], &["--seed", "2", "--layout", "bricked:16"]].concat(),
    );
    let mut outs = Vec::new();
    for threads in ["1", "3"] {
        let v = json(&ok(tool("vol-psnr")
            .env("RAYON_NUM_THREADS", threads)
            .arg(&a)
            .arg(&b)
            .arg("--json")));
        let p = v["psnr"].as_f64().expect("finite PSNR");
        assert!(p.is_finite() && p > 0.0, "{v}");
        assert_eq!(v["identical"], false);
        assert_eq!(v["peak_source"], "reference-range");
        assert!(v["differing_fraction"].as_f64().unwrap() > 0.5);
        outs.push((v["psnr"].clone(), v["mse"].clone(), v["max_abs"].clone()));
    }
    assert_eq!(outs[0], outs[1]);
    // --range replaces the reference's value range.
    let v = json(&ok(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--range", "10"])));
    assert_eq!(v["peak"], 10.0);
    assert_eq!(v["peak_source"], "given");
}

fn png_size(p: &Path) -> (u32, u32) {
    let b = std::fs::read(p).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        p.display()
    );
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn diff_writes_a_heat_map_png() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = png(d, "a.png", 90, 70, |i| (i % 256) as u8);
    let b = png(d, "b.png", 90, 70, |i| {
        ((i % 256) as u8).saturating_add((i % 17) as u8)
    });
    let out = d.join("diff.png");
    let v = json(&ok(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .arg("--json")
        .arg("--diff")
        .arg(&out)));
    let (w, h) = png_size(&out);
    assert!(w > 90 && h == 70, "{w}x{h}: the map plus a scale bar");
    assert_eq!(v["diff"]["scale_max"], 16.0);
    // Volumes: an X×Y map of the largest error along z.
    let va = gen(d, "a.vvol", &["noise", "--dims", "30,20,10", "--seed", "1"]);
    let vb = gen(d, "b.vvol", &["noise", "--dims", "30,20,10", "--seed", "2"]);
    let vout = d.join("vdiff.png");
    let run = run(tool("vol-psnr").arg(&va).arg(&vb).arg("--diff").arg(&vout));
    assert!(run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("wrote"));
    let (w, h) = png_size(&vout);
    assert!(w > 30 && h == 64, "{w}x{h}");
    // A diff into a missing directory is a read/write failure, status 1.
    let mut c = tool("vol-psnr");
    c.arg(&a)
        .arg(&b)
        .arg("--diff")
        .arg(d.join("no/such/dir.png"));
    fails(&mut c, "dir.png");
    assert_eq!(status(&mut c), 1);
    assert!(leftovers(d).is_empty());
}

#[test]
fn float_images_and_luma() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rgb: Vec<f32> = (0..4 * 4 * 3).map(|i| i as f32 / 64.0).collect();
    let shifted: Vec<f32> = rgb
        .iter()
        .enumerate()
        .map(|(i, v)| v + if i % 3 == 1 { 0.125 } else { 0.0 })
        .collect();
    let (a, b) = (d.join("a.pfm"), d.join("b.pfm"));
    write_pfm(&a, 4, 4, &rgb).unwrap();
    write_pfm(&b, 4, 4, &shifted).unwrap();
    let v = json(&ok(tool("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(v["peak"], 1.0);
    let want = 10.0 * (1.0 / (0.125f64 * 0.125 / 3.0)).log10();
    assert!((v["psnr"].as_f64().unwrap() - want).abs() < 1e-9, "{v}");
    let v = json(&ok(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--luma"])));
    assert_eq!(v["metric"], "luma");
    let want = 20.0 * (1.0 / (0.7152 * 0.125f64)).log10();
    assert!((v["psnr"].as_f64().unwrap() - want).abs() < 1e-6, "{v}");
    assert!(v["pooled"]["psnr"].is_number());
    let text = ok(tool("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--luma", "--per-channel"]));
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 4, "{text}");
    assert!(lines[0].starts_with("luma PSNR"), "{text}");
    assert!(
        lines[1].trim_start().starts_with("R PSNR inf (identical)"),
        "{text}"
    );
}
