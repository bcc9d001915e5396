//! Visiting a volume's samples in storage order, split into parallel tasks.
//!
//! A [`Walk`] splits the volume into *tasks* (units of parallel work: z
//! slabs of cells for row-ordered layouts, rows of bricks for bricked ones)
//! and hands each task's voxels out as [`Block`]s: boxes of voxels with a
//! strided view of their samples. Every voxel belongs to exactly one block,
//! and a task's blocks come in the order the layout stores them, so memory
//! is read as sequentially as the layout allows:
//! - sliced grids are copied a piece-sized band of rows at a time, from a
//!   mapped file with positioned reads (see [`volcore::Data::read_at`]:
//!   cheaper for one pass than faulting the map in and tearing it down);
//! - bricked grids mapped from a file are read a run of bricks at a time;
//!   in memory they lend each brick's stored samples (one block per
//!   brick);
//! - compressed grids decode each brick once, bypassing the brick cache;
//! - any other source is copied through [`VoxelSource::read_row`], a
//!   piece-sized band of rows at a time.

use crate::error::IndexError;
use std::mem::size_of;
use std::ops::Range;
use std::sync::Mutex;
use volcore::brick::APRON_LO;
use volcore::{
    BrickGeometry, BrickedGrid, CompressedGrid, Data, Dims, Sample, SliceOrder, SlicedGrid,
    VoxelSource,
};

/// Samples a band walk's block holds at most, unless one band of rows of
/// one slice is larger.
const BAND_SAMPLES: u64 = 1 << 22;

/// Bytes the bricked walk reads from a file at once (whole bricks, at
/// least one), so that they are still in cache when folded.
const READ_BYTES: usize = 1 << 17;

/// A box of voxels: `lo[a] .. hi[a]` along each axis `a`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Region {
    /// First voxel along x, y, z.
    pub lo: [u64; 3],
    /// One past the last voxel along x, y, z.
    pub hi: [u64; 3],
}

impl Region {
    /// The voxels of `r` along axis `a`.
    pub fn axis(&self, a: usize) -> Range<u64> {
        self.lo[a]..self.hi[a]
    }
}

/// Accumulator elements a piece aims for (per bound), so that its
/// accumulator rows stay in cache.
const PIECE_ACC: u64 = 1 << 15;
/// Most slices in one piece (fewer streams through memory at once).
const PIECE_SLICES: u64 = 32;

/// Slices and rows of the pieces of a block `width × depth` voxels wide
/// and deep: at most [`PIECE_SLICES`] slices, and rows (a multiple of the
/// cell edge when more than one fits) keeping the accumulators near
/// [`PIECE_ACC`] elements.
pub(crate) fn piece_shape(width: u64, depth: u64, edge: u64) -> (u64, u64) {
    let slices = depth.min(PIECE_SLICES);
    let layers = slices / edge + 2;
    let bands = PIECE_ACC / (layers * width);
    let rows = (bands.saturating_sub(2) * edge).max(1);
    (slices, rows)
}

/// A region and its samples: voxel `(x, y, z)` of the region is
/// `data[(x − origin.x) + (y − origin.y)·row + (z − origin.z)·plane]`.
pub(crate) struct Block<'a, T> {
    /// The voxels of the block.
    pub region: Region,
    data: &'a [T],
    origin: [u64; 3],
    row: usize,
    plane: usize,
}

