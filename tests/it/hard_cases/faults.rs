//! Faults survived, nothing lost (issue 43): every writer killed (SIGKILL)
//! at random moments, every writer on a full disk, and a `.vvol` replaced
//! while eight renders read it. The rules, per output, are in
//! docs/OUTPUTS.md; these tests assert only invariants, never timings:
//!
//! - after a kill, each output holds the complete previous output or the
//!   complete new one (a header/data pair may also have no header: data
//!   first, header last), never a partial one; at most one temporary file
//!   per output is left, and the next run removes it;
//! - on a full disk, the writer exits non-zero with one line naming the
//!   output and leaves nothing (no partial output, no temporary file);
//!   `--accumulate` keeps its previous state;
//! - every render of a file replaced meanwhile is A's image or B's, bit for
//!   bit.
//!
//! CI runs a few kill moments per writer (deterministic seeds);
//! `VOLKIT_FAULT_KILLS=100` (scripts/fault-kill.sh) runs 100, and
//! `VOLKIT_FAULT_REPLACEMENTS=50` the full replacement race. Each test
//! prints its figures (`--nocapture` shows them).

use super::*;
use std::collections::BTreeMap;
use std::ffi::OsString;

/// Kill moments per writer.
fn kills() -> u64 {
    env_count("VOLKIT_FAULT_KILLS", 4)
}

fn env_count(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// SplitMix64: the kill moments, from a seed per writer and moment.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn seed_of(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// One output: the file or directory whose appearance is the commit point
/// and, for header/data pairs, the detached data file.
struct Unit {
    commit: PathBuf,
    data: Option<PathBuf>,
}

impl Unit {
    fn file(p: PathBuf) -> Unit {
        Unit {
            commit: p,
            data: None,
        }
    }
    fn pair(header: PathBuf, data: PathBuf) -> Unit {
        Unit {
            commit: header,
            data: Some(data),
        }
    }
    fn paths(&self) -> Vec<&Path> {
        std::iter::once(self.commit.as_path())
            .chain(self.data.as_deref())
            .collect()
    }
}

/// Every file at or under `paths`, with its bytes (absent paths: none).
type Snap = BTreeMap<PathBuf, Vec<u8>>;

fn snap(paths: &[&Path]) -> Snap {
    let mut out = Snap::new();
    let mut todo: Vec<PathBuf> = paths.iter().map(|p| p.to_path_buf()).collect();
    while let Some(p) = todo.pop() {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.is_dir() => {
                for e in std::fs::read_dir(&p).unwrap() {
                    todo.push(e.unwrap().path());
                }
            }
            Ok(_) => {
                out.insert(p.clone(), std::fs::read(&p).unwrap());
            }
            Err(_) => {}
        }
    }
    out
}

fn restore(unit: &Unit, s: &Snap) {
    for p in unit.paths() {
        remove(p);
    }
    for (p, bytes) in s {
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::write(p, bytes).unwrap();
    }
}

fn remove(p: &Path) {
    match std::fs::symlink_metadata(p) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(p).unwrap(),
        Ok(_) => std::fs::remove_file(p).unwrap(),
        Err(_) => {}
    }
}

/// A writer under test: the command that writes `units` into `out` (a
/// directory holding nothing else), and the command that writes an
/// earlier, different version of them (`None`: the output has no earlier
/// version to replace).
struct Writer {
    name: &'static str,
    tool: &'static str,
    args: Vec<OsString>,
    previous: Option<Vec<OsString>>,
    units: Vec<Unit>,
    out: PathBuf,
}

fn os(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    args.iter().map(|a| a.as_ref().to_os_string()).collect()
}

