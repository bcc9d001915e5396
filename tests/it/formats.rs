//! End to end: files written by other tools (nibabel, pydicom: fixtures
//! made by scripts/make-fixtures.py) read with the right spacing,
//! orientation and values; round trips through every header format with
//! geometry; every tool reading every format; malformed files refused.

use crate::common::{fails, json, leftovers, ok, python_json, tool};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The samples of any volume, through vol-convert to raw f32.
fn samples(input: &Path, extra: &[&str]) -> Vec<f32> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.raw");
    ok(tool("vol-convert")
        .arg(input)
        .args(extra)
        .args(["--type", "f32", "--quiet", "-o"])
        .arg(&out));
    let b = std::fs::read(&out).unwrap();
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

fn info(input: &Path, extra: &[&str]) -> serde_json::Value {
    json(&ok(tool("vol-info").arg(input).args(extra).arg("--json")))
}

fn close(v: &serde_json::Value, want: &[f64]) -> bool {
    let got: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|x| match x.as_array() {
            Some(row) => row.iter().map(|y| y.as_f64().unwrap()).collect(),
            None => vec![x.as_f64().unwrap()],
        })
        .collect();
    got.len() == want.len() && got.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-4)
}

#[test]
fn nibabel_nifti_reads_with_geometry_and_rescale() {
    let p = fixture("nibabel_int16.nii.gz");
    let j = info(&p, &[]);
    assert_eq!(j["dims"], serde_json::json!([8, 7, 6]));
    // int16 with an integer rescale stays integer: i16.
    assert_eq!(j["type"], "i16");
    assert!(close(&j["spacing"], &[0.5, 0.75, 1.5]), "{j}");
    // RAS affine (-x, +y, +z; origin 10, -20, 30) in LPS.
    assert!(close(&j["origin"], &[-10.0, 20.0, 30.0]), "{j}");
    assert!(
        close(
            &j["direction"],
            &[1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0]
        ),
        "{j}"
    );
    assert_eq!(j["orientation"], "LAS");
    let v = samples(&p, &[]);
    let mut want = Vec::new();
    for k in 0..6 {
        for jj in 0..7 {
            for i in 0..8 {
                want.push((2 * (i + 10 * jj + 100 * k) - 10) as f32);
            }
        }
    }
    assert_eq!(v, want);
    // NIfTI-2, float64 written by nibabel.
    let p = fixture("nibabel_f64.nii");
    let j = info(&p, &[]);
    assert_eq!(j["type"], "f64");
    assert_eq!(j["format"], "nifti-2 (nii)");
    assert!(close(&j["spacing"], &[2.0, 2.0, 3.0]), "{j}");
    let v = samples(&p, &[]);
    assert_eq!(v[1 + 8], 0.25 + 1.0);
}

#[test]
fn dicom_series_sorts_by_position_and_gives_hounsfield_units() {
    let p = fixture("dicom_ct");
    let j = info(&p, &[]);
    assert_eq!(j["dims"], serde_json::json!([16, 12, 10]));
    assert_eq!(j["type"], "i16");
    assert!(close(&j["spacing"], &[0.7, 0.8, 2.5]), "{j}");
    assert!(close(&j["origin"], &[-40.0, -30.0, 12.5]), "{j}");
    assert_eq!(j["orientation"], "LPS");
    let v = samples(&p, &[]);
    let mut want = Vec::new();
    for k in 0..10 {
        for y in 0..12 {
            for x in 0..16 {
                want.push((10 * (x + 2 * y + 3 * k) - 1024) as f32);
            }
        }
    }
    assert_eq!(
        v, want,
        "files are shuffled: only the positions give this order"
    );
}

fn copy_dir(from: &Path, to: &Path, skip: &[&str]) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if !skip.contains(&name.as_str()) {
            std::fs::copy(e.path(), to.join(&name)).unwrap();
        }
    }
}

/// The file of dicom_ct holding slice `k` (by position).
fn ct_file(k: usize) -> String {
    let mut files: Vec<PathBuf> = std::fs::read_dir(fixture("dicom_ct"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    // The slice's pixels start at 10·3k: find the file by its position in
    // the converted volume instead of parsing DICOM here.
    let dir = tempfile::tempdir().unwrap();
    for f in &files {
        let one = dir.path().join("one");
        let _ = std::fs::remove_dir_all(&one);
        std::fs::create_dir(&one).unwrap();
        std::fs::copy(f, one.join("a.dcm")).unwrap();
        let v = samples(&one, &[]);
        if v[0] == (30 * k as i32 - 1024) as f32 {
            return f.file_name().unwrap().to_string_lossy().into_owned();
        }
    }
    panic!("no file for slice {k}");
}

#[test]
fn bad_dicom_series_are_refused_with_the_reason() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // A missing slice: the gap is named.
    let gap = d.join("gap");
    copy_dir(&fixture("dicom_ct"), &gap, &[&ct_file(4)]);
    let out = d.join("o.vvol");
    let e = fails(tool("vol-convert").arg(&gap).arg("-o").arg(&out), "missing");
    assert!(e.contains("20.000 mm") && e.contains("25.000 mm"), "{e}");
    assert!(!out.exists() && leftovers(d).is_empty());
    // Gantry tilt.
    fails(
        tool("vol-convert")
            .arg(fixture("dicom_tilt"))
            .arg("-o")
            .arg(&out),
        "gantry tilt",
    );
    // Two series: listed, then picked.
    let two = d.join("two");
    copy_dir(&fixture("dicom_ct"), &two, &[]);
    copy_dir(&fixture("dicom_mr"), &two, &[]);
    let e = fails(
        tool("vol-convert").arg(&two).arg("-o").arg(&out),
        "--series",
    );
    assert!(
        e.contains("1.2.826.0.1.3680043.8.498.10") && e.contains("1.2.826.0.1.3680043.8.498.20"),
        "{e}"
    );
    let j = info(&two, &["--series", "1.2.826.0.1.3680043.8.498.20"]);
    assert_eq!(j["dims"], serde_json::json!([8, 8, 3]));
    fails(
        tool("vol-info").arg(&two).args(["--series", "9.9"]),
        "no series 9.9",
    );
    // A damaged file: one line naming it, nothing written.
    let bad = d.join("bad");
    copy_dir(&fixture("dicom_ct"), &bad, &[]);
    let victim = bad.join(ct_file(2));
    let mut b = std::fs::read(&victim).unwrap();
    b.truncate(300);
    std::fs::write(&victim, b).unwrap();
    let e = fails(tool("vol-convert").arg(&bad).arg("-o").arg(&out), "dcm");
    assert!(
        e.contains(&victim.file_name().unwrap().to_string_lossy().into_owned()),
        "{e}"
    );
    assert!(!out.exists() && leftovers(d).is_empty());
}

#[test]
fn header_formats_round_trip_with_geometry() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let src = fixture("nibabel_int16.nii.gz");
    let want = info(&src, &[]);
    let vvol = d.join("ref.vvol");
    ok(tool("vol-convert").arg(&src).arg("-o").arg(&vvol).arg("-q"));
    for (name, extra) in [
        ("a.nii", &[][..]),
        ("b.nii.gz", &[]),
        ("c.hdr", &[]),
        ("c2.hdr", &["--compress", "gzip"]),
        ("d.nrrd", &[]),
        ("e.nrrd", &["--compress", "gzip"]),
        ("f.nhdr", &["--compress", "gzip"]),
        ("g.mha", &[]),
        ("h.mhd", &["--compress", "gzip"]),
        ("i.vvol", &[]),
    ] {
        let out = d.join(name);
        ok(tool("vol-convert")
            .arg(&vvol)
            .args(extra)
            .arg("-o")
            .arg(&out)
            .arg("-q"));
        let j = info(&out, &[]);
        for key in ["dims", "type"] {
            assert_eq!(j[key], want[key], "{name}: {key}");
        }
        for key in ["spacing", "origin", "direction"] {
            let w: Vec<f64> = want[key]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|x| match x.as_array() {
                    Some(r) => r.iter().map(|y| y.as_f64().unwrap()).collect(),
                    None => vec![x.as_f64().unwrap()],
                })
                .collect();
            assert!(
                close(&j[key], &w),
                "{name}: {key} {} vs {}",
                j[key],
                want[key]
            );
        }
        ok(tool("vol-psnr")
            .arg(&vvol)
            .arg(&out)
            .args(["--min-psnr", "inf", "-q"]));
    }
    assert!(leftovers(d).is_empty());
    // Crop and flip move the origin and turn the axis.
    let out = d.join("crop.nrrd");
    ok(tool("vol-convert")
        .arg(&src)
        .args(["--crop", "2:8,:,:", "--flip", "z", "-q", "-o"])
        .arg(&out));
    let j = info(&out, &[]);
    // Voxel 2 along x (LPS +x, 0.5 mm) and the last slice (5 · 1.5 mm up).
    assert!(close(&j["origin"], &[-9.0, 20.0, 37.5]), "{j}");
    assert_eq!(j["orientation"], "LAI");
}

