//! Building an index: one parallel pass over the volume in storage order.
//!
//! The volume is walked as tasks of blocks (module `walk`): z slabs of
//! cells for sliced volumes, rows of bricks for bricked ones. Sliced
//! samples are copied into cache-sized buffers a piece's band of rows at a
//! time (read from the file when mapped); bricked ones are read from the
//! file a run of bricks at a time, or borrowed in memory; zstd bricks are
//! decoded once each; any other source is copied through
//! [`VoxelSource::read_row`]. Every voxel is read exactly once.
//!
//! A task whose accumulators are small (a row of bricks) is one *piece*;
//! otherwise each block is cut into pieces of at most 32 slices and a
//! bounded number of rows (see module `piece`). A piece folds
//! its rows element-wise (min/max in the native sample type, which
//! vectorises) into one accumulator row per cell layer and cell row it
//! meets, the rows of one cell row and layer together (a box, a chunk of
//! columns at a time with its bounds in registers; AVX2 where the CPU has
//! it): a row on a cell boundary (`y` or `z` a multiple of the edge) is
//! also the apron of the cell before, so it goes into both. When the
//! piece is done each cell's range is reduced from its `N + 1` columns (the
//! apron column on the far side included) and folded into the task's box
//! of cells, which is merged into the level-0 arrays under a per-layer lock
//! when the task ends. A cell whose footprint spans several pieces or tasks
//! is the union of their parts; min and max do not depend on the order, and
//! zeros are canonicalised, so the result depends only on the samples, not
//! on the layout or the thread count. Memory: the level-0 arrays plus, per
//! thread, one task's cells and one piece's accumulators (about
//! 64K samples per bound, more only for rows wider than that).
//!
//! Integer samples are also counted per value in the same pass (each voxel
//! once) and rebinned into the histogram afterwards; `f32` samples are
//! binned in a second pass once their range is known.

use crate::error::IndexError;
use crate::histogram::{self, Histogram, DEFAULT_BINS, MAX_BINS};
use crate::index::MinMaxIndex;
use crate::level::{cell_count, level_shapes, try_zeroed, Level};
use crate::piece::{cells_meeting, CellBox, PieceRanges};
use crate::scan::{range_to_f32, Avx2, ExactCounts, ScanSample};
use crate::walk::{
    piece_shape, BandWalk, Block, BrickedWalk, CompressedWalk, Region, SlicedBands, SourceRows,
    Walk,
};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Mutex;
use volcore::volume::TypedGrid;
use volcore::{Sample, SampleType, SliceOrder, Volume, VolumeData, VoxelSource};

/// Smallest allowed macrocell edge.
pub const MIN_CELL_EDGE: u32 = 2;
/// Largest allowed macrocell edge.
pub const MAX_CELL_EDGE: u32 = 1024;
/// Default macrocell edge.
pub const DEFAULT_CELL_EDGE: u32 = 8;

/// Parameters of an index build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildOptions {
    /// Level-0 cell edge in voxels (`MIN_CELL_EDGE ..= MAX_CELL_EDGE`).
    pub cell_edge: u32,
    /// Requested histogram bins (`1 ..= 65536`); see [`crate::histogram`]
    /// for how the sample type shapes the bins.
    pub histogram_bins: u32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            cell_edge: DEFAULT_CELL_EDGE,
            histogram_bins: DEFAULT_BINS,
        }
    }
}

impl BuildOptions {
    /// Check every field against its allowed range.
    pub fn validate(&self) -> Result<(), IndexError> {
        if !(MIN_CELL_EDGE..=MAX_CELL_EDGE).contains(&self.cell_edge) {
            return Err(IndexError::Options(format!(
                "cell edge {} is outside {MIN_CELL_EDGE}..={MAX_CELL_EDGE}",
                self.cell_edge
            )));
        }
        if !(1..=MAX_BINS).contains(&self.histogram_bins) {
            return Err(IndexError::Options(format!(
                "{} histogram bins is outside 1..={MAX_BINS}",
                self.histogram_bins
            )));
        }
        Ok(())
    }
}

impl MinMaxIndex {
    /// Build the index of `src` (see [`crate::build`], where the building is) on the current rayon
    /// pool; `fingerprint` identifies the volume and is stored as given.
    pub fn build<S: VoxelSource>(
        src: &S,
        opts: &BuildOptions,
        fingerprint: u64,
    ) -> Result<MinMaxIndex, IndexError> {
        build_source(src, opts, fingerprint)
    }

    /// Build the index of an open volume of any layout and sample type.
    pub fn build_volume(
        vol: &Volume,
        opts: &BuildOptions,
        fingerprint: u64,
    ) -> Result<MinMaxIndex, IndexError> {
        build_volume(vol, opts, fingerprint)
    }
}

