//! Splitting a volume among `N` ranks for data-parallel rendering: a k-d
//! tree over a grid of blocks (bricks, or groups of macrocells), each cut
//! at the block plane, on whichever axis, that best balances the ranks'
//! work as the blocks' weights measure it (ties to the longest axis; the
//! weights are the caller's: [`super::Split`] counts the cells a frame
//! can see, scaled by the camera's ray density). Each rank owns one convex box
//! of whole blocks; the tree gives the order in which the boxes must be
//! composited for any viewer, inside the volume or out.

use std::ops::Range;

/// A k-d split of a block grid among ranks (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KdTree {
    shape: [u64; 3],
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Node {
    /// Blocks below plane `at` on `axis` go to `lower`, the rest to
    /// `upper` (node indices).
    Split {
        axis: usize,
        at: u64,
        lower: usize,
        upper: usize,
    },
    /// A rank's box.
    Leaf(usize),
}

/// One rank's share: a box of blocks (empty when there were more ranks
/// than blocks to give out) and its weight.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Leaf {
    /// The blocks `x, y, z` of the box, half-open.
    pub blocks: [Range<u64>; 3],
    /// The sum of its blocks' weights.
    pub weight: u64,
}

impl Leaf {
    /// Whether the box holds no block.
    pub fn is_empty(&self) -> bool {
        self.blocks.iter().any(|r| r.is_empty())
    }
}

/// Where the viewer is, to order the boxes front to back, in block units
/// (voxel coordinates divided by the block edge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Viewer {
    /// A perspective camera's eye.
    Point([f64; 3]),
    /// An orthographic camera's viewing direction.
    Direction([f64; 3]),
}

/// Prefix sums of a block grid's weights along one axis of a box.
fn slab_weights(weights: &[u64], shape: [u64; 3], b: &[Range<u64>; 3], axis: usize) -> Vec<u64> {
    let mut slabs = vec![0u64; (b[axis].end - b[axis].start) as usize];
    for z in b[2].clone() {
        for y in b[1].clone() {
            let row = ((z * shape[1] + y) * shape[0]) as usize;
            for x in b[0].clone() {
                let i = [x, y, z][axis] - b[axis].start;
                slabs[i as usize] += weights[row + x as usize];
            }
        }
    }
    slabs
}

impl KdTree {
    /// Split the blocks of a grid of `shape` (x fastest) with `weights`
    /// among `ranks` ranks (at least one).
    pub fn split(weights: &[u64], shape: [u64; 3], ranks: usize) -> KdTree {
        debug_assert_eq!(weights.len() as u64, shape.iter().product::<u64>());
        let mut t = KdTree {
            shape,
            nodes: Vec::new(),
            leaves: vec![
                Leaf {
                    blocks: [0..0, 0..0, 0..0],
                    weight: 0,
                };
                ranks.max(1)
            ],
        };
        let all = [0..shape[0], 0..shape[1], 0..shape[2]];
        t.build(weights, all, 0..ranks.max(1));
        t
    }

