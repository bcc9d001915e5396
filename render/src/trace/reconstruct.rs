//! Reconstruction and gradients at a point. The reconstruction is a value
//! chosen per frame ([`Interp`]): a branch per sample taken one by one,
//! none in the runs of eight most trilinear samples are read in. The
//! gradient method is a zero-sized type per choice, so an integrator is
//! compiled for exactly the ones it uses (they read different cells).

pub use crate::settings::Interp;
use glam::Vec3;
use volcore::grid::{blend, blend_extended, Locator};
use volcore::Cursor;

impl Interp {
    /// Whether this is trilinear interpolation ([`Cursor::trilinear`]),
    /// whose values cursors can read eight at a time.
    #[inline(always)]
    pub fn is_trilinear(self) -> bool {
        matches!(self, Interp::Trilinear)
    }

    /// The value at voxel-space point `p`.
    #[inline(always)]
    pub fn value<C: Cursor>(self, loc: &Locator, cur: &mut C, p: Vec3) -> f32 {
        let (base, t) = loc.locate(p.into());
        match self {
            Interp::Trilinear => cur.cell_blend(base[0], base[1], base[2], t),
            // Halves round up, as `Cursor::nearest` does for the clamped,
            // non-negative coordinates.
            Interp::Nearest => {
                let d = cur.dims().as_array();
                let pick = |a: usize| (base[a] + (t[a] >= 0.5) as u64).min(d[a] - 1);
                cur.voxel(pick(0), pick(1), pick(2))
            }
        }
    }

    /// [`Interp::value`] where that is not finite, by the rule of
    /// [`blend_extended`]: a sample next to an infinite voxel is that
    /// infinity, not the NaN of `inf - inf` in a blend. Nearest samples are
    /// voxels and need no second look.
    #[cold]
    #[inline(never)]
    pub fn value_extended<C: Cursor>(self, loc: &Locator, cur: &mut C, p: Vec3) -> f32 {
        match self {
            Interp::Trilinear => {
                let (base, t) = loc.locate(p.into());
                blend_extended(&cur.cell(base[0], base[1], base[2]), t)
            }
            Interp::Nearest => self.value(loc, cur, p),
        }
    }

    /// The value at offsets `t` inside the cell whose corner values are
    /// `c` (corners ordered `dx + 2·dy + 4·dz`).
    #[inline(always)]
    pub fn in_cell(self, c: &[f32; 8], t: [f32; 3]) -> f32 {
        match self {
            Interp::Trilinear => blend(c, t),
            Interp::Nearest => {
                let i = (t[0] >= 0.5) as usize
                    + 2 * (t[1] >= 0.5) as usize
                    + 4 * (t[2] >= 0.5) as usize;
                c[i]
            }
        }
    }
}

/// How the gradient at a sample is computed (per voxel; the integrators
/// scale it to world units).
pub trait Gradient: Copy + Send + Sync + 'static {
    /// What the method gets for free while reading the value (the
    /// analytic gradient comes from the same cell fetch).
    type Early: Copy;
    /// What [`Gradient::value`] returns beside the value when that is all
    /// it reads (then values read in a batch serve as well); `None` when it
    /// reads more.
    const FROM_VALUE: Option<Self::Early>;
    /// Whether this method's gradient is the blend of the cell's central
    /// differences, which a cursor reads for a run of eight samples at once
    /// (`Cursor::cross_blend8`), so such runs take their gradients in lanes
    /// ([`Central`]'s is; the others' are not).
    #[inline(always)]
    fn reads_lane_blends() -> bool {
        false
    }
    /// The value at `p` (reconstructed by `interp`), and what the gradient
    /// can reuse.
    fn value<C: Cursor>(interp: Interp, loc: &Locator, cur: &mut C, p: Vec3) -> (f32, Self::Early);
    /// The gradient at `p`, given what [`Gradient::value`] returned there.
    fn gradient<C: Cursor>(early: Self::Early, loc: &Locator, cur: &mut C, p: Vec3) -> Vec3;
}

/// No gradient at all: for integrators that neither shade nor classify by
/// gradient. Its [`Gradient::gradient`] is never called by them.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoGradient;

/// Central differences of the interpolant (six more cells read).
#[derive(Clone, Copy, Debug, Default)]
pub struct Central;

/// The exact gradient of the trilinear cell around the point.
#[derive(Clone, Copy, Debug, Default)]
pub struct Analytic;

impl Gradient for NoGradient {
    type Early = ();
    const FROM_VALUE: Option<()> = Some(());
    #[inline(always)]
    fn value<C: Cursor>(interp: Interp, loc: &Locator, cur: &mut C, p: Vec3) -> (f32, ()) {
        (interp.value(loc, cur, p), ())
    }
    #[inline(always)]
    fn gradient<C: Cursor>(_: (), _: &Locator, _: &mut C, _: Vec3) -> Vec3 {
        Vec3::ZERO
    }
}

impl Gradient for Central {
    type Early = ();
    const FROM_VALUE: Option<()> = Some(());
    #[inline(always)]
    fn reads_lane_blends() -> bool {
        true
    }
    #[inline(always)]
    fn value<C: Cursor>(interp: Interp, loc: &Locator, cur: &mut C, p: Vec3) -> (f32, ()) {
        (interp.value(loc, cur, p), ())
    }
    #[inline(always)]
    fn gradient<C: Cursor>(_: (), loc: &Locator, cur: &mut C, p: Vec3) -> Vec3 {
        central_gradient(loc, cur, p)
    }
}

