//! Random test volumes and brute-force references shared by the tests.

use volcore::volume::IntoVolumeData;
use volcore::{Dims, Volume};

/// Sample types the tests draw at random.
pub trait RandomSample: IntoVolumeData {
    /// One random sample; `kind` varies the distribution between volumes.
    fn random(rng: &mut fastrand::Rng, kind: u8) -> Self;
}

impl RandomSample for u8 {
    fn random(rng: &mut fastrand::Rng, kind: u8) -> Self {
        match kind % 3 {
            0 => rng.u8(..),
            1 => rng.u8(..4) * 60, // few distinct values, many equal
            _ => {
                if rng.u8(..10) == 0 {
                    rng.u8(..)
                } else {
                    0 // mostly empty
                }
            }
        }
    }
}

impl RandomSample for u16 {
    fn random(rng: &mut fastrand::Rng, kind: u8) -> Self {
        match kind % 2 {
            0 => rng.u16(..),
            _ => 1000 + rng.u16(..4096), // a 12-bit scanner
        }
    }
}

impl RandomSample for i16 {
    fn random(rng: &mut fastrand::Rng, kind: u8) -> Self {
        match kind % 2 {
            0 => rng.i16(..),
            _ => rng.i16(-1024..3072), // Hounsfield-like
        }
    }
}

impl RandomSample for f32 {
    fn random(rng: &mut fastrand::Rng, kind: u8) -> Self {
        match rng.u8(..20) {
            0 | 1 => f32::NAN,
            2 => -0.0,
            3 if kind % 3 == 2 => {
                if rng.bool() {
                    f32::INFINITY
                } else {
                    f32::NEG_INFINITY
                }
            }
            _ => (rng.f32() - 0.3) * 1000.0 * if kind % 3 == 1 { 1e-3 } else { 1.0 },
        }
    }
}

/// Random samples of `T` for `dims`, drawn as `kind` says.
pub fn random_samples<T: RandomSample>(dims: Dims, seed: u64, kind: u8) -> Vec<T> {
    let mut rng = fastrand::Rng::with_seed(seed);
    (0..dims.count())
        .map(|_| T::random(&mut rng, kind))
        .collect()
}

/// Odd test shapes: not multiples of the cell edge, single voxels, planes.
pub fn odd_dims() -> Vec<Dims> {
    [
        (1, 1, 1),
        (1, 9, 9),
        (9, 1, 9),
        (13, 7, 1),
        (8, 8, 8),
        (9, 9, 9),
        (17, 5, 12),
        (21, 13, 9),
        (33, 18, 16),
    ]
    .into_iter()
    .map(|(x, y, z)| Dims::new(x, y, z).unwrap())
    .collect()
}

/// A sliced in-memory volume of `samples`.
pub fn volume<T: RandomSample>(dims: Dims, samples: Vec<T>) -> Volume {
    Volume::from_samples(dims, samples).unwrap()
}

/// The NaN-ignoring range of the voxels `lo ..= hi` (per axis) of `f`
/// (sliced f32 values).
pub fn brute_range(f: &[f32], dims: Dims, lo: [u64; 3], hi: [u64; 3]) -> (f32, f32) {
    let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let v = f[dims.index(x, y, z) as usize];
                if !v.is_nan() {
                    a = a.min(v);
                    b = b.max(v);
                }
            }
        }
    }
    (a, b)
}

/// The voxel footprint of cell `c` of cells `edge` voxels wide:
/// `c·edge ..= c·edge + edge`, clamped to the volume.
pub fn footprint(c: [u64; 3], edge: u64, dims: Dims) -> ([u64; 3], [u64; 3]) {
    let d = dims.as_array();
    let lo = std::array::from_fn(|a| c[a] * edge);
    let hi = std::array::from_fn(|a| (c[a] * edge + edge).min(d[a] - 1));
    (lo, hi)
}

/// `samples` in a temporary file after `header` bytes, memory-mapped, with
/// the file kept for positioned reads (as volume files are opened).
pub fn file_data<T: volcore::Sample>(samples: &[T], header: usize) -> volcore::Data<T> {
    use std::io::Write;
    use std::sync::Arc;
    let mut bytes = vec![0x5A; header];
    bytes.extend_from_slice(bytemuck::cast_slice(samples));
    // One sample's worth of bytes after the data: reads must stop short.
    bytes.extend_from_slice(bytemuck::cast_slice(&samples[..1.min(samples.len())]));
    let mut f = tempfile::tempfile().unwrap();
    f.write_all(&bytes).unwrap();
    let map = Arc::new(unsafe { memmap2::Mmap::map(&f) }.unwrap());
    volcore::Data::mapped_file(map, Arc::new(f), header, samples.len()).unwrap()
}
