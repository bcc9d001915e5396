//! The named hard cases: extreme but valid settings and corrupted files, as
//! a hostile user would try them. One test per case; each checks a closed
//! form, an invariant, or a specific clean error (non-zero exit, one line
//! `tool: file: problem`, no panic, no abort, no hang, no raw control bytes,
//! nothing half-written left behind). The README's "Hard cases" section
//! lists them.

use crate::common::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

// ------------------------------------------------------------ helpers --

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

fn pfm(dir: &Path, name: &str, w: u32, h: u32, v: &[f32]) -> PathBuf {
    let p = dir.join(name);
    volcompare::pfm::write_pfm_channels(&p, w, h, 1, v).unwrap();
    p
}

fn read_f32(p: &Path) -> Vec<f32> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
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

/// Every slice of `path` through the converter's reader, in-process:
/// errors are fine, panics and aborts are not.
fn read_all(path: &Path) -> Result<(), String> {
    use volformats::open::{open_input, ReadOptions};
    let r = open_input(path, &ReadOptions::default()).map_err(|e| e.to_string())?;
    let d = r.info().dims;
    for z in 0..d.z {
        r.read_slice(z).map_err(|e| e.to_string())?;
    }
    r.finish().map_err(|e| e.to_string())
}

// ------------------------------------------------- vol-psnr and non-finite --

#[test]
fn psnr_min_inf_fails_an_image_with_one_nan_pixel() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 3, 2, &[0.5; 6]);
    let mut v = [0.5f32; 6];
    v[4] = f32::NAN;
    let b = pfm(d.path(), "b.pfm", 3, 2, &v);
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "inf"]));
    assert_eq!(code(&out), 4, "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("not finite 1"));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not finite"));
}

#[test]
fn psnr_infinite_pixel_fails_min_psnr_40() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 2, 2, &[0.25; 4]);
    let b = pfm(d.path(), "b.pfm", 2, 2, &[0.25, f32::INFINITY, 0.25, 0.25]);
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "40"]));
    assert_eq!(code(&out), 4, "{out:?}");
    // Even the lowest gate fails.
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr=-inf"]));
    assert_eq!(code(&out), 4, "{out:?}");
}

#[test]
fn psnr_json_counts_nonfinite_differences() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 4, 1, &[0.0, 1.0, f32::NAN, 0.5]);
    let b = pfm(
        d.path(),
        "b.pfm",
        4,
        1,
        &[f32::NAN, f32::NEG_INFINITY, f32::NAN, 0.5],
    );
    let out = run(bin("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--min-psnr", "0"]));
    assert_eq!(code(&out), 4);
    let j = json(&String::from_utf8_lossy(&out.stdout));
    // NaN equals NaN; NaN against 0 and -inf against 1 are not finite.
    assert_eq!(j["nonfinite"], 2);
    assert_eq!(j["differing"], 2);
    assert_eq!(j["passed"], false);
}

#[test]
fn psnr_nan_in_both_inputs_is_identical() {
    let d = tmp();
    let v = [f32::NAN, 1.0, f32::INFINITY, -0.0];
    let a = pfm(d.path(), "a.pfm", 2, 2, &v);
    let b = pfm(d.path(), "b.pfm", 2, 2, &v);
    let s = ok(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "inf"]));
    assert!(s.contains("PSNR inf (identical)"), "{s}");
}

#[test]
fn psnr_f32_volumes_with_nan_and_inf_fail_the_gate() {
    let d = tmp();
    let a = raw_f32(d.path(), "a", [4, 1, 1], &[1.0, 2.0, 3.0, 4.0]);
    let b = raw_f32(
        d.path(),
        "b",
        [4, 1, 1],
        &[1.0, f32::NAN, 3.0, f32::INFINITY],
    );
    let out = run(bin("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--min-psnr", "10"]));
    assert_eq!(code(&out), 4);
    let j = json(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(j["nonfinite"], 2);
    assert_eq!(j["mse"], 0.0);
}