#[test]
fn every_tool_reads_every_format() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let nii = fixture("nibabel_int16.nii.gz");
    let nrrd = d.join("a.nrrd");
    let tif = d.join("a.tif");
    ok(tool("vol-convert").arg(&nii).arg("-q").arg("-o").arg(&nrrd));
    ok(tool("vol-convert").arg(&nii).arg("-q").arg("-o").arg(&tif));
    ok(tool("vol-psnr")
        .arg(&nrrd)
        .arg(&nii)
        .args(["--min-psnr", "inf", "-q"]));
    ok(tool("vol-psnr")
        .arg(&tif)
        .arg(fixture("nibabel_int16.nii.gz"))
        .args(["--min-psnr", "inf", "-q"]));
    let j = info(&tif, &[]);
    assert_eq!(j["dims"], serde_json::json!([8, 7, 6]));
    ok(tool("vol-index").arg(&nrrd).arg("-q"));
    assert!(d.join("a.nrrd.vidx").exists());
    ok(tool("vol-index")
        .arg("--check")
        .arg(d.join("a.nrrd.vidx"))
        .arg(&nrrd)
        .arg("-q"));
    ok(tool("vol-index")
        .arg(fixture("dicom_ct"))
        .arg("-o")
        .arg(d.join("ct.vidx"))
        .arg("-q"));
}

#[test]
fn wide_integer_and_double_inputs_narrow_by_their_values() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // An int32 NRRD as SimpleITK writes it: HU values fit i16.
    let vals: Vec<i32> = (0..4 * 3 * 2).map(|i| i * 100 - 1024).collect();
    let mut text = b"NRRD0004\ntype: int\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\nendian: little\nencoding: raw\nspace origin: (1,2,3)\n\n".to_vec();
    for v in &vals {
        text.extend_from_slice(&v.to_le_bytes());
    }
    let p = d.join("ct.nrrd");
    std::fs::write(&p, &text).unwrap();
    let j = info(&p, &[]);
    assert_eq!(j["type"], "i16");
    assert!(close(&j["origin"], &[1.0, 2.0, 3.0]), "{j}");
    assert_eq!(
        samples(&p, &[]),
        vals.iter().map(|&v| v as f32).collect::<Vec<_>>()
    );
    // Asking for u8 without a window names the values and the way out.
    let e = fails(
        tool("vol-convert")
            .arg(&p)
            .args(["--type", "u8", "-o"])
            .arg(d.join("o.vvol")),
        "--window",
    );
    assert!(e.contains("-1024"), "{e}");
    ok(tool("vol-convert")
        .arg(&p)
        .args(["--type", "u8", "--window", "full", "-q", "-o"])
        .arg(d.join("o.vvol")));
    // Raw int32 big-endian and f64 through the raw options.
    let r = d.join("w.bin");
    let be: Vec<u8> = vals.iter().flat_map(|v| v.to_be_bytes()).collect();
    std::fs::write(&r, be).unwrap();
    let v = samples(
        &r,
        &[
            "--raw-dims",
            "4,3,2",
            "--raw-type",
            "i32",
            "--raw-endian",
            "big",
        ],
    );
    assert_eq!(v, vals.iter().map(|&v| v as f32).collect::<Vec<_>>());
    let f = d.join("f_2x2x1_float64.raw");
    let fb: Vec<u8> = [0.5f64, -1.25, 3.0, 1e6]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(&f, fb).unwrap();
    assert_eq!(samples(&f, &[]), vec![0.5, -1.25, 3.0, 1e6]);
}

