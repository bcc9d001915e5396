//! The thesis's `shapes` scene: random cuboids and ellipsoids on an empty
//! background.
//!
//! N shapes, each a cuboid or an ellipsoid with equal odds; each axis extent
//! drawn uniformly from `[S − S/3, S + S/3]` (at most the volume's extent),
//! placed so the shape lies inside the volume. Voxels inside a shape take a
//! value drawn uniformly from the integers `value − 10 ..= value + 10`
//! (hashed from the seed and the voxel index); where shapes overlap, the
//! first one drawn wins; the background is 0.

use super::{clip, hash64, Scene};
use crate::dims::Dims;
use std::ops::Range;

/// Cuboid or ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeKind {
    /// Axis-aligned box filling its extent.
    Cuboid,
    /// Axis-aligned ellipsoid inscribed in its extent.
    Ellipsoid,
}

/// One placed shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shape {
    /// Cuboid or ellipsoid.
    pub kind: ShapeKind,
    /// Lowest voxel of its bounding box.
    pub lo: [u64; 3],
    /// Bounding box extent in voxels.
    pub ext: [u64; 3],
}

impl Shape {
    /// The covered x range `[a, b)` on row `(y, z)`, if any.
    #[inline]
    fn row_span(&self, y: u64, z: u64) -> Option<(i64, i64)> {
        let inside = |c: u64, a: usize| c >= self.lo[a] && c < self.lo[a] + self.ext[a];
        if !inside(y, 1) || !inside(z, 2) {
            return None;
        }
        match self.kind {
            ShapeKind::Cuboid => Some((self.lo[0] as i64, (self.lo[0] + self.ext[0]) as i64)),
            ShapeKind::Ellipsoid => {
                let centre = |a: usize| self.lo[a] as f64 + (self.ext[a] as f64 - 1.0) / 2.0;
                let semi = |a: usize| self.ext[a] as f64 / 2.0;
                let dy = (y as f64 - centre(1)) / semi(1);
                let dz = (z as f64 - centre(2)) / semi(2);
                let q = 1.0 - dy * dy - dz * dz;
                if q < 0.0 {
                    return None;
                }
                let half = semi(0) * q.sqrt();
                let a = (centre(0) - half).ceil() as i64;
                let b = (centre(0) + half).floor() as i64 + 1;
                (a < b).then_some((a, b))
            }
        }
    }
}

/// Slices of z per bucket in the shape lookup.
const Z_BUCKET: u64 = 16;

/// Random shapes on an empty background (see the module docs).
pub struct ShapesScene {
    dims: Dims,
    seed: u64,
    value: f32,
    shapes: Vec<Shape>,
    /// For each bucket of `Z_BUCKET` slices, the shapes reaching into it,
    /// in reverse draw order (the painting order).
    by_z: Vec<Vec<u32>>,
}

impl ShapesScene {
    /// `count` shapes of nominal size `size` and value `value`, placed by
    /// `seed`.
    pub fn new(dims: Dims, seed: u64, count: usize, size: u64, value: f32) -> Self {
        let mut rng = fastrand::Rng::with_seed(seed);
        let d = dims.as_array();
        let spread = size / 3;
        let shapes = (0..count)
            .map(|_| {
                let kind = if rng.bool() {
                    ShapeKind::Cuboid
                } else {
                    ShapeKind::Ellipsoid
                };
                let ext: [u64; 3] = std::array::from_fn(|a| {
                    let e = rng.u64(size.saturating_sub(spread)..=size + spread);
                    e.clamp(1, d[a])
                });
                let lo = std::array::from_fn(|a| rng.u64(0..=d[a] - ext[a]));
                Shape { kind, lo, ext }
            })
            .collect();
        let mut scene = ShapesScene {
            dims,
            seed,
            value,
            shapes,
            by_z: Vec::new(),
        };
        scene.index_shapes();
        scene
    }

    fn index_shapes(&mut self) {
        let buckets = self.dims.z.div_ceil(Z_BUCKET) as usize;
        self.by_z = vec![Vec::new(); buckets];
        for (i, s) in self.shapes.iter().enumerate().rev() {
            let first = s.lo[2] / Z_BUCKET;
            let last = (s.lo[2] + s.ext[2] - 1) / Z_BUCKET;
            for b in first..=last {
                self.by_z[b as usize].push(i as u32);
            }
        }
    }

    /// The placed shapes, in draw order.
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }
}

impl ShapesScene {
    /// The covered spans of row `(y, z)` within `[x0, x0 + len)`, as
    /// offsets, in painting order (only the shapes of the row's z bucket
    /// are tested).
    fn spans(
        &self,
        x0: u64,
        y: u64,
        z: u64,
        len: usize,
    ) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.by_z[(z / Z_BUCKET) as usize]
            .iter()
            .map(|&i| &self.shapes[i as usize])
            .filter_map(move |s| {
                let (a, b) = s.row_span(y, z)?;
                clip(a, b, x0, len)
            })
    }
}

