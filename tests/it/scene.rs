//! End to end: vol-render scene files (`--scene`, `--print-scene`), lights
//! and the command line overriding a scene.

use crate::common::*;
use std::path::{Path, PathBuf};

/// Render `vol` from the tests' camera with `--json` and `extra`; the
/// figures printed.
fn render_json(dir: &Path, vol: &str, extra: &[&str]) -> serde_json::Value {
    json(&ok(tool("vol-render")
        .arg(vol)
        .args(CAMERA)
        .args(["--json", "-o"])
        .arg(dir.join("j.png"))
        .args(extra)))
}

fn shapes(dir: &Path) -> PathBuf {
    let p = dir.join("s.vvol");
    ok(tool("vol-gen")
        .args([
            "shapes", "--dims", "48,40,32", "--count", "8", "--size", "12", "--seed", "3",
        ])
        .arg("-o")
        .arg(&p)
        .arg("--quiet"));
    p
}

fn render(args: &[&str], dir: &Path, out: &str) -> Vec<u8> {
    let p = dir.join(out);
    ok(tool("vol-render")
        .args(args)
        .arg("-o")
        .arg(&p)
        .arg("--quiet"));
    std::fs::read(&p).unwrap()
}

const CAMERA: [&str; 8] = [
    "--tf",
    "shapes",
    "--shading",
    "phong",
    "--size",
    "40x30",
    "--orbit",
    "40,25,150",
];

#[test]
fn a_scene_renders_as_its_options_and_the_command_line_overrides_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    shapes(d);
    // Relative paths in a scene are the scene file's folder's.
    std::fs::write(
        d.join("a.toml"),
        "volume = \"s.vvol\"\ntf = \"shapes\"\nshading = \"phong\"\nsize = [40, 30]\n\
         orbit = [40, 25, 150]\nstep = 0.5\n",
    )
    .unwrap();
    let vol = d.join("s.vvol");
    let v = vol.to_str().unwrap();
    let by_options = render(
        &[&[v][..], &CAMERA[..], &["--step", "0.5"]].concat(),
        d,
        "o.png",
    );
    let scene = d.join("a.toml");
    let s = scene.to_str().unwrap();
    let by_scene = render(&["--scene", s], d, "s.png");
    assert_eq!(by_options, by_scene);
    // An option on the command line wins over the scene's.
    let override_ = render(&["--scene", s, "--step", "0.25"], d, "s2.png");
    let finer = render(
        &[&[v][..], &CAMERA[..], &["--step", "0.25"]].concat(),
        d,
        "o2.png",
    );
    assert_eq!(override_, finer);
    assert_ne!(override_, by_scene);
    // The effective scene, printed, renders the same image again.
    let printed = ok(tool("vol-render").args(["--scene", s, "--print-scene"]));
    assert!(printed.contains("step = 0.5"), "{printed}");
    let elsewhere = tempfile::tempdir().unwrap();
    let again = elsewhere.path().join("again.toml");
    std::fs::write(&again, &printed).unwrap();
    let out = d.join("again.png");
    ok(tool("vol-render")
        .args(["--scene", again.to_str().unwrap(), "--quiet", "-o"])
        .arg(&out));
    assert_eq!(std::fs::read(out).unwrap(), by_scene);
    // --json records the scene.
    let j = json(&ok(tool("vol-render")
        .args(["--scene", s, "--json", "-o"])
        .arg(d.join("j.png"))));
    assert_eq!(j["scene"]["step"], 0.5);
    // The volume is `input`, as in every tool's report.
    assert_eq!(j["input"], vol.to_str().unwrap(), "{j}");
    assert!(j.get("path").is_none(), "{j}");
    assert_eq!(j["scene"]["lights"][0]["type"], "headlight");
}

