//! Chessboard distances between level-0 macrocells, per octant: for a
//! ray moving with given signs along the three axes, how many cells
//! ahead of its cell (in the largest of the three axis offsets, counting
//! only the cells the ray can still reach) the nearest cell a skipping
//! rule keeps lies. A ray moving monotonically never leaves the octant
//! of cells ahead of it, so at distance `d > 0` it may jump to the exit
//! of the `d × d × d` block of cells starting at its own, all of which
//! the rule skips, in one step instead of one cell (or one aligned
//! coarser cell) at a time. Busy cells behind the ray do not shorten its
//! jumps, as they would with one distance for all directions.
//!
//! A table is one raster pass from the octant's far corner: a cell's
//! distance is 0 when it is kept, else one more than the least of its
//! seven neighbours ahead, which is exact (a shortest path of chessboard
//! steps toward a cell in the octant can step ahead along every axis it
//! still has to cross). Values saturate at 255, which only shortens
//! jumps. Tables are made when a ray first asks for one, so a frame pays
//! only for the directions its rays (and shadow rays) travel.

use std::sync::OnceLock;

/// Per-octant distance tables over a grid of cells, made on first use
/// from the skipping rule's level-0 flags.
pub struct OctantDistances {
    /// Cells along x, y, z.
    n: [usize; 3],
    /// Per octant (see [`octant`]), the distances.
    tables: [OnceLock<Vec<u8>>; 8],
}

/// The octant of a direction: bit `a` set when it moves toward lower
/// coordinates along axis `a` (not moving counts as moving up).
#[inline(always)]
pub fn octant(d: [f32; 3]) -> usize {
    (d[0] < 0.0) as usize | ((d[1] < 0.0) as usize) << 1 | ((d[2] < 0.0) as usize) << 2
}

impl OctantDistances {
    /// Empty tables for an `n[0] × n[1] × n[2]` grid of cells (x fastest).
    pub fn new(n: [usize; 3]) -> OctantDistances {
        OctantDistances {
            n,
            tables: Default::default(),
        }
    }

    /// The distances for rays in octant `o` (see [`octant`]), made on the
    /// first call from `clear` (per cell, x fastest: non-zero where the
    /// rule skips the cell; the same flags on every call).
    #[inline(always)]
    pub fn table(&self, o: usize, clear: &[u8]) -> &[u8] {
        self.tables[o & 7].get_or_init(|| ahead(self.n, clear, o & 7))
    }
}