/// Build the index of `src`, tagging it with the caller's `fingerprint` of
/// the volume. Runs on the current rayon pool. Samples are copied through
/// [`VoxelSource::read_row`]; [`build_volume`] copies sliced samples a
/// band of rows at a time, reads bricked files in large runs (or borrows
/// bricks in memory) and decodes zstd bricks once each, which is faster.
pub fn build_source<S: VoxelSource>(
    src: &S,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MinMaxIndex, IndexError> {
    opts.validate()?;
    let edge = u64::from(opts.cell_edge);
    let index = match <S::Sample as Sample>::TYPE {
        SampleType::U8 => {
            build_walk::<u8>(&BandWalk::new(SourceRows(src), edge), opts, fingerprint)
        }
        SampleType::U16 => {
            build_walk::<u16>(&BandWalk::new(SourceRows(src), edge), opts, fingerprint)
        }
        SampleType::I16 => {
            build_walk::<i16>(&BandWalk::new(SourceRows(src), edge), opts, fingerprint)
        }
        SampleType::F32 => {
            build_walk::<f32>(&BandWalk::new(SourceRows(src), edge), opts, fingerprint)
        }
        // Opening narrows f64 volumes to f32 once (Volume::narrowed_from_f64),
        // so the index never gets its own f64 copy of the scan.
        SampleType::F64 => Err(IndexError::Source(
            "f64 samples are indexed as the f32 volume they open as".into(),
        )),
    }?;
    match src.error() {
        Some(msg) => Err(IndexError::Source(msg)),
        None => Ok(index),
    }
}

/// Build the index of an open volume (any layout and sample type), reading
/// its samples in storage order (see the module docs).
pub fn build_volume(
    vol: &Volume,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MinMaxIndex, IndexError> {
    opts.validate()?;
    match &vol.data {
        VolumeData::U8(g) => build_grid(g, opts, fingerprint),
        VolumeData::U16(g) => build_grid(g, opts, fingerprint),
        VolumeData::I16(g) => build_grid(g, opts, fingerprint),
        VolumeData::F32(g) => build_grid(g, opts, fingerprint),
    }
}

/// [`build_volume`] for one sample type: the walk that suits the layout.
fn build_grid<T: ScanSample>(
    grid: &TypedGrid<T>,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MinMaxIndex, IndexError> {
    let edge = u64::from(opts.cell_edge);
    match grid {
        TypedGrid::Sliced(grid) => match grid.order() {
            SliceOrder::XFastest => build_walk(
                &BandWalk::new(SlicedBands::new(grid), edge),
                opts,
                fingerprint,
            ),
            SliceOrder::ZFastest => {
                let bands = BandWalk::new(SlicedBands::transposed(grid), edge);
                build_walk(&bands, opts, fingerprint).map(MinMaxIndex::transposed_xz)
            }
        },
        TypedGrid::Bricked(grid) => build_walk(&BrickedWalk::new(grid), opts, fingerprint),
        TypedGrid::Compressed(grid) => build_walk(&CompressedWalk { grid }, opts, fingerprint),
    }
}

/// One cell layer of the level-0 arrays. It starts out as zeroed memory
/// the system has not handed out yet, and is set to the empty range by the
/// first task that merges into it: the arrays' pages are then faulted in by
/// the scanning threads in parallel, not by one thread before they start.
struct Layer<'a> {
    min: &'a mut [f32],
    max: &'a mut [f32],
    ready: bool,
}

impl Layer<'_> {
    /// Set every cell to the empty range, the first time only.
    fn make_ready(&mut self) {
        if !self.ready {
            self.min.fill(f32::INFINITY);
            self.max.fill(f32::NEG_INFINITY);
            self.ready = true;
        }
    }
}

/// The level-0 arrays, one lock per cell layer, for tasks to merge into.
struct Layers<'a> {
    cells: [u64; 3],
    planes: Vec<Mutex<Layer<'a>>>,
}

impl<'a> Layers<'a> {
    /// Split `min` and `max` (`cells` shaped, x fastest, contents
    /// unspecified) into layers.
    fn new(cells: [u64; 3], min: &'a mut [f32], max: &'a mut [f32]) -> Self {
        let plane = (cells[0] * cells[1]) as usize;
        let planes = min
            .chunks_mut(plane)
            .zip(max.chunks_mut(plane))
            .map(|(min, max)| {
                Mutex::new(Layer {
                    min,
                    max,
                    ready: false,
                })
            })
            .collect();
        Layers { cells, planes }
    }

