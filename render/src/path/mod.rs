//! Monte Carlo volumetric path tracing over the index's majorant grid.
//!
//! The pieces, each in its module: the [`medium`] (extinction and albedo
//! from a density mapping or a transfer function, and its majorants per
//! macrocell), [`tracking`] (delta tracking for free flights, ratio
//! tracking for transmittance, both over the DDA segments of the majorant
//! grid), the Henyey-Greenstein [`phase`] function, the per-sample
//! [`estimator`] (next-event estimation toward suns and point lights,
//! environment light where paths escape, Russian roulette), the
//! importance-sampled [`envmap`]. Passes add their samples to the path
//! tracer's film ([`crate::film::PathFilm`]: per-pixel f64 sums,
//! resumable from a state file).
//!
//! Every random number is a hash of (seed, pixel, sample index,
//! dimension) ([`crate::sampler`]) and every pixel adds its samples in
//! sample order, so an image is the same bit for bit for any thread
//! count, and a render continued from its state equals one run.
//!
//! Only what the scene asks for runs: no light of a kind, no code for it
//! (no shadow rays without suns or point lights); a medium that cannot
//! scatter runs no scattering code; one bounce runs no multiple-scattering
//! code. The counters ([`PathCounters`]) show it.

pub mod envmap;
pub mod estimator;
pub mod medium;
pub mod phase;
pub mod surface;
pub mod tracking;

pub use crate::sampler::SamplerKind;
pub use envmap::EnvMap;
pub use medium::{DensityMedium, Medium, TableMedium};
pub use tracking::MajorantMode;

use crate::accel::cull::{busy_blocks, BlockMask};
use crate::accel::majorant::MajorantGrid;
use crate::accel::skip::SkipFlags;
use crate::camera::Camera;
use crate::error::RenderError;
use crate::film::{luminance, PathFilm};
use crate::light::Light;
use crate::tf::TransferFunction;
use estimator::Estimator;
use glam::Vec3;
use phase::HenyeyGreenstein;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;
use tracking::Tracker;
use volcore::{Volume, VolumeVisitor, VoxelSource};
use volindex::MinMaxIndex;

/// Bytes a path-traced frame needs per pixel, for the frame-memory check
/// ([`crate::frame::check::memory`]): the film's f64 sums, the mean image
/// and its encodings.
pub const PATH_BYTES_PER_PIXEL: u64 = 32 + 12 + 12 + 8;

/// The lights of a path-traced scene: the ray caster's light model
/// ([`Light`], one direction convention: `towards` points from the scene
/// to the light), less the headlight, which lights nothing a path tracer
/// sees; and the sky.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PathLights {
    /// Directional lights (whose radiance is the irradiance on a surface
    /// facing them) and point lights.
    pub lights: Vec<Light>,
    /// Constant environment radiance, linear RGB (zero: none).
    pub env: Vec3,
    /// An environment map (instead of the constant radiance), sampled at
    /// every scattering event.
    pub env_map: Option<Arc<EnvMap>>,
}

/// What the medium is made of.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumSpec {
    /// `σt = scale × normalised value`, constant albedo.
    Density {
        /// Extinction per world unit at normalised value 1.
        scale: f32,
        /// Albedo, linear RGB in `[0, 1]`.
        albedo: Vec3,
    },
    /// From a 1D transfer function (opacity per unit length and colour).
    Table(TransferFunction),
}

/// How to path-trace a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct PathSettings {
    /// The medium.
    pub medium: MediumSpec,
    /// Scattering events allowed per path (>= 1).
    pub bounces: u32,
    /// Henyey-Greenstein asymmetry.
    pub g: f32,
    /// Hybrid scattering: where the extinction's gradient is steep, an
    /// event reflects off a surface BRDF with probability
    /// `1 − exp(−scale × |∇σt| / max σt)` (per voxel); `None`: the phase
    /// function everywhere.
    pub hybrid: Option<f32>,
    /// Majorant grid or one global majorant.
    pub majorant: MajorantMode,
    /// The lights.
    pub lights: PathLights,
    /// Radiance seen directly where camera rays leave the volume without
    /// scattering (`None`: the environment).
    pub background: Option<Vec3>,
    /// Seed of the sampler.
    pub seed: u64,
    /// The sampler: Owen-scrambled Sobol points or independent hashes.
    pub sampler: SamplerKind,
    /// How shadow rays estimate transmittance.
    pub transmittance: Transmittance,
}