fn command(tool_name: &str, args: &[OsString]) -> Command {
    let mut c = bin(tool_name);
    c.args(args).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

fn succeed(tool_name: &str, args: &[OsString]) -> Duration {
    let t = Instant::now();
    ok(&mut command(tool_name, args));
    t.elapsed()
}

/// Temporary entries in `dir` (hidden names: `.NAME.XXXXXX.partial`, the
/// spooled copies of inputs).
fn temps(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    v.sort();
    v
}

/// Each temporary entry belongs to one unit path (or is a spooled copy),
/// and there is at most one per path.
fn check_temps(w: &Writer, left: &[String], when: &str) {
    let mut per: BTreeMap<String, usize> = BTreeMap::new();
    for n in left {
        let owner = w
            .units
            .iter()
            .flat_map(|u| u.paths())
            .map(|p| format!(".{}.", p.file_name().unwrap().to_string_lossy()))
            .find(|pre| n.starts_with(pre.as_str()) && n.ends_with(".partial"))
            .or_else(|| {
                n.starts_with(".vol-convert-spool.")
                    .then(|| "spool".to_string())
            })
            .unwrap_or_else(|| panic!("{}: {when}: stray temporary {n:?} in {left:?}", w.name));
        *per.entry(owner).or_default() += 1;
    }
    for (owner, n) in per {
        assert!(
            n <= 1,
            "{}: {when}: {n} temporaries for {owner}: {left:?}",
            w.name
        );
    }
}

/// The figures of one writer's kills.
#[derive(Default, Debug)]
struct Tally {
    kills: u64,
    /// A temporary file of this run was there after the kill.
    mid_write: u64,
    /// The run had already finished when the kill came.
    finished: u64,
    /// The output was the new one after the kill.
    new: u64,
    /// A header/data pair had no header after the kill.
    absent: u64,
}

/// Run `w` to the end, watching `w.out` for the run's first temporary
/// entry: the run time, and the time from that entry's appearance to the
/// end (about the time spent writing).
fn timed_run(w: &Writer) -> (Duration, Duration) {
    let before = temps(&w.out);
    let start = Instant::now();
    let mut child = command(w.tool, &w.args).spawn().unwrap();
    let mut seen = None;
    while child.try_wait().unwrap().is_none() {
        if seen.is_none() && temps(&w.out).iter().any(|n| !before.contains(n)) {
            seen = Some(start.elapsed());
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    let took = start.elapsed();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}: {}",
        w.name,
        String::from_utf8_lossy(&out.stderr)
    );
    (took, took - seen.unwrap_or(took))
}

/// Kill `w` at `kills()` moments spread over its run time, and check the
/// invariants after each kill and after a final uninterrupted run.
fn kill_writer(w: &Writer) -> Tally {
    let started = Instant::now();
    // The previous version, and the new one (timed: the kill window).
    let prev: Option<Vec<Snap>> = w.previous.as_ref().map(|args| {
        succeed(w.tool, args);
        w.units.iter().map(|u| snap(&u.paths())).collect()
    });
    let (took, writing) = timed_run(w);
    let new: Vec<Snap> = w.units.iter().map(|u| snap(&u.paths())).collect();
    for (i, (u, s)) in w.units.iter().zip(&new).enumerate() {
        assert!(
            !s.is_empty(),
            "{}: {} not written",
            w.name,
            u.commit.display()
        );
        if let Some(p) = &prev {
            assert!(p[i] != *s, "{}: previous and new outputs are equal", w.name);
        }
    }
    let reset = || {
        for (i, u) in w.units.iter().enumerate() {
            match &prev {
                Some(p) => restore(u, &p[i]),
                None => u.paths().into_iter().for_each(remove),
            }
        }
    };
    let mut t = Tally::default();
    let window = took.as_secs_f64() * 1.2;
    for k in 0..kills() {
        reset();
        let before = temps(&w.out);
        let u = (mix(seed_of(w.name) ^ k) >> 11) as f64 / (1u64 << 53) as f64;
        let mut child = command(w.tool, &w.args).spawn().unwrap();
        // Even moments: anywhere in the run. Odd ones: once the run's
        // first temporary file has appeared, anywhere in the time the
        // reference run took from there (the writing, for tools that
        // compute first and write at the end).
        let delay = if k % 2 == 0 {
            window * u
        } else {
            while child.try_wait().unwrap().is_none()
                && !temps(&w.out).iter().any(|n| !before.contains(n))
            {
                std::thread::sleep(Duration::from_micros(500));
            }
            writing.as_secs_f64() * 1.2 * u
        };
        std::thread::sleep(Duration::from_secs_f64(delay));
        if child.try_wait().unwrap().is_some() {
            t.finished += 1;
        }
        let _ = child.kill();
        let _ = child.wait();
        t.kills += 1;
        let left = temps(&w.out);
        if left.iter().any(|n| !before.contains(n)) {
            t.mid_write += 1;
        }
        let when = format!(
            "kill {k} ({} {:.1} ms)",
            if k % 2 == 0 {
                "at"
            } else {
                "after the temporary file by"
            },
            delay * 1e3
        );
        check_temps(w, &left, &when);
        for (i, unit) in w.units.iter().enumerate() {
            let s = snap(&unit.paths());
            if s == new[i] {
                t.new += 1;
                continue;
            }
            if prev.as_ref().is_some_and(|p| s == p[i]) {
                continue;
            }
            let commit_absent = !unit.commit.exists();
            // Nothing at all (no previous), or a pair without its header:
            // its data file, if there, must be a whole previous or new one.
            if commit_absent && (prev.is_none() || unit.data.is_some()) {
                if let Some(d) = &unit.data {
                    let data = snap(&[d]);
                    let whole = |x: &Snap| x.get(d) == data.get(d);
                    assert!(
                        data.is_empty()
                            || whole(&new[i])
                            || prev.as_ref().is_some_and(|p| whole(&p[i])),
                        "{}: {when}: partial data file {}",
                        w.name,
                        d.display()
                    );
                }
                if prev.is_some() {
                    t.absent += 1;
                }
                continue;
            }
            panic!(
                "{}: {when}: {} is neither the previous output nor the new one ({} files: {:?})",
                w.name,
                unit.commit.display(),
                s.len(),
                s.iter().map(|(p, b)| (p, b.len())).collect::<Vec<_>>()
            );
        }
    }
    // One more run completes the output and removes the killed runs'
    // temporary files.
    reset();
    succeed(w.tool, &w.args);
    for (i, u) in w.units.iter().enumerate() {
        assert!(snap(&u.paths()) == new[i], "{}: rerun differs", w.name);
    }
    assert_eq!(
        temps(&w.out),
        Vec::<String>::new(),
        "{}: temporaries left",
        w.name
    );
    println!(
        "faults: {:<16} kills {:>3}  mid-write {:>3}  finished {:>3}  new {:>3}  headerless {:>3}  partial 0  (run {:.0} ms, writing {:.0} ms; {:.1} s)",
        w.name,
        t.kills,
        t.mid_write,
        t.finished,
        t.new,
        t.absent,
        took.as_secs_f64() * 1e3,
        writing.as_secs_f64() * 1e3,
        started.elapsed().as_secs_f64()
    );
    t
}

/// The inputs every writer reads, made once per test process: a 224^3
/// noise volume (11 MiB, hardly compressible: every writer takes a while)
/// and a different one for the previous outputs. They live in
/// `CARGO_TARGET_TMPDIR/faults-PID`; the directories of test processes
/// that are gone are removed when the next one starts.
fn shared_inputs() -> &'static (PathBuf, PathBuf) {
    static INPUTS: std::sync::OnceLock<(PathBuf, PathBuf)> = std::sync::OnceLock::new();
    INPUTS.get_or_init(|| {
        let root = Path::new(env!("CARGO_TARGET_TMPDIR"));
        if let Ok(entries) = std::fs::read_dir(root) {
            for e in entries.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if let Some(pid) = name.strip_prefix("faults-") {
                    if !Path::new("/proc").join(pid).exists() {
                        let _ = std::fs::remove_dir_all(e.path());
                    }
                }
            }
        }
        let dir = root.join(format!("faults-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = gen(
            &dir,
            "a.vvol",
            &["noise", "--dims", "224,224,224", "--seed", "1"],
        );
        let b = gen(
            &dir,
            "b.vvol",
            &["noise", "--dims", "192,176,160", "--seed", "2"],
        );
        (a, b)
    })
}