    /// Lock layer `cz`. A panic while merging leaves the arrays unused:
    /// the build fails as a whole, so a poisoned lock is still safe to take.
    fn lock(&self, cz: u64) -> std::sync::MutexGuard<'_, Layer<'a>> {
        self.planes[cz as usize]
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// Widen every cell of `part` to hold its range there.
    fn merge<T: ScanSample>(&self, part: &CellBox<T>) {
        let [xs, ys, zs] = part.cells().clone();
        let nx = self.cells[0];
        for cz in zs {
            let mut layer = self.lock(cz);
            layer.make_ready();
            let Layer { min, max, .. } = &mut *layer;
            for cy in ys.clone() {
                let (lo, hi) = part.row(cy, cz);
                let i = (xs.start + nx * cy) as usize;
                let n = lo.len();
                let outs = min[i..i + n].iter_mut().zip(&mut max[i..i + n]);
                for ((min, max), (&lo, &hi)) in outs.zip(lo.iter().zip(hi)) {
                    let (lo, hi) = range_to_f32(lo, hi);
                    *min = f32::lower(*min, lo);
                    *max = f32::upper(*max, hi);
                }
            }
        }
    }

    /// Make every layer no task merged into (none, when every voxel was
    /// scanned) hold empty ranges.
    fn finish(self) {
        for layer in self.planes {
            layer
                .into_inner()
                .unwrap_or_else(|p| p.into_inner())
                .make_ready();
        }
    }
}

/// The whole build over a walk of the volume's samples.
fn build_walk<T: ScanSample>(
    walk: &dyn Walk<T>,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MinMaxIndex, IndexError> {
    build_walk_with(walk, opts, fingerprint, Avx2::detect())
}

/// [`build_walk`], its scan compiled for and run on AVX2 when `avx2` is
/// given (the proof that the CPU has it).
fn build_walk_with<T: ScanSample>(
    walk: &dyn Walk<T>,
    opts: &BuildOptions,
    fingerprint: u64,
    avx2: Option<Avx2>,
) -> Result<MinMaxIndex, IndexError> {
    let dims = walk.dims();
    let shapes = level_shapes(dims, opts.cell_edge);
    let Scanned {
        cells,
        min,
        max,
        counts,
    } = scan_walk(walk, opts, avx2)?;
    let edge = u64::from(opts.cell_edge);
    let mut levels = vec![Level::from_parts(cells, edge, min, max)?];
    while levels.len() < shapes.len() {
        let next = levels[levels.len() - 1].coarsen()?;
        levels.push(next);
    }
    let top = &levels[levels.len() - 1];
    let range = (top.min()[0], top.max()[0]);
    let hist = if T::EXACT_VALUES > 0 {
        Histogram::from_exact(T::TYPE_MIN, &counts.per_value(), opts.histogram_bins)
    } else {
        float_histogram(walk, range, opts.histogram_bins)?
    };
    MinMaxIndex::from_parts(dims, T::TYPE, fingerprint, range, hist, levels)
}

/// The level-0 cell ranges of a walk and its exact value counts.
pub(crate) struct Scanned {
    /// Level-0 cells per axis.
    pub cells: [u64; 3],
    /// Per-cell minima, x fastest.
    pub min: Vec<f32>,
    /// Per-cell maxima.
    pub max: Vec<f32>,
    /// Per-value counts (integer sample types).
    pub counts: ExactCounts,
}

/// One parallel pass over `walk`: the level-0 cell ranges and the exact
/// value counts, on AVX2 when `avx2` is given.
pub(crate) fn scan_walk<T: ScanSample>(
    walk: &dyn Walk<T>,
    opts: &BuildOptions,
    avx2: Option<Avx2>,
) -> Result<Scanned, IndexError> {
    let dims = walk.dims();
    let cells = level_shapes(dims, opts.cell_edge)[0];
    let total = cell_count(cells)?;
    usize::try_from(dims.x)
        .map_err(|_| IndexError::TooLarge(format!("rows of {} voxels", dims.x)))?;
    let mut min = try_zeroed(total)?;
    let mut max = try_zeroed(total)?;
    let edge = u64::from(opts.cell_edge);
    let counts = {
        let layers = Layers::new(cells, &mut min, &mut max);
        let counts = (0..walk.tasks())
            .into_par_iter()
            .try_fold(
                || Scratch::new(edge, avx2),
                |mut scratch, task| {
                    scan_task(walk, edge, task, &mut scratch)?;
                    layers.merge(&scratch.part);
                    Ok::<_, IndexError>(scratch)
                },
            )
            .map(|scratch| scratch.map(|s| s.counts))
            .try_reduce(ExactCounts::new::<T>, |a, b| Ok(a.merge(b)))?;
        layers.finish();
        counts
    };
    Ok(Scanned {
        cells,
        min,
        max,
        counts,
    })
}

/// The cells whose footprints meet the voxels of `r`, per axis.
fn cells_of(r: &Region, edge: u64) -> [Range<u64>; 3] {
    std::array::from_fn(|a| cells_meeting(r.axis(a), edge))
}

/// What a thread scanning tasks one after the other keeps between them:
/// the counts so far and the buffers of the last task (allocating them
/// per task would cost the allocator's trimming and the page faults that
/// follow).
struct Scratch<T> {
    counts: ExactCounts,
    part: CellBox<T>,
    acc: PieceRanges<T>,
}

impl<T: ScanSample> Scratch<T> {
    /// Empty scratch for cells of `edge` voxels, folding on AVX2 if given.
    fn new(edge: u64, avx2: Option<Avx2>) -> Self {
        Scratch {
            counts: ExactCounts::new::<T>(),
            part: CellBox::new([0..0, 0..0, 0..0]),
            acc: PieceRanges::new(edge, avx2),
        }
    }
}

/// Scan task `task` into `scratch.part`: the ranges of the cells its
/// voxels meet (the parts of their footprints it holds), counting its
/// voxels into `scratch.counts`. A task whose accumulators fit
/// [`TASK_ACC`] is one piece, fed by all its blocks (a row of bricks: each
/// cell's range is then reduced once, not once per brick); otherwise each
/// block is cut into pieces of its own.
fn scan_task<T: ScanSample>(
    walk: &dyn Walk<T>,
    edge: u64,
    task: u64,
    scratch: &mut Scratch<T>,
) -> Result<(), IndexError> {
    let r = walk.task_region(task);
    let Scratch { counts, part, acc } = scratch;
    let avx2 = acc.cpu();
    part.reset(cells_of(&r, edge));
    let one_piece = PieceRanges::<T>::len_for(edge, r.axis(0), r.axis(1), r.axis(2)) <= TASK_ACC;
    if one_piece {
        acc.start(r.axis(0), r.axis(1), r.axis(2));
    }
    walk.blocks(task, &mut |block| {
        let pieces = (!one_piece).then_some(edge);
        scan_block_on(avx2, acc, part, &block, pieces, counts);
    })?;
    if one_piece {
        finish_on(avx2, acc, part);
    }
    Ok(())
}

/// One block of a scan task: with `pieces` (the cell edge), cut into
/// pieces of its own, each folded and finished into `part`; without, folded
/// into the piece `acc` holds.
#[inline(always)]
fn scan_block<T: ScanSample>(
    acc: &mut PieceRanges<T>,
    part: &mut CellBox<T>,
    block: &Block<'_, T>,
    pieces: Option<u64>,
    counts: &mut ExactCounts,
) {
    let Some(edge) = pieces else {
        return acc.add_block(block, counts);
    };
    // Runs of slices, each cut into runs of rows (see `piece_shape`).
    let r = block.region;
    let (slices, rows) = piece_shape(r.hi[0] - r.lo[0], r.hi[2] - r.lo[2], edge);
    for z in r.axis(2).step_by(slices as usize) {
        let z1 = (z + slices).min(r.hi[2]);
        for y in r.axis(1).step_by(rows as usize) {
            let y1 = (y + rows).min(r.hi[1]);
            acc.start(r.axis(0), y..y1, z..z1);
            let piece = block.sub(Region {
                lo: [r.lo[0], y, z],
                hi: [r.hi[0], y1, z1],
            });
            acc.add_block(&piece, counts);
            acc.finish(part);
        }
    }
}

/// [`scan_block`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scan_block_avx2<T: ScanSample>(
    acc: &mut PieceRanges<T>,
    part: &mut CellBox<T>,
    block: &Block<'_, T>,
    pieces: Option<u64>,
    counts: &mut ExactCounts,
) {
    scan_block(acc, part, block, pieces, counts);
}

/// [`scan_block`], compiled for AVX2 when `avx2` is given (the proof that
/// the CPU has it): the folds then take 32 bytes per instruction, not 16.
fn scan_block_on<T: ScanSample>(
    avx2: Option<Avx2>,
    acc: &mut PieceRanges<T>,
    part: &mut CellBox<T>,
    block: &Block<'_, T>,
    pieces: Option<u64>,
    counts: &mut ExactCounts,
) {
    #[cfg(target_arch = "x86_64")]
    if avx2.is_some() {
        // SAFETY: `avx2` proves the CPU supports AVX2.
        return unsafe { scan_block_avx2(acc, part, block, pieces, counts) };
    }
    let _ = avx2;
    scan_block(acc, part, block, pieces, counts);
}

/// [`PieceRanges::finish`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn finish_avx2<T: ScanSample>(acc: &mut PieceRanges<T>, part: &mut CellBox<T>) {
    acc.finish(part);
}

