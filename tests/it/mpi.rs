//! End to end under `mpirun` (cargo feature `mpi`; Open MPI): `vol-render`
//! as N = 1..4 ranks gives MIP, MinIP and iso images bit for bit the
//! single process's, DVR and X-ray within rounding (>= 60 dB) and the same
//! bytes run after run; a camera inside the volume and ranks without a
//! box work; a failure on one rank ends the job with one line from rank 0
//! and no output; effects that stay single-node are refused.
//!
//! Compiled only with the cargo feature `mpi` (see `main.rs`); run with
//! `cargo test -p volkit --features mpi --test it mpi::` (needs `mpirun`).

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// `vol-render` as `n` ranks, with Open MPI's session files under `dir`.
///
/// The tests run side by side, and `mpirun`s that share the default
/// session directory race on it: one job's cleanup removes the top
/// directory while another creates its own below it, and the second
/// fails in `orte_init` (`session_dir.c`). A session directory per test
/// keeps concurrent jobs apart.
fn mpirun(dir: &Path, n: usize) -> Command {
    let session = dir.join("mpi-session");
    std::fs::create_dir_all(&session).unwrap();
    let mut c = Command::new("mpirun");
    c.args(["-q", "--oversubscribe", "-np", &n.to_string()])
        .env("TMPDIR", &session)
        .env("OMPI_MCA_orte_tmpdir_base", &session)
        // Containers and CI run as root; a bound on ranks per core would
        // refuse 4 ranks on 2 cores.
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .arg(env!("CARGO_BIN_EXE_vol-render"))
        .stdin(std::process::Stdio::null());
    c
}

/// A bricked 96x80x88 scene (bricks of 32, so ranks own whole bricks).
fn scene(dir: &Path, extra: &[&str]) -> PathBuf {
    let p = dir.join(format!("scene{}.vvol", extra.len()));
    ok(tool("vol-gen")
        .args([
            "shapes", "--dims", "96,80,88", "--seed", "3", "--count", "20",
        ])
        .args([
            "--size",
            "14",
            "--value",
            "100",
            "--layout",
            "bricked:32",
            "-q",
        ])
        .args(extra)
        .arg("-o")
        .arg(&p));
    p
}

/// The cameras: outside (default), inside the volume, orthographic.
const CAMERAS: [&[&str]; 3] = [
    &[],
    &["--eye", "30,35,40", "--look-at", "80,60,70", "--fov", "70"],
    &[
        "--eye",
        "-100,40,44",
        "--look-at",
        "48,40,44",
        "--ortho=110",
    ],
];

/// Render `vol` with `args` in one process and as `n` ranks; the two
/// float images' paths, and the ranks' JSON report.
fn both(dir: &Path, vol: &Path, args: &[&str], n: usize) -> (PathBuf, PathBuf, serde_json::Value) {
    let one = dir.join("one.pfm");
    let many = dir.join(format!("many{n}.pfm"));
    let common = ["--size", "120x96", "--quiet", "-o"];
    ok(tool("vol-render")
        .arg(vol)
        .args(args)
        .args(common)
        .arg(dir.join("one.png"))
        .arg("--hdr")
        .arg(&one));
    let out = ok(mpirun(dir, n)
        .arg(vol)
        .args(args)
        .args(common)
        .arg(dir.join(format!("many{n}.png")))
        .arg("--hdr")
        .arg(&many)
        .arg("--json"));
    (one, many, json(&out))
}

fn psnr(a: &Path, b: &Path) -> Option<f64> {
    let j = json(&ok(tool("vol-psnr").arg(a).arg(b).arg("--json")));
    j["psnr"].as_f64()
}

#[test]
fn ranks_give_the_single_process_image() {
    let dir = tempfile::tempdir().unwrap();
    let vol = scene(dir.path(), &[]);
    let modes: [&[&str]; 6] = [
        &["--mode", "mip"],
        &["--mode", "minip"],
        &["--mode", "iso", "--iso", "60"],
        &["--mode", "dvr", "--tf", "shapes"],
        &["--mode", "dvr", "--tf", "shapes", "--no-ert"],
        &["--mode", "xray"],
    ];
    for cam in CAMERAS {
        for mode in modes {
            let args: Vec<&str> = cam.iter().chain(mode.iter()).copied().collect();
            for n in 1..=4 {
                let (one, many, j) = both(dir.path(), &vol, &args, n);
                assert_eq!(j["ranks"], n, "{args:?}");
                assert_eq!(j["per_rank"].as_array().unwrap().len(), n);
                let exact = !matches!(mode[1], "dvr" | "xray");
                if exact || n == 1 {
                    assert_eq!(
                        std::fs::read(&one).unwrap(),
                        std::fs::read(&many).unwrap(),
                        "{args:?} on {n} ranks: not bit for bit"
                    );
                } else if let Some(db) = psnr(&one, &many) {
                    assert!(db >= 60.0, "{args:?} on {n} ranks: {db:.1} dB");
                }
            }
        }
    }
}

