//! From a frame's choices to one concrete integrator type, in visitor
//! style: each choice (reconstruction, gradient method, classifier,
//! shading, termination, skipping) is matched once per frame and becomes a
//! type parameter, and the visitor is called with the fully specialised
//! integrator. Combinations that cannot differ are not instantiated: DVR
//! without shading and with a 1D classifier never computes a gradient, so
//! it exists once, not once per gradient method; MIP, MinIP and X-ray have
//! no gradient, classifier or shading parameter at all.

use crate::accel::open_sky::OpenSky;
use crate::accel::{FixedCells, IsoSides, NoSkipping, RunningMax, RunningMin};
use crate::classify::{Classifier, TfTable, TfTable2d};
use crate::effects::{AoSource, Classified, EffectsPhong, IsoInside, LightGrid, ShadowCaster};
use crate::integrator::dvr::{
    Dvr, NoTermination, OpacityThreshold, PhongShading, Shading, Termination, Unshaded,
};
use crate::integrator::iso::Iso;
use crate::integrator::mip::{Maximum, Minimum, Mip};
use crate::integrator::reconstruct::{
    Analytic, Central, Gradient, Nearest, NoGradient, Reconstruct, Trilinear,
};
use crate::integrator::xray::{Xray, XrayOutput};
use crate::integrator::{FrameGeometry, Integrator};
use crate::settings::{GradientMethod, Interp};
use crate::shade::Lighting;
use glam::Vec3;
use volindex::MajorantIndex;

/// Code to run with a fully specialised integrator.
pub trait IntegratorVisitor {
    /// What the visit returns.
    type Output;
    /// Run with the integrator.
    fn visit<I: Integrator>(self, integrator: I) -> Self::Output;
}

/// A frame's classifier, either kind.
#[derive(Clone, Copy)]
pub enum ClassifierRef<'a> {
    /// Over the value.
    OneD(&'a TfTable),
    /// Over value and gradient magnitude.
    TwoD(&'a TfTable2d),
}

/// The choices of a DVR frame.
pub struct DvrPlan<'a> {
    /// Sample placement.
    pub geom: FrameGeometry,
    /// Reconstruction.
    pub interp: Interp,
    /// Gradient method (for shading and 2D classification).
    pub gradient: GradientMethod,
    /// The classifier.
    pub classifier: ClassifierRef<'a>,
    /// Blinn-Phong shading, if the frame is shaded.
    pub shading: Option<PhongShading<'a>>,
    /// Early termination threshold, if rays stop early.
    pub termination: Option<f32>,
    /// Transparent cells to skip, if skipping is on.
    pub skip: Option<&'a FixedCells<'a>>,
    /// Shadows and ambient occlusion, if the frame has either (needs
    /// shading).
    pub effects: Option<DvrEffects<'a>>,
}

/// What a DVR frame's effects need.
#[derive(Clone, Copy)]
pub struct DvrEffects<'a> {
    /// Whether the frame casts shadows.
    pub shadows: bool,
    /// Ambient occlusion, if the frame asks for it.
    pub ao: Option<&'a AoSource<'a>>,
    /// The classifier as optical depth per shadow step (the same kind as
    /// the frame's classifier).
    pub depth: ClassifierRef<'a>,
    /// Cells clear for shadow rays, if skipping is on.
    pub skip: Option<&'a FixedCells<'a>>,
    /// Shadow-ray sample placement (the shadow step).
    pub geom: FrameGeometry,
    /// The far corner of the volume's box.
    pub hi: Vec3,
    /// Per light: its transmittance grid, or `None` for shadow rays.
    pub grids: &'a [Option<LightGrid>],
    /// Per light: where a shadow ray's way to it becomes clear, if known.
    pub skies: &'a [Option<OpenSky>],
    /// The lights.
    pub lighting: &'a Lighting,
    /// Squared gradient length above which samples get a normal.
    pub threshold2: f32,
}

