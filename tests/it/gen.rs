//! End to end: vol-gen and vol-info through files and pipes.

use crate::common::*;
use std::io::Write;
use std::path::Path;
use std::process::Stdio;

fn gen(dir: &Path, name: &str, extra: &[&str]) -> std::path::PathBuf {
    let out = dir.join(name);
    let mut c = tool("vol-gen");
    c.args(extra).arg("-o").arg(&out).arg("--quiet");
    ok(&mut c);
    out
}

#[test]
fn generates_sliced_bricked_and_compressed_and_verifies_them() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "shapes", "--dims", "96,80,72", "--count", "12", "--size", "24", "--seed", "2",
    ];
    let mut ranges = Vec::new();
    for (name, extra) in [
        ("s.vvol", vec![]),
        ("b.vvol", vec!["--layout", "bricked:16"]),
        (
            "z.vvol",
            vec!["--layout", "bricked:16", "--compress", "zstd:5"],
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        let p = gen(dir.path(), name, &args);
        let info = json(&ok(tool("vol-info").arg("--verify").arg("--json").arg(&p)));
        assert_eq!(info["dims"], serde_json::json!([96, 80, 72]));
        assert_eq!(info["verified"], true);
        ranges.push((info["min"].clone(), info["max"].clone()));
    }
    assert!(ranges.windows(2).all(|w| w[0] == w[1]));
    assert_eq!(ranges[0].0, 0.0);
    assert!(ranges[0].1.as_f64().unwrap() <= 110.0);
    assert!(leftovers(dir.path()).is_empty());
}

#[test]
fn json_reports_the_figures_scripts_rely_on() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("n.vvol");
    let v = json(&ok(tool("vol-gen")
        .args(["noise", "--dims", "32,32,32", "--json", "-o"])
        .arg(&out)));
    for key in ["seconds", "bytes", "dims", "type", "min", "max"] {
        assert!(!v[key].is_null(), "missing {key}: {v}");
    }
    assert_eq!(
        v["bytes"].as_u64().unwrap(),
        std::fs::metadata(&out).unwrap().len()
    );
}

/// The same arguments give the same bytes whatever the thread count.
#[test]
fn output_does_not_depend_on_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str]); 5] = [
        (
            "a.vvol",
            &[
                "shapes", "--dims", "70,61,53", "--count", "20", "--size", "20",
            ],
        ),
        (
            "b.vvol",
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
            "c.vvol",
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
        (
            "d.vol",
            &[
                "shapes",
                "--dims",
                "30,31,32",
                "--count",
                "5",
                "--size",
                "9",
                "--layout",
                "bricked:8",
            ],
        ),
        (
            "e_17x18x19_uint16.raw",
            &["sphere", "--dims", "17,18,19", "--type", "u16"],
        ),
    ];
    for (name, args) in cases {
        let mut outputs = Vec::new();
        for threads in ["1", "2", "7"] {
            let p = dir.path().join(format!("{threads}-{name}"));
            let mut c = tool("vol-gen");
            c.env("RAYON_NUM_THREADS", threads)
                .args(args)
                .arg("-o")
                .arg(&p);
            ok(&mut c);
            outputs.push(std::fs::read(&p).unwrap());
        }
        assert!(
            outputs.windows(2).all(|w| w[0] == w[1]),
            "{name} differs between thread counts"
        );
    }
}

#[test]
fn seeds_change_the_volume_and_repeat_it() {
    let dir = tempfile::tempdir().unwrap();
    let a = gen(
        dir.path(),
        "a.vvol",
        &[
            "shapes", "--dims", "40,40,40", "--size", "10", "--seed", "1",
        ],
    );
    let b = gen(
        dir.path(),
        "b.vvol",
        &[
            "shapes", "--dims", "40,40,40", "--size", "10", "--seed", "1",
        ],
    );
    let c = gen(
        dir.path(),
        "c.vvol",
        &[
            "shapes", "--dims", "40,40,40", "--size", "10", "--seed", "2",
        ],
    );
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_ne!(std::fs::read(&a).unwrap(), std::fs::read(&c).unwrap());
}