/// The saturated chessboard distance of each cell of an `n` grid (x
/// fastest) to the nearest kept cell (`clear` zero) among those ahead of
/// it in octant `o` (itself included): 0 on kept cells, 255 when there is
/// none (or none within 255 cells). `clear` holds at least one flag per
/// cell (any more are ignored).
pub fn ahead(n: [usize; 3], clear: &[u8], o: usize) -> Vec<u8> {
    let [nx, ny, nz] = n;
    let len = nx * ny * nz;
    let mut d = vec![u8::MAX; len];
    if len == 0 {
        return d;
    }
    let clear = &clear[..len];
    // Along each axis the pass starts at the far end of the octant's
    // direction, so that the neighbours ahead are done first.
    let down = [o & 1 != 0, o & 2 != 0, o & 4 != 0];
    let order = |i: usize, len: usize, down: bool| if down { i } else { len - 1 - i };
    let slab = nx * ny;
    // Per x, the least of the three neighbour rows ahead (the slab ahead,
    // rows y and y ahead; this slab, row y ahead), then also of the next
    // cell's along x: all but the cell ahead along x, which the row's
    // pass takes as it goes.
    let mut near = vec![u8::MAX; nx];
    for zi in 0..nz {
        let z = order(zi, nz, down[2]);
        let z_ahead = (zi > 0).then(|| if down[2] { z - 1 } else { z + 1 });
        for yi in 0..ny {
            let y = order(yi, ny, down[1]);
            let y_ahead = (yi > 0).then(|| if down[1] { y - 1 } else { y + 1 });
            near.fill(u8::MAX);
            let rows = [
                z_ahead.map(|za| za * slab + y * nx),
                z_ahead.zip(y_ahead).map(|(za, ya)| za * slab + ya * nx),
                y_ahead.map(|ya| z * slab + ya * nx),
            ];
            for at in rows.into_iter().flatten() {
                near.iter_mut()
                    .zip(&d[at..at + nx])
                    .for_each(|(m, &v)| *m = (*m).min(v));
            }
            // Fold in the next cell's column along x (x + 1 moving up,
            // x − 1 moving down), in place: each cell reads a neighbour
            // not yet overwritten.
            if down[0] {
                for x in (1..nx).rev() {
                    near[x] = near[x].min(near[x - 1]);
                }
            } else {
                for x in 0..nx - 1 {
                    near[x] = near[x].min(near[x + 1]);
                }
            }
            let at = z * slab + y * nx;
            let (row, clear) = (&mut d[at..at + nx], &clear[at..at + nx]);
            // Along the row, from its far end: the one step that depends
            // on the cell just done.
            let mut next = u8::MAX; // the cell ahead along x, done
            let mut cell = |x: usize| {
                let v = if clear[x] == 0 {
                    0
                } else {
                    near[x].min(next).saturating_add(1)
                };
                row[x] = v;
                next = v;
            };
            if down[0] {
                (0..nx).for_each(&mut cell);
            } else {
                (0..nx).rev().for_each(&mut cell);
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance by definition: the least chessboard offset to a kept
    /// cell ahead in the octant, saturated.
    fn brute(n: [usize; 3], keep: &[bool], o: usize) -> Vec<u8> {
        let at = |i: usize| [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
        (0..keep.len())
            .map(|i| {
                let a = at(i);
                (0..keep.len())
                    .filter(|&j| keep[j])
                    .filter_map(|j| {
                        let b = at(j);
                        let ahead = (0..3).all(|k| {
                            if o >> k & 1 != 0 {
                                b[k] <= a[k]
                            } else {
                                b[k] >= a[k]
                            }
                        });
                        ahead.then(|| (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap_or(0))
                    })
                    .min()
                    .map_or(255, |m| m.min(255) as u8)
            })
            .collect()
    }

    /// Random grids of many shapes (flat, thin, cubic; sparse and dense
    /// kept cells, none, all), every octant: each distance is the
    /// brute-force one.
    #[test]
    fn distances_are_exact_in_every_octant() {
        let mut rng = fastrand::Rng::with_seed(5);
        let shapes = [
            [1, 1, 1],
            [7, 1, 1],
            [1, 9, 1],
            [1, 1, 6],
            [5, 4, 3],
            [12, 11, 10],
            [3, 17, 2],
            [10, 9, 8],
        ];
        for (s, &n) in shapes.iter().enumerate() {
            for density in [0.0, 0.002, 0.02, 0.2, 1.0] {
                let len = n[0] * n[1] * n[2];
                let keep: Vec<bool> = (0..len).map(|_| rng.f64() < density).collect();
                let clear: Vec<u8> = keep.iter().map(|&k| u8::from(!k)).collect();
                let tables = OctantDistances::new(n);
                for o in 0..8 {
                    assert_eq!(
                        tables.table(o, &clear),
                        brute(n, &keep, o),
                        "shape {s} {n:?}, density {density}, octant {o}"
                    );
                }
            }
        }
    }

    /// A single kept cell at the end of a long row: distances grow by one
    /// per cell toward it and saturate at 255; rays moving away from it
    /// see nothing.
    #[test]
    fn distances_saturate() {
        let mut clear = vec![1u8; 600];
        clear[599] = 0;
        let up = ahead([600, 1, 1], &clear, 0);
        assert_eq!(up[596..], [3, 2, 1, 0]);
        assert_eq!(up[599 - 254], 254);
        assert!(up[..599 - 254].iter().all(|&v| v == 255));
        let down = ahead([600, 1, 1], &clear, 1);
        assert!(down[..599].iter().all(|&v| v == 255));
        assert_eq!(down[599], 0);
    }

    /// The octant of a direction, zero components counting as upward.
    #[test]
    fn octants_follow_the_signs() {
        assert_eq!(octant([1.0, 0.0, 2.0]), 0);
        assert_eq!(octant([-1.0, 0.5, 0.0]), 1);
        assert_eq!(octant([1.0, -0.5, -0.0]), 2);
        assert_eq!(octant([-1.0, -1.0, -1.0]), 7);
    }
}
