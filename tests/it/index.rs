//! End to end: vol-index on volumes written by vol-gen, and its --check.

use crate::common::*;
use std::path::{Path, PathBuf};

/// Offset of the fingerprint in a `.vidx` header (see index/FORMAT.md).
const FINGERPRINT: std::ops::Range<usize> = 48..56;

fn gen(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    ok(tool("vol-gen")
        .args(args)
        .arg("-o")
        .arg(&out)
        .arg("--quiet"));
    out
}

/// `vol-index VOLUME EXTRA...`, insisting on success; the index path.
fn index(volume: &Path, extra: &[&str]) -> PathBuf {
    ok(tool("vol-index").arg(volume).args(extra).arg("--quiet"));
    let mut p = volume.as_os_str().to_owned();
    p.push(".vidx");
    PathBuf::from(p)
}

fn check(index: &Path, volume: &Path) -> std::process::Command {
    let mut c = tool("vol-index");
    c.arg("--check").arg(index).arg(volume);
    c
}

/// The index bytes that depend on the samples only: everything but the
/// volume fingerprint and the checksum over it.
fn sample_part(bytes: &[u8]) -> Vec<u8> {
    let mut b = bytes[..bytes.len() - 4].to_vec();
    b[FINGERPRINT].fill(0);
    b
}

const SCENE: [&str; 9] = [
    "shapes", "--dims", "61,47,39", "--count", "10", "--size", "16", "--seed", "3",
];

/// Sliced, bricked, zstd, thesis .vol and .raw copies of one volume give
/// the same index; only the fingerprint (and the checksum over it) tells
/// them apart, and each index belongs to its own file only.
#[test]
fn every_copy_of_a_volume_gives_the_same_index() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let copies: Vec<(&str, Vec<&str>)> = vec![
        ("s.vvol", vec![]),
        ("b.vvol", vec!["--layout", "bricked:16"]),
        ("b5.vvol", vec!["--layout", "bricked:5"]),
        (
            "z.vvol",
            vec!["--layout", "bricked:16", "--compress", "zstd"],
        ),
        ("t.vol", vec!["--layout", "bricked:8"]),
        ("r_61x47x39_uint8.raw", vec![]),
    ];
    let mut files = Vec::new();
    for (name, extra) in &copies {
        let args: Vec<&str> = SCENE.iter().copied().chain(extra.iter().copied()).collect();
        let vol = gen(d, name, &args);
        let ix = index(&vol, &[]);
        files.push((vol, std::fs::read(&ix).unwrap(), ix));
    }
    let reference = sample_part(&files[0].1);
    let mut fingerprints = Vec::new();
    for (vol, bytes, _) in &files {
        assert_eq!(bytes.len(), files[0].1.len(), "{}", vol.display());
        assert!(
            sample_part(bytes) == reference,
            "{}: index differs from the sliced copy's",
            vol.display()
        );
        fingerprints.push(bytes[FINGERPRINT].to_vec());
    }
    fingerprints.sort();
    fingerprints.dedup();
    assert_eq!(fingerprints.len(), copies.len(), "fingerprints collide");
    // Each index checks against its own volume and no other copy.
    for (i, (vol, _, ix)) in files.iter().enumerate() {
        ok(&mut check(ix, vol));
        let (other, _, _) = &files[(i + 1) % files.len()];
        fails(&mut check(ix, other), "another volume");
    }
    assert!(leftovers(d).is_empty());
}

