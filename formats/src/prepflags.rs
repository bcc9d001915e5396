//! The preprocessing flags of `vol-convert` (and the Python package's
//! keywords of the same names): one definition, parsed by the kernels'
//! own parsers, resolved into a [`Preprocess`] with the files that
//! `--resample like:FILE` and `--mask FILE` name opened.

// The value parsers are named only in the clap attributes.
#![cfg_attr(not(feature = "clap"), allow(unused_imports, dead_code))]

use crate::convert::{MaskInput, Preprocess, ResampleTo, Resampling};
use crate::open::{open_input, ReadOptions};
use std::path::{Path, PathBuf};
use volprep::gauss::parse_gauss;
use volprep::orient::OrientCode;
use volprep::pointwise::parse_range;
use volprep::resample::{Kernel, ResampleSpec};
use volprep::Grid;

/// `LO:HI` of `--clamp` and `--threshold`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The low bound.
    pub lo: f64,
    /// The high bound.
    pub hi: f64,
}

fn clamp_bounds(s: &str) -> Result<Bounds, String> {
    parse_range("--clamp", s).map(|(lo, hi)| Bounds { lo, hi })
}

fn threshold_bounds(s: &str) -> Result<Bounds, String> {
    parse_range("--threshold", s).map(|(lo, hi)| Bounds { lo, hi })
}

fn background(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a finite number")),
    }
}

/// The preprocessing flags. The stages apply in one fixed order, whatever
/// the order of the flags: crop → orient → resample → smooth → median →
/// clamp → threshold → mask → type and window. Another order is a pipe of
/// two `vol-convert` calls over the `.vvol` stream (`-o -` and `-`).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct PrepFlags {
    /// Reorient by permuting and flipping axes exactly (no
    /// interpolation): three letters, one each from R/L, A/P, S/I, naming
    /// where each output axis points (RAS, LPS, PIR, ...), as nibabel's
    /// aff2axcodes and SimpleITK's DICOMOrient name them.
    #[cfg_attr(feature = "clap", arg(long, value_name = "CODE"))]
    pub orient: Option<OrientCode>,
    /// Resample onto a new grid: spacing:S or spacing:X,Y,Z (in the
    /// output's unit), dims:NX,NY,NZ, or like:FILE (that volume's dims,
    /// spacing, origin and directions, oblique too). spacing: and dims:
    /// keep the input's directions and its box, which runs from the first
    /// voxel's outer face to the last's (extent = n·s per axis): the new
    /// dims are round(extent / spacing), at least 1, and the new box is
    /// centred on the old one, so origin' = origin + D·((n−1)·s −
    /// (n'−1)·s')/2 per axis. Output voxels whose centres fall outside the
    /// input's box get --background.
    #[cfg_attr(feature = "clap", arg(long, value_name = "SPEC"))]
    pub resample: Option<ResampleSpec>,
    /// The --resample kernel: nearest, linear (the default), cubic
    /// (Catmull-Rom), bspline3 (interpolating cubic B-spline, with its
    /// prefilter), lanczos3, or label (label volumes: nearest when
    /// upsampling, the majority of the covered voxels when downsampling).
    #[cfg_attr(feature = "clap", arg(long, value_name = "K", requires = "resample"))]
    pub kernel: Option<Kernel>,
    /// Do not widen the kernel when downsampling (by default it is widened
    /// by the scale factor along each axis, as unu resample does, so
    /// detail finer than the new spacing does not alias).
    #[cfg_attr(feature = "clap", arg(long, requires = "resample"))]
    pub no_antialias: bool,
    /// The value of resampled voxels outside the input, and of voxels
    /// --mask removes.
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "V", default_value = "0", allow_hyphen_values = true, value_parser = background)
    )]
    pub background: f64,
    /// Gaussian smoothing: gauss:SIGMA or gauss:SX,SY,SZ, σ in the
    /// output's unit of length (so anisotropic spacing is handled);
    /// separable, truncated at ceil(4σ/spacing) voxels, replicate borders.
    #[cfg_attr(feature = "clap", arg(long, value_name = "gauss:SIGMA", value_parser = parse_gauss))]
    pub smooth: Option<[f64; 3]>,
    /// Median of the (2R+1)³ neighbourhood (exact on integers; replicate
    /// borders).
    #[cfg_attr(feature = "clap", arg(long, value_name = "R"))]
    pub median: Option<u64>,
    /// Values below LO become LO and above HI become HI; no rescaling, the
    /// type is kept.
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "LO:HI", allow_hyphen_values = true, value_parser = clamp_bounds)
    )]
    pub clamp: Option<Bounds>,
    /// A u8 mask: 1 where LO <= value <= HI, else 0.
    #[cfg_attr(
        feature = "clap",
        arg(long, value_name = "LO:HI", allow_hyphen_values = true, value_parser = threshold_bounds)
    )]
    pub threshold: Option<Bounds>,
    /// Voxels where FILE is 0 become --background. FILE must be on the
    /// grid the earlier stages make (dims, spacing, origin, directions).
    #[cfg_attr(feature = "clap", arg(long, value_name = "FILE"))]
    pub mask: Option<PathBuf>,
}

impl PrepFlags {
    /// Whether any stage was asked for.
    pub fn is_given(&self) -> bool {
        self.orient.is_some()
            || self.resample.is_some()
            || self.smooth.is_some()
            || self.median.is_some()
            || self.clamp.is_some()
            || self.threshold.is_some()
            || self.mask.is_some()
    }

    /// The stages these flags ask for, with `like:FILE` read for its grid
    /// and `--mask FILE` opened (sequential inputs copied to `temp_dir`).
    /// Errors name the file.
    pub fn resolve(&self, temp_dir: &Path) -> Result<Preprocess, crate::reader::ConvertError> {
        let resample = match &self.resample {
            None => None,
            Some(spec) => {
                let to = match spec {
                    ResampleSpec::Like(path) => ResampleTo::Like(path.clone(), grid_of(path)?),
                    other => ResampleTo::Spec(other.clone()),
                };
                Some(Resampling {
                    to,
                    kernel: self.kernel.unwrap_or(Kernel::Linear),
                    antialias: !self.no_antialias,
                })
            }
        };
        let mask = match &self.mask {
            None => None,
            Some(path) => {
                let reader = open_input(path, &ReadOptions::default())?;
                Some(MaskInput {
                    path: path.clone(),
                    reader: crate::convert::stages::random_access(reader, temp_dir)?,
                })
            }
        };
        Ok(Preprocess {
            orient: self.orient,
            resample,
            smooth: self.smooth,
            median: self.median,
            clamp: self.clamp.map(|b| (b.lo, b.hi)),
            threshold: self.threshold.map(|b| (b.lo, b.hi)),
            mask,
            background: self.background,
        })
    }
}

/// The grid of the volume at `path`, from its header.
fn grid_of(path: &Path) -> Result<Grid, crate::reader::ConvertError> {
    let reader = open_input(path, &ReadOptions::default())?;
    let info = reader.info();
    Ok(Grid::new(
        info.dims,
        info.spacing.unwrap_or([1.0; 3]),
        info.geometry,
    ))
}