#[test]
fn pipe_round_trip_through_stdout_and_stdin() {
    let dir = tempfile::tempdir().unwrap();
    let file = gen(
        dir.path(),
        "f.vvol",
        &[
            "noise", "--dims", "50,40,30", "--type", "u16", "--value", "4000",
        ],
    );
    let out = run(tool("vol-gen").args([
        "noise", "--dims", "50,40,30", "--type", "u16", "--value", "4000", "-o", "-",
    ]));
    assert!(out.status.success());
    // The stream is byte for byte the file, except for the value range the
    // file's header gains once it is known (the trailer has it in both).
    let disk = std::fs::read(&file).unwrap();
    assert_eq!(out.stdout.len(), disk.len());
    assert_eq!(out.stdout[128..], disk[128..]);
    let mut child = tool("vol-info")
        .args(["-", "--json"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(&out.stdout).unwrap();
    let got = child.wait_with_output().unwrap();
    assert!(
        got.status.success(),
        "{}",
        String::from_utf8_lossy(&got.stderr)
    );
    let info = json(&String::from_utf8_lossy(&got.stdout));
    let disk_info = json(&ok(tool("vol-info").arg("--json").arg(&file)));
    assert_eq!(info["min"], disk_info["min"]);
    assert_eq!(info["max"], disk_info["max"]);
    // A stream cut short is an error, not a short volume.
    let mut child = tool("vol-info")
        .arg("-")
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&out.stdout[..5000])
        .unwrap();
    let got = child.wait_with_output().unwrap();
    assert!(!got.status.success());
    assert!(String::from_utf8_lossy(&got.stderr).contains("truncated"));
}

#[test]
fn bad_arguments_fail_cleanly_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let target = d.join("out.vol");
    fails(
        tool("vol-gen")
            .args(["shapes", "--dims", "8,8,8", "--type", "u16", "-o"])
            .arg(&target),
        "u8",
    );
    assert!(!target.exists());
    fails(
        tool("vol-gen")
            .args(["shapes", "--dims", "8,8,8", "--compress", "zstd", "-o"])
            .arg(d.join("x.vvol")),
        "bricked",
    );
    fails(
        tool("vol-gen").args([
            "shapes",
            "--dims",
            "8,8,8",
            "--layout",
            "bricked:8",
            "-o",
            "-",
        ]),
        "stdout",
    );
    fails(
        tool("vol-gen")
            .args(["shapes", "--dims", "8,8,8", "-o"])
            .arg(d.join("x.png")),
        "unknown output",
    );
    fails(
        tool("vol-gen")
            .args(["shapes", "--dims", "16777216,16777216,16777216", "-o"])
            .arg(d.join("x.vvol")),
        "overflow",
    );
    fails(
        tool("vol-gen")
            .args(["shapes", "--dims", "8,8,8", "-o"])
            .arg(d.join("missing/dir/x.vvol")),
        "x.vvol",
    );
    // clap's own usage errors are non-zero too (zero dims, unknown scene).
    assert!(!run(tool("vol-gen")
        .args(["shapes", "--dims", "0,8,8", "-o"])
        .arg(d.join("x.vvol")))
    .status
    .success());
    assert!(!run(tool("vol-gen")
        .args(["cubes", "--dims", "8,8,8", "-o"])
        .arg(d.join("x.vvol")))
    .status
    .success());
    assert!(!d.join("x.vvol").exists());
    assert!(leftovers(d).is_empty());
}

fn truncate(p: &Path, by: u64) {
    let len = std::fs::metadata(p).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(p)
        .unwrap()
        .set_len(len - by)
        .unwrap();
}

fn patch(p: &Path, at: usize, bytes: &[u8]) {
    let mut b = std::fs::read(p).unwrap();
    b[at..at + bytes.len()].copy_from_slice(bytes);
    std::fs::write(p, b).unwrap();
}

/// Every reader rejects truncated files, lying headers, overflowing and
/// zero dimensions with one line and a non-zero exit.
#[test]
fn malformed_files_are_rejected_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = [
        "shapes", "--dims", "20,20,20", "--count", "4", "--size", "6",
    ];

    // .vvol
    let p = gen(d, "t.vvol", &args);
    truncate(&p, 1);
    fails(tool("vol-info").arg(&p), "t.vvol");
    let p = gen(d, "bits.vvol", &args);
    patch(&p, 200, &[0xEE]);
    fails(tool("vol-info").arg("--verify").arg(&p), "checksum");
    let p = gen(d, "hdr.vvol", &args);
    patch(&p, 16, &7u64.to_le_bytes());
    fails(tool("vol-info").arg(&p), "header");

    // .vol (thesis): truncated, lying header, overflow, zero.
    let p = gen(d, "t.vol", &args);
    truncate(&p, 3);
    fails(tool("vol-info").arg(&p), "file has");
    let p = gen(d, "lie.vol", &args);
    patch(&p, 0, &400u32.to_le_bytes());
    fails(tool("vol-info").arg(&p), "file has");
    let p = gen(d, "big.vol", &args);
    for a in 0..3 {
        patch(&p, 4 * a, &u32::MAX.to_le_bytes());
    }
    fails(tool("vol-info").arg(&p), "dimensions");
    let p = gen(d, "zero.vol", &args);
    patch(&p, 4, &0u32.to_le_bytes());
    fails(tool("vol-info").arg(&p), "zero");
    std::fs::write(d.join("tiny.vol"), b"abc").unwrap();
    fails(tool("vol-info").arg(d.join("tiny.vol")), "truncated");

    // .raw: wrong length for the name, unparseable name, overflow via flags.
    let p = gen(d, "r_20x20x20_uint8.raw", &args);
    truncate(&p, 1);
    fails(tool("vol-info").arg(&p), "file has");
    std::fs::write(d.join("plain.raw"), [0u8; 10]).unwrap();
    fails(
        tool("vol-info").arg(d.join("plain.raw")),
        "raw input needs dims",
    );
    fails(
        tool("vol-info")
            .args([
                "--raw-dims",
                "16777216,16777216,16777216",
                "--raw-type",
                "f32",
            ])
            .arg(d.join("plain.raw")),
        "overflow",
    );
    fails(
        tool("vol-info").arg(d.join("does-not-exist.vvol")),
        "does-not-exist.vvol",
    );
}