/// How shadow rays (and the camera rays of a medium that only absorbs)
/// estimate transmittance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Transmittance {
    /// Ratio tracking against each cell's majorant.
    Ratio,
    /// Residual ratio tracking: each cell's smallest extinction in closed
    /// form, ratio tracking of the rest.
    #[default]
    Residual,
}

impl Transmittance {
    /// The estimator a name (`ratio` or `residual`) stands for.
    pub fn from_name(name: &str) -> Option<Transmittance> {
        match name {
            "ratio" => Some(Transmittance::Ratio),
            "residual" => Some(Transmittance::Residual),
            _ => None,
        }
    }

    /// The estimator's name.
    pub fn name(self) -> &'static str {
        match self {
            Transmittance::Ratio => "ratio",
            Transmittance::Residual => "residual",
        }
    }
}

/// Most scattering events a path may be allowed.
pub const MAX_BOUNCES: u32 = 1 << 16;

/// What a path-traced frame did, summed over its samples (order
/// independent: every count is a sum of per-sample counts).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathCounters {
    /// Camera samples traced.
    pub paths: u64,
    /// Real collisions (scattering or absorbing events found).
    pub real_collisions: u64,
    /// Null collisions (tentative collisions rejected).
    pub null_collisions: u64,
    /// Macrocells (with a majorant above 0) a tracking call walked.
    pub majorant_cells: u64,
    /// Macrocells crossed one by one without a sample (majorant 0).
    pub empty_cells: u64,
    /// Jumps across blocks of empty macrocells (one each, however many
    /// cells the block holds).
    pub empty_jumps: u64,
    /// Of the camera samples, those in image blocks whose rays meet only
    /// empty cells: the background, not traced.
    pub culled_paths: u64,
    /// Voxel cells walked inside macrocells at the extinction cap (each
    /// with its own majorant; see [`tracking`]).
    pub voxel_cells: u64,
    /// Extinction lookups (trilinear samples).
    pub density_lookups: u64,
    /// Transmittance rays toward lights (and camera rays of an absorbing
    /// medium).
    pub shadow_rays: u64,
    /// Scattering events.
    pub scatter_events: u64,
    /// Of those, events that reflected off a surface (hybrid scattering).
    pub surface_events: u64,
    /// Continuation rays after a scattering event.
    pub bounce_rays: u64,
    /// Extinction lookups at the cap [`crate::accel::majorant::MAX_SIGMA_T`] (infinite or
    /// huge values, an opacity of 1): the medium there is as opaque as
    /// tracking honours.
    pub capped: u64,
    /// Tracking calls cut at [`tracking::MAX_COLLISIONS`].
    pub truncated: u64,
    /// Samples whose estimate was not finite (dropped).
    pub non_finite: u64,
}

impl std::ops::AddAssign for PathCounters {
    fn add_assign(&mut self, o: PathCounters) {
        self.paths += o.paths;
        self.real_collisions += o.real_collisions;
        self.null_collisions += o.null_collisions;
        self.majorant_cells += o.majorant_cells;
        self.empty_cells += o.empty_cells;
        self.empty_jumps += o.empty_jumps;
        self.culled_paths += o.culled_paths;
        self.voxel_cells += o.voxel_cells;
        self.capped += o.capped;
        self.density_lookups += o.density_lookups;
        self.shadow_rays += o.shadow_rays;
        self.scatter_events += o.scatter_events;
        self.surface_events += o.surface_events;
        self.bounce_rays += o.bounce_rays;
        self.truncated += o.truncated;
        self.non_finite += o.non_finite;
    }
}

