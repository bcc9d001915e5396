//! Times `--smooth gauss:1` and `--median 1` kernels through a `Chain` on
//! the benchmark shape (512x512x300 at 0.5x0.5x2 mm, CT-like
//! integer values), without file I/O:
//! `cargo run --release -p volprep --example bench_filters [REPEATS]`.

use std::ops::Range;
use std::time::Instant;
use volcore::{Dims, Geometry};
use volprep::chain::Source;
use volprep::gauss::Gauss;
use volprep::median::Median;
use volprep::{Chain, Grid, Slab, Stage};

/// Builds a fresh stage for one timed run.
type MakeStage = Box<dyn Fn() -> Box<dyn Stage>>;

/// The median's general path (gather and select) at R = 1, for comparison.
struct General(Median);

impl Stage for General {
    fn name(&self) -> &str {
        "median-general"
    }
    fn output(&self) -> Grid {
        self.0.output()
    }
    fn needs(&self, zs: Range<u64>) -> Range<u64> {
        self.0.needs(zs)
    }
    fn window(&self) -> u64 {
        self.0.window()
    }
    fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
        self.0.run_general(z, input, out);
        Ok(())
    }
}

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let (nx, ny, nz) = (512u64, 512u64, 300u64);
    let grid = Grid {
        dims: Dims::new(nx, ny, nz).unwrap(),
        spacing: [0.5, 0.5, 2.0],
        geometry: Geometry::IDENTITY,
    };
    // Air, a body ellipse of soft tissue with noise, a bone ring.
    let mut rng = fastrand::Rng::with_seed(52);
    let vol: Vec<Vec<f32>> = (0..nz)
        .map(|_| {
            let mut s = Vec::with_capacity((nx * ny) as usize);
            for y in 0..ny {
                for x in 0..nx {
                    let (u, v) = (x as f64 / 256.0 - 1.0, y as f64 / 230.0 - 1.0);
                    let r = (u * u + v * v).sqrt();
                    let base = if r > 0.9 {
                        -1000
                    } else if r > 0.8 {
                        1200
                    } else {
                        40
                    };
                    s.push((base + rng.i32(-30..=30)) as f32);
                }
            }
            s
        })
        .collect();
    let mvox = (nx * ny * nz) as f64 / 1e6;
    println!(
        "{}x{}x{} at 0.5,0.5,2 mm, {} threads",
        nx,
        ny,
        nz,
        rayon::current_num_threads()
    );
    let cases: Vec<(&str, MakeStage)> = vec![
        (
            "copy (source and chain only)",
            Box::new(move || -> Box<dyn Stage> {
                Box::new(volprep::pointwise::Clamp {
                    grid,
                    lo: f64::NEG_INFINITY,
                    hi: f64::INFINITY,
                })
            }),
        ),
        (
            "gauss sigma 1 mm",
            Box::new(move || -> Box<dyn Stage> { Box::new(Gauss::new(grid, [1.0; 3]).unwrap()) }),
        ),
        (
            "median R=1",
            Box::new(move || -> Box<dyn Stage> { Box::new(Median::new(grid, 1).unwrap()) }),
        ),
        (
            "median R=1, general path",
            Box::new(move || -> Box<dyn Stage> {
                Box::new(General(Median::new(grid, 1).unwrap()))
            }),
        ),
    ];
    for (name, make) in &cases {
        let mut times = Vec::new();
        for _ in 0..repeats {
            let source: Source<'_, String> =
                Box::new(|zs: Range<u64>| Ok(zs.map(|z| vol[z as usize].clone()).collect()));
            let mut c = Chain::new(grid, source, vec![make()], &std::env::temp_dir());
            let t = Instant::now();
            let mut sum = 0.0f64;
            let mut z = 0;
            while z < nz {
                let end = (z + 16).min(nz);
                let s = c.slices(z..end).unwrap();
                for k in z..end {
                    sum += s.slice(k)[(nx * ny / 2 + nx / 2) as usize] as f64;
                }
                z = end;
            }
            times.push(t.elapsed().as_secs_f64());
            std::hint::black_box(sum);
        }
        times.sort_by(f64::total_cmp);
        let med = times[times.len() / 2];
        println!(
            "{name:32} median of {repeats}: {med:.3} s  {:.1} Mvoxel/s  (all: {})",
            mvox / med,
            times
                .iter()
                .map(|t| format!("{t:.3}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
}
