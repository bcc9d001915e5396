//! Building an index: one parallel pass over z-slabs of cells.
//!
//! Each rayon task owns one z-slab of level-0 cells (cell layer `cz`) and
//! reads its `N + 1` voxel slices (the last one is the apron, shared with
//! the next slab) row by row through [`VoxelSource::read_row`], y outer and
//! z inner so compressed sources touch few bricks at a time. Rows are folded
//! element-wise into a running min/max in the native sample type; when a
//! cell row is complete each cell's range is a fold over its `N + 1`
//! columns, converted to `f32` once per cell. Memory per task is two
//! accumulators and one row buffer (`5 · X` samples), whatever the volume.
//!
//! Integer samples are also counted per value in the same pass (each voxel
//! once: apron slices are not counted) and rebinned into the histogram
//! afterwards. Every cell is computed by one task in a fixed order and
//! counts are summed exactly, so the result depends only on the samples.

use crate::error::IndexError;
use crate::histogram::{self, Histogram, DEFAULT_BINS, MAX_BINS};
use crate::index::MajorantIndex;
use crate::level::{cell_count, level_shapes, try_filled, Level};
use crate::scan::{ExactCounts, RowRange, ScanSample};
use rayon::prelude::*;
use std::any::{Any, TypeId};
use volcore::{Dims, Sample, SampleType, Volume, VolumeVisitor, VoxelSource};

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

/// Build the index of `src`, tagging it with the caller's `fingerprint` of
/// the volume. Runs on the current rayon pool.
pub fn build_source<S: VoxelSource>(
    src: &S,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MajorantIndex, IndexError> {
    opts.validate()?;
    let index = match <S::Sample as Sample>::TYPE {
        SampleType::U8 => build_typed::<S, u8>(src, opts, fingerprint),
        SampleType::U16 => build_typed::<S, u16>(src, opts, fingerprint),
        SampleType::I16 => build_typed::<S, i16>(src, opts, fingerprint),
        SampleType::F32 => build_typed::<S, f32>(src, opts, fingerprint),
    }?;
    match src.error() {
        Some(msg) => Err(IndexError::Source(msg)),
        None => Ok(index),
    }
}

/// Build the index of an open volume (any layout and sample type).
pub fn build_volume(
    vol: &Volume,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MajorantIndex, IndexError> {
    struct Build<'a>(&'a BuildOptions, u64);
    impl VolumeVisitor for Build<'_> {
        type Output = Result<MajorantIndex, IndexError>;
        fn visit<S: VoxelSource>(self, src: &S) -> Self::Output {
            build_source(src, self.0, self.1)
        }
    }
    vol.visit(Build(opts, fingerprint))
}

/// Reads whole rows of a source as `T`, the concrete type of its samples.
struct Rows<'a, S: VoxelSource> {
    src: &'a S,
    dims: Dims,
}

impl<S: VoxelSource> Rows<'_, S> {
    /// Fill `buf` (`dims.x` samples) with row `(y, z)`. `T` is
    /// `S::Sample`, checked once in [`build_typed`], so the downcast is
    /// resolved at compile time and never fails.
    #[inline]
    #[allow(clippy::ptr_arg)] // `Any` downcasts the sized `Vec`, not a slice
    fn read<T: ScanSample>(&self, y: u64, z: u64, buf: &mut Vec<T>) {
        if let Some(b) = (buf as &mut dyn Any).downcast_mut::<Vec<S::Sample>>() {
            self.src.read_row(0, y, z, b);
        }
    }
}

/// The whole build for samples of type `T == S::Sample`.
fn build_typed<S: VoxelSource, T: ScanSample>(
    src: &S,
    opts: &BuildOptions,
    fingerprint: u64,
) -> Result<MajorantIndex, IndexError> {
    if TypeId::of::<T>() != TypeId::of::<S::Sample>() {
        return Err(IndexError::Source(format!(
            "sample type {} does not match its tag",
            T::TYPE
        )));
    }
    let dims = src.dims();
    let rows = Rows { src, dims };
    let shapes = level_shapes(dims, opts.cell_edge);
    let cells = shapes[0];
    let total = cell_count(cells)?;
    usize::try_from(dims.x)
        .map_err(|_| IndexError::TooLarge(format!("rows of {} voxels", dims.x)))?;
    let plane = (cells[0] * cells[1]) as usize;
    let mut min = try_filled(total, f32::INFINITY)?;
    let mut max = try_filled(total, f32::NEG_INFINITY)?;
    let edge = u64::from(opts.cell_edge);
    let counts = min
        .par_chunks_mut(plane)
        .zip(max.par_chunks_mut(plane))
        .enumerate()
        .fold(ExactCounts::new::<T>, |mut counts, (cz, (mn, mx))| {
            scan_slab::<S, T>(&rows, edge, cz as u64, mn, mx, &mut counts);
            counts
        })
        .reduce(ExactCounts::new::<T>, ExactCounts::merge);

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
        float_histogram::<S, T>(&rows, edge, range, opts.histogram_bins)
    };
    MajorantIndex::from_parts(dims, T::TYPE, fingerprint, range, hist, levels)
}

