//! `vol-info --stats`, `--mask`, `--labels` (issue 53 §5): the figures
//! against a plain computation and against numpy, text and JSON, the
//! refusals, and no file written.

use crate::common::{fails, json, ok, python_json, run, tool};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Write samples as a raw file whose name carries dims and type.
fn raw<T: Copy>(
    dir: &Path,
    stem: &str,
    dims: [u64; 3],
    ty: &str,
    v: &[T],
    bytes: fn(T) -> Vec<u8>,
) -> PathBuf {
    let p = dir.join(format!(
        "{stem}_{}x{}x{}_{ty}.raw",
        dims[0], dims[1], dims[2]
    ));
    let data: Vec<u8> = v.iter().flat_map(|&x| bytes(x)).collect();
    std::fs::write(&p, data).unwrap();
    p
}

fn f32_raw(dir: &Path, stem: &str, dims: [u64; 3], v: &[f32]) -> PathBuf {
    raw(dir, stem, dims, "float32", v, |x| x.to_le_bytes().to_vec())
}

fn u8_raw(dir: &Path, stem: &str, dims: [u64; 3], v: &[u8]) -> PathBuf {
    raw(dir, stem, dims, "uint8", v, |x| vec![x])
}

/// numpy's mean, std() and percentile (linear) of `xs`, sorted here.
fn reference(xs: &[f64]) -> (f64, f64, Vec<f64>) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let sd = (xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n).sqrt();
    let mut s = xs.to_vec();
    s.sort_by(f64::total_cmp);
    let pct = [1, 5, 25, 50, 75, 95, 99]
        .iter()
        .map(|&p| {
            let h = (s.len() - 1) as f64 * (p as f64 / 100.0);
            let (lo, t) = (h.floor() as usize, h - h.floor());
            let (a, b) = (s[lo], s[(lo + 1).min(s.len() - 1)]);
            if t >= 0.5 {
                b - (b - a) * (1.0 - t)
            } else {
                a + (b - a) * t
            }
        })
        .collect();
    (mean, sd, pct)
}

fn close(a: &Value, b: f64) -> bool {
    let a = a.as_f64().unwrap();
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300)
}

