//! Writing the studies' tables: under a temporary name, then renamed into
//! place, so a failed study leaves no half-written table.

use anyhow::{Context, Result};
use std::path::Path;

/// Write `text` to `path` through `path` with the extension `tmp_ext`,
/// then rename.
pub fn write_via_temp(path: &Path, tmp_ext: &str, text: &str) -> Result<()> {
    let tmp = path.with_extension(tmp_ext);
    std::fs::write(&tmp, text).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))
}
