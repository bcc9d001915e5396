//! What blocks light: the optical depth one shadow sample adds.

use crate::classify::Classifier;
use crate::trace::reconstruct::{Gradient, Interp};
use crate::trace::FrameGeometry;
use glam::Vec3;
use std::marker::PhantomData;
use volcore::grid::Locator;
use volcore::Cursor;

/// Optical depth along shadow rays, one sample at a time.
pub trait Occluder: Sync {
    /// What a shadow ray adds to the rule (`()` for the classified volume,
    /// the outside's side for an iso-surface).
    type Query: Copy + Send + Sync;
    /// The optical depth of the sample at voxel-space point `p`, for the
    /// step the occluder was built for: 0 clear, infinite opaque, never
    /// negative or NaN.
    fn depth<C: Cursor>(&self, cur: &mut C, p: Vec3, q: Self::Query) -> f32;
    /// Whether a sample's depth follows from its value alone (then, where
    /// the frame reconstructs trilinearly, [`Occluder::depth8`] gives it,
    /// and shadow rays read values eight at a time).
    const FROM_VALUE: bool = false;
    /// Whether samples are reconstructed trilinearly (asked once per
    /// shadow ray, where [`Occluder::FROM_VALUE`] holds).
    #[inline(always)]
    fn trilinear(&self) -> bool {
        true
    }
    /// The depths of eight samples of trilinear values `v`, where
    /// [`Occluder::FROM_VALUE`] holds: [`Occluder::depth`] bit for bit.
    #[inline(always)]
    fn depth8(&self, v: &[f32; 8], q: Self::Query) -> [f32; 8] {
        let _ = (v, q);
        [f32::NAN; 8]
    }
}

/// The classified volume (DVR): a sample's depth is `−ln(1 − α)` of its
/// opacity for the shadow step, read from a depth table
/// ([`Classifier::to_optical_depth`]); gradients from `G` when the
/// classifier reads them.
pub struct Classified<'a, G, K> {
    table: &'a K,
    loc: Locator,
    inv_spacing: Vec3,
    interp: Interp,
    _gradient: PhantomData<G>,
}

impl<'a, G, K> Classified<'a, G, K> {
    /// The occluder reading `depth_table` (built by
    /// [`Classifier::to_optical_depth`]) in a frame of geometry `geom`.
    pub fn new(depth_table: &'a K, geom: &FrameGeometry) -> Self {
        Classified {
            table: depth_table,
            loc: geom.locator,
            inv_spacing: geom.inv_spacing,
            interp: geom.interp,
            _gradient: PhantomData,
        }
    }
}

impl<G: Gradient, K: Classifier> Occluder for Classified<'_, G, K> {
    type Query = ();
    const FROM_VALUE: bool = G::FROM_VALUE.is_some() && !K::NEEDS_GRADIENT;
    #[inline(always)]
    fn trilinear(&self) -> bool {
        self.interp.is_trilinear()
    }
    #[inline(always)]
    fn depth8(&self, v: &[f32; 8], _: ()) -> [f32; 8] {
        self.table.alpha8(v)
    }
    #[inline(always)]
    fn depth<C: Cursor>(&self, cur: &mut C, p: Vec3, _: ()) -> f32 {
        let (v, early) = G::value(self.interp, &self.loc, cur, p);
        let g = if K::NEEDS_GRADIENT {
            (G::gradient(early, &self.loc, cur, p) * self.inv_spacing).length()
        } else {
            0.0
        };
        self.table.classify(v, g)[3]
    }
}

/// The inside of an iso-surface, opaque: a sample on the other side of the
/// level from the outside blocks all light. The query is the outside's
/// side (`true`: values at or above the level; a surface seen from inside
/// lights its inside).
pub struct IsoInside {
    level: f32,
    loc: Locator,
    interp: Interp,
}

impl IsoInside {
    /// The inside for iso value `level` in a frame of geometry `geom`.
    pub fn new(level: f32, geom: &FrameGeometry) -> Self {
        IsoInside {
            level,
            loc: geom.locator,
            interp: geom.interp,
        }
    }
}

impl Occluder for IsoInside {
    type Query = bool;
    const FROM_VALUE: bool = true;
    #[inline(always)]
    fn trilinear(&self) -> bool {
        self.interp.is_trilinear()
    }
    #[inline(always)]
    fn depth8(&self, v: &[f32; 8], outside_above: bool) -> [f32; 8] {
        v.map(|v| {
            if (v >= self.level) != outside_above {
                f32::INFINITY
            } else {
                0.0
            }
        })
    }
    #[inline(always)]
    fn depth<C: Cursor>(&self, cur: &mut C, p: Vec3, outside_above: bool) -> f32 {
        if (self.interp.value(&self.loc, cur, p) >= self.level) != outside_above {
            f32::INFINITY
        } else {
            0.0
        }
    }
}
