//! Enhanced multi-frame DICOM (issue 64 §5): one file whose frames are
//! the slices, each placed by its functional groups. nibabel's Philips
//! Enhanced MR (176 frames of 256x256) given distinct pixels, against
//! dcm2niix; and the same file with a frame count its functional groups
//! do not back, refused.

use crate::common::{fails, ok, python_json, tool};

/// Copy nibabel's Philips MPRAGE into `dir` with pixels `(i * 7919) %
/// 4093`, NumberOfFrames set to `frames` (176 is the file's own), and
/// convert it with dcm2niix into `reference` when asked.
fn mprage(dir: &std::path::Path, frames: u32, reference: Option<&std::path::Path>) -> Option<()> {
    mprage_with(dir, frames, reference, "")
}

/// [`mprage`], with `more` (Python run on the data set `ds`) before it is
/// saved.
fn mprage_with(
    dir: &std::path::Path,
    frames: u32,
    reference: Option<&std::path::Path>,
    more: &str,
) -> Option<()> {
    let dcm2niix = reference.map_or(String::new(), |r| {
        format!(
            r#"subprocess.run(["dcm2niix", "-z", "n", "-f", "ref", "-o", {r:?}, {dir:?}], check=True, capture_output=True)"#,
            r = r.to_string_lossy(),
            dir = dir.to_string_lossy()
        )
    });
    let script = format!(
        r#"
import gzip, io, json, os, shutil, subprocess, sys
try:
    import nibabel, numpy as np, pydicom
except ImportError as e:
    print("SKIP", e); sys.exit(0)
if {need} and shutil.which("dcm2niix") is None:
    print("SKIP dcm2niix is not installed"); sys.exit(0)
data = os.path.join(os.path.dirname(nibabel.__file__), "nicom", "tests", "data")
with gzip.open(os.path.join(data, "philips_mprage.dcm.gz")) as f:
    ds = pydicom.dcmread(io.BytesIO(f.read()))
n = len(ds.PixelData) // 2
ds.PixelData = ((np.arange(n, dtype=np.uint64) * 7919) % 4093).astype(np.uint16).tobytes()
ds.NumberOfFrames = {frames}
{more}
ds.save_as(os.path.join({dir:?}, "mprage.dcm"))
{dcm2niix}
print(json.dumps({{"ok": True}}))
"#,
        need = if reference.is_some() { "True" } else { "False" },
        dir = dir.to_string_lossy(),
    );
    python_json(&script, "pip install nibabel pydicom; apt install dcm2niix").map(|_| ())
}

/// `dir/in` holding the MPRAGE and `dir/ref` dcm2niix's conversion of
/// it; `None` without the Python modules or dcm2niix outside CI.
fn mprage_and_dcm2niix(dir: &std::path::Path) -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    let (input, reference) = (dir.join("in"), dir.join("ref"));
    std::fs::create_dir_all(&input).unwrap();
    std::fs::create_dir_all(&reference).unwrap();
    mprage(&input, 176, Some(&reference))?;
    Some((input, reference))
}

#[test]
fn an_enhanced_mr_equals_dcm2niix_in_world_space() {
    let d = tempfile::tempdir().unwrap();
    let Some((input, reference)) = mprage_and_dcm2niix(d.path()) else {
        return;
    };
    let text = ok(tool("vol-info").arg(&input));
    assert!(text.contains("256x256x176"), "{text}");
    // dcm2niix writes Philips' precise values (the private scale slope);
    // --philips-scale precise gives the same, the default the displayed.
    let out = d.path().join("precise.nii");
    ok(tool("vol-convert")
        .arg(&input)
        .args(["--philips-scale", "precise", "--type", "f32", "-o"])
        .arg(&out));
    let displayed = d.path().join("displayed.nii");
    ok(tool("vol-convert")
        .arg(&input)
        .args(["--type", "f32", "-o"])
        .arg(&displayed));
    let compare = format!(
        r#"
import json, nibabel as nib, numpy as np
ref = nib.as_closest_canonical(nib.load({reference:?} + "/ref.nii"))
got = nib.as_closest_canonical(nib.load({out:?}))
shown = nib.as_closest_canonical(nib.load({displayed:?}))
a, b = got.get_fdata(), ref.get_fdata()
print(json.dumps({{"shape": list(a.shape), "ref_shape": list(b.shape),
                  "affine": float(np.abs(got.affine - ref.affine).max()),
                  "relative": float(np.abs(a - b).max() / np.abs(b).max()),
                  "ratio": float(shown.get_fdata().max() / a.max())}}))
"#,
        reference = reference.to_string_lossy(),
        out = out.to_string_lossy(),
        displayed = displayed.to_string_lossy(),
    );
    let j = python_json(&compare, "pip install nibabel").unwrap();
    assert_eq!(j["shape"], j["ref_shape"], "{j}");
    // Sagittal: canonical (RAS) axes put the 176 frames first.
    assert_eq!(j["shape"], serde_json::json!([176, 256, 256]), "{j}");
    assert!(j["affine"].as_f64().unwrap() < 1e-3, "{j}");
    // f32 against dcm2niix's int16 x scl_slope: equal within rounding.
    assert!(j["relative"].as_f64().unwrap() < 1e-5, "{j}");
    // The displayed values are RescaleSlope x scale slope times the
    // precise ones (2.10794 x 0.00026825 here).
    let ratio = j["ratio"].as_f64().unwrap();
    assert!((ratio - 2.10794 * 0.00026825).abs() < 1e-6, "{j}");
}