#[test]
fn psnr_flt_max_extremes_stay_finite_in_f64() {
    let d = tmp();
    let m = f32::MAX;
    let a = raw_f32(d.path(), "a", [2, 1, 1], &[m, -m]);
    let b = raw_f32(d.path(), "b", [2, 1, 1], &[-m, m]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(j["nonfinite"], 0);
    assert!(close(&j["max_abs"], 2.0 * m as f64), "{j}");
    // Closed form: every |d| is 2·FLT_MAX = the peak, so PSNR = 0 dB.
    assert_eq!(j["psnr"], 0.0);
}

#[test]
fn psnr_denormals_differ_and_are_measured() {
    let d = tmp();
    let tiny = f32::from_bits(1); // the smallest denormal
    let a = raw_f32(d.path(), "a", [2, 1, 1], &[tiny, 1.0]);
    let b = raw_f32(d.path(), "b", [2, 1, 1], &[0.0, 1.0]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(j["differing"], 1);
    assert_eq!(j["max_abs"], tiny as f64);
    assert_eq!(j["nonfinite"], 0);
}

#[test]
fn psnr_i16_extremes_give_zero_db() {
    let d = tmp();
    let a = raw_16(d.path(), "a", "i16", &[-32768, -32768]);
    let b = raw_16(d.path(), "b", "i16", &[32767, 32767]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    // |d| = 65535 = the i16 type range, the peak.
    assert_eq!(j["max_abs"], 65535.0);
    assert_eq!(j["peak"], 65535.0);
    assert_eq!(j["psnr"], 0.0);
}

// ---------------------------------------------- corrupted .vvol and .vol --

#[test]
fn vvol_truncated_at_every_length_fails_cleanly() {
    let d = tmp();
    let full = std::fs::read(gen(
        d.path(),
        "a.vvol",
        &[
            "noise",
            "--dims",
            "5,4,3",
            "--layout",
            "bricked:2",
            "--type",
            "u16",
        ],
    ))
    .unwrap();
    let p = d.path().join("cut.vvol");
    for len in (0..full.len()).step_by(7).chain([full.len() - 1]) {
        std::fs::write(&p, &full[..len]).unwrap();
        let line = fails(bin("vol-info").arg("--verify").arg(&p), "cut.vvol");
        assert!(line.starts_with("vol-info: "), "{line}");
    }
}

#[test]
fn vvol_header_bit_flips_never_panic() {
    let d = tmp();
    let full = std::fs::read(gen(
        d.path(),
        "a.vvol",
        &["ramp", "--dims", "4,3,2", "--type", "f32"],
    ))
    .unwrap();
    let p = d.path().join("flip.vvol");
    let mut rejected = 0;
    for bit in 0..128 * 8 {
        let mut b = full.clone();
        b[bit / 8] ^= 1 << (bit % 8);
        std::fs::write(&p, &b).unwrap();
        let opts = volformats::vvol::OpenOptions {
            verify: true,
            ..Default::default()
        };
        match volformats::vvol::open(&p, opts) {
            Ok(v) => {
                let _ = v.to_f32_vec();
            }
            Err(_) => rejected += 1,
        }
    }
    // The header CRC catches every single-bit flip.
    assert_eq!(rejected, 128 * 8);
}

#[test]
fn vvol_brick_table_pointing_outside_is_refused() {
    let d = tmp();
    let p = gen(
        d.path(),
        "b.vvol",
        &[
            "sphere",
            "--dims",
            "6,6,6",
            "--layout",
            "bricked:4",
            "--compress",
            "zstd",
        ],
    );
    let mut b = std::fs::read(&p).unwrap();
    // Entry 0's offset (the table follows the header) far past the end.
    let t = volformats::vvol::HEADER_LEN as usize;
    b[t..t + 8].copy_from_slice(&(u64::MAX - 8).to_le_bytes());
    std::fs::write(&p, &b).unwrap();
    fails(bin("vol-info").arg(&p), "outside the data");
    // Its length instead: a brick that overruns the data section.
    let mut b = std::fs::read(gen(
        d.path(),
        "c.vvol",
        &[
            "sphere",
            "--dims",
            "6,6,6",
            "--layout",
            "bricked:4",
            "--compress",
            "zstd",
        ],
    ))
    .unwrap();
    b[t + 8..t + 16].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&p, &b).unwrap();
    fails(bin("vol-info").arg(&p), "outside the data");
}

/// CRC-32 (IEEE), as the .vvol trailer and brick table use.
fn crc32(b: &[u8]) -> u32 {
    let mut c = flate2::Crc::new();
    c.update(b);
    c.sum()
}

#[test]
fn vvol_compressed_bricks_cannot_share_one_frame() {
    // Every entry of the table points at brick 0's frame, with its CRC:
    // each entry checks out alone, but the file would decode to far more
    // than it holds. Compressed bricks lie back to back, so entry 1 must
    // start where brick 0 ends.
    let d = tmp();
    let p = gen(
        d.path(),
        "shared.vvol",
        &[
            "solid",
            "--dims",
            "16,16,16",
            "--layout",
            "bricked:4",
            "--compress",
            "zstd",
        ],
    );
    let mut b = std::fs::read(&p).unwrap();
    let t = volformats::vvol::HEADER_LEN as usize;
    let n = 64;
    let first = b[t..t + 24].to_vec();
    for i in 1..n {
        b[t + 24 * i..t + 24 * (i + 1)].copy_from_slice(&first);
    }
    // The trailer's table CRC, so --verify judges only the layout.
    let crc = crc32(&b[t..t + 24 * n]);
    let end = b.len() - 32;
    b[end + 8..end + 12].copy_from_slice(&crc.to_le_bytes());
    std::fs::write(&p, &b).unwrap();
    for verify in [false, true] {
        let mut cmd = bin("vol-info");
        if verify {
            cmd.arg("--verify");
        }
        let line = fails(cmd.arg(&p), "shared.vvol");
        assert!(
            line.contains("entry 1") && line.contains("back to back"),
            "{line}"
        );
    }
}

/// A zstd-bricked .vvol header claiming `dims` (brick edge 4, u8) with
/// `data_len` bytes of data, in a sparse file of the length it implies:
/// the brick table reads as zeros and costs no disk.
fn huge_sparse_vvol(p: &Path, dims: [u64; 3], data_len: u64) {
    let dims = volcore::Dims::new(dims[0], dims[1], dims[2]).unwrap();
    let meta = volcore::VolumeMeta {
        layout: volcore::Layout::Bricked(volcore::BrickGeometry::new(dims, 4).unwrap()),
        compression: volcore::Compression::Zstd(3),
        ..volcore::VolumeMeta::sliced(dims, volcore::SampleType::U8)
    };
    let mut h = volformats::vvol::Header::for_meta(meta).unwrap();
    h.data_len = data_len;
    let f = std::fs::File::create(p).unwrap();
    (&f).write_all(&h.encode()).unwrap();
    f.set_len(h.file_len().unwrap()).unwrap();
    // The trailer's magic, at the very end.
    use std::os::unix::fs::FileExt;
    f.write_all_at(b"VVOLEND\0", h.file_len().unwrap() - 32)
        .unwrap();
}

/// The C library calls the limits below make between fork and exec.
mod libc_calls {
    extern "C" {
        /// `setrlimit(2)`: `rlim` is `[soft, hard]`.
        pub fn setrlimit(resource: i32, rlim: *const [u64; 2]) -> i32;
        /// `signal(2)`, with the handler as an address (`SIG_IGN` is 1).
        pub fn signal(sig: i32, handler: usize) -> usize;
    }
}

/// Run with the process's private memory capped at `bytes`
/// (RLIMIT_DATA): an allocation the header asked for, and not the file,
/// shows as an abort instead of as memory taken from the machine.
fn with_memory_cap(cmd: &mut Command, bytes: u64) -> &mut Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: only an async-signal-safe call between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            const RLIMIT_DATA: i32 = 2;
            libc_calls::setrlimit(RLIMIT_DATA, &[bytes, bytes]);
            Ok(())
        });
    }
    cmd
}

#[test]
fn vvol_huge_dims_in_a_small_or_sparse_file_are_refused_quickly() {
    let d = tmp();
    // 2048 x 2048 x 4096 in bricks of 4: 2^28 bricks, a 6 GiB table
    // (sparse: zeros) that a reader must not hold before judging it.
    let dims = [2048, 2048, 4096];
    let cases = [
        // 64 bytes of data cannot hold 2^28 compressed bricks.
        ("few-bytes.vvol", 64, "bytes of compressed data"),
        // Enough data bytes, but the zero table points outside it.
        ("zero-table.vvol", 1 << 29, "outside the data"),
    ];
    for (name, data_len, needle) in cases {
        let p = d.path().join(name);
        huge_sparse_vvol(&p, dims, data_len);
        for verify in [false, true] {
            let mut cmd = bin("vol-info");
            if verify {
                cmd.arg("--verify");
            }
            with_memory_cap(cmd.arg(&p), 512 << 20);
            let start = Instant::now();
            let out = run_within(&mut cmd, Duration::from_secs(60));
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{name} opened: {err}");
            let line = err.trim();
            assert_eq!(line.lines().count(), 1, "{name}: {err}");
            assert!(
                line.starts_with("vol-info: ") && line.contains(name),
                "{err}"
            );
            assert!(line.contains(needle), "{name}: expected '{needle}': {err}");
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "{name} took {:?}",
                start.elapsed()
            );
        }
    }
}

#[test]
fn vvol_damaged_zstd_brick_is_an_error_not_garbage() {
    let d = tmp();
    let p = gen(
        d.path(),
        "z.vvol",
        &[
            "noise",
            "--dims",
            "8,8,8",
            "--layout",
            "bricked:4",
            "--compress",
            "zstd",
        ],
    );
    let mut b = std::fs::read(&p).unwrap();
    let n = b.len();
    // Scribble over the middle of the compressed data.
    for x in &mut b[n / 2..n / 2 + 16] {
        *x = !*x;
    }
    std::fs::write(&p, &b).unwrap();
    fails(bin("vol-info").arg("--verify").arg(&p), "z.vvol");
    fails(bin("vol-psnr").arg(&p).arg(&p), "z.vvol");
}