#[test]
fn malformed_new_formats_fail_with_one_line_and_leave_nothing() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let out = d.join("o.vvol");
    // Truncated gzip NIfTI.
    let b = std::fs::read(fixture("nibabel_int16.nii.gz")).unwrap();
    let p = d.join("short.nii.gz");
    std::fs::write(&p, &b[..b.len() / 2]).unwrap();
    fails(
        tool("vol-convert").arg(&p).arg("-o").arg(&out),
        "short.nii.gz",
    );
    assert!(!out.exists());
    // Garbage with a NIfTI name, and a header whose data is missing.
    let p = d.join("junk.nii");
    std::fs::write(&p, vec![7u8; 400]).unwrap();
    fails(tool("vol-info").arg(&p), "not a NIfTI");
    let n = std::fs::read(fixture("nibabel_f64.nii")).unwrap();
    let p = d.join("cut.nii");
    std::fs::write(&p, &n[..600]).unwrap();
    fails(tool("vol-convert").arg(&p).arg("-o").arg(&out), "cut.nii");
    // A NRRD with a bad space.
    let p = d.join("bad.nrrd");
    std::fs::write(
        &p,
        "NRRD0004\ntype: uchar\nsizes: 2 2 2\nspace: sideways\nencoding: raw\n\n\0\0\0\0\0\0\0\0",
    )
    .unwrap();
    fails(tool("vol-convert").arg(&p).arg("-o").arg(&out), "space");
    assert!(!out.exists() && leftovers(d).is_empty());
    // An OME-Zarr whose metadata is not JSON, and one without multiscales.
    let z = d.join("bad.ome.zarr");
    std::fs::create_dir(&z).unwrap();
    std::fs::write(z.join("zarr.json"), "{not json").unwrap();
    fails(
        tool("vol-convert").arg(&z).arg("-o").arg(&out),
        "bad.ome.zarr",
    );
    std::fs::write(
        z.join("zarr.json"),
        r#"{"zarr_format":3,"node_type":"group","attributes":{}}"#,
    )
    .unwrap();
    fails(tool("vol-info").arg(&z), "multiscales");
    assert!(!out.exists() && leftovers(d).is_empty());
    // An output name no tool writes: usage error before any work.
    let o = tool("vol-convert")
        .arg(fixture("nibabel_int16.nii.gz"))
        .arg("-o")
        .arg(d.join("a.jpg"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(!d.join("a.jpg").exists());
}

/// x + 10 y + 100 z + 1000 c + 5000 t over a stack.
fn tiff_values(nx: i64, ny: i64, nz: i64, c: i64, t: i64, f: impl Fn(i64) -> i64) -> Vec<f32> {
    let mut v = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                v.push(f(x + 10 * y + 100 * z + 1000 * c + 5000 * t) as f32);
            }
        }
    }
    v
}

#[test]
fn tifffile_ome_hyperstacks_and_zstd_int32() {
    // OME-TIFF: physical sizes, and one channel of ZCYX.
    // vol-info describes its first channel; vol-convert needs a pick.
    let p = fixture("tifffile_ome.ome.tif");
    let j = info(&p, &[]);
    assert_eq!(j["channels"], 2, "{j}");
    assert_eq!(j["channel"], 0, "{j}");
    let d = tempfile::tempdir().unwrap();
    let o = d.path().join("ome.nrrd");
    let e = fails(tool("vol-convert").arg(&p).arg("-o").arg(&o), "--channel");
    assert!(e.contains("ZCYX"), "{e}");
    let v = samples(&p, &["--channel", "1"]);
    assert_eq!(v, tiff_values(6, 8, 5, 1, 0, |v| v));
    ok(tool("vol-convert")
        .arg(&p)
        .args(["--channel", "1", "-q", "-o"])
        .arg(&o));
    let j = info(&o, &[]);
    assert!(close(&j["spacing"], &[0.25, 0.25, 1.5]), "{j}");
    // ImageJ hyperstack TZCYX: the error lists the axes; a pick reads one stack.
    let p = fixture("tifffile_hyperstack.tif");
    let e = fails(
        tool("vol-convert").arg(&p).arg("-o").arg(&o),
        "--channel C --time-point T",
    );
    assert!(e.contains("TZCYX"), "{e}");
    let v = samples(&p, &["--channel", "1", "--time-point", "1"]);
    assert_eq!(v, tiff_values(5, 6, 4, 1, 1, |v| v % 256));
    fails(
        tool("vol-convert")
            .arg(&p)
            .args(["--channel", "2", "--time-point", "0", "-o"])
            .arg(&o),
        "channels 0..1",
    );
    // zstd-compressed int32 pages: narrowed by their values (they fit f32 only).
    let p = fixture("tifffile_zstd_i32.tif");
    let j = info(&p, &[]);
    assert_eq!(j["dims"], serde_json::json!([5, 6, 3]));
    assert_eq!(j["type"], "f32");
    assert_eq!(samples(&p, &[]), tiff_values(5, 6, 3, 0, 0, |v| v - 70000));
}

/// What zarr-python and ome-zarr-py read from the OME-Zarr at `path`:
/// the NGFF version, the Zarr format, each level's shape, scale and
/// translation, a voxel, and the first voxel of level 1 with the mean of
/// the block of level 0 it stands for (the level's scale over level 0's
/// along each axis). `None` (with a note) when
/// python3 or a module is missing outside CI; CI installs them (.ci/run).
fn read_in_ome_zarr_py(path: &Path) -> Option<serde_json::Value> {
    let script = format!(
        r#"
import json, sys
try:
    import numpy as np
    import zarr
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Reader
except ImportError as e:
    print("SKIP", e); sys.exit(0)
path = {path:?}
loc = parse_url(path, mode="r")
image = list(Reader(loc)())[0]
ts = image.metadata["coordinateTransformations"]
pick = lambda level, kind: [t[kind] for t in level if t["type"] == kind][0]
a0 = np.asarray(image.data[0])
a1 = np.asarray(image.data[1])
f = [round(b / a) for a, b in zip(pick(ts[0], "scale"), pick(ts[1], "scale"))]
print(json.dumps({{
    "version": loc.version,
    "zarr_format": zarr.open_group(path, mode="r").metadata.zarr_format,
    "shapes": [list(d.shape) for d in image.data],
    "scales": [pick(t, "scale") for t in ts],
    "translations": [pick(t, "translation") for t in ts],
    "v": int(a0[9, 11, 15]),
    "l1": int(a1[0, 0, 0]),
    "l1_mean": float(a0[0:f[0], 0:f[1], 0:f[2]].astype(np.float64).mean()),
}}))
"#,
        path = path.to_string_lossy()
    );
    python_json(&script, "pip install zarr ome-zarr")
}