/// Run `v` with the DVR integrator for `p`.
pub fn dvr<V: IntegratorVisitor>(p: DvrPlan<'_>, v: V) -> V::Output {
    match p.interp {
        Interp::Trilinear => dvr_skip::<Trilinear, V>(p, v),
        Interp::Nearest => dvr_skip::<Nearest, V>(p, v),
    }
}

fn dvr_skip<R: Reconstruct, V: IntegratorVisitor>(p: DvrPlan<'_>, v: V) -> V::Output {
    match p.skip {
        Some(a) => dvr_term::<R, _, V>(&p, a, v),
        None => dvr_term::<R, _, V>(&p, NoSkipping, v),
    }
}

fn dvr_term<R, A, V>(p: &DvrPlan<'_>, a: A, v: V) -> V::Output
where
    R: Reconstruct,
    A: crate::accel::Accel<()>,
    V: IntegratorVisitor,
{
    match p.termination {
        Some(t) => dvr_parts::<R, _, _, V>(p, a, OpacityThreshold(t), v),
        None => dvr_parts::<R, _, _, V>(p, a, NoTermination, v),
    }
}

fn dvr_parts<R, A, T, V>(p: &DvrPlan<'_>, a: A, t: T, v: V) -> V::Output
where
    R: Reconstruct,
    A: crate::accel::Accel<()>,
    T: Termination,
    V: IntegratorVisitor,
{
    use ClassifierRef::{OneD, TwoD};
    use GradientMethod::{Analytic as A_, Central as C_};
    match (p.classifier, p.shading) {
        // Unshaded, 1D: no gradient, whatever the method.
        (OneD(k), None) => go::<R, NoGradient, _, _, _, _, V>(p, k, Unshaded, t, a, v),
        (OneD(k), Some(_)) if p.effects.is_some() => {
            let sh = p.effects.as_ref().and_then(|sh| match sh.depth {
                OneD(d) => Some((sh, d)),
                TwoD(_) => None,
            });
            match sh {
                Some((sh, d)) => dvr_shadowed::<R, _, T, A, V>(p, k, d, sh, t, a, v),
                None => unreachable!("shadow tables are built with the classifier"),
            }
        }
        (TwoD(k), Some(_)) if p.effects.is_some() => {
            let sh = p.effects.as_ref().and_then(|sh| match sh.depth {
                TwoD(d) => Some((sh, d)),
                OneD(_) => None,
            });
            match sh {
                Some((sh, d)) => dvr_shadowed::<R, _, T, A, V>(p, k, d, sh, t, a, v),
                None => unreachable!("shadow tables are built with the classifier"),
            }
        }
        (OneD(k), Some(s)) => dvr_shaded::<R, _, T, A, V>(p, k, s, t, a, v),
        (TwoD(k), None) => match p.gradient {
            C_ => go::<R, Central, _, _, _, _, V>(p, k, Unshaded, t, a, v),
            A_ => go::<R, Analytic, _, _, _, _, V>(p, k, Unshaded, t, a, v),
        },
        (TwoD(k), Some(s)) => dvr_shaded::<R, _, T, A, V>(p, k, s, t, a, v),
    }
}

fn dvr_shaded<R, K, T, A, V>(
    p: &DvrPlan<'_>,
    k: &K,
    s: PhongShading<'_>,
    t: T,
    a: A,
    v: V,
) -> V::Output
where
    R: Reconstruct,
    K: Classifier,
    T: Termination,
    A: crate::accel::Accel<()>,
    V: IntegratorVisitor,
{
    use GradientMethod::{Analytic as A_, Central as C_};
    match (s, p.gradient) {
        (PhongShading::OneLight(s), C_) => go::<R, Central, _, _, _, _, V>(p, k, s, t, a, v),
        (PhongShading::OneLight(s), A_) => go::<R, Analytic, _, _, _, _, V>(p, k, s, t, a, v),
        (PhongShading::Lights(s), C_) => go::<R, Central, _, _, _, _, V>(p, k, s, t, a, v),
        (PhongShading::Lights(s), A_) => go::<R, Analytic, _, _, _, _, V>(p, k, s, t, a, v),
    }
}

/// Shaded DVR with effects: the gradient method chosen, the shadow caster
/// built over the depth table `d` (of the classifier's kind) when the
/// frame casts shadows.
fn dvr_shadowed<R, K, T, A, V>(
    p: &DvrPlan<'_>,
    k: &K,
    d: &K,
    sh: &DvrEffects<'_>,
    t: T,
    a: A,
    v: V,
) -> V::Output
where
    R: Reconstruct,
    K: Classifier,
    T: Termination,
    A: crate::accel::Accel<()>,
    V: IntegratorVisitor,
{
    fn with<R, G, K, T, A, V>(
        p: &DvrPlan<'_>,
        k: &K,
        d: &K,
        sh: &DvrEffects<'_>,
        t: T,
        a: A,
        v: V,
    ) -> V::Output
    where
        R: Reconstruct,
        G: Gradient,
        K: Classifier,
        T: Termination,
        A: crate::accel::Accel<()>,
        V: IntegratorVisitor,
    {
        let occ = Classified::<R, G, K>::new(d, sh.geom.locator, sh.geom.inv_spacing);
        let caster = ShadowCaster::new(occ, sh.skip, sh.geom, sh.hi, sh.grids, 0.0)
            .with_open_skies(sh.skies);
        let caster = sh.shadows.then_some(&caster);
        let s = EffectsPhong::new(sh.lighting, sh.threshold2, caster, sh.ao);
        go::<R, G, _, _, _, _, V>(p, k, s, t, a, v)
    }
    match p.gradient {
        GradientMethod::Central => with::<R, Central, K, T, A, V>(p, k, d, sh, t, a, v),
        GradientMethod::Analytic => with::<R, Analytic, K, T, A, V>(p, k, d, sh, t, a, v),
    }
}

/// Run `v` with the DVR integrator of fully chosen parts.
fn go<R, G, K, S, T, A, V>(p: &DvrPlan<'_>, k: &K, s: S, t: T, a: A, v: V) -> V::Output
where
    R: Reconstruct,
    G: Gradient,
    K: Classifier,
    S: Shading,
    T: Termination,
    A: crate::accel::Accel<()>,
    V: IntegratorVisitor,
{
    v.visit(Dvr::<R, G, K, S, T, A>::new(p.geom, k, s, t, a))
}

/// The choices of a MIP or MinIP frame.
pub struct MipPlan<'a> {
    /// Sample placement.
    pub geom: FrameGeometry,
    /// Reconstruction.
    pub interp: Interp,
    /// Maximum (MIP) or minimum (MinIP).
    pub maximum: bool,
    /// Whether rays stop at the volume's extreme.
    pub stop_at_extreme: bool,
    /// The volume's largest (MIP) or smallest (MinIP) value.
    pub extreme: f32,
    /// The index to skip with, if skipping is on.
    pub skip: Option<&'a MajorantIndex>,
}

/// Run `v` with the MIP or MinIP integrator for `p`.
pub fn mip<V: IntegratorVisitor>(p: MipPlan<'_>, v: V) -> V::Output {
    match p.interp {
        Interp::Trilinear => mip_dir::<Trilinear, V>(p, v),
        Interp::Nearest => mip_dir::<Nearest, V>(p, v),
    }
}

fn mip_dir<R: Reconstruct, V: IntegratorVisitor>(p: MipPlan<'_>, v: V) -> V::Output {
    let (g, s, e) = (p.geom, p.stop_at_extreme, p.extreme);
    match (p.maximum, p.skip) {
        (true, Some(ix)) => v.visit(Mip::<R, Maximum, _>::new(g, RunningMax::new(ix), s, e)),
        (true, None) => v.visit(Mip::<R, Maximum, _>::new(g, NoSkipping, s, e)),
        (false, Some(ix)) => v.visit(Mip::<R, Minimum, _>::new(g, RunningMin::new(ix), s, e)),
        (false, None) => v.visit(Mip::<R, Minimum, _>::new(g, NoSkipping, s, e)),
    }
}

/// The choices of an X-ray frame.
pub struct XrayPlan<'a> {
    /// Sample placement.
    pub geom: FrameGeometry,
    /// Reconstruction.
    pub interp: Interp,
    /// Sum or mean.
    pub output: XrayOutput,
    /// Zero cells to skip, if skipping is on.
    pub skip: Option<&'a FixedCells<'a>>,
}

/// Run `v` with the X-ray integrator for `p`.
pub fn xray<V: IntegratorVisitor>(p: XrayPlan<'_>, v: V) -> V::Output {
    fn go<R: Reconstruct, V: IntegratorVisitor>(p: XrayPlan<'_>, v: V) -> V::Output {
        match p.skip {
            Some(a) => v.visit(Xray::<R, _>::new(p.geom, a, p.output)),
            None => v.visit(Xray::<R, _>::new(p.geom, NoSkipping, p.output)),
        }
    }
    match p.interp {
        Interp::Trilinear => go::<Trilinear, V>(p, v),
        Interp::Nearest => go::<Nearest, V>(p, v),
    }
}

/// The choices of an iso-surface frame.
pub struct IsoPlan<'a> {
    /// Sample placement.
    pub geom: FrameGeometry,
    /// Reconstruction.
    pub interp: Interp,
    /// Gradient method for the surface normal.
    pub gradient: GradientMethod,
    /// The iso value.
    pub level: f32,
    /// Linear surface colour.
    pub colour: Vec3,
    /// Light and reflection model.
    pub lighting: &'a Lighting,
    /// Uniform cells to skip, if skipping is on.
    pub skip: Option<&'a IsoSides<'a>>,
    /// Shadows, if the frame casts them.
    pub shadows: Option<IsoShadows<'a>>,
    /// Ambient occlusion, if the frame asks for it.
    pub ao: Option<&'a AoSource<'a>>,
}