#[test]
fn thesis_vol_bad_headers_fail_cleanly() {
    let d = tmp();
    let good = std::fs::read(gen(d.path(), "a.vol", &["solid", "--dims", "3,3,3"])).unwrap();
    let p = d.path().join("bad.vol");
    type Edit = Box<dyn Fn(&mut Vec<u8>)>;
    let cases: [(&str, Edit); 5] = [
        (
            "dimensions",
            Box::new(|b| b[0..4].copy_from_slice(&0u32.to_le_bytes())),
        ),
        ("layout", Box::new(|b| b[24] = 9)),
        ("brick side", Box::new(|b| (b[24], b[25]) = (2, 1))),
        (
            "voxel shape",
            Box::new(|b| b[12..16].copy_from_slice(&f32::NAN.to_le_bytes())),
        ),
        ("bytes", Box::new(|b| b.truncate(30))),
    ];
    for (needle, edit) in cases {
        let mut b = good.clone();
        edit(&mut b);
        std::fs::write(&p, &b).unwrap();
        fails(bin("vol-info").arg(&p), needle);
        fails(
            bin("vol-convert")
                .arg(&p)
                .arg("-o")
                .arg(d.path().join("o.vvol")),
            needle,
        );
    }
    assert!(!d.path().join("o.vvol").exists());
}

#[test]
fn raw_length_must_match_its_name() {
    let d = tmp();
    let p = d.path().join("v_4x4x4_u16.raw");
    std::fs::write(&p, vec![0u8; 127]).unwrap();
    fails(bin("vol-info").arg(&p), "128");
    fails(bin("vol-index").arg(&p), "128");
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "128",
    );
}

#[test]
fn raw_dims_whose_product_overflows_are_refused() {
    let d = tmp();
    let p = d.path().join("x.raw");
    std::fs::write(&p, [0u8; 8]).unwrap();
    let huge = "4294967296,4294967296,4294967296";
    fails(
        bin("vol-info").arg(&p).args(["--raw-dims", huge]),
        "dimensions",
    );
    fails(
        bin("vol-convert")
            .arg(&p)
            .args(["--raw-dims", huge, "-o"])
            .arg(d.path().join("o.vvol")),
        "dimensions",
    );
}

// --------------------------------------------------- NRRD and MetaImage --

fn nrrd(dir: &Path, name: &str, header: &str, data: &[u8]) -> PathBuf {
    let p = dir.join(name);
    let mut f = std::fs::File::create(&p).unwrap();
    f.write_all(header.as_bytes()).unwrap();
    f.write_all(data).unwrap();
    p
}

const NRRD_U8: &str = "NRRD0004\ntype: uchar\nsizes: 2 2 2\nencoding: raw\n";

#[test]
fn nrrd_huge_line_skip_on_stdin_ends() {
    let d = tmp();
    let p = nrrd(
        d.path(),
        "skip.nrrd",
        &format!("{NRRD_U8}line skip: 4294967295\n\n"),
        &[1u8; 8],
    );
    let out = run_within(
        bin("vol-convert")
            .arg("-")
            .arg("-o")
            .arg(d.path().join("o.vvol"))
            .stdin(std::fs::File::open(&p).unwrap()),
        Duration::from_secs(20),
    );
    assert_eq!(code(&out), 1);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("lines to skip"), "{err}");
    assert!(!d.path().join("o.vvol").exists());
}

#[test]
fn nrrd_huge_line_skip_by_path_is_refused() {
    let d = tmp();
    let p = nrrd(
        d.path(),
        "skip.nrrd",
        &format!("{NRRD_U8}line skip: 4294967295\n\n"),
        &[1u8; 8],
    );
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "lines to skip",
    );
}

#[test]
fn nrrd_control_bytes_in_a_header_line_are_escaped() {
    let d = tmp();
    let p = nrrd(
        d.path(),
        "esc.nrrd",
        "NRRD0004\ntype: uchar\n\x1b[2J\x1b]0;pwned\x07\0oops\nsizes: 2 2 2\n\n",
        &[0u8; 8],
    );
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("\\x1b[2J"), "{err}");
    assert_eq!(err.lines().count(), 1);
}

#[test]
fn nrrd_binary_header_excerpt_is_cut_short() {
    let d = tmp();
    let junk: Vec<u8> = (0..20_000u32)
        .map(|i| (i * 7919 % 251) as u8)
        .filter(|&b| b != b'\n')
        .collect();
    let mut header = b"NRRD0004\ntype: uchar\n".to_vec();
    header.extend_from_slice(&junk);
    header.extend_from_slice(b"\n\n");
    let p = d.path().join("bin.nrrd");
    std::fs::write(&p, &header).unwrap();
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(
        out.stderr.len() < 600,
        "{} bytes of message",
        out.stderr.len()
    );
}

#[test]
fn nrrd_bad_values_are_named_and_escaped() {
    let d = tmp();
    for (field, needle) in [
        ("type: \x1b[31mdouble\n", "\\x1b[31mdouble"),
        ("sizes: 2 x\x00 2\n", "sizes"),
        ("encoding: \u{9b}bzip2\n", "\\x9bbzip2"),
    ] {
        let p = nrrd(
            d.path(),
            "v.nrrd",
            &format!("NRRD0004\n{field}type: uchar\nsizes: 2 2 2\nencoding: raw\n\n"),
            &[0u8; 8],
        );
        let out = run(bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")));
        assert_eq!(code(&out), 1);
        no_control_bytes(&out.stderr);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{err}");
    }
}

#[test]
fn mhd_control_bytes_are_escaped() {
    let d = tmp();
    let p = d.path().join("e.mha");
    std::fs::write(
        &p,
        b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_\x1b[5mLONG\nElementDataFile = LOCAL\n\0\0",
    )
    .unwrap();
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(String::from_utf8_lossy(&out.stderr).contains("MET_\\x1b[5mLONG"));
}

#[test]
fn mhd_truncated_data_is_reported() {
    let d = tmp();
    let p = d.path().join("t.mha");
    std::fs::write(
        &p,
        b"NDims = 3\nDimSize = 4 4 4\nElementType = MET_USHORT\nElementDataFile = LOCAL\n\0\0\0",
    )
    .unwrap();
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "bytes",
    );
    assert!(leftovers(d.path()).is_empty());
}

#[test]
fn nrrd_corrupt_gzip_data_fails_cleanly() {
    let d = tmp();
    let p = nrrd(
        d.path(),
        "gz.nrrd",
        "NRRD0004\ntype: uchar\nsizes: 4 4 4\nencoding: gzip\n\n",
        b"\x1f\x8b\x08\x00garbage that is not deflate at all",
    );
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "gz.nrrd",
    );
    assert!(!d.path().join("o.vvol").exists());
    assert!(leftovers(d.path()).is_empty());
}

#[test]
fn mhd_header_size_past_the_end_is_refused() {
    let d = tmp();
    let p = d.path().join("h.mha");
    std::fs::write(
        &p,
        b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nHeaderSize = 9223372036854775807\nElementDataFile = LOCAL\n\0\0\0\0\0\0\0\0",
    )
    .unwrap();
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "h.mha",
    );
}