/// The shared inputs, and `d/in` (for a test's own inputs) and `d/out`
/// (the outputs and nothing else) created.
fn inputs(d: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let out = d.join("out");
    std::fs::create_dir_all(d.join("in")).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let (a, b) = shared_inputs();
    (a.clone(), b.clone(), out)
}

/// A `vol-convert` writer of `out/name` with extra arguments.
fn convert_writer(d: &Path, name: &'static str, file: &str, extra: &[&str]) -> Writer {
    let (a, b, out) = inputs(d);
    let target = out.join(file);
    let with = |input: &Path| {
        let mut v = os(&[&input, &"-q", &"-o", &target]);
        v.extend(extra.iter().map(OsString::from));
        v
    };
    let units = match Path::new(file).extension().and_then(|e| e.to_str()) {
        Some("nhdr") | Some("mhd") => {
            vec![Unit::pair(target.clone(), target.with_extension("raw"))]
        }
        Some("hdr") => vec![Unit::pair(target.clone(), target.with_extension("img"))],
        _ => vec![Unit::file(target.components().as_path().to_path_buf())],
    };
    Writer {
        name,
        tool: "vol-convert",
        args: with(&a),
        previous: Some(with(&b)),
        units,
        out,
    }
}

fn run_convert(name: &'static str, file: &str, extra: &[&str]) {
    let d = tmp();
    kill_writer(&convert_writer(d.path(), name, file, extra));
}