impl<'a, T> Block<'a, T> {
    /// Voxels `xs` of row `(y, z)`, which must lie in the block's region.
    #[inline]
    pub fn row(&self, xs: Range<u64>, y: u64, z: u64) -> &'a [T] {
        let o = self.origin;
        let start = (xs.start - o[0]) as usize
            + (y - o[1]) as usize * self.row
            + (z - o[2]) as usize * self.plane;
        &self.data[start..start + (xs.end - xs.start) as usize]
    }

    /// The block of `region` whose first voxel is `data[0]`, rows `row`
    /// and slices `plane` samples apart.
    #[cfg(test)]
    pub fn new(region: Region, data: &'a [T], row: usize, plane: usize) -> Self {
        Block {
            region,
            data,
            origin: region.lo,
            row,
            plane,
        }
    }

    /// The samples of the region from its first voxel on, with the row
    /// and plane strides: voxel `(x, y, z)` is at
    /// `(x − lo.x) + (y − lo.y)·row + (z − lo.z)·plane`.
    #[inline]
    pub fn samples(&self) -> (&'a [T], usize, usize) {
        let (r, o) = (self.region, self.origin);
        let at = (r.lo[0] - o[0]) as usize
            + (r.lo[1] - o[1]) as usize * self.row
            + (r.lo[2] - o[2]) as usize * self.plane;
        let len = (r.hi[2] - r.lo[2] - 1) as usize * self.plane
            + (r.hi[1] - r.lo[1] - 1) as usize * self.row
            + (r.hi[0] - r.lo[0]) as usize;
        (&self.data[at..at + len], self.row, self.plane)
    }

    /// The same samples seen through a smaller region.
    pub fn sub(&self, region: Region) -> Block<'a, T> {
        Block { region, ..*self }
    }

    /// The same samples with every z coordinate lowered by `dz` (at most
    /// the region's first z).
    pub fn shifted_z(&self, dz: u64) -> Block<'a, T> {
        let (data, row, plane) = self.samples();
        let mut region = self.region;
        region.lo[2] -= dz;
        region.hi[2] -= dz;
        Block {
            region,
            data,
            origin: region.lo,
            row,
            plane,
        }
    }

    /// Call `f(y, z, row)` for every row of the block, z outer, y inner.
    #[inline]
    pub fn for_each_row(&self, mut f: impl FnMut(u64, u64, &'a [T])) {
        let r = self.region;
        for z in r.axis(2) {
            for y in r.axis(1) {
                f(y, z, self.row(r.axis(0), y, z));
            }
        }
    }
}

impl<T> Clone for Block<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Block<'_, T> {}

/// A volume's samples as tasks of blocks (see the module docs).
pub(crate) trait Walk<T>: Sync {
    /// The volume's dimensions.
    fn dims(&self) -> Dims;
    /// Number of tasks.
    fn tasks(&self) -> u64;
    /// The voxels task `task` covers (the union of its blocks).
    fn task_region(&self, task: u64) -> Region;
    /// Call `f` with each block of task `task`, in storage order. Fails
    /// only if stored data cannot be decoded.
    fn blocks(&self, task: u64, f: &mut dyn FnMut(Block<'_, T>)) -> Result<(), IndexError>;
}

/// The z slab `[k·edge, (k + 1)·edge)` of a volume, clamped.
fn slab(dims: Dims, edge: u64, k: u64) -> Region {
    Region {
        lo: [0, 0, k * edge],
        hi: [dims.x, dims.y, (k * edge + edge).min(dims.z)],
    }
}

/// The slices `zs` of another walk's volume, as a volume of their own
/// (slice `zs.start` becomes slice 0): its tasks are the other walk's
/// tasks that meet those slices, their blocks cut to them, so only the
/// storage those slices live in is read.
pub(crate) struct ZClip<'w, T> {
    inner: &'w dyn Walk<T>,
    zs: Range<u64>,
    tasks: Vec<u64>,
}

impl<'w, T> ZClip<'w, T> {
    /// Slices `zs` (within the volume, not empty) of `inner`.
    pub fn new(inner: &'w dyn Walk<T>, zs: Range<u64>) -> Self {
        let tasks = (0..inner.tasks())
            .filter(|&t| {
                let r = inner.task_region(t);
                r.lo[2] < zs.end && r.hi[2] > zs.start
            })
            .collect();
        ZClip { inner, zs, tasks }
    }

    fn clip(&self, r: Region) -> Option<Region> {
        let lo = r.lo[2].max(self.zs.start);
        let hi = r.hi[2].min(self.zs.end);
        (lo < hi).then(|| {
            let mut c = r;
            c.lo[2] = lo - self.zs.start;
            c.hi[2] = hi - self.zs.start;
            c
        })
    }
}

impl<T: Sync> Walk<T> for ZClip<'_, T> {
    fn dims(&self) -> Dims {
        let d = self.inner.dims();
        Dims {
            z: self.zs.end - self.zs.start,
            ..d
        }
    }