/// Fill the level-0 cells of slab `cz` (`mn`, `mx`: one cell plane) and
/// count the slab's own voxels.
fn scan_slab<S: VoxelSource, T: ScanSample>(
    rows: &Rows<'_, S>,
    edge: u64,
    cz: u64,
    mn: &mut [f32],
    mx: &mut [f32],
    counts: &mut ExactCounts,
) {
    let [dx, dy, dz] = rows.dims.as_array();
    let nx = dx.div_ceil(edge);
    let ny = dy.div_ceil(edge);
    let z0 = cz * edge;
    let z_owned = (z0 + edge).min(dz);
    let z_last = (z0 + edge).min(dz - 1);
    let mut row = vec![T::default(); dx as usize];
    let mut even = RowRange::<T>::new(dx as usize);
    let mut odd = RowRange::<T>::new(dx as usize);
    // Cell row `cy` accumulates in `even` or `odd` by parity; row y = cy·N
    // (cy > 0) is also the apron of cell row cy − 1, which it completes.
    let mut finish = |acc: &RowRange<T>, cy: u64| {
        let base = (cy * nx) as usize;
        for cx in 0..nx {
            let a = (cx * edge) as usize;
            let b = (cx * edge + edge).min(dx - 1) as usize;
            let (lo, hi) = acc.span(a, b);
            mn[base + cx as usize] = lo;
            mx[base + cx as usize] = hi;
        }
    };
    for y in 0..dy {
        let cy = y / edge;
        let first = y % edge == 0;
        let (cur, prev) = if cy & 1 == 0 {
            (&mut even, &mut odd)
        } else {
            (&mut odd, &mut even)
        };
        if first {
            cur.reset();
        }
        for z in z0..=z_last {
            rows.read(y, z, &mut row);
            cur.add(&row);
            if first && cy > 0 {
                prev.add(&row);
            }
            if z < z_owned {
                counts.add(&row);
            }
        }
        if first && cy > 0 {
            finish(prev, cy - 1);
        }
    }
    let last = ny - 1;
    finish(if last & 1 == 0 { &even } else { &odd }, last);
}

/// The `f32` histogram: a second pass binning every sample over the range
/// of the finite samples (found with a third pass only when the global
/// range itself is infinite).
fn float_histogram<S: VoxelSource, T: ScanSample>(
    rows: &Rows<'_, S>,
    edge: u64,
    range: (f32, f32),
    bins: u32,
) -> Histogram {
    let (lo, hi) = if range.0.is_finite() && range.1.is_finite() {
        range
    } else {
        finite_range::<S, T>(rows, edge)
    };
    // `+ 0.0` maps a −0.0 bound to +0.0, whichever zero the folds kept.
    let (lo, hi) = if lo <= hi {
        (f64::from(lo) + 0.0, f64::from(hi) + 0.0)
    } else {
        (0.0, 0.0)
    };
    let n = bins as usize;
    let slabs = rows.dims.z.div_ceil(edge);
    let (counts, nans) = (0..slabs)
        .into_par_iter()
        .fold(
            || (vec![0u64; n], 0u64),
            |(mut counts, mut nans), s| {
                for_each_owned_row::<S, T>(rows, edge, s, |row| {
                    for &v in row {
                        let f = f64::from(v.to_f32());
                        if f.is_nan() {
                            nans += 1;
                        } else {
                            counts[histogram::bin_of(f, lo, hi, n)] += 1;
                        }
                    }
                });
                (counts, nans)
            },
        )
        .reduce(
            || (vec![0u64; n], 0),
            |(mut a, na), (b, nb)| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                (a, na + nb)
            },
        );
    let mut h = Histogram::from_parts(lo, hi, counts, 0);
    h.set_nan_count(nans);
    h
}

/// The range of the finite samples (empty if there are none).
fn finite_range<S: VoxelSource, T: ScanSample>(rows: &Rows<'_, S>, edge: u64) -> (f32, f32) {
    let slabs = rows.dims.z.div_ceil(edge);
    (0..slabs)
        .into_par_iter()
        .map(|s| {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for_each_owned_row::<S, T>(rows, edge, s, |row| {
                for v in row.iter().map(|v| v.to_f32()).filter(|v| v.is_finite()) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            });
            (lo, hi)
        })
        .reduce(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        )
}