#[test]
fn killed_vvol_sliced() {
    run_convert("vvol sliced", "o.vvol", &[]);
}

#[test]
fn killed_vvol_bricked() {
    run_convert("vvol bricked", "o.vvol", &["--layout", "bricked:32"]);
}

#[test]
fn killed_vvol_zstd() {
    run_convert(
        "vvol zstd",
        "o.vvol",
        &["--layout", "bricked:32", "--compress", "zstd"],
    );
}

#[test]
fn killed_nifti() {
    run_convert("nifti .nii", "o.nii", &[]);
}

#[test]
fn killed_nifti_pair() {
    run_convert("nifti .hdr/.img", "o.hdr", &[]);
}

#[test]
fn killed_nrrd_detached() {
    run_convert("nrrd .nhdr/.raw", "o.nhdr", &[]);
}

#[test]
fn killed_nrrd_attached() {
    run_convert("nrrd .nrrd", "o.nrrd", &[]);
}

#[test]
fn killed_metaimage_pair() {
    run_convert("mhd .mhd/.raw", "o.mhd", &[]);
}

#[test]
fn killed_omezarr() {
    run_convert("ome-zarr", "o.ome.zarr", &["--pyramid", "2"]);
}

#[test]
fn killed_tiff() {
    run_convert("tiff", "o.tif", &[]);
}

#[test]
fn killed_tiff_slices() {
    run_convert("tiff slices", "slices/", &[]);
}

#[test]
fn killed_vpart_merge() {
    let d = tmp();
    let (a, b, out) = inputs(d.path());
    let parts = |v: &Path, stem: &str| -> Vec<OsString> {
        (0..2)
            .map(|k| {
                let p = d.path().join("in").join(format!("{stem}.{k}.vpart"));
                succeed(
                    "vol-convert",
                    &os(&[
                        &v,
                        &"-q",
                        &"--layout",
                        &"bricked:32",
                        &"--shard",
                        &format!("{k}/2"),
                        &"-o",
                        &p,
                    ]),
                );
                p.into_os_string()
            })
            .collect()
    };
    let target = out.join("m.vvol");
    let merge = |p: Vec<OsString>| {
        let mut v = os(&[&"-q", &"-o", &target, &"--merge"]);
        v.extend(p);
        v
    };
    kill_writer(&Writer {
        name: "vpart merge",
        tool: "vol-convert",
        args: merge(parts(&a, "a")),
        previous: Some(merge(parts(&b, "b"))),
        units: vec![Unit::file(target.clone())],
        out,
    });
}

