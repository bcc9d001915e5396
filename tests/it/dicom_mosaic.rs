//! Siemens mosaics (issue 64 §1): one image holding a volume's slices as
//! tiles. Unpacked into slices with the position corrected for the tile
//! grid and the slices stacked along the CSA header's slice normal, as
//! dcm2niix does; a mosaic that cannot be unpacked is refused, never
//! written as one 2D image.

use crate::common::{fails, python_json, tool};
use crate::dicom::{convert, ct_slice, info_json, skipped, us, DataSet, COLS, EXPLICIT_LE, ROWS};
use std::path::PathBuf;
use volformats::dicom::csa::write_csa2;

/// A 2x2 mosaic of `tiles` CT-sized tiles (COLS x ROWS each), 2.5 mm
/// apart along `normal`; tile k's pixel (x, y) is 1000 k + 10 y + x.
fn mosaic(tiles: u32, normal: &str) -> DataSet {
    let (w, h) = (2 * COLS as u32, 2 * ROWS as u32);
    let pixels: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            let k = (y / ROWS as u32) * 2 + x / COLS as u32;
            let v = 1000 * k + 10 * (y % ROWS as u32) + x % COLS as u32;
            (v as u16).to_le_bytes()
        })
        .collect();
    let normal: Vec<&str> = normal.split(',').collect();
    let count = tiles.to_string();
    ct_slice(0)
        .set(0x0008_0008, b"CS", "ORIGINAL\\PRIMARY\\M\\ND\\MOSAIC")
        .set(0x0018_0088, b"DS", "2.5")
        .set(0x0028_0010, b"US", us(h as u16))
        .set(0x0028_0011, b"US", us(w as u16))
        .set(0x0028_1052, b"DS", "0")
        .set(0x0029_0010, b"LO", "SIEMENS CSA HEADER")
        .set(
            0x0029_1010,
            b"OB",
            write_csa2(&[
                ("NumberOfImagesInMosaic", &[count.as_str()]),
                ("SliceNormalVector", &normal),
            ]),
        )
        .set(0x7fe0_0010, b"OW", pixels)
}

fn folder(dir: PathBuf, file: DataSet) -> PathBuf {
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mosaic.dcm"), file.file(EXPLICIT_LE)).unwrap();
    dir
}

