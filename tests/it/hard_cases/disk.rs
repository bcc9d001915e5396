//! Disk space: an output larger than the free space is refused before
//! anything is written; a disk that fills up mid-write is reported and the
//! partial file removed.

use super::*;

/// Bug: `vol-gen --dims 16777216,16777216,1` started writing 281 TB (fixed in c80723a).
#[test]
fn gen_refuses_an_output_larger_than_the_disk() {
    let d = tmp();
    let start = Instant::now();
    let line = fails(
        bin("vol-gen")
            .args(["solid", "--dims", "16777216,16777216,1", "-o"])
            .arg(d.path().join("huge.vvol")),
        "free",
    );
    // 2^48 samples plus the header and trailer.
    assert!(line.contains("needs 2814749767109"), "{line}");
    assert!(start.elapsed() < Duration::from_secs(10));
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
}

#[test]
fn convert_refuses_an_output_larger_than_the_disk() {
    let d = tmp();
    // A gzip NRRD claims 2^48 samples: the output cannot fit anywhere.
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&[0u8; 64]).unwrap();
    let p = nrrd(
        d.path(),
        "big.nrrd",
        "NRRD0004\ntype: uchar\nsizes: 16777216 16777216 1\nencoding: gzip\n\n",
        &gz.finish().unwrap(),
    );
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.raw")),
        "free",
    );
    assert!(!d.path().join("o.raw").exists());
}

#[test]
fn gen_disk_full_on_a_stream_is_reported() {
    let out = run(bin("vol-gen")
        .args(["noise", "--dims", "32,32,32", "-o", "-"])
        .stdout(
            std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/full")
                .unwrap(),
        ));
    assert_eq!(code(&out), 1);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("No space left"), "{err}");
    assert_eq!(err.lines().count(), 1);
}

/// Run `tool args... -o SMALL/x.vvol` with SMALL a 256 KiB file system of
/// its own (tmpfs in a private mount namespace); where mounts are not
/// allowed, a 1 MiB file size limit (EFBIG, SIGXFSZ ignored) stands in for
/// the full disk. Returns the status and stderr, and checks that nothing
/// is left on the small file system.
fn on_a_full_disk(dir: &Path, tool_path: &str, args: &[&str]) -> (i32, String) {
    let mnt = dir.join("small");
    std::fs::create_dir(&mnt).unwrap();
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    let script = format!(
        "mount -t tmpfs -o size=256k none '{m}' || exit 99; '{t}' {a} -q -o '{m}/x.vvol'; s=$?; ls -A '{m}' >&2; exit $s",
        m = mnt.display(),
        t = tool_path,
        a = quoted.join(" "),
    );
    let out = run(Command::new("unshare").args(["-m", "sh", "-c", &script]));
    if out.status.code().is_some_and(|c| c != 99) {
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        // ls printed nothing: the partial file is gone.
        assert_eq!(err.lines().count(), 1, "{err}");
        return (code(&out), err);
    }
    use libc_calls::{setrlimit, signal};
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(tool_path);
    cmd.args(args).arg("-q").arg("-o").arg(mnt.join("x.vvol"));
    // SAFETY: only async-signal-safe calls between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            const RLIMIT_FSIZE: i32 = 1;
            const SIGXFSZ: i32 = 25;
            const SIG_IGN: usize = 1;
            signal(SIGXFSZ, SIG_IGN);
            setrlimit(RLIMIT_FSIZE, &[1 << 20, 1 << 20]);
            Ok(())
        });
    }
    let out = run(&mut cmd);
    assert_eq!(std::fs::read_dir(&mnt).unwrap().count(), 0);
    (
        code(&out),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn gen_disk_full_mid_write_removes_the_partial_file() {
    let d = tmp();
    // Compressed bricks: the size is not known before writing.
    let (status, err) = on_a_full_disk(
        d.path(),
        env!("CARGO_BIN_EXE_vol-gen"),
        &[
            "noise",
            "--dims",
            "128,128,128",
            "--layout",
            "bricked:32",
            "--compress",
            "zstd",
        ],
    );
    assert_eq!(status, 1, "{err}");
    assert!(
        err.contains("out of space: the partial output was removed"),
        "{err}"
    );
    assert!(err.contains("x.vvol"), "{err}");
}

#[test]
fn convert_disk_full_mid_write_removes_the_partial_file() {
    let d = tmp();
    let v = gen(d.path(), "n.vvol", &["noise", "--dims", "128,128,128"]);
    let (status, err) = on_a_full_disk(
        d.path(),
        env!("CARGO_BIN_EXE_vol-convert"),
        &[
            v.to_str().unwrap(),
            "--layout",
            "bricked:32",
            "--compress",
            "zstd",
        ],
    );
    assert_eq!(status, 1, "{err}");
    assert!(
        err.contains("out of space: the partial output was removed"),
        "{err}"
    );
}