/// When a progressive render stops (whichever comes first; at least one
/// must be given).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Budget {
    /// Samples per pixel to add.
    pub spp: Option<u64>,
    /// Seconds of rendering (whole passes: the last may run over).
    pub seconds: Option<f64>,
    /// Stop once the relative standard error falls below this.
    pub until_error: Option<f64>,
}

/// Samples per pixel a render adds at most when only `until_error`
/// bounds it.
pub const MAX_SPP: u64 = 1 << 16;

impl PathLights {
    /// The directional lights, in order: toward each (unit) and its
    /// irradiance on a surface facing it.
    pub fn directional(&self) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        self.lights.iter().filter_map(|l| match *l {
            Light::Directional { towards, radiance } => Some((towards, radiance)),
            _ => None,
        })
    }

    /// The point lights, in order: position and intensity.
    pub fn points(&self) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        self.lights.iter().filter_map(|l| match *l {
            Light::Point {
                position,
                intensity,
            } => Some((position, intensity)),
            _ => None,
        })
    }
}

/// The medium resolved for the volume.
enum AnyMedium {
    Density(DensityMedium),
    Table(TableMedium),
}

/// A path tracer set up for one volume, camera and scene: the medium and
/// its majorant grid are built once and serve every pass.
pub struct PathTracer<'a> {
    vol: &'a Volume,
    index: &'a MinMaxIndex,
    camera: &'a Camera,
    settings: &'a PathSettings,
    medium: AnyMedium,
    grid: MajorantGrid,
    blocks: Option<SkipFlags>,
    visible: Option<BlockMask>,
    scatters: bool,
    cancel: crate::settings::Cancel,
}

/// The majorant grid's level: the index's finest.
const GRID_LEVEL: usize = 0;

/// The most grid cells whose empty blocks are measured (a byte per cell
/// and per octant a ray travels in); past it rays cross empty cells one
/// by one.
const MAX_BLOCK_CELLS: u64 = 1 << 26;

