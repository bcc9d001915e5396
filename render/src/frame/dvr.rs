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
use crate::accel::skip::SkipFlags;
use crate::accel::strides::stride_log2s;
use crate::accel::{cull, FixedCells};
use crate::classify::pairs::DEFAULT_PAIR_BINS;
use crate::classify::{Classifier, GradientBound, PairTable, TfTable, TfTable2d};
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

impl ReadGradient for PairTable {
    type Of<G: Gradient> = NoGradient;
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
    /// Over pairs of values, pre-integrated for the view step; shadow and
    /// occlusion samples are classified one by one.
    PreIntegrated {
        /// For view samples.
        view: PairTable,
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
    /// function's domain, or the volume's value `range`; the view table
    /// pre-integrated when `preintegrated` (1D transfer functions only).
    pub fn new(
        vol: &Volume,
        tf: &Tf,
        range: (f32, f32),
        step: f32,
        shadow_step: Option<f32>,
        preintegrated: bool,
    ) -> Result<Tables, RenderError> {
        let (lo, hi) = tf.domain().unwrap_or(range);
        let hi = if hi > lo { hi } else { lo + 1.0 };
        let bins = TfTable::default_bins(lo, hi);
        Ok(match tf {
            Tf::OneD(t) if preintegrated => {
                let pair_bins = PairTable::default_bins(lo, hi, DEFAULT_PAIR_BINS);
                Tables::PreIntegrated {
                    view: PairTable::new(t, lo, hi, pair_bins, step),
                    shadow: shadow_step.map(|step| TfTable::new(t, lo, hi, bins, step)),
                }
            }
            Tf::TwoD(_) if preintegrated => return Err(not_pre_integrated()),
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
        })
    }

    /// The tables' memory, bytes.
    pub fn bytes(&self) -> u64 {
        let n = match self {
            Tables::OneD { view, shadow } => view.bins() + shadow.as_ref().map_or(0, |t| t.bins()),
            Tables::PreIntegrated { view, shadow } => {
                // The pairs, and the single and half-step tables.
                view.bins() * (view.bins() + 2) + shadow.as_ref().map_or(0, |t| t.bins())
            }
            Tables::TwoD { view, shadow } => {
                view.entries() + shadow.as_ref().map_or(0, |t| t.entries())
            }
        };
        (n * std::mem::size_of::<[f32; 4]>()) as u64
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
            Tables::PreIntegrated { view, .. } => view.transparent_cells(index, gradients)?,
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

/// Why a 2D transfer function is not pre-integrated.
pub fn not_pre_integrated() -> RenderError {
    RenderError::Setting(
        "pre-integration is for 1D transfer functions: a 2D one classifies by gradient \
         magnitude too, and a table over pairs of (value, gradient) would have four \
         dimensions"
            .into(),
    )
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

/// The parts of a DVR frame shared by every choice of types: view
/// samples are classified by `V`, shadow and occlusion samples by `K`.
struct Parts<'a, V, K> {
    /// The classifier at the view step.
    table: &'a V,
    /// The shadow samples' classifier at the shadow step, when the frame
    /// has effects.
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
        let start = std::time::Instant::now();
        let tables = Tables::new(
            self.inputs.vol,
            self.tf,
            self.inputs.range,
            s.step,
            shadow_step,
            s.preintegrated,
        )?;
        let (table_s, table_bytes) = (start.elapsed().as_secs_f64(), tables.bytes());
        let mut film = match tables {
            Tables::OneD { view, shadow } => self.classified(&view, shadow.as_ref()),
            Tables::PreIntegrated { view, shadow } => self.classified(&view, shadow.as_ref()),
            Tables::TwoD { view, shadow } => self.classified(&view, shadow.as_ref()),
        }?;
        film.add_table(table_s, table_bytes);
        Ok(film)
    }

    /// Render with classifier `table` (and `shadow`, the classifier of
    /// shadow samples at the shadow step, with effects): its transparent
    /// cells, the pixel blocks whose rays meet none of the others, then
    /// the reconstruction.
    fn classified<V: ReadGradient, K: ReadGradient>(
        &self,
        table: &V,
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
        let start = std::time::Instant::now();
        let skip = match s.adaptive {
            Some(tol) => Some(adaptive_cells(self.inputs, table, &gradients, tol)?),
            None => transparent_cells(self.inputs.skip_index, table, &gradients)?,
        };
        // Adaptive steps' strides count with the tables: what a change of
        // transfer function or step costs.
        let (strides_s, strides_bytes) = skip
            .as_ref()
            .and_then(|c| c.strides())
            .map_or((0.0, 0), |st| {
                (start.elapsed().as_secs_f64(), st.len() as u64)
            });
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
        let mut film = self.shaded(&parts)?;
        film.set_culled_blocks(busy.as_ref().map_or(0, |b| b.culled()) as u64);
        film.add_table(strides_s, strides_bytes);
        Ok(film)
    }

    /// Render with classifiers `V` and `K`: the gradient method and
    /// shading.
    fn shaded<V: ReadGradient, K: ReadGradient>(
        &self,
        parts: &Parts<'_, V, K>,
    ) -> Result<Film, RenderError> {
        use GradientMethod as M;
        match (self.inputs.settings.shading, self.inputs.settings.gradient) {
            // A 1D table reads no gradient: both arms are one type.
            (false, M::Central) => self.trace::<V::Of<Central>, V, K, _>(parts, Unshaded),
            (false, M::Analytic) => self.trace::<V::Of<Analytic>, V, K, _>(parts, Unshaded),
            (true, M::Central) => self.lit::<Central, V, K>(parts),
            (true, M::Analytic) => self.lit::<Analytic, V, K>(parts),
        }
    }

    /// Render shaded, with gradient method `G`: Blinn-Phong, with the
    /// frame's shadows and occlusion when it has them, through its
    /// occluder.
    fn lit<G: Gradient, V: ReadGradient, K: ReadGradient>(
        &self,
        parts: &Parts<'_, V, K>,
    ) -> Result<Film, RenderError> {
        let s = self.inputs.settings;
        let Some(alpha) = parts.shadow else {
            let phong = Phong::<DvrOccluder<G, K>>::new(&s.lighting, parts.threshold2, None, None);
            return self.trace::<G, V, K, _>(parts, phong);
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
        let mut film = self.trace::<G, V, K, _>(parts, phong)?;
        film.add_grid_stats(&stats);
        Ok(film)
    }

    /// Trace the frame with the integrator of these types.
    fn trace<G: Gradient, V: Classifier, K, S: Shading>(
        &self,
        parts: &Parts<'_, V, K>,
        shading: S,
    ) -> Result<Film, RenderError> {
        let dvr = Dvr::<G, V, S>::new(
            self.inputs.geom,
            parts.table,
            shading,
            self.inputs.settings.ert,
            parts.skip,
        );
        parts.tiles.render(self.inputs.vol, &dvr)
    }
}

/// The most level-0 cells whose transparent flags and distances an index
/// keeps between frames (at most about 10 bytes a cell for each of
/// [`volindex::memo::SLOTS`] tables; a 1280³ volume's 4 M cells of edge
/// 8): past it every frame classifies afresh, as it did before.
pub const MEMO_MAX_CELLS: usize = 1 << 22;

/// The cells `classifier` makes transparent, as a skipping rule, when
/// skipping is on (kept with the index for the next frame with the same
/// table: see [`MEMO_MAX_CELLS`]).
pub fn transparent_cells<'a>(
    index: Option<&'a MinMaxIndex>,
    classifier: &impl Classifier,
    gradients: &GradientBound,
) -> Result<Option<FixedCells<'a>>, RenderError> {
    index
        .map(|ix| {
            let classify = || {
                classifier
                    .transparent_cells(ix, gradients)
                    .map(|flags| SkipFlags::transparent(ix, flags))
            };
            let small = ix
                .levels()
                .first()
                .is_some_and(|l| l.len() <= MEMO_MAX_CELLS);
            let cells = match classifier.cells_key(gradients).filter(|_| small) {
                // Kept with the index: the next frame with the same table
                // (a viewer's, a probe's, `--repeat`'s) reuses the flags
                // and the distance tables they made.
                Some(key) => ix.memo(key, classify)?,
                None => std::sync::Arc::new(classify()?),
            };
            Ok(FixedCells::shared(ix, cells))
        })
        .transpose()
}

/// The cells view rays walk with adaptive steps under tolerance `tol`
/// (optical depth per unit length): every level-0 cell's stride from how
/// much `classifier` can change over its range, the transparent cells
/// skipped when skipping is on (and looked up sample by sample when it is
/// off, see [`crate::accel::strides`]).
fn adaptive_cells<'a>(
    inputs: &FrameInputs<'a>,
    classifier: &impl Classifier,
    gradients: &GradientBound,
    tol: f32,
) -> Result<FixedCells<'a>, RenderError> {
    let index = inputs.index.ok_or_else(|| {
        RenderError::Setting("adaptive steps need the volume's index (its cells' ranges)".into())
    })?;
    let variation = classifier.variation().ok_or_else(not_adaptive)?;
    let flags = classifier.transparent_cells(index, gradients)?;
    let finest = flags.first().map_or(&[][..], Vec::as_slice);
    let cell_length = index.cell_edge() as f32 * inputs.vol.meta.min_spacing();
    let strides = stride_log2s(index, &variation, finest, tol, cell_length);
    let cells = if inputs.skip_index.is_some() {
        FixedCells::transparent(index, flags)
    } else {
        FixedCells::none(index)
    };
    Ok(cells.with_strides(strides))
}

/// Why a frame's classifier takes no adaptive steps.
pub fn not_adaptive() -> RenderError {
    RenderError::Setting(
        "adaptive steps are for 1D transfer functions without pre-integration: they bound \
         how fast a cell's classification can change from its value range alone"
            .into(),
    )
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