/// The index file does not depend on the number of threads.
#[test]
fn index_bytes_do_not_depend_on_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: [(&str, &[&str]); 4] = [
        ("u8.vvol", &SCENE),
        (
            "f32z.vvol",
            &[
                "spheres",
                "--dims",
                "40,41,42",
                "--count",
                "9",
                "--size",
                "10",
                "--layout",
                "bricked:8",
                "--compress",
                "zstd",
                "--type",
                "f32",
            ],
        ),
        (
            "i16.vvol",
            &[
                "noise",
                "--dims",
                "33,34,35",
                "--period",
                "9",
                "--type",
                "i16",
                "--value",
                "3000",
                "--layout",
                "bricked:16",
            ],
        ),
        ("u16.vvol", &["ramp", "--dims", "17,18,19", "--type", "u16"]),
    ];
    for (name, args) in cases {
        let vol = gen(d, name, args);
        let mut outputs = Vec::new();
        for threads in ["1", "2", "7"] {
            let out = d.join(format!("{name}.{threads}.vidx"));
            ok(tool("vol-index")
                .env("RAYON_NUM_THREADS", threads)
                .arg(&vol)
                .args(["--cell", "4", "-o"])
                .arg(&out));
            outputs.push(std::fs::read(&out).unwrap());
        }
        assert!(
            outputs.windows(2).all(|w| w[0] == w[1]),
            "{name}: index differs between thread counts"
        );
    }
}

#[test]
fn stale_and_damaged_indexes_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = |seed: &'static str| {
        vec![
            "shapes",
            "--dims",
            "40,30,20",
            "--count",
            "6",
            "--size",
            "10",
            "--seed",
            seed,
            "--layout",
            "bricked:16",
        ]
    };
    let vol = gen(d, "v.vvol", &args("1"));
    let ix = index(&vol, &[]);
    let good = std::fs::read(&ix).unwrap();
    let out = ok(&mut check(&ix, &vol));
    assert!(out.contains("ok"), "{out}");
    // --quiet: the exit status alone.
    assert_eq!(ok(check(&ix, &vol).arg("--quiet")), "");

    // The volume regenerated with another seed: stale.
    gen(d, "v.vvol", &args("2"));
    let line = fails(&mut check(&ix, &vol), "another volume");
    assert!(line.starts_with("vol-index: "), "{line}");
    assert!(line.contains("v.vvol.vidx"), "{line}");
    assert!(line.contains("rebuild"), "{line}");
    // Rebuilt, it is fresh again.
    index(&vol, &[]);
    ok(&mut check(&ix, &vol));
    let good2 = std::fs::read(&ix).unwrap();
    assert_ne!(good, good2);

    // Truncated anywhere: in the header, the levels, the checksum.
    for keep in [5, 60, good2.len() / 2, good2.len() - 1] {
        std::fs::write(&ix, &good2[..keep]).unwrap();
        fails(&mut check(&ix, &vol), "truncated");
    }
    std::fs::write(&ix, []).unwrap();
    fails(&mut check(&ix, &vol), "truncated");
    // A flipped bit in the level data.
    let mut bad = good2.clone();
    let n = bad.len();
    bad[n - 9] ^= 0x40;
    std::fs::write(&ix, &bad).unwrap();
    fails(&mut check(&ix, &vol), "checksum");
    // Not an index at all; a missing index.
    std::fs::write(&ix, b"hello, this is not an index file").unwrap();
    fails(&mut check(&ix, &vol), "not a volkit index");
    fails(&mut check(&d.join("none.vidx"), &vol), "none.vidx");

    // Raw files: regenerated with another seed (same length) is stale too.
    let raw = gen(
        d,
        "r_24x20x16_uint8.raw",
        &["noise", "--dims", "24,20,16", "--seed", "1"],
    );
    let rix = index(&raw, &[]);
    ok(&mut check(&rix, &raw));
    gen(
        d,
        "r_24x20x16_uint8.raw",
        &["noise", "--dims", "24,20,16", "--seed", "2"],
    );
    fails(&mut check(&rix, &raw), "another volume");
    // The same raw bytes read with other (permuted) dimensions.
    index(&raw, &[]);
    fails(
        check(&rix, &raw).args(["--raw-dims", "16,20,24"]),
        "index is for a 24x20x16",
    );
}

