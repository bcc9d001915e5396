//! The preprocessing stages of a conversion (`--orient`, `--resample`,
//! `--smooth`, `--median`, `--clamp`, `--threshold`, `--mask`): what the
//! user asked for, built into [`volprep`] stages on the grid the crop and
//! the units left, in the one fixed order
//! orient → resample → smooth → median → clamp → threshold → mask.

use crate::error::Error;
use crate::reader::{Access, CResult, ConvertError, SliceReader};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volprep::gauss::Gauss;
use volprep::median::Median;
use volprep::orient::{Orient, OrientCode};
use volprep::pointwise::{Clamp, Mask, Threshold};
use volprep::resample::{target_grid, Kernel, Resample, ResampleSpec};
use volprep::{Grid, Stage};

/// The most voxels a resampled output may have (2^40).
pub const MAX_VOXELS: u64 = 1 << 40;

/// Where `--resample` goes.
#[derive(Clone, Debug)]
pub enum ResampleTo {
    /// `spacing:` or `dims:`, on the input's box.
    Spec(ResampleSpec),
    /// `like:FILE`: that file's grid, read from its header.
    Like(PathBuf, Grid),
}

/// `--resample` with its kernel options.
#[derive(Clone, Debug)]
pub struct Resampling {
    /// The output grid.
    pub to: ResampleTo,
    /// The interpolation kernel.
    pub kernel: Kernel,
    /// Widen the kernel when downsampling (off with `--no-antialias`).
    pub antialias: bool,
}

/// `--mask FILE`: the file and a reader of it.
#[derive(Clone)]
pub struct MaskInput {
    /// The mask file, as named.
    pub path: PathBuf,
    /// Its slices (random access: a sequential input is spooled first).
    pub reader: Arc<dyn SliceReader>,
}

impl std::fmt::Debug for MaskInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MaskInput({})", self.path.display())
    }
}

/// The preprocessing a conversion does, as parsed from the flags (files
/// named by `like:` and `--mask` already opened).
#[derive(Clone, Debug, Default)]
pub struct Preprocess {
    /// `--orient CODE`.
    pub orient: Option<OrientCode>,
    /// `--resample SPEC` with `--kernel` and `--no-antialias`.
    pub resample: Option<Resampling>,
    /// `--smooth gauss:S`: σ per axis in the output's unit.
    pub smooth: Option<[f64; 3]>,
    /// `--median R`.
    pub median: Option<u64>,
    /// `--clamp LO:HI`.
    pub clamp: Option<(f64, f64)>,
    /// `--threshold LO:HI`.
    pub threshold: Option<(f64, f64)>,
    /// `--mask FILE`.
    pub mask: Option<MaskInput>,
    /// `--background V`: resampled voxels outside the input, and masked
    /// ones.
    pub background: f64,
}

impl Preprocess {
    /// Whether no stage was asked for.
    pub fn is_empty(&self) -> bool {
        self.orient.is_none()
            && self.resample.is_none()
            && self.smooth.is_none()
            && self.median.is_none()
            && self.clamp.is_none()
            && self.threshold.is_none()
            && self.mask.is_none()
    }

    /// Whether the output is a 0/1 mask (`--threshold`): u8 unless
    /// `--type` says otherwise.
    pub fn makes_mask(&self) -> bool {
        self.threshold.is_some()
    }