impl<'a> PathTracer<'a> {
    /// Check the frame's memory ([`PATH_BYTES_PER_PIXEL`] per pixel of the
    /// camera's image) and the settings, resolve the medium and build its
    /// majorant grid.
    pub fn new(
        vol: &'a Volume,
        index: &'a MinMaxIndex,
        camera: &'a Camera,
        settings: &'a PathSettings,
    ) -> Result<PathTracer<'a>, RenderError> {
        crate::frame::check::memory(camera, PATH_BYTES_PER_PIXEL, "path-traced frame")?;
        index
            .check_volume(vol.dims(), vol.meta.sample_type)
            .map_err(|e| RenderError::Index(e.to_string()))?;
        if !(1..=MAX_BOUNCES).contains(&settings.bounces) {
            return Err(RenderError::Setting(format!(
                "bounces {} must be 1..={MAX_BOUNCES}",
                settings.bounces
            )));
        }
        if !settings.g.is_finite() || settings.g.abs() > 1.0 {
            return Err(RenderError::Setting(format!(
                "g {} must be in [-1, 1]",
                settings.g
            )));
        }
        let l = &settings.lights;
        let radiance_ok = |c: Vec3| c.is_finite() && c.min_element() >= 0.0;
        if l.lights
            .iter()
            .any(|l| matches!(l, Light::Headlight { .. }))
        {
            return Err(RenderError::Setting(
                "a headlight does not light a path-traced scene: give directional or point lights"
                    .into(),
            ));
        }
        if !radiance_ok(l.env)
            || !settings.background.is_none_or(radiance_ok)
            || l.directional()
                .any(|(towards, e)| !radiance_ok(e) || !towards.is_finite())
            || l.points()
                .any(|(position, i)| !radiance_ok(i) || !position.is_finite())
        {
            return Err(RenderError::Setting(
                "light and background radiances must be finite and not negative".into(),
            ));
        }
        if settings.hybrid.is_some_and(|h| !(h.is_finite() && h > 0.0)) {
            return Err(RenderError::Setting(
                "the hybrid gradient scale must be a finite number above 0".into(),
            ));
        }
        if l.env_map.is_some() && l.env != Vec3::ZERO {
            return Err(RenderError::Setting(
                "give a constant environment or an environment map, not both".into(),
            ));
        }
        if vol.meta.world_diagonal().is_none() {
            return Err(RenderError::Setting(
                "the volume's extent is too large for f32 world coordinates".into(),
            ));
        }
        let medium = match &settings.medium {
            MediumSpec::Density { scale, albedo } => {
                AnyMedium::Density(DensityMedium::new(*scale, vol.meta.sample_type, *albedo)?)
            }
            MediumSpec::Table(tf) => {
                let range = if vol.meta.range.is_empty() {
                    (0.0, 0.0)
                } else {
                    (vol.meta.range.min as f32, vol.meta.range.max as f32)
                };
                let (lo, hi) = tf.domain.unwrap_or(range);
                AnyMedium::Table(TableMedium::new(tf, lo, hi))
            }
        };
        let residual = settings.transmittance == Transmittance::Residual;
        let (grid, max_albedo) = match &medium {
            AnyMedium::Density(m) => (controls(m, index, residual)?, m.max_albedo()),
            AnyMedium::Table(m) => (controls(m, index, residual)?, m.max_albedo()),
        };
        let cells = index.level(GRID_LEVEL).cells();
        let grid_mode = settings.majorant == MajorantMode::Grid;
        let blocks = (grid_mode && cells.iter().product::<u64>() <= MAX_BLOCK_CELLS)
            .then(|| SkipFlags::finest(cells, grid.empty_flags()));
        let visible = if grid_mode {
            match &medium {
                AnyMedium::Density(m) => camera_blocks(m, index, camera, vol),
                AnyMedium::Table(m) => camera_blocks(m, index, camera, vol),
            }
        } else {
            None
        };
        Ok(PathTracer {
            vol,
            index,
            camera,
            settings,
            medium,
            grid,
            blocks,
            visible,
            scatters: max_albedo > 0.0,
            cancel: crate::settings::Cancel::default(),
        })
    }

    /// The same tracer, [`PathTracer::render`] stopping before its next
    /// pass once `cancel` is raised (the passes done so far stay in the
    /// film, whole).
    pub fn with_cancel(self, cancel: crate::settings::Cancel) -> Self {
        PathTracer { cancel, ..self }
    }

    /// The same tracer without its empty-space shortcuts: empty macrocells
    /// crossed one by one instead of in blocks, and every camera ray traced
    /// (none known to meet only empty cells). The same image bit for bit,
    /// slower; what the shortcuts save is measured against it.
    pub fn without_shortcuts(self) -> Self {
        PathTracer {
            blocks: None,
            visible: None,
            ..self
        }
    }

    /// The fraction of majorant-grid cells that are empty (majorant 0).
    pub fn empty_fraction(&self) -> f64 {
        self.grid.empty_fraction()
    }

    /// Whether the medium scatters (an albedo above 0 somewhere).
    pub fn scatters(&self) -> bool {
        self.scatters
    }

    /// A key naming everything the samples depend on (the volume's shape,
    /// type and range, `volume_id` for its contents, the camera and the
    /// settings), for state files: a state saved under another key is
    /// refused.
    pub fn key(&self, volume_id: u64) -> u64 {
        let m = &self.vol.meta;
        let text = format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{volume_id}",
            m.dims, m.sample_type, m.spacing, m.range, self.camera, self.settings
        );
        // FNV-1a, then the sampler's finaliser.
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for b in text.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        crate::sampler::mix(h)
    }

    /// Add `spp` samples to every pixel of `acc` (one pass, all threads).
    pub fn pass(&self, acc: &mut PathFilm, spp: u64) -> Result<PathCounters, RenderError> {
        if (acc.width(), acc.height()) != (self.camera.width(), self.camera.height()) {
            return Err(RenderError::Setting(format!(
                "the accumulated image is {}x{}, the camera's {}x{}",
                acc.width(),
                acc.height(),
                self.camera.width(),
                self.camera.height()
            )));
        }
        let counters = match &self.medium {
            AnyMedium::Density(m) => self.pass_with(m, acc, spp),
            AnyMedium::Table(m) => self.pass_with(m, acc, spp),
        };
        acc.finish_pass(spp);
        Ok(counters)
    }

    fn pass_with<M: Medium>(&self, medium: &M, acc: &mut PathFilm, spp: u64) -> PathCounters {
        let s = self.vol.meta.spacing;
        let d = self.vol.dims().as_array();
        let est = Estimator {
            tracker: Tracker {
                medium,
                grid: &self.grid,
                level: self.index.level(GRID_LEVEL),
                hi: d.map(|n| n.saturating_sub(1) as f32),
                dims: self.vol.dims(),
                mode: self.settings.majorant,
                blocks: self.blocks.as_ref(),
            },
            visible: self.visible.as_ref(),
            camera: self.camera,
            inv_spacing: Vec3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2]),
            extent: Vec3::from(self.vol.meta.world_extent()),
            phase: HenyeyGreenstein::new(self.settings.g),
            lights: &self.settings.lights,
            background: self.settings.background,
            env_map: self
                .settings
                .lights
                .env_map
                .as_deref()
                .filter(|m| !m.is_black()),
            bounces: self.settings.bounces,
            hybrid: self.settings.hybrid,
            scatters: self.scatters,
            sampler: crate::sampler::HashSampler::with_kind(
                self.settings.seed,
                self.settings.sampler,
            ),
        };
        let width = acc.width() as usize;
        let (rows, start) = acc.rows_mut();
        self.vol.visit(Pass {
            est: &est,
            rows,
            width,
            start,
            spp,
        })
    }

    /// Render passes into `acc` until `budget` is spent, calling
    /// `progress` after each pass; [`RenderError::Cancelled`] when the
    /// tracer's cancel flag ([`PathTracer::with_cancel`]) is raised first.
    pub fn render(
        &self,
        acc: &mut PathFilm,
        budget: &Budget,
        mut progress: impl FnMut(&PathFilm, &PathCounters),
    ) -> Result<PathCounters, RenderError> {
        if budget.spp.is_none() && budget.seconds.is_none() && budget.until_error.is_none() {
            return Err(RenderError::Setting(
                "give a sample count, a time budget or an error target".into(),
            ));
        }
        let cap = budget.spp.unwrap_or(if budget.seconds.is_some() {
            u64::MAX
        } else {
            MAX_SPP
        });
        let t = Instant::now();
        let mut total = PathCounters::default();
        let mut done = 0u64;
        while done < cap {
            if self.cancel.is_cancelled() {
                return Err(RenderError::Cancelled);
            }
            let remaining = cap - done;
            // Passes of a sixteenth of a fixed count; when time or error
            // decide, passes that double from one sample, to a pass of at
            // most a quarter of the time left.
            let batch = if budget.seconds.is_none() && budget.until_error.is_none() {
                remaining.min(cap.div_ceil(16).max(1))
            } else {
                let mut b = done.clamp(1, 64);
                if let Some(limit) = budget.seconds {
                    let per = t.elapsed().as_secs_f64() / done.max(1) as f64;
                    let left = limit - t.elapsed().as_secs_f64();
                    if done > 0 && per > 0.0 {
                        b = b.min(((left * 0.25 / per) as u64).max(1));
                    }
                }
                b.min(remaining)
            };
            total += self.pass(acc, batch)?;
            done += batch;
            progress(acc, &total);
            if budget
                .seconds
                .is_some_and(|s| t.elapsed().as_secs_f64() >= s)
            {
                break;
            }
            if let Some(e) = budget.until_error {
                if acc.relative_error().is_some_and(|r| r <= e) {
                    break;
                }
            }
        }
        Ok(total)
    }
}

