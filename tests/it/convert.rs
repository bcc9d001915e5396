//! End to end: vol-convert on TIFF stacks, raw, NRRD, MetaImage, .vol and
//! .vvol, checked voxel by voxel against vol-gen's output.

use crate::common::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use tiff::encoder::{colortype, Compression, DeflateLevel, Predictor, TiffEncoder};

fn convert() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_vol-convert"));
    c.stdin(Stdio::null());
    c
}

/// vol-gen a raw volume; returns its path and bytes.
fn gen_raw(dir: &Path, name: &str, args: &[&str]) -> (PathBuf, Vec<u8>) {
    let p = dir.join(name);
    ok(tool("vol-gen").args(args).arg("--quiet").arg("-o").arg(&p));
    let b = std::fs::read(&p).unwrap();
    (p, b)
}

/// Convert `input` to raw with extra flags and return the bytes.
fn to_raw(dir: &Path, input: &Path, extra: &[&str]) -> Vec<u8> {
    let out = dir.join(format!(
        "check-{}.raw",
        fastrand_name(input.to_string_lossy().as_ref())
    ));
    ok(convert()
        .arg(input)
        .args(extra)
        .arg("-o")
        .arg(&out)
        .arg("--quiet"));
    let b = std::fs::read(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    b
}

fn fastrand_name(s: &str) -> String {
    // A stable, file-name-safe tag for an input path.
    let h = s.bytes().fold(1469598103934665603u64, |h, b| {
        (h ^ b as u64).wrapping_mul(1099511628211)
    });
    format!("{h:016x}")
}

const DIMS: [u64; 3] = [37, 29, 23];

fn dims_arg() -> String {
    format!("{},{},{}", DIMS[0], DIMS[1], DIMS[2])
}

fn slice_len() -> usize {
    (DIMS[0] * DIMS[1]) as usize
}

fn gen_typed(dir: &Path, t: &str) -> (PathBuf, Vec<u8>) {
    let scene: &[&str] = match t {
        "f32" | "u16" | "i16" => &["spheres", "--count", "6", "--size", "9", "--value", "3000"],
        _ => &["shapes", "--count", "6", "--size", "12"],
    };
    let d = dims_arg();
    let mut args: Vec<&str> = scene.to_vec();
    args.extend(["--dims", &d, "--type", t]);
    let name = format!("g_{}x{}x{}_{t}.raw", DIMS[0], DIMS[1], DIMS[2]);
    gen_raw(dir, &name, &args)
}

#[test]
fn tiff_vvol_tiff_round_trips_are_bit_exact_for_every_type() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for t in ["u8", "u16", "i16", "f32"] {
        let (raw, want) = gen_typed(d, t);
        let raw_args = ["--raw-dims", &dims_arg(), "--raw-type", t];
        // raw -> directory of TIFF slices -> bricked zstd .vvol ->
        // multipage TIFF -> sliced .vvol -> raw.
        let slices = d.join(format!("slices_{t}/"));
        ok(convert()
            .arg(&raw)
            .args(raw_args)
            .arg("-o")
            .arg(&slices)
            .arg("-q"));
        let v1 = d.join(format!("b_{t}.vvol"));
        ok(convert()
            .arg(&slices)
            .args(["--layout", "bricked:8", "--compress", "zstd:3", "-q", "-o"])
            .arg(&v1));
        let multi = d.join(format!("m_{t}.tif"));
        ok(convert().arg(&v1).arg("-o").arg(&multi).arg("-q"));
        let v2 = d.join(format!("s_{t}.vvol"));
        ok(convert().arg(&multi).arg("-o").arg(&v2).arg("-q"));
        let info = json(&ok(tool("vol-info").arg("--verify").arg("--json").arg(&v2)));
        assert_eq!(info["type"], t);
        assert_eq!(to_raw(d, &v2, &[]), want, "{t} round trip");
        assert!(leftovers(d).is_empty());
    }
}

