//! End-to-end test of vol-accuracy, the accuracy-against-time harness: the
//! quick study runs, writes the CSV with every knob's rows, and the error
//! falls as the step shrinks.

use crate::common::{fails, ok, tool};
use std::collections::HashMap;

/// One parsed CSV row: (scene, knob, value) -> (median_s, samples, psnr_db).
type Rows = HashMap<(String, String, String), (f64, u64, f64)>;

fn parse_csv(text: &str) -> Rows {
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("scene,knob,value,median_s,min_s,max_s,samples,psnr_db,build_s")
    );
    let mut rows = Rows::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 9, "bad row: {line}");
        let build: f64 = f[8].parse().expect("build_s");
        // Only an AO field (and a budget's probe frames) is computed
        // outside the frame.
        let built = f[1].starts_with("AO field") || f[1] == "budget";
        assert_eq!(build > 0.0, built, "build_s: {line}");
        let median: f64 = f[3].parse().expect("median_s");
        let min: f64 = f[4].parse().expect("min_s");
        let max: f64 = f[5].parse().expect("max_s");
        assert!(
            min <= median && median <= max && min > 0.0,
            "spread: {line}"
        );
        let samples: u64 = f[6].parse().expect("samples");
        // "inf" (the reference, or an image equal to it) parses as f64.
        let psnr: f64 = f[7].parse().expect("psnr_db");
        let key = (f[0].to_string(), f[1].to_string(), f[2].to_string());
        assert!(
            rows.insert(key, (median, samples, psnr)).is_none(),
            "duplicate: {line}"
        );
    }
    rows
}