#[test]
fn ome_zarr_ngff_04_and_05_round_trip_and_read_in_ome_zarr_py() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let src = fixture("dicom_ct");
    // Default (no --ngff): NGFF 0.4 on Zarr v2.
    for (ngff, zarr_format) in [(None, 2), (Some("0.4"), 2), (Some("0.5"), 3)] {
        let z = d.join(format!("ct-{}.ome.zarr", ngff.unwrap_or("default")));
        let write = || {
            let mut c = tool("vol-convert");
            c.arg(&src).args(["--pyramid", "3", "-q", "-o"]).arg(&z);
            if let Some(v) = ngff {
                c.args(["--ngff", v]);
            }
            ok(&mut c);
        };
        write();
        let version = ngff.unwrap_or("0.4");
        let meta = if zarr_format == 2 {
            ".zgroup"
        } else {
            "zarr.json"
        };
        assert!(z.join(meta).is_file(), "{version}: no {meta}");
        // volkit reads both back with the geometry.
        let j = info(&z, &[]);
        assert!(
            j["format"].as_str().unwrap().starts_with("ome-zarr "),
            "{j}"
        );
        assert_eq!(j["dims"], serde_json::json!([16, 12, 10]));
        assert!(close(&j["spacing"], &[0.7, 0.8, 2.5]), "{j}");
        assert!(close(&j["origin"], &[-40.0, -30.0, 12.5]), "{j}");
        ok(tool("vol-psnr")
            .arg(&src)
            .arg(&z)
            .args(["--min-psnr", "inf", "-q"]));
        // A second run replaces the store (see
        // ome_zarr_output_replaces_an_earlier_store_whole), and
        write();
        // zarr-python and ome-zarr-py read what it wrote: the version, the
        // pyramid's levels, scale and translation per level, the values.
        let Some(j) = read_in_ome_zarr_py(&z) else {
            continue;
        };
        assert_eq!(j["version"], version, "{j}");
        assert_eq!(j["zarr_format"], zarr_format, "{j}");
        // z (2.5) is over twice as coarse as x (0.7): level 1 halves x
        // and y alone, level 2 all three.
        assert_eq!(
            j["shapes"],
            serde_json::json!([[10, 12, 16], [10, 6, 8], [5, 3, 4]]),
            "{j}"
        );
        assert!(close(&j["scales"][0], &[2.5, 0.8, 0.7]), "{j}");
        assert!(close(&j["scales"][1], &[2.5, 1.6, 1.4]), "{j}");
        assert!(close(&j["scales"][2], &[5.0, 3.2, 2.8]), "{j}");
        // A level's voxel sits at the centre of the voxels it covers.
        assert!(close(&j["translations"][0], &[12.5, -30.0, -40.0]), "{j}");
        assert!(close(&j["translations"][1], &[12.5, -29.6, -39.65]), "{j}");
        assert!(close(&j["translations"][2], &[13.75, -28.8, -38.95]), "{j}");
        assert_eq!(j["v"], 10 * (15 + 2 * 11 + 3 * 9) - 1024);
        let mean = j["l1_mean"].as_f64().unwrap();
        assert_eq!(j["l1"].as_f64().unwrap(), mean.round(), "{j}");
    }
    // --ngff is for OME-Zarr output only.
    let mut c = tool("vol-convert");
    c.arg(&src)
        .args(["--ngff", "0.5", "-o"])
        .arg(d.join("x.nrrd"));
    fails(&mut c, "--ngff applies to OME-Zarr output");
    assert_eq!(c.status().unwrap().code(), Some(2));
}

/// What ome-zarr-py reads from each level of the OME-Zarr at `path`:
/// its shape, scale and translation, whether its samples equal the raw
/// u16 file `raw[N]` (what volkit reads as level N), and the first voxel
/// of the last level with the mean of the full-resolution block it stands
/// for, rounded half away from zero.
fn levels_in_ome_zarr_py(path: &Path, raw: &[PathBuf]) -> Option<serde_json::Value> {
    let raw: Vec<String> = raw
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let script = format!(
        r#"
import json, math, sys
try:
    import numpy as np
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Reader
except ImportError as e:
    print("SKIP", e); sys.exit(0)
loc = parse_url({path:?}, mode="r")
image = list(Reader(loc)())[0]
ts = image.metadata["coordinateTransformations"]
pick = lambda level, kind: [t[kind] for t in level if t["type"] == kind][0]
raw = {raw:?}
levels = [np.asarray(d) for d in image.data]
equal = [bool(np.array_equal(a, np.fromfile(r, dtype="<u2").reshape(a.shape)))
         for a, r in zip(levels, raw)]
s0, sl = pick(ts[0], "scale"), pick(ts[-1], "scale")
f = [round(b / a) for a, b in zip(s0, sl)]
block = levels[0][0:f[0], 0:f[1], 0:f[2]].astype(np.float64)
print(json.dumps({{
    "shapes": [list(a.shape) for a in levels],
    "scales": [pick(t, "scale") for t in ts],
    "translations": [pick(t, "translation") for t in ts],
    "equal": equal,
    "last": int(levels[-1][0, 0, 0]),
    "last_mean": math.floor(block.mean() + 0.5),
}}))
"#,
        path = path.to_string_lossy()
    );
    python_json(&script, "pip install zarr ome-zarr")
}

/// Every level `vol-convert --pyramid` writes of anisotropic data reads
/// the same in ome-zarr-py as `--level N` reads it in volkit, with the
/// scale and translation `vol-info --level N` gives; a level is the mean
/// of the full-resolution voxels it stands for, rounded once.
#[test]
fn ome_zarr_levels_read_the_same_in_ome_zarr_py_and_with_level() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let src = d.join("a.vvol");
    ok(tool("vol-gen")
        .args(["noise", "--dims", "37,29,23", "--type", "u16"])
        .args(["--spacing", "0.5,0.5,2", "-q", "-o"])
        .arg(&src));
    for ngff in ["0.4", "0.5"] {
        let z = d.join(format!("a-{ngff}.ome.zarr"));
        ok(tool("vol-convert")
            .arg(&src)
            .args(["--pyramid", "5", "--ngff", ngff, "-q", "-o"])
            .arg(&z));
        // x and y halve alone until they reach z's 2, then all three.
        let want_dims = [
            [37, 29, 23],
            [19, 15, 23],
            [10, 8, 23],
            [5, 4, 12],
            [3, 2, 6],
        ];
        let want_spacing = [
            [0.5, 0.5, 2.0],
            [1.0, 1.0, 2.0],
            [2.0, 2.0, 2.0],
            [4.0, 4.0, 4.0],
            [8.0, 8.0, 8.0],
        ];
        let j = info(&z, &[]);
        assert_eq!(j["level"], 0, "{j}");
        assert_eq!(j["levels"].as_array().unwrap().len(), 5, "{j}");
        let mut raw = Vec::new();
        let mut origins = Vec::new();
        for n in 0..5 {
            let level = n.to_string();
            let j = info(&z, &["--level", &level]);
            assert_eq!(j["dims"], serde_json::json!(want_dims[n]), "{j}");
            assert!(close(&j["spacing"], &want_spacing[n]), "{j}");
            assert!(close(&j["levels"][n]["spacing"], &want_spacing[n]), "{j}");
            assert_eq!(j["levels"][n]["dims"], j["dims"], "{j}");
            assert_eq!(j["level"], n, "{j}");
            // Centred on the level-0 voxels it stands for.
            let f = [0, 1, 2].map(|a| want_spacing[n][a] / want_spacing[0][a]);
            let o = [0, 1, 2].map(|a| (f[a] - 1.0) / 2.0 * want_spacing[0][a]);
            assert!(close(&j["origin"], &o), "{j}");
            origins.push(o);
            let r = d.join(format!("l{n}.raw"));
            ok(tool("vol-convert")
                .arg(&z)
                .args(["--level", &level, "-q", "-o"])
                .arg(&r));
            raw.push(r);
        }
        let Some(j) = levels_in_ome_zarr_py(&z, &raw) else {
            continue;
        };
        assert_eq!(
            j["equal"],
            serde_json::json!([true, true, true, true, true]),
            "{ngff}: {j}"
        );
        for n in 0..5 {
            let w = want_dims[n];
            assert_eq!(j["shapes"][n], serde_json::json!([w[2], w[1], w[0]]), "{j}");
            let s = want_spacing[n];
            assert!(close(&j["scales"][n], &[s[2], s[1], s[0]]), "{j}");
            let o = origins[n];
            assert!(close(&j["translations"][n], &[o[2], o[1], o[0]]), "{j}");
        }
        // Level 4 stands for 16x16x4 voxels: their mean, rounded once.
        assert_eq!(j["last"], j["last_mean"], "{ngff}: {j}");
    }
}