#[test]
fn streams_on_stdin_truncated_or_too_long_fail_cleanly() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["ramp", "--dims", "8,8,8"]);
    let full = std::fs::read(&v).unwrap();
    let cut = d.path().join("cut.vvol");
    std::fs::write(&cut, &full[..full.len() - 40]).unwrap();
    fails(
        bin("vol-info")
            .arg("-")
            .stdin(std::fs::File::open(&cut).unwrap()),
        "truncated",
    );
    fails(
        bin("vol-convert")
            .args(["-", "-o"])
            .arg(d.path().join("o.vvol"))
            .stdin(std::fs::File::open(&cut).unwrap()),
        "truncated",
    );
    // Raw samples: ten bytes short of 4x4x4, then ten bytes too many.
    let short = d.path().join("short.bin");
    std::fs::write(&short, [1u8; 54]).unwrap();
    fails(
        bin("vol-convert")
            .args(["-", "--raw-dims", "4,4,4", "--raw-type", "u8", "-o"])
            .arg(d.path().join("o.vvol"))
            .stdin(std::fs::File::open(&short).unwrap()),
        "truncated",
    );
    let long = d.path().join("long.bin");
    std::fs::write(&long, [1u8; 74]).unwrap();
    fails(
        bin("vol-convert")
            .args(["-", "--raw-dims", "4,4,4", "--raw-type", "u8", "-o"])
            .arg(d.path().join("o.vvol"))
            .stdin(std::fs::File::open(&long).unwrap()),
        "10 bytes more",
    );
    assert!(!d.path().join("o.vvol").exists());
}

// ----------------------------------------------------------------- TIFF --

/// A multipage BigTIFF of `d.z` pages of u16 ramps, deflated or not.
fn bigtiff(p: &Path, d: [u32; 3], deflate: bool) {
    use tiff::encoder::{colortype, Compression, DeflateLevel, TiffEncoder};
    let f = std::fs::File::create(p).unwrap();
    let mut e = TiffEncoder::new_big(f).unwrap();
    if deflate {
        e = e.with_compression(Compression::Deflate(DeflateLevel::Balanced));
    }
    for z in 0..d[2] {
        let page: Vec<u16> = (0..d[0] * d[1]).map(|i| (i * 31 + z * 7) as u16).collect();
        e.write_image::<colortype::Gray16>(d[0], d[1], &page)
            .unwrap();
    }
}

/// Byte offset and entry count of the first directory of a BigTIFF.
fn first_ifd(b: &[u8]) -> (usize, usize) {
    let off = u64::from_le_bytes(b[8..16].try_into().unwrap()) as usize;
    let n = u64::from_le_bytes(b[off..off + 8].try_into().unwrap()) as usize;
    (off, n)
}

#[test]
fn tiff_bit_flips_in_a_bigtiff_directory_never_abort() {
    let d = tmp();
    let src = d.path().join("src.tif");
    bigtiff(&src, [16, 12, 6], false);
    let good = std::fs::read(&src).unwrap();
    let (off, n) = first_ifd(&good);
    let dir_bytes = 8 + n * 20 + 8;
    let p = d.path().join("m.tif");
    let mut rng = fastrand::Rng::with_seed(14);
    let (mut ok_reads, mut errors) = (0, 0);
    for _ in 0..300 {
        let mut b = good.clone();
        let bit = rng.usize(0..dir_bytes * 8);
        b[off + bit / 8] ^= 1 << (bit % 8);
        std::fs::write(&p, &b).unwrap();
        match read_all(&p) {
            Ok(()) => ok_reads += 1,
            Err(e) => {
                assert!(!e.contains('\n'), "{e}");
                errors += 1
            }
        }
    }
    assert_eq!(ok_reads + errors, 300);
    assert!(errors > 0, "no flip was noticed");
}

#[test]
fn tiff_huge_value_count_in_a_later_directory_is_refused() {
    // Before the limits, the decoder read later directories unlimited and
    // a count of 2^58 strip offsets panicked with "capacity overflow".
    let d = tmp();
    let p = d.path().join("count.tif");
    bigtiff(&p, [8, 4, 3], false);
    let mut b = std::fs::read(&p).unwrap();
    let (off, n) = first_ifd(&b);
    let next =
        u64::from_le_bytes(b[off + 8 + n * 20..off + 16 + n * 20].try_into().unwrap()) as usize;
    let n2 = u64::from_le_bytes(b[next..next + 8].try_into().unwrap()) as usize;
    let mut patched = false;
    for i in 0..n2 {
        let e = next + 8 + i * 20;
        if u16::from_le_bytes([b[e], b[e + 1]]) == 273 {
            b[e + 4..e + 12].copy_from_slice(&(1u64 << 58).to_le_bytes());
            patched = true;
        }
    }
    assert!(patched);
    std::fs::write(&p, &b).unwrap();
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "damaged directory",
    );
}

#[test]
fn tiff_page_larger_than_its_file_can_hold_is_refused() {
    let d = tmp();
    let p = d.path().join("wide.tif");
    // Deflated: the decoder cannot compare strip sizes with the width.
    bigtiff(&p, [16, 12, 2], true);
    let mut b = std::fs::read(&p).unwrap();
    let (off, n) = first_ifd(&b);
    for i in 0..n {
        let e = off + 8 + i * 20;
        let tag = u16::from_le_bytes([b[e], b[e + 1]]);
        if tag == 256 {
            // ImageWidth: 2^31 (a LONG): 48 GiB pages in a 1 KiB file.
            b[e + 2..e + 4].copy_from_slice(&4u16.to_le_bytes());
            b[e + 12..e + 20].copy_from_slice(&(1u64 << 31).to_le_bytes());
        }
    }
    std::fs::write(&p, &b).unwrap();
    let line = fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "wide.tif",
    );
    assert!(line.contains("damaged directory"), "{line}");
}

#[test]
fn tiff_truncated_files_fail_cleanly() {
    let d = tmp();
    let src = d.path().join("src.tif");
    bigtiff(&src, [9, 7, 3], true);
    let good = std::fs::read(&src).unwrap();
    let p = d.path().join("cut.tif");
    for len in (0..good.len()).step_by(37) {
        std::fs::write(&p, &good[..len]).unwrap();
        assert!(read_all(&p).is_err(), "cut at {len} read fine");
    }
    std::fs::write(&p, &good[..good.len() / 2]).unwrap();
    fails(
        bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")),
        "cut.tif",
    );
    assert!(!d.path().join("o.vvol").exists());
}

// ------------------------------------------------ .vidx, PFM and PNG --

#[test]
fn vidx_damaged_indexes_are_rejected() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["noise", "--dims", "9,8,7"]);
    ok(bin("vol-index").arg(&v).arg("-q"));
    let ix = d.path().join("a.vvol.vidx");
    let good = std::fs::read(&ix).unwrap();
    for len in [0, 4, 16, good.len() / 2, good.len() - 1] {
        std::fs::write(&ix, &good[..len]).unwrap();
        fails(
            bin("vol-index").arg("--check").arg(&ix).arg(&v),
            "a.vvol.vidx",
        );
    }
    let mut b = good.clone();
    let n = b.len();
    b[n - 20] ^= 0x40;
    std::fs::write(&ix, &b).unwrap();
    fails(
        bin("vol-index").arg("--check").arg(&ix).arg(&v),
        "a.vvol.vidx",
    );
}

