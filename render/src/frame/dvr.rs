//! A DVR frame's set-up: the classifier's tables for the frame's step,
//! the cells they make transparent (for skipping and for culling pixel
//! blocks), the effects' parts (depth table, light grids, occlusion), and
//! the one concrete integrator the frame's choices make, handed to the
//! tile loop.
//!
//! The choices that become types are matched here once per frame, in
//! this order: the classifier's kind ([`Tables`]), then the gradient
//! method and shading together. Everything else (the reconstruction,
//! termination, skipping, the lights, shadows and occlusion) is a value.

use super::effects::{ao_parts, light_grids, open_skies, shadow_geometry};
use super::FrameInputs;
use crate::accel::{cull, FixedCells};
use crate::classify::{Classifier, GradientBound, TfTable, TfTable2d};
use crate::effects::{Classified, ShadowCaster};
use crate::error::RenderError;
use crate::film::{EffectStats, Film};
use crate::integrator::dvr::shading::{DvrCaster, Phong, Shading, Unshaded};
use crate::integrator::Dvr;
use crate::settings::GradientMethod;
use crate::tf::Tf;
use crate::tiles::Tiles;
use crate::trace::reconstruct::{Analytic, Central, Gradient, NoGradient};
use glam::Vec3;
use volcore::Volume;
use volindex::MinMaxIndex;

/// The gradient a classifier has samples read when the frame's method is
/// `G` but nothing else asks for one (an unshaded frame, a shadow sample):
/// none for tables over the value alone, `G` for tables that classify by
/// gradient magnitude. One rule for view rays and shadow rays, so a frame
/// that needs no gradient never reads one.
pub trait ReadGradient: Classifier {
    /// The gradient read.
    type Of<G: Gradient>: Gradient;
}

impl ReadGradient for TfTable {
    type Of<G: Gradient> = NoGradient;
}

impl ReadGradient for TfTable2d {
    type Of<G: Gradient> = G;
}

/// What blocks light in a DVR frame with gradient method `G` and
/// classifier `K`: the classified volume, reading the gradient `K` needs.
pub type DvrOccluder<'a, G, K> = Classified<'a, <K as ReadGradient>::Of<G>, K>;

/// A DVR frame's classifier tables, of the transfer function's kind: for
/// the view step, and for the shadow step when the frame has effects.
pub enum Tables {
    /// Over the value.
    OneD {
        /// For view samples.
        view: TfTable,
        /// For shadow and occlusion samples.
        shadow: Option<TfTable>,
    },
    /// Over value and gradient magnitude.
    TwoD {
        /// For view samples.
        view: TfTable2d,
        /// For shadow and occlusion samples.
        shadow: Option<TfTable2d>,
    },
}

impl Tables {
    /// The tables of `tf` for `step` (and `shadow_step`) over the transfer
    /// function's domain, or the volume's value `range`.
    pub fn new(
        vol: &Volume,
        tf: &Tf,
        range: (f32, f32),
        step: f32,
        shadow_step: Option<f32>,
    ) -> Tables {
        let (lo, hi) = tf.domain().unwrap_or(range);
        let hi = if hi > lo { hi } else { lo + 1.0 };
        let bins = TfTable::default_bins(lo, hi);
        match tf {
            Tf::OneD(t) => {
                let table = |step| TfTable::new(t, lo, hi, bins, step);
                Tables::OneD {
                    view: table(step),
                    shadow: shadow_step.map(table),
                }
            }
            Tf::TwoD(t) => {
                let glimit = (hi - lo) / vol.meta.min_spacing();
                let (glo, ghi) = t.gradient_domain.unwrap_or((0.0, glimit));
                let ghi = if ghi > glo { ghi } else { glo + 1.0 };
                let table = |step| {
                    TfTable2d::new(
                        t,
                        (lo, hi),
                        bins,
                        (glo, ghi),
                        crate::classify::table2d::GRADIENT_BINS,
                        step,
                    )
                };
                Tables::TwoD {
                    view: table(step),
                    shadow: shadow_step.map(table),
                }
            }
        }
    }

    /// Per finest-level cell of `index`: whether the view table can show
    /// a sample there (the cells it does not make transparent).
    pub fn busy_cells(
        &self,
        index: &MinMaxIndex,
        gradients: &GradientBound,
    ) -> Result<Vec<bool>, RenderError> {
        let mut levels = match self {
            Tables::OneD { view, .. } => view.transparent_cells(index, gradients)?,
            Tables::TwoD { view, .. } => view.transparent_cells(index, gradients)?,
        };
        let finest = if levels.is_empty() {
            Vec::new()
        } else {
            levels.swap_remove(0)
        };
        Ok(finest.into_iter().map(|clear| !clear).collect())
    }
}

