//! Run inputs through a target without AFL, timing each: for looking
//! into a crash or hang the fuzzer saved.
//!
//! `cargo run --release -p volkit-fuzz --example replay -- TARGET FILE...`

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_default();
    let Some(target) = volkit_fuzz::Target::from_name(&name) else {
        eprintln!("usage: replay TARGET FILE...");
        std::process::exit(2);
    };
    let scratch = tempfile::tempdir().expect("a scratch directory");
    for f in args {
        let data = match std::fs::read(&f) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("replay: {f}: {e}");
                std::process::exit(1);
            }
        };
        let start = std::time::Instant::now();
        volkit_fuzz::run(target, &data, scratch.path());
        println!("{f}: {:.3} s", start.elapsed().as_secs_f64());
    }
}