/// What an iso frame's shadows need (shadow rays skip with the frame's
/// [`IsoSides`]).
#[derive(Clone, Copy)]
pub struct IsoShadows<'a> {
    /// Shadow-ray sample placement (the shadow step).
    pub geom: FrameGeometry,
    /// The far corner of the volume's box.
    pub hi: Vec3,
    /// Per light: its transmittance grid, or `None` for shadow rays.
    pub grids: &'a [Option<LightGrid>],
    /// Voxels along the light a grid read moves off the surface.
    pub grid_offset: f32,
}

/// Run `v` with the iso-surface integrator for `p`.
pub fn iso<V: IntegratorVisitor>(p: IsoPlan<'_>, v: V) -> V::Output {
    fn go<R: Reconstruct, G: Gradient, V: IntegratorVisitor>(p: IsoPlan<'_>, v: V) -> V::Output {
        let caster = p.shadows.map(|sh| {
            let occ = IsoInside::<R>::new(p.level, sh.geom.locator);
            ShadowCaster::new(occ, p.skip, sh.geom, sh.hi, sh.grids, sh.grid_offset)
        });
        let caster = caster.as_ref();
        match p.skip {
            Some(a) => v.visit(Iso::<R, G, _>::new(
                p.geom, a, p.level, p.colour, p.lighting, caster, p.ao,
            )),
            None => v.visit(Iso::<R, G, _>::new(
                p.geom, NoSkipping, p.level, p.colour, p.lighting, caster, p.ao,
            )),
        }
    }
    match (p.interp, p.gradient) {
        (Interp::Trilinear, GradientMethod::Central) => go::<Trilinear, Central, V>(p, v),
        (Interp::Trilinear, GradientMethod::Analytic) => go::<Trilinear, Analytic, V>(p, v),
        (Interp::Nearest, GradientMethod::Central) => go::<Nearest, Central, V>(p, v),
        (Interp::Nearest, GradientMethod::Analytic) => go::<Nearest, Analytic, V>(p, v),
    }
}
