//! Inputs of a conversion, read slice by slice, and the errors reading
//! and writing raise ([`ConvertError`], located at a file).
//!
//! With [`crate::slice`], the vocabulary every reader speaks. It imports
//! nothing of the crate but `slice` and [`crate::error`]; the readers,
//! [`open`](mod@crate::open) and [`convert`](crate::convert) (which
//! re-exports these names) all sit above it.
//!
//! A [`SliceReader`] hands out whole z slices. Random-access readers (files
//! of slices, raw data read at offsets, open volumes) may be asked for any
//! slice from any thread, so slices decode in parallel; sequential readers
//! (pipes, gzip streams) must be asked in increasing z order and skip what
//! is not asked for.
//!
//! Each format keeps its reader beside its decoder: [`crate::raw`],
//! [`crate::stream`] (pipes and decompressors), [`crate::thesis`],
//! [`crate::vvol`], [`crate::tiff`], [`crate::nrrd`], [`crate::mhd`],
//! [`crate::nifti`], [`crate::dicom`], and [`crate::convert::spool`] for inputs
//! copied to disk first.

use crate::error::Error;
use crate::slice::{SliceData, SliceSample, SliceType};
use std::fmt;
use std::path::{Path, PathBuf};
use volcore::{Dims, Geometry};

/// An error tied to the file it concerns (the input, one slice file of a
/// stack, or the output). Displays as `path: problem`, on one line.
#[derive(Debug)]
pub struct ConvertError {
    /// The file the problem is about.
    pub path: PathBuf,
    /// What went wrong.
    pub error: Error,
}

impl ConvertError {
    /// An error about `path`.
    pub fn new(path: &Path, error: impl Into<Error>) -> ConvertError {
        ConvertError {
            path: path.to_path_buf(),
            error: error.into(),
        }
    }
}

impl fmt::Display for ConvertError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let msg = self.error.to_string().replace('\n', " ");
        write!(f, "{}: {}", self.path.display(), msg)
    }
}

impl std::error::Error for ConvertError {}

/// Result of conversion steps.
pub type CResult<T> = std::result::Result<T, ConvertError>;

/// Attach a path to an error.
pub trait At<T> {
    /// The error, located at `path`.
    fn at(self, path: &Path) -> CResult<T>;
}

impl<T, E: Into<Error>> At<T> for std::result::Result<T, E> {
    fn at(self, path: &Path) -> CResult<T> {
        self.map_err(|e| ConvertError::new(path, e))
    }
}

/// What an input holds.
#[derive(Clone, Debug, PartialEq)]
pub struct InputInfo {
    /// The input as named on the command line (`-` for standard input).
    pub path: PathBuf,
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type of the slices handed out.
    pub sample_type: SliceType,
    /// Voxel spacing, when the input records one.
    pub spacing: Option<[f32; 3]>,
    /// Origin and axis directions (identity when the input records none).
    pub geometry: Geometry,
    /// A short description of the input format, e.g. `tiff stack (512 files)`.
    pub format: String,
    /// NIfTI input: the codes of the space its geometry maps to, which a
    /// NIfTI output keeps (`None`: the writer's default).
    pub nifti_codes: Option<NiftiCodes>,
}

/// NIfTI `qform_code` and `sform_code`: which space a NIfTI affine maps
/// voxels to (1 scanner, 2 aligned, 3 Talairach, 4 MNI 152, 5 another
/// template; 0 none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NiftiCodes {
    /// The qform's code.
    pub qform: i16,
    /// The sform's code.
    pub sform: i16,
}

impl NiftiCodes {
    /// What volkit writes when the input says nothing: both transforms in
    /// scanner coordinates.
    pub const SCANNER: NiftiCodes = NiftiCodes { qform: 1, sform: 1 };
}

/// Whether slices can be read in any order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Any slice, from any thread.
    Random,
    /// Increasing z only, from one thread at a time.
    Sequential,
}

