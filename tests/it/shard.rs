//! End to end: sharded conversion (`vol-convert --shard K/N`, `--merge`)
//! and sharded indexing (`vol-index --shard K/N`, `--merge`) give the very
//! bytes the unsharded runs give, and refuse incomplete or mixed parts.

use crate::common::*;
use std::path::{Path, PathBuf};

/// Convert `input` with `args` as `n` shards (run in reverse order, merged
/// from a list in another order); the merged file's bytes.
fn sharded_convert(dir: &Path, input: &Path, args: &[&str], n: u32) -> Vec<u8> {
    let mut parts = Vec::new();
    for k in (0..n).rev() {
        let p = dir.join(format!("part.{k}.vpart"));
        ok(tool("vol-convert")
            .arg(input)
            .args(args)
            .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
            .arg(&p));
        parts.push(p);
    }
    let half = parts.len() / 2;
    parts.rotate_left(half);
    let out = dir.join("merged.vvol");
    let _ = std::fs::remove_file(&out);
    ok(tool("vol-convert")
        .arg("--merge")
        .args(&parts)
        .args(["-q", "-o"])
        .arg(&out));
    ok(tool("vol-info").arg("--verify").arg(&out));
    for p in &parts {
        std::fs::remove_file(p).unwrap();
    }
    std::fs::read(&out).unwrap()
}

fn unsharded_convert(dir: &Path, input: &Path, args: &[&str]) -> Vec<u8> {
    let out = dir.join("whole.vvol");
    let _ = std::fs::remove_file(&out);
    ok(tool("vol-convert")
        .arg(input)
        .args(args)
        .args(["-q", "-o"])
        .arg(&out));
    std::fs::read(&out).unwrap()
}

/// A directory of TIFF slices of a `t` volume of `dims`.
fn tiff_stack(dir: &Path, t: &str, dims: &str) -> PathBuf {
    let raw = dir.join(format!("g_{t}.vvol"));
    let scene: &[&str] = match t {
        "u8" => &["shapes", "--count", "8", "--size", "10"],
        _ => &["spheres", "--count", "7", "--size", "9", "--value", "3000"],
    };
    ok(tool("vol-gen")
        .args(scene)
        .args(["--dims", dims, "--type", t, "-q", "-o"])
        .arg(&raw));
    let stack = dir.join(format!("stack_{t}/"));
    ok(tool("vol-convert")
        .arg(&raw)
        .arg("-q")
        .arg("-o")
        .arg(&stack));
    stack
}

#[test]
fn sharded_conversions_are_byte_identical_to_unsharded_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for t in ["u8", "u16", "f32"] {
        let stack = tiff_stack(d, t, "37,29,45");
        let layouts: &[&[&str]] = &[
            &["--layout", "sliced"],
            &["--layout", "bricked:8"],
            &["--layout", "bricked:8", "--compress", "zstd"],
            &[
                "--layout",
                "bricked:16",
                "--compress",
                "zstd:5",
                "--flip",
                "z",
            ],
            &[
                "--layout",
                "bricked:8",
                "--crop",
                "3:30,:,5:40",
                "--type",
                "u8",
                "--window",
                "0:2000",
            ],
        ];
        for args in layouts {
            let want = unsharded_convert(d, &stack, args);
            // 1 shard, a few, and more shards than there are units.
            for n in [1, 2, 3, 5, 50] {
                let got = sharded_convert(d, &stack, args, n);
                assert!(got == want, "{t} {args:?} in {n} shards differs");
            }
        }
        assert!(leftovers(d).is_empty());
    }
}