/// Check a `stats` (or `per_label` entry) object against `xs`.
fn check(s: &Value, xs: &[f64], percentiles: bool) {
    let (mean, sd, pct) = reference(xs);
    assert_eq!(s["count"], xs.len() as u64, "{s}");
    assert!(
        close(&s["mean"], mean) && close(&s["sd"], sd),
        "{s}: {mean} {sd}"
    );
    let min = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let max = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(
        (s["min"].as_f64(), s["max"].as_f64()),
        (Some(min), Some(max))
    );
    if percentiles {
        for (p, want) in [1, 5, 25, 50, 75, 95, 99].iter().zip(pct) {
            assert_eq!(
                s["percentiles"][format!("p{p}")].as_f64(),
                Some(want),
                "p{p}"
            );
        }
    }
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A float volume with NaN and infinities, a mask and labels.
fn inputs(d: &Path) -> (Vec<f32>, Vec<u8>, Vec<u8>, [PathBuf; 3]) {
    let dims = [37, 23, 19];
    let n = 37 * 23 * 19;
    let mut rng = fastrand::Rng::with_seed(53);
    let mut v: Vec<f32> = (0..n).map(|_| 100.0 + 15.0 * (rng.f32() - 0.5)).collect();
    v[7] = f32::NAN;
    v[100] = f32::INFINITY;
    v[200] = f32::NEG_INFINITY;
    let mask: Vec<u8> = (0..n).map(|i| (i % 3 != 0) as u8).collect();
    let labels: Vec<u8> = (0..n).map(|i| [0, 1, 7][i / 1000 % 3]).collect();
    let paths = [
        f32_raw(d, "v", dims, &v),
        u8_raw(d, "mask", dims, &mask),
        u8_raw(d, "labels", dims, &labels),
    ];
    (v, mask, labels, paths)
}

#[test]
fn stats_match_a_plain_computation_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (v, _, _, [vol, ..]) = inputs(d);
    let before = files(d);
    let j = json(&ok(tool("vol-info").arg(&vol).args(["--stats", "--json"])));
    let s = &j["stats"];
    let finite: Vec<f64> = v
        .iter()
        .filter(|x| x.is_finite())
        .map(|&x| x as f64)
        .collect();
    check(s, &finite, true);
    assert_eq!(
        (&s["voxels"], &s["nan_count"], &s["inf_count"]),
        (&v.len().into(), &1.into(), &2.into())
    );
    assert_eq!(
        (&s["ddof"], &s["type"], &s["mask"]),
        (&0.into(), &"f32".into(), &Value::Null)
    );
    let h = &s["histogram"];
    assert_eq!(h["bins"], 256);
    let total: u64 = h["counts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .sum();
    assert_eq!(total, finite.len() as u64);
    // --bins means vol-index's: 16 bins.
    let j = json(&ok(tool("vol-info")
        .arg(&vol)
        .args(["--stats", "--json", "--bins", "16"])));
    assert_eq!(j["stats"]["histogram"]["bins"], 16);
    let text = ok(tool("vol-info").arg(&vol).arg("--stats"));
    for part in [
        "stats (f32) of 16169 voxels",
        "1 NaN, 2 infinite (left out of the figures)",
        "count 16166, min ",
        "(ddof 0)",
        "percentiles (exact, linear): p1 ",
        "histogram: 256 bins over [",
    ] {
        assert!(text.contains(part), "missing '{part}' in:\n{text}");
    }
    assert_eq!(files(d), before, "--stats wrote a file");
    // Without --stats: no figures.
    let j = json(&ok(tool("vol-info").arg(&vol).arg("--json")));
    assert!(j.get("stats").is_none());
}

#[test]
fn a_mask_and_labels_restrict_and_split_the_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (v, mask, labels, [vol, m, l]) = inputs(d);
    let j = json(&ok(tool("vol-info")
        .arg(&vol)
        .arg("--mask")
        .arg(&m)
        .arg("--labels")
        .arg(&l)
        .args(["--json"])));
    let s = &j["stats"];
    let inside = |i: usize| mask[i] != 0 && v[i].is_finite();
    let xs: Vec<f64> = (0..v.len())
        .filter(|&i| inside(i))
        .map(|i| v[i] as f64)
        .collect();
    check(s, &xs, true);
    assert_eq!(s["mask"], m.display().to_string());
    let per = s["per_label"].as_array().unwrap();
    assert_eq!(
        per.iter()
            .map(|e| e["label"].as_i64().unwrap())
            .collect::<Vec<_>>(),
        [0, 1, 7]
    );
    for e in per {
        let label = e["label"].as_u64().unwrap() as u8;
        let xs: Vec<f64> = (0..v.len())
            .filter(|&i| inside(i) && labels[i] == label)
            .map(|i| v[i] as f64)
            .collect();
        check(e, &xs, false);
        let voxels = (0..v.len())
            .filter(|&i| mask[i] != 0 && labels[i] == label)
            .count();
        assert_eq!(e["voxels"], voxels as u64);
        // Spacing 1 (a raw file): the volume is the voxel count.
        assert_eq!(e["volume"].as_f64(), Some(voxels as f64));
    }
    let text = ok(tool("vol-info").arg(&vol).arg("--labels").arg(&l));
    assert!(
        text.contains("LABEL  VOXELS  VOLUME (spacing unit³)  MEAN"),
        "{text}"
    );
    assert!(
        text.contains("labels of ") && text.contains(": 3\n"),
        "{text}"
    );
}

#[test]
fn an_empty_mask_gives_counts_and_no_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_, _, _, [vol, ..]) = inputs(d);
    let zero = u8_raw(d, "zero", [37, 23, 19], &vec![0; 37 * 23 * 19]);
    let j = json(&ok(tool("vol-info")
        .arg(&vol)
        .arg("--mask")
        .arg(&zero)
        .arg("--json")));
    let s = &j["stats"];
    assert_eq!((&s["voxels"], &s["count"]), (&0.into(), &0.into()));
    for k in ["mean", "sd", "min", "max", "percentiles", "histogram"] {
        assert_eq!(s[k], Value::Null, "{k}");
    }
    let text = ok(tool("vol-info").arg(&vol).arg("--mask").arg(&zero));
    assert!(
        text.contains("count 0: no finite sample, no figures"),
        "{text}"
    );
}