/// The blocks of `camera`'s image whose camera rays may meet a cell with
/// extinction ([`busy_blocks`], on the medium's bound over each cell's
/// range): the others' rays cross only empty cells and leave unscattered,
/// so their samples are the background, known without tracing. `None`:
/// every block is traced.
fn camera_blocks<M: Medium>(
    medium: &M,
    index: &MinMaxIndex,
    camera: &Camera,
    vol: &Volume,
) -> Option<BlockMask> {
    let busy = |level: usize, cell: usize| {
        let l = index.level(level);
        let (lo, hi) = (l.min()[cell], l.max()[cell]);
        // NaN fails the comparison: a cell of NaN is empty, as in the grid.
        lo <= hi && medium.majorant_over(lo, hi) > 0.0
    };
    let spacing = Vec3::from(vol.meta.spacing);
    busy_blocks(camera, index, spacing, None, busy).filter(|m| m.culled() > 0)
}

/// The medium's majorant grid, with its controls when `residual`.
fn controls<M: Medium>(
    medium: &M,
    index: &MinMaxIndex,
    residual: bool,
) -> Result<MajorantGrid, RenderError> {
    let grid = medium.majorants(index, GRID_LEVEL)?;
    Ok(if residual {
        grid.with_controls(index, |lo, hi| medium.control_over(lo, hi))
    } else {
        grid
    })
}

