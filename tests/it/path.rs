//! End to end: `vol-render --mode path` through files: its figures, a
//! render continued from a state file equal to one run, refusals of a
//! state from another scene and of options outside path mode, the scene
//! file's path keys, and the outputs (PNG, PFM, EXR, noise map).

use crate::common::*;
use std::path::{Path, PathBuf};

fn spheres(dir: &Path) -> PathBuf {
    let p = dir.join("spheres.vvol");
    ok(tool("vol-gen")
        .args([
            "spheres", "--dims", "48,48,48", "--count", "6", "--size", "10",
        ])
        .args(["--seed", "1", "-o"])
        .arg(&p)
        .arg("--quiet"));
    p
}

const SCENE: &[&str] = &[
    "--mode",
    "path",
    "--density-scale",
    "0.5",
    "--albedo",
    "0.8",
    "--sun=-1,-1.2,0.4:4",
    "--env",
    "0.1",
    "--size",
    "32x24",
    "--bounces",
    "4",
];

fn path_render(vol: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    json(&ok(tool("vol-render")
        .arg(vol)
        .arg("-o")
        .arg(out)
        .args(SCENE)
        .arg("--json")
        .args(extra)))
}

#[test]
fn path_mode_reports_figures_and_writes_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let hdr = d.join("a.exr");
    let var = d.join("noise.png");
    let v = path_render(
        &vol,
        &d.join("a.png"),
        &[
            "--spp",
            "16",
            "--hdr",
            hdr.to_str().unwrap(),
            "--variance",
            var.to_str().unwrap(),
            "--tonemap",
            "aces",
        ],
    );
    assert_eq!(v["mode"], "path");
    assert_eq!(v["spp"], 16);
    assert_eq!(v["paths"], 32 * 24 * 16);
    for key in [
        "real_collisions",
        "null_collisions",
        "majorant_cells",
        "empty_jumps",
        "culled_paths",
        "density_lookups",
        "shadow_rays",
        "render_s",
        "paths_per_s_per_core",
        "lookups_per_path",
        "relative_error",
    ] {
        assert!(v[key].is_number(), "missing {key}: {v}");
    }
    assert!(v["shadow_rays"].as_u64().unwrap() > 0);
    assert_eq!(v["scene"]["mode"], "path");
    assert_eq!(v["scene"]["bounces"], 4);
    for p in [d.join("a.png"), hdr, var] {
        assert!(
            std::fs::metadata(&p).unwrap().len() > 100,
            "{}",
            p.display()
        );
    }
    // The global majorant: the same scene, more lookups.
    let g = path_render(
        &vol,
        &d.join("g.png"),
        &["--spp", "4", "--majorant", "global"],
    );
    let l = path_render(&vol, &d.join("l.png"), &["--spp", "4"]);
    assert!(
        g["density_lookups"].as_u64().unwrap() > l["density_lookups"].as_u64().unwrap(),
        "{g}\n{l}"
    );
}

#[test]
fn a_render_continued_from_its_state_equals_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let state = d.join("s.state");
    let st = state.to_str().unwrap();
    let (a, b) = (d.join("a.pfm"), d.join("b.pfm"));
    path_render(
        &vol,
        &d.join("a.png"),
        &["--spp", "6", "--hdr", a.to_str().unwrap()],
    );
    let first = path_render(&vol, &d.join("b.png"), &["--spp", "4", "--accumulate", st]);
    assert_eq!(first["spp"], 4);
    let second = path_render(
        &vol,
        &d.join("b.png"),
        &[
            "--spp",
            "2",
            "--accumulate",
            st,
            "--hdr",
            b.to_str().unwrap(),
        ],
    );
    assert_eq!(
        (second["spp"].as_u64(), second["spp_added"].as_u64()),
        (Some(6), Some(2))
    );
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // Another scene (another sun) refuses the state, and keeps it.
    let before = std::fs::read(&state).unwrap();
    let e = fails(
        tool("vol-render")
            .arg(&vol)
            .arg("-o")
            .arg(d.join("c.png"))
            .args(SCENE)
            .args(["--sun=1,0,0:2", "--spp", "2", "--accumulate", st]),
        "another scene",
    );
    assert!(e.contains("s.state"), "{e}");
    assert_eq!(std::fs::read(&state).unwrap(), before);
    assert!(!d.join("c.png").exists());
}

