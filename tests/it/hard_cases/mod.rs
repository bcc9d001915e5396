//! The named hard cases: extreme but valid settings and corrupted files, as
//! a hostile user would try them. One test per case; each checks a closed
//! form, an invariant, or a specific clean error (non-zero exit, one line
//! `tool: file: problem`, no panic, no abort, no hang, no raw control bytes,
//! nothing half-written left behind). The README's "Hard cases" section
//! lists them.
//!
//! One module per topic; a case that began as a bug says so in a `Bug:`
//! line naming the fix (the commit). This module holds only the helpers
//! the topics share: each takes them, and the imports below, with
//! `use super::*`.

mod degenerate;
mod disk;
mod escaping;
mod extremes;
mod faults;
mod formats;
mod pipes;
mod psnr;
mod ranges;
mod render;

use crate::common::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin(name: &str) -> Command {
    let path = match name {
        "vol-convert" => env!("CARGO_BIN_EXE_vol-convert"),
        other => return tool(other),
    };
    let mut c = Command::new(path);
    c.stdin(Stdio::null());
    c
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// vol-gen into `dir/name`.
fn gen(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let p = dir.join(name);
    ok(bin("vol-gen").args(args).arg("-q").arg("-o").arg(&p));
    p
}

/// A raw f32 volume named so the tools read its shape from the name.
fn raw_f32(dir: &Path, stem: &str, dims: [u64; 3], v: &[f32]) -> PathBuf {
    assert_eq!(v.len() as u64, dims.iter().product::<u64>());
    let p = dir.join(format!(
        "{stem}_{}x{}x{}_f32.raw",
        dims[0], dims[1], dims[2]
    ));
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A raw volume of 16-bit samples (`t` is u16 or i16).
fn raw_16(dir: &Path, stem: &str, t: &str, v: &[i32]) -> PathBuf {
    let p = dir.join(format!("{stem}_{}x1x1_{t}.raw", v.len()));
    let bytes: Vec<u8> = v
        .iter()
        .flat_map(|&x| {
            if t == "u16" {
                (x as u16).to_le_bytes()
            } else {
                (x as i16).to_le_bytes()
            }
        })
        .collect();
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A JSON number equal to `want` up to the last bit that JSON parsing
/// may round.
fn close(v: &serde_json::Value, want: f64) -> bool {
    v.as_f64()
        .is_some_and(|x| x == want || ((x - want) / want).abs() < 1e-15)
}

fn code(out: &Output) -> i32 {
    out.status
        .code()
        .unwrap_or_else(|| panic!("killed by a signal: {out:?}"))
}

/// Run with a deadline: a hang fails the test instead of blocking it.
fn run_within(cmd: &mut Command, limit: Duration) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("{cmd:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// No raw control byte (ESC, NUL, CSI, BEL...) reached stderr.
fn no_control_bytes(err: &[u8]) {
    let s = String::from_utf8_lossy(err);
    let bad: Vec<char> = s
        .trim_end_matches('\n')
        .chars()
        .filter(|c| c.is_control())
        .collect();
    assert!(bad.is_empty(), "raw control characters {bad:?} in: {s}");
}

fn nrrd(dir: &Path, name: &str, header: &str, data: &[u8]) -> PathBuf {
    let p = dir.join(name);
    let mut f = std::fs::File::create(&p).unwrap();
    f.write_all(header.as_bytes()).unwrap();
    f.write_all(data).unwrap();
    p
}

/// The C library calls that the memory and file size limits (`formats`,
/// `disk`) make between fork and exec.
mod libc_calls {
    extern "C" {
        /// `setrlimit(2)`: `rlim` is `[soft, hard]`.
        pub fn setrlimit(resource: i32, rlim: *const [u64; 2]) -> i32;
        /// `signal(2)`, with the handler as an address (`SIG_IGN` is 1).
        pub fn signal(sig: i32, handler: usize) -> usize;
    }
}