#[test]
fn lights_colour_and_place_the_shading() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = shapes(d);
    let v = vol.to_str().unwrap();
    let scene = |name: &str, lights: &str| {
        let p = d.join(name);
        std::fs::write(&p, format!("ambient = 0.1\n{lights}")).unwrap();
        p
    };
    let frame = |scene: &Path, out: &str| {
        let p = d.join(out);
        ok(tool("vol-render")
            .arg(v)
            .args(CAMERA)
            .args([
                "--step",
                "0.5",
                "--scene",
                scene.to_str().unwrap(),
                "--quiet",
                "--hdr",
            ])
            .arg(&p)
            .arg("-o")
            .arg(d.join(format!("{out}.png"))));
        pfm(&p)
    };
    let white = frame(
        &scene(
            "w.toml",
            "[[lights]]\ntype = \"directional\"\ndirection = [-1, -1, -1]\n",
        ),
        "w.pfm",
    );
    let red = frame(
        &scene(
            "r.toml",
            "[[lights]]\ntype = \"directional\"\ndirection = [-1, -1, -1]\ncolour = [1, 0, 0]\n",
        ),
        "r.pfm",
    );
    // A red light leaves red as it was and takes away green and blue
    // down to what the ambient term lights.
    let sum = |img: &[f32], c: usize| {
        img.iter()
            .skip(c)
            .step_by(3)
            .map(|&x| x as f64)
            .sum::<f64>()
    };
    assert!((sum(&red, 0) - sum(&white, 0)).abs() < 1e-3 * sum(&white, 0));
    assert!(sum(&red, 1) < 0.6 * sum(&white, 1));
    // Two lights give more light than one; a point light far off gives
    // almost none beyond the ambient term; none is NaN.
    let two = frame(
        &scene(
            "2.toml",
            "[[lights]]\ntype = \"directional\"\ndirection = [-1, -1, -1]\n\
             [[lights]]\ntype = \"directional\"\ndirection = [1, 0, 0]\n",
        ),
        "2.pfm",
    );
    assert!(sum(&two, 1) > sum(&white, 1));
    let far = frame(
        &scene(
            "p.toml",
            "[[lights]]\ntype = \"point\"\nposition = [1e6, 1e6, 1e6]\n",
        ),
        "p.pfm",
    );
    let none = frame(&scene("n.toml", "lights = []\n"), "n.pfm");
    assert!(far.iter().chain(&two).all(|x| x.is_finite()));
    assert!((sum(&far, 1) - sum(&none, 1)).abs() < 1e-3 * sum(&none, 1).max(1e-9));
    assert!(sum(&none, 1) > 0.0);
    // A point light close by lights the side it faces.
    let near = frame(
        &scene(
            "q.toml",
            "[[lights]]\ntype = \"point\"\nposition = [24, 20, 16]\nintensity = 400\n",
        ),
        "q.pfm",
    );
    assert!(sum(&near, 1) > sum(&none, 1));
}

