//! vol-convert's preprocessing stages (issue 52) end to end: resampling
//! and orientation against SimpleITK, filters against SimpleITK and
//! numpy, same-grid and sharded runs byte for byte, and bad input refused
//! with one line before any work.

use crate::common::{fails, ok, python_json, run, tool};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// A smooth CT-like volume (the phantom, f32) at 0.5,0.5,2 mm as NIfTI.
fn phantom(dir: &Path, dims: &str) -> PathBuf {
    let vvol = dir.join("ph.vvol");
    ok(tool("vol-gen")
        .args([
            "phantom",
            "--dims",
            dims,
            "--type",
            "f32",
            "--spacing",
            "0.5,0.5,2",
            "-q",
            "-o",
        ])
        .arg(&vvol));
    let nii = dir.join("ph.nii");
    ok(tool("vol-convert")
        .arg(&vvol)
        .args(["--units", "mm", "-q", "-o"])
        .arg(&nii));
    nii
}

fn convert(input: &Path, args: &[&str], out: &Path) {
    ok(tool("vol-convert")
        .arg(input)
        .args(args)
        .arg("-q")
        .arg("-o")
        .arg(out));
}

/// Python that reads `src` (a file or a DICOM folder) and `ours` with
/// SimpleITK, resamples `src` onto `ours`'s grid with `interp`, and
/// prints the largest difference over the voxels whose input position is
/// at least one voxel inside the input (the border rule differs: volkit
/// replicates, ITK too, but the inside test at the last half voxel is the
/// caller's to state), with the input's value range.
fn sitk_resample_diff(src: &Path, ours: &Path, interp: &str) -> Option<serde_json::Value> {
    let script = format!(
        r#"
import json, os, sys
try:
    import SimpleITK as sitk, numpy as np
except ImportError:
    print("SKIP SimpleITK or numpy missing"); sys.exit(0)
src_path, ours_path = {src:?}, {ours:?}
if os.path.isdir(src_path):
    r = sitk.ImageSeriesReader()
    r.SetFileNames(r.GetGDCMSeriesFileNames(src_path))
    src = r.Execute()
else:
    src = sitk.ReadImage(src_path)
src = sitk.Cast(src, sitk.sitkFloat32)
ours = sitk.ReadImage(ours_path)
ref = sitk.Resample(src, ours, sitk.Transform(), sitk.{interp}, 0.0, sitk.sitkFloat32)
a = sitk.GetArrayFromImage(ref).astype(np.float64)
b = sitk.GetArrayFromImage(ours).astype(np.float64)
# Output voxel centres as input continuous indices (numpy is z,y,x).
nz, ny, nx = b.shape
k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
ijk = np.stack([i.ravel(), j.ravel(), k.ravel()]).astype(np.float64)
D2 = np.array(ours.GetDirection()).reshape(3, 3); S2 = np.diag(ours.GetSpacing())
P = np.array(ours.GetOrigin())[:, None] + D2 @ S2 @ ijk
D1 = np.array(src.GetDirection()).reshape(3, 3); S1 = np.diag(src.GetSpacing())
u = np.linalg.solve(D1 @ S1, P - np.array(src.GetOrigin())[:, None])
n = np.array(src.GetSize(), dtype=np.float64)[:, None]
inner = np.all((u >= 1.0) & (u <= n - 2.0), axis=0).reshape(b.shape)
s = sitk.GetArrayFromImage(src)
print(json.dumps({{"max": float(np.abs(a - b)[inner].max()), "range": float(s.max() - s.min()),
                  "count": int(inner.sum()), "total": int(inner.size)}}))
"#,
        src = src.display().to_string(),
        ours = ours.display().to_string(),
    );
    python_json(&script, "pip install SimpleITK numpy")
}

fn assert_agrees(j: &serde_json::Value, what: &str) {
    let max = j["max"].as_f64().unwrap();
    let range = j["range"].as_f64().unwrap();
    let count = j["count"].as_u64().unwrap();
    assert!(count > 100, "{what}: too few interior voxels compared: {j}");
    assert!(
        max <= 1e-4 * range,
        "{what}: largest difference {max} is over 1e-4 of the range {range}: {j}"
    );
}

