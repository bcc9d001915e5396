//! Write the seeds of the CSA fuzz target: a mosaic's CSA2 image header
//! (tile count, slice normal, a diffusion direction) as Siemens lays one
//! out (`volformats::dicom::csa::write_csa2`).
//!
//! `cargo run -p volkit-fuzz --example csa -- OUT`

fn main() {
    let Some(out) = std::env::args().nth(1) else {
        eprintln!("usage: csa OUT");
        std::process::exit(2);
    };
    let header = volformats::dicom::csa::write_csa2(&[
        ("NumberOfImagesInMosaic", &["48"]),
        ("SliceNormalVector", &["0", "0.00523632", "0.99998629"]),
        (
            "DiffusionGradientDirection",
            &["0.99997", "0.00505", "-0.00505"],
        ),
        ("B_value", &["1000"]),
    ]);
    if let Err(e) = std::fs::write(&out, header) {
        eprintln!("csa: {out}: {e}");
        std::process::exit(1);
    }
}