/// The pixels of a PFM written by vol-render (RGB, little-endian).
fn pfm(p: &Path) -> Vec<f32> {
    let bytes = std::fs::read(p).unwrap();
    // Three header lines.
    let mut at = 0;
    for _ in 0..3 {
        at += bytes[at..].iter().position(|&b| b == b'\n').unwrap() + 1;
    }
    bytes[at..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn bad_scenes_fail_in_one_line_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = shapes(d);
    let v = vol.to_str().unwrap();
    let case = |text: &str, needle: &str| {
        let p = d.join("bad.toml");
        std::fs::write(&p, text).unwrap();
        let out = d.join("bad.png");
        fails(
            tool("vol-render")
                .arg(v)
                .args(["--scene", p.to_str().unwrap(), "-o"])
                .arg(&out),
            needle,
        );
        assert!(!out.exists());
    };
    case(
        "fov = 30\nsteps = 0.5\n",
        "bad.toml: line 2, key `steps`: unknown key",
    );
    case(
        "fov = \"wide\"\n",
        "bad.toml: line 1, key `fov`: invalid value 'wide' for '--fov",
    );
    case(
        "[[lights]]\ntype = \"spot\"\n",
        "bad.toml: line 2, key `type`: unknown variant",
    );
    case(
        "[[lights]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = -1\n",
        "bad.toml: lights[0]: intensity must be finite and not negative",
    );
    case(
        "tf-text = \"domain 0 1\\nrange 0\\n\"\n",
        "the scene's tf-text",
    );
    case("size = [40, 30\n", "bad.toml: line 1");
    fails(
        tool("vol-render").args([
            "--scene",
            d.join("missing.toml").to_str().unwrap(),
            "-o",
            "x.png",
        ]),
        "missing.toml",
    );
    // A file the scene names that cannot be read: the error names the
    // scene and its key as well as the file.
    for (text, needle) in [
        ("volume = \"none.vvol\"\n", "key `volume`: "),
        ("volume = \"s.vvol\"\ntf = \"none.tf\"\n", "key `tf`: "),
    ] {
        std::fs::write(d.join("paths.toml"), text).unwrap();
        let msg = fails(
            tool("vol-render").args([
                "--scene",
                d.join("paths.toml").to_str().unwrap(),
                "-o",
                d.join("x.png").to_str().unwrap(),
            ]),
            &format!("paths.toml: {needle}"),
        );
        assert!(
            msg.contains(&format!("{needle}{}", d.join("none").display())),
            "{msg}"
        );
    }
    // Without a volume anywhere: a usage error.
    std::fs::write(d.join("empty.toml"), "").unwrap();
    fails(
        tool("vol-render").args([
            "--scene",
            d.join("empty.toml").to_str().unwrap(),
            "-o",
            "x.png",
        ]),
        "no volume",
    );
}

#[test]
fn shadows_from_the_command_line_or_a_scene_report_their_counters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = shapes(d);
    let v = vol.to_str().unwrap();
    let json = |extra: &[&str]| render_json(d, v, &[&["--light", "1,2,0.5"], extra].concat());
    // Off: no shadow keys at all.
    let off = json(&[]);
    assert!(off.get("shadow_rays").is_none(), "{off}");
    // Rays: shadow rays and samples, no grid.
    let ray = json(&["--shadows", "ray", "--shadow-step", "0.8"]);
    assert!(ray["shadow_rays"].as_u64().unwrap() > 0, "{ray}");
    assert!(ray["shadow_samples"].as_u64().unwrap() > 0);
    assert_eq!(ray["shadow_grids"], 0);
    assert_eq!(ray["scene"]["shadows"], "ray");
    let shadow_step = ray["scene"]["shadow-step"].as_f64().unwrap();
    assert!((shadow_step - 0.8).abs() < 1e-6, "{shadow_step}");
    // A grid for the one directional light: no shadow rays.
    let grid = json(&["--shadows", "grid:4"]);
    assert_eq!(grid["shadow_rays"], 0, "{grid}");
    assert_eq!(grid["shadow_grids"], 1);
    assert!(grid["shadow_grid_bytes"].as_u64().unwrap() > 0);
    // The same from a scene file.
    std::fs::write(
        d.join("sh.toml"),
        "shadows = \"grid:4\"\n[[lights]]\ntype = \"directional\"\ndirection = [-1, -2, -0.5]\n",
    )
    .unwrap();
    let from_scene = json(&["--scene", d.join("sh.toml").to_str().unwrap()]);
    assert_eq!(from_scene["shadow_grids"], 1, "{from_scene}");
    // Bad values: one line naming the option.
    fails(
        tool("vol-render")
            .arg(v)
            .args(["--shadows", "grid:3", "-o"])
            .arg(d.join("x.png")),
        "grid:DIV with DIV 1, 2 or 4",
    );
    assert!(!d.join("x.png").exists());
    std::fs::write(d.join("bad.toml"), "shadows = \"soft\"\n").unwrap();
    let msg = fails(
        tool("vol-render")
            .arg(v)
            .args(["--scene", d.join("bad.toml").to_str().unwrap(), "-o"])
            .arg(d.join("y.png")),
        "--shadows",
    );
    assert!(msg.contains("soft"), "{msg}");
    fails(
        tool("vol-render")
            .arg(v)
            .args(["--mode", "mip", "--shadows", "ray", "-o"])
            .arg(d.join("z.png")),
        "DVR and iso",
    );
}

