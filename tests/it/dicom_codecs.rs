//! Compressed DICOM pixel data as PACS archives store it (issue 64):
//! JPEG-LS (lossless and near-lossless) and JPEG 2000 (reversible and
//! irreversible), decoded to the values pydicom with pylibjpeg decodes,
//! and a byte-written CT series recompressed by GDCM and DCMTK decoding
//! to the uncompressed series bit for bit.

use crate::common::{ok, python_json, tool};
use crate::dicom::{convert, ct_slice, info_json, us, EXPLICIT_LE};
use std::path::Path;
use std::process::Command;

/// The values pydicom (with pylibjpeg's codecs) decodes from `file`,
/// rescaled, against volkit's conversion of it to raw samples of `ty`.
fn compare_with_pydicom(file: &Path, raw: &Path, ty: &str) -> Option<serde_json::Value> {
    let script = format!(
        r#"
import json, sys
try:
    import numpy as np, pydicom, pylibjpeg
    import libjpeg, openjpeg
except ImportError as e:
    print("SKIP", e); sys.exit(0)
ds = pydicom.dcmread({file:?})
want = ds.pixel_array.astype(np.float64)
want = want * float(getattr(ds, "RescaleSlope", 1)) + float(getattr(ds, "RescaleIntercept", 0))
types = {{"u8": "<u1", "i8": "<i1", "u16": "<u2", "i16": "<i2", "i32": "<i4", "f32": "<f4", "f64": "<f8"}}
got = np.fromfile({raw:?}, dtype=types[{ty:?}]).astype(np.float64).reshape(want.shape)
print(json.dumps({{"diff": float(np.abs(got - want).max()), "range": float(want.max() - want.min()),
                  "syntax": str(ds.file_meta.TransferSyntaxUID.name)}}))
"#,
        file = file.to_string_lossy(),
        raw = raw.to_string_lossy(),
    );
    python_json(
        &script,
        "pip install pydicom pylibjpeg pylibjpeg-libjpeg pylibjpeg-openjpeg",
    )
}

/// pydicom's bundled test files compressed with JPEG-LS or JPEG 2000
/// (reversible, and 14-bit irreversible), each read alone.
#[test]
fn jpeg_ls_and_jpeg_2000_decode_to_pydicoms_values() {
    let d = tempfile::tempdir().unwrap();
    let find = r#"
import json, os, sys
try:
    import pydicom.data
except ImportError as e:
    print("SKIP", e); sys.exit(0)
print(json.dumps({"dir": os.path.join(os.path.dirname(pydicom.data.__file__), "test_files")}))
"#;
    let Some(j) = python_json(find, "pip install pydicom") else {
        return;
    };
    let src = Path::new(j["dir"].as_str().unwrap());
    for (name, syntax) in [
        ("MR_small_jpeg_ls_lossless.dcm", "JPEG-LS Lossless"),
        (
            "MR_small_jp2klossless.dcm",
            "JPEG 2000 Image Compression (Lossless Only)",
        ),
        ("693_J2KI.dcm", "JPEG 2000 Image Compression"),
    ] {
        let dir = d.path().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(src.join(name), dir.join(name)).unwrap();
        let info = info_json(&dir, &[]);
        let ty = info["type"].as_str().unwrap().to_string();
        let raw = d.path().join(format!("{name}.raw"));
        ok(tool("vol-convert").arg(&dir).arg("-o").arg(&raw));
        let j = compare_with_pydicom(&dir.join(name), &raw, &ty).unwrap();
        assert!(
            j["syntax"].as_str().unwrap().starts_with(syntax),
            "{name}: {j}"
        );
        assert!(j["range"].as_f64().unwrap() > 0.0, "{name}: {j}");
        assert_eq!(j["diff"].as_f64(), Some(0.0), "{name}: {j}");
    }
    // The lossless copies hold MR_small's own values.
    let plain = d.path().join("plain");
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::copy(src.join("MR_small.dcm"), plain.join("MR_small.dcm")).unwrap();
    let (want, _) = convert(&plain, &[]);
    for name in ["MR_small_jpeg_ls_lossless.dcm", "MR_small_jp2klossless.dcm"] {
        let (got, _) = convert(&d.path().join(name), &[]);
        assert!(got == want, "{name} differs from MR_small.dcm");
    }
}

