//! Documented ranges: values outside them are refused in one line
//! (usage errors), the ends of each range accepted; dimensions whose size
//! overflows are refused.

use super::*;

/// Bug: vol-gen accepted --octaves 0 and 17 (fixed in c80723a).
#[test]
fn gen_octaves_outside_1_to_16_are_refused() {
    let d = tmp();
    for o in ["0", "17", "-1"] {
        let out = run(bin("vol-gen")
            .args(["noise", "--dims", "4,4,4", "--octaves", o, "-o"])
            .arg(d.path().join("n.vvol")));
        assert_eq!(code(&out), 2, "--octaves {o}: {out:?}");
        assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    }
    gen(
        d.path(),
        "ok.vvol",
        &["noise", "--dims", "4,4,4", "--octaves", "16"],
    );
}

/// Bug: vol-gen accepted --value 300 for u8 (fixed in c80723a).
#[test]
fn gen_value_must_fit_the_sample_type() {
    let d = tmp();
    let o = d.path().join("v.vvol");
    for (t, v) in [
        ("u8", "300"),
        ("u8", "-1"),
        ("u16", "65536"),
        ("i16", "-32769"),
        ("i16", "40000"),
        ("f32", "nan"),
        ("f32", "inf"),
    ] {
        let out = run(bin("vol-gen")
            .args(["solid", "--dims", "4,4,4", "--type", t, "--value", v, "-o"])
            .arg(&o));
        assert_eq!(code(&out), 2, "{t} {v}: {out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--value"), "{err}");
    }
    assert!(!o.exists());
    // The ends of each range are accepted and stored exactly.
    for (t, v, want) in [
        ("u8", "255", 255.0),
        ("i16", "-32768", -32768.0),
        ("u16", "65535", 65535.0),
    ] {
        let p = gen(
            d.path(),
            &format!("{t}.vvol"),
            &["box", "--dims", "4,4,4", "--type", t, "--value", v],
        );
        let j = json(&ok(bin("vol-info").arg(&p).arg("--json")));
        assert!(j["min"] == want || j["max"] == want, "{t}: {j}");
    }
}

#[test]
fn gen_other_documented_ranges_are_enforced() {
    let d = tmp();
    let o = d.path().join("x.vvol");
    for args in [
        &["noise", "--period", "0.5"][..],
        &["noise", "--period", "inf"],
        &["sphere", "--radius", "0"],
        &["sphere", "--radius", "-3"],
        &["sphere", "--radius", "nan"],
        &["shapes", "--count", "100001"],
        &["shapes", "--size", "0"],
        &["shapes", "--size", "4294967296"],
        &["box", "--margin", "2"],
        &["solid", "--layout", "bricked:1"],
        &["solid", "--layout", "bricked:1025"],
        &["solid", "--layout", "bricked:2", "--compress", "zstd:23"],
        &["solid", "--spacing", "1,0,1"],
    ] {
        let out = run(bin("vol-gen")
            .args(args)
            .args(["--dims", "4,4,4", "-o"])
            .arg(&o));
        assert_eq!(code(&out), 2, "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
    assert!(!o.exists());
}

#[test]
fn gen_zero_and_overflowing_dims_are_refused() {
    let d = tmp();
    for dims in ["0,4,4", "4,4", "4294967296,4294967296,4294967296"] {
        let out = run(bin("vol-gen")
            .args(["solid", "--dims", dims, "-o"])
            .arg(d.path().join("x.vvol")));
        assert!(matches!(code(&out), 1 | 2), "{dims}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{dims}"
        );
    }
}

/// Dimensions whose bricked bytes pass u64 are refused with one line.
/// Bug: the header's data length was multiplied unchecked (unwrap audit, f67a976).
#[test]
fn a_bricked_volume_whose_bytes_pass_u64_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.vvol");
    fails(
        tool("vol-gen")
            .args([
                "solid",
                "--dims",
                "16777216,16777216,16383",
                "--type",
                "f32",
            ])
            .args(["--layout", "bricked:1024", "-o"])
            .arg(&out),
        "overflows",
    );
    assert!(!out.exists());
    assert!(leftovers(dir.path()).is_empty());
}

#[test]
fn index_cell_and_bins_ranges_are_enforced() {
    let d = tmp();
    let v = gen(d.path(), "a.vvol", &["solid", "--dims", "4,4,4"]);
    for (flag, val) in [
        ("--cell", "1"),
        ("--cell", "1025"),
        ("--bins", "0"),
        ("--bins", "65537"),
    ] {
        fails(bin("vol-index").arg(&v).args([flag, val]), val);
    }
    assert!(!d.path().join("a.vvol.vidx").exists());
    ok(bin("vol-index")
        .arg(&v)
        .args(["--cell", "1024", "--bins", "65536", "-q"]));
}

#[test]
fn convert_window_and_crop_ranges_are_enforced() {
    let d = tmp();
    let v = gen(
        d.path(),
        "a.vvol",
        &["ramp", "--dims", "4,4,4", "--type", "u16"],
    );
    let o = d.path().join("o.vvol");
    for args in [
        &["--type", "u8", "--window", "5:5"][..],
        &["--type", "u8", "--window", "9:1"],
        &["--type", "u8", "--window", "auto:50"],
        &["--type", "u8", "--window", "nan:3"],
        &["--crop", "0:5,:,:"],
        &["--crop", "3:2,:,:"],
    ] {
        let out = run(bin("vol-convert").arg(&v).args(args).arg("-o").arg(&o));
        assert!(matches!(code(&out), 1 | 2), "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
    assert!(!o.exists());
}

#[test]
fn psnr_range_and_min_psnr_are_validated() {
    let d = tmp();
    let a = gen(d.path(), "a.vvol", &["solid", "--dims", "2,2,2"]);
    for args in [
        ["--range", "0"],
        ["--range", "-1"],
        ["--range", "nan"],
        ["--min-psnr", "nan"],
    ] {
        let out = run(bin("vol-psnr").arg(&a).arg(&a).args(args));
        assert_eq!(code(&out), 2, "{args:?}: {out:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).lines().count(),
            1,
            "{args:?}"
        );
    }
}