#[test]
fn pfm_header_tokens_are_escaped_and_cut() {
    let d = tmp();
    let p = d.path().join("e.pfm");
    let mut b = b"Pf\n\x1b[31m".to_vec();
    b.extend(std::iter::repeat_n(b'9', 5000));
    b.extend_from_slice(b" 1\n-1\n\0\0\0\0");
    std::fs::write(&p, &b).unwrap();
    let out = run(bin("vol-psnr").arg(&p).arg(&p));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(
        out.stderr.len() < 400,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn pfm_truncated_and_oversized_headers_fail_cleanly() {
    let d = tmp();
    let p = d.path().join("t.pfm");
    for bytes in [
        &b"PF\n4 4\n-1\n\0\0\0\0"[..],
        b"Pf\n4294967295 4294967295\n-1\n\0\0\0\0",
        b"Pf\n2 2\n",
        b"",
    ] {
        std::fs::write(&p, bytes).unwrap();
        fails(bin("vol-psnr").arg(&p).arg(&p), "t.pfm");
    }
}

#[test]
fn png_garbage_truncation_and_huge_dims_fail_cleanly() {
    let d = tmp();
    let p = d.path().join("a.png");
    volcompare::write_png8(&p, 8, 8, 1, &[7u8; 64]).unwrap();
    let good = std::fs::read(&p).unwrap();
    let bad = d.path().join("bad.png");
    std::fs::write(&bad, &good[..good.len() - 20]).unwrap();
    fails(bin("vol-psnr").arg(&p).arg(&bad), "bad.png");
    // IHDR claims 1,000,000 x 1,000,000 pixels.
    let mut b = good.clone();
    b[16..20].copy_from_slice(&1_000_000u32.to_be_bytes());
    b[20..24].copy_from_slice(&1_000_000u32.to_be_bytes());
    std::fs::write(&bad, &b).unwrap();
    fails(bin("vol-psnr").arg(&bad).arg(&p), "bad.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\n\x1b[2Jjunk").unwrap();
    let out = run(bin("vol-psnr").arg(&bad).arg(&p));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
}

// -------------------------------------------------------- broken pipes --

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

// ----------------------------------------------------------- disk space --

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

// ------------------------------------------------- documented ranges --

#[test]
fn gen_octaves_outside_1_to_16_are_refused() {
    let d = tmp();
    for o in ["0", "17", "-1"] {
        let out = run(bin("vol-gen")
            .args(["noise", "--dims", "4,4,4", "--octaves", o, "-o"])
            .arg(d.path().join("n.vvol")));
        assert_eq!(code(&out), 2, "--octaves {o}: {out:?}");
        assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    }
    gen(
        d.path(),
        "ok.vvol",
        &["noise", "--dims", "4,4,4", "--octaves", "16"],
    );
}

#[test]
fn gen_value_must_fit_the_sample_type() {
    let d = tmp();
    let o = d.path().join("v.vvol");
    for (t, v) in [
        ("u8", "300"),
        ("u8", "-1"),
        ("u16", "65536"),
        ("i16", "-32769"),
        ("i16", "40000"),
        ("f32", "nan"),
        ("f32", "inf"),
    ] {
        let out = run(bin("vol-gen")
            .args(["solid", "--dims", "4,4,4", "--type", t, "--value", v, "-o"])
            .arg(&o));
        assert_eq!(code(&out), 2, "{t} {v}: {out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--value"), "{err}");
    }
    assert!(!o.exists());
    // The ends of each range are accepted and stored exactly.
    for (t, v, want) in [
        ("u8", "255", 255.0),
        ("i16", "-32768", -32768.0),
        ("u16", "65535", 65535.0),
    ] {
        let p = gen(
            d.path(),
            &format!("{t}.vvol"),
            &["box", "--dims", "4,4,4", "--type", t, "--value", v],
        );
        let j = json(&ok(bin("vol-info").arg(&p).arg("--json")));
        assert!(j["min"] == want || j["max"] == want, "{t}: {j}");
    }
}

#[test]
fn gen_other_documented_ranges_are_enforced() {
    let d = tmp();
    let o = d.path().join("x.vvol");
    for args in [
        &["noise", "--period", "0.5"][..],
        &["noise", "--period", "inf"],
        &["sphere", "--radius", "0"],
        &["sphere", "--radius", "-3"],
        &["sphere", "--radius", "nan"],
        &["shapes", "--count", "100001"],
        &["shapes", "--size", "0"],
        &["shapes", "--size", "4294967296"],
        &["box", "--margin", "2"],
        &["solid", "--layout", "bricked:1"],
        &["solid", "--layout", "bricked:1025"],
        &["solid", "--layout", "bricked:2", "--compress", "zstd:23"],
        &["solid", "--spacing", "1,0,1"],
    ] {
        let out = run(bin("vol-gen")
            .args(args)
            .args(["--dims", "4,4,4", "-o"])
            .arg(&o));
        assert_eq!(code(&out), 2, "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
    assert!(!o.exists());
}

#[test]
fn gen_zero_and_overflowing_dims_are_refused() {
    let d = tmp();
    for dims in ["0,4,4", "4,4", "4294967296,4294967296,4294967296"] {
        let out = run(bin("vol-gen")
            .args(["solid", "--dims", dims, "-o"])
            .arg(d.path().join("x.vvol")));
        assert!(matches!(code(&out), 1 | 2), "{dims}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{dims}"
        );
    }
}

#[test]
fn index_cell_and_bins_ranges_are_enforced() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["solid", "--dims", "4,4,4"]);
    for (flag, val) in [
        ("--cell", "1"),
        ("--cell", "1025"),
        ("--bins", "0"),
        ("--bins", "65537"),
    ] {
        fails(bin("vol-index").arg(&v).args([flag, val]), val);
    }
    assert!(!d.path().join("a.vvol.vidx").exists());
    ok(bin("vol-index")
        .arg(&v)
        .args(["--cell", "1024", "--bins", "65536", "-q"]));
}

#[test]
fn convert_window_and_crop_ranges_are_enforced() {
    let d = tmp();
    let v = gen(
        d.path(),
        "a.vvol",
        &["ramp", "--dims", "4,4,4", "--type", "u16"],
    );
    let o = d.path().join("o.vvol");
    for args in [
        &["--type", "u8", "--window", "5:5"][..],
        &["--type", "u8", "--window", "9:1"],
        &["--type", "u8", "--window", "auto:50"],
        &["--type", "u8", "--window", "nan:3"],
        &["--crop", "0:5,:,:"],
        &["--crop", "3:2,:,:"],
    ] {
        let out = run(bin("vol-convert").arg(&v).args(args).arg("-o").arg(&o));
        assert!(matches!(code(&out), 1 | 2), "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
    assert!(!o.exists());
}

#[test]
fn psnr_range_and_min_psnr_are_validated() {
    let d = tmp();
    let a = gen(d.path(), "a.vvol", &["solid", "--dims", "2,2,2"]);
    for args in [
        ["--range", "0"],
        ["--range", "-1"],
        ["--range", "nan"],
        ["--min-psnr", "nan"],
    ] {
        let out = run(bin("vol-psnr").arg(&a).arg(&a).args(args));
        assert_eq!(code(&out), 2, "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
}

// ------------------------------------------------- degenerate volumes --

/// A volume through every tool: gen, info, index, convert to each format
/// and back, and psnr of the copies against the original (identical).
fn through_every_tool(dims: &str, layouts: &[&str]) {
    let d = tmp();
    for scene in ["shapes", "spheres", "noise", "solid", "ramp", "sphere"] {
        for layout in layouts {
            let name = format!("{scene}-{}.vvol", layout.replace(':', ""));
            let v = gen(
                d.path(),
                &name,
                &[scene, "--dims", dims, "--layout", layout, "--size", "1"],
            );
            let j = json(&ok(bin("vol-info").arg(&v).args(["--json", "--verify"])));
            assert_eq!(j["dims"].to_string().replace(' ', ""), format!("[{dims}]"));
            ok(bin("vol-index").arg(&v).arg("-q"));
            ok(bin("vol-index")
                .arg("--check")
                .arg(d.path().join(format!("{name}.vidx")))
                .arg(&v)
                .arg("-q"));
            for ext in ["vol", "raw", "tif", "vvol"] {
                let dims_u: Vec<&str> = dims.split(',').collect();
                let out = d.path().join(format!(
                    "copy_{}x{}x{}_u8.{ext}",
                    dims_u[0], dims_u[1], dims_u[2]
                ));
                ok(bin("vol-convert").arg(&v).arg("-q").arg("-o").arg(&out));
                let back = d.path().join("back.vvol");
                ok(bin("vol-convert").arg(&out).arg("-q").arg("-o").arg(&back));
                let s = ok(bin("vol-psnr").arg(&v).arg(&back));
                assert!(s.contains("identical"), "{name} via {ext}: {s}");
            }
        }
    }
}

#[test]
fn degenerate_1x1x1_through_every_tool() {
    through_every_tool("1,1,1", &["sliced", "bricked:2"]);
}

#[test]
fn degenerate_1xnxn_through_every_tool() {
    through_every_tool("1,5,5", &["sliced", "bricked:2"]);
}

#[test]
fn degenerate_nx1x1_through_every_tool() {
    through_every_tool("7,1,1", &["sliced", "bricked:4"]);
}

#[test]
fn degenerate_2x2x2_through_every_tool() {
    through_every_tool("2,2,2", &["sliced", "bricked:2"]);
}

// ---------------------------------------------------- sample extremes --

fn f32_extremes() -> Vec<f32> {
    vec![
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        -f32::MAX,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(0x007f_ffff),
        0.0,
        -0.0,
        1.5,
        -2.5,
    ]
}

#[test]
fn f32_extremes_survive_convert_bit_for_bit() {
    let d = tmp();
    let v = f32_extremes();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &v);
    for via in ["a.vvol", "b.vol.tif", "c.tif"] {
        let mid = d.path().join(via);
        ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&mid));
        let back = d
            .path()
            .join(format!("back_{}_4x3x1_f32.raw", via.replace('.', "")));
        ok(bin("vol-convert").arg(&mid).arg("-q").arg("-o").arg(&back));
        let got: Vec<u32> = read_f32(&back).iter().map(|x| x.to_bits()).collect();
        let want: Vec<u32> = v.iter().map(|x| x.to_bits()).collect();
        assert_eq!(got, want, "via {via}");
    }
    // Bricked and compressed copies too.
    let b = d.path().join("b.vvol");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--layout", "bricked:2", "--compress", "zstd", "-q", "-o"])
        .arg(&b));
    let s = ok(bin("vol-psnr").arg(&src).arg(&b));
    assert!(s.contains("identical"), "{s}");
}

#[test]
fn f32_extremes_info_reports_the_range_without_nan() {
    let d = tmp();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &f32_extremes());
    let v = d.path().join("x.vvol");
    ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&v));
    let text = ok(bin("vol-info").arg(&v));
    assert!(text.contains("values -inf .. inf"), "{text}");
    let j = json(&ok(bin("vol-info").arg(&v).arg("--json")));
    // JSON has no infinities: the range is null rather than a lie.
    assert!(j["min"].is_null() && j["max"].is_null(), "{j}");
    let only_nan = raw_f32(d.path(), "n", [2, 1, 1], &[f32::NAN, f32::NAN]);
    let text = ok(bin("vol-info").arg(&only_nan));
    assert!(text.contains("values: none (all NaN)"), "{text}");
}

