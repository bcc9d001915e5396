//! The AFL++ driver: `volkit-fuzz TARGET`, built by `cargo afl build` with
//! the `afl` feature and run by `scripts/fuzz.sh`. Persistent mode: one
//! process feeds many inputs to the target's function.

fn main() {
    let name = std::env::args().nth(1).unwrap_or_default();
    let Some(target) = volkit_fuzz::Target::from_name(&name) else {
        let names: Vec<&str> = volkit_fuzz::Target::ALL.iter().map(|t| t.name()).collect();
        eprintln!("usage: volkit-fuzz TARGET (one of {})", names.join(", "));
        std::process::exit(2);
    };
    let scratch = match tempfile::Builder::new().prefix("volkit-fuzz.").tempdir() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("volkit-fuzz: cannot create a scratch directory: {e}");
            std::process::exit(1);
        }
    };
    let dir = scratch.path().to_path_buf();
    afl::fuzz!(|data: &[u8]| {
        volkit_fuzz::run(target, data, &dir);
    });
    drop(scratch);
}
