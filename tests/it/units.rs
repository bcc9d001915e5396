//! Units of length, end to end: what tifffile writes in micrometres or
//! nanometres reaches NIfTI (read back by nibabel), OME-Zarr (checked
//! against ome-zarr-py's list of spatial units), NRRD, ImageJ TIFF and
//! `.vvol` with the unit it had, or converted to the nearest unit the
//! format can state, with the factor said; `--units` converts on request.

use crate::common::{json, ok, python_json, run, tool};
use std::path::Path;

/// Make the inputs with tifffile in `dir`: an OME-TIFF in µm (the unit
/// spelled out), one in nm, and an ImageJ stack in `micron`.
fn make_inputs(dir: &Path) -> bool {
    let script = format!(
        r#"
import json, sys
try:
    import numpy as np
    import tifffile
except ImportError as e:
    print("SKIP", e); sys.exit(0)
d = {dir:?}
a = (np.arange(4 * 5 * 6) % 251).astype(np.uint8).reshape(4, 5, 6)
tifffile.imwrite(d + "/um.ome.tif", a, ome=True, metadata={{
    "axes": "ZYX", "PhysicalSizeX": 0.25, "PhysicalSizeXUnit": "µm",
    "PhysicalSizeY": 0.5, "PhysicalSizeYUnit": "µm",
    "PhysicalSizeZ": 1.5, "PhysicalSizeZUnit": "µm"}})
tifffile.imwrite(d + "/nm.ome.tif", a, ome=True, metadata={{
    "axes": "ZYX", "PhysicalSizeX": 40, "PhysicalSizeXUnit": "nm",
    "PhysicalSizeY": 40, "PhysicalSizeYUnit": "nm",
    "PhysicalSizeZ": 0.2, "PhysicalSizeZUnit": "µm"}})
tifffile.imwrite(d + "/ij.tif", a, imagej=True, resolution=(1 / 0.5, 1 / 0.5),
    metadata={{"spacing": 2.0, "unit": "micron", "axes": "ZYX"}})
print(json.dumps({{"ok": True}}))
"#,
        dir = dir.to_string_lossy()
    );
    python_json(&script, "pip install numpy tifffile").is_some()
}

/// nibabel's view of a NIfTI file: the unit of length and the zooms.
fn nibabel(path: &Path) -> Option<serde_json::Value> {
    let script = format!(
        r#"
import json, sys
try:
    import nibabel as nib
except ImportError as e:
    print("SKIP", e); sys.exit(0)
img = nib.load({path:?})
print(json.dumps({{
    "unit": img.header.get_xyzt_units()[0],
    "zooms": [float(z) for z in img.header.get_zooms()[:3]],
    "offset": [float(v) for v in img.affine[:3, 3]],
}}))
"#,
        path = path.to_string_lossy()
    );
    python_json(&script, "pip install nibabel")
}

fn info(path: &Path) -> serde_json::Value {
    json(&ok(tool("vol-info").arg(path).arg("--json")))
}

fn near(v: &serde_json::Value, want: [f64; 3]) -> bool {
    (0..3).all(|i| (v[i].as_f64().unwrap_or(f64::NAN) - want[i]).abs() <= 1e-6 * want[i].abs())
}

#[test]
fn micrometre_ome_tiff_reaches_nibabel_and_ome_zarr_as_micrometres() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    if !make_inputs(d) {
        return;
    }
    let um = d.join("um.ome.tif");
    let j = info(&um);
    assert_eq!(j["unit"], "micrometer", "{j}");
    assert!(near(&j["spacing"], [0.25, 0.5, 1.5]), "{j}");
    // NIfTI: code 3 (micron), the same numbers; before, it said mm.
    let nii = d.join("um.nii");
    ok(tool("vol-convert").arg(&um).arg("-q").arg("-o").arg(&nii));
    if let Some(n) = nibabel(&nii) {
        assert_eq!(n["unit"], "micron", "{n}");
        assert!(near(&n["zooms"], [0.25, 0.5, 1.5]), "{n}");
    }
    assert_eq!(info(&nii)["unit"], "micrometer");
    // .vvol, NRRD and ImageJ TIFF keep it; read back by volkit.
    for name in ["um.vvol", "um.nrrd", "um.tif"] {
        let o = d.join(name);
        ok(tool("vol-convert").arg(&um).arg("-q").arg("-o").arg(&o));
        let j = info(&o);
        assert_eq!(j["unit"], "micrometer", "{name}: {j}");
        assert!(near(&j["spacing"], [0.25, 0.5, 1.5]), "{name}: {j}");
    }
    // OME-Zarr: every spatial axis carries a unit ome-zarr-py knows.
    let z = d.join("um.ome.zarr");
    ok(tool("vol-convert").arg(&um).arg("-q").arg("-o").arg(&z));
    assert_eq!(info(&z)["unit"], "micrometer");
    let script = format!(
        r#"
import json, sys
try:
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Reader
    from ome_zarr.axes import KNOWN_SPATIAL_UNITS
except ImportError as e:
    print("SKIP", e); sys.exit(0)
node = list(Reader(parse_url({z:?}, mode="r"))())[0]
axes = node.metadata["axes"]
print(json.dumps({{"units": [a.get("unit") for a in axes],
    "known": all(a.get("unit") in KNOWN_SPATIAL_UNITS for a in axes)}}))
"#,
        z = z.to_string_lossy()
    );
    if let Some(j) = python_json(&script, "pip install ome-zarr") {
        assert_eq!(
            j["units"],
            serde_json::json!(["micrometer", "micrometer", "micrometer"]),
            "{j}"
        );
        assert_eq!(j["known"], true, "{j}");
    }
    // ImageJ's `unit=micron` is read as µm.
    let j = info(&d.join("ij.tif"));
    assert_eq!(j["unit"], "micrometer", "{j}");
    assert!(near(&j["spacing"], [0.5, 0.5, 2.0]), "{j}");
}