/// `--level` picks a level of an OME-Zarr pyramid in every tool that
/// reads volumes; any other input refuses it as a usage error naming the
/// file, and a level past the last is refused naming the file and how
/// many levels it has.
#[test]
fn level_is_refused_by_inputs_without_levels_and_past_the_last() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let (gen, src, z) = (d.join("a.vvol"), d.join("a.nrrd"), d.join("a.ome.zarr"));
    ok(tool("vol-gen")
        .args(["noise", "--dims", "24,20,18", "-q", "-o"])
        .arg(&gen));
    ok(tool("vol-convert").arg(&gen).args(["-q", "-o"]).arg(&src));
    ok(tool("vol-convert")
        .arg(&src)
        .args(["--pyramid", "3", "-q", "-o"])
        .arg(&z));
    let out = d.join("o.nrrd");
    let png = d.join("o.png");
    let vidx = d.join("o.vidx");
    let runs: [(&str, Vec<&std::ffi::OsStr>); 5] = [
        ("vol-info", vec![]),
        ("vol-convert", vec!["-o".as_ref(), out.as_os_str()]),
        ("vol-index", vec!["-o".as_ref(), vidx.as_os_str()]),
        (
            "vol-render",
            vec![
                "--size".as_ref(),
                "16x16".as_ref(),
                "-o".as_ref(),
                png.as_os_str(),
            ],
        ),
        ("vol-psnr", vec![]),
    ];
    for (name, extra) in &runs {
        let with = |input: &Path, level: &str| {
            let mut c = tool(name);
            c.arg(input);
            if *name == "vol-psnr" {
                c.arg(input);
            }
            c.args(["--level", level]).args(extra);
            c
        };
        let mut c = with(&src, "1");
        let e = fails(&mut c, "a nrrd input has no pyramid levels");
        assert!(
            e.contains("a.nrrd") && e.contains("--level 1"),
            "{name}: {e}"
        );
        assert_eq!(c.status().unwrap().code(), Some(2), "{name}");
        let mut c = with(&z, "3");
        let e = fails(&mut c, "the pyramid has 3 levels (0..2)");
        assert!(e.contains("a.ome.zarr"), "{name}: {e}");
        ok(&mut with(&z, "2"));
    }
    // A level's array named as the input: the store and --level to use.
    fails(
        tool("vol-info").arg(z.join("1")),
        "is level 1 of the OME-Zarr pyramid",
    );
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// An OME-Zarr output replaces an earlier OME-Zarr store as a file output
/// replaces a file (docs/OUTPUTS.md): whole, in one swap, nothing of the
/// old store left in it or beside it; any other directory, and a file,
/// are refused and left as they were.
#[test]
fn ome_zarr_output_replaces_an_earlier_store_whole() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let (a, b) = (d.join("a.vvol"), d.join("b.vvol"));
    ok(tool("vol-gen")
        .args(["shapes", "--dims", "40,30,20", "-q", "-o"])
        .arg(&a));
    ok(tool("vol-gen")
        .args(["noise", "--dims", "24,20,18", "--type", "u16", "-q", "-o"])
        .arg(&b));
    let want = samples(&b, &[]);
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    let z = out.join("v.ome.zarr");
    for (first, second) in [("0.4", "0.5"), ("0.5", "0.4"), ("0.4", "0.4")] {
        ok(tool("vol-convert")
            .arg(&a)
            .args(["--pyramid", "3", "--ngff", first, "-q", "-o"])
            .arg(&z));
        ok(tool("vol-convert")
            .arg(&b)
            .args(["--pyramid", "2", "--ngff", second, "-q", "-o"])
            .arg(&z));
        let j = info(&z, &[]);
        assert!(
            j["format"].as_str().unwrap().starts_with("ome-zarr "),
            "{first} -> {second}: {j}"
        );
        assert_eq!(j["dims"], serde_json::json!([24, 20, 18]));
        assert_eq!(j["type"], "u16");
        assert_eq!(samples(&z, &[]), want, "{first} -> {second}");
        // Nothing of the first store: its third level, the other
        // version's metadata.
        assert!(!z.join("2").exists(), "{first} -> {second}");
        let stale = if second == "0.5" {
            ".zattrs"
        } else {
            "zarr.json"
        };
        assert!(!z.join(stale).exists(), "{first} -> {second}");
        // Nothing beside it: no staging directory, no old store.
        assert_eq!(names(&out), ["v.ome.zarr"], "{first} -> {second}");
        if let Some(j) = read_in_ome_zarr_py(&z) {
            assert_eq!(j["version"], second, "{j}");
            assert_eq!(
                j["shapes"],
                serde_json::json!([[18, 20, 24], [9, 10, 12]]),
                "{j}"
            );
            assert_eq!(
                j["v"].as_f64(),
                Some(want[9 * 20 * 24 + 11 * 24 + 15] as f64)
            );
        }
    }
    // A directory that is no OME-Zarr image, and a file, are refused.
    let other = out.join("other.ome.zarr");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("notes.txt"), b"mine").unwrap();
    fails(
        tool("vol-convert").arg(&b).arg("-o").arg(&other),
        "is no OME-Zarr image to replace",
    );
    assert_eq!(names(&other), ["notes.txt"]);
    let file = out.join("file.ome.zarr");
    std::fs::write(&file, b"x").unwrap();
    fails(
        tool("vol-convert").arg(&b).arg("-o").arg(&file),
        "exists and is not a directory",
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
    assert_eq!(
        names(&out),
        ["file.ome.zarr", "other.ome.zarr", "v.ome.zarr"]
    );
}