#[test]
fn path_options_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let out = d.join("x.png");
    let cases: &[(&[&str], &str)] = &[
        (&["--spp", "4"], "--spp needs --mode path"),
        (&["--mode", "path", "--spp", "0"], "at least 1"),
        (&["--mode", "path", "--sun=0,0,0:1"], "must not be zero"),
        (&["--mode", "path", "--sun=1,0,0:-2"], "irradiance"),
        (&["--mode", "path", "--bounces", "0"], "bounces 0"),
        (&["--mode", "path", "--g", "1.5"], "g 1.5"),
        (
            &["--mode", "path", "--albedo", "0.5"],
            "--albedo is for --density-scale",
        ),
        (
            &["--mode", "path", "--density-scale", "1", "--albedo", "2"],
            "albedo",
        ),
        (
            &["--mode", "path", "--tf", "boundary"],
            "1D transfer function",
        ),
        (
            &["--mode", "path", "--shadows", "ray"],
            "ray caster's effects",
        ),
        (&["--mode", "path", "--until-error", "0"], "above 0"),
        (&["--mode", "path", "--sampler", "halton"], "halton"),
        (&["--mode", "path", "--transmittance", "exact"], "exact"),
        (
            &["--mode", "path", "--repeat", "3"],
            "--repeat times the ray caster",
        ),
    ];
    for (args, needle) in cases {
        fails(
            tool("vol-render").arg(&vol).arg("-o").arg(&out).args(*args),
            needle,
        );
    }
    assert!(!out.exists());
}

#[test]
fn scene_files_hold_the_path_keys() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let scene = d.join("pt.toml");
    std::fs::write(
        &scene,
        format!(
            "volume = {:?}\nmode = \"path\"\ndensity-scale = 0.5\nalbedo = [0.9, 0.8, 0.7]\n\
             sun = [\"-1,-1.2,0.4:4\"]\nenv = 0.1\nspp = 3\nbounces = 2\ng = 0.5\n\
             size = [16, 12]\nmajorant = \"global\"\nsampler = \"hash\"\ntransmittance = \"ratio\"\n",
            vol.to_str().unwrap()
        ),
    )
    .unwrap();
    let printed = ok(tool("vol-render")
        .arg("--scene")
        .arg(&scene)
        .arg("--print-scene"));
    for key in [
        "spp = 3",
        "bounces = 2",
        "g = 0.5",
        "majorant = \"global\"",
        "sampler = \"hash\"",
        "transmittance = \"ratio\"",
        "density-scale = 0.5",
    ] {
        assert!(printed.contains(key), "{key}:\n{printed}");
    }
    let v = json(&ok(tool("vol-render")
        .arg("--scene")
        .arg(&scene)
        .arg("-o")
        .arg(d.join("s.png"))
        .args(["--json", "--spp", "2"])));
    assert_eq!(
        (v["spp"].as_u64(), v["width"].as_u64()),
        (Some(2), Some(16))
    );
    assert_eq!(v["majorant"], "global");
    assert_eq!(
        (&v["sampler"], &v["transmittance"]),
        (&"hash".into(), &"ratio".into())
    );
    std::fs::write(&scene, "mode = \"path\"\nmajorant = \"fine\"\n").unwrap();
    fails(
        tool("vol-render")
            .arg(&vol)
            .arg("--scene")
            .arg(&scene)
            .arg("-o")
            .arg(d.join("t.png")),
        "key `majorant`: invalid value 'fine'",
    );
}