/// A source of whole z slices.
pub trait SliceReader: Send + Sync {
    /// Dimensions, type, spacing.
    fn info(&self) -> &InputInfo;
    /// Random or sequential access.
    fn access(&self) -> Access;
    /// Slice `z`, x fastest, reusing the allocation of `reuse` where the
    /// reader can (readers that cannot drop it). Sequential readers need
    /// increasing `z`.
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData>;
    /// Slice `z` in a new allocation: [`SliceReader::read_slice_into`]
    /// with nothing to reuse.
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        self.read_slice_into(z, None)
    }
    /// Input bytes consumed so far (file sizes for files, bytes read for
    /// streams).
    fn bytes_in(&self) -> u64;
    /// Called once after the last slice: sequential readers read what is
    /// left (so a writer upstream in a pipe never sees a broken pipe) and
    /// check trailers.
    fn finish(&self) -> CResult<()> {
        Ok(())
    }
    /// What the reader did that its user should hear of (files skipped),
    /// one line each.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// The type the file stores, when the slices handed out are of a
    /// wider one (a DICOM series rescaled by its slope and intercept), so
    /// messages name the file's type: None when they are the same.
    fn stored_type(&self) -> Option<SliceType> {
        None
    }
    /// What the input states about its acquisition, under BIDS's names
    /// (a DICOM series: the sidecar dcm2niix writes); `None` for inputs
    /// that state none.
    fn sidecar(&self) -> Option<serde_json::Map<String, serde_json::Value>> {
        None
    }
}

/// A reader of samples a header describes (raw data at an offset, a
/// stream): what the header states beyond the samples (spacing, geometry,
/// NIfTI codes) is set on it once opened.
pub trait Described: Sized {
    /// The description to amend.
    fn info_mut(&mut self) -> &mut InputInfo;

    /// Set the spacing and geometry the header recorded.
    fn with_geometry(mut self, spacing: Option<[f32; 3]>, geometry: Geometry) -> Self {
        let info = self.info_mut();
        info.spacing = spacing;
        info.geometry = geometry;
        self
    }

    /// Carry a NIfTI input's qform and sform codes (see
    /// [`InputInfo::nifti_codes`]).
    fn with_nifti_codes(mut self, codes: Option<NiftiCodes>) -> Self {
        self.info_mut().nifti_codes = codes;
        self
    }
}

/// Slices of one type as a [`SliceReader`] (tests and small volumes).
pub struct MemoryReader {
    info: InputInfo,
    slices: Vec<SliceData>,
}

impl MemoryReader {
    /// A reader over samples of type `T` in sliced order.
    pub fn new<T: SliceSample>(dims: Dims, samples: &[T]) -> MemoryReader {
        let n = dims.slice_len() as usize;
        MemoryReader {
            info: InputInfo {
                path: PathBuf::from("memory"),
                dims,
                sample_type: T::TYPE.into(),
                spacing: None,
                geometry: Geometry::IDENTITY,
                format: "memory".into(),
                nifti_codes: None,
            },
            slices: samples.chunks(n).map(|c| T::wrap(c.to_vec())).collect(),
        }
    }
}

impl MemoryReader {
    /// A reader over z slices already in memory (the arrays of a Python
    /// caller), of any [`SliceType`]: `dims.z` slices of
    /// `dims.slice_len()` samples each, all of one type; `path` names
    /// them in messages, `spacing` and `geometry` are theirs.
    pub fn from_slices(
        path: &Path,
        dims: Dims,
        slices: Vec<SliceData>,
        spacing: Option<[f32; 3]>,
        geometry: Geometry,
    ) -> std::result::Result<MemoryReader, String> {
        let Some(first) = slices.first() else {
            return Err("no slices".into());
        };
        let sample_type = first.sample_type();
        if slices.len() as u64 != dims.z
            || slices
                .iter()
                .any(|s| s.len() as u64 != dims.slice_len() || s.sample_type() != sample_type)
        {
            return Err(format!(
                "the slices do not make a {dims} volume of one sample type"
            ));
        }
        Ok(MemoryReader {
            info: InputInfo {
                path: path.to_path_buf(),
                dims,
                sample_type,
                spacing,
                geometry,
                format: "memory".into(),
                nifti_codes: None,
            },
            slices,
        })
    }
}

impl SliceReader for MemoryReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        Ok(self.slices[z as usize].clone())
    }
    fn bytes_in(&self) -> u64 {
        self.slices.iter().map(|s| s.as_bytes().len() as u64).sum()
    }
}