#[test]
fn f32_extremes_index_counts_nan_and_keeps_range() {
    let d = tmp();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &f32_extremes());
    let j = json(&ok(bin("vol-index")
        .arg(&src)
        .args(["--json", "--cell", "2"])));
    assert_eq!(j["nan_count"], 1);
    let s = ok(bin("vol-index")
        .arg(&src)
        .args(["--stats", "-q", "--cell", "2"]));
    assert!(s.contains("1 NaN"), "{s}");
    // Finite extremes only, without infinities in the data.
    let m = f32::MAX;
    let fin = raw_f32(d.path(), "f", [3, 1, 1], &[-m, 0.0, m]);
    let j = json(&ok(bin("vol-index").arg(&fin).arg("--json")));
    assert!(close(&j["min"], -m as f64), "{j}");
    assert!(close(&j["max"], m as f64), "{j}");
    ok(bin("vol-index")
        .arg("--check")
        .arg(d.path().join("f_3x1x1_f32.raw.vidx"))
        .arg(&fin)
        .arg("-q"));
}

#[test]
fn f32_to_u8_nan_takes_the_bottom_and_extremes_clamp() {
    let d = tmp();
    let src = raw_f32(
        d.path(),
        "x",
        [5, 1, 1],
        &[f32::NAN, f32::NEG_INFINITY, f32::INFINITY, -f32::MAX, 0.5],
    );
    let out = d.path().join("o_5x1x1_u8.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u8", "--window", "0:1", "-q", "-o"])
        .arg(&out));
    assert_eq!(std::fs::read(&out).unwrap(), [0, 0, 255, 0, 128]);
}

#[test]
fn u16_extremes_through_convert_index_and_psnr() {
    let d = tmp();
    let src = raw_16(d.path(), "x", "u16", &[0, 65535, 1, 65534]);
    let out = d.path().join("o_4x1x1_u8.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u8", "--window", "full", "-q", "-o"])
        .arg(&out));
    assert_eq!(std::fs::read(&out).unwrap(), [0, 255, 0, 255]);
    let j = json(&ok(bin("vol-index").arg(&src).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(0.0), Some(65535.0))
    );
    let zero = raw_16(d.path(), "z", "u16", &[65535, 0, 1, 65534]);
    let j = json(&ok(bin("vol-psnr").arg(&src).arg(&zero).arg("--json")));
    // Two errors of 65535 in four: MSE = 65535²/2, PSNR = 10·log10(2).
    assert!(
        (j["psnr"].as_f64().unwrap() - 10.0 * 2f64.log10()).abs() < 1e-12,
        "{j}"
    );
}