#[test]
fn same_grid_resampling_returns_the_input_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "24,20,9");
    let plain = dir.path().join("plain.raw");
    convert(&nii, &[], &plain);
    let want = std::fs::read(&plain).unwrap();
    for k in [
        "nearest", "linear", "cubic", "bspline3", "lanczos3", "label",
    ] {
        for spec in ["spacing:0.5,0.5,2", "dims:24,20,9"] {
            let out = dir.path().join(format!("{k}.raw"));
            convert(&nii, &["--resample", spec, "--kernel", k], &out);
            assert!(std::fs::read(&out).unwrap() == want, "{k} {spec}");
        }
        let out = dir.path().join(format!("{k}-like.raw"));
        let like = format!("like:{}", nii.display());
        convert(&nii, &["--resample", &like, "--kernel", k], &out);
        assert!(std::fs::read(&out).unwrap() == want, "{k} like:");
    }
}

#[test]
fn linear_and_nearest_equal_simpleitk_on_an_axis_aligned_grid() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "48,40,12");
    for (k, interp) in [("linear", "sitkLinear"), ("nearest", "sitkNearestNeighbor")] {
        // No output centre falls exactly half-way between two input voxels
        // (nearest would then depend on the last bit of each side's
        // arithmetic), except on spacing:1, where both sides compute the
        // halves exactly.
        for spec in ["spacing:1", "spacing:0.3,0.45,1.3", "dims:17,50,31"] {
            let out = dir.path().join(format!("{k}.nii"));
            convert(
                &nii,
                &[
                    "--resample",
                    spec,
                    "--kernel",
                    k,
                    "--no-antialias",
                    "--type",
                    "f32",
                ],
                &out,
            );
            if let Some(j) = sitk_resample_diff(&nii, &out, interp) {
                assert_agrees(&j, &format!("{k} {spec}"));
            }
        }
    }
}

/// A NIfTI grid rotated against the phantom's (about z by 30° and x by
/// 10°) whose box is centred on `centre`, written by SimpleITK.
fn rotated_grid(
    dir: &Path,
    name: &str,
    size: [u32; 3],
    spacing: [f64; 3],
    centre: [f64; 3],
) -> Option<PathBuf> {
    let path = dir.join(name);
    let script = format!(
        r#"
import json, sys, math
try:
    import SimpleITK as sitk, numpy as np
except ImportError:
    print("SKIP SimpleITK missing"); sys.exit(0)
a, b = math.radians(30), math.radians(10)
Rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
Rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
R = Rz @ Rx
size, spacing = np.array({size:?}), np.array({spacing:?})
origin = np.array({centre:?}) - R @ ((size - 1) * spacing / 2)
img = sitk.Image([int(v) for v in size], sitk.sitkFloat32)
img.SetSpacing(tuple(spacing)); img.SetOrigin(tuple(origin))
img.SetDirection(tuple(R.ravel()))
img = img + 1.0
sitk.WriteImage(img, {path:?})
print(json.dumps({{"ok": True}}))
"#,
        size = size.to_vec(),
        spacing = spacing.to_vec(),
        centre = centre.to_vec(),
        path = path.display().to_string(),
    );
    python_json(&script, "pip install SimpleITK numpy").map(|_| path)
}

#[test]
fn a_rotated_like_grid_equals_simpleitk() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "40,40,10");
    // The phantom's voxel centres span 0..19.5 x 0..19.5 x 0..18 mm: a
    // smaller rotated grid centred in it, and reaching past its edges.
    let Some(like) = rotated_grid(
        dir.path(),
        "like.nii",
        [20, 18, 9],
        [0.8, 0.9, 1.1],
        [9.75, 9.75, 9.0],
    ) else {
        return;
    };
    for (k, interp) in [("linear", "sitkLinear"), ("nearest", "sitkNearestNeighbor")] {
        let out = dir.path().join(format!("{k}.nii"));
        let spec = format!("like:{}", like.display());
        convert(
            &nii,
            &[
                "--resample",
                &spec,
                "--kernel",
                k,
                "--no-antialias",
                "--type",
                "f32",
            ],
            &out,
        );
        if let Some(j) = sitk_resample_diff(&nii, &out, interp) {
            assert_agrees(&j, &format!("{k} like: rotated"));
        }
    }
}