#[test]
fn frames_the_functional_groups_do_not_back_are_refused() {
    let d = tempfile::tempdir().unwrap();
    if mprage(d.path(), 177, None).is_none() {
        return;
    }
    let err = fails(tool("vol-info").arg(d.path()), "mprage.dcm");
    assert!(
        err.contains(
            "NumberOfFrames is 177 but the Per-frame Functional Groups Sequence holds 176 items"
        ),
        "{err}"
    );
}

/// Two stacks in one file (StackID 1 for the first 88 frames, 2 for the
/// rest) are two sub-series, though their frames would line up into one
/// evenly spaced volume (dcm2niix merges them).
#[test]
fn two_stacks_of_one_file_are_two_sub_series() {
    let d = tempfile::tempdir().unwrap();
    let stacks = r#"
for k, f in enumerate(ds.PerFrameFunctionalGroupsSequence):
    f.FrameContentSequence[0].StackID = "1" if k < 88 else "2"
"#;
    if mprage_with(d.path(), 176, None, stacks).is_none() {
        return;
    }
    let j = crate::dicom::info_json(d.path(), &[]);
    let series: Vec<(String, u64)> = j["series"]
        .as_array()
        .unwrap_or_else(|| panic!("{j}"))
        .iter()
        .map(|s| {
            (
                s["id"].as_str().unwrap().to_string(),
                s["images"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        series,
        vec![("301-1".to_string(), 88), ("301-2".to_string(), 88)],
        "{j}"
    );
    let j = crate::dicom::info_json(d.path(), &["--series", "301-2"]);
    assert_eq!(j["dims"], serde_json::json!([256, 256, 88]), "{j}");
}

/// `--sidecar` writes what the series states about its acquisition under
/// BIDS's names and units, as dcm2niix's sidecar does: the fields both
/// write agree (times in seconds; dcm2niix rounds to six digits). Where
/// they differ legitimately: dcm2niix shortens Manufacturer ("Philips"
/// for "Philips Medical Systems") and adds fields volkit does not write.
#[test]
fn a_sidecar_states_the_acquisition_as_dcm2niix_does() {
    let d = tempfile::tempdir().unwrap();
    let Some((input, reference)) = mprage_and_dcm2niix(d.path()) else {
        return;
    };
    let out = d.path().join("run.nii.gz");
    ok(tool("vol-convert")
        .arg(&input)
        .arg("--sidecar")
        .arg("-o")
        .arg(&out));
    let ours: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("run.json")).unwrap()).unwrap();
    let theirs: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(reference.join("ref.json")).unwrap())
            .unwrap();
    for key in [
        "Modality",
        "ManufacturersModelName",
        "SeriesDescription",
        "ProtocolName",
        "BodyPartExamined",
        "PatientPosition",
        "ScanningSequence",
        "SeriesNumber",
        "AcquisitionTime",
        "MagneticFieldStrength",
        "SliceThickness",
        "SpacingBetweenSlices",
        "FlipAngle",
        "EchoTime",
        "RepetitionTime",
    ] {
        let (a, b) = (&ours[key], &theirs[key]);
        let same = match (a.as_f64(), b.as_f64()) {
            (Some(x), Some(y)) => (x - y).abs() <= 1e-6 * y.abs().max(1.0),
            _ => a == b && !a.is_null(),
        };
        assert!(same, "{key}: ours {a}, dcm2niix {b}");
    }
    assert_eq!(ours["ConversionSoftware"], "volkit vol-convert");
    // Not DICOM: refused, and nothing written.
    let plain = d.path().join("plain.nii");
    ok(tool("vol-convert").arg(&out).arg("-o").arg(&plain));
    crate::common::fails(
        tool("vol-convert")
            .arg(&plain)
            .args(["--sidecar", "-o"])
            .arg(d.path().join("again.nii")),
        "states none",
    );
    assert!(!d.path().join("again.nii").exists() && !d.path().join("again.json").exists());
}