#[test]
fn quick_study_writes_rows_and_error_falls_with_step() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("acc");
    // -o, -q and --json as every tool takes them: no progress lines, one
    // JSON object naming the table.
    let o = crate::common::run(
        tool("vol-accuracy")
            .args(["--quick", "-q", "--json", "-o"])
            .arg(&out),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j = crate::common::json(&String::from_utf8_lossy(&o.stdout));
    assert_eq!(j["tool"], "vol-accuracy", "{j}");
    assert_eq!(
        j["files"][0],
        out.join("accuracy.csv").display().to_string()
    );
    assert_eq!(j["files"][1], out.join("methods.md").display().to_string());
    let text = std::fs::read_to_string(out.join("accuracy.csv")).unwrap();
    let rows = parse_csv(&text);

    let expected: &[(&str, &[&str])] = &[
        ("reference", &["0.02"]),
        ("step", &["0.05", "0.2", "0.8", "1.6"]),
        ("budget", &["0.01", "0.04"]),
        ("ert", &["0.9", "0.99", "off"]),
        ("interp", &["nearest", "trilinear"]),
        ("gradient", &["central", "analytic"]),
        ("cell", &["4", "16"]),
        ("tile", &["8", "32"]),
        ("threads", &["1", "2"]),
    ];
    let per_scene: usize = expected.iter().map(|(_, v)| v.len()).sum();
    let scenes = ["thesis", "noise", "boundary", "ct"];
    // The steps again, pre-integrated, on the scenes with a 1D transfer
    // function (not `boundary`).
    let pre_scenes = ["thesis", "noise", "ct"];
    let steps = expected[1].1;
    // And adaptive steps' tolerances, on the same scenes.
    let tolerances = ["0.01", "0.1"];
    // The thesis and CT scenes' shadow studies: reference, off, 2 ray
    // steps, 2 grids; and their AO studies: reference, off, 2 ray counts,
    // 2 fields, 1 finer field.
    let effect_scenes = ["thesis", "ct"];
    let (shadow_rows, ao_rows) = (6, 7);
    assert_eq!(
        rows.len(),
        scenes.len() * per_scene
            + pre_scenes.len() * (steps.len() + tolerances.len())
            + effect_scenes.len() * (shadow_rows + ao_rows),
        "{text}"
    );
    for scene in effect_scenes {
        let get = |study: &str, knob: &str, v: &str| {
            let key = (format!("{scene}-{study}"), knob.to_string(), v.to_string());
            *rows
                .get(&key)
                .unwrap_or_else(|| panic!("missing row {key:?}"))
        };
        let shadow = |knob: &str, v: &str| get("shadows", knob, v);
        assert!(shadow("reference", "ray:0.1").2.is_infinite());
        let off = shadow("shadows off", "off").2;
        let ray = shadow("shadow rays", "0.5").2;
        let grid = shadow("shadow grid", "2").2;
        shadow("shadow rays", "2");
        shadow("shadow grid", "4");
        // Shadows matter in these scenes, and both methods come closer to
        // the reference than leaving them off.
        assert!(
            off.is_finite() && ray > off && grid > off,
            "{scene}: {text}"
        );
        let ao = |knob: &str, v: &str| get("ao", knob, v);
        assert!(ao("reference", "rays:64").2.is_infinite());
        let (off, few, many) = (
            ao("AO off", "off").2,
            ao("AO rays", "4").2,
            ao("AO rays", "16").2,
        );
        let (k16, k32) = (ao("AO field", "16").2, ao("AO field", "32").2);
        ao("AO field cell", "4");
        // Occlusion matters here; more directions come closer to the
        // reference, and a field beats leaving AO off.
        assert!(
            off.is_finite() && few > off && many > few,
            "{scene}: {text}"
        );
        assert!(k16 > off && k32 > off, "{scene}: {text}");
    }
    for scene in scenes {
        for (knob, values) in expected {
            for v in *values {
                let key = (scene.to_string(), knob.to_string(), v.to_string());
                assert!(rows.contains_key(&key), "missing row {key:?}");
            }
        }
        let get = |knob: &str, v: &str| rows[&(scene.to_string(), knob.to_string(), v.to_string())];
        // Error falls as the step shrinks, and more samples are taken.
        let (_, fine_samples, fine) = get("step", "0.05");
        let (_, coarse_samples, coarse) = get("step", "1.6");
        assert!(fine.is_finite() && coarse.is_finite(), "{scene}: psnr");
        assert!(
            get("reference", "0.02").2.is_infinite(),
            "{scene}: reference"
        );
        assert!(
            fine > coarse,
            "{scene}: PSNR at step 0.05 ({fine}) <= at 1.6 ({coarse})"
        );
        assert!(fine_samples > coarse_samples, "{scene}: samples");
        // A frame-time budget's frames are measured against the
        // reference (which one they pick depends on the machine's speed).
        let (_, tight_samples, tight) = get("budget", "0.01");
        let (_, _, loose) = get("budget", "0.04");
        assert!(
            tight.is_finite() && loose.is_finite(),
            "{scene}: budget PSNR"
        );
        assert!(tight_samples > 0, "{scene}: budget samples");
        if pre_scenes.contains(&scene) {
            let (_, _, pre_fine) = get("preintegrated", "0.05");
            let (_, _, pre_coarse) = get("preintegrated", "1.6");
            assert!(pre_fine > pre_coarse, "{scene}: pre-integrated PSNR");
            // A tighter tolerance takes more samples, and is closer.
            let (_, tight_samples, tight) = get("adaptive", "0.01");
            let (_, loose_samples, loose) = get("adaptive", "0.1");
            assert!(tight_samples > loose_samples, "{scene}: adaptive samples");
            assert!(tight >= loose, "{scene}: adaptive PSNR {tight} < {loose}");
        }
        // Tiles and threads change the time only, never the image.
        assert_eq!(get("tile", "8").2, get("tile", "32").2, "{scene}: tile");
        assert_eq!(
            get("threads", "1").2,
            get("threads", "2").2,
            "{scene}: threads"
        );
    }
    // Time to each PSNR per method and scene.
    let methods = std::fs::read_to_string(out.join("methods.md")).unwrap();
    for scene in pre_scenes {
        for method in ["step", "pre-integrated", "adaptive", "budget"] {
            assert!(
                methods.contains(&format!("| {scene} | {method} |")),
                "{methods}"
            );
        }
    }
    assert!(
        !methods.contains("| boundary | pre-integrated |")
            && !methods.contains("| boundary | adaptive |"),
        "{methods}"
    );
    // The plots (when a font was found, as on any machine with DejaVu).
    if std::path::Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").exists() {
        for f in [
            "accuracy-thesis.png",
            "accuracy-thesis.svg",
            "accuracy-noise.svg",
            "accuracy-boundary.svg",
            "accuracy-thesis-shadows.svg",
            "accuracy-thesis-ao.svg",
            "accuracy-ct.svg",
            "accuracy-ct-shadows.svg",
            "accuracy-ct-ao.svg",
        ] {
            let len = std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
            assert!(len > 1000, "{f} missing or empty");
        }
    }
}