#[test]
fn an_lps_dicom_series_resamples_as_simpleitk_does() {
    let dir = tempfile::tempdir().unwrap();
    let ct = fixture("dicom_ct");
    for (k, interp) in [("linear", "sitkLinear"), ("nearest", "sitkNearestNeighbor")] {
        let out = dir.path().join(format!("{k}.nii"));
        convert(
            &ct,
            &[
                "--resample",
                "spacing:0.5,0.6,1",
                "--kernel",
                k,
                "--no-antialias",
                "--type",
                "f32",
            ],
            &out,
        );
        if let Some(j) = sitk_resample_diff(&ct, &out, interp) {
            assert_agrees(&j, &format!("{k} DICOM"));
        }
    }
}

#[test]
fn a_nifti_with_a_rotated_sform_resamples_in_its_own_axes_as_simpleitk_does() {
    let dir = tempfile::tempdir().unwrap();
    let Some(rot) = rotated_grid(
        dir.path(),
        "rot.nii",
        [30, 26, 12],
        [0.6, 0.7, 1.5],
        [3.0, -2.0, 1.0],
    ) else {
        return;
    };
    // Give it content: the phantom's values, relabelled onto that grid.
    let vvol = dir.path().join("ph.vvol");
    ok(tool("vol-gen")
        .args(["phantom", "--dims", "30,26,12", "--type", "f32", "-q", "-o"])
        .arg(&vvol));
    let raw = dir.path().join("ph.raw");
    convert(&vvol, &[], &raw);
    let script = format!(
        r#"
import json, sys
import SimpleITK as sitk, numpy as np
g = sitk.ReadImage({rot:?})
a = np.fromfile({raw:?}, dtype="<f4").reshape(12, 26, 30)
img = sitk.GetImageFromArray(a); img.CopyInformation(g)
sitk.WriteImage(img, {rot:?})
print(json.dumps({{"ok": True}}))
"#,
        rot = rot.display().to_string(),
        raw = raw.display().to_string()
    );
    if python_json(&script, "pip install SimpleITK numpy").is_none() {
        return;
    }
    for (k, interp) in [("linear", "sitkLinear"), ("nearest", "sitkNearestNeighbor")] {
        let out = dir.path().join(format!("{k}.nii"));
        let o = run(tool("vol-convert")
            .arg(&rot)
            .args([
                "--resample",
                "spacing:1",
                "--kernel",
                k,
                "--no-antialias",
                "--type",
                "f32",
                "-o",
            ])
            .arg(&out));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("oblique"),
            "no note that the axes are oblique: {err}"
        );
        if let Some(j) = sitk_resample_diff(&rot, &out, interp) {
            assert_agrees(&j, &format!("{k} rotated sform"));
        }
    }
}

/// A small NIfTI (i16, unique values, anisotropic spacing, origin off
/// zero, axes permuted and flipped: PIL-like) written by SimpleITK.
fn odd_grid_volume(dir: &Path) -> Option<PathBuf> {
    let path = dir.join("odd.nii");
    let script = format!(
        r#"
import json, sys
try:
    import SimpleITK as sitk, numpy as np
except ImportError:
    print("SKIP SimpleITK missing"); sys.exit(0)
a = (np.arange(5 * 4 * 3, dtype=np.int16) * 7 - 100).reshape(5, 4, 3)
img = sitk.GetImageFromArray(a)
img.SetSpacing((0.5, 0.75, 2.0)); img.SetOrigin((10.0, -20.0, 30.0))
img.SetDirection((0, 0, -1, 1, 0, 0, 0, -1, 0))
sitk.WriteImage(img, {path:?})
print(json.dumps({{"ok": True}}))
"#,
        path = path.display().to_string()
    );
    python_json(&script, "pip install SimpleITK numpy").map(|_| path)
}

/// The 48 orientation codes.
fn all_codes() -> Vec<String> {
    let pairs = [['R', 'L'], ['A', 'P'], ['S', 'I']];
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::new();
    for p in perms {
        for signs in 0..8 {
            out.push(
                (0..3)
                    .map(|a| pairs[p[a]][(signs >> a) & 1])
                    .collect::<String>(),
            );
        }
    }
    out
}

