//! `vol-convert EXPORT/ --series all -o TEMPLATE` (issue 64 §8): every
//! series of a folder after one scan, each into the file the template
//! names; a time series as one 4D NIfTI; a series that cannot be read
//! listed with its reason, the rest written.

use crate::common::{fails, json, ok, run, tool};
use crate::dicom::{convert, ct_folder, ct_slice, mr_folder, secondary_capture, EXPLICIT_LE};

#[test]
fn every_series_of_an_export_is_written_by_its_template() {
    let d = tempfile::tempdir().unwrap();
    let export = ct_folder(&d.path().join("export"), 6);
    mr_folder(&export, 4, 3, 1);
    std::fs::write(
        export.join("capture.dcm"),
        secondary_capture().file(EXPLICIT_LE),
    )
    .unwrap();
    // Series 7: slice 3 is missing.
    for z in [0, 1, 2, 4, 5] {
        let f = ct_slice(z)
            .set(0x0020_000e, b"UI", "1.2.826.0.1.3680043.8.498.64.7")
            .set(
                0x0008_0018,
                b"UI",
                format!("1.2.826.0.1.3680043.8.498.64.7.{z}"),
            )
            .set(0x0020_0011, b"IS", "7");
        std::fs::write(export.join(format!("gap{z}.dcm")), f.file(EXPLICIT_LE)).unwrap();
    }
    let out = d.path().join("nifti");
    let template = format!("{}/{{number}}_{{modality}}.nii.gz", out.display());
    let j = json(&ok(tool("vol-convert")
        .arg(&export)
        .args(["--series", "all", "--json", "-o", &template])));
    let status: Vec<(String, String)> = j["series"]
        .as_array()
        .unwrap_or_else(|| panic!("{j}"))
        .iter()
        .map(|s| {
            (
                s["id"].as_str().unwrap().to_string(),
                s["status"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let want: Vec<(String, String)> = [("3", "written"), ("5", "written"), ("7", "skipped")]
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    assert_eq!(status, want, "{j}");
    assert!(
        j["series"][2]["reason"]
            .as_str()
            .unwrap()
            .contains("missing"),
        "{j}"
    );
    // The CT as --series 3 converts it; the MR run as one 4D NIfTI whose
    // time points are the run's.
    let (want, _) = convert(&export, &["--series", "3"]);
    let (got, _) = convert(&out.join("3_CT.nii.gz"), &[]);
    assert!(got == want, "series 3 differs from --series 3");
    let info = json(&ok(tool("vol-info")
        .arg(out.join("5_MR.nii.gz"))
        .arg("--json")));
    assert_eq!(info["time_points"], 3, "{info}");
    for t in ["0", "2"] {
        let (want, _) = convert(&export, &["--series", "5", "--time-point", t]);
        let (got, _) = convert(&out.join("5_MR.nii.gz"), &["--time-point", t]);
        assert!(got == want, "time point {t} of series 5 differs");
    }
    assert!(!out.join("7_CT.nii.gz").exists());
    // The table on stderr says the same.
    let o = run(tool("vol-convert")
        .arg(&export)
        .args(["--series", "all", "-o", &template]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("3 series") && err.contains("2 written, 1 not"),
        "{err}"
    );
    assert!(
        err.contains("skipped:") && err.contains("1 files joined no series"),
        "{err}"
    );
}

#[test]
fn an_export_without_a_template_or_of_no_dicom_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let export = ct_folder(&d.path().join("export"), 3);
    mr_folder(&export, 2, 1, 1);
    fails(
        tool("vol-convert")
            .arg(&export)
            .args(["--series", "all", "-o"])
            .arg(d.path().join("one.nii")),
        "name them with a template",
    );
    let vvol = d.path().join("v.vvol");
    ok(tool("vol-gen")
        .args(["shapes", "--dims", "8,8,8", "-q", "-o"])
        .arg(&vvol));
    fails(
        tool("vol-convert")
            .arg(&vvol)
            .args(["--series", "all", "-o"])
            .arg(d.path().join("{number}.nii")),
        "converts every series of a DICOM input",
    );
}