    fn tasks(&self) -> u64 {
        self.tasks.len() as u64
    }

    fn task_region(&self, task: u64) -> Region {
        let r = self.inner.task_region(self.tasks[task as usize]);
        self.clip(r).unwrap_or(Region {
            lo: [0; 3],
            hi: [0; 3],
        })
    }

    fn blocks(&self, task: u64, f: &mut dyn FnMut(Block<'_, T>)) -> Result<(), IndexError> {
        let z0 = self.zs.start;
        let (lo, hi) = (self.zs.start, self.zs.end);
        self.inner
            .blocks(self.tasks[task as usize], &mut |b: Block<'_, T>| {
                let r = b.region;
                let (a, e) = (r.lo[2].max(lo), r.hi[2].min(hi));
                if a < e {
                    let mut cut = r;
                    cut.lo[2] = a;
                    cut.hi[2] = e;
                    f(b.sub(cut).shifted_z(z0));
                }
            })
    }
}

/// Rows of a row-ordered volume, copied out on request.
pub(crate) trait BandSource<T>: Sync {
    /// The volume's dimensions.
    fn dims(&self) -> Dims;
    /// Copy the whole rows `ys` of slice `z` into `out` (`out.len()` is
    /// their sample count), x fastest.
    fn read_band(&self, ys: Range<u64>, z: u64, out: &mut [T]) -> Result<(), IndexError>;
}

/// Any [`VoxelSource`], a row at a time through [`VoxelSource::read_row`].
/// `T` must be `S::Sample` (otherwise every read fails).
pub(crate) struct SourceRows<'a, S>(pub &'a S);

impl<S: VoxelSource, T: Sample> BandSource<T> for SourceRows<'_, S> {
    fn dims(&self) -> Dims {
        self.0.dims()
    }

    fn read_band(&self, ys: Range<u64>, z: u64, out: &mut [T]) -> Result<(), IndexError> {
        let out: &mut [S::Sample] = bytemuck::try_cast_slice_mut(out)
            .ok()
            .filter(|_| T::TYPE == S::Sample::TYPE)
            .ok_or_else(|| {
                IndexError::Source(format!("sample type {} does not match its tag", T::TYPE))
            })?;
        let w = self.0.dims().x as usize;
        for (y, row) in ys.zip(out.chunks_exact_mut(w)) {
            self.0.read_row(0, y, z, row);
        }
        Ok(())
    }
}

/// A sliced grid, a band of rows (one piece's rows of one slice) at a time:
/// one positioned read from a mapped file (see [`volcore::Data::read_at`]),
/// one copy from memory. Folding a cache-sized copy is faster than
/// folding the samples in place, even in memory: the folds go down a box
/// of rows from several slices at once, too many streams for the hardware
/// prefetcher.
pub(crate) struct SlicedBands<'a, T: Sample> {
    /// The dimensions the storage order spells, x fastest.
    dims: Dims,
    data: &'a Data<T>,
}

impl<'a, T: Sample> SlicedBands<'a, T> {
    /// The bands of an x-fastest grid.
    pub(crate) fn new(grid: &'a SlicedGrid<T>) -> Self {
        debug_assert_eq!(grid.order(), SliceOrder::XFastest);
        SlicedBands {
            dims: grid.dims(),
            data: grid.data(),
        }
    }

    /// The bands of a z-fastest grid read as the x-fastest grid of its
    /// transpose (dimensions z, y, x): an index built from them is the
    /// grid's own after [`crate::MinMaxIndex::transposed_xz`].
    pub(crate) fn transposed(grid: &'a SlicedGrid<T>) -> Self {
        let d = grid.dims();
        SlicedBands {
            dims: Dims::new(d.z, d.y, d.x).unwrap_or(d),
            data: grid.data(),
        }
    }
}