/// Render a DVR frame: refused without a transfer function; its
/// classifier tables (over the transfer function's domain, or the
/// volume's value range when it gives none), then the frame traced with
/// the integrator of the frame's choices.
pub fn render_frame(inputs: &FrameInputs<'_>) -> Result<Film, RenderError> {
    let tf = inputs
        .tf
        .ok_or_else(|| RenderError::Setting("DVR needs a transfer function".into()))?;
    DvrFrame { inputs, tf }.render()
}

/// A DVR frame before its types are chosen: what every frame has, and
/// its transfer function.
struct DvrFrame<'a> {
    /// The frame's volume, index, settings, sample placement and pixels.
    inputs: &'a FrameInputs<'a>,
    /// The transfer function.
    tf: &'a Tf,
}

/// The parts of a DVR frame shared by every choice of types.
struct Parts<'a, K> {
    /// The classifier at the view step.
    table: &'a K,
    /// The same classifier at the shadow step, when the frame has effects.
    shadow: Option<&'a K>,
    /// The cells view rays skip, when skipping is on.
    skip: Option<&'a FixedCells<'a>>,
    /// Squared gradient length above which a sample gets a normal.
    threshold2: f32,
    /// How long gradients can be, for the skipping rules.
    gradients: GradientBound,
    /// The frame's pixels (with its culled blocks).
    tiles: Tiles<'a>,
}