#[test]
fn imports_match_the_generator_voxel_by_voxel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_, want) = gen_typed(d, "u16");
    let header = format!(
        "NRRD0004\ntype: ushort\ndimension: 3\nsizes: {} {} {}\nspacings: 0.5 0.5 2\n",
        DIMS[0], DIMS[1], DIMS[2]
    );
    let be: Vec<u8> = want.chunks_exact(2).flat_map(|c| [c[1], c[0]]).collect();
    // NRRD attached raw, little-endian.
    let p = d.join("a.nrrd");
    let mut f = std::fs::File::create(&p).unwrap();
    write!(f, "{header}endian: little\nencoding: raw\n\n").unwrap();
    f.write_all(&want).unwrap();
    drop(f);
    assert_eq!(to_raw(d, &p, &[]), want, "nrrd raw");
    let v = json(&ok(convert()
        .arg(&p)
        .arg("--json")
        .arg("-o")
        .arg(d.join("a.vvol"))));
    assert_eq!(v["spacing"], serde_json::json!([0.5, 0.5, 2.0]));
    // NRRD attached gzip, big-endian.
    let p = d.join("b.nrrd");
    let mut f = std::fs::File::create(&p).unwrap();
    write!(f, "{header}endian: big\nencoding: gzip\n\n").unwrap();
    let mut gz = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
    gz.write_all(&be).unwrap();
    gz.finish().unwrap();
    assert_eq!(to_raw(d, &p, &[]), want, "nrrd gzip big-endian");
    // NRRD detached header with a byte skip.
    std::fs::write(d.join("data.bin"), [&[9u8; 5][..], &want].concat()).unwrap();
    let p = d.join("c.nhdr");
    std::fs::write(
        &p,
        format!("{header}endian: little\nencoding: raw\nbyte skip: 5\ndata file: data.bin\n"),
    )
    .unwrap();
    assert_eq!(to_raw(d, &p, &[]), want, "nrrd detached");
    // NRRD on standard input.
    let mut child = convert()
        .args(["-", "-q", "-o"])
        .arg(d.join("stdin.raw"))
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut si = child.stdin.take().unwrap();
        write!(si, "{header}endian: little\nencoding: raw\n\n").unwrap();
        si.write_all(&want).unwrap();
    }
    assert!(child.wait().unwrap().success());
    assert_eq!(
        std::fs::read(d.join("stdin.raw")).unwrap(),
        want,
        "nrrd stdin"
    );
    // MetaImage: .mhd + data file, .mha local, .mha zlib, big-endian.
    let mhd = format!(
        "ObjectType = Image\nNDims = 3\nDimSize = {} {} {}\nElementSpacing = 1 1 1\nElementType = MET_USHORT\n",
        DIMS[0], DIMS[1], DIMS[2]
    );
    std::fs::write(d.join("m.raw_data"), &be).unwrap();
    let p = d.join("m.mhd");
    std::fs::write(
        &p,
        format!("{mhd}BinaryDataByteOrderMSB = True\nElementDataFile = m.raw_data\n"),
    )
    .unwrap();
    assert_eq!(to_raw(d, &p, &[]), want, "mhd");
    let p = d.join("l.mha");
    let mut f = std::fs::File::create(&p).unwrap();
    writeln!(f, "{mhd}ElementDataFile = LOCAL").unwrap();
    f.write_all(&want).unwrap();
    drop(f);
    assert_eq!(to_raw(d, &p, &[]), want, "mha local");
    let p = d.join("z.mha");
    let mut f = std::fs::File::create(&p).unwrap();
    write!(f, "{mhd}CompressedData = True\nElementDataFile = LOCAL\n").unwrap();
    let mut z = flate2::write::ZlibEncoder::new(f, flate2::Compression::default());
    z.write_all(&want).unwrap();
    z.finish().unwrap();
    assert_eq!(to_raw(d, &p, &[]), want, "mha zlib");
    // Raw: big-endian with a header skip, and from standard input.
    let p = d.join("be.bin");
    std::fs::write(&p, [&[0u8; 7][..], &be].concat()).unwrap();
    let raw_be = [
        "--raw-dims",
        &dims_arg(),
        "--raw-type",
        "u16",
        "--raw-endian",
        "big",
        "--raw-skip",
        "7",
    ];
    assert_eq!(to_raw(d, &p, &raw_be), want, "raw big-endian");
    // Thesis .vol, both layouts, and every .vvol layout, against u8 raw.
    let (_, want8) = gen_typed(d, "u8");
    let dd = dims_arg();
    for (name, layout) in [
        ("s.vol", "sliced"),
        ("b.vol", "bricked:8"),
        ("s.vvol", "sliced"),
        ("b.vvol", "bricked:8"),
    ] {
        let p = d.join(name);
        ok(tool("vol-gen")
            .args([
                "shapes", "--count", "6", "--size", "12", "--dims", &dd, "--layout", layout, "-q",
                "-o",
            ])
            .arg(&p));
        assert_eq!(to_raw(d, &p, &[]), want8, "{name}");
    }
}

/// A big-endian TIFF written by hand (the tiff crate writes little-endian
/// only): `pages` of `w × h` samples, each already big-endian bytes.
fn be_tiff(pages: &[Vec<u8>], w: u32, h: u32, bits: u16, format: u16) -> Vec<u8> {
    let mut out = b"MM\0\x2a".to_vec();
    out.extend(8u32.to_be_bytes());
    let n_entries = 10u16;
    let ifd_len = 2 + 12 * n_entries as usize + 4;
    for (i, data) in pages.iter().enumerate() {
        let ifd_at = out.len();
        let data_at = ifd_at + ifd_len;
        let next = if i + 1 < pages.len() {
            (data_at + data.len()) as u32
        } else {
            0
        };
        out.extend(n_entries.to_be_bytes());
        let mut entry = |tag: u16, ty: u16, v: u32| {
            out.extend(tag.to_be_bytes());
            out.extend(ty.to_be_bytes());
            out.extend(1u32.to_be_bytes());
            if ty == 3 {
                out.extend((v as u16).to_be_bytes());
                out.extend([0, 0]);
            } else {
                out.extend(v.to_be_bytes());
            }
        };
        entry(256, 4, w);
        entry(257, 4, h);
        entry(258, 3, bits as u32);
        entry(259, 3, 1);
        entry(262, 3, 1);
        entry(273, 4, data_at as u32);
        entry(277, 3, 1);
        entry(278, 4, h);
        entry(279, 4, data.len() as u32);
        entry(339, 3, format as u32);
        out.extend(next.to_be_bytes());
        out.extend(data);
    }
    out
}

