//! Running stages one after another with bounded memory.
//!
//! Each grid along the chain (the input, then every stage's output) is a
//! level with a sliding window of slices: a request for output slices
//! asks the last stage which input slices it needs, recursively down to
//! the source, and every level drops the slices below what is asked for.
//! A stage whose window would not fit [`SLAB_BUDGET`] (an orientation
//! that moves z, a rotated resampling grid) reads its input from a copy
//! on disk instead, written once and mapped.

use crate::grid::Grid;
use crate::stage::{Slab, Stage, SLAB_BUDGET};
use rayon::prelude::*;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Where the source's slices come from: `Ok` holds exactly the slices
/// asked for, each `dims.x * dims.y` long.
pub type Source<'f, E> = Box<dyn FnMut(Range<u64>) -> Result<Vec<Vec<f32>>, E> + 'f>;

/// What one level holds.
enum Store {
    /// Slices `first .. first + slices.len()`.
    Window { first: u64, slices: Vec<Vec<f32>> },
    /// The whole level, once [`Chain`] has written it to disk.
    Mapped {
        map: Option<memmap2::Mmap>,
        _file: Option<tempfile::NamedTempFile>,
    },
}

struct Level {
    grid: Grid,
    store: Store,
    /// Slices done with, for reuse: fresh allocations would make the
    /// allocator's heap grow with every batch (and fault in new pages).
    spare: Vec<Vec<f32>>,
}

/// The errors a chain adds to its source's: the disk copy of a level.
#[derive(Debug)]
pub enum ChainError<E> {
    /// The source failed.
    Source(E),
    /// Writing or mapping the on-disk copy of a level failed.
    Spill(PathBuf, std::io::Error),
    /// A stage failed (one line, naming the file it read).
    Stage(String),
}

impl<E: std::fmt::Display> std::fmt::Display for ChainError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChainError::Source(e) => e.fmt(f),
            ChainError::Stage(e) => f.write_str(e),
            ChainError::Spill(p, e) => write!(
                f,
                "{}: cannot write the temporary copy a stage reads: {e}",
                p.display()
            ),
        }
    }
}

/// Stages applied one after another to the slices of a source.
pub struct Chain<'f, E> {
    source: Source<'f, E>,
    stages: Vec<Box<dyn Stage>>,
    levels: Vec<Level>,
    temp_dir: PathBuf,
    /// Output slices computed per request at the least (parallelism).
    batch: u64,
    /// Where the source's slices go when the chain is done with them.
    recycle: Option<Box<dyn FnMut(Vec<f32>) + 'f>>,
}