#[test]
fn a_shard_reads_only_the_slices_its_bricks_need() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let stack = tiff_stack(d, "u8", "40,30,32");
    // Damage the last slice: the first shard of bricked:8 in 4 (slices
    // 0..10 with the apron) never reads it; the last shard does.
    let last = stack.join("slice_0031.tif");
    assert!(last.exists(), "expected {}", last.display());
    std::fs::write(&last, b"not a tiff").unwrap();
    let part = |k: u32| d.join(format!("p{k}.vpart"));
    ok(tool("vol-convert")
        .arg(&stack)
        .args(["--layout", "bricked:8", "--shard", "0/4", "-q", "-o"])
        .arg(part(0)));
    fails(
        tool("vol-convert")
            .arg(&stack)
            .args(["--layout", "bricked:8", "--shard", "3/4", "-q", "-o"])
            .arg(part(3)),
        "slice_0031.tif",
    );
    assert!(!part(3).exists());
    assert!(leftovers(d).is_empty());
}

#[test]
fn merging_refuses_missing_doubled_foreign_and_damaged_parts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let vol = d.join("v.vvol");
    ok(tool("vol-gen")
        .args(["shapes", "--dims", "40,30,50", "-q", "-o"])
        .arg(&vol));
    let shard = |k: u32, n: u32, layout: &str, name: &str| -> PathBuf {
        let p = d.join(name);
        ok(tool("vol-convert")
            .arg(&vol)
            .args(["--layout", layout, "--compress", "zstd"])
            .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
            .arg(&p));
        p
    };
    let p: Vec<PathBuf> = (0..3)
        .map(|k| shard(k, 3, "bricked:16", &format!("p{k}.vpart")))
        .collect();
    let out = d.join("out.vvol");
    let merge = |parts: &[&PathBuf], needle: &str| {
        fails(
            tool("vol-convert")
                .arg("--merge")
                .args(parts)
                .arg("-o")
                .arg(&out),
            needle,
        );
        assert!(!out.exists());
        assert!(leftovers(d).is_empty());
    };
    merge(&[&p[0], &p[2]], "missing shard 1/3");
    merge(&[&p[0], &p[1], &p[1], &p[2]], "given twice");
    let other = shard(1, 3, "bricked:8", "other.vpart");
    merge(&[&p[0], &other, &p[2]], "another volume");
    let four = shard(1, 4, "bricked:16", "four.vpart");
    merge(&[&p[0], &four, &p[2]], "split into 4");
    merge(&[&p[0], &p[1], &vol], "not a volkit part");

    // One flipped bit in a brick, a truncated part, a damaged header.
    let bytes = std::fs::read(&p[1]).unwrap();
    let bad = d.join("bad.vpart");
    let mut b = bytes.clone();
    b[400] ^= 0x10;
    std::fs::write(&bad, &b).unwrap();
    merge(&[&p[0], &bad, &p[2]], "damaged");
    std::fs::write(&bad, &bytes[..bytes.len() - 3]).unwrap();
    merge(&[&p[0], &bad, &p[2]], "truncated");
    let mut b = bytes.clone();
    b[20] ^= 1;
    std::fs::write(&bad, &b).unwrap();
    merge(&[&p[0], &bad, &p[2]], "header is damaged");

    // Names: parts are .vpart, the merge writes .vvol.
    fails(
        tool("vol-convert")
            .arg(&vol)
            .args(["--shard", "0/2", "-o"])
            .arg(d.join("x.vvol")),
        "NAME.vpart",
    );
    fails(
        tool("vol-convert")
            .arg(&vol)
            .arg("-o")
            .arg(d.join("x.vpart")),
        "--shard",
    );
    fails(
        tool("vol-convert")
            .arg("--merge")
            .args(&p)
            .arg("-o")
            .arg(d.join("x.raw")),
        "OUT.vvol",
    );
    fails(
        tool("vol-convert")
            .arg(&vol)
            .args(["--shard", "2/2", "-o"])
            .arg(d.join("x.vpart")),
        "does not exist",
    );
    // And the good parts still merge.
    ok(tool("vol-convert")
        .arg("--merge")
        .args(&p)
        .arg("-q")
        .arg("-o")
        .arg(&out));
    ok(tool("vol-info").arg("--verify").arg(&out));
}