/// One pass over every row: the rows in parallel (compiled once), each
/// traced by a [`PassRows`] (the part specialised per medium and per
/// volume layout).
struct Pass<'e, 'r, M: Medium> {
    est: &'e Estimator<'e, M>,
    rows: &'r mut [[f64; 4]],
    width: usize,
    start: u64,
    spp: u64,
}

/// Traces the samples of one row of a pass.
trait PassRows: Sync {
    /// Add samples `start .. start + spp` to each pixel of row `y`.
    fn row(&self, y: usize, row: &mut [[f64; 4]], start: u64, spp: u64) -> PathCounters;
}

/// An estimator over one sample source (one cursor per row).
struct SourceRows<'a, S, M: Medium> {
    src: &'a S,
    est: &'a Estimator<'a, M>,
}

impl<S: VoxelSource, M: Medium> PassRows for SourceRows<'_, S, M> {
    fn row(&self, y: usize, row: &mut [[f64; 4]], start: u64, spp: u64) -> PathCounters {
        let mut cur = self.src.cursor();
        let mut n = PathCounters::default();
        for (x, px) in row.iter_mut().enumerate() {
            for i in start..start + spp {
                let l = self.est.radiance(&mut cur, x as u32, y as u32, i, &mut n);
                let (r, g, b) = (l.x as f64, l.y as f64, l.z as f64);
                let lum = luminance(r, g, b);
                px[0] += r;
                px[1] += g;
                px[2] += b;
                px[3] += lum * lum;
            }
        }
        n
    }
}

/// Every row of a pass with `tracer`, in parallel.
fn pass_rows(
    tracer: &dyn PassRows,
    rows: &mut [[f64; 4]],
    width: usize,
    start: u64,
    spp: u64,
) -> PathCounters {
    rows.par_chunks_mut(width.max(1))
        .enumerate()
        .map(|(y, row)| tracer.row(y, row, start, spp))
        .reduce(PathCounters::default, |mut a, b| {
            a += b;
            a
        })
}

impl<M: Medium> VolumeVisitor for Pass<'_, '_, M> {
    type Output = PathCounters;

    fn visit<S: VoxelSource>(self, src: &S) -> PathCounters {
        let tracer = SourceRows { src, est: self.est };
        pass_rows(&tracer, self.rows, self.width, self.start, self.spp)
    }
}
