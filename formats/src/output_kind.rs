//! Naming the native output formats from a path (inputs are recognised
//! by [`crate::open::input_kind`]).

use std::path::Path;

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
