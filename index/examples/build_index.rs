//! Build the majorant index of a generated shapes scene and report timings.
//!
//! ```text
//! cargo run --release -p volindex --example build_index -- [SIZE] [u8|u16|i16|f32] [CELL] [RUNS]
//! ```
//!
//! SIZE defaults to 256 (a SIZE³ volume), the type to u8, the cell edge to 8,
//! RUNS (timed builds) to 3.

use std::time::Instant;
use volcore::region::pack_sliced;
use volcore::scene::{SceneSource, ShapesScene};
use volcore::volume::IntoVolumeData;
use volcore::{Dims, SampleType, Volume};
use volindex::{BuildOptions, MinMaxIndex};

fn generate<T: IntoVolumeData>(scene: &ShapesScene, dims: Dims) -> Result<Volume, String> {
    let samples = pack_sliced(&SceneSource::<T>::new(scene));
    Volume::from_samples(dims, samples).map_err(|e| e.to_string())
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size: u64 = match args.first() {
        Some(s) => s.parse().map_err(|e| format!("size '{s}': {e}"))?,
        None => 256,
    };
    let ty: SampleType = match args.get(1) {
        Some(s) => s.parse()?,
        None => SampleType::U8,
    };
    let cell_edge: u32 = match args.get(2) {
        Some(s) => s.parse().map_err(|e| format!("cell edge '{s}': {e}"))?,
        None => 8,
    };
    let dims = Dims::new(size, size, size).map_err(|e| e.to_string())?;
    let scene = ShapesScene::new(dims, 42, 60, size / 5 + 1, 120.0);

    let t = Instant::now();
    let vol = match ty {
        SampleType::U8 => generate::<u8>(&scene, dims)?,
        SampleType::U16 => generate::<u16>(&scene, dims)?,
        SampleType::I16 => generate::<i16>(&scene, dims)?,
        SampleType::F32 => generate::<f32>(&scene, dims)?,
        SampleType::F64 => return Err("f64 volumes open as f32: index those".into()),
    };
    println!("generated {dims} {ty} in {:.3?}", t.elapsed());

    let opts = BuildOptions {
        cell_edge,
        ..BuildOptions::default()
    };
    let runs: usize = match args.get(3) {
        Some(s) => s.parse().map_err(|e| format!("runs '{s}': {e}"))?,
        None => 3,
    };
    let mut index = None;
    for run in 0..runs {
        let t = Instant::now();
        let ix = MinMaxIndex::build_volume(&vol, &opts, 0).map_err(|e| e.to_string())?;
        let secs = t.elapsed().as_secs_f64();
        let gb = dims.count() as f64 * ty.size() as f64 / 1e9;
        println!(
            "build {run}: {:.1} ms on {} threads ({:.2} GB/s)",
            secs * 1e3,
            rayon::current_num_threads(),
            gb / secs
        );
        index = Some(ix);
    }
    let Some(ix) = index else {
        return Ok(());
    };
    let mut bytes = Vec::new();
    ix.write_to(&mut bytes).map_err(|e| e.to_string())?;
    let s = ix.stats();
    println!(
        "range {:?}, {} cells, {} levels, empty fraction {:.3}, .vidx {} bytes",
        s.value_range,
        s.cells,
        s.levels,
        s.empty_fraction,
        bytes.len()
    );
    Ok(())
}

fn main() {
    if let Err(e) = run() {
        eprintln!("build_index: {e}");
        std::process::exit(1);
    }
}