/// A big-endian u16 TIFF of one page stored as `tile × tile` tiles (edge
/// tiles padded), written by hand: the tiff crate's encoder writes strips.
fn be_tiled_tiff(v: &[u16], w: u32, h: u32, tile: u32) -> Vec<u8> {
    let (tx, ty) = (w.div_ceil(tile), h.div_ceil(tile));
    let n = (tx * ty) as usize;
    let tile_bytes = (tile * tile * 2) as usize;
    let entries: u16 = 11;
    let ifd_at = 8usize;
    let arrays_at = ifd_at + 2 + 12 * entries as usize + 4;
    let data_at = arrays_at + 8 * n;
    let mut out = b"MM\0\x2a".to_vec();
    out.extend((ifd_at as u32).to_be_bytes());
    out.extend(entries.to_be_bytes());
    let mut entry = |tag: u16, ty: u16, count: u32, v: u32| {
        out.extend(tag.to_be_bytes());
        out.extend(ty.to_be_bytes());
        out.extend(count.to_be_bytes());
        if ty == 3 && count == 1 {
            out.extend((v as u16).to_be_bytes());
            out.extend([0, 0]);
        } else {
            out.extend(v.to_be_bytes());
        }
    };
    entry(256, 4, 1, w);
    entry(257, 4, 1, h);
    entry(258, 3, 1, 16);
    entry(259, 3, 1, 1);
    entry(262, 3, 1, 1);
    entry(277, 3, 1, 1);
    entry(322, 4, 1, tile);
    entry(323, 4, 1, tile);
    entry(324, 4, n as u32, arrays_at as u32);
    entry(325, 4, n as u32, (arrays_at + 4 * n) as u32);
    entry(339, 3, 1, 1);
    out.extend(0u32.to_be_bytes());
    for i in 0..n {
        out.extend(((data_at + i * tile_bytes) as u32).to_be_bytes());
    }
    for _ in 0..n {
        out.extend((tile_bytes as u32).to_be_bytes());
    }
    for t in 0..n as u32 {
        let (x0, y0) = ((t % tx) * tile, (t / tx) * tile);
        for y in y0..y0 + tile {
            for x in x0..x0 + tile {
                let s = if x < w && y < h {
                    v[(y * w + x) as usize]
                } else {
                    0
                };
                out.extend(s.to_be_bytes());
            }
        }
    }
    out
}

/// An ImageJ "hyperstack" as ImageJ writes stacks past 4 GiB: one
/// directory, a description announcing `images=N`, and all N images
/// back to back after the first one's data. Little-endian u16.
fn imagej_one_ifd(v: &[u16], w: u32, h: u32, n: u32) -> Vec<u8> {
    let desc = format!("ImageJ=1.54f\nimages={n}\nslices={n}\nspacing=2.5\nloop=false\n\0");
    let entries: u16 = 11;
    let desc_at = 8 + 2 + 12 * entries as usize + 4;
    let data_at = desc_at + desc.len();
    let mut out = b"II\x2a\0".to_vec();
    out.extend(8u32.to_le_bytes());
    out.extend(entries.to_le_bytes());
    let mut entry = |tag: u16, ty: u16, count: u32, v: u32| {
        out.extend(tag.to_le_bytes());
        out.extend(ty.to_le_bytes());
        out.extend(count.to_le_bytes());
        out.extend(v.to_le_bytes());
    };
    entry(256, 4, 1, w);
    entry(257, 4, 1, h);
    entry(258, 3, 1, 16);
    entry(259, 3, 1, 1);
    entry(262, 3, 1, 1);
    entry(270, 2, desc.len() as u32, desc_at as u32);
    entry(273, 4, 1, data_at as u32);
    entry(277, 3, 1, 1);
    entry(278, 4, 1, h);
    entry(279, 4, 1, w * h * 2);
    entry(339, 3, 1, 1);
    out.extend(0u32.to_le_bytes());
    out.extend(desc.as_bytes());
    for s in v {
        out.extend(s.to_le_bytes());
    }
    out
}

#[test]
fn imagej_stacks_with_one_directory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (w, h, n) = (9u32, 7u32, 5u32);
    let v: Vec<u16> = (0..w * h * n).map(|i| (i * 13) as u16).collect();
    let p = d.join("ij.tif");
    std::fs::write(&p, imagej_one_ifd(&v, w, h, n)).unwrap();
    let got: Vec<u16> = to_raw(d, &p, &[])
        .chunks(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got, v);
    let j = json(&ok(convert()
        .arg(&p)
        .arg("--json")
        .arg("-o")
        .arg(d.join("ij.vvol"))));
    assert_eq!(j["dims"], serde_json::json!([9, 7, 5]));
    assert_eq!(j["spacing"][2], 2.5);
    // Cut short: the images announced are not all there.
    let full = std::fs::read(&p).unwrap();
    std::fs::write(&p, &full[..full.len() - 4]).unwrap();
    fails(convert().arg(&p).arg("-o").arg(d.join("x.vvol")), "bytes");
}