/// `tool args... in out`, or `None` (with a note) when the tool is
/// missing outside CI.
fn recompress(tool_args: &[&str], input: &Path, output: &Path) -> Option<()> {
    let out = match Command::new(tool_args[0])
        .args(&tool_args[1..])
        .arg(input)
        .arg(output)
        .output()
    {
        Ok(o) => o,
        Err(_) => {
            assert!(
                std::env::var("CI").is_err(),
                "CI must have {} (apt install libgdcm-tools dcmtk)",
                tool_args[0]
            );
            eprintln!("SKIP: {} is not installed", tool_args[0]);
            return None;
        }
    };
    assert!(
        out.status.success(),
        "{tool_args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(())
}

/// Slice `z` of a 64x48 12-bit CT series (codecs need more than the
/// 4x3 pixels of the other tests' slices: OpenJPEG's resolution levels).
fn ct_64x48(z: u32) -> crate::dicom::DataSet {
    let pixels: Vec<u8> = (0..64 * 48u32)
        .flat_map(|i| (((i * 37 + z * 500) % 4096) as u16).to_le_bytes())
        .collect();
    ct_slice(z)
        .set(0x0028_0010, b"US", us(48))
        .set(0x0028_0011, b"US", us(64))
        .set(0x7fe0_0010, b"OW", pixels)
}

/// A 12-bit CT series compressed losslessly by GDCM (JPEG-LS, JPEG 2000)
/// and DCMTK (JPEG-LS) converts to the uncompressed series' bytes; DCMTK's
/// near-lossless JPEG-LS (NEAR 2) to pydicom's values, within 2 of the
/// original.
#[test]
fn a_series_recompressed_by_gdcm_and_dcmtk_reads_as_the_original() {
    let d = tempfile::tempdir().unwrap();
    let plain = d.path().join("plain");
    std::fs::create_dir_all(&plain).unwrap();
    for z in 0..4 {
        std::fs::write(
            plain.join(format!("{z}.dcm")),
            ct_64x48(z).file(EXPLICIT_LE),
        )
        .unwrap();
    }
    let (want, _) = convert(&plain, &[]);
    for (name, args) in [
        ("gdcm-jpegls", &["gdcmconv", "--jpegls"][..]),
        ("gdcm-j2k", &["gdcmconv", "--j2k"][..]),
        ("dcmtk-jpegls", &["dcmcjpls"][..]),
    ] {
        let dir = d.path().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        for z in 0..4 {
            let f = format!("{z}.dcm");
            if recompress(args, &plain.join(&f), &dir.join(&f)).is_none() {
                return;
            }
        }
        let (got, _) = convert(&dir, &[]);
        assert!(got == want, "{name}: differs from the uncompressed series");
        assert_eq!(info_json(&dir, &[])["skipped"], serde_json::json!([]));
    }
    let near = d.path().join("dcmtk-near");
    std::fs::create_dir_all(&near).unwrap();
    let f = "0.dcm";
    recompress(
        &["dcmcjpls", "--encode-nearlossless"],
        &plain.join(f),
        &near.join(f),
    );
    let raw = d.path().join("near.raw");
    ok(tool("vol-convert").arg(&near).arg("-o").arg(&raw));
    let ty = info_json(&near, &[])["type"].as_str().unwrap().to_string();
    if let Some(j) = compare_with_pydicom(&near.join(f), &raw, &ty) {
        assert!(
            j["syntax"].as_str().unwrap().starts_with("JPEG-LS Lossy"),
            "{j}"
        );
        assert_eq!(j["diff"].as_f64(), Some(0.0), "{j}");
    }
    let (got, _) = convert(&near, &[]);
    let (orig, _) = convert(&plain, &["--crop", ",,0:1"]);
    let worst = got
        .chunks(2)
        .zip(orig.chunks(2))
        .map(|(a, b)| (i16::from_le_bytes([a[0], a[1]]) - i16::from_le_bytes([b[0], b[1]])).abs())
        .max();
    assert!(worst.is_some_and(|w| w <= 2), "{worst:?}");
}