#[test]
fn orient_equals_simpleitk_dicomorient_for_all_48_codes() {
    let dir = tempfile::tempdir().unwrap();
    let Some(src) = odd_grid_volume(dir.path()) else {
        return;
    };
    let codes = all_codes();
    assert_eq!(codes.len(), 48);
    for c in &codes {
        convert(
            &src,
            &["--orient", c],
            &dir.path().join(format!("o_{c}.nii")),
        );
    }
    let script = format!(
        r#"
import json, sys
import SimpleITK as sitk, numpy as np
try:
    import nibabel as nib
except ImportError:
    nib = None
src = sitk.ReadImage({src:?})
bad = []
for c in {codes:?}:
    want = sitk.DICOMOrient(src, c)
    got = sitk.ReadImage({dir:?} + "/o_" + c + ".nii")
    if not np.array_equal(sitk.GetArrayFromImage(want), sitk.GetArrayFromImage(got)):
        bad.append(c + ": voxels")
    for what, f in [("origin", "GetOrigin"), ("direction", "GetDirection"), ("spacing", "GetSpacing")]:
        if not np.allclose(getattr(want, f)(), getattr(got, f)(), atol=1e-5):
            bad.append(c + ": " + what + " " + str(getattr(got, f)()) + " != " + str(getattr(want, f)()))
    if nib is not None:
        codes = "".join(nib.aff2axcodes(nib.load({dir:?} + "/o_" + c + ".nii").affine))
        if codes != c:
            bad.append(c + ": nibabel reads " + codes)
print(json.dumps({{"bad": bad, "nibabel": nib is not None}}))
"#,
        src = src.display().to_string(),
        dir = dir.path().display().to_string(),
        codes = codes,
    );
    let Some(j) = python_json(&script, "pip install SimpleITK numpy nibabel") else {
        return;
    };
    assert_eq!(j["bad"], serde_json::json!([]), "{j}");
}

#[test]
fn median_equals_simpleitk_and_clamp_threshold_mask_equal_numpy() {
    let dir = tempfile::tempdir().unwrap();
    let vvol = dir.path().join("s.vvol");
    ok(tool("vol-gen")
        .args(["phantom", "--dims", "40,36,14", "--seed", "3", "-q", "-o"])
        .arg(&vvol));
    let nii = dir.path().join("s.nii");
    convert(&vvol, &[], &nii);
    let med = dir.path().join("med.nii");
    convert(&nii, &["--median", "1"], &med);
    let med2 = dir.path().join("med2.nii");
    convert(&nii, &["--median", "2"], &med2);
    let clamp = dir.path().join("clamp.nii");
    convert(&nii, &["--clamp", "-200:300"], &clamp);
    let thr = dir.path().join("thr.nii");
    convert(&nii, &["--threshold", "20:1200"], &thr);
    let masked = dir.path().join("masked.nii");
    ok(tool("vol-convert")
        .arg(&nii)
        .args(["--mask"])
        .arg(&thr)
        .args(["--background", "-1024", "-q", "-o"])
        .arg(&masked));
    let script = format!(
        r#"
import json, sys
try:
    import SimpleITK as sitk, numpy as np
except ImportError:
    print("SKIP SimpleITK missing"); sys.exit(0)
d = {dir:?} + "/"
rd = lambda n: sitk.GetArrayFromImage(sitk.ReadImage(d + n))
src = sitk.ReadImage(d + "s.nii")
a = sitk.GetArrayFromImage(src)
out = {{}}
for name, r in [("med.nii", 1), ("med2.nii", 2)]:
    want = sitk.GetArrayFromImage(sitk.Median(src, [r, r, r]))
    got = rd(name)
    out[name + " dtype"] = str(got.dtype)
    out[name + " interior"] = bool(np.array_equal(want[r:-r, r:-r, r:-r], got[r:-r, r:-r, r:-r]))
    out[name + " all"] = bool(np.array_equal(want, got))
out["clamp"] = bool(np.array_equal(rd("clamp.nii"), np.clip(a, -200, 300)))
t = rd("thr.nii")
out["thr dtype"] = str(t.dtype)
out["threshold"] = bool(np.array_equal(t, ((a >= 20) & (a <= 1200)).astype(np.uint8)))
out["mask"] = bool(np.array_equal(rd("masked.nii"), np.where(t == 0, -1024, a).astype(a.dtype)))
print(json.dumps(out))
"#,
        dir = dir.path().display().to_string()
    );
    let Some(j) = python_json(&script, "pip install SimpleITK numpy") else {
        return;
    };
    for key in [
        "med.nii interior",
        "med2.nii interior",
        "clamp",
        "threshold",
        "mask",
    ] {
        assert_eq!(j[key], serde_json::json!(true), "{key}: {j}");
    }
    assert_eq!(j["med.nii dtype"], "int16", "{j}");
    assert_eq!(j["thr dtype"], "uint8", "{j}");
}

