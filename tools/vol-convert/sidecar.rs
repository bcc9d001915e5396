//! `--sidecar`: the JSON beside an output that says what the DICOM
//! series states about its acquisition, under BIDS's names (as dcm2niix's
//! sidecar does): `run.nii.gz` gets `run.json`.

use anyhow::{anyhow, Result};
use serde_json::{Map, Value};
use std::io::Write;
use std::path::{Path, PathBuf};

/// `path` split before its format's extension (`.nii.gz` and
/// `.ome.zarr` count as one; a name that is all extension keeps it).
pub fn split_extension(path: &str) -> (&str, &str) {
    let lower = path.to_ascii_lowercase();
    let file_start = path.rfind('/').map_or(0, |i| i + 1);
    let cut = [
        ".nii.gz",
        ".ome.zarr",
        ".nhdr",
        ".nrrd",
        ".nii",
        ".hdr",
        ".mha",
        ".mhd",
        ".vvol",
        ".tiff",
        ".tif",
        ".raw",
        ".vol",
    ]
    .iter()
    .find(|e| lower.ends_with(*e) && path.len() - e.len() > file_start)
    .map_or(0, |e| e.len());
    path.split_at(path.len() - cut)
}

/// The sidecar's path for output `out`: its name less its format's
/// extension, plus `.json`.
pub fn path_for(out: &Path) -> PathBuf {
    let name = out.to_string_lossy();
    PathBuf::from(format!("{}.json", split_extension(&name).0))
}

/// Write `fields` (with the converting software named) beside `out`,
/// under a temporary name renamed when complete.
pub fn write(out: &Path, mut fields: Map<String, Value>) -> Result<()> {
    fields.insert("ConversionSoftware".into(), "volkit vol-convert".into());
    fields.insert(
        "ConversionSoftwareVersion".into(),
        env!("CARGO_PKG_VERSION").into(),
    );
    let path = path_for(out);
    let write = || -> Result<()> {
        let mut f = volformats::output::AtomicFile::create(&path)?;
        let text = serde_json::to_string_pretty(&Value::Object(fields))?;
        f.file().write_all(text.as_bytes())?;
        f.file().write_all(b"\n")?;
        f.commit()?;
        Ok(())
    };
    write().map_err(|e| anyhow!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sidecar_takes_the_outputs_name_less_its_extension() {
        assert_eq!(
            path_for(Path::new("out/run.nii.gz")),
            PathBuf::from("out/run.json")
        );
        assert_eq!(path_for(Path::new("ct.NRRD")), PathBuf::from("ct.json"));
        assert_eq!(
            path_for(Path::new("a.b/scan")),
            PathBuf::from("a.b/scan.json")
        );
        assert_eq!(path_for(Path::new("x.ome.zarr")), PathBuf::from("x.json"));
    }
}
