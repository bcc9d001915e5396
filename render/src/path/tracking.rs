//! Free-flight sampling (delta tracking) and transmittance (ratio
//! tracking) over the majorant grid: the ray's stretch inside the volume
//! is cut into the macrocells it crosses ([`crate::accel::dda`]), and each
//! cell is tracked with its own majorant. A cell whose majorant is 0 is
//! crossed without a single sample; crossing a cell boundary restarts the
//! exponential step there (it is memoryless), so every cell's collisions
//! follow its own majorant exactly. With [`MajorantMode::Global`] the
//! whole stretch is one segment under the volume's largest majorant.
//!
//! Distances along the ray are f64 (a tiny step never stalls against a
//! large `t`); every loop is bounded by [`MAX_COLLISIONS`], and both the
//! extinction and the majorants are finite, at most
//! [`crate::accel::majorant::MAX_SIGMA_T`] (above it a medium is as opaque as at
//! it).
//!
//! A sample next to an infinite voxel (or between values near ±FLT_MAX)
//! is read by [`volcore::grid::blend_extended`] where the plain blend is
//! not finite, as MIP does: a cell of `+inf` is `+inf` (extinction at the
//! cap), not the NaN of `inf − inf` (extinction 0, under which every
//! tentative collision at the capped majorant was a null one, a million
//! per unit, and a frame of an infinite medium never ended).

use super::medium::Medium;
use super::PathCounters;
use crate::accel::dda::{segments, voxel_segments};
use crate::accel::majorant::{MajorantGrid, MAX_SIGMA_T};
use crate::accel::skip::SkipFlags;
use crate::accel::VoxelRay;
use crate::sampler::PixelSampler;
use volcore::Cursor;
use volindex::Level;

/// The most tentative collisions one tracking call takes. Past it the
/// ray counts as absorbed (free flight) or opaque (transmittance) and the
/// frame's `truncated` counter says so; no scene this renderer is meant
/// for comes near it (it takes a majorant of 1e6 per unit across 100
/// units of empty space).
pub const MAX_COLLISIONS: u32 = 100_000_000;

/// Ratio tracking plays Russian roulette once the transmittance estimate
/// falls below this, killing the ray with probability
/// [`ROULETTE_KILL`] and dividing survivors' estimate by the rest (the
/// estimate stays unbiased).
pub const ROULETTE_BELOW: f32 = 0.05;
/// See [`ROULETTE_BELOW`].
pub const ROULETTE_KILL: f32 = 0.75;

/// The trilinear sample at voxel position `p`; where the plain blend is
/// not finite (an infinite corner, or a blend of values near ±FLT_MAX),
/// the extended blend's: an infinite corner with weight gives its
/// infinity. Integer samples never take the second look.
#[inline(always)]
fn sample<C: Cursor>(cur: &mut C, p: [f32; 3]) -> f32 {
    let v = cur.trilinear(p);
    if cur.finite() || v.is_finite() {
        v
    } else {
        sample_extended(cur, p)
    }
}

/// The cold half of [`sample`].
#[cold]
#[inline(never)]
fn sample_extended<C: Cursor>(cur: &mut C, p: [f32; 3]) -> f32 {
    let (base, t) = volcore::grid::locate(p, cur.dims());
    volcore::grid::blend_extended(&cur.cell(base[0], base[1], base[2]), t)
}

/// How tracking bounds extinction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MajorantMode {
    /// One majorant per macrocell of the index's finest level.
    Grid,
    /// The largest majorant for the whole volume (what the grid buys is
    /// the difference).
    Global,
}

/// The grid and the volume box tracking runs over.
pub struct Tracker<'a, M: Medium> {
    /// The medium.
    pub medium: &'a M,
    /// The majorant grid (its level is `level`).
    pub grid: &'a MajorantGrid,
    /// The index level the grid is for.
    pub level: &'a Level,
    /// The volume's voxel box, `dims − 1` per axis.
    pub hi: [f32; 3],
    /// The volume's dimensions.
    pub dims: volcore::Dims,
    /// Grid or global.
    pub mode: MajorantMode,
    /// The grid's empty blocks, crossed in one jump each (`None`: cell by
    /// cell). The same collisions either way: empty cells take none.
    pub blocks: Option<&'a SkipFlags>,
}