impl<T: Sample> BandSource<T> for SlicedBands<'_, T> {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn read_band(&self, ys: Range<u64>, z: u64, out: &mut [T]) -> Result<(), IndexError> {
        let first = self.dims().index(0, ys.start, z) as usize;
        self.data.read_at(first, out).map_err(read_failed)
    }
}

/// The error of a failed read of mapped samples.
fn read_failed(e: std::io::Error) -> IndexError {
    IndexError::Source(format!("reading samples failed: {e}"))
}

/// Scratch buffers for walks that copy samples, reused across tasks (one
/// per task running at a time): a fresh large buffer per task would cost
/// page faults on every use.
struct Buffers<T>(Mutex<Vec<Vec<T>>>);

impl<T: Sample> Buffers<T> {
    fn new() -> Self {
        Buffers(Mutex::new(Vec::new()))
    }

    /// Call `f` with a buffer of `len` samples (contents unspecified).
    fn with<R>(&self, len: usize, f: impl FnOnce(&mut [T]) -> R) -> R {
        // A panic elsewhere leaves only spare buffers behind the lock.
        let pool = || self.0.lock().unwrap_or_else(|p| p.into_inner());
        let mut buf = pool().pop().unwrap_or_default();
        if buf.len() < len {
            buf.resize(len, T::default());
        }
        let r = f(&mut buf[..len]);
        pool().push(buf);
        r
    }
}

/// A row-ordered volume copied from a [`BandSource`]: one task per z slab
/// of `edge` slices, each handed out in blocks the shape of the build's
/// pieces (see [`piece_shape`]), so that a block's samples are still in
/// cache while they are folded.
pub(crate) struct BandWalk<B, T> {
    src: B,
    edge: u64,
    band_samples: u64,
    buffers: Buffers<T>,
}

impl<B: BandSource<T>, T: Sample> BandWalk<B, T> {
    /// Tasks of `edge` slices over `src`.
    pub fn new(src: B, edge: u64) -> Self {
        Self::bounded(src, edge, BAND_SAMPLES)
    }

    /// [`BandWalk::new`] with blocks of at most `band_samples` samples
    /// (unless one band of one slice is larger).
    pub fn bounded(src: B, edge: u64, band_samples: u64) -> Self {
        BandWalk {
            src,
            edge,
            band_samples,
            buffers: Buffers::new(),
        }
    }
}

impl<B: BandSource<T>, T: Sample> Walk<T> for BandWalk<B, T> {
    fn dims(&self) -> Dims {
        self.src.dims()
    }

    fn tasks(&self) -> u64 {
        self.dims().z.div_ceil(self.edge)
    }

    fn task_region(&self, task: u64) -> Region {
        slab(self.dims(), self.edge, task)
    }

    fn blocks(&self, task: u64, f: &mut dyn FnMut(Block<'_, T>)) -> Result<(), IndexError> {
        let d = self.dims();
        let slab = self.task_region(task);
        let (slices, rows) = piece_shape(d.x, slab.hi[2] - slab.lo[2], self.edge);
        let rows = rows.min(d.y);
        let row = d.x as usize;
        // Very wide rows: fewer slices per block than per piece (each block
        // then makes a piece of its own), keeping the buffer bounded.
        let slices = slices.min((self.band_samples / (d.x * rows)).max(1));
        self.buffers.with(row * (rows * slices) as usize, |buf| {
            for z0 in slab.axis(2).step_by(slices as usize) {
                let z1 = (z0 + slices).min(slab.hi[2]);
                for y0 in (0..d.y).step_by(rows as usize) {
                    let y1 = (y0 + rows).min(d.y);
                    let plane = row * (y1 - y0) as usize;
                    for z in z0..z1 {
                        let at = (z - z0) as usize * plane;
                        self.src.read_band(y0..y1, z, &mut buf[at..at + plane])?;
                    }
                    let region = Region {
                        lo: [0, y0, z0],
                        hi: [d.x, y1, z1],
                    };
                    f(Block {
                        region,
                        data: buf,
                        origin: region.lo,
                        row,
                        plane,
                    });
                }
            }
            Ok(())
        })
    }
}

/// One task per row of bricks `(by, bz)`, x fastest like the bricks.
fn brick_row_tasks(g: &BrickGeometry) -> u64 {
    let c = g.counts();
    c[1] * c[2]
}

/// The voxels the bricks of row `task` own.
fn brick_row_region(g: &BrickGeometry, task: u64) -> Region {
    let c = g.counts();
    let (by, bz) = (task % c[1], task / c[1]);
    let b = u64::from(g.brick());
    let d = g.dims();
    Region {
        lo: [0, by * b, bz * b],
        hi: [d.x, (by * b + b).min(d.y), (bz * b + b).min(d.z)],
    }
}

/// The block of brick `(bx, task)` given its stored samples.
fn brick_block<'a, T>(g: &BrickGeometry, task: u64, bx: u64, stored: &'a [T]) -> Block<'a, T> {
    let b = u64::from(g.brick());
    let row_region = brick_row_region(g, task);
    let mut region = row_region;
    region.lo[0] = bx * b;
    region.hi[0] = (bx * b + b).min(g.dims().x);
    let e = g.stored_edge() as usize;
    let a = APRON_LO as usize;
    Block {
        region,
        // The owned voxels start after the low apron on each axis.
        data: &stored[a * (1 + e + e * e)..],
        origin: region.lo,
        row: e,
        plane: e * e,
    }
}