/// The qform and sform codes of a NIfTI-1 header file (uncompressed).
fn nifti_codes(path: &Path) -> (i16, i16) {
    let b = std::fs::read(path).unwrap();
    (
        i16::from_le_bytes([b[252], b[253]]),
        i16::from_le_bytes([b[254], b[255]]),
    )
}

#[test]
fn nifti_outputs_keep_the_inputs_qform_and_sform_codes() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // nibabel wrote qform 1 (scanner) and sform 2 (aligned), one affine.
    let src = fixture("nibabel_int16.nii.gz");
    let a = d.join("a.nii");
    ok(tool("vol-convert").arg(&src).arg("-q").arg("-o").arg(&a));
    assert_eq!(nifti_codes(&a), (1, 2));
    // From an uncompressed NIfTI (the other reader), cropped and flipped:
    // the same space.
    let b = d.join("b.hdr");
    ok(tool("vol-convert")
        .arg(&a)
        .args(["--crop", "1:7,:,:", "--flip", "z", "-q", "-o"])
        .arg(&b));
    assert_eq!(nifti_codes(&b), (1, 2));
    assert!(close(&info(&b, &[])["origin"], &[-9.5, 20.0, 37.5]));
    // Another format has no code: scanner coordinates, as before.
    let c = d.join("c.nii");
    ok(tool("vol-convert")
        .arg(fixture("dicom_ct"))
        .arg("-q")
        .arg("-o")
        .arg(&c));
    assert_eq!(nifti_codes(&c), (1, 1));
}

#[test]
fn more_pyramid_levels_than_the_volume_makes_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let src = d.join("v.vvol");
    ok(tool("vol-gen")
        .args(["noise", "--dims", "64,64,20", "-q", "-o"])
        .arg(&src));
    let z = d.join("v.ome.zarr");
    // 64 halves to 32, 16, 8, 4, 2: six levels, the last 2x2x1.
    let e = fails(
        tool("vol-convert")
            .arg(&src)
            .args(["--pyramid", "9", "-o"])
            .arg(&z),
        "at most 6 pyramid levels",
    );
    assert!(e.contains("v.ome.zarr") && e.contains("2x2x1"), "{e}");
    assert!(!z.exists());
    ok(tool("vol-convert")
        .arg(&src)
        .args(["--pyramid", "6", "-q", "-o"])
        .arg(&z));
    assert!(z.join("5").is_dir() && !z.join("6").exists());
    // Sharded writes check the same way.
    fails(
        tool("vol-convert")
            .arg(&src)
            .args(["--pyramid", "7", "--shard", "0/2", "-o"])
            .arg(d.join("s.ome.zarr")),
        "at most 6",
    );
    assert!(leftovers(d).is_empty());
}

/// What SimpleITK's ImageSeriesReader reads from series `uid` of `dir`:
/// size, spacing, origin, direction (LPS, rows) and the voxels, x fastest.
/// `None` (with a note) when python3 or SimpleITK is missing outside CI;
/// CI installs them (.ci/run).
fn read_in_simpleitk(dir: &Path, uid: &str) -> Option<serde_json::Value> {
    let script = format!(
        r#"
import json, sys
try:
    import SimpleITK as sitk
except ImportError as e:
    print("SKIP", e); sys.exit(0)
files = sitk.ImageSeriesReader.GetGDCMSeriesFileNames({dir:?}, {uid:?})
r = sitk.ImageSeriesReader()
r.SetFileNames(files)
img = r.Execute()
print(json.dumps({{
    "ids": list(sitk.ImageSeriesReader.GetGDCMSeriesIDs({dir:?})),
    "size": list(img.GetSize()),
    "spacing": list(img.GetSpacing()),
    "origin": list(img.GetOrigin()),
    "direction": list(img.GetDirection()),
    "values": [float(v) for v in sitk.GetArrayViewFromImage(img).ravel()],
}}))
"#,
        dir = dir.to_string_lossy()
    );
    python_json(&script, "pip install SimpleITK")
}

const PACS_CT: &str = "1.2.826.0.1.3680043.8.498.40";
const PACS_MR: &str = "1.2.826.0.1.3680043.8.498.41";

