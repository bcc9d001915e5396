//! Producing samples region by region: the input side of every writer.
//!
//! Writers pull rows from a [`RegionSource`] in whatever order their layout
//! needs, from many threads at once. Procedural scenes, open volumes and
//! foreign files all implement it, so one set of writers serves vol-gen and
//! vol-convert alike.

use crate::brick::BrickGeometry;
use crate::dims::Dims;
use crate::grid::VoxelSource;
use crate::sample::Sample;

/// Anything that can fill rows of samples, in any order, from any thread.
pub trait RegionSource: Sync {
    /// The sample type produced.
    type Sample: Sample;
    /// The volume's dimensions.
    fn dims(&self) -> Dims;
    /// Fill voxels `x0 .. x0 + out.len()` of row `(y, z)`, all inside.
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [Self::Sample]);
}

/// Adapts any [`VoxelSource`] as a [`RegionSource`].
pub struct Rows<'a, V>(pub &'a V);

impl<V: VoxelSource> RegionSource for Rows<'_, V> {
    type Sample = V::Sample;
    fn dims(&self) -> Dims {
        self.0.dims()
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [V::Sample]) {
        self.0.read_row(x0, y, z, out)
    }
}

/// Fill the stored samples of one brick (apron included, clamp-to-edge
/// padding) from `src`. `out` has `geom.stored_len()` samples.
pub fn fill_brick<R: RegionSource>(
    src: &R,
    geom: &BrickGeometry,
    brick: [u64; 3],
    out: &mut [R::Sample],
) {
    let e = geom.stored_edge() as usize;
    let coords = geom.stored_coords(brick);
    let xs = &coords[0];
    // Stored x coordinates are the owned range plus apron, clamped: the
    // in-volume run lies between the last repeat of the first coordinate and
    // the first repeat of the last one.
    let run_start = xs.iter().rposition(|&x| x == xs[0]).unwrap_or(0);
    let run_end = if xs[0] == xs[e - 1] {
        run_start
    } else {
        xs.iter().position(|&x| x == xs[e - 1]).unwrap_or(e - 1)
    };
    for (lk, &z) in coords[2].iter().enumerate() {
        for (lj, &y) in coords[1].iter().enumerate() {
            let row = &mut out[e * (lj + e * lk)..][..e];
            src.fill_row(xs[run_start], y, z, &mut row[run_start..=run_end]);
            let lo = row[run_start];
            row[..run_start].fill(lo);
            let hi = row[run_end];
            row[run_end + 1..].fill(hi);
        }
    }
}

/// All bricks of `src` packed back to back (stride = stored length), built
/// in memory in parallel. Meant for tests and small volumes; writers stream.
pub fn pack_bricks<R: RegionSource>(src: &R, geom: &BrickGeometry) -> Vec<R::Sample> {
    use rayon::prelude::*;
    let n = geom.stored_len();
    let mut out = vec![R::Sample::default(); n * geom.brick_count() as usize];
    out.par_chunks_mut(n).enumerate().for_each(|(i, chunk)| {
        fill_brick(src, geom, geom.brick_coords(i as u64), chunk);
    });
    out
}

/// All samples of `src` in sliced order, built in memory in parallel.
pub fn pack_sliced<R: RegionSource>(src: &R) -> Vec<R::Sample> {
    use rayon::prelude::*;
    let d = src.dims();
    let mut out = vec![R::Sample::default(); d.count() as usize];
    out.par_chunks_mut(d.x as usize)
        .enumerate()
        .for_each(|(row, chunk)| {
            let row = row as u64;
            src.fill_row(0, row % d.y, row / d.y, chunk);
        });
    out
}

/// A z-range of whole slices held in memory, filled in parallel from
/// another source with full-length rows. Writers of bricked layouts read
/// each slice many times in short brick rows (and the aprons twice);
/// reading them from a slab instead of recomputing a procedural source is
/// much cheaper. Only rows inside the slab may be read.
pub struct Slab<T: Sample> {
    dims: Dims,
    z0: u64,
    z1: u64,
    data: Vec<T>,
}

impl<T: Sample> Slab<T> {
    /// Slices `zs` of `src`, reusing `buffer`'s allocation.
    pub fn fill<R: RegionSource<Sample = T>>(
        src: &R,
        zs: std::ops::Range<u64>,
        buffer: Vec<T>,
    ) -> Slab<T> {
        use rayon::prelude::*;
        let d = src.dims();
        let len = (d.slice_len() * (zs.end - zs.start)) as usize;
        let mut data = buffer;
        data.resize(len, T::default());
        data.truncate(len);
        data.par_chunks_mut(d.x as usize)
            .enumerate()
            .for_each(|(r, row)| {
                let r = r as u64;
                src.fill_row(0, r % d.y, zs.start + r / d.y, row);
            });
        Slab {
            dims: d,
            z0: zs.start,
            z1: zs.end,
            data,
        }
    }

    /// Give the storage back for the next slab.
    pub fn into_buffer(self) -> Vec<T> {
        self.data
    }
}

impl<T: Sample> RegionSource for Slab<T> {
    type Sample = T;
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        assert!(
            (self.z0..self.z1).contains(&z),
            "slab holds slices {}..{}, asked for {z}",
            self.z0,
            self.z1
        );
        let start = (x0 + self.dims.x * (y + self.dims.y * (z - self.z0))) as usize;
        out.copy_from_slice(&self.data[start..start + out.len()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{SceneSource, ShapesScene};

    #[test]
    fn slab_rows_equal_the_source_rows() {
        let d = Dims::new(23, 9, 30).unwrap();
        let scene = ShapesScene::new(d, 4, 6, 7, 100.0);
        let src = SceneSource::<u16>::new(&scene);
        let slab = Slab::fill(&src, 11..19, Vec::new());
        let (mut a, mut b) = (vec![0u16; 17], vec![0u16; 17]);
        for z in 11..19 {
            for y in 0..9 {
                slab.fill_row(5, y, z, &mut a);
                src.fill_row(5, y, z, &mut b);
                assert_eq!(a, b);
            }
        }
    }
}