impl<'f, E: Send> Chain<'f, E> {
    /// A chain from `input` (the source's grid) through `stages`, in
    /// order. Copies of levels that must be read whole go to `temp_dir`.
    pub fn new(
        input: Grid,
        source: Source<'f, E>,
        stages: Vec<Box<dyn Stage>>,
        temp_dir: &Path,
    ) -> Chain<'f, E> {
        let mut levels = vec![Level {
            grid: input,
            store: Store::Window {
                first: 0,
                slices: Vec::new(),
            },
            spare: Vec::new(),
        }];
        for s in &stages {
            levels.push(Level {
                grid: s.output(),
                store: Store::Window {
                    first: 0,
                    slices: Vec::new(),
                },
                spare: Vec::new(),
            });
        }
        // A stage whose window would not fit half the budget reads its
        // input level from disk.
        for (i, s) in stages.iter().enumerate() {
            let bytes = levels[i].grid.dims.slice_len().saturating_mul(4);
            if s.window().saturating_mul(bytes) > SLAB_BUDGET / 2 {
                levels[i].store = Store::Mapped {
                    map: None,
                    _file: None,
                };
            }
        }
        let out_bytes = levels
            .last()
            .map_or(4, |l| l.grid.dims.slice_len().saturating_mul(4))
            .max(1);
        let threads = rayon::current_num_threads() as u64;
        let batch = (2 * threads)
            .max(8)
            .min((SLAB_BUDGET / 8 / out_bytes).max(1));
        Chain {
            source,
            stages,
            levels,
            temp_dir: temp_dir.to_path_buf(),
            batch,
            recycle: None,
        }
    }

    /// Hand the source's slices back to `recycle` when the chain is done
    /// with them (a source that reuses its buffers).
    pub fn with_recycler(mut self, recycle: Box<dyn FnMut(Vec<f32>) + 'f>) -> Self {
        self.recycle = Some(recycle);
        self
    }

    /// A slice the caller is done with (one [`Chain::slices`] gave), for
    /// reuse by the last stage.
    pub fn recycle(&mut self, v: Vec<f32>) {
        if let Some(l) = self.levels.last_mut() {
            l.spare.push(v);
        }
    }

    /// The grid the chain writes (the input's when there is no stage).
    pub fn output(&self) -> Grid {
        self.levels
            .last()
            .map(|l| l.grid)
            .unwrap_or_else(|| unreachable!())
    }

    /// The stages, in order.
    pub fn stages(&self) -> &[Box<dyn Stage>] {
        &self.stages
    }

    /// Output slices `zs` (a range inside the output's z), computed in
    /// parallel; later requests should move up (a request below the held
    /// slices computes them again).
    pub fn slices(&mut self, zs: Range<u64>) -> Result<Slab<'_>, ChainError<E>> {
        let top = self.levels.len() - 1;
        let nz = self.levels[top].grid.dims.z;
        let want = zs.start..zs.end.max(zs.start + self.batch).min(nz).max(zs.end);
        // A batch at a time: the levels below then hold what one batch
        // needs, not what the whole request does (a writer's slab of
        // many slices).
        let mut end = want.start;
        while end < want.end {
            end = (end + self.batch).min(want.end);
            self.ensure(top, want.start..end)?;
        }
        Ok(self.slab(top, zs))
    }

    /// A view of slices `zs` of `level`, which holds them.
    fn slab(&self, level: usize, zs: Range<u64>) -> Slab<'_> {
        let l = &self.levels[level];
        let dims = l.grid.dims;
        let n = dims.slice_len() as usize;
        match &l.store {
            Store::Window { first, slices } => {
                let a = (zs.start - first) as usize;
                let b = (zs.end - first) as usize;
                Slab::new(
                    zs.start,
                    dims,
                    slices[a..b].iter().map(|v| v.as_slice()).collect(),
                )
            }
            Store::Mapped { map, .. } => {
                let all: &[f32] = map.as_deref().map_or(&[], bytemuck::cast_slice);
                let v = zs
                    .clone()
                    .map(|z| &all[z as usize * n..(z as usize + 1) * n])
                    .collect();
                Slab::new(zs.start, dims, v)
            }
        }
    }

    /// Make `level` hold slices `zs`.
    fn ensure(&mut self, level: usize, zs: Range<u64>) -> Result<(), ChainError<E>> {
        if zs.is_empty() {
            return Ok(());
        }
        if let Store::Mapped { map, .. } = &self.levels[level].store {
            if map.is_none() {
                self.spill(level)?;
            }
            return Ok(());
        }
        let need = {
            let l = &mut self.levels[level];
            let Store::Window { first, slices } = &mut l.store else {
                unreachable!()
            };
            let end = *first + slices.len() as u64;
            let gone = if zs.start < *first || zs.start >= end {
                slices.len()
            } else {
                (zs.start - *first) as usize
            };
            let dropped: Vec<Vec<f32>> = slices.drain(..gone).collect();
            if level == 0 {
                // The source's slices go back to the source.
                if let Some(r) = self.recycle.as_mut() {
                    dropped.into_iter().for_each(r);
                }
            } else {
                l.spare.extend(dropped);
            }
            *first = zs.start;
            (*first + slices.len() as u64).max(zs.start)..zs.end
        };
        if need.is_empty() {
            return Ok(());
        }
        let fresh = self.compute(level, need)?;
        if let Store::Window { slices, .. } = &mut self.levels[level].store {
            slices.extend(fresh);
        }
        Ok(())
    }

    /// Slices `zs` of `level`, computed.
    fn compute(&mut self, level: usize, zs: Range<u64>) -> Result<Vec<Vec<f32>>, ChainError<E>> {
        if level == 0 {
            return (self.source)(zs).map_err(ChainError::Source);
        }
        let stage_i = level - 1;
        let inr = self.stages[stage_i].needs(zs.clone());
        self.ensure(stage_i, inr.clone())?;
        let n = self.levels[level].grid.dims.slice_len() as usize;
        let want = (zs.end - zs.start) as usize;
        let spare = &mut self.levels[level].spare;
        let mut bufs: Vec<Vec<f32>> = spare.split_off(spare.len().saturating_sub(want));
        bufs.resize_with(want, Vec::new);
        let stage = &self.stages[stage_i];
        let slab = self.slab(stage_i, inr);
        bufs.into_par_iter()
            .enumerate()
            .map(|(i, mut out)| {
                let z = zs.start + i as u64;
                out.clear();
                out.resize(n, 0.0);
                stage.run(z, &slab, &mut out).map_err(ChainError::Stage)?;
                Ok(out)
            })
            .collect()
    }

    /// Write all of `level` to a temporary file and map it.
    fn spill(&mut self, level: usize) -> Result<(), ChainError<E>> {
        let dir = self.temp_dir.clone();
        let io = |e: std::io::Error| ChainError::Spill(dir.clone(), e);
        let mut file = tempfile::Builder::new()
            .prefix(".vol-convert-stage.")
            .tempfile_in(&self.temp_dir)
            .map_err(io)?;
        let grid = self.levels[level].grid;
        let slice_bytes = grid.dims.slice_len().saturating_mul(4).max(1);
        let step = (SLAB_BUDGET / 4 / slice_bytes).max(1);
        {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, file.as_file_mut());
            let mut z = 0;
            while z < grid.dims.z {
                let end = (z + step).min(grid.dims.z);
                // The level below is a window: fill this one piece by piece.
                let part = if level == 0 {
                    (self.source)(z..end).map_err(ChainError::Source)?
                } else {
                    self.compute(level, z..end)?
                };
                for s in &part {
                    w.write_all(bytemuck::cast_slice(s)).map_err(io)?;
                }
                z = end;
            }
            w.flush().map_err(io)?;
        }
        // SAFETY: the file is private to this process (a fresh temporary
        // file, removed when dropped) and not written while mapped.
        let map = unsafe { memmap2::Mmap::map(file.as_file()) }.map_err(io)?;
        self.levels[level].store = Store::Mapped {
            map: Some(map),
            _file: Some(file),
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::{Dims, Geometry};

    /// Output slice z = input slice z + input slice z+1 (clamped): a
    /// stage with a window of two.
    struct PairSum(Grid, u64);
    impl Stage for PairSum {
        fn name(&self) -> &str {
            "pair"
        }
        fn output(&self) -> Grid {
            self.0
        }
        fn needs(&self, zs: Range<u64>) -> Range<u64> {
            zs.start..(zs.end + 1).min(self.0.dims.z)
        }
        fn window(&self) -> u64 {
            self.1
        }
        fn run(&self, z: u64, input: &Slab<'_>, out: &mut [f32]) -> Result<(), String> {
            let a = input.slice(z);
            let b = input.slice_clamped(z as i64 + 1);
            for (o, (x, y)) in out.iter_mut().zip(a.iter().zip(b)) {
                *o = x + y;
            }
            Ok(())
        }
    }

    fn grid(nz: u64) -> Grid {
        Grid::new(Dims::new(3, 2, nz).unwrap(), [1.0; 3], Geometry::IDENTITY)
    }

    fn run_chain(window: u64, order: &[Range<u64>]) -> Vec<Vec<f32>> {
        let g = grid(40);
        let loads = std::cell::Cell::new(0u64);
        let source: Source<'_, String> = Box::new(|zs: Range<u64>| {
            loads.set(loads.get() + (zs.end - zs.start));
            Ok(zs.map(|z| vec![z as f32; 6]).collect())
        });
        let stages: Vec<Box<dyn Stage>> =
            vec![Box::new(PairSum(g, window)), Box::new(PairSum(g, window))];
        let dir = std::env::temp_dir();
        let mut c = Chain::new(g, source, stages, &dir);
        let mut out = Vec::new();
        for zs in order {
            let s = c.slices(zs.clone()).unwrap();
            for z in zs.clone() {
                out.push(s.slice(z).to_vec());
            }
        }
        out
    }

    #[test]
    fn two_stages_stream_and_match_the_formula() {
        let order: Vec<Range<u64>> = (0..40).step_by(3).map(|z| z..(z + 3).min(40)).collect();
        let out = run_chain(2, &order);
        for (z, s) in out.iter().enumerate() {
            let v = |z: usize| z.min(39) as f32;
            let p = |z: usize| v(z) + v(z + 1);
            assert_eq!(s[0], p(z) + p((z + 1).min(39)), "slice {z}");
        }
        // Any order of requests gives the same slices; a window past the
        // budget reads its input from disk and gives them too.
        let back: Vec<Range<u64>> = vec![30..40, 0..10, 10..30];
        let mut again = run_chain(2, &back);
        let mut mapped = run_chain(u64::MAX / 2, &back);
        let reorder = |v: &mut Vec<Vec<f32>>| {
            let tail: Vec<_> = v.drain(..10).collect();
            v.extend(tail);
        };
        reorder(&mut again);
        reorder(&mut mapped);
        assert_eq!(out, again);
        assert_eq!(out, mapped);
    }
}