#[test]
fn tiled_and_signed_8_bit_tiffs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (w, h) = (37u32, 29u32);
    let v: Vec<u16> = (0..w * h).map(|i| (i * 31 % 65521) as u16).collect();
    let p = d.join("tiled.tif");
    std::fs::write(&p, be_tiled_tiff(&v, w, h, 16)).unwrap();
    let got: Vec<u16> = to_raw(d, &p, &[])
        .chunks(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got, v);
    // Signed 8-bit slices are widened to i16, values kept.
    let p = d.join("i8.tif");
    {
        let f = std::fs::File::create(&p).unwrap();
        let px: Vec<i8> = vec![-128, -1, 0, 127];
        TiffEncoder::new(f)
            .unwrap()
            .write_image::<colortype::GrayI8>(2, 2, &px)
            .unwrap();
    }
    let got: Vec<i16> = to_raw(d, &p, &[])
        .chunks(2)
        .map(|c| i16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got, [-128, -1, 0, 127]);
}

#[test]
fn big_endian_compressed_and_bigtiff_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (w, h) = (DIMS[0] as u32, DIMS[1] as u32);
    for t in ["u8", "u16", "i16", "f32"] {
        let (_, want) = gen_typed(d, t);
        let size = match t {
            "u8" => 1,
            "f32" => 4,
            _ => 2,
        };
        let slices: Vec<&[u8]> = want.chunks(slice_len() * size).collect();
        // Big-endian multipage, written by hand.
        let pages: Vec<Vec<u8>> = slices
            .iter()
            .map(|s| {
                s.chunks(size)
                    .flat_map(|c| c.iter().rev().copied())
                    .collect()
            })
            .collect();
        let (bits, fmt) = match t {
            "u8" => (8, 1),
            "u16" => (16, 1),
            "i16" => (16, 2),
            _ => (32, 3),
        };
        let p = d.join(format!("be_{t}.tif"));
        std::fs::write(&p, be_tiff(&pages, w, h, bits, fmt)).unwrap();
        assert_eq!(to_raw(d, &p, &[]), want, "big-endian {t}");
        // Every compression the encoder has, with and without the
        // horizontal predictor (integers only), as a directory of slices
        // and as a BigTIFF.
        let comps = [
            ("none", Compression::Uncompressed),
            ("lzw", Compression::Lzw),
            ("deflate", Compression::Deflate(DeflateLevel::Balanced)),
            ("packbits", Compression::Packbits),
        ];
        for (cname, comp) in comps {
            for pred in [Predictor::None, Predictor::Horizontal] {
                if t == "f32" && pred == Predictor::Horizontal {
                    continue;
                }
                let sub = d.join(format!("{t}_{cname}_{}", pred as u16));
                std::fs::create_dir(&sub).unwrap();
                for (z, s) in slices.iter().enumerate() {
                    let f = std::fs::File::create(sub.join(format!("img{z}.tif"))).unwrap();
                    let mut e = TiffEncoder::new(f)
                        .unwrap()
                        .with_compression(comp)
                        .with_predictor(pred);
                    write_typed(&mut e, t, w, h, s);
                }
                assert_eq!(to_raw(d, &sub, &[]), want, "{t} {cname} {pred:?}");
            }
        }
        let p = d.join(format!("big_{t}.tif"));
        let f = std::fs::File::create(&p).unwrap();
        let mut e = TiffEncoder::new_big(f)
            .unwrap()
            .with_compression(Compression::Lzw);
        for s in &slices {
            write_typed(&mut e, t, w, h, s);
        }
        drop(e);
        assert_eq!(to_raw(d, &p, &[]), want, "bigtiff {t}");
    }
}

