//! Inputs with several channels (C) or time points (T): an OME-TIFF
//! (TCZYX), an ImageJ hyperstack (TZCYX), an OME-Zarr with `t` and `c`
//! axes and a 4D NIfTI, made with tifffile, ome-zarr-py and nibabel.
//! `vol-info` describes them without a selection (the first channel and
//! time point, with the sizes of C and T, the time step, and the flags
//! that pick another); with `--channel` and `--time-point` it describes
//! the one picked. `vol-convert` still needs the selection, and says so
//! with its own flags.

use crate::common::{fails, json, ok, python_json, tool};
use serde_json::{json, Value};
use std::path::Path;

/// The inputs, in `dir`: every one holds x + 10 y + 100 z + 1000 c +
/// 5000 t over 6 x 5 x 4 voxels, with 2 channels (NIfTI: 1) and 3 time
/// points.
fn make_inputs(dir: &Path) -> bool {
    let script = format!(
        r#"
import json, sys
try:
    import numpy as np
    import tifffile
    import nibabel as nib
    import zarr
    from ome_zarr.io import parse_url
    from ome_zarr.writer import write_multiscale
except ImportError as e:
    print("SKIP", e); sys.exit(0)
d = {dir:?}
t, c, z, y, x = np.meshgrid(*[np.arange(n) for n in (3, 2, 4, 5, 6)], indexing="ij")
a = (x + 10 * y + 100 * z + 1000 * c + 5000 * t).astype(np.uint16)
tifffile.imwrite(d + "/ct.ome.tif", a, ome=True, metadata={{
    "axes": "TCZYX", "PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25,
    "PhysicalSizeZ": 1.5, "TimeIncrement": 2.5, "TimeIncrementUnit": "s"}})
tifffile.imwrite(d + "/ct_ij.tif", np.ascontiguousarray(a.transpose(0, 2, 1, 3, 4)),
    imagej=True, resolution=(4, 4),
    metadata={{"axes": "TZCYX", "spacing": 1.5, "unit": "micron", "finterval": 0.5}})
root = zarr.group(store=parse_url(d + "/ct.ome.zarr", mode="w").store)
write_multiscale([a], root, axes=[
    {{"name": "t", "type": "time", "unit": "millisecond"}},
    {{"name": "c", "type": "channel"}},
    {{"name": "z", "type": "space", "unit": "micrometer"}},
    {{"name": "y", "type": "space", "unit": "micrometer"}},
    {{"name": "x", "type": "space", "unit": "micrometer"}}],
    coordinate_transformations=[[{{"type": "scale", "scale": [40, 1, 1.5, 0.25, 0.25]}}]])
# NIfTI: x y z t, channel 0.
v = np.ascontiguousarray(a[:, 0].transpose(3, 2, 1, 0)).astype(np.int16)
img = nib.Nifti1Image(v, np.diag([0.25, 0.25, 1.5, 1.0]))
img.header.set_xyzt_units("mm", "sec")
img.header["pixdim"][4] = 1.25
nib.save(img, d + "/ct4d.nii.gz")
print(json.dumps({{"ok": True}}))
"#,
        dir = dir.to_string_lossy()
    );
    python_json(&script, "pip install numpy tifffile nibabel zarr ome-zarr").is_some()
}

/// What each input should report: its name, channels, time step and
/// time unit (JSON), and the text of its time points line.
struct Case {
    name: &'static str,
    channels: u64,
    time_step: f64,
    time_unit: &'static str,
    time_line: &'static str,
}

const CASES: [Case; 4] = [
    Case {
        name: "ct.ome.tif",
        channels: 2,
        time_step: 2.5,
        time_unit: "second",
        time_line: "  time points: 3 (step 2.5 s)",
    },
    Case {
        name: "ct_ij.tif",
        channels: 2,
        time_step: 0.5,
        time_unit: "second",
        time_line: "  time points: 3 (step 0.5 s)",
    },
    Case {
        name: "ct.ome.zarr",
        channels: 2,
        time_step: 40.0,
        time_unit: "millisecond",
        time_line: "  time points: 3 (step 40 ms)",
    },
    Case {
        name: "ct4d.nii.gz",
        channels: 1,
        time_step: 1.25,
        time_unit: "second",
        time_line: "  time points: 3 (step 1.25 s)",
    },
];

fn info_json(path: &Path, extra: &[&str]) -> Value {
    json(&ok(tool("vol-info").arg(path).args(extra).arg("--json")))
}