/// Where a free flight ended.
pub enum Flight {
    /// A real collision at ray parameter `t`, in a sample of value `value`.
    Collision {
        /// Ray parameter of the collision.
        t: f32,
        /// The sample's value (for the albedo).
        value: f32,
    },
    /// The ray left the volume.
    Escaped,
    /// The collision budget ran out: the path ends without light.
    Truncated,
}

impl<M: Medium> Tracker<'_, M> {
    /// Walk the segments of `ray` over `[t0, t1]`, calling
    /// `visit(cur, m, c, a, b, n)` for each stretch `[a, b]` with a nonzero
    /// majorant `m` and control extinction `c` (0 without controls, under
    /// the global majorant and inside cells at the cap), until it returns
    /// `Some`. A macrocell at the cap
    /// ([`MAX_SIGMA_T`]) is walked voxel cell by voxel cell, each with the
    /// bound of its own eight values ([`Tracker::voxel_majorant`]).
    #[inline(always)]
    fn walk<C: Cursor, R>(
        &self,
        cur: &mut C,
        ray: &VoxelRay,
        t0: f32,
        t1: f32,
        n: &mut PathCounters,
        mut visit: impl FnMut(&mut C, f32, f32, f64, f64, &mut PathCounters) -> Option<R>,
    ) -> Option<R> {
        match self.mode {
            MajorantMode::Global => {
                let m = self.grid.global();
                if m > 0.0 && t0 <= t1 {
                    n.majorant_cells += 1;
                    return visit(cur, m, 0.0, t0 as f64, t1 as f64, n);
                }
                None
            }
            MajorantMode::Grid => {
                let mut segs = segments(self.level, self.hi, ray, t0, t1);
                loop {
                    if let (Some(blocks), Some(i)) = (self.blocks, segs.upcoming()) {
                        let d = blocks.ahead(ray.octant, i);
                        if d > 1 {
                            n.empty_jumps += 1;
                            segs.jump(u64::from(d));
                            continue;
                        }
                    }
                    let Some(seg) = segs.next() else {
                        break;
                    };
                    let m = self.grid.get(seg.index);
                    if m <= 0.0 {
                        n.empty_cells += 1;
                        continue;
                    }
                    n.majorant_cells += 1;
                    if m >= MAX_SIGMA_T {
                        if let Some(r) =
                            self.walk_voxels(cur, ray, seg.t0, seg.t1, m, n, &mut visit)
                        {
                            return Some(r);
                        }
                        continue;
                    }
                    let c = self.grid.control(seg.index);
                    if let Some(r) = visit(cur, m, c, seg.t0 as f64, seg.t1 as f64, n) {
                        return Some(r);
                    }
                }
                None
            }
        }
    }

    /// [`Tracker::walk`] inside a macrocell at the cap (majorant `m`): a
    /// stretch of a ray through the transparent part of a cell that also
    /// holds opaque voxels (an opacity-1 bin of a transfer function, or
    /// infinite values) would otherwise take a million null collisions
    /// per unit. Voxel cells whose values all map to nothing are crossed
    /// without a sample.
    #[cold]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn walk_voxels<C: Cursor, R>(
        &self,
        cur: &mut C,
        ray: &VoxelRay,
        t0: f32,
        t1: f32,
        m: f32,
        n: &mut PathCounters,
        visit: &mut impl FnMut(&mut C, f32, f32, f64, f64, &mut PathCounters) -> Option<R>,
    ) -> Option<R> {
        for seg in voxel_segments(self.dims, self.hi, ray, t0, t1) {
            let [i, j, k] = seg.cell;
            let v = self.voxel_majorant(&cur.cell(i, j, k)).min(m);
            n.voxel_cells += 1;
            if v <= 0.0 {
                continue;
            }
            if let Some(r) = visit(cur, v, 0.0, seg.t0 as f64, seg.t1 as f64, n) {
                return Some(r);
            }
        }
        None
    }

    /// A bound of the extinction of every sample the sampler blends from
    /// one voxel cell's eight `corners`: the medium's bound over their
    /// range (a trilinear or extended blend lies within it, or is NaN,
    /// whose extinction is 0). NaN corners are left out.
    fn voxel_majorant(&self, corners: &[f32; 8]) -> f32 {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for &c in corners {
            // NaN fails both comparisons.
            if c < lo {
                lo = c;
            }
            if c > hi {
                hi = c;
            }
        }
        if lo > hi {
            return 0.0;
        }
        let b = self.medium.majorant_over(lo, hi);
        // NaN fails the comparison: 0.
        if b > 0.0 {
            b
        } else {
            0.0
        }
    }

    /// The extinction at ray parameter `t`, with the sample's value.
    ///
    /// Debug builds check that the majorant bounds it (as pbrt does): the
    /// segment's, or, for a point that rounding put a hair across the
    /// segment's face, the cell the sampler reads it from. Such a point
    /// can exceed the segment's majorant by a rounding-sized amount; the
    /// trackers clamp the ratio to 1.
    #[inline(always)]
    fn sigma_at<C: Cursor>(&self, cur: &mut C, ray: &VoxelRay, t: f64, m: f32) -> (f32, f32) {
        let p = ray.at(t as f32);
        let v = sample(cur, p.to_array());
        let s = self.medium.sigma_t(v);
        // The majorant is read by the debug checks alone.
        #[cfg(not(debug_assertions))]
        let _ = m;
        #[cfg(debug_assertions)]
        {
            let c = self.level.cell_of(p.to_array(), self.dims);
            let own = self.grid.get(self.level.index(c[0], c[1], c[2]));
            debug_assert!(
                s <= m.max(own) * (1.0 + 1e-5) + 1e-30,
                "extinction {s} above the majorants {m} and {own} at {p}"
            );
        }
        (s, v)
    }

    /// The gradient of the extinction at voxel position `p`, per voxel
    /// (central differences one voxel apart, clamped into the volume):
    /// six lookups.
    #[inline]
    pub fn gradient<C: Cursor>(&self, cur: &mut C, p: glam::Vec3) -> glam::Vec3 {
        let hi = glam::Vec3::from(self.hi);
        let mut s = |q: glam::Vec3| {
            let q = q.clamp(glam::Vec3::ZERO, hi);
            self.medium.sigma_t(sample(cur, q.to_array()))
        };
        let (x, y, z) = (glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z);
        glam::Vec3::new(
            s(p + x) - s(p - x),
            s(p + y) - s(p - y),
            s(p + z) - s(p - z),
        ) * 0.5
    }

    /// The tentative collisions along `ray` over `[t0, t1]`, in order:
    /// an optical depth is drawn (exponential, mean 1; the first from
    /// `first`, uniform in `[0, 1)`, the rest from `rng`) and spent across
    /// the cells at their rates (`RESIDUAL`: the majorant less the cell's
    /// control, whose optical depth is added to `control_depth`; else the
    /// majorant); where it runs out, `at(Some(t), m, c, d, rng, n)` (`d`:
    /// the control's optical depth to the end of the current cell) is asked
    /// whether to stop there (`Some`) or to go on with a fresh depth;
    /// `RESIDUAL` also asks `at(None, m, c, d, rng, n)` on entering each
    /// cell (where the control alone can make the estimate small enough
    /// for roulette). The walk is
    /// memoryless, so this is the same process as restarting in every
    /// cell, at one random number and one logarithm per collision instead
    /// of per cell. Past [`MAX_COLLISIONS`] it stops with `truncated`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn collisions<C: Cursor, R, const RESIDUAL: bool>(
        &self,
        cur: &mut C,
        (ray, t0, t1): (&VoxelRay, f32, f32),
        first: f32,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
        control_depth: &mut f64,
        truncated: R,
        mut at: impl FnMut(
            &mut C,
            Option<f64>,
            f32,
            f32,
            f64,
            &mut PixelSampler,
            &mut PathCounters,
        ) -> Option<R>,
    ) -> Option<R> {
        let exp = |u: f32| -(-(u as f64)).ln_1p();
        // The optical depth to the next collision, its logarithm taken in
        // the first cell with anything to track (NaN until then: a ray that
        // meets only empty cells, as most camera rays of a sparse volume
        // do, never pays for it).
        let mut tau = f64::NAN;
        let mut budget = MAX_COLLISIONS;
        let mut truncated = Some(truncated);
        self.walk(cur, ray, t0, t1, n, |cur, m, c, a, b, n| {
            let rate = if RESIDUAL {
                *control_depth += c as f64 * (b - a);
                if let Some(r) = at(cur, None, m, c, *control_depth, rng, n) {
                    return Some(r);
                }
                (m - c) as f64
            } else {
                m as f64
            };
            if rate <= 0.0 {
                // A cell whose extinction is its control: nothing to track.
                return None;
            }
            if tau.is_nan() {
                tau = exp(first);
            }
            let mut t = a;
            loop {
                let need = tau / rate;
                if t + need >= b {
                    tau = (tau - (b - t) * rate).max(0.0);
                    return None;
                }
                t += need;
                if budget == 0 {
                    n.truncated += 1;
                    return truncated.take();
                }
                budget -= 1;
                if let Some(r) = at(cur, Some(t), m, c, *control_depth, rng, n) {
                    return Some(r);
                }
                tau = exp(rng.next_1d());
            }
        })
    }

    /// Delta tracking along `ray` over `[t0, t1]`: the first real
    /// collision, or escape.
    pub fn free_flight<C: Cursor>(
        &self,
        cur: &mut C,
        ray: &VoxelRay,
        (t0, t1): (f32, f32),
        first: f32,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> Flight {
        self.collisions::<C, Flight, false>(
            cur,
            (ray, t0, t1),
            first,
            rng,
            n,
            &mut 0.0,
            Flight::Truncated,
            |cur, t, m, _, _, rng, n| {
                let t = t?;
                n.density_lookups += 1;
                let (s, v) = self.sigma_at(cur, ray, t, m);
                n.capped += u64::from(s >= MAX_SIGMA_T);
                if rng.next_1d() * m < s {
                    n.real_collisions += 1;
                    Some(Flight::Collision {
                        t: t as f32,
                        value: v,
                    })
                } else {
                    n.null_collisions += 1;
                    None
                }
            },
        )
        .unwrap_or(Flight::Escaped)
    }

    /// Residual ratio tracking (Novák et al. 2014) along `ray` over
    /// `[t0, t1]`: an unbiased estimate of the transmittance, in
    /// `[0, 1 / (1 − ROULETTE_KILL)]`, with Russian roulette below
    /// [`ROULETTE_BELOW`]. Each cell's control extinction `c` (see
    /// [`crate::accel::majorant::MajorantGrid::with_controls`]) is
    /// integrated in closed form (`exp(−∫c)`) and only the residual
    /// `σt − c` is tracked, at the rate `majorant − c`: a cell whose
    /// extinction varies little costs few lookups however dense it is.
    /// Without controls (all 0) this is plain ratio tracking. The first
    /// exponential step comes from `first`.
    #[allow(clippy::too_many_arguments)]
    pub fn transmittance<C: Cursor>(
        &self,
        cur: &mut C,
        ray: &VoxelRay,
        t0: f32,
        t1: f32,
        first: f32,
        rng: &mut PixelSampler,
        n: &mut PathCounters,
    ) -> f32 {
        let mut tr = 1.0f32;
        // The control's optical depth past which the estimate,
        // tr × exp(−depth), is below the roulette's threshold (recomputed
        // when tr changed and a depth is there to compare).
        let mut beyond = 0.0f64;
        let mut stale = true;
        let mut control = 0.0f64;
        let stop = self.collisions::<C, (), true>(
            cur,
            (ray, t0, t1),
            first,
            rng,
            n,
            &mut control,
            (),
            |cur, t, m, c, depth, rng, n| {
                match t {
                    Some(t) => {
                        n.density_lookups += 1;
                        let (s, _) = self.sigma_at(cur, ray, t, m);
                        n.capped += u64::from(s >= MAX_SIGMA_T);
                        tr *= (1.0 - (s - c) / (m - c)).max(0.0);
                        if tr <= 0.0 {
                            return Some(());
                        }
                        stale = true;
                    }
                    // Entering a cell: only its control can have made the
                    // estimate small.
                    None if c <= 0.0 => return None,
                    None => {}
                }
                let below = if depth > 0.0 {
                    if stale {
                        beyond = (tr / ROULETTE_BELOW).ln() as f64;
                        stale = false;
                    }
                    depth > beyond
                } else {
                    // No control yet: plain ratio tracking's test.
                    tr < ROULETTE_BELOW
                };
                if below {
                    if rng.next_1d() < ROULETTE_KILL {
                        return Some(());
                    }
                    tr /= 1.0 - ROULETTE_KILL;
                    stale = true;
                }
                None
            },
        );
        if stop.is_some() {
            0.0
        } else {
            tr * (-control).exp() as f32
        }
    }
}