impl Scene for ShapesScene {
    fn dims(&self) -> Dims {
        self.dims
    }

    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> bool {
        let span = self.fill_row_span(x0, y, z, out);
        out[..span.start].fill(0.0);
        out[span.end..].fill(0.0);
        !span.is_empty()
    }

    /// Only the hull of the shapes crossing the row is written: most of a
    /// row (and most rows) is background.
    fn fill_row_span(&self, x0: u64, y: u64, z: u64, out: &mut [f32]) -> Range<usize> {
        let len = out.len();
        let (lo, hi) = self
            .spans(x0, y, z, len)
            .fold((len, 0), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
        if lo >= hi {
            return 0..0;
        }
        out[lo..hi].fill(0.0);
        // A voxel's value depends on its index alone, so overlapping
        // shapes write the same value and the painting order does not
        // matter.
        let row = self.dims.index(x0, y, z);
        for (a, b) in self.spans(x0, y, z, len) {
            for (i, o) in out[a..b].iter_mut().enumerate() {
                let h = hash64(self.seed, row + (a + i) as u64);
                *o = self.value + (h % 21) as f32 - 10.0;
            }
        }
        lo..hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_fit_and_values_stay_in_band() {
        let d = Dims::new(64, 50, 40).unwrap();
        let s = ShapesScene::new(d, 2, 20, 30, 100.0);
        for sh in s.shapes() {
            for a in 0..3 {
                assert!(sh.lo[a] + sh.ext[a] <= d.as_array()[a]);
                assert!(sh.ext[a] >= 20 && sh.ext[a] <= 40 || sh.ext[a] == d.as_array()[a]);
            }
        }
        let mut row = vec![0f32; 64];
        let mut filled = 0;
        for z in 0..40 {
            for y in 0..50 {
                s.fill_row(0, y, z, &mut row);
                for &v in &row {
                    assert!(v == 0.0 || (90.0..=110.0).contains(&v));
                    filled += (v != 0.0) as usize;
                }
            }
        }
        assert!(filled > 1000);
    }

    /// Rows painted span by span match every shape painted on a zeroed
    /// row (no bucket lookup, no hull), in pieces that cut shapes, and
    /// nothing outside the returned span is written.
    #[test]
    fn spans_match_painting_every_shape() {
        let d = Dims::new(90, 40, 70).unwrap();
        let s = ShapesScene::new(d, 5, 25, 24, 100.0);
        let mut rows_with_gaps = 0;
        for z in 0..d.z {
            for y in 0..d.y {
                let mut want = vec![0f32; 90];
                for sh in s.shapes().iter().rev() {
                    if let Some((a, b)) = sh.row_span(y, z) {
                        for (x, w) in want
                            .iter_mut()
                            .enumerate()
                            .take(b as usize)
                            .skip(a as usize)
                        {
                            let h = hash64(5, d.index(x as u64, y, z));
                            *w = 100.0 + (h % 21) as f32 - 10.0;
                        }
                    }
                }
                let covered = want.iter().filter(|&&v| v != 0.0).count();
                let first = want.iter().position(|&v| v != 0.0);
                let last = want.iter().rposition(|&v| v != 0.0);
                if let (Some(f), Some(l)) = (first, last) {
                    rows_with_gaps += (covered < l + 1 - f) as usize;
                }
                for (x0, len) in [(0, 90), (0, 31), (31, 40), (71, 19)] {
                    let mut got = vec![f32::NAN; len];
                    let span = s.fill_row_span(x0 as u64, y, z, &mut got);
                    assert!(span.end <= len);
                    for (i, g) in got.iter_mut().enumerate() {
                        if span.contains(&i) {
                            assert!(!g.is_nan(), "({y}, {z}) offset {i} not written");
                        } else {
                            assert!(g.is_nan(), "({y}, {z}) offset {i} outside {span:?} written");
                            *g = 0.0;
                        }
                    }
                    assert_eq!(got, want[x0..x0 + len], "row ({y}, {z}) from {x0}");
                }
            }
        }
        // The scene has rows where two shapes leave a gap between them.
        assert!(rows_with_gaps > 0);
    }

    #[test]
    fn first_shape_wins() {
        let d = Dims::new(16, 16, 16).unwrap();
        let mut s = ShapesScene::new(d, 0, 0, 4, 100.0);
        s.shapes = vec![
            Shape {
                kind: ShapeKind::Cuboid,
                lo: [0, 0, 0],
                ext: [4, 4, 4],
            },
            Shape {
                kind: ShapeKind::Cuboid,
                lo: [2, 0, 0],
                ext: [4, 4, 4],
            },
        ];
        s.value = 50.0;
        s.index_shapes();
        let mut row = vec![0f32; 8];
        s.fill_row(0, 1, 1, &mut row);
        assert!(row[..6].iter().all(|&v| v >= 40.0));
        assert_eq!(row[6], 0.0);
    }
}