#[test]
fn pacs_folder_lists_its_series_and_skips_what_holds_no_image() {
    let p = fixture("dicom_pacs");
    // Two series, an SR, a presentation state and a DICOMDIR: a table of
    // the series, then one of the files skipped, each with its reason.
    let o = tool("vol-info").arg(&p).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let (series, files) = text
        .split_once("  3 files skipped:\n")
        .expect("a skipped table");
    assert_eq!(
        files
            .lines()
            .map(str::split_whitespace)
            .map(|w| w.collect::<Vec<_>>().join(" "))
            .collect::<Vec<_>>(),
        vec![
            "FILE REASON",
            "DICOMDIR holds no image: DICOMDIR",
            "PR000001.dcm holds no image: Grayscale Softcopy Presentation State Storage",
            "SR000001.dcm holds no image: Basic Text SR Storage",
        ],
        "{text}"
    );
    let rows: Vec<Vec<&str>> = series
        .lines()
        .skip(2)
        .map(|l| {
            l.split("  ")
                .filter(|c| !c.is_empty())
                .map(str::trim)
                .collect()
        })
        .collect();
    assert_eq!(
        rows,
        vec![
            vec!["3", PACS_CT, "3", "Axial 2.0", "CT", "4", "6x5x4", "1"],
            vec!["7", PACS_MR, "7", "Axial T1", "MR", "3", "5x4x3", "1"],
        ],
        "{text}"
    );
    // The same list in JSON.
    let j = info(&p, &[]);
    assert_eq!(
        j["skipped"][0],
        serde_json::json!({"file": "DICOMDIR", "kind": "no-image", "reason": "holds no image: DICOMDIR"})
    );
    assert_eq!(j["skipped"].as_array().unwrap().len(), 3);
    assert_eq!(
        j["series"],
        serde_json::json!([
            {"id": "3", "uid": PACS_CT, "number": 3, "sub": null, "description": "Axial 2.0", "modality": "CT", "images": 4, "dims": [6, 5, 4], "time_points": 1, "echoes": 1, "time_step": null, "volumes": "", "problem": null},
            {"id": "7", "uid": PACS_MR, "number": 7, "sub": null, "description": "Axial T1", "modality": "MR", "images": 3, "dims": [5, 4, 3], "time_points": 1, "echoes": 1, "time_step": null, "volumes": "", "problem": null},
        ])
    );
    // vol-convert needs a pick, and names the candidates.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o.nrrd");
    let e = fails(tool("vol-convert").arg(&p).arg("-o").arg(&out), "--series");
    assert!(
        e.contains(PACS_CT) && e.contains(PACS_MR) && e.contains("#7"),
        "{e}"
    );
    // A prefix both UIDs share, and a number no series has that is a
    // prefix of both: one line listing the candidates.
    for sel in ["1.2.826.0.1.3680043.8.498.4", "1"] {
        let e = fails(
            tool("vol-info").arg(&p).args(["--series", sel]),
            "ambiguous",
        );
        assert!(e.contains(PACS_CT) && e.contains(PACS_MR), "{e}");
    }
    fails(
        tool("vol-convert")
            .arg(&p)
            .args(["--series", "8", "-o"])
            .arg(&out),
        "no series 8",
    );
    // Picked by number, the skipped files are counted on stderr.
    let o = tool("vol-convert")
        .arg(&p)
        .args(["--series", "7", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("skipped 3 files"), "{err}");
    assert_eq!(info(&out, &[])["dims"], serde_json::json!([5, 4, 3]));
    // Nothing but objects without images: refused, naming the folder.
    let none = d.path().join("no-images");
    std::fs::create_dir(&none).unwrap();
    for f in ["DICOMDIR", "SR000001.dcm", "PR000001.dcm"] {
        std::fs::copy(p.join(f), none.join(f)).unwrap();
    }
    let e = fails(tool("vol-info").arg(&none), "no readable DICOM series");
    assert!(
        e.contains("no-images") && e.contains("3 files") && e.contains("first: DICOMDIR"),
        "{e}"
    );
}

#[test]
fn pacs_folder_series_read_like_simpleitk_reads_them() {
    let p = fixture("dicom_pacs");
    // The number, the whole UID and a unique prefix each pick a series.
    for (sel, uid) in [
        ("3", PACS_CT),
        (PACS_MR, PACS_MR),
        ("1.2.826.0.1.3680043.8.498.40", PACS_CT),
        ("7", PACS_MR),
    ] {
        let j = info(&p, &["--series", sel]);
        let v = samples(&p, &["--series", sel]);
        let Some(s) = read_in_simpleitk(&p, uid) else {
            return;
        };
        assert_eq!(s["ids"], serde_json::json!([PACS_CT, PACS_MR]), "{s}");
        assert_eq!(j["dims"], s["size"], "{sel}");
        let want = |k: &str| -> Vec<f64> {
            s[k].as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        };
        for key in ["spacing", "origin", "direction"] {
            assert!(
                close(&j[key], &want(key)),
                "{sel} {key}: {} vs {}",
                j[key],
                s[key]
            );
        }
        let got: Vec<f64> = v.iter().map(|&x| x as f64).collect();
        assert_eq!(got, want("values"), "{sel}: voxels differ from SimpleITK's");
    }
}

#[test]
fn dicom_globs_are_dicom_series_in_both_tools() {
    let d = tempfile::tempdir().unwrap();
    for (glob, want) in [
        (
            fixture("dicom_ct").join("*.dcm"),
            "dicom series (CT, 10 images)",
        ),
        (
            fixture("dicom_pacs").join("MR*.dcm"),
            "dicom series (MR, 3 images)",
        ),
    ] {
        let i = info(&glob, &[]);
        let c = json(&ok(tool("vol-convert")
            .arg(&glob)
            .arg("--json")
            .arg("-o")
            .arg(d.path().join("o.nrrd"))));
        assert_eq!(i["format"], want);
        assert_eq!(c["format"], want);
        std::fs::remove_file(d.path().join("o.nrrd")).unwrap();
    }
    // A directory reads with the same words.
    assert_eq!(
        info(&fixture("dicom_ct"), &[])["format"],
        "dicom series (CT, 10 images)"
    );
}

/// Issue 53 §6: vol-info names a file's format as vol-convert does
/// (`nifti-1 (nii, gzip)`, not `nifti`), for every format it writes.
#[test]
fn every_format_is_named_alike_in_both_tools() {
    let d = tempfile::tempdir().unwrap();
    let src = d.path().join("src.vvol");
    ok(tool("vol-gen")
        .args(["ramp", "--dims", "6,5,4", "--type", "u16", "-q", "-o"])
        .arg(&src));
    for name in [
        "a.nii.gz",
        "a.nii",
        "a.nrrd",
        "a.mhd",
        "a.mha",
        "a.tif",
        "a.vvol",
        "a_6x5x4_uint16.raw",
        "a.vol",
        "a.ome.zarr",
    ] {
        let p = d.path().join(name);
        let mut convert = tool("vol-convert");
        convert.arg(&src).args(["-q", "-o"]).arg(&p);
        if name == "a.vol" {
            convert.args(["--type", "u8", "--window", "0:255"]);
        }
        ok(&mut convert);
        let i = info(&p, &[]);
        let c = json(&ok(tool("vol-convert")
            .arg(&p)
            .arg("--json")
            .arg("-o")
            .arg(d.path().join("back.nrrd"))));
        assert_eq!(i["format"], c["format"], "{name}");
    }
}

/// `n` f64 values none of which is an f32 value (tenths plus a little).
fn f64_values(n: usize) -> Vec<f64> {
    (0..n).map(|i| i as f64 / 10.0 + 1e-9 * i as f64).collect()
}

fn f64_raw(d: &Path, name: &str, vals: &[f64]) -> PathBuf {
    let p = d.join(name);
    let b: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&p, b).unwrap();
    p
}

