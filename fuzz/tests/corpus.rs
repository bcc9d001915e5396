//! Every saved corpus file and every regression input (a crash or hang the
//! fuzzer found, since fixed) goes through its target once more, as a plain
//! test: a reader change that panics, aborts or hangs on any of them fails
//! here, without AFL.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use volkit_fuzz::{run, Target};

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(rd) => rd.filter_map(|e| e.ok().map(|e| e.path())).collect(),
        Err(_) => Vec::new(),
    };
    v.retain(|p| p.is_file());
    v.sort();
    v
}

/// Run every file of `fuzz/KIND/TARGET` through the target; each input
/// must finish within a few seconds (a hang found by the fuzzer took the
/// fuzzer's whole timeout).
fn replay(kind: &str, t: Target) -> usize {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(kind)
        .join(t.name());
    let scratch = tempfile::tempdir().unwrap();
    let list = files(&dir);
    for f in &list {
        let data = std::fs::read(f).unwrap();
        let start = Instant::now();
        run(t, &data, scratch.path());
        let took = start.elapsed();
        assert!(
            took < Duration::from_secs(10),
            "{}: took {took:?}",
            f.display()
        );
    }
    list.len()
}

#[test]
fn every_target_has_a_saved_corpus_and_replays_it() {
    for t in Target::ALL {
        let n = replay("corpus", t);
        assert!(n > 0, "fuzz/corpus/{} is empty", t.name());
    }
}

#[test]
fn regression_inputs_replay_cleanly() {
    for t in Target::ALL {
        replay("regressions", t);
    }
}

#[test]
fn target_names_round_trip() {
    for t in Target::ALL {
        assert_eq!(Target::from_name(t.name()), Some(t));
    }
    assert_eq!(Target::from_name("nope"), None);
}

/// The files the new targets build around their input must be valid
/// themselves, or the fuzzer never gets past the first check.
#[test]
fn the_targets_fixed_files_open() {
    use volformats::open::{open_input, ReadOptions};
    let dir = tempfile::tempdir().unwrap();
    // The DICOM target's series, with its seed as the middle slice.
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    for z in 0..3 {
        std::fs::write(series.join(format!("{z}.dcm")), volkit_fuzz::dicom_slice(z)).unwrap();
    }
    let r = open_input(&series, &ReadOptions::default()).unwrap();
    assert_eq!(r.info().dims.to_string(), "4x3x3");
    for z in 0..3 {
        r.read_slice(z).unwrap();
    }
    // The OME-TIFF target's file: an ImageJ hyperstack of 2 channels.
    let desc = b"ImageJ=1.54f\nimages=4\nchannels=2\nslices=2\nspacing=2.5\n";
    let p = dir.path().join("a.tif");
    std::fs::write(&p, volkit_fuzz::tiff_with_description(4, 1, desc)).unwrap();
    let opts = ReadOptions {
        channel: volformats::tiff::ChannelSel::Channel(1),
        ..ReadOptions::default()
    };
    let r = open_input(&p, &opts).unwrap();
    assert_eq!(r.info().dims.to_string(), "3x2x2");
    assert_eq!(r.info().spacing.map(|s| s[2]), Some(2.5));
    r.read_slice(1).unwrap();
}

/// A DICOM element that claims more bytes than its file holds is refused
/// with the element named, before dicom-rs would reserve and zero-fill
/// the claimed length.
#[test]
fn dicom_lengths_past_the_file_are_refused() {
    use volformats::open::{open_input, ReadOptions};
    let dir = tempfile::tempdir().unwrap();
    let mut b = volkit_fuzz::dicom_slice(1);
    let n = b.len();
    // The pixel data (the last element, 24 bytes) claims 2 GiB.
    b[n - 28..n - 24].copy_from_slice(&(1u32 << 31).to_le_bytes());
    let p = dir.path().join("a.dcm");
    std::fs::write(&p, &b).unwrap();
    let e = open_input(&p, &ReadOptions::default())
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("a.dcm") && e.contains("(7FE0,0010) claims 2147483648 bytes"),
        "{e}"
    );
}
