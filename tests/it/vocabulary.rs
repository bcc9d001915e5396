//! One vocabulary: every tool that opens a volume takes the same input
//! selection (`--raw-*`, `--series`, `--channel`, `--time-point`), and an
//! error names only flags its tool has. Each input below makes a reader
//! ask for a flag; through every tool, every `--flag` the message names
//! must be in that tool's `--help`.

use crate::common::{ok, run, tool};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

const TOOLS: [&str; 5] = [
    "vol-info",
    "vol-convert",
    "vol-index",
    "vol-render",
    "vol-psnr",
];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The `--flag` words of a text.
fn flags(text: &str) -> BTreeSet<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(String::from)
        .collect()
}

/// Run `name` on `input` with `extra` flags (and what the tool needs
/// besides: an output, a second volume); its exit code and stderr.
fn attempt(name: &str, input: &Path, extra: &[&str], out: &Path) -> (Option<i32>, String) {
    let mut c = tool(name);
    c.arg(input).args(extra);
    match name {
        "vol-convert" => {
            c.arg("-o").arg(out.join("o.vvol"));
        }
        "vol-render" => {
            c.arg("-o").arg(out.join("o.png"));
        }
        "vol-index" => {
            c.arg("-o").arg(out.join("o.vidx"));
        }
        "vol-psnr" => {
            c.arg(input);
        }
        _ => {}
    }
    let o = run(&mut c);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn every_flag_an_error_names_is_a_flag_of_the_tool() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // A raw file that does not say its dims; a hyperstack with C and T; a
    // folder with two DICOM series.
    let raw = d.join("plain.raw");
    std::fs::write(&raw, vec![0u8; 1000]).unwrap();
    let two = d.join("two-series");
    std::fs::create_dir(&two).unwrap();
    for (dir, prefix) in [("dicom_ct", "ct"), ("dicom_mr", "mr")] {
        for e in std::fs::read_dir(fixture(dir)).unwrap() {
            let e = e.unwrap();
            let name = format!("{prefix}-{}", e.file_name().to_string_lossy());
            std::fs::copy(e.path(), two.join(name)).unwrap();
        }
    }
    let hyperstack = fixture("tifffile_hyperstack.tif");
    let cases: [(&Path, &[&str], &[&str]); 4] = [
        (&raw, &[], &["--raw-dims"]),
        (&hyperstack, &[], &["--channel", "--time-point"]),
        (&two, &[], &["--series"]),
        // The old spelling: refused (exit 2) naming what replaced it.
        (&raw, &["--time", "1"], &["--time-point", "--seconds"]),
    ];
    for name in TOOLS {
        let help = String::from_utf8_lossy(&run(tool(name).arg("--help")).stdout).into_owned();
        let has = flags(&help);
        for (input, extra, asked) in cases {
            if name == "vol-info" && input == two {
                // vol-info lists the series of a folder instead.
                continue;
            }
            if name == "vol-info" && input == hyperstack {
                // vol-info describes one stack, naming the flags that
                // pick another.
                let named = flags(&ok(tool(name).arg(input)));
                for a in asked {
                    assert!(named.contains(*a), "{name}: does not name {a}");
                }
                assert!(named.is_subset(&has), "{name}: names {named:?}");
                continue;
            }
            let (code, err) = attempt(name, input, extra, d);
            assert!(code.is_some_and(|c| c != 0), "{name} {input:?}: {err}");
            assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
            let named = flags(&err);
            for a in asked {
                assert!(
                    named.contains(*a),
                    "{name} {input:?}: {err} does not ask for {a}"
                );
            }
            for f in &named {
                // The refused --time itself, and vol-render's --seconds,
                // which the refusal names as vol-render's.
                if f == "--time" || (f == "--seconds" && name != "vol-render") {
                    continue;
                }
                assert!(
                    has.contains(f),
                    "{name}: {err} names {f}, not in its --help"
                );
            }
            if extra.contains(&"--time") {
                assert_eq!(code, Some(2), "{name}: {err}");
            }
        }
        // The selection itself is in every tool's help.
        for f in [
            "--raw-dims",
            "--raw-type",
            "--series",
            "--channel",
            "--time-point",
        ] {
            assert!(has.contains(f), "{name} --help lacks {f}");
        }
    }
}

#[test]
fn scene_files_use_the_new_names_and_refuse_time() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let v = d.join("s.vvol");
    crate::common::ok(
        tool("vol-gen")
            .args(["sphere", "--dims", "16,16,16", "-q", "-o"])
            .arg(&v),
    );
    let scene = d.join("old.toml");
    std::fs::write(&scene, "mode = \"path\"\ntime = 1\n").unwrap();
    let o = run(tool("vol-render")
        .arg(&v)
        .arg("--scene")
        .arg(&scene)
        .arg("-o")
        .arg(d.join("o.png")));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("`seconds`") && err.contains("--time-point"),
        "{err}"
    );
    // `seconds` and `time-point` are keys; --print-scene writes them back.
    std::fs::write(&scene, "mode = \"path\"\nseconds = 0.01\ntime-point = 0\n").unwrap();
    let o = run(tool("vol-render")
        .arg(&v)
        .arg("--scene")
        .arg(&scene)
        .arg("--print-scene"));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("seconds = 0.01"), "{text}");
    assert!(text.contains("time-point = 0"), "{text}");
}