/// The JSON object carries the figures scripts rely on, consistent with
/// vol-info and with the file written.
#[test]
fn json_figures_are_present_and_sane() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, args, cell) in [
        ("u8.vvol", SCENE.to_vec(), 8u64),
        (
            "f32.vvol",
            vec![
                "sphere", "--dims", "30,31,32", "--type", "f32", "--radius", "12",
            ],
            5,
        ),
        (
            "i16.vvol",
            vec![
                "noise", "--dims", "20,21,22", "--type", "i16", "--value", "3000",
            ],
            16,
        ),
    ] {
        let vol = gen(d, name, &args);
        let cell_arg = cell.to_string();
        let v = json(&ok(tool("vol-index")
            .arg(&vol)
            .args(["--json", "--cell", &cell_arg])));
        for key in [
            "seconds",
            "load_s",
            "build_s",
            "write_s",
            "cells",
            "cell",
            "levels",
            "level_cells",
            "empty_fraction",
            "min",
            "max",
            "nan_count",
            "bytes",
            "input",
            "index",
            "threads",
            "fingerprint",
            "histogram",
            "percentiles",
        ] {
            assert!(!v[key].is_null(), "{name}: missing {key}: {v}");
        }
        let e = v["empty_fraction"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&e), "{name}: {e}");
        let info = json(&ok(tool("vol-info").arg("--json").arg(&vol)));
        assert_eq!(v["min"], info["min"], "{name}");
        assert_eq!(v["max"], info["max"], "{name}");
        let dims: Vec<u64> = info["dims"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect();
        let cells: u64 = dims.iter().map(|n| n.div_ceil(cell)).product();
        assert_eq!(v["cells"].as_u64(), Some(cells), "{name}");
        assert_eq!(v["cell"].as_u64(), Some(cell), "{name}");
        let levels = v["level_cells"].as_array().unwrap();
        assert_eq!(v["levels"].as_u64(), Some(levels.len() as u64));
        assert_eq!(levels.last().unwrap(), &serde_json::json!([1, 1, 1]));
        let ix = PathBuf::from(v["index"].as_str().unwrap());
        assert_eq!(
            v["bytes"].as_u64(),
            Some(std::fs::metadata(&ix).unwrap().len())
        );
        for key in ["seconds", "load_s", "build_s", "write_s"] {
            assert!(v[key].as_f64().unwrap() >= 0.0);
        }
        assert!(v["seconds"].as_f64() >= v["build_s"].as_f64());
        let p50 = v["percentiles"]["p50"].as_f64().unwrap();
        assert!(p50 >= v["min"].as_f64().unwrap() && p50 <= v["max"].as_f64().unwrap());
        // --check --json reports the same figures from the file.
        let c = json(&ok(tool("vol-index")
            .arg("--check")
            .arg(&ix)
            .arg(&vol)
            .arg("--json")));
        assert_eq!(c["ok"], true);
        for key in ["cells", "empty_fraction", "min", "max", "fingerprint"] {
            assert_eq!(c[key], v[key], "{name}: {key}");
        }
    }
    // The shapes scene is mostly empty space, but not entirely.
    let v = json(&ok(tool("vol-index").arg(d.join("u8.vvol")).arg("--json")));
    let e = v["empty_fraction"].as_f64().unwrap();
    assert!(e > 0.05 && e < 0.95, "{e}");
}

#[test]
fn stats_output_options_and_default_path() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = gen(d, "s.vvol", &SCENE);
    let out = ok(tool("vol-index").arg(&vol).arg("--stats"));
    for part in [
        "values 0 .. ",
        "percentiles",
        "busiest",
        "level 0: 8x6x5 = 240 cells",
        "empty at threshold 0",
    ] {
        assert!(out.contains(part), "missing '{part}' in:\n{out}");
    }
    // --stats alone prints and writes nothing (issue 53 §5); with -o it
    // writes the index too.
    assert!(!d.join("s.vvol.vidx").exists());
    let v = json(&ok(tool("vol-index").arg(&vol).args(["--stats", "--json"])));
    assert_eq!(
        (&v["output"], &v["bytes"]),
        (&serde_json::Value::Null, &serde_json::Value::Null)
    );
    assert!(!d.join("s.vvol.vidx").exists());
    ok(tool("vol-index")
        .arg(&vol)
        .args(["--stats", "-o"])
        .arg(d.join("s.vidx")));
    assert!(d.join("s.vidx").exists());
    ok(tool("vol-index").arg(&vol));
    assert!(d.join("s.vvol.vidx").exists());
    // -o and --cell; the check reads the cell edge from the file.
    let other = d.join("sub-16.vidx");
    ok(tool("vol-index")
        .arg(&vol)
        .args(["--cell", "16", "--bins", "16", "-o"])
        .arg(&other));
    let v = json(&ok(check(&other, &vol).arg("--json")));
    assert_eq!(v["cell"], 16);
    assert_eq!(v["cells"], 4 * 3 * 3);
    // 16 bins of integer width over the data range, not 256 of width 1.
    let bins = v["histogram"]["bins"].as_u64().unwrap();
    let width = v["histogram"]["bin_width"].as_f64().unwrap();
    assert!(bins <= 16 && width > 1.0 && width.fract() == 0.0, "{v}");
    assert!(leftovers(d).is_empty());
}