fn write_typed<W: std::io::Write + std::io::Seek, K: tiff::encoder::TiffKind>(
    e: &mut TiffEncoder<W, K>,
    t: &str,
    w: u32,
    h: u32,
    le_bytes: &[u8],
) {
    match t {
        "u8" => e.write_image::<colortype::Gray8>(w, h, le_bytes).unwrap(),
        "u16" => {
            let v: Vec<u16> = le_bytes
                .chunks(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            e.write_image::<colortype::Gray16>(w, h, &v).unwrap()
        }
        "i16" => {
            let v: Vec<i16> = le_bytes
                .chunks(2)
                .map(|c| i16::from_le_bytes([c[0], c[1]]))
                .collect();
            e.write_image::<colortype::GrayI16>(w, h, &v).unwrap()
        }
        _ => {
            let v: Vec<f32> = le_bytes
                .chunks(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            e.write_image::<colortype::Gray32Float>(w, h, &v).unwrap()
        }
    }
}

#[test]
fn signed_16_bit_ct_values_and_windows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Hounsfield-like values: -1024 .. 3071 along x.
    let (w, h, n) = (64u32, 4u32, 3usize);
    let v: Vec<i16> = (0..(w * h) as usize * n)
        .map(|i| ((i % w as usize) as i32 * 64 - 1024) as i16)
        .collect();
    let p = d.join("ct.tif");
    {
        let f = std::fs::File::create(&p).unwrap();
        let mut e = TiffEncoder::new(f).unwrap();
        for s in v.chunks((w * h) as usize) {
            e.write_image::<colortype::GrayI16>(w, h, s).unwrap();
        }
    }
    let raw = to_raw(d, &p, &[]);
    let back: Vec<i16> = raw
        .chunks(2)
        .map(|c| i16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(back, v);
    // Window -1000:1000 to u8: below clamps to 0, above to 255, linear between.
    let out = to_raw(d, &p, &["--type", "u8", "--window", "-1000:1000"]);
    for (o, &i) in out.iter().zip(&v) {
        let want = ((i as f64 + 1000.0) * 255.0 / 2000.0)
            .clamp(0.0, 255.0)
            .round() as u8;
        assert_eq!(*o, want, "{i}");
    }
    assert_eq!(out[0], 0); // -1024 clamps
    assert_eq!(out[63], 255); // 2968 clamps
                              // Narrowing without a window is an error, and writes nothing.
    let o = d.join("n.vvol");
    fails(
        convert().arg(&p).args(["--type", "u8", "-o"]).arg(&o),
        "--window",
    );
    assert!(!o.exists());
    // lo == hi is an error.
    fails(
        convert()
            .arg(&p)
            .args(["--type", "u8", "--window", "5:5", "-o"])
            .arg(&o),
        "lo == hi",
    );
    assert!(!o.exists());
    // i16 -> u16 narrows too; full maps the whole i16 range.
    let full = to_raw(d, &p, &["--type", "u16", "--window", "full"]);
    let first = u16::from_le_bytes([full[0], full[1]]);
    assert_eq!(first, (-1024i32 + 32768) as u16);
    // auto picks percentiles; the JSON reports the window used.
    let j = json(&ok(convert()
        .arg(&p)
        .args(["--type", "u8", "--window", "auto:0", "--json", "-o"])
        .arg(d.join("auto.vvol"))));
    assert_eq!(j["window"], serde_json::json!([-1024.0, 3008.0]));
}

#[test]
fn float_to_int_rounds_and_nan_gets_the_bottom() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = [0.0f32, 0.5, 1.4999, 2.5, f32::NAN, -3.0, 1e9, 7.0];
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    let p = d.join("f_2x2x2_float32.raw");
    std::fs::write(&p, &bytes).unwrap();
    let out = to_raw(d, &p, &["--type", "u8", "--window", "0:255"]);
    assert_eq!(out, [0, 1, 1, 3, 0, 0, 255, 7]);
    let out = to_raw(d, &p, &["--type", "i16", "--window", "0:255"]);
    let got: Vec<i16> = out
        .chunks(2)
        .map(|c| i16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got[4], -32768, "NaN to i16");
}

#[test]
fn crop_and_flip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (raw, want) = gen_typed(d, "u8");
    let out = to_raw(d, &raw, &["--crop", "3:20,:,5:9", "--flip", "x,z"]);
    let [nx, ny, _] = DIMS.map(|v| v as usize);
    let (cx, cz) = (17usize, 4usize);
    assert_eq!(out.len(), cx * ny * cz);
    for z in 0..cz {
        for y in 0..ny {
            for x in 0..cx {
                let (xi, zi) = (3 + (cx - 1 - x), 5 + (cz - 1 - z));
                assert_eq!(out[x + cx * (y + ny * z)], want[xi + nx * (y + ny * zi)]);
            }
        }
    }
    fails(
        convert()
            .arg(&raw)
            .args(["--crop", "0:99,:,:", "-o"])
            .arg(d.join("x.vvol")),
        "crop",
    );
}

#[test]
fn stacks_by_directory_glob_and_list_in_natural_order() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = d.join("stack");
    std::fs::create_dir(&s).unwrap();
    // Slices 0..12 named without padding: slice2 must come before slice10.
    for z in 0..12u8 {
        let f = std::fs::File::create(s.join(format!("slice{z}.tif"))).unwrap();
        TiffEncoder::new(f)
            .unwrap()
            .write_image::<colortype::Gray8>(3, 2, &[z; 6])
            .unwrap();
    }
    std::fs::write(s.join("notes.txt"), "not a slice").unwrap();
    let want: Vec<u8> = (0..12u8).flat_map(|z| [z; 6]).collect();
    assert_eq!(to_raw(d, &s, &[]), want);
    assert_eq!(to_raw(d, &s.join("slice*.tif"), &[]), want);
    assert_eq!(
        to_raw(d, &s.join("slice1?.tif"), &[]),
        [[10u8; 6], [11; 6]].concat()
    );
    std::fs::write(
        d.join("list.txt"),
        "# two slices\nstack/slice3.tif\n\nstack/slice1.tif\n",
    )
    .unwrap();
    assert_eq!(
        to_raw(d, &d.join("list.txt"), &[]),
        [[3u8; 6], [1; 6]].concat()
    );
}