fn samples(raw: &[u8]) -> Vec<u16> {
    raw.chunks(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect()
}

#[test]
fn a_mosaic_is_unpacked_into_its_tiles_at_their_corrected_positions() {
    let d = tempfile::tempdir().unwrap();
    let up = folder(d.path().join("up"), mosaic(3, "0,0,1"));
    let j = info_json(&up, &[]);
    // Three tiles of the 2x2 grid (the fourth is empty), not an 8x6 image.
    assert_eq!(j["dims"], serde_json::json!([4, 3, 3]), "{j}");
    // The first tile's corner: half the frame less one tile along x
    // (2 x 0.5 mm) and y (1.5 x 0.5 mm) from the frame's.
    assert_eq!(j["origin"], serde_json::json!([-9.0, -19.25, 0.0]), "{j}");
    assert_eq!(j["spacing"], serde_json::json!([0.5, 0.5, 2.5]), "{j}");
    let (raw, _) = convert(&up, &[]);
    let v = samples(&raw);
    let at = |x: usize, y: usize, z: usize| v[(z * ROWS as usize + y) * COLS as usize + x];
    assert_eq!((at(0, 0, 0), at(3, 2, 0)), (0, 23));
    assert_eq!((at(0, 0, 1), at(1, 2, 2)), (1000, 2021));
    // Tiles stacked against the image normal: the last tile is lowest,
    // so it is slice 0 of the volume.
    let down = folder(d.path().join("down"), mosaic(3, "0,0,-1"));
    let j = info_json(&down, &[]);
    assert_eq!(j["origin"], serde_json::json!([-9.0, -19.25, -5.0]), "{j}");
    let (raw, _) = convert(&down, &[]);
    assert_eq!(samples(&raw)[0], 2000);
}

#[test]
fn a_mosaic_that_cannot_be_unpacked_is_refused_with_its_reason() {
    let d = tempfile::tempdir().unwrap();
    let cut = {
        let m = mosaic(3, "0,0,1");
        let csa = m.get(0x0029_1010);
        m.set(0x0029_1010, b"OB", &csa[..csa.len() / 2])
    };
    for (name, file, why) in [
        (
            "no-csa",
            mosaic(3, "0,0,1").without(0x0029_1010),
            "no Siemens CSA image header (0029,1010)",
        ),
        ("cut-csa", cut, "its CSA header (0029,1010) ends at"),
        (
            "no-normal",
            mosaic(3, "0,0,1").set(
                0x0029_1010,
                b"OB",
                write_csa2(&[("NumberOfImagesInMosaic", &["3"])]),
            ),
            "no SliceNormalVector",
        ),
        (
            "tilted-normal",
            mosaic(3, "0,0.5,0.8"),
            "does not stand on the image plane",
        ),
        (
            "odd-grid",
            mosaic(3, "0,0,1").set(0x0028_0011, b"US", us(2 * COLS + 1)),
            "does not divide into a 2x2 grid",
        ),
        (
            "too-many",
            mosaic(5, "0,0,1"),
            "does not divide into a 3x3 grid of 5 tiles",
        ),
    ] {
        let dir = folder(d.path().join(name), file);
        // Alone, the folder has no series: both tools say why in one line.
        let err = fails(tool("vol-info").arg(&dir), "mosaic.dcm: a Siemens mosaic");
        assert!(err.contains(why), "{name}: {err}");
        let err = fails(
            tool("vol-convert")
                .arg(&dir)
                .arg("-o")
                .arg(d.path().join(format!("{name}.nii"))),
            "cannot be unpacked",
        );
        assert!(err.contains(why), "{name}: {err}");
        // Beside a readable series, it is listed as skipped.
        std::fs::write(dir.join("ct.dcm"), ct_slice(0).file(EXPLICIT_LE)).unwrap();
        let j = info_json(&dir, &[]);
        assert_eq!(
            skipped(&j),
            vec![("mosaic.dcm".to_string(), "unsupported".to_string())],
            "{name}: {j}"
        );
        assert!(!d.path().join(format!("{name}.nii")).exists());
    }
}

/// nibabel's two Siemens DWI mosaics (b = 0 and 1000: 48 tiles of
/// 128x128 in a 7x7 grid of 896x896, slightly oblique), given distinct
/// pixels (nibabel ships them zeroed), against dcm2niix's 4D NIfTI of
/// the same files: each volume's affine and values in world space.
#[test]
fn siemens_dwi_mosaics_equal_dcm2niix_in_world_space() {
    let d = tempfile::tempdir().unwrap();
    let (input, reference) = (d.path().join("in"), d.path().join("ref"));
    std::fs::create_dir_all(&input).unwrap();
    std::fs::create_dir_all(&reference).unwrap();
    let prepare = format!(
        r#"
import gzip, io, json, os, shutil, subprocess, sys
try:
    import nibabel, numpy as np, pydicom
except ImportError as e:
    print("SKIP", e); sys.exit(0)
if shutil.which("dcm2niix") is None:
    print("SKIP dcm2niix is not installed"); sys.exit(0)
data = os.path.join(os.path.dirname(nibabel.__file__), "nicom", "tests", "data")
for seed, name in enumerate(["siemens_dwi_0", "siemens_dwi_1000"]):
    with gzip.open(os.path.join(data, name + ".dcm.gz")) as f:
        ds = pydicom.dcmread(io.BytesIO(f.read()))
    n = ds.Rows * ds.Columns
    px = (np.arange(n, dtype=np.uint64) * 7919 + 1013 * seed) % 4093
    ds.PixelData = px.astype(np.uint16).tobytes()
    ds.save_as(os.path.join({input:?}, name + ".dcm"))
subprocess.run(["dcm2niix", "-z", "n", "-f", "ref", "-o", {reference:?}, {input:?}],
               check=True, capture_output=True)
print(json.dumps({{"shape": list(nibabel.load(os.path.join({reference:?}, "ref.nii")).shape)}}))
"#,
        input = input.to_string_lossy(),
        reference = reference.to_string_lossy(),
    );
    let Some(j) = python_json(
        &prepare,
        "pip install nibabel pydicom; apt install dcm2niix",
    ) else {
        return;
    };
    assert_eq!(j["shape"], serde_json::json!([128, 128, 48, 2]), "{j}");
    let text = crate::common::ok(tool("vol-info").arg(&input));
    assert!(
        text.contains("128x128x48") && text.contains("time points: 2"),
        "{text}"
    );
    for t in 0..2 {
        let out = d.path().join(format!("v{t}.nii"));
        crate::common::ok(
            tool("vol-convert")
                .arg(&input)
                .args(["--time-point", &t.to_string(), "-o"])
                .arg(&out),
        );
        let compare = format!(
            r#"
import json, nibabel as nib, numpy as np
ref = nib.as_closest_canonical(nib.load({reference:?} + "/ref.nii"))
got = nib.as_closest_canonical(nib.load({out:?}))
a, b = got.get_fdata(), ref.get_fdata()[..., {t}]
print(json.dumps({{"shape": list(a.shape), "affine": float(np.abs(got.affine - ref.affine).max()),
                  "values": float(np.abs(a - b).max()), "max": float(b.max())}}))
"#,
            reference = reference.to_string_lossy(),
            out = out.to_string_lossy(),
        );
        let j = python_json(&compare, "pip install nibabel").unwrap();
        assert_eq!(j["shape"], serde_json::json!([128, 128, 48]), "{j}");
        assert!(j["affine"].as_f64().unwrap() < 1e-3, "t {t}: {j}");
        assert_eq!(j["values"].as_f64(), Some(0.0), "t {t}: {j}");
        assert!(j["max"].as_f64().unwrap() > 4000.0, "{j}");
    }
}
