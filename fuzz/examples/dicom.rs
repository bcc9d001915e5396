//! Write the seed of the DICOM fuzz target: the middle slice of its
//! three-slice series (`volkit_fuzz::dicom_slice`).
//!
//! `cargo run -p volkit-fuzz --example dicom -- OUT`

fn main() {
    let Some(out) = std::env::args().nth(1) else {
        eprintln!("usage: dicom OUT");
        std::process::exit(2);
    };
    if let Err(e) = std::fs::write(&out, volkit_fuzz::dicom_slice(1)) {
        eprintln!("dicom: {out}: {e}");
        std::process::exit(1);
    }
}
