//! Picking a format from a path.

use crate::error::{Error, Result};
use crate::{raw, thesis, vvol};
use std::path::Path;
use volcore::Volume;

/// The volume formats volkit reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// Native `.vvol` (also `-`, a sliced `.vvol` stream).
    Vvol,
    /// The thesis `.vol`.
    ThesisVol,
    /// Headerless `.raw`.
    Raw,
}

impl FileKind {
    /// The kind a path's extension names; `-` is a `.vvol` stream.
    pub fn of(path: &Path) -> Option<FileKind> {
        if path.as_os_str() == "-" {
            return Some(FileKind::Vvol);
        }
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "vvol" => Some(FileKind::Vvol),
            "vol" => Some(FileKind::ThesisVol),
            "raw" => Some(FileKind::Raw),
            _ => None,
        }
    }
}

/// Open any volume file by its extension (`-` reads a sliced `.vvol`
/// stream from standard input). Raw files take dims and type from their
/// name, or from `raw` when given.
pub fn open_volume(
    path: &Path,
    opts: vvol::OpenOptions,
    raw: Option<raw::RawSpec>,
) -> Result<Volume> {
    if path.as_os_str() == "-" {
        return vvol::read_stream(&mut std::io::stdin().lock());
    }
    match FileKind::of(path) {
        Some(FileKind::Vvol) => vvol::open(path, opts),
        Some(FileKind::ThesisVol) => thesis::open(path)?.load(),
        Some(FileKind::Raw) => {
            let spec = match raw {
                Some(s) => s,
                None => {
                    let (dims, sample_type) = raw::parse_name(path).ok_or_else(|| {
                        Error::invalid(
                            "raw file needs dims and type: name it NAME_XxYxZ_TYPE.raw or pass them",
                        )
                    })?;
                    raw::RawSpec {
                        dims,
                        sample_type,
                        big_endian: false,
                        skip: 0,
                    }
                }
            };
            raw::open(path, spec)
        }
        None => Err(Error::invalid(
            "unknown file type (expected .vvol, .vol or .raw)",
        )),
    }
}
