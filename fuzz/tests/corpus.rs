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