/// Convert as `n` shards and merge; the merged bytes.
fn sharded(dir: &Path, input: &Path, args: &[&str], n: u32) -> Vec<u8> {
    let mut parts = Vec::new();
    for k in 0..n {
        let p = dir.join(format!("part.{k}.vpart"));
        ok(tool("vol-convert")
            .arg(input)
            .args(args)
            .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
            .arg(&p));
        parts.push(p);
    }
    let out = dir.join("merged.vvol");
    let _ = std::fs::remove_file(&out);
    ok(tool("vol-convert")
        .arg("--merge")
        .args(&parts)
        .args(["-q", "-o"])
        .arg(&out));
    for p in &parts {
        std::fs::remove_file(p).unwrap();
    }
    std::fs::read(&out).unwrap()
}

#[test]
fn sharded_stages_equal_the_unsharded_run_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "40,36,30");
    let cases: [&[&str]; 5] = [
        &["--resample", "spacing:0.8,0.8,1.3", "--kernel", "bspline3"],
        &["--resample", "spacing:1.5", "--kernel", "lanczos3"],
        &["--smooth", "gauss:1.5"],
        &["--median", "1"],
        &[
            "--orient",
            "SAR",
            "--resample",
            "spacing:1",
            "--smooth",
            "gauss:1",
            "--clamp",
            "0:500",
        ],
    ];
    for args in cases {
        for layout in [
            &["--layout", "sliced"][..],
            &["--layout", "bricked:8", "--compress", "zstd"],
        ] {
            let mut all: Vec<&str> = args.to_vec();
            all.extend_from_slice(layout);
            let whole = dir.path().join("whole.vvol");
            convert(&nii, &all, &whole);
            let want = std::fs::read(&whole).unwrap();
            for n in [3, 7] {
                assert!(
                    sharded(dir.path(), &nii, &all, n) == want,
                    "{all:?} in {n} shards"
                );
            }
        }
    }
}

#[test]
fn bad_preprocessing_input_is_refused_in_one_line_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "16,16,8");
    let out = dir.path().join("o.nii");
    let refuse = |args: &[&str], needle: &str| {
        let line = fails(
            tool("vol-convert").arg(&nii).args(args).arg("-o").arg(&out),
            needle,
        );
        assert!(!out.exists(), "{args:?} left {}", out.display());
        line
    };
    for bad in [
        "spacing:0",
        "spacing:-1",
        "spacing:nan",
        "spacing:inf",
        "spacing:1,1",
        "dims:0,4,4",
        "cube:2",
    ] {
        refuse(&["--resample", bad], "--resample");
    }
    refuse(&["--resample", "dims:20000,20000,20000"], "2^40");
    // Fewer voxels than 2^40, but one slice past the slab budget.
    refuse(&["--resample", "dims:100000,100000,1"], "slab budget");
    refuse(
        &["--resample", "like:/nonexistent/grid.nii"],
        "/nonexistent/grid.nii",
    );
    let line = refuse(&["--resample", "spacing:1", "--kernel", "sinc"], "--kernel");
    assert!(
        line.contains("lanczos3") && line.contains("bspline3"),
        "{line}"
    );
    for code in ["RRS", "RA", "RAX"] {
        let line = refuse(&["--orient", code], "--orient");
        assert!(line.contains("R/L") || line.contains("R, L"), "{line}");
    }
    // A mask on another grid names both grids.
    let other = dir.path().join("other.nii");
    convert(&nii, &["--crop", "0:8,:,:"], &other);
    let line = refuse(&["--mask", other.to_str().unwrap()], "other.nii");
    assert!(
        line.contains("16x16x8") && line.contains("8x16x8"),
        "{line}"
    );
    refuse(&["--median", "400"], "--median");
    refuse(&["--median", "0"], "--median");
    refuse(&["--smooth", "gauss:-1"], "--smooth");
    refuse(&["--clamp", "5:1"], "--clamp");
    refuse(&["--threshold", "a:b"], "--threshold");
    // (A window past the slab budget is refused before any work too:
    // volprep's median and gauss unit tests, which need no giant file.)
}

#[test]
fn spacing_relabels_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let nii = phantom(dir.path(), "8,8,4");
    let o = run(tool("vol-convert")
        .arg(&nii)
        .args(["--spacing", "1,1,1", "-o"])
        .arg(dir.path().join("o.nii")));
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("relabels") && err.contains("--resample"),
        "{err}"
    );
}
