//! The files the page saves: the frame as shown (PNG), its linear image
//! (PFM, byte for byte what `vol-render --hdr` writes for the same view)
//! and the view as a scene file. They go to the browser as downloads;
//! the server writes them to disk only into `--save-dir`.

use crate::protocol::SaveKind;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What is kept of the last full frame, to save it.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    /// The request it answers.
    pub seq: u64,
    /// The name its files share (`view-12`, `view-12-16spp`; see
    /// [`crate::worker::stem`]).
    pub stem: String,
    /// The `vol-render` command that renders it to `STEM.png` and
    /// `STEM.pfm` (reading `STEM.toml` when it needs the scene file).
    pub command: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The linear image, RGB floats from the top row.
    pub rgb: Vec<f32>,
    /// The PNG the page shows.
    pub png: Vec<u8>,
    /// The effective scene, TOML.
    pub toml: String,
}

/// A file to download: its name, type and bytes.
#[derive(Clone, Debug)]
pub struct Download {
    /// The file's name (`view-12.pfm`: the snapshot's stem).
    pub name: String,
    /// Its media type.
    pub mime: &'static str,
    /// Its bytes.
    pub bytes: Vec<u8>,
}

/// The file `what` of `snap`.
pub fn download(snap: &Snapshot, what: SaveKind) -> Result<Download, String> {
    let (ext, mime, bytes) = match what {
        SaveKind::Png => ("png", "image/png", snap.png.clone()),
        SaveKind::Pfm => {
            let mut out = Vec::new();
            volformats::image::encode_pfm(&mut out, snap.width, snap.height, 3, &snap.rgb)
                .map_err(|e| format!("the PFM: {e}"))?;
            ("pfm", "application/octet-stream", out)
        }
        SaveKind::Scene => ("toml", "application/toml", snap.toml.clone().into_bytes()),
    };
    Ok(Download {
        name: format!("{}.{ext}", snap.stem),
        mime,
        bytes,
    })
}

/// Write `d` into `dir` (complete or not at all); its path.
pub fn write_into(dir: &Path, d: &Download) -> Result<PathBuf, String> {
    let path = dir.join(&d.name);
    let shown = path.display().to_string();
    let write = || -> std::io::Result<()> {
        let mut file = volformats::output::AtomicFile::create(&path)?;
        file.file().write_all(&d.bytes)?;
        file.commit()
    };
    write().map_err(|e| format!("{shown}: {e}"))?;
    Ok(path)
}
