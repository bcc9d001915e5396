//! Procedural test volumes, each a pure function of its parameters, seed
//! and voxel coordinates, so any region can be generated on any thread in
//! any order and the bytes never depend on the thread count.

mod analytic;
mod noise;
mod phantom;
mod shapes;
pub mod spec;
mod spheres;
mod waves;

pub use analytic::{BoxScene, RampScene, SolidScene, SphereScene};
pub use noise::{NoiseKind, NoiseScene};
pub use phantom::{PhantomScene, PHANTOM_AIR, PHANTOM_EDGE, PHANTOM_NOISE_SD};
pub use shapes::{Shape, ShapeKind, ShapesScene};
pub use spec::{SceneName, SceneSpec};
pub use spheres::SpheresScene;
pub use waves::{Wave, Waves, WavesScene, AMPLITUDES, NEAR_AXIS_DEG, WAVELENGTHS, WAVE_COUNT};

use crate::dims::Dims;
use crate::region::RegionSource;
use crate::sample::Sample;
use std::marker::PhantomData;
use std::ops::Range;

/// A procedural volume producing `f32` values row by row.
pub trait Scene: Sync {
    /// The volume's dimensions.
    fn dims(&self) -> Dims;
    /// Fill voxels `x0 .. x0 + out.len()` of row `(y, z)`. Returns `false`
    /// when every value written is zero, which lets callers skip converting
    /// empty rows (most rows of sparse scenes).
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool;

    /// Like [`Scene::fill_row`], but writes only the part of `out` that may
    /// hold non-zero values and returns it as offsets into `out`: every
    /// voxel outside the returned range is `+0.0` and is left unwritten
    /// (an empty range: the whole row is `+0.0`). Sparse scenes override
    /// it so that callers convert only that part. The default fills the
    /// whole row and returns it whole unless every value is `+0.0`.
    fn fill_row_span(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> Range<usize> {
        let any = self.fill_row(x0, y, z, out);
        // `+0.0` bit for bit: a `-0.0` is a different `f32` sample.
        if !any && out.iter().all(|v| v.to_bits() == 0) {
            0..0
        } else {
            0..out.len()
        }
    }
}

/// A scene as a [`RegionSource`] of sample type `T`, converting with
/// [`Sample::from_f32`] (round, clamp).
pub struct SceneSource<'a, T> {
    scene: &'a dyn Scene,
    _t: PhantomData<T>,
}

impl<'a, T: Sample> SceneSource<'a, T> {
    /// Wrap `scene`.
    pub fn new(scene: &'a dyn Scene) -> Self {
        SceneSource {
            scene,
            _t: PhantomData,
        }
    }
}

impl<T: Sample> RegionSource for SceneSource<'_, T> {
    type Sample = T;
    fn dims(&self) -> Dims {
        self.scene.dims()
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        const CHUNK: usize = 512;
        thread_local! {
            // One scratch row per thread: zeroing a fresh array on every
            // call costs more than filling the short rows of a brick.
            static SCRATCH: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        SCRATCH.with(|cell| {
            let mut scratch = cell.borrow_mut();
            if scratch.len() < CHUNK {
                scratch.resize(CHUNK, 0.0);
            }
            self.convert_row(x0, y, z, out, &mut scratch[..CHUNK]);
        });
    }
}

impl<T: Sample> SceneSource<'_, T> {
    /// Convert only the span the scene filled; the rest of the row is
    /// the sample of `+0.0`, which [`Sample::from_f32`] would give it.
    fn convert_row(&self, x0: u64, y: u64, z: u64, out: &mut [T], buf: &mut [f32]) {
        const CHUNK: usize = 512;
        let zero = T::from_f32(0.0);
        let mut done = 0;
        while done < out.len() {
            let n = CHUNK.min(out.len() - done);
            let span = self
                .scene
                .fill_row_span(x0 + done as u64, y, z, &mut buf[..n]);
            let end = span.end.min(n);
            let start = span.start.min(end);
            let dst = &mut out[done..done + n];
            dst[..start].fill(zero);
            for (o, &v) in dst[start..end].iter_mut().zip(&buf[start..end]) {
                *o = T::from_f32(v);
            }
            dst[end..].fill(zero);
            done += n;
        }
    }
}