    /// The subtree for ranks `rs` over box `b`; returns its node index.
    fn build(&mut self, weights: &[u64], b: [Range<u64>; 3], rs: Range<usize>) -> usize {
        let n = rs.end - rs.start;
        let weight_of = |b: &[Range<u64>; 3]| -> u64 {
            if b.iter().any(|r| r.is_empty()) {
                return 0;
            }
            slab_weights(weights, self.shape, b, 0).iter().sum()
        };
        if n == 1 {
            let w = weight_of(&b);
            self.leaves[rs.start] = Leaf {
                blocks: b,
                weight: w,
            };
            self.nodes.push(Node::Leaf(rs.start));
            return self.nodes.len() - 1;
        }
        let lower_ranks = n / 2;
        // On each axis that can be cut, the cut after `c` slabs closest to
        // the lower ranks' share; of those the closest (ties: the longest
        // axis, then x before y before z).
        let extent = |a: usize| b[a].end.saturating_sub(b[a].start);
        let any_visible = weight_of(&b) > 0;
        let mut best: Option<(f64, u64, usize, u64)> = None; // miss, extent, axis, at
        for axis in (0..3).filter(|&a| extent(a) >= 2) {
            let mut slabs = slab_weights(weights, self.shape, &b, axis);
            if !any_visible {
                // Nothing visible: balance the blocks themselves.
                slabs.fill(1);
            }
            let total: u64 = slabs.iter().sum();
            let target = total as f64 * lower_ranks as f64 / n as f64;
            let mut below = 0u64;
            for c in 1..slabs.len() {
                below += slabs[c - 1];
                let miss = (below as f64 - target).abs() / total.max(1) as f64;
                let better = match best {
                    None => true,
                    Some((m, e, ..)) => miss < m || (miss == m && extent(axis) > e),
                };
                if better {
                    best = Some((miss, extent(axis), axis, b[axis].start + c as u64));
                }
            }
        }
        let (axis, at) = match best {
            Some((_, _, axis, at)) => (axis, at),
            // One block (or none) left for several ranks: the first takes
            // it, the others get empty boxes.
            None => (0, b[0].end),
        };
        let mut lo = b.clone();
        let mut hi = b.clone();
        lo[axis].end = at;
        hi[axis].start = at;
        let me = self.nodes.len();
        self.nodes.push(Node::Leaf(usize::MAX));
        let lower = self.build(weights, lo, rs.start..rs.start + lower_ranks);
        let upper = self.build(weights, hi, rs.start + lower_ranks..rs.end);
        self.nodes[me] = Node::Split {
            axis,
            at,
            lower,
            upper,
        };
        me
    }

    /// The ranks' boxes, by rank.
    pub fn leaves(&self) -> &[Leaf] {
        &self.leaves
    }

    /// The rank whose box holds block `b`.
    pub fn rank_of(&self, b: [u64; 3]) -> usize {
        let mut i = 0;
        loop {
            match self.nodes[i] {
                Node::Leaf(r) => return r,
                Node::Split {
                    axis,
                    at,
                    lower,
                    upper,
                } => i = if b[axis] < at { lower } else { upper },
            }
        }
    }