#[test]
fn killed_render_images() {
    let d = tmp();
    let (a, b, out) = inputs(d.path());
    let (png, pfm) = (out.join("i.png"), out.join("i.pfm"));
    let with = |v: &Path| {
        os(&[
            &v, &"-q", &"--size", &"512x512", &"-o", &png, &"--hdr", &pfm,
        ])
    };
    kill_writer(&Writer {
        name: "render png+pfm",
        tool: "vol-render",
        args: with(&a),
        previous: Some(with(&b)),
        units: vec![Unit::file(png.clone()), Unit::file(pfm.clone())],
        out,
    });
}

#[test]
fn killed_index() {
    let d = tmp();
    let (a, b, out) = inputs(d.path());
    let target = out.join("i.vidx");
    let with = |v: &Path| os(&[&v, &"-q", &"--cell", &"4", &"-o", &target]);
    kill_writer(&Writer {
        name: "vidx",
        tool: "vol-index",
        args: with(&a),
        previous: Some(with(&b)),
        units: vec![Unit::file(target.clone())],
        out,
    });
}

const PATH_SCENE: &[&str] = &["--mode", "path", "--density-scale", "0.5", "--bounces", "1"];

#[test]
fn killed_accumulate_state() {
    let d = tmp();
    let out = d.path().join("out");
    let inp = d.path().join("in");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&inp).unwrap();
    let v = gen(
        &inp,
        "s.vvol",
        &["spheres", "--dims", "48,48,48", "--seed", "1"],
    );
    let (state, png) = (out.join("p.state"), out.join("p.png"));
    let mut args = os(&[&v, &"-q", &"-o", &png, &"--accumulate", &state]);
    args.extend(PATH_SCENE.iter().map(OsString::from));
    args.extend(os(&[&"--spp", &"1"]));
    args.extend(os(&[&"--size", &"640x640"]));
    // The previous state is the same command's first pass, from no state;
    // each killed run adds a pass to it.
    kill_writer(&Writer {
        name: "accumulate",
        tool: "vol-render",
        previous: Some(args.clone()),
        args,
        units: vec![Unit::file(state), Unit::file(png)],
        out,
    });
}

/// A tmpfs of `size` mounted at `dir` until dropped; `None` (with a note
/// printed) when not root or the mount fails.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(dir: &Path, size: &str) -> Option<Tmpfs> {
        extern "C" {
            fn geteuid() -> u32;
        }
        // SAFETY: geteuid has no preconditions.
        if unsafe { geteuid() } != 0 {
            println!("faults: disk-full cases skipped: not root (a tmpfs mount needs root)");
            return None;
        }
        std::fs::create_dir_all(dir).unwrap();
        let st = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "none"])
            .arg(dir)
            .stderr(Stdio::null())
            .status();
        if !st.is_ok_and(|s| s.success()) {
            println!(
                "faults: disk-full cases skipped: cannot mount a tmpfs on {}",
                dir.display()
            );
            return None;
        }
        Some(Tmpfs(dir.to_path_buf()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
    }
}

