//! Helpers shared by the end-to-end tests: run the built tools and check
//! how they fail.

#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output, Stdio};

/// A command for one of the workspace's binaries.
pub fn tool(name: &str) -> Command {
    let path = match name {
        "vol-gen" => env!("CARGO_BIN_EXE_vol-gen"),
        "vol-info" => env!("CARGO_BIN_EXE_vol-info"),
        "vol-psnr" => env!("CARGO_BIN_EXE_vol-psnr"),
        "vol-index" => env!("CARGO_BIN_EXE_vol-index"),
        "vol-render" => env!("CARGO_BIN_EXE_vol-render"),
        "vol-accuracy" => env!("CARGO_BIN_EXE_vol-accuracy"),
        "vol-convert" => env!("CARGO_BIN_EXE_vol-convert"),
        other => panic!("unknown tool {other}"),
    };
    let mut c = Command::new(path);
    c.stdin(Stdio::null());
    c
}

/// Run and return the output, without judging it.
pub fn run(cmd: &mut Command) -> Output {
    cmd.output().expect("the tool could not be started")
}

/// Run and insist on success; returns stdout.
pub fn ok(cmd: &mut Command) -> String {
    let out = run(cmd);
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Run and insist on a clean failure: non-zero exit, exactly one line on
/// stderr that starts with the tool's name and mentions `needle`, and no
/// panic. Returns that line.
pub fn fails(cmd: &mut Command, needle: &str) -> String {
    let out = run(cmd);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{cmd:?} succeeded but should fail");
    assert!(!err.contains("panicked"), "{cmd:?} panicked: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "{cmd:?} printed {} lines: {err}",
        lines.len()
    );
    assert!(lines[0].starts_with("vol-"), "no tool prefix: {err}");
    assert!(
        lines[0].to_lowercase().contains(&needle.to_lowercase()),
        "{cmd:?}: expected '{needle}' in: {err}"
    );
    lines[0].to_string()
}

/// Files in `dir` whose names contain `part`, e.g. left-over temporaries.
pub fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(".partial"))
                .collect()
        })
        .unwrap_or_default()
}

/// Parse the single JSON object a tool printed.
pub fn json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.trim()).expect("tool did not print one JSON object")
}

/// Run a Python script that prints one JSON object, or `SKIP reason` when
/// a module it needs is missing; `None` (with a note naming `install`)
/// when python3 or a module is missing outside CI. CI has both (.ci/run
/// installs them), so there a skip fails the test.
pub fn python_json(script: &str, install: &str) -> Option<serde_json::Value> {
    let out = match Command::new("python3").arg("-c").arg(script).output() {
        Ok(o) => o,
        Err(_) => {
            assert!(std::env::var("CI").is_err(), "CI must have python3");
            eprintln!("SKIP: python3 is not installed");
            return None;
        }
    };
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    if text.starts_with("SKIP") {
        assert!(
            std::env::var("CI").is_err(),
            "CI must have the Python modules: {text}"
        );
        eprintln!("{} ({install})", text.trim());
        return None;
    }
    Some(json(&text))
}
