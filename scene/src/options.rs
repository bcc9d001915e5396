//! The options of one render as vol-render's command line defines them:
//! every flag, its help text and its parser, before they are resolved
//! against the volume into a plan ([`crate::plan`]). A scene file
//! ([`crate::merge`]) and name/value pairs ([`crate::pairs`]) fill the
//! same struct.
//!
//! The struct's own doc comment is vol-render's `--help` text, word for
//! word: say more about it here, not there.
//!
//! It is the only list of the options: a scene file's keys are the flags'
//! names, read through clap as the flags are ([`crate::file`]), and the
//! printed scene serialises the struct under the same names
//! ([`crate::effective`]).

pub use crate::choices::{GradientArg, InterpArg, ModeArg, ShadingArg, TonemapArg, UpArg};
use crate::lights::LightSpec;
use crate::parse::{
    parse_ao, parse_colour, parse_positive, parse_positive_f64, parse_shadows, parse_size,
    parse_sun_arg, parse_up, parse_vec3,
};
use clap::Parser;
use glam::Vec3;
use serde::Serialize;
use std::path::PathBuf;

/// Render a volume to an image with a tiled, parallel CPU ray caster.
///
/// World space follows VTK: voxel (i, j, k) sits at (i·sx, j·sy, k·sz) and the
/// volume's box is [0, (dims − 1)·spacing]. The image is the same, bit for
/// bit, whatever the thread count, tile size, storage layout, and whether
/// empty-space skipping is on.
#[derive(Parser, Clone, Debug, Serialize)]
#[command(name = "vol-render", version, after_help = EXAMPLES)]
pub struct Options {
    /// The volume (any format vol-convert reads; or `volume` in --scene).
    pub volume: Option<PathBuf>,
    /// Output PNG (8-bit sRGB; or `output` in --scene).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// A scene file (TOML) holding any of these options under the same
    /// names, plus lights; options given here override it (see "Scene
    /// files" below).
    #[arg(long, value_name = "FILE.toml")]
    pub scene: Option<PathBuf>,
    /// Print the effective scene (the scene file, the options and the
    /// defaults resolved against the volume) as TOML, and render nothing.
    #[arg(long)]
    pub print_scene: bool,
    /// A .vidx index made by vol-index for this volume (otherwise one is
    /// built in memory when skipping is on).
    #[arg(long)]
    pub index: Option<PathBuf>,
    /// Transfer function: a file (1D or 2D), or a preset: grey (a greyscale
    /// ramp over the value range), auto or auto:P (the same ramp windowed
    /// from the P-th to the (100-P)-th percentile of the index's histogram,
    /// P = 0.5: for data of any units), ct (Hounsfield units: warns with the
    /// data range on other data), shapes, or boundary (2D: opacity rising
    /// with the gradient magnitude, so boundaries between materials show and
    /// flat regions vanish).
    #[arg(long, default_value = "grey")]
    pub tf: String,
    /// What each ray computes.
    #[arg(long, value_enum, default_value = "dvr")]
    pub mode: ModeArg,
    /// Iso value for --mode iso (default: the middle of the value range).
    #[arg(long, allow_hyphen_values = true)]
    pub iso: Option<f32>,
    /// Image size WxH, 1..=32768 per side, within a frame memory budget
    /// of 8 GiB at 160 bytes per pixel (about 53 megapixels, e.g.
    /// 7000x7000; path tracing: 64 bytes, about 134 megapixels); a larger
    /// frame is refused before rendering.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Camera position x,y,z (world units); needs --look-at.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at (default: the volume's centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<Vec3>,
    /// Up vector x,y,z (any length), or `patient`: the direction the
    /// data's superior (head) axis points, from the volume's direction
    /// matrix (.vvol v2, NIfTI, DICOM, NRRD geometry). --orbit turns around it.
    #[arg(long, value_parser = parse_up, default_value = "0,1,0", allow_hyphen_values = true)]
    pub up: UpArg,
    /// Orbit camera: azimuth, elevation (degrees) and distance from the
    /// volume's centre, around --up (default when no --eye: 30,20 and 1.8
    /// diagonals). Azimuth 0 puts the eye on the +z side (the −y side when
    /// up is near ±z).
    #[arg(long, value_parser = parse_vec3, conflicts_with = "eye", allow_hyphen_values = true)]
    pub orbit: Option<Vec3>,
    /// Vertical field of view in degrees (perspective).
    #[arg(long, default_value_t = 45.0)]
    pub fov: f32,
    /// Orthographic projection; --ortho=H sets the image height in world
    /// units (the value needs the '='; 0 or none: fit the volume's
    /// diagonal).
    #[arg(long, value_name = "H", num_args = 0..=1, require_equals = true, default_missing_value = "0")]
    pub ortho: Option<f32>,
    /// Orthographic projection with this image height in world units (0 =
    /// fit the volume's diagonal); the same as --ortho=H.
    #[arg(long, value_name = "H", conflicts_with = "ortho")]
    pub ortho_height: Option<f32>,
    /// Distance between samples along a ray, world units (default: half the
    /// smallest voxel spacing). A step that would take more than 10 million
    /// samples per ray across the volume's diagonal is refused.
    #[arg(long, allow_hyphen_values = true)]
    pub step: Option<f32>,
    /// DVR: classify each segment between consecutive samples from a
    /// pre-integrated table of (front, back) value pairs instead of each
    /// sample alone, so layers thinner than the step still show and a
    /// longer step reaches the same error (1D transfer functions,
    /// trilinear values). The table costs milliseconds per transfer
    /// function and step.
    #[arg(long)]
    pub preintegrated: bool,
    /// DVR: adaptive steps. In each macrocell of the index, one sample
    /// stands for up to 64 steps where the transfer function changes
    /// slowly over the cell's values (exactly, in closed form, where it is
    /// constant) and for one step where it changes fast; TOL is the error
    /// tolerated per unit length, in optical depth (try 0.01; smaller is
    /// closer to --step alone). 1D transfer functions, not with
    /// --preintegrated; builds the index even with --no-ess.
    #[arg(long, value_name = "TOL", value_parser = parse_positive, allow_hyphen_values = true)]
    pub adaptive: Option<f32>,
    /// Ray casting: a time budget for the frame, seconds. The step (a
    /// multiple of --step or its default, 1/4x to 8x) and an image scale
    /// (rendered smaller, then upsampled to --size) are picked for the
    /// best expected PSNR that fits, from three small probe frames that
    /// calibrate the cost and the error on this volume and machine (their
    /// time counts in the budget). A budget below the coarsest setting's
    /// cost gives the coarsest, with a note. --json states the choice, and
    /// the expected and measured time, under `budget`.
    #[arg(long, value_name = "SECONDS", value_parser = parse_positive_f64, allow_hyphen_values = true)]
    pub budget: Option<f64>,
    /// Early ray termination threshold (accumulated opacity).
    #[arg(long, default_value_t = 0.99)]
    pub ert: f32,
    /// Turn early ray termination off.
    #[arg(long)]
    pub no_ert: bool,
    /// Turn empty-space skipping off.
    #[arg(long)]
    pub no_ess: bool,
    /// Reconstruction between voxels.
    #[arg(long, value_enum, default_value = "trilinear")]
    pub interp: InterpArg,
    /// Shading for DVR (iso surfaces are always shaded).
    #[arg(long, value_enum, default_value = "none")]
    pub shading: ShadingArg,
    /// Gradient method for shading.
    #[arg(long, value_enum, default_value = "central")]
    pub gradient: GradientArg,
    /// Direction towards a white directional light x,y,z (default: a
    /// headlight; a scene file can give any lights).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light: Option<Vec3>,
    /// Ambient light: a grey level, or linear r,g,b (default 0.25).
    #[arg(long, value_parser = parse_colour)]
    pub ambient: Option<Vec3>,
    /// Shadows toward every light: `ray` (a shadow ray per shaded sample
    /// and light, with empty-space skipping) or `grid[:DIV]` (per
    /// directional light a transmittance grid every DIV = 1, 2 or 4
    /// voxels, default 2, built once per frame and read trilinearly; other
    /// lights cast rays). DVR shadows need --shading phong, which this
    /// turns on.
    #[arg(long, value_name = "ray|grid[:DIV]", value_parser = parse_shadows)]
    pub shadows: Option<String>,
    /// Distance between shadow samples, world units (default: --step).
    #[arg(long, value_name = "S")]
    pub shadow_step: Option<f32>,
    /// Ambient occlusion: the ambient light of each shaded sample scaled
    /// by the mean transmittance over N directions (cosine-weighted around
    /// the normal, from a hashed per-pixel sampler) up to R world units
    /// (default: a tenth of the volume's diagonal), through a coarse grid
    /// of the classified volume's extinction. DVR AO needs --shading
    /// phong, which this turns on.
    #[arg(long, value_name = "N[:R]", value_parser = parse_ao, conflicts_with = "ao_field")]
    pub ao: Option<String>,
    /// Ambient occlusion from a field precomputed once per frame: the
    /// transmittance toward K fixed directions up to R (default a tenth of
    /// the diagonal) every --ao-field-cell voxels, read trilinearly and
    /// weighted by each direction's cosine to the normal. Its build time
    /// and memory are reported beside the frame's (--json: ao_field_s,
    /// ao_field_bytes).
    #[arg(long, value_name = "K[:R]", value_parser = parse_ao)]
    pub ao_field: Option<String>,
    /// Voxels between the AO field's points, 1-64 (default 8): halving it
    /// resolves thinner structures for eight times the field's memory and
    /// precomputation.
    #[arg(long, value_name = "VOXELS", requires = "ao_field", conflicts_with = "ao",
          value_parser = clap::value_parser!(u32).range(1..=volrender::effects::ao::MAX_AO_FIELD_CELL as i64))]
    pub ao_field_cell: Option<u32>,
    /// The scene file's lights (set by --scene; `None`: a headlight).
    #[arg(skip)]
    #[serde(skip)]
    pub lights: Option<Vec<LightSpec>>,
    /// The scene file's transfer function text (set by --scene).
    #[arg(skip)]
    #[serde(skip)]
    pub tf_text: Option<String>,
    /// Background colour r,g,b (0-255; default black). In path mode it
    /// replaces the environment where camera rays leave the volume
    /// unscattered.
    #[arg(long, value_parser = parse_vec3)]
    pub background: Option<Vec3>,
    /// Write an RGBA PNG with coverage alpha instead of compositing onto the background.
    #[arg(long)]
    pub alpha: bool,
    /// Tile edge in pixels (a tile larger than the image is the image).
    #[arg(long, default_value_t = 16)]
    pub tile: u32,
    /// Macrocell edge of an index built in memory.
    #[arg(long, default_value_t = 8)]
    pub cell: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Read an uncompressed .vvol into memory (backed by huge pages where
    /// the system offers them) instead of sampling the memory-mapped file
    /// in place: start-up costs a copy of the file, frames cost about the
    /// same.
    #[arg(long)]
    pub in_memory: bool,
    /// Render this many times and report the median time (for benchmarks).
    #[arg(long, default_value_t = 1)]
    pub repeat: u32,
    /// Also write the linear float image (.pfm, or .exr).
    #[arg(long)]
    pub hdr: Option<PathBuf>,
    /// Also write a samples-per-pixel heat map with a colour scale (.png).
    #[arg(long)]
    pub heatmap: Option<PathBuf>,
    /// Path tracing: samples per pixel to add (default 64 unless --seconds
    /// or --until-error decides; with them, the most to add).
    #[arg(long, help_heading = PATH_HEADING)]
    pub spp: Option<u64>,
    /// Path tracing: render whole passes until this many seconds are spent.
    #[arg(long, value_name = "S", help_heading = PATH_HEADING)]
    pub seconds: Option<f64>,
    /// Path tracing: stop once the relative standard error of the image
    /// (the root mean square standard error of lit pixels' mean luminance
    /// over their mean) falls below E.
    #[arg(long, value_name = "E", help_heading = PATH_HEADING)]
    pub until_error: Option<f64>,
    /// Path tracing: scattering events per path (1 = single scattering).
    #[arg(long, default_value_t = 8, help_heading = PATH_HEADING)]
    pub bounces: u32,
    /// Path tracing: Henyey-Greenstein asymmetry in [-1, 1] (0 isotropic,
    /// > 0 forward).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        help_heading = PATH_HEADING
    )]
    pub g: f32,
    /// Path tracing: hybrid scattering (Kroes et al. 2012): where the
    /// extinction changes sharply, an event reflects off a surface BRDF
    /// (Lambertian in the albedo plus a white glossy lobe) around the
    /// gradient with probability 1 - exp(-SCALE x |gradient| / max
    /// extinction), per voxel; `off` (the default): the phase function
    /// everywhere. Try 5 to 50.
    #[arg(
        long,
        value_name = "off|SCALE",
        allow_hyphen_values = true,
        help_heading = PATH_HEADING
    )]
    pub hybrid: Option<String>,
    /// Path tracing: extinction per world unit = S x the normalised value
    /// (value/255 for u8, /65535 for u16, /32767 for i16, the value for
    /// f32; negative and NaN values are 0), with --albedo. Without it the
    /// transfer function is the medium: extinction -ln(1 - opacity per
    /// unit length), albedo its colour. Extinction is capped at 1e6 per
    /// unit (opacity 1, infinite or huge values act as that: opaque); the
    /// --json counters `capped` and `truncated` say when a frame met the
    /// cap or the limit of 1e8 collisions per tracking call.
    #[arg(long, value_name = "S", help_heading = PATH_HEADING)]
    pub density_scale: Option<f32>,
    /// Path tracing: the density medium's albedo, a grey level or linear
    /// r,g,b in [0, 1] (default 0.8; 0 = absorption only).
    #[arg(long, value_parser = parse_colour, help_heading = PATH_HEADING)]
    pub albedo: Option<Vec3>,
    /// Path tracing: a directional light travelling along dx,dy,dz with
    /// irradiance E (grey; default 3); repeatable. Values starting with '-'
    /// need the '=' form: --sun=-1,-1.2,0.4:4.
    #[arg(long, value_name = "DX,DY,DZ[:E]", value_parser = parse_sun_arg,
          allow_hyphen_values = true, help_heading = PATH_HEADING)]
    pub sun: Vec<String>,
    /// Path tracing: constant environment radiance, grey or linear r,g,b
    /// (default 1 when there is no sun or point light, else 0). It is seen
    /// behind the volume unless --background is given.
    #[arg(long, value_parser = parse_colour, help_heading = PATH_HEADING)]
    pub env: Option<Vec3>,
    /// Path tracing: an environment map instead of --env: an
    /// equirectangular linear image (.pfm or .exr), row 0 at the zenith
    /// (+y), the left edge toward +x, then +z a quarter across. Sampled in
    /// proportion to its luminance at every scattering event, weighted
    /// against the phase function (multiple importance sampling).
    #[arg(long, value_name = "FILE", help_heading = PATH_HEADING)]
    pub env_map: Option<PathBuf>,
    /// Path tracing: majorants for delta and ratio tracking: `grid` (per
    /// macrocell of the index) or `global` (one for the volume).
    #[arg(long, default_value = "grid", value_parser = ["grid", "global"],
          help_heading = PATH_HEADING)]
    pub majorant: String,
    /// Path tracing: the sampler's seed.
    #[arg(long, default_value_t = 0, help_heading = PATH_HEADING)]
    pub seed: u64,
    /// Path tracing: the sampler: `sobol` (Owen-scrambled Sobol points for
    /// the pixel position and the first bounces' draws, lower error per
    /// sample) or `hash` (independent samples).
    #[arg(long, default_value = "sobol", value_parser = ["sobol", "hash"],
          help_heading = PATH_HEADING)]
    pub sampler: String,
    /// Path tracing: shadow rays' transmittance: `residual` (residual
    /// ratio tracking: each macrocell's smallest extinction in closed form)
    /// or `ratio` (ratio tracking against the majorant).
    #[arg(long, default_value = "residual", value_parser = ["residual", "ratio"],
          help_heading = PATH_HEADING)]
    pub transmittance: String,
    /// Path tracing: keep the per-pixel sums in this state file and
    /// continue from it when it exists (64 samples, then 64 more, equal
    /// 128 at once, bit for bit); a state from another scene is refused.
    #[arg(
        long,
        value_name = "STATE",
        help_heading = PATH_HEADING
    )]
    pub accumulate: Option<PathBuf>,
    /// Path tracing: scale radiance by this before the PNG's tone map.
    #[arg(
        long,
        default_value_t = 1.0,
        help_heading = PATH_HEADING
    )]
    pub exposure: f32,
    /// Path tracing: tone map of the PNG (the --hdr file stays linear).
    #[arg(
        long,
        value_enum,
        default_value = "clamp",
        help_heading = PATH_HEADING
    )]
    pub tonemap: TonemapArg,
    /// Path tracing: write a heat map of each pixel's standard error
    /// (.png).
    #[arg(
        long,
        value_name = "OUT.png",
        help_heading = PATH_HEADING
    )]
    pub variance: Option<PathBuf>,
    /// Print one JSON object with the figures.
    #[arg(long)]
    pub json: bool,
    /// No progress messages.
    #[arg(short, long)]
    pub quiet: bool,
    /// What to read from the volume's file: raw layout, DICOM series,
    /// channel, time point (the same flags as every tool's). Last: its
    /// heading holds for every option after it.
    #[command(flatten, next_help_heading = "Input")]
    #[serde(flatten)]
    pub input: volformats::Selection,
}