/// Run `tool args` writing into a fresh `size` tmpfs at `small`: it must
/// fail (non-zero, one line naming `names[0]` or another of `names`,
/// no panic) and leave `small` as `keep` says (by default empty). Returns
/// the line, or `None` when the mount is not possible.
fn full_disk(
    small: &Path,
    size: &str,
    setup: &dyn Fn(),
    tool_name: &str,
    args: &[OsString],
    names: &[&str],
) -> Option<String> {
    let _m = Tmpfs::mount(small, size)?;
    setup();
    let before = snap(&[small]);
    let out = run(&mut command(tool_name, args));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "{tool_name} {args:?} succeeded on a full disk"
    );
    assert!(
        out.status.code().is_some(),
        "{tool_name} killed by a signal: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.lines().count(), 1, "{tool_name} {args:?}: {err}");
    assert!(err.starts_with(tool_name), "{err}");
    assert!(
        names.iter().any(|n| err.contains(n)),
        "{names:?} not named: {err}"
    );
    // Nothing new, nothing changed: no partial output, no temporary file.
    assert!(
        snap(&[small]) == before,
        "{tool_name} {args:?} left {:?}",
        std::fs::read_dir(small)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect::<Vec<_>>()
    );
    Some(err.trim_end().to_string())
}

#[test]
fn disk_full_every_writer_fails_cleanly() {
    let d = tmp();
    let (a, _, _) = inputs(d.path());
    let small = d.path().join("small");
    let vpart = d.path().join("in").join("a.0.vpart");
    let vpart1 = d.path().join("in").join("a.1.vpart");
    for (k, p) in [&vpart, &vpart1].iter().enumerate() {
        succeed(
            "vol-convert",
            &os(&[
                &a,
                &"-q",
                &"--layout",
                &"bricked:32",
                &"--compress",
                &"zstd",
                &"--shard",
                &format!("{k}/2"),
                &"-o",
                p,
            ]),
        );
    }
    let spheres = gen(
        &d.path().join("in"),
        "s.vvol",
        &["spheres", "--dims", "48,48,48", "--seed", "1"],
    );
    let none = || {};
    let mut lines = Vec::new();
    let convert = |file: &str, extra: &[&str]| {
        let mut v = os(&[&a, &"-q", &"-o", &small.join(file)]);
        v.extend(extra.iter().map(OsString::from));
        v
    };
    let cases: Vec<(&str, &str, Vec<OsString>, Vec<&str>)> = vec![
        (
            "vvol sliced",
            "vol-convert",
            convert("o.vvol", &[]),
            vec!["o.vvol"],
        ),
        (
            "vvol bricked",
            "vol-convert",
            convert("o.vvol", &["--layout", "bricked:32"]),
            vec!["o.vvol"],
        ),
        (
            "vvol zstd",
            "vol-convert",
            convert("o.vvol", &["--layout", "bricked:32", "--compress", "zstd"]),
            vec!["o.vvol"],
        ),
        (
            "nifti .nii",
            "vol-convert",
            convert("o.nii", &[]),
            vec!["o.nii"],
        ),
        (
            "nifti .nii.gz",
            "vol-convert",
            convert("o.nii.gz", &[]),
            vec!["o.nii.gz"],
        ),
        (
            "nifti .hdr/.img",
            "vol-convert",
            convert("o.hdr", &[]),
            vec!["o.hdr", "o.img"],
        ),
        (
            "nrrd .nrrd",
            "vol-convert",
            convert("o.nrrd", &["--compress", "gzip"]),
            vec!["o.nrrd"],
        ),
        (
            "nrrd .nhdr/.raw",
            "vol-convert",
            convert("o.nhdr", &[]),
            vec!["o.nhdr", "o.raw"],
        ),
        (
            "mhd .mhd/.raw",
            "vol-convert",
            convert("o.mhd", &[]),
            vec!["o.mhd", "o.raw"],
        ),
        (
            "ome-zarr",
            "vol-convert",
            convert("o.ome.zarr", &[]),
            vec!["o.ome.zarr"],
        ),
        ("tiff", "vol-convert", convert("o.tif", &[]), vec!["o.tif"]),
        (
            "tiff slices",
            "vol-convert",
            convert("slices/", &[]),
            vec!["slices"],
        ),
        ("raw", "vol-convert", convert("o.raw", &[]), vec!["o.raw"]),
        (
            "nrrd .nhdr/.raw.gz",
            "vol-convert",
            convert("o.nhdr", &["--compress", "gzip"]),
            vec!["o.nhdr", "o.raw.gz"],
        ),
        (
            "mhd .mhd/.zraw",
            "vol-convert",
            convert("o.mhd", &["--compress", "gzip"]),
            vec!["o.mhd", "o.zraw"],
        ),
        (
            "nifti .hdr/.img gzip",
            "vol-convert",
            convert("o.hdr", &["--compress", "gzip"]),
            vec!["o.hdr", "o.img"],
        ),
        (
            "vpart merge",
            "vol-convert",
            os(&[
                &"-q",
                &"-o",
                &small.join("m.vvol"),
                &"--merge",
                &vpart,
                &vpart1,
            ]),
            vec!["m.vvol"],
        ),
        (
            "vidx",
            "vol-index",
            os(&[&a, &"-q", &"--cell", &"4", &"-o", &small.join("i.vidx")]),
            vec!["i.vidx"],
        ),
        (
            "render png",
            "vol-render",
            os(&[
                &a,
                &"-q",
                &"--size",
                &"512x512",
                &"-o",
                &small.join("i.png"),
            ]),
            vec!["i.png"],
        ),
        (
            "render pfm",
            "vol-render",
            os(&[
                &a,
                &"-q",
                &"--size",
                &"512x512",
                &"-o",
                &d.path().join("i.png"),
                &"--hdr",
                &small.join("i.pfm"),
            ]),
            vec!["i.pfm"],
        ),
    ];
    // A 64 KiB file system: uncompressed outputs are refused before a byte
    // is written; compressed ones, images and indexes fill it up.
    for (name, tool_name, args, names) in &cases {
        match full_disk(&small, "64k", &none, tool_name, args, names) {
            Some(line) => lines.push(format!("{name}: {line}")),
            None => return,
        }
    }
    // Exactly the samples' bytes free (224^3, whole pages): the check
    // before writing passes, and the headers, trailers or page rounding of
    // many files fill the disk mid-write. (OME-Zarr chunks are compressed:
    // the store fits.)
    let mid_write = [
        "vvol sliced",
        "vvol bricked",
        "nifti .nii",
        "nifti .hdr/.img",
        "nrrd .nhdr/.raw",
        "mhd .mhd/.raw",
        "tiff",
        "tiff slices",
    ];
    for (name, tool_name, args, names) in cases.iter().filter(|c| mid_write.contains(&c.0)) {
        if let Some(line) = full_disk(&small, "11239424", &none, tool_name, args, names) {
            lines.push(format!("{name} (no room for headers): {line}"));
        }
    }
    // --accumulate: room for one state (1.6 MB at 224x224), not for a
    // second one beside it: the previous state stays as it was.
    let state = small.join("p.state");
    let mut args = os(&[
        &spheres,
        &"-q",
        &"-o",
        &d.path().join("p.png"),
        &"--accumulate",
        &state,
    ]);
    args.extend(PATH_SCENE.iter().map(OsString::from));
    args.extend(os(&[&"--spp", &"1"]));
    args.extend(os(&[&"--size", &"224x224"]));
    let first = || {
        succeed("vol-render", &args);
    };
    if let Some(line) = full_disk(&small, "2400k", &first, "vol-render", &args, &["p.state"]) {
        lines.push(format!("accumulate: {line}"));
    }
    for l in &lines {
        println!("faults: disk full: {l}");
    }
}

