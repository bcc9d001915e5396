//! Directory outputs (a TIFF directory, an OME-Zarr store): what may be at
//! the target, and the temporary directory renamed into place.

use crate::error::Error;
use crate::reader::{At, CResult, ConvertError};
use std::fs::File;
use std::path::{Path, PathBuf};

/// A kind of directory output, and what of an earlier write it replaces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum DirOutput {
    /// A TIFF slice folder: replaces a folder holding only slice files
    /// (`slice_0000.tif`, ...), as an earlier write left it.
    TiffSlices,
    /// An OME-Zarr store: replaces an OME-Zarr image.
    OmeZarr,
    /// A shard's share of an OME-Zarr store: replaces nothing.
    New,
}

impl DirOutput {
    /// Whether `target` (a directory, not empty) is what an earlier write
    /// of this kind left, to be replaced whole.
    fn is_earlier(self, target: &Path) -> bool {
        match self {
            DirOutput::TiffSlices => is_slice_folder(target),
            DirOutput::OmeZarr => crate::omezarr::is_image_store(target),
            DirOutput::New => false,
        }
    }

    /// Why another non-empty directory is refused.
    fn refusal(self) -> &'static str {
        match self {
            DirOutput::TiffSlices => {
                "output directory exists and is not empty, and is no TIFF slice folder to replace"
            }
            DirOutput::OmeZarr => {
                "output directory exists and is not empty, and is no OME-Zarr image to replace"
            }
            DirOutput::New => "output directory exists and is not empty",
        }
    }
}

/// Whether every entry of `dir` is a file named `slice_DIGITS.tif`.
fn is_slice_folder(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    entries.into_iter().all(|e| {
        e.is_ok_and(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            let digits = name
                .strip_prefix("slice_")
                .and_then(|n| n.strip_suffix(".tif"));
            e.file_type().is_ok_and(|t| t.is_file())
                && digits.is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
        })
    })
}

/// What a directory output found at its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Found {
    /// Nothing, or an empty directory.
    Nothing,
    /// An earlier write of the same kind, which the new one replaces.
    Earlier,
}

/// What is at a directory output's target: nothing or an empty directory,
/// or what an earlier write of the same `kind` left, which the output
/// replaces as a file output replaces a file. Anything else is refused: a
/// directory of other files is never replaced, nor a file.
pub(super) fn check_dir_target(target: &Path, kind: DirOutput) -> CResult<Found> {
    if let Ok(mut entries) = std::fs::read_dir(target) {
        if entries.next().is_some() {
            if kind.is_earlier(target) {
                return Ok(Found::Earlier);
            }
            return Err(ConvertError::new(target, Error::invalid(kind.refusal())));
        }
    } else if target.exists() {
        return Err(ConvertError::new(
            target,
            Error::invalid("exists and is not a directory"),
        ));
    }
    Ok(Found::Nothing)
}

/// A shard's OME-Zarr store must be new, or hold only other shards of an
/// unfinished sharded write (their bookkeeping directory is there).
pub(super) fn check_shard_store(target: &Path) -> CResult<()> {
    let unfinished = target.join(crate::omezarr::SHARDS_DIR).is_dir();
    if unfinished {
        return Ok(());
    }
    check_dir_target(target, DirOutput::New).map(drop)
}

/// A directory written under a temporary name beside the target and
/// renamed into place when complete (removed if dropped before; swept by
/// the next write of the same target if the writer is killed, see
/// [`crate::output::temp_dir_in`]). It replaces an earlier write of the
/// same kind at the target in one swap ([`crate::output::replace_dir`]).
pub(super) struct PartialDir {
    pub(super) temp: tempfile::TempDir,
    /// The temporary directory, open: its lock marks the writer alive.
    _lock: File,
    target: PathBuf,
    kind: DirOutput,
}

impl PartialDir {
    pub(super) fn create(target: &Path, kind: DirOutput) -> CResult<PartialDir> {
        let target = target.components().as_path().to_path_buf();
        check_dir_target(&target, kind)?;
        let parent = crate::output::parent_dir(&target);
        let (temp, lock) = crate::output::temp_dir_in(
            &parent,
            &crate::output::temp_prefix(&target),
            crate::output::PARTIAL,
        )
        .at(&parent)?;
        Ok(PartialDir {
            temp,
            _lock: lock,
            target,
            kind,
        })
    }

    pub(super) fn commit(self) -> CResult<()> {
        let target = self.target.clone();
        let temp = self.temp.keep();
        // What is there now (checked at creation too).
        let done = check_dir_target(&target, self.kind).and_then(|found| match found {
            Found::Earlier => crate::output::replace_dir(&temp, &target).at(&target),
            Found::Nothing => {
                if target.is_dir() {
                    // Empty: rename replaces it.
                    std::fs::remove_dir(&target).at(&target)?;
                }
                std::fs::rename(&temp, &target).at(&target)
            }
        });
        if done.is_err() {
            let _ = std::fs::remove_dir_all(&temp);
        }
        done
    }
}