/// Index `vol` in `n` shards (merged from a list in another order); the
/// merged index's bytes.
fn sharded_index(dir: &Path, vol: &Path, extra: &[&str], n: u32) -> Vec<u8> {
    let parts: Vec<PathBuf> = (0..n)
        .rev()
        .map(|k| {
            let p = dir.join(format!("ix.{k}.vidxpart"));
            ok(tool("vol-index")
                .arg(vol)
                .args(extra)
                .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
                .arg(&p));
            p
        })
        .collect();
    let out = dir.join("merged.vidx");
    ok(tool("vol-index")
        .arg("--merge")
        .args(&parts)
        .args(["-q", "-o"])
        .arg(&out));
    // The merged index is the volume's, fresh.
    ok(tool("vol-index")
        .arg("--check")
        .arg(&out)
        .arg(vol)
        .arg("-q"));
    for p in &parts {
        std::fs::remove_file(p).unwrap();
    }
    std::fs::read(&out).unwrap()
}

#[test]
fn sharded_indexes_are_byte_identical_to_unsharded_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: &[(&str, &[&str], &[&str])] = &[
        ("u8", &["--layout", "sliced"], &[]),
        (
            "u16",
            &["--layout", "bricked:16", "--compress", "zstd"],
            &["--cell", "4"],
        ),
        ("f32", &["--layout", "bricked:8"], &["--bins", "100"]),
        ("f32", &["--layout", "sliced"], &["--cell", "16"]),
    ];
    for (i, (t, layout, extra)) in cases.iter().enumerate() {
        let sub = d.join(format!("case{i}"));
        std::fs::create_dir(&sub).unwrap();
        let stack = tiff_stack(&sub, t, "45,38,70");
        let vol = d.join(format!("v{i}.vvol"));
        ok(tool("vol-convert")
            .arg(&stack)
            .args(*layout)
            .arg("-q")
            .arg("-o")
            .arg(&vol));
        let whole = d.join("whole.vidx");
        ok(tool("vol-index")
            .arg(&vol)
            .args(*extra)
            .arg("-q")
            .arg("-o")
            .arg(&whole));
        let want = std::fs::read(&whole).unwrap();
        for n in [1, 2, 3, 7, 30] {
            let got = sharded_index(d, &vol, extra, n);
            assert!(
                got == want,
                "{t} {layout:?} {extra:?} in {n} shards differs"
            );
        }
    }
    assert!(leftovers(d).is_empty());
}

#[test]
fn sharded_indexing_refuses_what_it_cannot_do_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // f32 raw: the reader finds the value range, so shards can bin exactly
    // (a volume without one is refused: see the index crate's tests).
    let raw = d.join("f_20x20x20_f32.raw");
    ok(tool("vol-gen")
        .args(["noise", "--dims", "20,20,20", "--type", "f32", "-q", "-o"])
        .arg(&raw));
    let whole = d.join("raw.vidx");
    ok(tool("vol-index").arg(&raw).arg("-q").arg("-o").arg(&whole));
    assert!(sharded_index(d, &raw, &[], 3) == std::fs::read(&whole).unwrap());
    let vol = d.join("v.vvol");
    ok(tool("vol-gen")
        .args(["shapes", "--dims", "30,30,40", "-q", "-o"])
        .arg(&vol));
    let part = |k: u32, n: u32, extra: &[&str]| -> PathBuf {
        let p = d.join(format!("p{k}of{n}{}.vidxpart", extra.len()));
        ok(tool("vol-index")
            .arg(&vol)
            .args(extra)
            .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
            .arg(&p));
        p
    };
    let out = d.join("out.vidx");
    let merge = |parts: &[PathBuf], needle: &str| {
        fails(
            tool("vol-index")
                .arg("--merge")
                .args(parts)
                .arg("-o")
                .arg(&out),
            needle,
        );
        assert!(!out.exists());
    };
    merge(&[part(0, 3, &[]), part(2, 3, &[])], "missing shard 1/3");
    merge(&[part(0, 2, &[]), part(0, 2, &[])], "twice");
    merge(
        &[part(0, 2, &[]), part(1, 2, &["--cell", "4"])],
        "another build",
    );
    let p1 = part(1, 2, &[]);
    let bytes = std::fs::read(&p1).unwrap();
    std::fs::write(&p1, &bytes[..bytes.len() - 7]).unwrap();
    merge(&[part(0, 2, &[]), p1.clone()], "truncated");
    let mut b = bytes.clone();
    let at = b.len() - 9;
    b[at] ^= 4;
    std::fs::write(&p1, &b).unwrap();
    merge(&[part(0, 2, &[]), p1], "damaged");
    merge(&[part(0, 2, &[]), vol.clone()], "not a volkit index part");
    fails(
        tool("vol-index")
            .arg(&vol)
            .args(["--shard", "0/2", "-o"])
            .arg(d.join("x.vidx")),
        "NAME.vidxpart",
    );
    fails(
        tool("vol-index")
            .arg(&vol)
            .arg("-o")
            .arg(d.join("x.vidxpart")),
        "--shard",
    );
    assert!(leftovers(d).is_empty());
}