/// Bad volumes and bad options fail with one line and leave no index.
#[test]
fn bad_input_fails_cleanly_and_leaves_no_index() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = [
        "shapes", "--dims", "20,20,20", "--count", "4", "--size", "6",
    ];

    // Truncated volumes of each kind.
    for name in ["t.vvol", "t.vol", "t_20x20x20_uint8.raw"] {
        let p = gen(d, name, &small);
        let len = std::fs::metadata(&p).unwrap().len();
        std::fs::OpenOptions::new()
            .write(true)
            .open(&p)
            .unwrap()
            .set_len(len - 7)
            .unwrap();
        let line = fails(tool("vol-index").arg(&p), name);
        assert!(
            line.starts_with(&format!("vol-index: {}", p.display())),
            "{line}"
        );
        assert!(!d.join(format!("{name}.vidx")).exists(), "{name}");
    }
    // A compressed volume with a damaged brick fails while building.
    let z = gen(
        d,
        "z.vvol",
        &[
            "noise",
            "--dims",
            "40,40,40",
            "--layout",
            "bricked:16",
            "--compress",
            "zstd",
        ],
    );
    let mut b = std::fs::read(&z).unwrap();
    let mid = b.len() / 2;
    for x in &mut b[mid..mid + 64] {
        *x ^= 0x5A;
    }
    std::fs::write(&z, &b).unwrap();
    fails(tool("vol-index").arg(&z), "z.vvol");
    assert!(!d.join("z.vvol.vidx").exists());

    let vol = gen(d, "ok.vvol", &small);
    for (args, needle) in [
        (vec!["--cell", "1"], "cell edge 1"),
        (vec!["--cell", "2000"], "cell edge 2000"),
        (vec!["--bins", "0"], "histogram bins"),
    ] {
        fails(tool("vol-index").arg(&vol).args(&args), needle);
    }
    assert!(!d.join("ok.vvol.vidx").exists());
    fails(
        tool("vol-index").arg(d.join("missing.vvol")),
        "missing.vvol",
    );
    std::fs::write(d.join("x.png"), b"png").unwrap();
    fails(tool("vol-index").arg(d.join("x.png")), "unknown input type");
    fails(tool("vol-index").arg("-"), "stream");
    fails(tool("vol-index").arg(&vol).args(["-o", "-"]), "stdout");
    // Never write an index over a volume.
    let victim = gen(d, "victim.vvol", &small);
    let before = std::fs::read(&victim).unwrap();
    fails(
        tool("vol-index").arg(&vol).arg("-o").arg(&victim),
        "refusing",
    );
    assert_eq!(std::fs::read(&victim).unwrap(), before);
    fails(
        tool("vol-index")
            .arg(&vol)
            .arg("-o")
            .arg(d.join("no/such/dir/x.vidx")),
        "x.vidx",
    );
    // clap's usage errors (a non-number, -o with --check) are non-zero too.
    assert!(!run(tool("vol-index").arg(&vol).args(["--cell", "eight"]))
        .status
        .success());
    assert!(!run(tool("vol-index")
        .args(["--check", "a.vidx", "-o", "b.vidx"])
        .arg(&vol))
    .status
    .success());
    assert!(!d.join("ok.vvol.vidx").exists());
    assert!(leftovers(d).is_empty());
}