#[test]
fn environment_maps_light_the_scene_and_bad_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let (w, h) = (16u32, 8u32);
    let mut sky = Vec::new();
    for r in 0..h {
        for c in 0..w {
            let v = if (r, c) == (2, 5) {
                300.0
            } else if r < h / 2 {
                0.6
            } else {
                0.05
            };
            sky.extend([v * 0.9, v, v * 1.2]);
        }
    }
    let map = d.join("sky.pfm");
    volformats::image::write_pfm(&map, w, h, &sky).unwrap();
    let base = [
        "--mode",
        "path",
        "--density-scale",
        "0.5",
        "--size",
        "16x12",
        "--spp",
        "4",
        "--bounces",
        "3",
    ];
    let v = json(&ok(tool("vol-render")
        .arg(&vol)
        .args(base)
        .arg("--env-map")
        .arg(&map)
        .arg("-o")
        .arg(d.join("m.png"))
        .arg("--json")));
    assert!(v["shadow_rays"].as_u64().unwrap() > 0, "{v}");
    assert_eq!(v["non_finite"].as_u64(), Some(0));
    // The printed scene names the map (and no constant environment), and
    // renders the same image again.
    let printed = ok(tool("vol-render")
        .arg(&vol)
        .args(base)
        .arg("--env-map")
        .arg(&map)
        .arg("--print-scene"));
    assert!(printed.contains("env-map = "), "{printed}");
    // No constant environment, no background hiding the map, no
    // headlight.
    for key in ["\nenv = ", "\nbackground = ", "headlight"] {
        assert!(!printed.contains(key), "{key}: {printed}");
    }
    let scene = d.join("sky.toml");
    std::fs::write(&scene, &printed).unwrap();
    ok(tool("vol-render")
        .arg("--scene")
        .arg(&scene)
        .arg("-o")
        .arg(d.join("n.png")));
    assert_eq!(
        std::fs::read(d.join("m.png")).unwrap(),
        std::fs::read(d.join("n.png")).unwrap()
    );

    let mut bad = sky.clone();
    bad[3 * 7 + 1] = f32::NAN;
    let nan_map = d.join("nan.pfm");
    volformats::image::write_pfm(&nan_map, w, h, &bad).unwrap();
    let png_map = d.join("sky.png");
    std::fs::write(&png_map, b"not really").unwrap();
    let out = d.join("x.png");
    let cases: Vec<(Vec<&str>, PathBuf, &str)> = vec![
        (
            base.to_vec(),
            nan_map.clone(),
            "nan.pfm: environment map texel (7, 0)",
        ),
        (base.to_vec(), png_map, "must be a linear .pfm or .exr"),
        (base.to_vec(), d.join("none.exr"), "none.exr: cannot read"),
        (
            [&base[..], &["--env", "0.2"]].concat(),
            map.clone(),
            "not both",
        ),
        (
            vec!["--tf", "shapes"],
            map.clone(),
            "--env-map needs --mode path",
        ),
    ];
    for (args, m, needle) in cases {
        fails(
            tool("vol-render")
                .arg(&vol)
                .args(&args)
                .arg("--env-map")
                .arg(&m)
                .arg("-o")
                .arg(&out),
            needle,
        );
    }
    assert!(!out.exists());
}

#[test]
fn hybrid_scattering_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = spheres(d);
    let v = path_render(&vol, &d.join("h.png"), &["--spp", "8", "--hybrid", "40"]);
    let (events, surface) = (
        v["scatter_events"].as_u64().unwrap(),
        v["surface_events"].as_u64().unwrap(),
    );
    assert!(surface > 0 && surface < events, "{v}");
    let v = path_render(&vol, &d.join("o.png"), &["--spp", "8", "--hybrid", "off"]);
    assert_eq!(v["surface_events"].as_u64(), Some(0));
    for (args, needle) in [
        (&["--hybrid", "-2"][..], "--hybrid `-2`"),
        (&["--hybrid", "soft"][..], "--hybrid `soft`"),
    ] {
        fails(
            tool("vol-render")
                .arg(&vol)
                .args(SCENE)
                .args(args)
                .arg("-o")
                .arg(d.join("x.png")),
            needle,
        );
    }
    fails(
        tool("vol-render")
            .arg(&vol)
            .args(["--hybrid", "5", "-o"])
            .arg(d.join("y.png")),
        "--hybrid needs --mode path",
    );
}