/// The help heading of the path tracer's options: outside `--mode path`
/// they are refused, and not printed in a scene.
pub const PATH_HEADING: &str = "Path tracing (--mode path)";

/// The options (by id) a printed scene leaves out: how to run, not what
/// to render (`threads`, `json`), files of the run itself (`scene`), and
/// the two that are printed in another form (`light` as `lights`,
/// `ortho_height` as `ortho`).
pub const NOT_PRINTED: [&str; 14] = [
    "scene",
    "print_scene",
    "light",
    "ortho_height",
    "tile",
    "cell",
    "threads",
    "in_memory",
    "repeat",
    "variance",
    "accumulate",
    "json",
    "quiet",
    "old_time",
];

/// Whether `--tf` names a preset (`auto:P` included) rather than a file.
pub fn is_preset(name: &str) -> bool {
    volrender::tf::PRESETS.contains(&name) || name.starts_with("auto:")
}

impl Options {
    /// Every option at its default (no volume).
    pub fn defaults() -> Options {
        // Parsing no arguments cannot fail: no option is required.
        Options::try_parse_from(["vol-render"]).unwrap_or_else(|e| unreachable!("{e}"))
    }
}

/// The examples and file formats after the options in `--help`.
const EXAMPLES: &str = "Examples:
  vol-render shapes.vvol --tf shapes --shading phong -o shapes.png
  vol-render shapes.vvol --tf shapes --shading phong --step 0.2 --size 700x700 \\
      --eye 1100,1100,1100 --look-at 0,0,0 --fov 60 -o thesis.png --json
  vol-render ct.vvol --tf ct --orbit 45,30,600 --hdr ct.pfm -o ct.png
  vol-render sphere.vvol --mode iso --iso 128 -o iso.png
  vol-render noise.vvol --mode mip --ortho -o mip.png --heatmap samples.png
  vol-render noise.vvol --mode mip --ortho-height 300 -o mip300.png
  vol-render brain.nii.gz --tf auto -o brain.png
  vol-render ct.vvol --tf ct --shading phong --step 0.05 --adaptive 0.03 -o ct-fast.png
  vol-render ct.vvol --tf ct --shading phong --budget 0.05 --json -o ct-50ms.png
  vol-render shapes.vvol --index shapes.vvol.vidx --no-ert --threads 1 -o a.png

  vol-render sphere.vvol --tf boundary --shading phong -o shell.png
  vol-render shapes.vvol --tf shapes --light 1,2,3 --shadows ray -o shadows.png
  vol-render shapes.vvol --tf shapes --light 1,2,3 --shadows grid:4 -o fast.png
  vol-render shapes.vvol --tf shapes --ao 8 -o ao.png
  vol-render shapes.vvol --tf shapes --light 1,2,3 --shadows grid:4 --ao-field 32 -o both.png
  vol-render head.vvol --tf ct --ao-field 32 --ao-field-cell 4 -o head-ao.png
  vol-render --scene thesis.toml --size 256x256 -o small.png
  vol-render shapes.vvol --tf shapes --orbit 30,20,700 --print-scene > shapes.toml

  vol-render spheres.vvol --mode path --density-scale 0.1 --albedo 0.8 --sun=-1,-1.2,0.4:4 \
      --env 0.1 --spp 64 --bounces 8 --hdr spheres.exr -o spheres.png --json
  vol-render shapes.vvol --mode path --tf shapes --env 1 --seconds 30 --tonemap aces -o pt.png
  vol-render ct.vvol --mode path --tf ct --until-error 0.01 --variance noise.png -o ct-pt.png
  vol-render ct.vvol --mode path --tf ct --env-map sky.exr --bounces 4 -o ct-sky.png
  vol-render big.vvol --mode path --density-scale 2 --spp 64 --accumulate big.state -o a.png

  # Data-parallel on 4 ranks (built with --features mpi; see docs/SCALE.md)
  mpirun -q -np 4 vol-render scan.vvol --index scan.vidx --tf ct --shading phong -o scan.png --json