#[test]
fn the_same_ranks_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let vol = scene(dir.path(), &[]);
    let args = ["--mode", "dvr", "--tf", "shapes", "--shading", "phong"];
    let (_, a, _) = both(dir.path(), &vol, &args, 3);
    let first = std::fs::read(&a).unwrap();
    let (_, b, j) = both(dir.path(), &vol, &args, 3);
    assert_eq!(first, std::fs::read(&b).unwrap());
    // Each rank reports its own work; the frame's totals are theirs.
    let per = j["per_rank"].as_array().unwrap();
    let samples: u64 = per.iter().map(|r| r["samples"].as_u64().unwrap()).sum();
    assert_eq!(j["samples"].as_u64().unwrap(), samples);
    assert!(j["bytes_exchanged"].as_u64().unwrap() > 0);
    for r in per {
        for key in [
            "render_s",
            "composite_s",
            "bytes_sent",
            "bytes_received",
            "box",
        ] {
            assert!(!r[key].is_null(), "no {key} in {r}");
        }
    }
}

#[test]
fn ranks_without_work_or_without_a_box_change_nothing() {
    // One small sphere inside one block of 32 voxels: the split weighs
    // only the cells that show it, so most ranks' boxes hold nothing to
    // see; and with more ranks than blocks, some get no box at all.
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("sphere.vvol");
    ok(tool("vol-gen")
        .args([
            "sphere",
            "--dims",
            "112,112,112",
            "--radius",
            "5",
            "-q",
            "-o",
        ])
        .arg(&vol));
    let small = dir.path().join("small.vvol");
    ok(tool("vol-gen")
        .args(["sphere", "--dims", "40,40,40", "--radius", "12", "-q", "-o"])
        .arg(&small));
    for (vol, n) in [(&vol, 4), (&small, 9)] {
        for mode in [
            &["--mode", "mip"][..],
            &["--mode", "iso", "--iso", "0.5"][..],
        ] {
            let (one, many, j) = both(dir.path(), vol, mode, n);
            assert_eq!(
                std::fs::read(&one).unwrap(),
                std::fs::read(&many).unwrap(),
                "{mode:?} on {n} ranks"
            );
            let per = j["per_rank"].as_array().unwrap();
            let idle = per.iter().filter(|r| r["samples"].as_u64() == Some(0));
            let boxless = per.iter().filter(|r| r["voxels"].as_u64() == Some(0));
            if n == 9 {
                // 2 x 2 x 2 blocks for 9 ranks.
                assert!(boxless.count() >= 1, "no rank without a box: {j}");
            } else if mode[1] == "iso" {
                assert!(idle.count() >= 2, "work not where the sphere is: {j}");
            }
        }
    }
}

#[test]
fn a_failure_on_one_rank_ends_the_job_with_one_line_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let vol = scene(dir.path(), &["--compress", "zstd"]);
    let index = dir.path().join("scene.vidx");
    ok(tool("vol-index").arg(&vol).args(["-q", "-o"]).arg(&index));
    // Damage one brick near the end of the file: only the rank whose box
    // holds it fails when it reads it.
    let bad = dir.path().join("bad.vvol");
    let mut bytes = std::fs::read(&vol).unwrap();
    let at = bytes.len() * 9 / 10;
    bytes[at..at + 16].fill(0);
    std::fs::write(&bad, &bytes).unwrap();
    let out = dir.path().join("out.png");
    for n in [2, 4] {
        let line = fails(
            mpirun(dir.path(), n)
                .arg(&bad)
                .args(["--mode", "mip", "--size", "64x48", "--index"])
                .arg(&index)
                .arg("-o")
                .arg(&out),
            "checksum",
        );
        assert!(line.contains("rank "), "{line}");
        assert!(line.contains("bad.vvol"), "{line}");
        assert!(!out.exists());
        assert!(leftovers(dir.path()).is_empty());
    }
    // The same failure on every rank is said once, without ranks.
    let line = fails(
        mpirun(dir.path(), 3)
            .arg(dir.path().join("missing.vvol"))
            .arg("-o")
            .arg(&out),
        "missing.vvol",
    );
    assert!(!line.contains("rank "), "{line}");
    // A bad option: a usage error (status 2) from rank 0 only.
    let o = run(mpirun(dir.path(), 3)
        .arg(&vol)
        .args(["--step", "banana", "-o"])
        .arg(&out));
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&o.stderr).lines().count(), 1);
    assert!(!out.exists());
}

#[test]
fn single_node_effects_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let vol = scene(dir.path(), &[]);
    let out = dir.path().join("out.png");
    for (args, needle) in [
        (&["--shading", "phong", "--shadows", "ray"][..], "--shadows"),
        (
            &["--shading", "phong", "--ao", "8"][..],
            "ambient occlusion",
        ),
        (&["--mode", "path"][..], "--mode path"),
        (&["--mode", "xray-mean"][..], "xray-mean"),
    ] {
        let line = fails(
            mpirun(dir.path(), 2)
                .arg(&vol)
                .args(args)
                .arg("-o")
                .arg(&out),
            needle,
        );
        assert!(line.contains("MPI"), "{line}");
        assert!(!out.exists());
    }
}
