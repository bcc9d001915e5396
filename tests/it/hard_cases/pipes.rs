//! Broken pipes: a tool whose reader has gone (a closed stdout, or
//! stderr) ends quietly: status 141 or 0, nothing on stderr, no panic.

use super::*;

/// Standard output whose reader is already gone: every write fails with
/// EPIPE.
fn closed_stdout() -> Stdio {
    let (r, w) = std::io::pipe().unwrap();
    drop(r);
    Stdio::from(w)
}

/// The tool ends quietly when its reader has gone: status 141 (or 0 when
/// it had nothing left to write), nothing on stderr, no panic.
fn quiet_pipe_end(cmd: &mut Command) {
    let out = cmd.stdout(closed_stdout()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.is_empty(), "{cmd:?} wrote to stderr: {err}");
    let c = code(&out);
    assert!(c == 141 || c == 0, "{cmd:?}: status {c}");
}

/// Bug: `vol-info x | head -1` panicked in println! (fixed in bffd864).
#[test]
fn broken_pipe_vol_info_ends_quietly() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["solid", "--dims", "4,4,4"]);
    quiet_pipe_end(bin("vol-info").arg(&v));
    quiet_pipe_end(bin("vol-info").arg(&v).arg("--json"));
    let out = run(bin("vol-info").arg(&v).stdout(closed_stdout()));
    assert_eq!(code(&out), 141);
}

#[test]
fn broken_pipe_vol_index_ends_quietly() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["noise", "--dims", "8,8,8"]);
    quiet_pipe_end(bin("vol-index").arg(&v).arg("--stats"));
    quiet_pipe_end(bin("vol-index").arg(&v).arg("--json"));
    let ix = d.path().join("a.vvol.vidx");
    quiet_pipe_end(bin("vol-index").arg("--check").arg(&ix).arg(&v));
    // The index itself was written completely before the report.
    ok(bin("vol-index").arg("--check").arg(&ix).arg(&v));
}

#[test]
fn broken_pipe_vol_psnr_ends_quietly() {
    let d = tmp();
    let a = gen(
        d.path(),
        "a.vvol",
        &["noise", "--dims", "6,6,6", "--seed", "1"],
    );
    let b = gen(
        d.path(),
        "b.vvol",
        &["noise", "--dims", "6,6,6", "--seed", "2"],
    );
    quiet_pipe_end(bin("vol-psnr").arg(&a).arg(&b));
    quiet_pipe_end(bin("vol-psnr").arg(&a).arg(&b).arg("--json"));
    let out = run(bin("vol-psnr").arg(&a).arg(&b).stdout(closed_stdout()));
    assert_eq!(code(&out), 141);
}

#[test]
fn broken_pipe_vol_gen_stream_ends_quietly() {
    let d = tmp();
    let out = run(bin("vol-gen")
        .args(["noise", "--dims", "64,64,64", "-o", "-"])
        .current_dir(d.path())
        .stdout(closed_stdout()));
    assert_eq!(code(&out), 141, "{out:?}");
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    quiet_pipe_end(
        bin("vol-gen")
            .args(["solid", "--dims", "4,4,4", "--json", "-o"])
            .arg(d.path().join("s.vvol")),
    );
    assert!(leftovers(d.path()).is_empty());
}

#[test]
fn broken_pipe_vol_convert_ends_quietly() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["noise", "--dims", "32,32,32"]);
    let out = run(bin("vol-convert")
        .arg(&v)
        .args(["-o", "-"])
        .stdout(closed_stdout()));
    assert_eq!(code(&out), 141, "{out:?}");
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    quiet_pipe_end(
        bin("vol-convert")
            .arg(&v)
            .arg("--json")
            .arg("-o")
            .arg(d.path().join("b.vvol")),
    );
    // Flipping z spools the stream to a temporary file: gone afterwards.
    let out = run(bin("vol-convert")
        .arg("-")
        .args(["--flip", "z", "-o", "-"])
        .current_dir(d.path())
        .stdin(std::fs::File::open(&v).unwrap())
        .stdout(closed_stdout()));
    assert_eq!(code(&out), 141, "{out:?}");
    let left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("spool"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn broken_pipe_help_and_version_do_not_panic() {
    for t in [
        "vol-gen",
        "vol-info",
        "vol-index",
        "vol-psnr",
        "vol-convert",
    ] {
        for flag in ["--help", "--version"] {
            let out = run(bin(t).arg(flag).stdout(closed_stdout()));
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!err.contains("panicked"), "{t} {flag}: {err}");
            assert!(matches!(code(&out), 0 | 141), "{t} {flag}: {out:?}");
        }
    }
}

/// Bug: vol-render printed with println!, which panics on a closed stdout (issue 14, 2aca2eb).
#[test]
fn broken_pipe_vol_render_json_ends_quietly() {
    let d = tmp();
    let v = gen(d.path(), "s.vvol", &["solid", "--dims", "8,8,8"]);
    quiet_pipe_end(
        bin("vol-render")
            .arg(&v)
            .arg("-o")
            .arg(d.path().join("a.png"))
            .args(["--size", "8x8", "--json"]),
    );
}

/// Bug: vol-accuracy wrote with eprintln!, which panics on a closed stderr (issue 14, 2aca2eb).
#[test]
fn vol_accuracy_with_a_closed_stderr_does_not_panic() {
    let d = tmp();
    let out = bin("vol-accuracy")
        .args(["--bin-dir", "/nonexistent-volkit", "--quick", "--out"])
        .arg(d.path())
        .stdout(closed_stdout())
        .stderr(closed_stdout())
        .output()
        .unwrap();
    assert_eq!(code(&out), 1, "{out:?}");
}