/// Every file under `root` (relative path, bytes), sorted.
fn tree(root: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(root, root, &mut out);
    out.sort();
    out
}

#[test]
fn sharded_ome_zarr_stores_are_identical_and_appear_only_when_complete() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let stack = tiff_stack(d, "u16", "40,30,300");
    // Anisotropic spacing: z coarse (levels 1 and 2 keep every slice,
    // level 3 halves it), or z fine (levels 1 and 2 halve z alone).
    for (pyramid, ngff, spacing) in [
        ("1", "0.4", "1,1,1"),
        ("2", "0.5", "1,1,1"),
        ("3", "0.4", "1,1,1"),
        ("4", "0.4", "1,1,4"),
        ("3", "0.5", "4,4,1"),
    ] {
        let args = ["--pyramid", pyramid, "--ngff", ngff, "--spacing", spacing];
        // The same store name (the multiscale's name) in other directories.
        let whole = d
            .join(format!("whole{pyramid}-{spacing}"))
            .join("v.ome.zarr");
        std::fs::create_dir(whole.parent().unwrap()).unwrap();
        ok(tool("vol-convert")
            .arg(&stack)
            .args(args)
            .arg("-q")
            .arg("-o")
            .arg(&whole));
        let want = tree(&whole);
        for n in [1, 2, 3, 7] {
            let out = d
                .join(format!("sharded{pyramid}-{spacing}-{n}"))
                .join("v.ome.zarr");
            for k in (0..n).rev() {
                // Until the last shard is in, the store is no OME-Zarr.
                if k + 1 < n {
                    assert!(!out.join(".zattrs").exists() && !out.join("zarr.json").exists());
                }
                ok(tool("vol-convert")
                    .arg(&stack)
                    .args(args)
                    .args(["--shard", &format!("{k}/{n}"), "-q", "-o"])
                    .arg(&out));
                if k > 0 {
                    fails(
                        tool("vol-convert")
                            .arg(&out)
                            .arg("-o")
                            .arg(d.join("x.vvol")),
                        "zarr",
                    );
                }
            }
            assert!(
                tree(&out) == want,
                "pyramid {pyramid} NGFF {ngff} spacing {spacing} in {n} shards"
            );
        }
    }
    // A shard refuses a store that is complete or another write's.
    let whole = d.join("whole1-1,1,1").join("v.ome.zarr");
    fails(
        tool("vol-convert")
            .arg(&stack)
            .args(["--shard", "0/2", "-o"])
            .arg(&whole),
        "not empty",
    );
    let other = d.join("other.ome.zarr");
    ok(tool("vol-convert")
        .arg(&stack)
        .args(["--shard", "0/3", "-q", "-o"])
        .arg(&other));
    fails(
        tool("vol-convert")
            .arg(&stack)
            .args(["--shard", "1/2", "-o"])
            .arg(&other),
        "another conversion",
    );
}
