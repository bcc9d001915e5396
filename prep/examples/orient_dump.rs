//! Orients a small volume whose voxel values are their linear index
//! (`i + nx·(j + ny·k)`) and prints, per code, one JSON line with the
//! output's dims, spacing, origin, direction (row-major) and voxels (x
//! fastest), for `prep/tests/orient_vs_sitk.py` to compare with
//! SimpleITK's `DICOMOrient`.
//!
//! Usage: `orient_dump NX NY NZ SX SY SZ OX OY OZ D00 D01 .. D22 CODE...`
//! (the direction row-major, as SimpleITK's `GetDirection`).

use std::ops::Range;
use volcore::{Dims, Geometry};
use volprep::chain::Source;
use volprep::orient::{Orient, OrientCode};
use volprep::{Chain, Grid, Stage};

fn main() {
    if let Err(e) = run() {
        eprintln!("orient_dump: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 19 {
        return Err("usage: orient_dump NX NY NZ SX SY SZ OX OY OZ D00..D22 CODE...".into());
    }
    let num = |i: usize| -> Result<f64, String> {
        args[i]
            .parse::<f64>()
            .map_err(|e| format!("{}: {e}", args[i]))
    };
    let n: Vec<u64> = (0..3)
        .map(|i| {
            args[i]
                .parse::<u64>()
                .map_err(|e| format!("{}: {e}", args[i]))
        })
        .collect::<Result<_, _>>()?;
    let dims = Dims::new(n[0], n[1], n[2]).map_err(|e| e.to_string())?;
    let spacing = [num(3)?, num(4)?, num(5)?];
    let origin = [num(6)?, num(7)?, num(8)?];
    let mut direction = [[0.0; 3]; 3];
    for (r, row) in direction.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = num(9 + 3 * r + c)?;
        }
    }
    let input = Grid {
        dims,
        spacing,
        geometry: Geometry {
            origin,
            direction,
            ..Geometry::IDENTITY
        },
    };
    for code in &args[18..] {
        let code: OrientCode = code.parse()?;
        let (grid, voxels) = match Orient::new(input, code) {
            None => (input, values(dims).concat()),
            Some(stage) => orient(input, stage)?,
        };
        println!("{}", json(code, &grid, &voxels));
    }
    Ok(())
}

/// Voxel values = their linear index, slice by slice.
fn values(d: Dims) -> Vec<Vec<f32>> {
    (0..d.z)
        .map(|k| {
            (0..d.slice_len())
                .map(|i| (k * d.slice_len() + i) as f32)
                .collect()
        })
        .collect()
}

/// The output grid and all its voxels, through a chain as vol-convert runs it.
fn orient(input: Grid, stage: Orient) -> Result<(Grid, Vec<f32>), String> {
    let src = values(input.dims);
    let source: Source<'_, String> =
        Box::new(move |zs: Range<u64>| Ok(zs.map(|z| src[z as usize].clone()).collect()));
    let out = stage.output();
    let dir = std::env::temp_dir();
    let mut chain = Chain::new(input, source, vec![Box::new(stage)], &dir);
    let mut voxels = Vec::new();
    for z in 0..out.dims.z {
        let slab = chain.slices(z..z + 1).map_err(|e| e.to_string())?;
        voxels.extend_from_slice(slab.slice(z));
    }
    Ok((out, voxels))
}

fn json(code: OrientCode, g: &Grid, voxels: &[f32]) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let d = g.geometry.direction;
    let vox = voxels
        .iter()
        .map(|v| format!("{}", *v as i64))
        .collect::<Vec<_>>()
        .join(",");
    format!(
        "{{\"code\":\"{code}\",\"dims\":[{},{},{}],\"spacing\":[{}],\"origin\":[{}],\"direction\":[{}],\"voxels\":[{vox}]}}",
        g.dims.x,
        g.dims.y,
        g.dims.z,
        list(&g.spacing),
        list(&g.geometry.origin),
        list(&d.concat()),
    )
}