#[test]
fn thesis_files_written_by_vol_gen_read_back_equal_to_native() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "shapes", "--dims", "45,33,29", "--count", "8", "--size", "12", "--seed", "4",
    ];
    let native = gen(dir.path(), "n.vvol", &args);
    let want = json(&ok(tool("vol-info").arg("--json").arg(&native)));
    for layout in ["sliced", "bricked:16", "bricked:5"] {
        let extra: Vec<&str> = args.iter().copied().chain(["--layout", layout]).collect();
        let p = gen(
            dir.path(),
            &format!("t-{}.vol", layout.replace(':', "")),
            &extra,
        );
        let got = json(&ok(tool("vol-info").arg("--json").arg("--verify").arg(&p)));
        assert_eq!(got["dims"], want["dims"]);
        assert_eq!(
            (got["min"].clone(), got["max"].clone()),
            (want["min"].clone(), want["max"].clone())
        );
    }
}

#[test]
fn raw_and_unknown_output_names_are_usage_errors_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = ["solid", "--dims", "8,8,8"];
    for (name, needle) in [
        ("x.raw", "NAME_8x8x8_uint8.raw"),
        ("x_8x8x9_uint8.raw", "other dims or type"),
        ("x.jpg", "unknown output type"),
    ] {
        let mut c = tool("vol-gen");
        c.args(base).arg("-o").arg(d.join(name));
        fails(&mut c, needle);
        assert_eq!(c.status().unwrap().code(), Some(2), "{name}");
        assert!(!d.join(name).exists());
    }
    ok(tool("vol-gen")
        .args(base)
        .arg("-o")
        .arg(d.join("x_8x8x8_uint8.raw")));
    // Completions and man pages come from the clap definitions.
    let bash = ok(tool("vol-gen").args(["--completions", "bash"]));
    assert!(bash.contains("vol-gen") && bash.contains("--dims"));
    let man = ok(tool("vol-convert").arg("--man"));
    assert!(man.contains(".TH") && man.contains("raw\\-endian"), "{man}");
}

/// The CT-like phantom: Hounsfield units in i16 by default, air to bone,
/// refused in types that cannot hold them, and seen by the `ct` preset.
#[test]
fn phantom_is_a_ct_in_hounsfield_units() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("head.vvol");
    let v = json(&ok(tool("vol-gen")
        .args(["phantom", "--dims", "48,48,48", "--json", "-o"])
        .arg(&out)));
    assert_eq!(v["type"], "i16", "{v}");
    let (lo, hi) = (v["min"].as_f64().unwrap(), v["max"].as_f64().unwrap());
    assert!((-1030.0..=-970.0).contains(&lo), "{v}");
    assert!((1050.0..=1330.0).contains(&hi), "{v}");
    for t in ["u8", "u16"] {
        let bad = dir.path().join(format!("{t}.vvol"));
        fails(
            tool("vol-gen")
                .args(["phantom", "--dims", "8,8,8", "--type", t, "-o"])
                .arg(&bad),
            "Hounsfield",
        );
        assert!(!bad.exists());
    }
    // The ct preset shows the skull: most of the centre of the image is
    // lit, the corners stay background.
    let hdr = dir.path().join("head.pfm");
    ok(tool("vol-render")
        .arg(&out)
        .args(["--tf", "ct", "--size", "32x32", "--quiet", "-o"])
        .arg(dir.path().join("head.png"))
        .arg("--hdr")
        .arg(&hdr));
    let img = volcompare::pfm::read_pfm(&hdr).unwrap();
    let lit = |x: usize, y: usize| {
        img.samples[(y * 32 + x) * 3..][..3]
            .iter()
            .any(|&c| c > 0.1)
    };
    assert!(lit(16, 16));
    assert!(!lit(0, 0));
}