impl DvrFrame<'_> {
    /// Render the frame.
    fn render(&self) -> Result<Film, RenderError> {
        let s = self.inputs.settings;
        // Effects apply to shaded samples only (checked before); their
        // tables are made for the shadow step.
        let effects = s.shading && (s.shadows.is_some() || s.ao.is_some());
        let shadow_step =
            effects.then(|| shadow_geometry(&self.inputs.geom, s.shadows.as_ref()).step);
        match Tables::new(
            self.inputs.vol,
            self.tf,
            self.inputs.range,
            s.step,
            shadow_step,
        ) {
            Tables::OneD { view, shadow } => self.classified(&view, shadow.as_ref()),
            Tables::TwoD { view, shadow } => self.classified(&view, shadow.as_ref()),
        }
    }

    /// Render with classifier `table` (and `shadow`, the same at the
    /// shadow step, with effects): its transparent cells, the pixel blocks
    /// whose rays meet none of the others, then the reconstruction.
    fn classified<K: ReadGradient>(
        &self,
        table: &K,
        shadow: Option<&K>,
    ) -> Result<Film, RenderError> {
        let s = self.inputs.settings;
        let value_span = (self.inputs.range.1 - self.inputs.range.0).max(f32::MIN_POSITIVE);
        // Compared with squared lengths; never below 0, so a zero gradient
        // is never normalised.
        let threshold2 = (s.gradient_threshold * value_span).max(0.0).powi(2);
        let gradients = GradientBound {
            method: s.gradient,
            inv_spacing: self.inputs.geom.inv_spacing,
        };
        let skip = transparent_cells(self.inputs.skip_index, table, &gradients)?;
        // Pixel blocks whose rays meet no cell the rule keeps are not
        // traced (their pixels are empty either way).
        let tiles = self.inputs.tiles;
        let busy = skip.as_ref().and_then(|c| {
            cull::busy_blocks(
                tiles.camera,
                c.index(),
                Vec3::from(self.inputs.vol.meta.spacing),
                tiles.share.map(|b| b.clipped(tiles.hi)),
                |level, cell| !c.skippable(level, cell),
            )
        });
        let parts = Parts {
            table,
            shadow,
            skip: skip.as_ref(),
            threshold2,
            gradients,
            tiles: Tiles {
                busy: busy.as_ref(),
                ..tiles
            },
        };
        let mut film = self.shaded::<K>(&parts)?;
        film.set_culled_blocks(busy.as_ref().map_or(0, |b| b.culled()) as u64);
        Ok(film)
    }

    /// Render with classifier `K`: the gradient method and shading.
    fn shaded<K: ReadGradient>(&self, parts: &Parts<'_, K>) -> Result<Film, RenderError> {
        use GradientMethod as M;
        match (self.inputs.settings.shading, self.inputs.settings.gradient) {
            // A 1D table reads no gradient: both arms are one type.
            (false, M::Central) => self.trace::<K::Of<Central>, K, _>(parts, Unshaded),
            (false, M::Analytic) => self.trace::<K::Of<Analytic>, K, _>(parts, Unshaded),
            (true, M::Central) => self.lit::<Central, K>(parts),
            (true, M::Analytic) => self.lit::<Analytic, K>(parts),
        }
    }

    /// Render shaded, with gradient method `G`: Blinn-Phong, with the
    /// frame's shadows and occlusion when it has them, through its
    /// occluder.
    fn lit<G: Gradient, K: ReadGradient>(&self, parts: &Parts<'_, K>) -> Result<Film, RenderError> {
        let s = self.inputs.settings;
        let Some(alpha) = parts.shadow else {
            let phong = Phong::<DvrOccluder<G, K>>::new(&s.lighting, parts.threshold2, None, None);
            return self.trace::<G, K, _>(parts, phong);
        };
        let sgeom = shadow_geometry(&self.inputs.geom, s.shadows.as_ref());
        let depth = alpha.to_optical_depth();
        let occ = DvrOccluder::<G, K>::new(&depth, &sgeom);
        // Cells clear for shadow and occlusion rays.
        let clear = transparent_cells(self.inputs.skip_index, alpha, &parts.gradients)?;
        let boxes = clear.as_ref().map(|c| c.clear_boxes());
        let lights = &s.lighting.lights;
        let (grids, mut stats) = match &s.shadows {
            Some(sh) => light_grids(
                self.inputs.vol,
                lights,
                sh,
                sgeom.step,
                &occ,
                (),
                boxes.as_ref(),
            )?,
            None => (Vec::new(), EffectStats::default()),
        };
        let ao = match &s.ao {
            Some(ao) => Some(ao_parts(
                self.inputs.vol,
                ao,
                sgeom.step,
                &occ,
                (),
                boxes.as_ref(),
                &mut stats,
            )?),
            None => None,
        };
        // Shadow rays toward a distant light stop where the rest of their
        // way is clear.
        let skies = match &s.shadows {
            Some(_) => open_skies(lights, &grids, clear.as_ref(), &sgeom),
            None => Vec::new(),
        };
        let hi = parts.tiles.hi;
        let min_spacing = self.inputs.vol.meta.min_spacing();
        let ao_source = ao.as_ref().map(|a| a.source(hi, 1.0, min_spacing));
        let caster: DvrCaster<'_, _> =
            ShadowCaster::new(occ, clear.as_ref(), sgeom, hi, &grids, 0.0).with_open_skies(&skies);
        let caster = s.shadows.is_some().then_some(&caster);
        let phong = Phong::new(&s.lighting, parts.threshold2, caster, ao_source.as_ref());
        let mut film = self.trace::<G, K, _>(parts, phong)?;
        film.add_grid_stats(&stats);
        Ok(film)
    }

    /// Trace the frame with the integrator of these types.
    fn trace<G: Gradient, K: Classifier, S: Shading>(
        &self,
        parts: &Parts<'_, K>,
        shading: S,
    ) -> Result<Film, RenderError> {
        let dvr = Dvr::<G, K, S>::new(
            self.inputs.geom,
            parts.table,
            shading,
            self.inputs.settings.ert,
            parts.skip,
        );
        parts.tiles.render(self.inputs.vol, &dvr)
    }
}

/// The cells `classifier` makes transparent, as a skipping rule, when
/// skipping is on.
pub fn transparent_cells<'a>(
    index: Option<&'a MinMaxIndex>,
    classifier: &impl Classifier,
    gradients: &GradientBound,
) -> Result<Option<FixedCells<'a>>, RenderError> {
    index
        .map(|ix| {
            classifier
                .transparent_cells(ix, gradients)
                .map(|flags| FixedCells::transparent(ix, flags))
        })
        .transpose()
}

// Checked when the crate compiles. Bug: with analytic gradients and a 1D
// table, shadow rays read the gradient the table ignores and lost the
// 8-lane march; `ReadGradient` now gives view and shadow rays their
// gradient by one rule.
const _: () = {
    use crate::effects::Occluder;
    assert!(<DvrOccluder<'static, Analytic, TfTable> as Occluder>::FROM_VALUE);
    assert!(<DvrOccluder<'static, Central, TfTable> as Occluder>::FROM_VALUE);
    assert!(!<DvrOccluder<'static, Analytic, TfTable2d> as Occluder>::FROM_VALUE);
    assert!(!<DvrOccluder<'static, Central, TfTable2d> as Occluder>::FROM_VALUE);
};