#[test]
fn colour_slices_need_a_channel_choice() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = d.join("rgb.tif");
    {
        let f = std::fs::File::create(&p).unwrap();
        let mut e = TiffEncoder::new(f).unwrap();
        let px: Vec<u8> = (0..4).flat_map(|_| [200u8, 100, 50]).collect();
        e.write_image::<colortype::RGB8>(2, 2, &px).unwrap();
    }
    let o = d.join("o.vvol");
    fails(convert().arg(&p).arg("-o").arg(&o), "--channel");
    assert!(!o.exists());
    assert_eq!(to_raw(d, &p, &["--channel", "1"]), [100u8; 4]);
    let luma = (0.299f64 * 200.0 + 0.587 * 100.0 + 0.114 * 50.0).round() as u8;
    assert_eq!(to_raw(d, &p, &["--luma"]), [luma; 4]);
    fails(
        convert().arg(&p).args(["--channel", "3", "-o"]).arg(&o),
        "channel",
    );
}

#[test]
fn spacing_comes_from_tiff_tags_and_can_be_overridden() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (raw, _) = gen_typed(d, "u8");
    let t = d.join("sp.tif");
    ok(convert()
        .arg(&raw)
        .args(["--spacing", "0.25,0.5,2", "-q", "-o"])
        .arg(&t));
    let j = json(&ok(convert()
        .arg(&t)
        .arg("--json")
        .arg("-o")
        .arg(d.join("a.vvol"))));
    assert_eq!(j["spacing"], serde_json::json!([0.25, 0.5, 2.0]));
    let j = json(&ok(convert()
        .arg(&t)
        .args(["--json", "--spacing", "1,1,3", "-o"])
        .arg(d.join("b.vvol"))));
    assert_eq!(j["spacing"], serde_json::json!([1.0, 1.0, 3.0]));
    // 72 dpi and no ImageJ description: z follows x.
    let p = d.join("dpi.tif");
    {
        let f = std::fs::File::create(&p).unwrap();
        let mut e = TiffEncoder::new(f).unwrap();
        let mut img = e.new_image::<colortype::Gray8>(2, 2).unwrap();
        img.resolution(
            tiff::tags::ResolutionUnit::Inch,
            tiff::encoder::Rational { n: 72, d: 1 },
        );
        img.write_data(&[1, 2, 3, 4]).unwrap();
    }
    let j2 = json(&ok(convert()
        .arg(&p)
        .arg("--json")
        .arg("-o")
        .arg(d.join("c.vvol"))));
    let sx = j2["spacing"][0].as_f64().unwrap();
    assert!((sx - 1.0 / 72.0).abs() < 1e-6, "{j2}");
    assert_eq!(j2["spacing"][2], j2["spacing"][0]);
    for key in [
        "seconds",
        "bytes_in",
        "bytes",
        "dims",
        "type",
        "origin",
        "direction",
    ] {
        assert!(!j[key].is_null(), "missing {key}: {j}");
    }
    assert_eq!(
        j["bytes"].as_u64().unwrap(),
        std::fs::metadata(d.join("b.vvol")).unwrap().len()
    );
}

#[test]
fn broken_stacks_fail_with_one_line_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A slice of a different size in the middle of a directory.
    let s = d.join("mixed");
    std::fs::create_dir(&s).unwrap();
    for z in 0..6u32 {
        let w = if z == 3 { 5 } else { 4 };
        let f = std::fs::File::create(s.join(format!("s{z:02}.tif"))).unwrap();
        TiffEncoder::new(f)
            .unwrap()
            .write_image::<colortype::Gray8>(w, 4, &vec![1u8; (w * 4) as usize])
            .unwrap();
    }
    let o = d.join("out.vvol");
    let line = fails(convert().arg(&s).arg("-o").arg(&o), "s03.tif");
    assert!(line.contains("5x4"), "{line}");
    assert!(!o.exists());
    // A slice of another type.
    let f = std::fs::File::create(s.join("s03.tif")).unwrap();
    TiffEncoder::new(f)
        .unwrap()
        .write_image::<colortype::Gray16>(4, 4, &[1u16; 16])
        .unwrap();
    fails(convert().arg(&s).arg("-o").arg(&o), "16-bit");
    assert!(!o.exists());
    // A truncated TIFF: as one file, and in a directory.
    let t = d.join("t.tif");
    {
        let f = std::fs::File::create(&t).unwrap();
        let mut e = TiffEncoder::new(f).unwrap();
        for _ in 0..4 {
            e.write_image::<colortype::Gray16>(64, 64, &[7u16; 4096])
                .unwrap();
        }
    }
    let full = std::fs::read(&t).unwrap();
    std::fs::write(&t, &full[..full.len() / 2]).unwrap();
    fails(convert().arg(&t).arg("-o").arg(&o), "t.tif");
    assert!(!o.exists());
    let f = std::fs::File::create(s.join("s03.tif")).unwrap();
    TiffEncoder::new(f)
        .unwrap()
        .write_image::<colortype::Gray8>(4, 4, &[1u8; 16])
        .unwrap();
    let good = std::fs::read(s.join("s03.tif")).unwrap();
    std::fs::write(s.join("s03.tif"), &good[..good.len() - 10]).unwrap();
    fails(convert().arg(&s).arg("-o").arg(&o), "truncated");
    assert!(!o.exists());
    // Not a TIFF at all.
    std::fs::write(s.join("s03.tif"), b"hello").unwrap();
    fails(convert().arg(&s).arg("-o").arg(&o), "s03.tif");
    // An empty directory.
    let e = d.join("empty");
    std::fs::create_dir(&e).unwrap();
    fails(convert().arg(&e).arg("-o").arg(&o), "no .tif");
    assert!(!o.exists());
    // An output directory of slices holding anything but slice files is
    // refused and left as it was.
    let full_dir = d.join("full");
    std::fs::create_dir(&full_dir).unwrap();
    std::fs::write(full_dir.join("x"), b"x").unwrap();
    std::fs::write(full_dir.join("slice_0000.tif"), b"x").unwrap();
    fails(
        convert()
            .arg(&t)
            .arg("-o")
            .arg(format!("{}/", full_dir.display())),
        "no TIFF slice folder to replace",
    );
    assert_eq!(std::fs::read(full_dir.join("x")).unwrap(), b"x");
    assert!(leftovers(d).is_empty());
}