/// [`PieceRanges::finish`], compiled for AVX2 when `avx2` is given (the
/// proof that the CPU has it).
fn finish_on<T: ScanSample>(avx2: Option<Avx2>, acc: &mut PieceRanges<T>, part: &mut CellBox<T>) {
    #[cfg(target_arch = "x86_64")]
    if avx2.is_some() {
        // SAFETY: `avx2` proves the CPU supports AVX2.
        return unsafe { finish_avx2(acc, part) };
    }
    let _ = avx2;
    acc.finish(part);
}

/// Accumulator elements (per bound) up to which a whole task is one piece.
const TASK_ACC: u64 = 1 << 16;

/// The `f32` histogram: a second pass binning every sample over the range
/// of the finite samples (found with a third pass only when the global
/// range itself is infinite).
pub(crate) fn float_histogram<T: ScanSample>(
    walk: &dyn Walk<T>,
    range: (f32, f32),
    bins: u32,
) -> Result<Histogram, IndexError> {
    let (lo, hi) = if range.0.is_finite() && range.1.is_finite() {
        range
    } else {
        finite_range(walk)?
    };
    // `+ 0.0` maps a −0.0 bound to +0.0, whichever zero the folds kept.
    let (lo, hi) = if lo <= hi {
        (f64::from(lo) + 0.0, f64::from(hi) + 0.0)
    } else {
        (0.0, 0.0)
    };
    let n = bins as usize;
    let (counts, nans) = (0..walk.tasks())
        .into_par_iter()
        .try_fold(
            || (vec![0u64; n], 0u64),
            |(mut counts, mut nans), task| {
                for_each_row(walk, task, |row| {
                    for &v in row {
                        let f = f64::from(v.to_f32());
                        if f.is_nan() {
                            nans += 1;
                        } else {
                            counts[histogram::bin_of(f, lo, hi, n)] += 1;
                        }
                    }
                })?;
                Ok::<_, IndexError>((counts, nans))
            },
        )
        .try_reduce(
            || (vec![0u64; n], 0),
            |(mut a, na), (b, nb)| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                Ok((a, na + nb))
            },
        )?;
    let mut h = Histogram::from_parts(lo, hi, counts, 0);
    h.set_nan_count(nans);
    Ok(h)
}