#[test]
fn mismatched_files_and_bad_labels_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (v, _, _, [vol, ..]) = inputs(d);
    let small = u8_raw(d, "small", [4, 4, 4], &[1; 64]);
    for flag in ["--mask", "--labels"] {
        let out = run(tool("vol-info").arg(&vol).arg(flag).arg(&small));
        assert_eq!(out.status.code(), Some(2), "{flag}");
        let line = fails(tool("vol-info").arg(&vol).arg(flag).arg(&small), "4x4x4");
        assert!(
            line.contains("37x23x19") && line.contains("small_4x4x4"),
            "{line}"
        );
        assert!(line.contains(&vol.display().to_string()), "{line}");
    }
    // Float labels that are not whole numbers.
    let frac: Vec<f32> = v.iter().map(|_| 0.5).collect();
    let f = f32_raw(d, "frac", [37, 23, 19], &frac);
    fails(
        tool("vol-info").arg(&vol).arg("--labels").arg(&f),
        "label value 0.5 is not a whole number",
    );
    // Standard input as a mask: refused (exit 2).
    let out = run(tool("vol-info").arg(&vol).args(["--mask", "-"]));
    assert_eq!(out.status.code(), Some(2));
    fails(
        tool("vol-info")
            .arg(&vol)
            .arg("--mask")
            .arg(d.join("missing.nrrd")),
        "missing.nrrd",
    );
    let out = run(tool("vol-info").arg(&vol).args(["--stats", "--bins", "0"]));
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn standard_input_gives_the_figures_of_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = d.join("n.vvol");
    ok(tool("vol-gen")
        .args(["noise", "--dims", "40,30,20", "--type", "f32", "-q", "-o"])
        .arg(&vol));
    let file = json(&ok(tool("vol-info").arg(&vol).args(["--stats", "--json"])));
    let piped = json(&ok(tool("vol-info")
        .args(["-", "--stats", "--json"])
        .stdin(std::fs::File::open(&vol).unwrap())));
    assert_eq!(piped["stats"], file["stats"]);
}

#[test]
fn figures_match_numpy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_string_lossy().into_owned();
    let script = format!(
        r#"
import json, subprocess, sys
try:
    import numpy as np
except ImportError as e:
    print("SKIP", e); sys.exit(0)
rng = np.random.default_rng(5)
out = {{}}
for ty, a in [
    ("float64", rng.normal(100, 15, (30, 40, 50))),
    ("int16", rng.integers(-3000, 3000, (30, 40, 50)).astype(np.int16)),
    ("float32", rng.random((30, 40, 50), dtype=np.float32) * 1e3),
]:
    p = {d:?} + "/a_50x40x30_" + ty + ".raw"
    a.astype(a.dtype.newbyteorder("<")).tofile(p)
    s = json.loads(subprocess.run([{exe:?}, p, "--stats", "--json"], capture_output=True,
                                  text=True, check=True).stdout)["stats"]
    f = a.astype(np.float64).ravel()
    rel = lambda x, y: abs(x - y) / max(abs(y), 1e-300)
    pct = np.percentile(f, [1, 5, 25, 50, 75, 95, 99])
    out[ty] = {{
        "mean": rel(s["mean"], f.mean()),
        "sd": rel(s["sd"], f.std()),
        "percentiles": max(rel(s["percentiles"]["p%d" % p], v)
                           for p, v in zip([1, 5, 25, 50, 75, 95, 99], pct)),
        "range": [bool(s["min"] == f.min()), bool(s["max"] == f.max())],
    }}
print(json.dumps(out))
"#,
        exe = env!("CARGO_BIN_EXE_vol-info"),
    );
    let Some(v) = python_json(&script, "pip install numpy") else {
        return;
    };
    for (ty, r) in v.as_object().unwrap() {
        for k in ["mean", "sd", "percentiles"] {
            assert!(r[k].as_f64().unwrap() <= 1e-12, "{ty} {k}: {r}");
        }
        assert_eq!(r["range"], serde_json::json!([true, true]), "{ty}");
    }
}