#[test]
fn truncated_and_bad_streams_leave_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = d.join("o.vvol");
    // A header claiming slices no machine holds.
    let p = d.join("huge.nrrd");
    std::fs::write(
        &p,
        "NRRD0004\ntype: uchar\nsizes: 100000 100000 2\nencoding: gzip\n\n",
    )
    .unwrap();
    fails(convert().arg(&p).arg("-o").arg(&o), "GiB");
    assert!(!o.exists());
    // Raw with too few bytes.
    let p = d.join("short_8x8x8_uint8.raw");
    std::fs::write(&p, [0u8; 500]).unwrap();
    fails(convert().arg(&p).arg("-o").arg(&o), "bytes");
    assert!(!o.exists());
    // A truncated .vvol stream on stdin.
    let mut g = tool("vol-gen");
    g.args(["noise", "--dims", "32,32,32", "-q", "-o", "-"]);
    let bytes = g.output().unwrap().stdout;
    let mut child = convert()
        .args(["-", "-o"])
        .arg(&o)
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&bytes[..bytes.len() / 2])
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("truncated"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!o.exists());
    assert!(leftovers(d).is_empty());
}

#[test]
fn interrupted_conversions_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = d.join("o.vvol");
    let slice = vec![7u8; 64 * 64];
    let mut child = convert()
        .args([
            "-",
            "--raw-dims",
            "64,64,100",
            "--raw-type",
            "u8",
            "--layout",
            "bricked:8",
            "-o",
        ])
        .arg(&o)
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut si = child.stdin.take().unwrap();
    for _ in 0..20 {
        si.write_all(&slice).unwrap();
    }
    si.flush().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    // The reader is blocked on the pipe: feed it so it notices.
    for _ in 0..20 {
        if si.write_all(&slice).is_err() {
            break;
        }
    }
    drop(si);
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("interrupted"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!o.exists());
    assert!(leftovers(d).is_empty(), "{:?}", leftovers(d));
}

