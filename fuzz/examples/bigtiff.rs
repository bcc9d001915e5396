//! Write a volume as a multipage BigTIFF (volkit writes BigTIFF only past
//! 4 GiB): a seed for the TIFF fuzz target and for the hard-case tests.
//!
//! `cargo run -p volkit-fuzz --example bigtiff -- IN.vvol OUT.tif`

use volcore::{Volume, VolumeVisitor, VoxelSource};

struct Pages<'a>(&'a std::path::Path, [f32; 3]);

impl VolumeVisitor for Pages<'_> {
    type Output = Result<(), String>;
    fn visit<S: VoxelSource>(self, src: &S) -> Result<(), String> {
        let d = src.dims();
        let file = std::fs::File::create(self.0).map_err(|e| e.to_string())?;
        let mut enc = tiff::encoder::TiffEncoder::new_big(std::io::BufWriter::new(file))
            .map_err(|e| e.to_string())?;
        let mut row = vec![S::Sample::default(); d.x as usize];
        for z in 0..d.z {
            let mut page: Vec<S::Sample> = Vec::new();
            for y in 0..d.y {
                src.read_row(0, y, z, &mut row);
                page.extend_from_slice(&row);
            }
            volformats::tiff::write_page(&mut enc, d.x as u32, d.y as u32, &page, self.1, None)?;
        }
        Ok(())
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = &args[..] else {
        eprintln!("usage: bigtiff IN.vvol OUT.tif");
        std::process::exit(2);
    };
    let run = || -> Result<(), String> {
        let v: Volume = volformats::vvol::open(input.as_ref(), Default::default())
            .map_err(|e| format!("{input}: {e}"))?;
        v.visit(Pages(output.as_ref(), v.meta.spacing))
            .map_err(|e| format!("{output}: {e}"))
    };
    if let Err(e) = run() {
        eprintln!("bigtiff: {e}");
        std::process::exit(1);
    }
}