#[test]
fn vol_info_describes_channels_and_time_points_without_a_selection() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    if !make_inputs(d) {
        return;
    }
    for case in &CASES {
        let p = d.join(case.name);
        let name = case.name;
        // Text: the first channel and time point described, the sizes of
        // C and T, and the flags that pick another (only those that apply).
        let text = ok(tool("vol-info").arg(&p));
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].contains("6x5x4"), "{name}: {text}");
        assert!(
            lines.contains(&format!("  channels: {}", case.channels).as_str()),
            "{name}: {text}"
        );
        assert!(lines.contains(&case.time_line), "{name}: {text}");
        assert!(text.contains("  values 0 .. 345\n"), "{name}: {text}");
        let hint = lines
            .iter()
            .find(|l| l.starts_with("  described:"))
            .unwrap_or_else(|| panic!("{name}: no hint in {text}"));
        if case.channels > 1 {
            assert!(
                hint.contains("channel 0, time point 0")
                    && hint.contains("--channel C, --time-point T"),
                "{name}: {hint}"
            );
        } else {
            assert!(
                hint.contains("time point 0") && !hint.contains("channel"),
                "{name}: {hint}"
            );
            assert!(hint.ends_with("--time-point T"), "{name}: {hint}");
        }
        // JSON: the same as keys.
        let j = info_json(&p, &[]);
        assert_eq!(j["dims"], json!([6, 5, 4]), "{name}: {j}");
        assert_eq!(j["channels"], case.channels, "{name}: {j}");
        assert_eq!(j["time_points"], 3, "{name}: {j}");
        assert_eq!(j["time_step"], case.time_step, "{name}: {j}");
        assert_eq!(j["time_unit"], case.time_unit, "{name}: {j}");
        assert_eq!((&j["channel"], &j["time_point"]), (&json!(0), &json!(0)));
        assert_eq!(
            (&j["min"], &j["max"]),
            (&json!(0.0), &json!(345.0)),
            "{name}: {j}"
        );
        let spacing: Vec<f64> = serde_json::from_value(j["spacing"].clone()).unwrap();
        assert_eq!(spacing, [0.25, 0.25, 1.5], "{name}: {j}");
        // A selection: that volume, and still the sizes of the file.
        let pick: &[&str] = if case.channels > 1 {
            &["--channel", "1", "--time-point", "2"]
        } else {
            &["--time-point", "2"]
        };
        let base = if case.channels > 1 { 11000.0 } else { 10000.0 };
        let j = info_json(&p, pick);
        assert_eq!(j["channels"], case.channels, "{name}: {j}");
        assert_eq!(j["time_points"], 3, "{name}: {j}");
        assert_eq!(j["channel"], if case.channels > 1 { 1 } else { 0 });
        assert_eq!(j["time_point"], 2, "{name}: {j}");
        assert_eq!(
            (&j["min"], &j["max"]),
            (&json!(base), &json!(base + 345.0)),
            "{name}: {j}"
        );
        let text = ok(tool("vol-info").arg(&p).args(pick));
        assert!(text.contains(case.time_line), "{name}: {text}");
        assert!(text.contains("  described: "), "{name}: {text}");
        assert!(!text.contains("--time-point T"), "{name}: {text}");
        // vol-convert still needs the selection, and names its flags.
        let out = d.join("o.nrrd");
        let e = fails(tool("vol-convert").arg(&p).arg("-o").arg(&out), "pick one");
        assert!(e.contains("--time-point"), "{name}: {e}");
        if case.channels > 1 && !name.ends_with(".zarr") {
            // (OME-Zarr names the first axis it meets without a pick.)
            assert!(e.contains("--channel C"), "{name}: {e}");
        }
        assert!(!out.exists());
    }
}

#[test]
fn single_volumes_report_one_channel_and_one_time_point() {
    let d = tempfile::tempdir().unwrap();
    let raw = d.path().join("a_4x3x2_u8.raw");
    std::fs::write(&raw, [7u8; 24]).unwrap();
    let j = info_json(&raw, &[]);
    assert_eq!((&j["channels"], &j["time_points"]), (&json!(1), &json!(1)));
    assert_eq!((&j["channel"], &j["time_point"]), (&json!(0), &json!(0)));
    assert_eq!(
        (&j["time_step"], &j["time_unit"]),
        (&Value::Null, &Value::Null)
    );
    let text = ok(tool("vol-info").arg(&raw));
    assert!(
        !text.contains("channels") && !text.contains("time point") && !text.contains("described"),
        "{text}"
    );
}