/// A 64-bit mix of a seed and a voxel index (SplitMix64 finaliser): the
/// per-voxel random source of every scene.
#[inline(always)]
pub fn hash64(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Intersect the half-open interval `[a, b)` with the row `[x0, x0 + len)`,
/// as offsets into the row.
#[inline]
pub(crate) fn clip(a: i64, b: i64, x0: u64, len: usize) -> Option<(usize, usize)> {
    let lo = a.max(x0 as i64);
    let hi = b.min(x0 as i64 + len as i64);
    (lo < hi).then(|| ((lo - x0 as i64) as usize, (hi - x0 as i64) as usize))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::region::pack_sliced;

    /// Every scene gives the same row whether asked for whole or in pieces.
    #[test]
    fn rows_do_not_depend_on_how_they_are_split() {
        let d = Dims::new(37, 11, 9).unwrap();
        let scenes: Vec<Box<dyn Scene>> = vec![
            Box::new(ShapesScene::new(d, 7, 12, 8, 100.0)),
            Box::new(SpheresScene::new(d, 3, 5, 8, 200.0)),
            Box::new(NoiseScene::new(d, 4, NoiseKind::Gradient, 16.0, 3, 255.0)),
            Box::new(NoiseScene::new(d, 4, NoiseKind::Value, 7.0, 2, 255.0)),
            Box::new(SolidScene::new(d, 50.0)),
            Box::new(BoxScene::new(d, 2, 9.0)),
            Box::new(RampScene::new(d, 1, 100.0)),
            Box::new(SphereScene::new(d, 5.0, 100.0)),
            Box::new(PhantomScene::new(d, 5)),
            Box::new(WavesScene::new(d, 3, 255.0)),
        ];
        for s in &scenes {
            let whole = pack_sliced(&SceneSource::<f32>::new(s.as_ref()));
            for z in 0..d.z {
                for y in 0..d.y {
                    let mut a = vec![0f32; 13];
                    let mut b = vec![0f32; 24];
                    let any_a = s.fill_row(0, y, z, &mut a);
                    let any_b = s.fill_row(13, y, z, &mut b);
                    assert!(any_a || a.iter().all(|&v| v == 0.0));
                    assert!(any_b || b.iter().all(|&v| v == 0.0));
                    a.extend(b);
                    let i = d.index(0, y, z) as usize;
                    assert_eq!(&whole[i..i + 37], &a[..]);
                }
            }
            assert!(whole.iter().all(|v| v.is_finite()));
        }
    }

    /// Every scene's span holds what its full row holds, and the full row
    /// is `+0.0`, bit for bit, outside the span.
    #[test]
    fn spans_agree_with_full_rows() {
        let d = Dims::new(37, 11, 9).unwrap();
        let scenes: Vec<Box<dyn Scene>> = vec![
            Box::new(ShapesScene::new(d, 7, 12, 8, 100.0)),
            Box::new(SpheresScene::new(d, 3, 5, 8, 200.0)),
            Box::new(NoiseScene::new(d, 4, NoiseKind::Value, 7.0, 2, 255.0)),
            Box::new(SolidScene::new(d, 50.0)),
            Box::new(BoxScene::new(d, 2, 9.0)),
            Box::new(PhantomScene::new(d, 5)),
        ];
        let mut partial = 0;
        for s in &scenes {
            for z in 0..d.z {
                for y in 0..d.y {
                    for (x0, len) in [(0, 37), (5, 20)] {
                        let mut full = vec![1f32; len];
                        s.fill_row(x0, y, z, &mut full);
                        let mut part = vec![f32::NAN; len];
                        let span = s.fill_row_span(x0, y, z, &mut part);
                        partial += (span.len() < len) as usize;
                        for (i, (f, p)) in full.iter().zip(&part).enumerate() {
                            if span.contains(&i) {
                                assert_eq!(f.to_bits(), p.to_bits());
                            } else {
                                assert_eq!(f.to_bits(), 0);
                            }
                        }
                    }
                }
            }
        }
        assert!(partial > 0);
    }

    /// A row of `-0.0` reported as all zero.
    struct NegativeZero(Dims);

    impl Scene for NegativeZero {
        fn dims(&self) -> Dims {
            self.0
        }
        fn fill_row(&self, _: u64, _: u64, _: u64, out: &mut [f32]) -> bool {
            out.fill(-0.0);
            false
        }
    }

    /// `-0.0` is not `+0.0` to an `f32` output: the default span keeps it.
    #[test]
    fn negative_zero_is_kept() {
        let s = NegativeZero(Dims::new(5, 2, 2).unwrap());
        let mut row = vec![0f32; 5];
        assert_eq!(s.fill_row_span(0, 0, 0, &mut row), 0..5);
        let whole = pack_sliced(&SceneSource::<f32>::new(&s));
        assert!(whole.iter().all(|v| v.to_bits() == (-0f32).to_bits()));
        assert!(pack_sliced(&SceneSource::<u8>::new(&s))
            .iter()
            .all(|&v| v == 0));
    }
}