#[test]
fn i16_extremes_through_convert_and_index() {
    let d = tmp();
    let src = raw_16(d.path(), "x", "i16", &[-32768, 32767, 0, -1]);
    let out = d.path().join("o_4x1x1_u16.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u16", "--window", "full", "-q", "-o"])
        .arg(&out));
    let got: Vec<u16> = std::fs::read(&out)
        .unwrap()
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got, [0, 65535, 32768, 32767]);
    let j = json(&ok(bin("vol-index").arg(&src).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(-32768.0), Some(32767.0))
    );
    let v = d.path().join("x.vvol");
    ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&v));
    let j = json(&ok(bin("vol-info").arg(&v).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(-32768.0), Some(32767.0))
    );
}

// ------------------------------------------------------ control bytes --

#[test]
fn control_bytes_in_a_file_name_are_escaped() {
    let d = tmp();
    let p = d.path().join("evil\x1b[31m\x07name.vvol");
    std::fs::write(&p, b"not a volume").unwrap();
    for t in ["vol-info", "vol-index"] {
        let out = run(bin(t).arg(&p));
        assert_eq!(code(&out), 1);
        no_control_bytes(&out.stderr);
        assert!(String::from_utf8_lossy(&out.stderr).contains("evil\\x1b[31m\\x07name"));
    }
    let out = run(bin("vol-psnr").arg(&p).arg(&p));
    no_control_bytes(&out.stderr);
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    no_control_bytes(&out.stderr);
}

#[test]
fn control_bytes_in_arguments_are_escaped() {
    let out = run(bin("vol-info").args(["x.raw", "--raw-type", "\x1b]0;title\x07"]));
    assert_eq!(code(&out), 2);
    no_control_bytes(&out.stderr);
    let out = run(bin("vol-gen").args(["solid", "--dims", "\x1b[2J", "-o", "x.vvol"]));
    assert_eq!(code(&out), 2);
    no_control_bytes(&out.stderr);
}

// ------------------------------------------------------- vol-render --

/// vol-render on `vol` writing `dir/name.png`, with `args`.
fn render_cmd(dir: &Path, vol: &Path, name: &str, args: &[&str]) -> Command {
    let mut c = bin("vol-render");
    c.arg(vol)
        .arg("-o")
        .arg(dir.join(format!("{name}.png")))
        .arg("-q")
        .args(args);
    if !args.contains(&"--size") {
        c.args(["--size", "24x24"]);
    }
    c
}

/// Render and return the linear float image (grey: the red channel).
fn render_hdr(dir: &Path, vol: &Path, name: &str, args: &[&str]) -> Vec<f32> {
    let hdr = dir.join(format!("{name}.pfm"));
    ok(render_cmd(dir, vol, name, args).arg("--hdr").arg(&hdr));
    volcompare::pfm::read_pfm(&hdr)
        .unwrap()
        .samples
        .chunks(3)
        .map(|p| p[0])
        .collect()
}

fn png_bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(format!("{name}.png"))).unwrap()
}

#[test]
fn render_spacing_that_implies_endless_rays_is_refused() {
    let d = tmp();
    let v = gen(
        d.path(),
        "thin.vvol",
        &["solid", "--dims", "8,8,8", "--spacing", "1,1.1754944e-38,1"],
    );
    let out = run_within(
        &mut render_cmd(d.path(), &v, "a", &[]),
        Duration::from_secs(30),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("thin.vvol") && err.contains("samples per ray"),
        "{err}"
    );
    // A thesis .vol whose spacing field is damaged (1e-30 on y).
    let good = std::fs::read(gen(d.path(), "a.vol", &["solid", "--dims", "8,8,8"])).unwrap();
    let mut b = good.clone();
    b[16..20].copy_from_slice(&1e-30f32.to_le_bytes());
    let bad = d.path().join("bad.vol");
    std::fs::write(&bad, &b).unwrap();
    let out = run_within(
        &mut render_cmd(d.path(), &bad, "b", &[]),
        Duration::from_secs(30),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.lines().count() == 1, "{err}");
    assert!(
        err.contains("bad.vol") && err.contains("samples per ray"),
        "{err}"
    );
    // An explicit step that implies too many samples per ray.
    fails(
        &mut render_cmd(d.path(), &v, "c", &["--step", "5e-7"]),
        "samples per ray",
    );
}

#[test]
fn render_mip_and_minip_with_infinities_and_flt_max_are_finite() {
    let d = tmp();
    // The front half of the volume at one extreme, the back half at the
    // other; nearest samples (a trilinear blend of -inf and inf is NaN).
    let n = 8 * 8 * 8;
    for (lo, hi) in [
        (f32::NEG_INFINITY, f32::INFINITY),
        (-f32::MAX, f32::MAX),
        (0.0, f32::INFINITY),
    ] {
        let v: Vec<f32> = (0..n).map(|i| if i / 64 < 4 { lo } else { hi }).collect();
        let vol = raw_f32(d.path(), &format!("ext{lo}"), [8, 8, 8], &v);
        for mode in ["mip", "minip"] {
            let img = render_hdr(
                d.path(),
                &vol,
                mode,
                &[
                    "--mode",
                    mode,
                    "--interp",
                    "nearest",
                    "--eye",
                    "3.5,3.5,40",
                    "--look-at",
                    "3.5,3.5,0",
                ],
            );
            assert!(
                img.iter().all(|g| g.is_finite()),
                "{mode} {lo}..{hi}: {img:?}"
            );
            // Every ray through the volume meets both halves: MIP shows
            // white, MinIP black, at the centre.
            let c = img[12 * 24 + 12];
            let want = if mode == "mip" { 1.0 } else { 0.0 };
            assert_eq!(c, want, "{mode} {lo}..{hi}");
        }
    }
}

#[test]
fn render_xray_of_a_1e38_cube_is_not_black() {
    let d = tmp();
    let vol = raw_f32(d.path(), "big", [16, 16, 16], &[1e38; 4096]);
    let img = render_hdr(d.path(), &vol, "x", &["--mode", "xray"]);
    assert!(img.iter().all(|g| g.is_finite()));
    let top = img.iter().cloned().fold(0.0f32, f32::max);
    assert!(top > 0.99, "brightest pixel {top}");
    // The ordinary scale gives the same picture (the sum only scales).
    let small = raw_f32(d.path(), "one", [16, 16, 16], &[1.0; 4096]);
    let one = render_hdr(d.path(), &small, "y", &["--mode", "xray"]);
    for (a, b) in img.iter().zip(&one) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
}

#[test]
fn render_huge_and_tiny_camera_vectors_keep_their_direction() {
    let d = tmp();
    let v = gen(
        d.path(),
        "s.vvol",
        &[
            "shapes", "--dims", "24,24,24", "--count", "6", "--size", "6",
        ],
    );
    let r = |name: &str, args: &[&str]| {
        ok(&mut render_cmd(d.path(), &v, name, args));
        png_bytes(d.path(), name)
    };
    let eye = [
        "--eye",
        "40,30,50",
        "--look-at",
        "12,12,12",
        "--tf",
        "shapes",
    ];
    let up1 = r("up1", &[&eye[..], &["--up=1,1,0"]].concat());
    assert_eq!(r("up30", &[&eye[..], &["--up=1e30,1e30,0"]].concat()), up1);
    assert_eq!(
        r("up-25", &[&eye[..], &["--up=1e-25,1e-25,0"]].concat()),
        up1
    );
    let phong = [&eye[..], &["--shading", "phong"]].concat();
    let l1 = r("l1", &[&phong[..], &["--light=1,1,1"]].concat());
    assert_eq!(
        r("l30", &[&phong[..], &["--light=1e30,1e30,1e30"]].concat()),
        l1
    );
    let lx = r("lx", &[&phong[..], &["--light=1,0,0"]].concat());
    assert_eq!(
        r("l-25", &[&phong[..], &["--light=1e-25,0,0"]].concat()),
        lx
    );
    // An eye so far that f32 positions cannot tell samples apart: refused
    // for that reason, not as "the same point".
    let line = fails(
        &mut render_cmd(
            d.path(),
            &v,
            "far",
            &["--eye=1e20,1e20,1e20", "--look-at", "12,12,12"],
        ),
        "too far",
    );
    assert!(
        line.contains("s.vvol") && !line.contains("same point"),
        "{line}"
    );
    fails(
        &mut render_cmd(d.path(), &v, "same", &["--eye=3,3,3", "--look-at", "3,3,3"]),
        "same point",
    );
}