/// A render of `v` to `png` (both kinds are deterministic): ray cast
/// 48x48, or path traced 24x24 at 2 samples per pixel, whose random
/// sequence is keyed on the volume file's fingerprint.
fn render_args(v: &Path, png: &Path, path: bool) -> Vec<OsString> {
    let mut a = os(&[&v, &"-q", &"-o", &png]);
    if path {
        a.extend(PATH_SCENE.iter().map(OsString::from));
        a.extend(os(&[&"--size", &"24x24", &"--spp", &"2"]));
    } else {
        a.extend(os(&[&"--size", &"48x48", &"--shading", &"phong"]));
    }
    a
}

#[test]
fn replaced_while_read() {
    replaced_while_rendered(false, 8);
}

#[test]
fn replaced_while_path_traced() {
    replaced_while_rendered(true, 4);
}

/// `renderers` processes render a `.vvol` in a loop while `vol-convert`
/// renames another volume over it, again and again.
fn replaced_while_rendered(path: bool, renderers: usize) {
    let replacements = env_count("VOLKIT_FAULT_REPLACEMENTS", 12);
    let d = tmp();
    let inp = d.path().join("in");
    std::fs::create_dir_all(&inp).unwrap();
    // Two different volumes in two layouts: a header of one read with the
    // data of the other would fail or render neither image.
    let a = gen(
        &inp,
        "a.vvol",
        &["shapes", "--dims", "64,64,64", "--seed", "1"],
    );
    let b = gen(
        &inp,
        "b.vvol",
        &["spheres", "--dims", "56,48,72", "--seed", "2"],
    );
    let target = d.path().join("v.vvol");
    let put = |src: &Path, layout: &[&str]| {
        let mut v = os(&[&src, &"-q", &"-o", &target]);
        v.extend(layout.iter().map(OsString::from));
        succeed("vol-convert", &v);
    };
    let a_layout: &[&str] = &[];
    let b_layout: &[&str] = &["--layout", "bricked:16", "--compress", "zstd"];
    let reference = |src: &Path, layout: &[&str], name: &str| {
        put(src, layout);
        let png = d.path().join(name);
        succeed("vol-render", &render_args(&target, &png, path));
        std::fs::read(png).unwrap()
    };
    let img_b = reference(&b, b_layout, "b.png");
    let img_a = reference(&a, a_layout, "a.png");
    assert!(img_a != img_b);
    let done = std::sync::atomic::AtomicBool::new(false);
    let start = Instant::now();
    let (counts, n_replaced) = std::thread::scope(|s| {
        let readers: Vec<_> = (0..renderers)
            .map(|r| {
                let (done, target, d, img_a, img_b) = (&done, &target, d.path(), &img_a, &img_b);
                s.spawn(move || {
                    let (mut na, mut nb) = (0u64, 0u64);
                    let mut i = 0;
                    // At least one render each, then until the last
                    // replacement.
                    while i == 0 || !done.load(std::sync::atomic::Ordering::Relaxed) {
                        let png = d.join(format!("r{r}_{i}.png"));
                        let out = run(&mut command("vol-render", &render_args(target, &png, path)));
                        assert!(
                            out.status.success(),
                            "render {r}.{i} failed: {}",
                            String::from_utf8_lossy(&out.stderr)
                        );
                        let img = std::fs::read(&png).unwrap();
                        if img == *img_a {
                            na += 1;
                        } else if img == *img_b {
                            nb += 1;
                        } else {
                            panic!("render {r}.{i} is neither A's image nor B's");
                        }
                        std::fs::remove_file(&png).unwrap();
                        i += 1;
                    }
                    (na, nb)
                })
            })
            .collect();
        for k in 0..replacements {
            if k % 2 == 0 {
                put(&b, b_layout);
            } else {
                put(&a, a_layout);
            }
        }
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        let counts: Vec<(u64, u64)> = readers.into_iter().map(|h| h.join().unwrap()).collect();
        (counts, replacements)
    });
    let (na, nb) = counts.iter().fold((0, 0), |(x, y), (a, b)| (x + a, y + b));
    println!(
        "faults: replaced while {}: {n_replaced} replacements, {renderers} renderers, {} renders ({na} A, {nb} B, 0 failed, 0 mixed) in {:.1} s",
        if path { "path traced" } else { "ray cast" },
        na + nb,
        start.elapsed().as_secs_f64()
    );
    assert!(temps(d.path()).is_empty(), "{:?}", temps(d.path()));
}