    /// The ranks in front-to-back order for `viewer`: along any ray of
    /// the view, the boxes it meets come in this order.
    pub fn front_to_back(&self, viewer: Viewer) -> Vec<usize> {
        let mut out = Vec::with_capacity(self.leaves.len());
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            match self.nodes[i] {
                Node::Leaf(r) => out.push(r),
                Node::Split {
                    axis,
                    at,
                    lower,
                    upper,
                } => {
                    let lower_first = match viewer {
                        Viewer::Point(e) => e[axis] < at as f64,
                        Viewer::Direction(d) => d[axis] >= 0.0,
                    };
                    let (near, far) = if lower_first {
                        (lower, upper)
                    } else {
                        (upper, lower)
                    };
                    stack.push(far);
                    stack.push(near);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(shape: [u64; 3], f: impl Fn(u64, u64, u64) -> u64) -> Vec<u64> {
        let mut w = Vec::new();
        for z in 0..shape[2] {
            for y in 0..shape[1] {
                for x in 0..shape[0] {
                    w.push(f(x, y, z));
                }
            }
        }
        w
    }

    /// Every block in exactly one box, that box's rank's.
    fn check_cover(t: &KdTree, shape: [u64; 3], weights: &[u64]) {
        let mut owner = vec![usize::MAX; weights.len()];
        for (r, leaf) in t.leaves().iter().enumerate() {
            let mut w = 0;
            for z in leaf.blocks[2].clone() {
                for y in leaf.blocks[1].clone() {
                    for x in leaf.blocks[0].clone() {
                        let i = ((z * shape[1] + y) * shape[0] + x) as usize;
                        assert_eq!(owner[i], usize::MAX, "block {x},{y},{z} twice");
                        owner[i] = r;
                        w += weights[i];
                        assert_eq!(t.rank_of([x, y, z]), r);
                    }
                }
            }
            assert_eq!(w, leaf.weight);
        }
        assert!(
            owner.iter().all(|&o| o != usize::MAX),
            "a block has no rank"
        );
    }

    #[test]
    fn boxes_cover_the_grid_once_and_balance_the_visible_blocks() {
        let shapes = [[1, 1, 1], [25, 25, 25], [7, 3, 12], [2, 1, 1], [40, 1, 3]];
        for shape in shapes {
            let uniform = grid(shape, |_, _, _| 1);
            // Visible only in one corner: balance follows the weights.
            let corner = grid(shape, |x, y, z| u64::from(x < 3 && y < 3 && z < 4));
            for ranks in [1, 2, 3, 4, 7, 8, 64] {
                for w in [&uniform, &corner] {
                    let t = KdTree::split(w, shape, ranks);
                    assert_eq!(t.leaves().len(), ranks);
                    check_cover(&t, shape, w);
                }
                let t = KdTree::split(&uniform, shape, ranks);
                let blocks: u64 = shape.iter().product();
                if blocks >= 8 * ranks as u64 && ranks <= 8 {
                    // Within a slab or so of the even share per cut.
                    let share = blocks as f64 / ranks as f64;
                    for l in t.leaves() {
                        assert!(
                            (l.weight as f64) < 2.0 * share && (l.weight as f64) > 0.4 * share,
                            "{shape:?} {ranks} ranks: {} against {share}",
                            l.weight
                        );
                    }
                }
            }
        }
        // 25^3 blocks visible in a 3x3x4 corner, 4 ranks: each gets 9.
        let shape = [25, 25, 25];
        let corner = grid(shape, |x, y, z| u64::from(x < 3 && y < 3 && z < 4));
        let t = KdTree::split(&corner, shape, 4);
        let w: Vec<u64> = t.leaves().iter().map(|l| l.weight).collect();
        assert_eq!(w.iter().sum::<u64>(), 36);
        assert!(w.iter().all(|&w| w == 9), "{w:?}");
    }

    #[test]
    fn more_ranks_than_blocks_leave_some_boxes_empty() {
        let t = KdTree::split(&[5, 1], [2, 1, 1], 5);
        check_cover(&t, [2, 1, 1], &[5, 1]);
        assert_eq!(t.leaves().iter().filter(|l| !l.is_empty()).count(), 2);
        assert_eq!(t.front_to_back(Viewer::Point([9.0, 0.0, 0.0])).len(), 5);
    }

    /// Walk rays from random viewers through the grid: the boxes they
    /// enter appear in the tree's order for that viewer.
    #[test]
    fn front_to_back_order_holds_along_every_ray() {
        let shape = [9, 6, 11];
        let w = grid(shape, |x, y, z| (x * 7 + y * 3 + z) % 4);
        let mut rng = fastrand::Rng::with_seed(3);
        for ranks in [2, 3, 5, 8, 13] {
            let t = KdTree::split(&w, shape, ranks);
            for case in 0..200 {
                let inside = case % 3 == 0;
                let ortho = case % 5 == 1;
                let eye: [f64; 3] = std::array::from_fn(|a| {
                    let n = shape[a] as f64;
                    if inside {
                        rng.f64() * n
                    } else {
                        rng.f64() * 3.0 * n - n
                    }
                });
                let dir: [f64; 3] = std::array::from_fn(|_| rng.f64() * 2.0 - 1.0);
                let viewer = if ortho {
                    Viewer::Direction(dir)
                } else {
                    Viewer::Point(eye)
                };
                let order = t.front_to_back(viewer);
                let pos: Vec<usize> = (0..ranks)
                    .map(|r| order.iter().position(|&o| o == r).unwrap())
                    .collect();
                for _ in 0..20 {
                    // A ray from the eye (or, orthographic, along dir from
                    // a point far behind the grid).
                    let d: [f64; 3] = if ortho {
                        dir
                    } else {
                        std::array::from_fn(|_| rng.f64() * 2.0 - 1.0)
                    };
                    let o: [f64; 3] = if ortho {
                        std::array::from_fn(|a| eye[a] - 40.0 * d[a])
                    } else {
                        eye
                    };
                    let mut last = 0;
                    for s in 0..4000 {
                        let tt = s as f64 * 0.02;
                        let p: [f64; 3] = std::array::from_fn(|a| o[a] + tt * d[a]);
                        if (0..3).any(|a| p[a] < 0.0 || p[a] >= shape[a] as f64) {
                            continue;
                        }
                        let r = t.rank_of(std::array::from_fn(|a| p[a] as u64));
                        assert!(pos[r] >= last, "{ranks} ranks, {viewer:?}: back to box {r}");
                        last = pos[r];
                    }
                }
            }
        }
    }
}