#[test]
fn units_a_format_cannot_state_are_converted_and_said() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    if !make_inputs(d) {
        return;
    }
    // nm in x and y, µm in z: one unit (x's) for all three.
    let nm = d.join("nm.ome.tif");
    let j = info(&nm);
    assert_eq!(j["unit"], "nanometer", "{j}");
    assert!(near(&j["spacing"], [40.0, 40.0, 200.0]), "{j}");
    // NIfTI has no nanometre code (a reader takes "unknown" as mm):
    // micrometres, spacing / 1000, and a note saying so.
    let nii = d.join("nm.nii.gz");
    let out = run(tool("vol-convert").arg(&nm).arg("-o").arg(&nii));
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("NIfTI cannot state nm") && err.contains("µm"),
        "{err}"
    );
    if let Some(n) = nibabel(&nii) {
        assert_eq!(n["unit"], "micron", "{n}");
        assert!(near(&n["zooms"], [0.04, 0.04, 0.2]), "{n}");
    }
    // MetaImage states no unit; ITK reads millimetres: converted to mm.
    let mha = d.join("nm.mha");
    let out = run(tool("vol-convert").arg(&nm).arg("-o").arg(&mha));
    assert!(String::from_utf8_lossy(&out.stderr).contains("MetaImage cannot state nm"));
    assert!(near(&info(&mha)["spacing"], [4e-5, 4e-5, 2e-4]));
    // Issue 53 §6: read back in the millimetres the writer assumed, and
    // kept through another MetaImage (.mhd) and a .vvol.
    assert_eq!(info(&mha)["unit"], "millimeter");
    let mhd = d.join("again.mhd");
    ok(tool("vol-convert").arg(&mha).arg("-q").arg("-o").arg(&mhd));
    let back = d.join("again.vvol");
    ok(tool("vol-convert").arg(&mhd).arg("-q").arg("-o").arg(&back));
    for p in [&mhd, &back] {
        let j = info(p);
        assert_eq!(j["unit"], "millimeter", "{}: {j}", p.display());
        assert!(near(&j["spacing"], [4e-5, 4e-5, 2e-4]), "{j}");
    }
    // .vvol holds nanometres as they are.
    let v = d.join("nm.vvol");
    let out = run(tool("vol-convert").arg(&nm).arg("-o").arg(&v));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("note"));
    assert_eq!(info(&v)["unit"], "nanometer");
    // --units converts on request, says the factor, and --json shows it.
    let mm = d.join("mm.vvol");
    let out = run(tool("vol-convert")
        .arg(&v)
        .args(["--units", "mm", "--json", "-o"])
        .arg(&mm));
    assert!(String::from_utf8_lossy(&out.stderr).contains("from nm to mm"));
    let j = json(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(j["unit"], "millimeter", "{j}");
    assert!(near(&j["spacing"], [4e-5, 4e-5, 2e-4]), "{j}");
    assert!(near(&info(&mm)["spacing"], [4e-5, 4e-5, 2e-4]));
    // A unit that is not one is refused by name.
    let out = run(tool("vol-convert")
        .arg(&v)
        .args(["--units", "furlong", "-o"])
        .arg(d.join("f.vvol")));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a unit of length"));
}

#[test]
fn unitless_inputs_claim_no_unit_until_told() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let raw = d.join("a_8x8x8_u8.raw");
    std::fs::write(&raw, vec![7u8; 512]).unwrap();
    let nii = d.join("a.nii");
    ok(tool("vol-convert").arg(&raw).arg("-q").arg("-o").arg(&nii));
    // NIfTI code 0 ("unknown"), not mm: the data never said mm.
    assert_eq!(info(&nii)["unit"], serde_json::Value::Null);
    if let Some(n) = nibabel(&nii) {
        assert_eq!(n["unit"], "unknown", "{n}");
    }
    // --units labels an input that states none (and says so).
    let v = d.join("a.vvol");
    let out = run(tool("vol-convert")
        .arg(&raw)
        .args(["--units", "um", "--spacing", "0.5,0.5,2", "-o"])
        .arg(&v));
    assert!(String::from_utf8_lossy(&out.stderr).contains("states no unit"));
    let j = info(&v);
    assert_eq!(j["unit"], "micrometer", "{j}");
    assert!(near(&j["spacing"], [0.5, 0.5, 2.0]), "{j}");
}