#[test]
fn converts_in_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = [
        "shapes", "--dims", "70,60,50", "--count", "8", "--size", "20",
    ];
    let direct = d.join("direct.vvol");
    ok(tool("vol-gen")
        .args(args)
        .args(["--layout", "bricked:32", "-q", "-o"])
        .arg(&direct));
    let piped = d.join("piped.vvol");
    let mut gen = tool("vol-gen")
        .args(args)
        .args(["-q", "-o", "-"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vol-convert"))
        .args(["-", "--layout", "bricked:32", "--json", "-o"])
        .arg(&piped)
        .stdin(gen.stdout.take().unwrap())
        .output()
        .unwrap();
    assert!(gen.wait().unwrap().success());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(j["format"], "vvol stream");
    assert_eq!(j["bytes_in"].as_u64().unwrap(), 70 * 60 * 50 + 256 + 32);
    assert_eq!(
        std::fs::read(&direct).unwrap(),
        std::fs::read(&piped).unwrap()
    );
    // Flipping z needs the whole stream: it is spooled to disk first.
    let mut gen = tool("vol-gen")
        .args(args)
        .args(["-q", "-o", "-"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vol-convert"))
        .args(["-", "--flip", "z", "--json", "-o"])
        .arg(d.join("f.raw"))
        .stdin(gen.stdout.take().unwrap())
        .output()
        .unwrap();
    assert!(gen.wait().unwrap().success());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(json(&String::from_utf8_lossy(&out.stdout))["spooled"], true);
    let flipped = std::fs::read(d.join("f.raw")).unwrap();
    let plain = to_raw(d, &direct, &[]);
    let s = 70 * 60;
    for z in 0..50 {
        assert_eq!(
            flipped[z * s..(z + 1) * s],
            plain[(49 - z) * s..(50 - z) * s]
        );
    }
    // And out to stdout again.
    let out = convert().args(["-o", "-"]).arg(&direct).output().unwrap();
    assert!(out.status.success());
    assert_eq!(&out.stdout[..8], b"\x89VVOL\r\n\x1a");
}

/// The bytes vol-convert reports for a multipage TIFF are the new file's,
/// also when it replaces a smaller one (they were the old file's).
#[test]
fn tiff_output_reports_the_size_of_the_file_it_wrote() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let out = d.join("o.tif");
    for (dims, name) in [("16,16,4", "small.vvol"), ("40,32,24", "big.vvol")] {
        let v = d.join(name);
        ok(tool("vol-gen")
            .args(["noise", "--dims", dims, "-q", "-o"])
            .arg(&v));
        let j = json(&ok(tool("vol-convert")
            .arg(&v)
            .arg("-o")
            .arg(&out)
            .arg("--json")));
        let len = std::fs::metadata(&out).unwrap().len();
        assert_eq!(j["bytes"].as_u64(), Some(len), "{name}: {j}");
    }
}

/// A TIFF slice folder replaces an earlier one, as files and OME-Zarr
/// stores are replaced (docs/OUTPUTS.md): whole, no slice of the earlier
/// write left, nothing beside it.
#[test]
fn tiff_slice_folder_replaces_an_earlier_one_whole() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let out = format!("{}/", d.join("slices").display());
    let (a, b) = (d.join("a.vvol"), d.join("b.vvol"));
    ok(tool("vol-gen")
        .args(["noise", "--dims", "8,6,12", "--seed", "1", "-q", "-o"])
        .arg(&a));
    ok(tool("vol-gen")
        .args(["noise", "--dims", "8,6,5", "--seed", "2", "-q", "-o"])
        .arg(&b));
    ok(tool("vol-convert").arg(&a).args(["-q", "-o", &out]));
    assert_eq!(std::fs::read_dir(d.join("slices")).unwrap().count(), 12);
    ok(tool("vol-convert").arg(&b).args(["-q", "-o", &out]));
    let mut names: Vec<String> = std::fs::read_dir(d.join("slices"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        (0..5)
            .map(|z| format!("slice_{z:04}.tif"))
            .collect::<Vec<_>>()
    );
    // The folder reads back as the second input.
    let (x, y) = (d.join("x_8x6x5_uint8.raw"), d.join("y_8x6x5_uint8.raw"));
    ok(tool("vol-convert").arg(&out).args(["-q", "-o"]).arg(&x));
    ok(tool("vol-convert").arg(&b).args(["-q", "-o"]).arg(&y));
    assert!(std::fs::read(&x).unwrap() == std::fs::read(&y).unwrap());
    let mut beside: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    beside.sort();
    assert_eq!(beside.len(), 5, "{beside:?}");
}

/// Malformed values of vol-convert's own flags are usage errors: exit
/// status 2, as clap's are, one line naming the flag's problem, and no
/// output.
#[test]
fn malformed_crop_and_window_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = d.join("s.vvol");
    ok(tool("vol-gen")
        .args(["shapes", "--dims", "16,16,16", "--quiet", "-o"])
        .arg(&v));
    let out = d.join("o.vvol");
    for (args, needle) in [
        (&["--crop", "0:10"][..], "is not x0:x1,y0:y1,z0:z1"),
        (
            &["--window", "1..2", "--type", "u8"][..],
            "--window '1..2' is not lo:hi",
        ),
        (&["--window", "1:2"][..], "--window needs --type"),
    ] {
        let mut c = tool("vol-convert");
        c.arg(&v).args(args).arg("-o").arg(&out);
        fails(&mut c, needle);
        assert_eq!(c.status().unwrap().code(), Some(2), "{args:?}");
        assert!(!out.exists(), "{args:?}");
    }
}

/// Issue 53 §6: TIFF and raw outputs cannot hold an origin or direction
/// (raw not even the spacing): one note on stderr says what was dropped,
/// and none when the input's are the defaults.
#[test]
fn tiff_and_raw_outputs_say_what_geometry_they_drop() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("a.raw"), [7u8; 24]).unwrap();
    let mhd = d.path().join("a.mhd");
    std::fs::write(
        &mhd,
        "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = MET_UCHAR\n\
         ElementSpacing = 2 2 2\nOffset = 10 20 30\nElementDataFile = a.raw\n",
    )
    .unwrap();
    for (name, want) in [
        (
            "o.tif",
            "TIFF holds no origin or direction: dropped origin 10,20,30",
        ),
        (
            "o_4x3x2_uint8.raw",
            "raw holds no geometry: dropped spacing 2,2,2, origin 10,20,30",
        ),
    ] {
        let err = convert_notes(&mhd, &d.path().join(name));
        let notes: Vec<&str> = err.lines().filter(|l| l.contains("holds no")).collect();
        assert_eq!(notes.len(), 1, "{name}: {err}");
        assert!(notes[0].contains(want), "{name}: {err}");
    }
    // The defaults: nothing to say.
    let plain = d.path().join("plain.vvol");
    ok(Command::new(env!("CARGO_BIN_EXE_vol-gen"))
        .args(["ramp", "--dims", "4,3,2", "-q", "-o"])
        .arg(&plain));
    for name in ["p.tif", "p_4x3x2_uint8.raw"] {
        let err = convert_notes(&plain, &d.path().join(name));
        assert!(!err.contains("holds no"), "{name}: {err}");
    }
}

/// `vol-convert input -o output`, which must succeed; its stderr.
fn convert_notes(input: &Path, output: &Path) -> String {
    let out = run(Command::new(env!("CARGO_BIN_EXE_vol-convert"))
        .arg(input)
        .arg("-o")
        .arg(output));
    assert!(out.status.success(), "{out:?}");
    String::from_utf8_lossy(&out.stderr).into_owned()
}