#[test]
fn render_orbit_turns_around_up() {
    let d = tmp();
    let v = gen(
        d.path(),
        "s.vvol",
        &[
            "shapes", "--dims", "24,24,24", "--count", "6", "--size", "6",
        ],
    );
    let r = |name: &str, args: &[&str]| {
        ok(&mut render_cmd(
            d.path(),
            &v,
            name,
            &[&["--tf", "shapes"][..], args].concat(),
        ));
        png_bytes(d.path(), name)
    };
    // Azimuth 0, elevation 0 puts the eye on the +z side whatever up is
    // (for up = x): exactly --eye there with that up.
    let orbit = r("o", &["--orbit", "0,0,60", "--up", "1,0,0"]);
    let eye = r(
        "e",
        &[
            "--eye",
            "11.5,11.5,71.5",
            "--look-at",
            "11.5,11.5,11.5",
            "--up",
            "1,0,0",
        ],
    );
    assert_eq!(orbit, eye, "--orbit ignored --up");
    assert_ne!(orbit, r("y", &["--orbit", "0,0,60"]));
    // Same framing, different up: different images.
    assert_ne!(
        r("z", &["--orbit", "30,20,60", "--up", "0,0,1"]),
        r("w", &["--orbit", "30,20,60"])
    );
}

#[test]
fn render_up_patient_follows_the_direction_matrix() {
    let d = tmp();
    let data: Vec<u8> = (0..8 * 8 * 8).map(|i| ((i * 37) % 251) as u8).collect();
    // Index axis y points superior: the patient's up is +y in the
    // renderer's world; with the identity geometry it is +z.
    let coronal = nrrd(
        d.path(),
        "cor.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\nspace: left-posterior-superior\nspace directions: (1,0,0) (0,0,1) (0,1,0)\nspace origin: (0,0,0)\n\n",
        &data,
    );
    let plain = nrrd(
        d.path(),
        "ax.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n\n",
        &data,
    );
    let r = |vol: &Path, name: &str, up: &str| {
        ok(&mut render_cmd(
            d.path(),
            vol,
            name,
            &["--orbit", "30,20,30", "--up", up],
        ));
        png_bytes(d.path(), name)
    };
    assert_eq!(r(&coronal, "cp", "patient"), r(&coronal, "cy", "0,1,0"));
    assert_eq!(r(&plain, "pp", "patient"), r(&plain, "pz", "0,0,1"));
    assert_ne!(r(&plain, "pp2", "patient"), r(&plain, "py", "0,1,0"));
}

#[test]
fn render_default_framing_at_spacing_1e_3_shows_the_volume() {
    let d = tmp();
    let v = gen(
        d.path(),
        "mm.vvol",
        &[
            "solid",
            "--dims",
            "16,16,16",
            "--spacing",
            "0.001,0.001,0.001",
        ],
    );
    let img = render_hdr(d.path(), &v, "a", &["--mode", "mip"]);
    assert!(
        img[12 * 24 + 12] > 0.5,
        "centre pixel {}",
        img[12 * 24 + 12]
    );
    let huge = gen(
        d.path(),
        "huge.vvol",
        &[
            "solid",
            "--dims",
            "16,16,16",
            "--spacing",
            "3.4e38,3.4e38,3.4e38",
        ],
    );
    let line = fails(&mut render_cmd(d.path(), &huge, "b", &[]), "too large");
    assert!(
        line.contains("huge.vvol") && !line.contains("orbit distance"),
        "{line}"
    );
}

#[test]
fn render_iso_default_on_an_infinite_range_is_finite_or_refused_clearly() {
    let d = tmp();
    let mut v = vec![10.0f32; 512];
    v[0] = f32::INFINITY;
    v[1] = f32::NEG_INFINITY;
    for (i, x) in v.iter_mut().enumerate().skip(2) {
        *x = (i % 8) as f32 * 10.0;
    }
    let vol = raw_f32(d.path(), "inf", [8, 8, 8], &v);
    // The midpoint of the finite samples (0..70): 35.
    let out = run(&mut render_cmd(d.path(), &vol, "a", &["--mode", "iso"]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let img = render_hdr(d.path(), &vol, "a", &["--mode", "iso"]);
    assert!(img.iter().any(|&g| g > 0.0) && img.iter().all(|g| g.is_finite()));
    // Without an index the finite range is unknown: refused with the reason.
    let line = fails(
        &mut render_cmd(d.path(), &vol, "b", &["--mode", "iso", "--no-ess"]),
        "give --iso",
    );
    assert!(!line.contains("must be finite"), "{line}");
}

#[test]
fn render_tile_and_size_allocations_are_bounded() {
    let d = tmp();
    let v = gen(d.path(), "s.vvol", &["solid", "--dims", "8,8,8"]);
    ok(&mut render_cmd(
        d.path(),
        &v,
        "a",
        &["--tile", "4", "--size", "16x16"],
    ));
    let want = png_bytes(d.path(), "a");
    let out = run_within(
        &mut render_cmd(d.path(), &v, "b", &["--tile", "100000", "--size", "16x16"]),
        Duration::from_secs(30),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(png_bytes(d.path(), "b"), want);
    // The widest allowed image, one row: within the budget, so it renders.
    ok(&mut render_cmd(
        d.path(),
        &v,
        "w",
        &["--size", "32768x1", "--tile", "32768"],
    ));
    let out = run_within(
        &mut render_cmd(d.path(), &v, "c", &["--size", "32768x32768"]),
        Duration::from_secs(30),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.lines().count() == 1, "{err}");
    assert!(
        err.contains("budget") && !err.contains("allocation"),
        "{err}"
    );
    assert!(!d.path().join("c.png").exists());
}

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

/// Dimensions whose bricked bytes pass u64 (found by the unwrap audit: the
/// header's data length multiplied unchecked) are refused with one line.
#[test]
fn a_bricked_volume_whose_bytes_pass_u64_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.vvol");
    fails(
        tool("vol-gen")
            .args([
                "solid",
                "--dims",
                "16777216,16777216,16383",
                "--type",
                "f32",
            ])
            .args(["--layout", "bricked:1024", "-o"])
            .arg(&out),
        "overflows",
    );
    assert!(!out.exists());
    assert!(leftovers(dir.path()).is_empty());
}