/// The linear index of brick `bx` in brick row `task`.
fn brick_id(g: &BrickGeometry, task: u64, bx: u64) -> u64 {
    bx + g.counts()[0] * task
}

/// An uncompressed bricked grid: one task per row of bricks. Bricks mapped
/// from a file are read from it a run of neighbouring bricks (stored back
/// to back) at a time (see [`volcore::Data::read_at`]); bricks in memory
/// lend their stored samples in place.
pub(crate) struct BrickedWalk<'a, T: Sample> {
    grid: &'a BrickedGrid<T>,
    read_bytes: usize,
    buffers: Buffers<T>,
}

impl<'a, T: Sample> BrickedWalk<'a, T> {
    /// The walk over `grid`.
    pub fn new(grid: &'a BrickedGrid<T>) -> Self {
        Self::reading(grid, READ_BYTES)
    }

    /// The walk over `grid`, reading runs of bricks of about `read_bytes`
    /// (at least one brick) from a file.
    fn reading(grid: &'a BrickedGrid<T>, read_bytes: usize) -> Self {
        BrickedWalk {
            grid,
            read_bytes,
            buffers: Buffers::new(),
        }
    }
}

impl<T: Sample> Walk<T> for BrickedWalk<'_, T> {
    fn dims(&self) -> Dims {
        self.grid.dims()
    }

    fn tasks(&self) -> u64 {
        brick_row_tasks(self.grid.geometry())
    }

    fn task_region(&self, task: u64) -> Region {
        brick_row_region(self.grid.geometry(), task)
    }

    fn blocks(&self, task: u64, f: &mut dyn FnMut(Block<'_, T>)) -> Result<(), IndexError> {
        let g = self.grid.geometry();
        let data = self.grid.data();
        let bricks = g.counts()[0];
        if !data.reads_file() {
            for bx in 0..bricks {
                let stored = self.grid.brick(brick_id(g, task, bx));
                f(brick_block(g, task, bx, stored));
            }
            return Ok(());
        }
        let (stride, stored) = (self.grid.brick_stride(), g.stored_len());
        let run = (self.read_bytes / (stride * size_of::<T>()).max(1)).clamp(1, bricks as usize);
        self.buffers.with(run * stride, |buf| {
            for bx0 in (0..bricks).step_by(run) {
                let n = run.min((bricks - bx0) as usize);
                let first = brick_id(g, task, bx0) as usize * stride;
                let len = (n - 1) * stride + stored;
                data.read_at(first, &mut buf[..len]).map_err(read_failed)?;
                for (k, bx) in (bx0..bx0 + n as u64).enumerate() {
                    f(brick_block(
                        g,
                        task,
                        bx,
                        &buf[k * stride..k * stride + stored],
                    ));
                }
            }
            Ok(())
        })
    }
}

