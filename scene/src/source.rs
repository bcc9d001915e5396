//! The volume a render reads and its index, opened and loaded (or built)
//! as the options say, with the time each took.

use crate::error::{Error, ErrorKind, Kind, Result};
use crate::options::Options;
use std::path::{Path, PathBuf};
use std::time::Instant;
use volcore::Volume;
use volformats::vvol;
use volindex::{BuildOptions, MinMaxIndex};

/// A volume ready to render: the data, its empty-space-skipping index
/// (none under `--no-ess`), where it came from, and the seconds spent.
pub struct Source {
    /// The volume.
    pub volume: Volume,
    /// Its index (`--index`, or built in memory with `--cell`); `None`
    /// when skipping is off.
    pub index: Option<MinMaxIndex>,
    /// The volume's path (errors name it; `--accumulate` fingerprints it).
    pub path: PathBuf,
    /// The fingerprint of the file that was opened (see [`Source::open`]),
    /// or why it has none; `None` when not taken.
    pub fingerprint: Option<std::result::Result<u64, String>>,
    /// Seconds to open the volume.
    pub load_s: f64,
    /// Seconds to read or build the index.
    pub index_s: f64,
}

impl Source {
    /// Open the volume at `path` (`--in-memory` as the options say) and
    /// read or build its index.
    ///
    /// Path tracing (whose random sequence and `--accumulate` state belong
    /// to the volume's fingerprint) and `--index` (checked against it) take
    /// the file's fingerprint before and after opening it, and open it
    /// again if the two differ: a file replaced (renamed over) meanwhile
    /// never pairs one file's data with the other's fingerprint.
    pub fn open(options: &Options, path: &Path) -> Result<Source> {
        let t = Instant::now();
        let wants = options.index.is_some() || options.mode == crate::choices::ModeArg::Path;
        let fp = || volformats::fingerprint(path).map_err(|e| e.to_string());
        let mut tries = 0;
        let (volume, fingerprint) = loop {
            let before = wants.then(fp);
            let volume = open(options, path)?;
            let Some(before) = before else {
                break (volume, None);
            };
            let after = fp();
            if before == after {
                break (volume, Some(after));
            }
            tries += 1;
            if tries == 5 {
                return Err(Error::file(format!(
                    "{}: the file changed while it was opened, {tries} times",
                    path.display()
                )));
            }
        };
        let load_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let index = index_for(options, path, &volume, fingerprint.clone())?;
        let index_s = t.elapsed().as_secs_f64();
        Ok(Source {
            volume,
            index,
            path: path.to_path_buf(),
            fingerprint,
            load_s,
            index_s,
        })
    }

    /// A volume already in memory (a caller's array), its index built
    /// as the options say (`--index` is read and checked against the file
    /// at `path`); `path` names the volume in messages.
    pub fn from_volume(options: &Options, volume: Volume, path: &Path) -> Result<Source> {
        let t = Instant::now();
        let index = load_index(options, path, &volume)?;
        let index_s = t.elapsed().as_secs_f64();
        Ok(Source {
            volume,
            index,
            path: path.to_path_buf(),
            fingerprint: None,
            load_s: 0.0,
            index_s,
        })
    }

    /// The volume as errors name it.
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }
}

/// Open the volume at `path` (in memory with `--in-memory`).
pub fn open(options: &Options, path: &Path) -> Result<Volume> {
    let mut read = options.input.read_options().map_err(Error::usage)?;
    volformats::open::check_applies(path, &read).map_err(|e| Error::usage(e.to_string()))?;
    read.vvol = vvol::OpenOptions {
        in_memory: options.in_memory,
        ..Default::default()
    };
    volformats::open(path, &read).map_err(|e| {
        // A reader's error names its file already (a slice of a stack,
        // the volume itself).
        Error::file(e.to_string())
    })
}

/// The index the options ask for: none under `--no-ess` (unless
/// `--adaptive` reads its cells), the `--index` file (checked against the
/// volume at `path`), else one built in memory with `--cell`.
pub fn load_index(options: &Options, path: &Path, vol: &Volume) -> Result<Option<MinMaxIndex>> {
    index_for(options, path, vol, None)
}

/// [`load_index`], with the volume file's fingerprint when already taken.
fn index_for(
    options: &Options,
    path: &Path,
    vol: &Volume,
    fingerprint: Option<std::result::Result<u64, String>>,
) -> Result<Option<MinMaxIndex>> {
    if options.no_ess && options.adaptive.is_none() {
        return Ok(None);
    }
    match &options.index {
        Some(p) => {
            let name = p.display().to_string();
            let fp = match fingerprint {
                Some(Ok(fp)) => fp,
                Some(Err(e)) => return Err(Error::file(format!("{}: {e}", path.display()))),
                None => volformats::fingerprint(path).kind_ctx(ErrorKind::File, path.display())?,
            };
            let file = std::fs::File::open(p).kind_ctx(ErrorKind::File, &name)?;
            let mut f = std::io::BufReader::new(file);
            let ix = MinMaxIndex::read_for_volume(&mut f, &vol.meta, fp)
                .kind_ctx(ErrorKind::File, &name)?;
            Ok(Some(ix))
        }
        None => {
            let opts = BuildOptions {
                cell_edge: options.cell,
                ..Default::default()
            };
            let ix = MinMaxIndex::build_volume(vol, &opts, 0).kind_ctx(
                ErrorKind::File,
                format_args!("{}: building the index", path.display()),
            )?;
            Ok(Some(ix))
        }
    }
}

/// Start the worker pool with `--threads` workers (rayon's default, one
/// per core, without it). The pool is the process's: a second call with
/// `--threads` fails.
pub fn start_threads(options: &Options) -> Result<()> {
    if let Some(n) = options.threads {
        if n == 0 {
            return Err(Error::option("--threads must be at least 1"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .kind_ctx(ErrorKind::Render, "cannot start the worker threads")?;
    }
    Ok(())
}