#[test]
fn unknown_scene_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    fails(
        tool("vol-accuracy")
            .args(["--quick", "--scene", "teapot", "--out"])
            .arg(dir.path()),
        "unknown scene",
    );
}

#[test]
fn completions_and_man_page_come_from_the_command_line_definition() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let text = ok(tool("vol-accuracy").args(["--completions", shell]));
        assert!(
            text.contains("vol-accuracy") && text.contains("bin-dir"),
            "{shell}: {text}"
        );
    }
    let man = ok(tool("vol-accuracy").arg("--man"));
    assert!(
        man.contains(".TH vol-accuracy") && man.contains("\\-\\-quick"),
        "{man}"
    );
    // Usage errors are one line with exit status 2, as in the other tools.
    let mut c = tool("vol-accuracy");
    c.args(["--repeat", "0"]);
    fails(&mut c, "--repeat");
    assert_eq!(c.status().unwrap().code(), Some(2));
}

/// The path tracer's quick study: every step of every run is in the CSV,
/// the error falls as samples accumulate, and the grid and the global
/// majorant (same estimator, other random draws) end at about the same
/// PSNR.
#[test]
fn quick_path_study_converges() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pt");
    ok(tool("vol-accuracy")
        .args(["--path", "--quick", "--out"])
        .arg(&out));
    let text = std::fs::read_to_string(out.join("path.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("scene,bounces,majorant,spp,seconds,psnr_db,relative_error,lookups_per_path")
    );
    /// (scene, bounces, majorant) -> [(spp, seconds, psnr)]
    type Runs = HashMap<(String, String, String), Vec<(u64, f64, f64)>>;
    let mut runs = Runs::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 8, "bad row: {line}");
        runs.entry((f[0].into(), f[1].into(), f[2].into()))
            .or_default()
            .push((
                f[3].parse().unwrap(),
                f[4].parse().unwrap(),
                f[5].parse().unwrap(),
            ));
    }
    assert_eq!(runs.len(), 2 * 2 * 2, "{text}");
    for (key, steps) in &runs {
        let spp: Vec<u64> = steps.iter().map(|s| s.0).collect();
        assert_eq!(spp, [1, 2, 4, 8, 16, 32], "{key:?}");
        // Time only grows; 32 spp beat 1 spp by far (10 dB per decade
        // would be 15 dB).
        assert!(steps.windows(2).all(|w| w[1].1 >= w[0].1), "{key:?}");
        let (first, last) = (steps[0].2, steps[5].2);
        assert!(
            first.is_finite() && last > first + 8.0,
            "{key:?}: {first} -> {last}"
        );
    }
    for scene in ["dense", "sparse"] {
        for d in ["1", "8"] {
            let end = |m: &str| runs[&(scene.into(), d.into(), m.into())][5].2;
            // Both majorants converge to one answer; the grid's cells
            // also give residual ratio tracking a control extinction per
            // cell (the global one has only the volume's least), so the
            // grid may be better by more than noise, never worse.
            let (grid, global) = (end("grid"), end("global"));
            assert!(
                grid > global - 3.0 && grid < global + 8.0,
                "{scene} D={d}: {grid} vs {global}"
            );
        }
    }
    let md = std::fs::read_to_string(out.join("path.md")).unwrap();
    assert!(
        md.contains("spp to 30 dB") && md.lines().count() == 2 + 8,
        "{md}"
    );
    if std::path::Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").exists() {
        for f in ["path-dense.png", "path-sparse.svg"] {
            let len = std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
            assert!(len > 1000, "{f} missing or empty");
        }
    }
    // The study picks its own scenes and times each step once.
    fails(
        tool("vol-accuracy").args(["--path", "--scene", "ct"]),
        "cannot be used with",
    );
}
