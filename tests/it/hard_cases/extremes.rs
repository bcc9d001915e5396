//! Sample extremes (NaN, ±inf, ±FLT_MAX, denormals, the u16 and i16
//! ends) through vol-convert, vol-info, vol-index and vol-psnr.

use super::*;

fn f32_extremes() -> Vec<f32> {
    vec![
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        -f32::MAX,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(0x007f_ffff),
        0.0,
        -0.0,
        1.5,
        -2.5,
    ]
}

fn read_f32(p: &Path) -> Vec<f32> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn f32_extremes_survive_convert_bit_for_bit() {
    let d = tmp();
    let v = f32_extremes();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &v);
    for via in ["a.vvol", "b.vol.tif", "c.tif"] {
        let mid = d.path().join(via);
        ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&mid));
        let back = d
            .path()
            .join(format!("back_{}_4x3x1_f32.raw", via.replace('.', "")));
        ok(bin("vol-convert").arg(&mid).arg("-q").arg("-o").arg(&back));
        let got: Vec<u32> = read_f32(&back).iter().map(|x| x.to_bits()).collect();
        let want: Vec<u32> = v.iter().map(|x| x.to_bits()).collect();
        assert_eq!(got, want, "via {via}");
    }
    // Bricked and compressed copies too.
    let b = d.path().join("b.vvol");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--layout", "bricked:2", "--compress", "zstd", "-q", "-o"])
        .arg(&b));
    let s = ok(bin("vol-psnr").arg(&src).arg(&b));
    assert!(s.contains("identical"), "{s}");
}

#[test]
fn f32_extremes_info_reports_the_range_without_nan() {
    let d = tmp();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &f32_extremes());
    let v = d.path().join("x.vvol");
    ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&v));
    let text = ok(bin("vol-info").arg(&v));
    assert!(text.contains("values -inf .. inf"), "{text}");
    let j = json(&ok(bin("vol-info").arg(&v).arg("--json")));
    // JSON has no infinities: the range is null rather than a lie.
    assert!(j["min"].is_null() && j["max"].is_null(), "{j}");
    let only_nan = raw_f32(d.path(), "n", [2, 1, 1], &[f32::NAN, f32::NAN]);
    let text = ok(bin("vol-info").arg(&only_nan));
    assert!(text.contains("values: none (all NaN)"), "{text}");
}

#[test]
fn f32_extremes_index_counts_nan_and_keeps_range() {
    let d = tmp();
    let src = raw_f32(d.path(), "x", [4, 3, 1], &f32_extremes());
    let j = json(&ok(bin("vol-index")
        .arg(&src)
        .args(["--json", "--cell", "2"])));
    assert_eq!(j["nan_count"], 1);
    let s = ok(bin("vol-index")
        .arg(&src)
        .args(["--stats", "-q", "--cell", "2"]));
    assert!(s.contains("1 NaN"), "{s}");
    // Finite extremes only, without infinities in the data.
    let m = f32::MAX;
    let fin = raw_f32(d.path(), "f", [3, 1, 1], &[-m, 0.0, m]);
    let j = json(&ok(bin("vol-index").arg(&fin).arg("--json")));
    assert!(close(&j["min"], -m as f64), "{j}");
    assert!(close(&j["max"], m as f64), "{j}");
    ok(bin("vol-index")
        .arg("--check")
        .arg(d.path().join("f_3x1x1_f32.raw.vidx"))
        .arg(&fin)
        .arg("-q"));
}

#[test]
fn f32_to_u8_nan_takes_the_bottom_and_extremes_clamp() {
    let d = tmp();
    let src = raw_f32(
        d.path(),
        "x",
        [5, 1, 1],
        &[f32::NAN, f32::NEG_INFINITY, f32::INFINITY, -f32::MAX, 0.5],
    );
    let out = d.path().join("o_5x1x1_u8.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u8", "--window", "0:1", "-q", "-o"])
        .arg(&out));
    assert_eq!(std::fs::read(&out).unwrap(), [0, 0, 255, 0, 128]);
}

#[test]
fn u16_extremes_through_convert_index_and_psnr() {
    let d = tmp();
    let src = raw_16(d.path(), "x", "u16", &[0, 65535, 1, 65534]);
    let out = d.path().join("o_4x1x1_u8.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u8", "--window", "full", "-q", "-o"])
        .arg(&out));
    assert_eq!(std::fs::read(&out).unwrap(), [0, 255, 0, 255]);
    let j = json(&ok(bin("vol-index").arg(&src).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(0.0), Some(65535.0))
    );
    let zero = raw_16(d.path(), "z", "u16", &[65535, 0, 1, 65534]);
    let j = json(&ok(bin("vol-psnr").arg(&src).arg(&zero).arg("--json")));
    // Two errors of 65535 in four: MSE = 65535²/2, PSNR = 10·log10(2).
    assert!(
        (j["psnr"].as_f64().unwrap() - 10.0 * 2f64.log10()).abs() < 1e-12,
        "{j}"
    );
}

#[test]
fn i16_extremes_through_convert_and_index() {
    let d = tmp();
    let src = raw_16(d.path(), "x", "i16", &[-32768, 32767, 0, -1]);
    let out = d.path().join("o_4x1x1_u16.raw");
    ok(bin("vol-convert")
        .arg(&src)
        .args(["--type", "u16", "--window", "full", "-q", "-o"])
        .arg(&out));
    let got: Vec<u16> = std::fs::read(&out)
        .unwrap()
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(got, [0, 65535, 32768, 32767]);
    let j = json(&ok(bin("vol-index").arg(&src).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(-32768.0), Some(32767.0))
    );
    let v = d.path().join("x.vvol");
    ok(bin("vol-convert").arg(&src).arg("-q").arg("-o").arg(&v));
    let j = json(&ok(bin("vol-info").arg(&v).arg("--json")));
    assert_eq!(
        (j["min"].as_f64(), j["max"].as_f64()),
        (Some(-32768.0), Some(32767.0))
    );
}