impl Gradient for Analytic {
    type Early = Vec3;
    const FROM_VALUE: Option<Vec3> = None;
    #[inline(always)]
    fn value<C: Cursor>(interp: Interp, loc: &Locator, cur: &mut C, p: Vec3) -> (f32, Vec3) {
        let (base, t) = loc.locate(p.into());
        let c = cur.cell(base[0], base[1], base[2]);
        (interp.in_cell(&c, t), cell_gradient(&c, t))
    }
    #[inline(always)]
    fn gradient<C: Cursor>(early: Vec3, _: &Locator, _: &mut C, _: Vec3) -> Vec3 {
        early
    }
}

/// The exact gradient of the trilinear interpolant of cell `c` at offsets
/// `t` (corners ordered `dx + 2·dy + 4·dz`).
#[inline(always)]
pub fn cell_gradient(c: &[f32; 8], t: [f32; 3]) -> Vec3 {
    let (tx, ty, tz) = (t[0], t[1], t[2]);
    let lerp = |a: f32, b: f32, s: f32| a + (b - a) * s;
    let gx = lerp(
        lerp(c[1] - c[0], c[3] - c[2], ty),
        lerp(c[5] - c[4], c[7] - c[6], ty),
        tz,
    );
    let gy = lerp(
        lerp(c[2] - c[0], c[3] - c[1], tx),
        lerp(c[6] - c[4], c[7] - c[5], tx),
        tz,
    );
    let gz = lerp(
        lerp(c[4] - c[0], c[5] - c[1], tx),
        lerp(c[6] - c[2], c[7] - c[3], tx),
        ty,
    );
    Vec3::new(gx, gy, gz)
}

/// The central-difference gradient of the interpolant (per voxel):
/// `(f(p + e) − f(p − e)) / 2` per axis. Away from the faces the six
/// points share `p`'s cell offsets, so the point is located once and the
/// cross of neighbouring cells is fetched together; within a voxel of a face
/// the clamping rules of [`Cursor::gradient`] apply.
#[inline(always)]
pub fn central_gradient<C: Cursor>(loc: &Locator, cur: &mut C, p: Vec3) -> Vec3 {
    let d = cur.dims().as_array();
    let (base, t) = loc.locate(p.into());
    let interior = (0..3).all(|a| base[a] >= 1 && base[a] + 2 < d[a]);
    if !interior {
        return Vec3::from(cur.gradient(p.into()));
    }
    // The interpolant is linear in the cell values, so f(p + e) − f(p − e)
    // is the blend of the two cells' differences: three blends, not six
    // (and exact differences for integer samples).
    Vec3::from(cur.cross_blend(base[0], base[1], base[2], t)) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcore::region::pack_sliced;
    use volcore::scene::{NoiseKind, NoiseScene, RampScene, SceneSource};
    use volcore::{Dims, VoxelSource};

    #[test]
    fn analytic_gradient_of_a_ramp_is_exact() {
        let d = Dims::new(9, 7, 5).unwrap();
        let scene = RampScene::new(d, 0, 80.0);
        let v = volcore::SlicedGrid::new(
            d,
            volcore::Data::Owned(pack_sliced(&SceneSource::<f32>::new(&scene))),
        )
        .unwrap();
        let mut cur = v.cursor();
        let loc = Locator::new(d);
        let p = Vec3::new(3.25, 2.5, 1.5);
        let (val, g) = Analytic::value(Interp::Trilinear, &loc, &mut cur, p);
        assert!((val - 80.0 * 3.25 / 8.0).abs() < 1e-4);
        assert!((g - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-5);
        let c = Central::gradient((), &loc, &mut cur, p);
        assert!((c - g).length() < 1e-4);
        // The interior shortcut agrees with the general definition.
        let mut rng = fastrand::Rng::with_seed(5);
        for _ in 0..1000 {
            let p = Vec3::new(
                1.0 + rng.f32() * 5.9,
                1.0 + rng.f32() * 3.9,
                1.0 + rng.f32() * 1.9,
            );
            let fast = central_gradient(&loc, &mut cur, p);
            let slow = Vec3::from(cur.gradient(p.into()));
            assert!((fast - slow).length() < 1e-3, "{p}: {fast} vs {slow}");
        }
    }

    #[test]
    fn reconstructions_match_the_cursor() {
        let d = Dims::new(6, 5, 4).unwrap();
        let scene = NoiseScene::new(d, 1, NoiseKind::Value, 2.0, 2, 100.0);
        let v = volcore::SlicedGrid::new(
            d,
            volcore::Data::Owned(pack_sliced(&SceneSource::<u8>::new(&scene))),
        )
        .unwrap();
        let mut cur = v.cursor();
        let loc = Locator::new(d);
        let mut rng = fastrand::Rng::with_seed(2);
        for _ in 0..2000 {
            let p = Vec3::new(
                rng.f32() * 7.0 - 0.5,
                rng.f32() * 6.0 - 0.5,
                rng.f32() * 5.0 - 0.5,
            );
            assert_eq!(
                Interp::Nearest.value(&loc, &mut cur, p),
                cur.nearest(p.into()),
                "{p}"
            );
            assert_eq!(
                Interp::Trilinear.value(&loc, &mut cur, p),
                cur.trilinear(p.into())
            );
            // The value read alongside the analytic gradient is the same.
            assert_eq!(
                Analytic::value(Interp::Nearest, &loc, &mut cur, p).0,
                cur.nearest(p.into())
            );
            assert_eq!(
                Analytic::value(Interp::Trilinear, &loc, &mut cur, p).0,
                cur.trilinear(p.into())
            );
        }
    }
}