/// A zstd-bricked grid: one task per row of bricks, each brick decoded
/// once (not through the grid's cache, which this single pass would only
/// churn).
pub(crate) struct CompressedWalk<'a, T: Sample> {
    /// The grid.
    pub grid: &'a CompressedGrid<T>,
}

impl<T: Sample> Walk<T> for CompressedWalk<'_, T> {
    fn dims(&self) -> Dims {
        self.grid.dims()
    }

    fn tasks(&self) -> u64 {
        brick_row_tasks(self.grid.geometry())
    }

    fn task_region(&self, task: u64) -> Region {
        brick_row_region(self.grid.geometry(), task)
    }

    fn blocks(&self, task: u64, f: &mut dyn FnMut(Block<'_, T>)) -> Result<(), IndexError> {
        let g = self.grid.geometry();
        for bx in 0..g.counts()[0] {
            let stored = self
                .grid
                .decode(brick_id(g, task, bx))
                .map_err(IndexError::Source)?;
            f(brick_block(g, task, bx, &stored));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{file_data, random_samples};
    use volcore::region::{pack_bricks, Rows};
    use volcore::Data;

    /// Every voxel once, with its value, inside its task's region.
    fn check_walk(w: &dyn Walk<u16>, want: &[u16], what: &str) {
        let d = w.dims();
        let mut seen = vec![0u32; want.len()];
        for t in 0..w.tasks() {
            let tr = w.task_region(t);
            w.blocks(t, &mut |b| {
                for a in 0..3 {
                    assert!(tr.lo[a] <= b.region.lo[a] && b.region.hi[a] <= tr.hi[a]);
                }
                b.for_each_row(|y, z, row| {
                    for (x, &v) in b.region.axis(0).zip(row) {
                        let i = d.index(x, y, z) as usize;
                        assert_eq!(v, want[i], "{what}: voxel {x},{y},{z}");
                        seen[i] += 1;
                    }
                });
            })
            .unwrap();
        }
        assert!(seen.iter().all(|&n| n == 1), "{what}: not every voxel once");
    }

    #[test]
    fn every_walk_visits_every_voxel_once() {
        for (x, y, z) in [(1, 1, 1), (37, 23, 29), (5, 1, 9), (300, 2, 3)] {
            let dims = Dims::new(x, y, z).unwrap();
            let s: Vec<u16> = random_samples(dims, 4, 0);
            let sliced = SlicedGrid::new(dims, Data::Owned(s.clone())).unwrap();
            for edge in [2, 3, 8] {
                check_walk(
                    &BandWalk::new(SlicedBands::new(&sliced), edge),
                    &s,
                    "sliced",
                );
                check_walk(&BandWalk::new(SourceRows(&sliced), edge), &s, "rows");
            }
            let in_file = SlicedGrid::new(dims, file_data(&s, 4)).unwrap();
            for edge in [2, 3, 8] {
                check_walk(&BandWalk::new(SlicedBands::new(&in_file), edge), &s, "file");
                // Blocks of one slice, or one band of a slice.
                let one = BandWalk::bounded(SlicedBands::new(&in_file), edge, 1);
                check_walk(&one, &s, "file, small blocks");
            }
            for brick in [2, 5, 16] {
                let geom = BrickGeometry::new(dims, brick).unwrap();
                let packed = pack_bricks(&Rows(&sliced), &geom);
                let in_file = BrickedGrid::new(geom, geom.stored_len(), file_data(&packed, 6));
                let grid = BrickedGrid::new(geom, geom.stored_len(), Data::Owned(packed)).unwrap();
                check_walk(&BrickedWalk::new(&grid), &s, "bricked");
                // Runs of one brick, two and three (the last run short).
                let in_file = in_file.unwrap();
                let brick_bytes = geom.stored_len() * size_of::<u16>();
                for run in [1, 2, 3] {
                    let walk = BrickedWalk::reading(&in_file, run * brick_bytes + 1);
                    check_walk(&walk, &s, "bricked from a file");
                }
            }
        }
    }
}
