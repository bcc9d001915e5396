//! Corrupted, mutated and truncated files, reader by reader: .vvol,
//! thesis .vol, raw, NRRD, MetaImage, streams on stdin, TIFF, .vidx, PFM
//! and PNG. (Crafted header text in messages: `escaping`.)

use super::*;

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

/// Bug: `vol-info --verify` passed a file whose trailer range disagreed with its header's (issue 43).
#[test]
fn vvol_trailer_range_that_disagrees_with_the_header_fails_verify() {
    let d = tmp();
    for layout in ["sliced", "bricked:4"] {
        let p = gen(
            d.path(),
            "r.vvol",
            &[
                "ramp", "--dims", "6,5,4", "--type", "u16", "--layout", layout,
            ],
        );
        ok(bin("vol-info").arg("--verify").arg(&p));
        let mut b = std::fs::read(&p).unwrap();
        // The trailer's maximum (its last eight bytes) off by one.
        let n = b.len();
        let max = f64::from_le_bytes(b[n - 8..].try_into().unwrap());
        b[n - 8..].copy_from_slice(&(max + 1.0).to_le_bytes());
        std::fs::write(&p, &b).unwrap();
        let line = fails(bin("vol-info").arg("--verify").arg(&p), "r.vvol");
        assert!(
            line.contains("range") && line.contains("header") && line.contains("trailer"),
            "{line}"
        );
    }
}

/// CRC-32 (IEEE), as the .vvol trailer and brick table use.
fn crc32(b: &[u8]) -> u32 {
    let mut c = flate2::Crc::new();
    c.update(b);
    c.sum()
}

/// Bug: table entries sharing one zstd frame decoded to more than the file held (audit, 48807d4).
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

/// Bug: open allocated the whole claimed brick table (6 GiB) before any check (audit, 48807d4).
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

const NRRD_U8: &str = "NRRD0004\ntype: uchar\nsizes: 2 2 2\nencoding: raw\n";

/// Bug: `line skip: 4294967295` on stdin read empty lines forever after EOF (fixed in 4543c7c).
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

/// Bug: a flipped bit in a directory count aborted on a 2.3e18-byte allocation (fixed in 1d15898).
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

/// Bug: 2^58 strip offsets in a later directory panicked: "capacity overflow" (1d15898, a34ab6d).
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

/// Bug: a page 2^31 pixels wide aborted the reader (1d15898; fuzz/regressions/tiff/width-2e31).
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

/// Bug: an ASCII tag count past the decoder's limits printed the `tiff` crate's `dbg!` line first (issue 43).
#[test]
fn tiff_huge_ascii_count_prints_one_line() {
    let d = tmp();
    let src = d.path().join("src.tif");
    bigtiff(&src, [8, 4, 3], false);
    let good = std::fs::read(&src).unwrap();
    let (off, n) = first_ifd(&good);
    // BitsPerSample (read by the decoder itself) and ImageDescription (read
    // by volkit) as ASCII with 2^40 characters, in the first directory.
    for tag in [258u16, 270] {
        let mut b = good.clone();
        let mut patched = false;
        for i in 0..n {
            let e = off + 8 + i * 20;
            if u16::from_le_bytes([b[e], b[e + 1]]) == tag {
                b[e + 2..e + 4].copy_from_slice(&2u16.to_le_bytes());
                b[e + 4..e + 12].copy_from_slice(&(1u64 << 40).to_le_bytes());
                patched = true;
            }
        }
        if !patched {
            // No such entry: the last one (ResolutionUnit) becomes it.
            let e = off + 8 + (n - 1) * 20;
            b[e..e + 2].copy_from_slice(&tag.to_le_bytes());
            b[e + 2..e + 4].copy_from_slice(&2u16.to_le_bytes());
            b[e + 4..e + 12].copy_from_slice(&(1u64 << 40).to_le_bytes());
        }
        let p = d.path().join(format!("ascii{tag}.tif"));
        std::fs::write(&p, &b).unwrap();
        for tool in ["vol-info", "vol-convert"] {
            let mut c = bin(tool);
            c.arg(&p);
            if tool == "vol-convert" {
                c.arg("-o").arg(d.path().join("o.vvol"));
            }
            let line = fails(&mut c, &format!("ascii{tag}.tif"));
            assert!(line.contains("damaged directory"), "{line}");
        }
        assert!(read_all(&p).is_err());
    }
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

/// Issue 53 §6: `--verify` refuses a flag bit it does not know and a
/// reserved byte other than 0 (header, brick table, trailer), in one line
/// naming the file and the field.
#[test]
fn vvol_unknown_flag_bits_and_reserved_bytes_fail_verify() {
    let d = tmp();
    for layout in ["sliced", "bricked:4"] {
        let p = gen(
            d.path(),
            "f.vvol",
            &[
                "ramp", "--dims", "6,5,4", "--type", "u16", "--layout", layout,
            ],
        );
        ok(bin("vol-info").arg("--verify").arg(&p));
        let good = std::fs::read(&p).unwrap();
        let n = good.len();
        // Trailer flags: bit 1. Header flags: bit 3 (its CRC renewed).
        // Header reserved byte 230 (its geometry CRC renewed).
        let mut cases: Vec<(Vec<u8>, &str)> = Vec::new();
        let mut b = good.clone();
        b[n - 32 + 12] |= 2;
        cases.push((b, "trailer flags"));
        let mut b = good.clone();
        b[12] |= 8;
        let crc = crc32(&b[..124]);
        b[124..128].copy_from_slice(&crc.to_le_bytes());
        cases.push((b, "header flags"));
        let mut b = good.clone();
        b[230] = 7;
        let crc = crc32(&b[128..252]);
        b[252..256].copy_from_slice(&crc.to_le_bytes());
        cases.push((b, "header reserved byte 230"));
        if layout != "sliced" {
            // The last entry's reserved bytes, the table's CRC renewed.
            let mut b = good.clone();
            let count = u64::from_le_bytes(b[96..104].try_into().unwrap()) as usize;
            b[256 + 24 * (count - 1) + 20] = 1;
            let crc = crc32(&b[256..256 + 24 * count]);
            b[n - 24..n - 20].copy_from_slice(&crc.to_le_bytes());
            cases.push((b, "brick table entry 3"));
        }
        for (bytes, field) in cases {
            std::fs::write(&p, &bytes).unwrap();
            let line = fails(bin("vol-info").arg("--verify").arg(&p), "f.vvol");
            assert!(line.contains(field), "{layout}, {field}: {line}");
        }
    }
}