    /// The stages on `input` (the grid after crop and units), in order;
    /// stages that would change nothing (same-grid resampling, the
    /// identity orientation) are left out, so their output is the input
    /// bit for bit. `notes` gets what the user should hear once.
    pub fn stages(
        &self,
        input: Grid,
        in_path: &Path,
        notes: &mut Vec<String>,
    ) -> CResult<Vec<Box<dyn Stage>>> {
        let at = |e: String| ConvertError::new(in_path, Error::invalid(e));
        let mut out: Vec<Box<dyn Stage>> = Vec::new();
        let mut grid = input;
        if let Some(code) = self.orient {
            if let Some(s) = Orient::new(grid, code) {
                grid = s.output();
                out.push(Box::new(s));
            }
        }
        if let Some(r) = &self.resample {
            let target = match &r.to {
                ResampleTo::Spec(spec) => {
                    if !is_axis_aligned(&grid) {
                        notes.push(format!(
                            "the input's axes are oblique ({}): --resample resamples along them, keeping its directions",
                            grid.geometry.orientation()
                        ));
                    }
                    target_grid(&grid, spec).map_err(at)?
                }
                ResampleTo::Like(path, like) => in_unit(like, &grid, path)?,
            };
            // The grid as files store it: spacing is f32 everywhere, and
            // NIfTI stores the origin as f32 too. Computing on the stored
            // grid makes a reader of the output (and nearest's choice at a
            // half-voxel tie) see the grid the samples were computed on.
            let mut target = target;
            target.spacing = target.spacing.map(|v| f64::from(v as f32));
            target.geometry.origin = target.geometry.origin.map(|v| f64::from(v as f32));
            if target.dims.count() > MAX_VOXELS {
                return Err(at(format!(
                    "--resample would write {} voxels ({}), more than the 2^40 volkit writes",
                    target.dims.count(),
                    target.dims
                )));
            }
            if let Some(s) =
                Resample::new(grid, target, r.kernel, r.antialias, self.background as f32)
                    .map_err(at)?
            {
                grid = s.output();
                out.push(Box::new(s));
            }
        }
        if let Some(sigma) = self.smooth {
            let s = Gauss::new(grid, sigma).map_err(at)?;
            out.push(Box::new(s));
        }
        if let Some(r) = self.median {
            let s = Median::new(grid, r).map_err(at)?;
            out.push(Box::new(s));
        }
        if let Some((lo, hi)) = self.clamp {
            out.push(Box::new(Clamp { grid, lo, hi }));
        }
        if let Some((lo, hi)) = self.threshold {
            out.push(Box::new(Threshold { grid, lo, hi }));
        }
        if let Some(m) = &self.mask {
            let info = m.reader.info();
            let mgrid = Grid::new(info.dims, info.spacing.unwrap_or([1.0; 3]), info.geometry);
            let mgrid = in_unit(&mgrid, &grid, &m.path)?;
            volprep::pointwise::check_mask_grid(&mgrid, &grid, &m.path.display().to_string())
                .map_err(|e| ConvertError::new(&m.path, Error::invalid(e)))?;
            let reader = m.reader.clone();
            // The reader's errors name the mask file.
            let read = move |z: u64| -> Result<Vec<f32>, String> {
                let s = reader.read_slice(z).map_err(|e| e.to_string())?;
                Ok((0..s.len()).map(|i| s.value(i) as f32).collect())
            };
            out.push(Box::new(Mask::new(
                grid,
                self.background as f32,
                Box::new(read),
            )));
        }
        Ok(out)
    }
}

/// Whether every axis of `grid` runs along a world axis.
fn is_axis_aligned(grid: &Grid) -> bool {
    grid.geometry
        .direction
        .iter()
        .flatten()
        .all(|v| v.abs() < 1e-9 || (v.abs() - 1.0).abs() < 1e-9)
}

/// `other` (read from `path`) in `grid`'s unit of length: converted when
/// both state a unit, taken as it is when either does not.
fn in_unit(other: &Grid, grid: &Grid, path: &Path) -> CResult<Grid> {
    let mut g = *other;
    if let Some((geo, k)) = other.geometry.converted(grid.geometry.unit) {
        g.geometry = geo;
        g.spacing = other.spacing.map(|s| s * k);
    } else {
        g.geometry.unit = grid.geometry.unit;
    }
    if g.spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(ConvertError::new(
            path,
            Error::invalid(format!(
                "its spacing {:?} is not positive and finite",
                g.spacing
            )),
        ));
    }
    Ok(g)
}

/// A mask reader that can be read in any order: sequential inputs are
/// copied to `temp_dir` first.
pub fn random_access(
    reader: Box<dyn SliceReader>,
    temp_dir: &Path,
) -> CResult<Arc<dyn SliceReader>> {
    Ok(match reader.access() {
        Access::Random => Arc::from(reader),
        Access::Sequential => Arc::new(super::spool::Spooled::new(
            reader.as_ref(),
            temp_dir,
            |_| {},
        )?),
    })
}