/// Call `f` with every row of the slices slab `s` owns.
fn for_each_owned_row<S: VoxelSource, T: ScanSample>(
    rows: &Rows<'_, S>,
    edge: u64,
    s: u64,
    mut f: impl FnMut(&[T]),
) {
    let d = rows.dims;
    let mut row = vec![T::default(); d.x as usize];
    for z in s * edge..(s * edge + edge).min(d.z) {
        for y in 0..d.y {
            rows.read(y, z, &mut row);
            f(&row);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{brute_range, footprint, odd_dims, random_samples, volume, RandomSample};
    use volcore::brick::BrickGeometry;
    use volcore::grid::{BrickedGrid, Cursor, SlicedGrid};
    use volcore::region::{pack_bricks, pack_sliced, Rows as RegionRows};
    use volcore::scene::{SceneSource, ShapesScene};
    use volcore::{Data, ValueRange};

    fn to_bytes(ix: &MajorantIndex) -> Vec<u8> {
        let mut out = Vec::new();
        ix.write_to(&mut out).unwrap();
        out
    }

    /// Every level's cells against a brute-force range over the cell's
    /// voxel footprint, and against the union of their children.
    fn check_against_brute_force(ix: &MajorantIndex, f: &[f32], what: &str) {
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
    fn check_histogram(ix: &MajorantIndex, f: &[f32], what: &str) {
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
    fn check_conservative(ix: &MajorantIndex, vol: &Volume, seed: u64, what: &str) {
        struct Check<'a>(&'a MajorantIndex, u64, &'a str);
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
                for edge in [2, 3, 8] {
                    let what = format!("{} {dims} kind {kind} edge {edge}", T::TYPE);
                    let seed = n as u64 * 31 + kind as u64;
                    let vol = volume::<T>(dims, random_samples(dims, seed, kind));
                    let opts = BuildOptions {
                        cell_edge: edge,
                        ..BuildOptions::default()
                    };
                    let ix = MajorantIndex::build_volume(&vol, &opts, 7).unwrap();
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
        let ix = MajorantIndex::build_volume(&vol, &opts, 0).unwrap();
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
        let ix = MajorantIndex::build_volume(&vol, &BuildOptions::default(), 0).unwrap();
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
        let ix =
            MajorantIndex::build_volume(&volume(dims, s), &BuildOptions::default(), 0).unwrap();
        assert_eq!(ix.level(0).cells(), [2, 1, 1]);
        assert_eq!(ix.empty_fraction(0.0), 0.5);
        assert_eq!(ix.empty_fraction(9.0), 1.0);
        assert_eq!(ix.empty_fraction(8.5), 0.5);
        assert_eq!(ix.stats().empty_fraction, 0.5);
        // Voxel x = 8 belongs to cell 1 and is the apron of cell 0.
        let mut s = vec![0u8; 128 * 8];
        s[dims.index(8, 3, 3) as usize] = 1;
        let ix =
            MajorantIndex::build_volume(&volume(dims, s), &BuildOptions::default(), 0).unwrap();
        assert_eq!(ix.empty_fraction(0.0), 0.0);
    }

    /// The same index, bit for bit, from a sliced volume, a bricked copy
    /// and on pools of 1, 2 and 7 threads.
    fn check_layout_and_threads<T: RandomSample>(dims: Dims, kind: u8) {
        let samples: Vec<T> = random_samples(dims, 99, kind);
        let sliced = SlicedGrid::new(dims, Data::Owned(samples)).unwrap();
        let opts = BuildOptions {
            cell_edge: 4,
            ..BuildOptions::default()
        };
        let reference = to_bytes(&MajorantIndex::build(&sliced, &opts, 5).unwrap());
        for brick in [2, 5, 16] {
            let geom = BrickGeometry::new(dims, brick).unwrap();
            let packed = pack_bricks(&RegionRows(&sliced), &geom);
            let bricked = BrickedGrid::new(geom, geom.stored_len(), Data::Owned(packed)).unwrap();
            let got = to_bytes(&MajorantIndex::build(&bricked, &opts, 5).unwrap());
            assert!(got == reference, "{} bricked:{brick} differs", T::TYPE);
        }
        for threads in [1, 2, 7] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got = pool.install(|| to_bytes(&MajorantIndex::build(&sliced, &opts, 5).unwrap()));
            assert!(got == reference, "{} on {threads} threads differs", T::TYPE);
        }
    }

    #[test]
    fn same_bits_for_any_layout_and_thread_count() {
        let dims = Dims::new(37, 23, 29).unwrap();
        check_layout_and_threads::<u8>(dims, 0);
        check_layout_and_threads::<u16>(dims, 1);
        check_layout_and_threads::<i16>(dims, 0);
        check_layout_and_threads::<f32>(dims, 0);
        check_layout_and_threads::<f32>(dims, 2); // with infinities
    }

    #[test]
    fn rejects_bad_options() {
        let vol = volume(Dims::new(4, 4, 4).unwrap(), vec![0u8; 64]);
        for (cell_edge, histogram_bins) in [(1, 256), (2000, 256), (8, 0), (8, 70000)] {
            let opts = BuildOptions {
                cell_edge,
                histogram_bins,
            };
            let err = MajorantIndex::build_volume(&vol, &opts, 0).unwrap_err();
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
        let ix = MajorantIndex::build_volume(&vol, &BuildOptions::default(), 1).unwrap();
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
