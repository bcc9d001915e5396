//! Directory outputs (a TIFF directory, an OME-Zarr store): what may be at
//! the target, and the temporary directory renamed into place.

use crate::error::Error;
use crate::reader::{At, CResult, ConvertError};
use std::fs::File;
use std::path::{Path, PathBuf};

/// What a directory output found at its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Found {
    /// Nothing, or an empty directory.
    Nothing,
    /// An OME-Zarr image (an earlier write's), which the new one replaces.
    Store,
}

/// What is at a directory output's target: nothing or an empty directory,
/// or (`store`: an OME-Zarr output) an OME-Zarr image, which the output
/// replaces as a file output replaces a file. Anything else is refused: a
/// directory of other files is never replaced, nor a file.
pub(super) fn check_dir_target(target: &Path, store: bool) -> CResult<Found> {
    if let Ok(mut entries) = std::fs::read_dir(target) {
        if entries.next().is_some() {
            if store && crate::omezarr::is_image_store(target) {
                return Ok(Found::Store);
            }
            return Err(ConvertError::new(
                target,
                Error::invalid(if store {
                    "output directory exists and is not empty, and is no OME-Zarr image to replace"
                } else {
                    "output directory exists and is not empty"
                }),
            ));
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
    check_dir_target(target, false).map(drop)
}

/// A directory written under a temporary name beside the target and
/// renamed into place when complete (removed if dropped before; swept by
/// the next write of the same target if the writer is killed, see
/// [`crate::output::temp_dir_in`]). An OME-Zarr store (`store`) replaces
/// an earlier one at the target in one swap
/// ([`crate::output::replace_dir`]).
pub(super) struct PartialDir {
    pub(super) temp: tempfile::TempDir,
    /// The temporary directory, open: its lock marks the writer alive.
    _lock: File,
    target: PathBuf,
    store: bool,
}

impl PartialDir {
    pub(super) fn create(target: &Path, store: bool) -> CResult<PartialDir> {
        let target = target.components().as_path().to_path_buf();
        check_dir_target(&target, store)?;
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
            store,
        })
    }

    pub(super) fn commit(self) -> CResult<()> {
        let target = self.target.clone();
        let temp = self.temp.keep();
        // What is there now (checked at creation too).
        let done = check_dir_target(&target, self.store).and_then(|found| match found {
            Found::Store => crate::output::replace_dir(&temp, &target).at(&target),
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