/// The range of the finite samples (empty if there are none).
fn finite_range<T: ScanSample>(walk: &dyn Walk<T>) -> Result<(f32, f32), IndexError> {
    (0..walk.tasks())
        .into_par_iter()
        .map(|task| {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for_each_row(walk, task, |row| {
                for v in row.iter().map(|v| v.to_f32()).filter(|v| v.is_finite()) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            })?;
            Ok((lo, hi))
        })
        .try_reduce(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |a, b| Ok((a.0.min(b.0), a.1.max(b.1))),
        )
}

/// Call `f` with every row (of some block) of task `task`.
pub(crate) fn for_each_row<T: ScanSample>(
    walk: &dyn Walk<T>,
    task: u64,
    mut f: impl FnMut(&[T]),
) -> Result<(), IndexError> {
    walk.blocks(task, &mut |block| block.for_each_row(|_, _, row| f(row)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{
        brute_range, file_data, footprint, odd_dims, random_samples, volume, RandomSample,
    };
    use volcore::brick::BrickGeometry;
    use volcore::grid::{BrickedGrid, Cursor, SlicedGrid};
    use volcore::region::{pack_bricks, pack_sliced, Rows as RegionRows};
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::{Data, Dims, ValueRange, VolumeVisitor};

    fn to_bytes(ix: &MinMaxIndex) -> Vec<u8> {
        let mut out = Vec::new();
        ix.write_to(&mut out).unwrap();
        out
    }

    /// Every level's cells against a brute-force range over the cell's
    /// voxel footprint, and against the union of their children.
    fn check_against_brute_force(ix: &MinMaxIndex, f: &[f32], what: &str) {
        let dims = ix.dims();
        for (l, lv) in ix.levels().iter().enumerate() {
            let c = lv.cells();
            for cz in 0..c[2] {
                for cy in 0..c[1] {
                    for cx in 0..c[0] {
                        let (lo, hi) = footprint([cx, cy, cz], lv.edge(), dims);
                        let want = brute_range(f, dims, lo, hi);
                        let got = lv.range(cx, cy, cz);
                        assert_eq!(got, want, "{what}: level {l} cell {cx},{cy},{cz}");
                        if l > 0 {
                            let prev = ix.level(l - 1);
                            let pc = prev.cells();
                            let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
                            for z in 2 * cz..(2 * cz + 2).min(pc[2]) {
                                for y in 2 * cy..(2 * cy + 2).min(pc[1]) {
                                    for x in 2 * cx..(2 * cx + 2).min(pc[0]) {
                                        let (p, q) = prev.range(x, y, z);
                                        a = a.min(p);
                                        b = b.max(q);
                                    }
                                }
                            }
                            assert_eq!(got, (a, b), "{what}: level {l} children");
                        }
                    }
                }
            }
        }
        assert_eq!(ix.level(ix.level_count() - 1).cells(), [1, 1, 1]);
        let r = ValueRange::of(f);
        assert_eq!(ix.value_range(), (r.min as f32, r.max as f32), "{what}");
    }

    /// Histogram totals, NaN count and per-bin counts by brute force.
    fn check_histogram(ix: &MinMaxIndex, f: &[f32], what: &str) {
        let h = ix.histogram();
        let mut want = vec![0u64; h.bins()];
        for &v in f.iter().filter(|v| !v.is_nan()) {
            want[h.bin_of(v as f64)] += 1;
        }
        assert_eq!(h.counts(), &want[..], "{what}");
        assert_eq!(
            h.nan_count(),
            f.iter().filter(|v| v.is_nan()).count() as u64
        );
        let finite: Vec<f64> = f
            .iter()
            .filter(|v| v.is_finite())
            .map(|&v| v as f64)
            .collect();
        if ix.sample_type() == SampleType::F32 && !finite.is_empty() {
            let lo = finite.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = finite.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            assert_eq!((h.lo(), h.hi()), (lo, hi), "{what}");
        }
        if ix.sample_type() == SampleType::U8 {
            assert_eq!((h.lo(), h.hi(), h.bins()), (0.0, 256.0, 256));
        }
    }

    /// Trilinear values at random points of every cell lie in the range of
    /// the cell holding the point, at every level.
    fn check_conservative(ix: &MinMaxIndex, vol: &Volume, seed: u64, what: &str) {
        struct Check<'a>(&'a MinMaxIndex, u64, &'a str);
        impl VolumeVisitor for Check<'_> {
            type Output = ();
            fn visit<S: VoxelSource>(self, src: &S) {
                let (ix, what) = (self.0, self.2);
                let mut rng = fastrand::Rng::with_seed(self.1);
                let mut cur = src.cursor();
                let d = ix.dims().as_array();
                let l0 = ix.level(0);
                let c = l0.cells();
                let e = l0.edge() as f32;
                for i in 0..l0.len() as u64 {
                    let cell = [i % c[0], (i / c[0]) % c[1], i / (c[0] * c[1])];
                    for _ in 0..12 {
                        let p: [f32; 3] = std::array::from_fn(|a| {
                            let v = cell[a] as f32 * e + rng.f32() * e;
                            v.min((d[a] - 1) as f32)
                        });
                        let v = cur.trilinear(p);
                        if v.is_nan() {
                            continue; // blends a NaN sample: unbounded by rule
                        }
                        for (l, lv) in ix.levels().iter().enumerate() {
                            let [x, y, z] = lv.cell_of(p, ix.dims());
                            if l == 0 {
                                assert_eq!([x, y, z], cell, "{what}: {p:?}");
                            }
                            let (lo, hi) = lv.range(x, y, z);
                            assert!(
                                lo <= v && v <= hi,
                                "{what}: level {l} value {v} at {p:?} outside [{lo}, {hi}]"
                            );
                        }
                    }
                }
            }
        }
        vol.visit(Check(ix, seed, what));
    }

    fn check_type<T: RandomSample>() {
        for (n, dims) in odd_dims().into_iter().enumerate() {
            for kind in 0..3u8 {
                for edge in [2, 3, 8, 17] {
                    let what = format!("{} {dims} kind {kind} edge {edge}", T::TYPE);
                    let seed = n as u64 * 31 + kind as u64;
                    let vol = volume::<T>(dims, random_samples(dims, seed, kind));
                    let opts = BuildOptions {
                        cell_edge: edge,
                        ..BuildOptions::default()
                    };
                    let ix = MinMaxIndex::build_volume(&vol, &opts, 7).unwrap();
                    let f = vol.to_f32_vec();
                    check_against_brute_force(&ix, &f, &what);
                    check_histogram(&ix, &f, &what);
                    check_conservative(&ix, &vol, seed, &what);
                }
            }
        }
    }

    #[test]
    fn u8_cells_match_brute_force() {
        check_type::<u8>();
    }

    #[test]
    fn u16_cells_match_brute_force() {
        check_type::<u16>();
    }

    #[test]
    fn i16_cells_match_brute_force() {
        check_type::<i16>();
    }

    #[test]
    fn f32_cells_with_nan_match_brute_force() {
        check_type::<f32>();
    }

    #[test]
    fn all_nan_cells_are_empty() {
        let dims = Dims::new(21, 13, 9).unwrap();
        let mut s: Vec<f32> = random_samples(dims, 3, 0);
        for z in 0..6 {
            for y in 0..10 {
                for x in 0..10 {
                    s[dims.index(x, y, z) as usize] = f32::NAN;
                }
            }
        }
        let vol = volume(dims, s);
        let opts = BuildOptions {
            cell_edge: 4,
            ..BuildOptions::default()
        };
        let ix = MinMaxIndex::build_volume(&vol, &opts, 0).unwrap();
        check_against_brute_force(&ix, &vol.to_f32_vec(), "nan block");
        // Cells (0..2, 0..2, 0) read voxels 0..=8 on x and y, 0..=4 on z.
        for c in [[0, 0, 0], [1, 1, 0], [1, 0, 0]] {
            let (lo, hi) = ix.cell_range(0, c[0], c[1], c[2]);
            assert!(lo == f32::INFINITY && hi == f32::NEG_INFINITY, "{c:?}");
        }
        assert!(ix.empty_fraction(f32::NEG_INFINITY) > 0.0);
        // Only NaNs: every cell empty, the global range too.
        let dims = Dims::new(5, 3, 2).unwrap();
        let vol = volume(dims, vec![f32::NAN; 30]);
        let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
        assert_eq!(ix.empty_fraction(-1e30), 1.0);
        assert!(ix.value_range().0 > ix.value_range().1);
        assert_eq!(ix.histogram().nan_count(), 30);
        assert_eq!(ix.histogram().total(), 0);
    }

    #[test]
    fn empty_fraction_counts_cells_at_or_below_the_threshold() {
        let dims = Dims::new(16, 8, 8).unwrap();
        let mut s = vec![0u8; 128 * 8];
        s[dims.index(15, 0, 0) as usize] = 9; // only cell x = 1 sees it
        let ix = MinMaxIndex::build_volume(&volume(dims, s), &BuildOptions::default(), 0).unwrap();
        assert_eq!(ix.level(0).cells(), [2, 1, 1]);
        assert_eq!(ix.empty_fraction(0.0), 0.5);
        assert_eq!(ix.empty_fraction(9.0), 1.0);
        assert_eq!(ix.empty_fraction(8.5), 0.5);
        assert_eq!(ix.stats().empty_fraction, 0.5);
        // Voxel x = 8 belongs to cell 1 and is the apron of cell 0.
        let mut s = vec![0u8; 128 * 8];
        s[dims.index(8, 3, 3) as usize] = 1;
        let ix = MinMaxIndex::build_volume(&volume(dims, s), &BuildOptions::default(), 0).unwrap();
        assert_eq!(ix.empty_fraction(0.0), 0.0);
    }

    /// A volume holding `grid` (its metadata says sliced: the build reads
    /// only the samples).
    fn volume_of<T: RandomSample>(dims: Dims, grid: TypedGrid<T>) -> Volume {
        Volume {
            meta: volcore::VolumeMeta::sliced(dims, T::TYPE),
            data: T::into_data(grid),
        }
    }

    /// A bricked copy of `sliced`.
    fn bricked<T: RandomSample>(sliced: &SlicedGrid<T>, brick: u32) -> BrickedGrid<T> {
        let geom = BrickGeometry::new(sliced.dims(), brick).unwrap();
        let packed = pack_bricks(&RegionRows(sliced), &geom);
        BrickedGrid::new(geom, geom.stored_len(), Data::Owned(packed)).unwrap()
    }

    /// Bricks of `grid` in a mapped file, `pad` samples apart beyond their
    /// stored length (as padded files store them), read from the file.
    fn bricked_in_file<T: RandomSample>(grid: &BrickedGrid<T>, pad: usize) -> BrickedGrid<T> {
        let geom = *grid.geometry();
        let stride = geom.stored_len() + pad;
        let mut spaced = vec![T::default(); stride * geom.brick_count() as usize];
        for (i, out) in spaced.chunks_exact_mut(stride).enumerate() {
            out[..geom.stored_len()].copy_from_slice(grid.brick(i as u64));
        }
        BrickedGrid::new(geom, stride, file_data(&spaced, 24)).unwrap()
    }

    /// The same index, bit for bit, from a sliced volume and bricked
    /// copies, read through `read_row`, in place, or from mapped files
    /// with positioned reads, and on pools of 1, 2 and 7 threads.
    fn check_layout_and_threads<T: RandomSample + ScanSample>(
        dims: Dims,
        kind: u8,
        edge: u32,
    ) -> Vec<u8> {
        let samples: Vec<T> = random_samples(dims, 99, kind);
        let sliced = SlicedGrid::new(dims, Data::Owned(samples.clone())).unwrap();
        let opts = BuildOptions {
            cell_edge: edge,
            ..BuildOptions::default()
        };
        let reference = to_bytes(&MinMaxIndex::build(&sliced, &opts, 5).unwrap());
        let in_file = SlicedGrid::new(dims, file_data(&samples, 8)).unwrap();
        assert!(in_file.data().reads_file() == cfg!(unix));
        // The folds compiled for AVX2 and without give the same bits.
        let bits_with = |walk: &dyn Walk<T>, avx2: Option<Avx2>| {
            to_bytes(&build_walk_with(walk, &opts, 5, avx2).unwrap())
        };
        if Avx2::detect().is_some() {
            for avx2 in [None, Avx2::detect()] {
                let walk = BandWalk::new(SlicedBands::new(&in_file), u64::from(edge));
                assert!(bits_with(&walk, avx2) == reference, "{} {avx2:?}", T::TYPE);
            }
        }
        // Blocks of one slice, smaller than the pieces (very wide rows).
        let small = BandWalk::bounded(SlicedBands::new(&in_file), u64::from(edge), 1);
        let what = format!("{} sliced in small blocks", T::TYPE);
        for avx2 in [None, Avx2::detect()] {
            assert!(bits_with(&small, avx2) == reference, "{what}, {avx2:?}");
        }
        let vol = volume_of(dims, TypedGrid::Sliced(in_file));
        let got = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap());
        assert!(got == reference, "{} sliced from a file differs", T::TYPE);
        let vol = volume(dims, samples.clone());
        let got = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap());
        assert!(got == reference, "{} sliced in memory differs", T::TYPE);
        // z fastest (the thesis's order): indexed as its transpose, in a
        // file and in memory, and through rows gathered across the order.
        let mut z_fastest = vec![T::default(); samples.len()];
        let [sx, sy, sz] = SliceOrder::ZFastest.strides(dims);
        for (n, &v) in samples.iter().enumerate() {
            let n = n as u64;
            let (x, y, z) = (n % dims.x, (n / dims.x) % dims.y, n / (dims.x * dims.y));
            z_fastest[(x * sx + y * sy + z * sz) as usize] = v;
        }
        for data in [file_data(&z_fastest, 8), Data::Owned(z_fastest.clone())] {
            let grid = SlicedGrid::with_order(dims, SliceOrder::ZFastest, data).unwrap();
            let got = to_bytes(&MinMaxIndex::build(&grid, &opts, 5).unwrap());
            assert!(got == reference, "{} z-fastest by rows differs", T::TYPE);
            let vol = volume_of(dims, TypedGrid::Sliced(grid));
            let got = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap());
            assert!(got == reference, "{} z-fastest differs", T::TYPE);
        }
        for brick in [2, 5, 16, 64] {
            let grid = bricked(&sliced, brick);
            let got = to_bytes(&MinMaxIndex::build(&grid, &opts, 5).unwrap());
            assert!(got == reference, "{} bricked:{brick} differs", T::TYPE);
            for avx2 in [None, Avx2::detect()] {
                let walk = BrickedWalk::new(&grid);
                let what = format!("{} bricked:{brick}, {avx2:?}", T::TYPE);
                assert!(bits_with(&walk, avx2) == reference, "{what}");
            }
            for pad in [0, 3] {
                let vol = volume_of(dims, TypedGrid::Bricked(bricked_in_file(&grid, pad)));
                let got = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap());
                assert!(
                    got == reference,
                    "{} bricked:{brick} from a file (pad {pad}) differs",
                    T::TYPE
                );
            }
            let vol = volume_of(dims, TypedGrid::Bricked(grid));
            let got = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap());
            assert!(
                got == reference,
                "{} bricked:{brick} in memory differs",
                T::TYPE
            );
        }
        for threads in [1, 2, 7] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got =
                pool.install(|| to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 5).unwrap()));
            assert!(got == reference, "{} on {threads} threads differs", T::TYPE);
        }
        reference
    }

    #[test]
    fn same_bits_for_any_layout_and_thread_count() {
        let dims = Dims::new(37, 23, 29).unwrap();
        check_layout_and_threads::<u8>(dims, 0, 4);
        check_layout_and_threads::<u16>(dims, 1, 4);
        check_layout_and_threads::<i16>(dims, 0, 4);
        check_layout_and_threads::<f32>(dims, 0, 4);
        check_layout_and_threads::<f32>(dims, 2, 4); // with infinities
    }

    /// Volumes wide enough that tasks are cut into pieces (slabs into runs
    /// of rows, big bricks into runs of slices and rows) give the same
    /// index as brute force.
    #[test]
    fn pieces_of_wide_tasks_match_brute_force() {
        for (dims, edge) in [((700, 101, 5), 2), ((150, 70, 66), 2), ((130, 9, 67), 3)] {
            let dims = Dims::new(dims.0, dims.1, dims.2).unwrap();
            for kind in [0, 2] {
                let bytes = check_layout_and_threads::<u8>(dims, kind, edge);
                let ix = MinMaxIndex::read_from(&mut &bytes[..], None).unwrap();
                let samples: Vec<u8> = random_samples(dims, 99, kind);
                let f: Vec<f32> = samples.iter().map(|&v| f32::from(v)).collect();
                let what = format!("{dims} edge {edge} kind {kind}");
                check_against_brute_force(&ix, &f, &what);
                check_histogram(&ix, &f, &what);
            }
        }
    }

    #[test]
    fn rejects_bad_options() {
        let vol = volume(Dims::new(4, 4, 4).unwrap(), vec![0u8; 64]);
        for (cell_edge, histogram_bins) in [(1, 256), (2000, 256), (8, 0), (8, 70000)] {
            let opts = BuildOptions {
                cell_edge,
                histogram_bins,
            };
            let err = MinMaxIndex::build_volume(&vol, &opts, 0).unwrap_err();
            assert!(matches!(err, IndexError::Options(_)), "{err}");
        }
    }

    /// Real-sized data: a 256³ shapes scene, checked against its samples.
    #[test]
    fn builds_a_256_cubed_scene() {
        let dims = Dims::new(256, 256, 256).unwrap();
        let scene = ShapesScene::new(dims, 42, 40, 48, 120.0);
        let samples = pack_sliced(&SceneSource::<u8>::new(&scene));
        let range = ValueRange::of(&samples);
        let mut per_value = [0u64; 256];
        for &v in &samples {
            per_value[v as usize] += 1;
        }
        let vol = volume(dims, samples);
        let start = std::time::Instant::now();
        let ix = MinMaxIndex::build_volume(&vol, &BuildOptions::default(), 1).unwrap();
        let took = start.elapsed();
        let stats = ix.stats();
        eprintln!("256^3 u8 index built in {took:?}: {stats:?}");
        assert_eq!(stats.value_range, (range.min as f32, range.max as f32));
        assert_eq!(ix.histogram().counts(), &per_value[..]);
        assert_eq!(stats.cells, 32 * 32 * 32);
        assert_eq!(stats.levels, 6);
        assert!(stats.empty_fraction > 0.05 && stats.empty_fraction < 0.95);
        assert_eq!(ix.cell_range(5, 0, 0, 0), stats.value_range);
        check_conservative(&ix, &vol, 3, "256^3 shapes");
    }
}
