//! `vol-convert --time-point all` (issue 64 §4): every volume of a 4D
//! input into one 4D NIfTI, each volume through the same stages, and back:
//! `--time-point k` of the 4D NIfTI equals `--time-point k` of the input.

use crate::common::{fails, json, ok, tool};
use crate::dicom::{convert, mr_folder};

#[test]
fn a_dicom_time_series_round_trips_through_one_4d_nifti() {
    let d = tempfile::tempdir().unwrap();
    let run = mr_folder(&d.path().join("run"), 4, 3, 1);
    let four = d.path().join("run.nii.gz");
    let j = json(&ok(tool("vol-convert")
        .arg(&run)
        .args(["--time-point", "all", "--flip", "x", "--json", "-o"])
        .arg(&four)));
    // The time step is the RepetitionTime, as dcm2niix writes it.
    assert_eq!(
        (j["time_points"].as_u64(), j["time_step"].as_f64()),
        (Some(3), Some(2.0)),
        "{j}"
    );
    let info = json(&ok(tool("vol-info").arg(&four).arg("--json")));
    assert_eq!(info["dims"], serde_json::json!([4, 3, 4]), "{info}");
    assert_eq!(
        (info["time_points"].as_u64(), info["time_step"].as_f64()),
        (Some(3), Some(2.0)),
        "{info}"
    );
    assert_eq!(info["time_unit"], "second", "{info}");
    let mut volumes = Vec::new();
    for t in 0..3 {
        let k = t.to_string();
        let (want, _) = convert(&run, &["--time-point", &k, "--flip", "x"]);
        let (got, _) = convert(&four, &["--time-point", &k]);
        assert!(got == want, "time point {t} differs after the round trip");
        volumes.push(got);
    }
    // The volumes are distinct (the pixels say their time point).
    assert!(volumes[0] != volumes[1] && volumes[1] != volumes[2]);
    // A 4D NIfTI in, the same 4D NIfTI out (uncompressed this time).
    let again = d.path().join("again.nii");
    ok(tool("vol-convert")
        .arg(&four)
        .args(["--time-point", "all", "-q", "-o"])
        .arg(&again));
    for (t, want) in volumes.iter().enumerate() {
        let k = t.to_string();
        let (got, _) = convert(&again, &["--time-point", &k]);
        assert!(
            got == *want,
            "time point {t} differs in the second 4D NIfTI"
        );
    }
}

#[test]
fn all_time_points_is_refused_where_it_cannot_be_written() {
    let d = tempfile::tempdir().unwrap();
    let run = mr_folder(&d.path().join("run"), 2, 2, 1);
    let err = fails(
        tool("vol-convert")
            .arg(&run)
            .args(["--time-point", "all", "-o"])
            .arg(d.path().join("run.nrrd")),
        "one 4D NIfTI",
    );
    assert!(err.contains("run.nrrd"), "{err}");
    assert!(!d.path().join("run.nrrd").exists());
    fails(
        tool("vol-info").arg(&run).args(["--time-point", "all"]),
        "is vol-convert's",
    );
    fails(
        tool("vol-convert")
            .arg(&run)
            .args(["--time-point", "some", "-o"])
            .arg(d.path().join("x.nii")),
        "no time point",
    );
    // A volume that fails leaves no output and no scratch behind.
    fails(
        tool("vol-convert")
            .arg(&run)
            .args(["--time-point", "all", "--crop", "9:10,,", "-o"])
            .arg(d.path().join("bad.nii")),
        "time point 0",
    );
    let left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "run")
        .collect();
    assert!(left.is_empty(), "{left:?}");
}