#[test]
fn f64_is_kept_exactly_through_vvol_and_every_format_that_has_it() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let vals = f64_values(12 * 10 * 8);
    let input = f64_raw(d, "in_12x10x8_float64.raw", &vals);
    let input_bytes = std::fs::read(&input).unwrap();
    // Into .vvol, sliced and bricked with zstd: stored as f64, no note.
    for (name, layout) in [
        ("s.vvol", &[][..]),
        (
            "b.vvol",
            &["--layout", "bricked:8", "--compress", "zstd:3"][..],
        ),
    ] {
        let v = d.join(name);
        let o = crate::common::run(
            tool("vol-convert")
                .arg(&input)
                .args(layout)
                .arg("-o")
                .arg(&v),
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(!err.contains("f32"), "nothing is narrowed: {err}");
        let j = info(&v, &[]);
        assert_eq!(j["type"], "f64", "{j}");
        // And back to raw: the same bytes.
        let back = d.join(format!("{name}_12x10x8_float64.raw"));
        ok(tool("vol-convert").arg(&v).args(["-q", "-o"]).arg(&back));
        assert!(std::fs::read(&back).unwrap() == input_bytes, "{name}");
    }
    // From .vvol into every writer that has f64: read back by the
    // anchors (nibabel, SimpleITK, tifffile, zarr) bit for bit.
    let outs = [
        "o.nii",
        "o.nii.gz",
        "o.nrrd",
        "o.mha",
        "o.tif",
        "o.ome.zarr",
    ];
    for o in outs {
        ok(tool("vol-convert")
            .arg(d.join("b.vvol"))
            .args(["-q", "-o"])
            .arg(d.join(o)));
    }
    let script = format!(
        r#"
import json, sys
try:
    import numpy as np, nibabel, SimpleITK as sitk, tifffile, zarr
except ImportError as e:
    print("SKIP:", e); sys.exit(0)
d = {d:?}
ref = np.fromfile(d + "/in_12x10x8_float64.raw", dtype="<f8").reshape(8, 10, 12)
def z(p):
    g = zarr.open_group(p, mode="r")
    return np.asarray(g["0"]).squeeze()
got = {{
    "o.nii": np.asanyarray(nibabel.load(d + "/o.nii").dataobj).T,
    "o.nii.gz": np.asanyarray(nibabel.load(d + "/o.nii.gz").dataobj).T,
    "o.nrrd": sitk.GetArrayFromImage(sitk.ReadImage(d + "/o.nrrd")),
    "o.mha": sitk.GetArrayFromImage(sitk.ReadImage(d + "/o.mha")),
    "o.tif": tifffile.imread(d + "/o.tif"),
    "o.ome.zarr": z(d + "/o.ome.zarr"),
}}
print(json.dumps({{k: [str(a.dtype), list(a.shape) == list(ref.shape) and bool(np.array_equal(a, ref))] for k, a in got.items()}}))
"#,
        d = d.display().to_string()
    );
    let Some(j) = python_json(&script, "pip install numpy nibabel SimpleITK tifffile zarr") else {
        return;
    };
    for o in outs {
        assert_eq!(j[o], serde_json::json!(["float64", true]), "{o}: {j}");
    }
    // And volkit reads each back exactly.
    for o in outs {
        let back = d.join(format!("{o}_12x10x8_float64.raw"));
        ok(tool("vol-convert")
            .arg(d.join(o))
            .args(["-q", "-o"])
            .arg(&back));
        assert!(std::fs::read(&back).unwrap() == input_bytes, "{o}");
    }
}

#[test]
fn f64_narrowed_to_f32_says_the_largest_change_and_renders_like_f32() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let vals = f64_values(32 * 32 * 32);
    let input = f64_raw(d, "in_32x32x32_float64.raw", &vals);
    let want = vals
        .iter()
        .map(|&v| (v as f32 as f64 - v).abs())
        .fold(0.0, f64::max);
    let said = format!("largest change is {want:.3e}");
    // --type f32 rounds and says by how much.
    let f32_vol = d.join("f32.vvol");
    let o = crate::common::run(
        tool("vol-convert")
            .arg(&input)
            .args(["--type", "f32", "-o"])
            .arg(&f32_vol),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("f64 values rounded to f32") && err.contains(&said),
        "{said}: {err}"
    );
    // Halves are f32 values: nothing to say.
    let halves: Vec<f64> = (0..64).map(|i| i as f64 / 2.0).collect();
    let exact = f64_raw(d, "halves_4x4x4_float64.raw", &halves);
    let o = crate::common::run(
        tool("vol-convert")
            .arg(&exact)
            .args(["--type", "f32", "-o"])
            .arg(d.join("h.vvol")),
    );
    assert!(!String::from_utf8_lossy(&o.stderr).contains("rounded"));
    // The renderer reads an f64 .vvol (and the raw f64 file) through its
    // f32 path: said once, and the image is the f32 volume's, bit for bit.
    let f64_vol = d.join("f64.vvol");
    ok(tool("vol-convert")
        .arg(&input)
        .args(["-q", "-o"])
        .arg(&f64_vol));
    let render = |v: &Path, png: &str| {
        let out = d.join(png);
        let o = crate::common::run(
            tool("vol-render")
                .arg(v)
                .arg("-o")
                .arg(&out)
                .args(["--size", "48x40", "--mode", "mip"]),
        );
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{err}");
        (std::fs::read(&out).unwrap(), err)
    };
    let (a, _) = render(&f32_vol, "a.png");
    for (v, png) in [(&f64_vol, "b.png"), (&input, "c.png")] {
        let (b, err) = render(v, png);
        assert!(
            err.contains("f64 values rounded to f32") && err.contains(&said),
            "{err}"
        );
        assert!(a == b, "{png}: f64 renders as its f32 rounding");
    }
    // Past f32's range: the renderer still reads it (the value becomes
    // infinite, and the change is said), whether the file is mapped (raw)
    // or decoded slice by slice (.nii.gz), and names no flag it lacks.
    let mut huge = halves.clone();
    huge[21] = 1e300;
    let raw = f64_raw(d, "huge_4x4x4_float64.raw", &huge);
    let gz = d.join("huge.nii.gz");
    ok(tool("vol-convert").arg(&raw).args(["-q", "-o"]).arg(&gz));
    for v in [&raw, &gz] {
        let (_, err) = render(v, "huge.png");
        assert!(err.contains("largest change is inf"), "{err}");
    }
}

#[test]
fn gzip_levels_trade_size_for_time_and_read_back_alike() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let v = d.join("p.vvol");
    ok(tool("vol-gen")
        .args(["phantom", "--dims", "96,96,64", "-q", "-o"])
        .arg(&v));
    let mut sizes = Vec::new();
    for (name, c) in [
        ("l1.nii.gz", Some("gzip:1")),
        ("l6.nii.gz", None),
        ("l9.nii.gz", Some("gzip:9")),
    ] {
        let o = d.join(name);
        let mut cmd = tool("vol-convert");
        cmd.arg(&v).args(["-q", "-o"]).arg(&o);
        if let Some(c) = c {
            cmd.args(["--compress", c]);
        }
        ok(&mut cmd);
        sizes.push(std::fs::metadata(&o).unwrap().len());
        ok(tool("vol-psnr")
            .arg(&v)
            .arg(&o)
            .args(["--min-psnr", "inf", "-q"]));
    }
    assert!(sizes[0] > sizes[1] && sizes[1] >= sizes[2], "{sizes:?}");
    // NRRD data too; an out-of-range level is a usage error naming it.
    ok(tool("vol-convert")
        .arg(&v)
        .args(["--compress", "gzip:1", "-q", "-o"])
        .arg(d.join("p.nrrd")));
    let mut c = tool("vol-convert");
    c.arg(&v)
        .args(["--compress", "gzip:10", "-o"])
        .arg(d.join("x.nrrd"));
    fails(&mut c, "gzip level must be 1..=9");
    assert_eq!(c.status().unwrap().code(), Some(2));
}
