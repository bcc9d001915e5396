//! vol-psnr and non-finite figures: NaN, infinities, FLT_MAX, denormals
//! and the i16 ends against the gates, the JSON counts and closed forms.

use super::*;

fn pfm(dir: &Path, name: &str, w: u32, h: u32, v: &[f32]) -> PathBuf {
    let p = dir.join(name);
    volcompare::pfm::write_pfm_channels(&p, w, h, 1, v).unwrap();
    p
}

/// Bug: a NaN or infinite difference passed `vol-psnr --min-psnr inf` (fixed in bffd864).
#[test]
fn psnr_min_inf_fails_an_image_with_one_nan_pixel() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 3, 2, &[0.5; 6]);
    let mut v = [0.5f32; 6];
    v[4] = f32::NAN;
    let b = pfm(d.path(), "b.pfm", 3, 2, &v);
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "inf"]));
    assert_eq!(code(&out), 4, "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("not finite 1"));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not finite"));
}

#[test]
fn psnr_infinite_pixel_fails_min_psnr_40() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 2, 2, &[0.25; 4]);
    let b = pfm(d.path(), "b.pfm", 2, 2, &[0.25, f32::INFINITY, 0.25, 0.25]);
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "40"]));
    assert_eq!(code(&out), 4, "{out:?}");
    // Even the lowest gate fails.
    let out = run(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr=-inf"]));
    assert_eq!(code(&out), 4, "{out:?}");
}

#[test]
fn psnr_json_counts_nonfinite_differences() {
    let d = tmp();
    let a = pfm(d.path(), "a.pfm", 4, 1, &[0.0, 1.0, f32::NAN, 0.5]);
    let b = pfm(
        d.path(),
        "b.pfm",
        4,
        1,
        &[f32::NAN, f32::NEG_INFINITY, f32::NAN, 0.5],
    );
    let out = run(bin("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--min-psnr", "0"]));
    assert_eq!(code(&out), 4);
    let j = json(&String::from_utf8_lossy(&out.stdout));
    // NaN equals NaN; NaN against 0 and -inf against 1 are not finite.
    assert_eq!(j["nonfinite"], 2);
    assert_eq!(j["differing"], 2);
    assert_eq!(j["passed"], false);
}

#[test]
fn psnr_nan_in_both_inputs_is_identical() {
    let d = tmp();
    let v = [f32::NAN, 1.0, f32::INFINITY, -0.0];
    let a = pfm(d.path(), "a.pfm", 2, 2, &v);
    let b = pfm(d.path(), "b.pfm", 2, 2, &v);
    let s = ok(bin("vol-psnr").arg(&a).arg(&b).args(["--min-psnr", "inf"]));
    assert!(s.contains("PSNR inf (identical)"), "{s}");
}

#[test]
fn psnr_f32_volumes_with_nan_and_inf_fail_the_gate() {
    let d = tmp();
    let a = raw_f32(d.path(), "a", [4, 1, 1], &[1.0, 2.0, 3.0, 4.0]);
    let b = raw_f32(
        d.path(),
        "b",
        [4, 1, 1],
        &[1.0, f32::NAN, 3.0, f32::INFINITY],
    );
    let out = run(bin("vol-psnr")
        .arg(&a)
        .arg(&b)
        .args(["--json", "--min-psnr", "10"]));
    assert_eq!(code(&out), 4);
    let j = json(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(j["nonfinite"], 2);
    assert_eq!(j["mse"], 0.0);
}

#[test]
fn psnr_flt_max_extremes_stay_finite_in_f64() {
    let d = tmp();
    let m = f32::MAX;
    let a = raw_f32(d.path(), "a", [2, 1, 1], &[m, -m]);
    let b = raw_f32(d.path(), "b", [2, 1, 1], &[-m, m]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(j["nonfinite"], 0);
    assert!(close(&j["max_abs"], 2.0 * m as f64), "{j}");
    // Closed form: every |d| is 2·FLT_MAX = the peak, so PSNR = 0 dB.
    assert_eq!(j["psnr"], 0.0);
}

#[test]
fn psnr_denormals_differ_and_are_measured() {
    let d = tmp();
    let tiny = f32::from_bits(1); // the smallest denormal
    let a = raw_f32(d.path(), "a", [2, 1, 1], &[tiny, 1.0]);
    let b = raw_f32(d.path(), "b", [2, 1, 1], &[0.0, 1.0]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    assert_eq!(j["differing"], 1);
    assert_eq!(j["max_abs"], tiny as f64);
    assert_eq!(j["nonfinite"], 0);
}

#[test]
fn psnr_i16_extremes_give_zero_db() {
    let d = tmp();
    let a = raw_16(d.path(), "a", "i16", &[-32768, -32768]);
    let b = raw_16(d.path(), "b", "i16", &[32767, 32767]);
    let j = json(&ok(bin("vol-psnr").arg(&a).arg(&b).arg("--json")));
    // |d| = 65535 = the i16 type range, the peak.
    assert_eq!(j["max_abs"], 65535.0);
    assert_eq!(j["peak"], 65535.0);
    assert_eq!(j["psnr"], 0.0);
}