Scene files (TOML) take every option above by the same name, and lights:
  volume = \"shapes.vvol\"            # relative paths: from the scene file's folder
  tf = \"shapes\"                     # or tf-text = \"\"\"...\"\"\" (the format below)
  shading = \"phong\"
  size = [700, 700]
  eye = [1100, 1100, 1100]
  look-at = [0, 0, 0]
  ambient = 0.2                     # or [r, g, b], linear
  [[lights]]
  type = \"directional\"              # also \"point\" (position), \"headlight\"
  direction = [-1, -1, -0.5]        # the direction the light travels
  colour = [1.0, 0.9, 0.8]          # linear; intensity = 1.5 scales it

Transfer function files: one statement per line, # for comments:
  domain 0 255              value range the table covers
  step 1                    reference step for the opacities (world units)
  range 85 95 255 0 0 0.02  [lo, hi): colour R G B (0-255), opacity per unit length
  point 100 0 255 0 0.6     control point: value, R G B, opacity (linear between points)
Two-dimensional ones, over value and gradient magnitude (per world unit), add:
  gradient-domain 0 120     gradient magnitudes the table covers
  rect 90 110 20 120 255 200 150 0.6   [v0, v1) x [g0, g1): colour, opacity
  blob 100 60 8 15 255 255 255 0.9     centre v g, std devs, colour, peak opacity
  (where parts overlap, the one with the largest opacity wins)";