#[test]
fn ambient_occlusion_from_the_command_line_or_a_scene_reports_its_counters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = shapes(d);
    let v = vol.to_str().unwrap();
    let json = |extra: &[&str]| render_json(d, v, extra);
    // Off: no AO keys at all.
    let off = json(&[]);
    assert!(off.get("ao_rays").is_none(), "{off}");
    // Rays: N per shaded sample, the grid's size, no field keys; the scene
    // records the option.
    let rays = json(&["--ao", "4:10"]);
    let n = rays["ao_rays"].as_u64().unwrap();
    assert!(n > 0 && n.is_multiple_of(4), "{rays}");
    assert!(rays["ao_samples"].as_u64().unwrap() > 0);
    assert!(rays["ao_grid_bytes"].as_u64().unwrap() > 0);
    assert!(rays.get("ao_field_s").is_none());
    assert_eq!(rays["scene"]["ao"], "4:10");
    // A field: no rays, its precomputation reported.
    let field = json(&["--ao-field", "16"]);
    assert_eq!(field["ao_rays"], 0, "{field}");
    assert!(field["ao_field_bytes"].as_u64().unwrap() > 0);
    assert!(field["ao_field_s"].as_f64().unwrap() > 0.0);
    assert_eq!(field["ao_field_cell"], 8, "{field}");
    // The same from a scene file, and bit for bit the same image.
    std::fs::write(d.join("ao.toml"), "ao-field = \"16\"\n").unwrap();
    let from_scene = json(&["--scene", d.join("ao.toml").to_str().unwrap()]);
    assert_eq!(from_scene["ao_field_bytes"], field["ao_field_bytes"]);
    // Points every 4 voxels: about eight times the memory, from the
    // command line or the scene file.
    let fine = json(&["--ao-field", "16", "--ao-field-cell", "4"]);
    assert_eq!(fine["ao_field_cell"], 4, "{fine}");
    let ratio =
        fine["ao_field_bytes"].as_f64().unwrap() / field["ao_field_bytes"].as_f64().unwrap();
    assert!((4.0..=8.0).contains(&ratio), "{ratio}");
    assert_eq!(fine["scene"]["ao-field-cell"], 4, "{fine}");
    std::fs::write(d.join("ao4.toml"), "ao-field = \"16\"\nao-field-cell = 4\n").unwrap();
    let from_scene = json(&["--scene", d.join("ao4.toml").to_str().unwrap()]);
    assert_eq!(from_scene["ao_field_bytes"], fine["ao_field_bytes"]);
    // Bad values: one line naming the option; nothing written.
    for (args, want) in [
        (&["--ao", "0"][..], "--ao"),
        (&["--ao", "8:-1"][..], "--ao"),
        (&["--ao-field", "x"][..], "--ao-field"),
        (&["--ao", "4", "--ao-field", "8"][..], "cannot be used with"),
        (&["--mode", "mip", "--ao", "4"][..], "DVR and iso"),
        (
            &["--ao-field", "8", "--ao-field-cell", "0"][..],
            "--ao-field-cell",
        ),
        (
            &["--ao-field", "8", "--ao-field-cell", "65"][..],
            "--ao-field-cell",
        ),
        (&["--ao", "8", "--ao-field-cell", "4"][..], "--ao-field"),
    ] {
        fails(
            tool("vol-render")
                .arg(v)
                .args(args)
                .arg("-o")
                .arg(d.join("x.png")),
            want,
        );
        assert!(!d.join("x.png").exists(), "{args:?}");
    }
}
