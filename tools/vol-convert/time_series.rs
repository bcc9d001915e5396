//! `--time-point all`: every volume of a 4D input (a DICOM time series,
//! 4D NIfTI, a hyperstack, an OME-Zarr time series) into one 4D NIfTI.
//!
//! Each volume goes through the one conversion path (its stages
//! included) into a NIfTI of its own in a scratch directory beside the
//! output, so memory stays one volume's slab; then the volumes' data are
//! joined behind one header whose `dim[4]` counts them and whose
//! `pixdim[4]` is the time step. Every volume must come out with the same
//! grid, type and scaling; the output appears only when complete.

use super::{convert_opened, prepare_output, usage_at, Cli};
use anyhow::{anyhow, Result};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;
use volcore::Compression;
use volformats::convert::{CompressArg, SliceReader};
use volformats::dicom::Scan;
use volformats::open::InputKind;
use volkit_cli::{json, noteln};

/// What a 4D conversion wrote.
pub struct Written {
    /// Volumes.
    pub count: u64,
    /// Seconds between them, where the input states it.
    pub step_s: Option<f64>,
    /// Bytes of the output.
    pub bytes: u64,
    /// The input's notes (skipped files, a value convention), from its
    /// first volume: the same for every one.
    pub notes: Vec<String>,
}

/// Convert every volume of `input` (a DICOM input through `scan` when
/// one was made, else scanned here once) into the 4D NIfTI `out`.
pub fn convert(cli: &Cli, input: &Path, scan: Option<&Scan>, out: &Path) -> Result<Written> {
    let name = out.to_string_lossy().to_ascii_lowercase();
    if !(name.ends_with(".nii") || name.ends_with(".nii.gz")) {
        return Err(usage_at(
            out,
            "--time-point all writes one 4D NIfTI: name it .nii or .nii.gz (4D OME-Zarr and NRRD are not written yet: convert one --time-point T at a time)",
        ));
    }
    if cli.shard.is_some() {
        return Err(usage_at(
            out,
            "--time-point all is not sharded: shard one --time-point T at a time",
        ));
    }
    let first = cli.input_sel.at_time(0);
    let opts = volkit_cli::select::read_options(&first, &[input])?;
    let owned;
    let scan = match scan {
        Some(s) => Some(s),
        None if matches!(
            volformats::open::input_kind(input, &opts)?,
            InputKind::DicomDir | InputKind::Dicom
        ) =>
        {
            owned = volformats::open::dicom_scan(input, &opts)?;
            Some(&owned)
        }
        None => None,
    };
    let axis = match scan {
        Some(s) => {
            let info = s.info(first.series.as_deref())?;
            TimeAxis {
                count: info.time_points,
                step_s: info.time_step,
            }
        }
        None => {
            let stacks = volformats::open::stacks(input, &opts)?;
            TimeAxis {
                count: stacks.time_points,
                step_s: stacks
                    .time_step
                    .zip(stacks.time_unit)
                    .map(|(s, u)| s * u.seconds()),
            }
        }
    };
    let open = |t: u64| -> Result<Box<dyn SliceReader>> {
        let sel = cli.input_sel.at_time(t);
        let opts = volkit_cli::select::read_options(&sel, &[input])?;
        Ok(match scan {
            Some(s) => Box::new(s.open(opts.dicom_pick())?),
            None => volformats::open_input(input, &opts)?,
        })
    };
    let dir = volformats::output::parent_dir(out);
    let (scratch, _lock) = volformats::output::temp_dir_in(
        &dir,
        &volformats::output::temp_prefix(out),
        volformats::output::PARTIAL,
    )
    .map_err(|e| anyhow!("{}: cannot make a scratch directory: {e}", dir.display()))?;
    let bar =
        volkit_cli::progress::count_bar(Some(axis.count), "vol-convert", "time points", cli.quiet);
    let mut parts = Vec::new();
    let mut notes = Vec::new();
    let mut acquisition = None;
    for t in 0..axis.count {
        bar.set_position(t);
        let reader = open(t).map_err(|e| e.context(format!("time point {t}")))?;
        if t == 0 {
            notes = reader.notes();
            if cli.sidecar {
                acquisition = Some(super::sidecar_fields(cli, input, reader.as_ref())?);
            }
        }
        let part = scratch.path().join(format!("{t}.nii"));
        let one = Cli {
            input_sel: cli.input_sel.at_time(t),
            output: part.clone(),
            compress: CompressArg::Vvol(Compression::None),
            json: false,
            quiet: true,
            sidecar: false,
            ..cli.clone()
        };
        let (window, target) = prepare_output(&one, input)?;
        convert_opened(&one, input, reader, window, target, Instant::now())
            .map_err(|e| e.context(format!("time point {t}")))?;
        parts.push(part);
    }
    bar.set_position(axis.count);
    join(&parts, &axis, out, cli.compress)?;
    if let Some(fields) = acquisition {
        super::sidecar::write(out, fields)?;
    }
    bar.finish_and_clear();
    Ok(Written {
        count: axis.count,
        step_s: axis.step_s,
        bytes: std::fs::metadata(out).map(|m| m.len()).unwrap_or(0),
        notes,
    })
}

/// Say what [`convert`] wrote: the notes and a line, or `--json`'s object.
pub fn report(cli: &Cli, input: &Path, w: &Written, start: Instant) -> Result<()> {
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-convert",
            "input": input.display().to_string(),
            "output": cli.output.display().to_string(),
            "time_points": w.count,
            "time_step": w.step_s,
            "time_unit": w.step_s.map(|_| "second"),
            "bytes": w.bytes,
            "seconds": seconds,
        });
        json::emit(&v, false)?;
    } else if !cli.quiet {
        for note in &w.notes {
            noteln!("vol-convert: {note}");
        }
        noteln!(
            "vol-convert: wrote {} ({} time points, {} bytes) in {seconds:.2} s",
            cli.output.display(),
            w.count,
            w.bytes
        );
    }
    Ok(())
}

/// What the volumes of a 4D input are: how many, and the time between
/// them (seconds) where the input states it.
pub struct TimeAxis {
    /// Volumes.
    pub count: u64,
    /// Seconds from one to the next.
    pub step_s: Option<f64>,
}

/// The NIfTI file `part`, split into its header (up to `vox_offset`) and
/// a reader of its data.
fn open_part(part: &Path) -> Result<(Vec<u8>, std::fs::File)> {
    let at = |e: &dyn std::fmt::Display| anyhow!("{}: {e}", part.display());
    let mut f = std::fs::File::open(part).map_err(|e| at(&e))?;
    let mut head = vec![0u8; volformats::nifti::NIFTI2_LEN];
    let n = f.read(&mut head).map_err(|e| at(&e))?;
    head.truncate(n);
    let vox_offset = volformats::nifti::NiftiHeader::decode(&head)
        .map_err(|e| at(&e))?
        .vox_offset as u64;
    f.seek(std::io::SeekFrom::Start(0)).map_err(|e| at(&e))?;
    let mut head = vec![0u8; vox_offset as usize];
    f.read_exact(&mut head).map_err(|e| at(&e))?;
    Ok((head, f))
}

/// Join the volume files `parts` (NIfTI, in time order, each with the
/// same header) into the 4D NIfTI `output` (gzip for `.gz`, at
/// `compress`'s level), under a temporary name renamed when complete.
pub fn join(
    parts: &[PathBuf],
    axis: &TimeAxis,
    output: &Path,
    compress: volformats::convert::CompressArg,
) -> Result<()> {
    let first = parts
        .first()
        .ok_or_else(|| anyhow!("{}: no volumes to write", output.display()))?;
    let (head0, _) = open_part(first)?;
    let header = volformats::nifti::with_time_axis(&head0, parts.len() as u64, axis.step_s)
        .map_err(|e| anyhow!("{}: {e}", output.display()))?;
    let body = |out: &mut dyn Write| -> Result<()> {
        out.write_all(&header)?;
        for (t, part) in parts.iter().enumerate() {
            let (head, mut data) = open_part(part)?;
            if head != head0 {
                return Err(anyhow!(
                    "volume {t} came out with another grid, type or scaling than volume 0: give --type (and --window) so every volume takes one"
                ));
            }
            std::io::copy(&mut data, out)?;
        }
        Ok(())
    };
    // .nii.gz's level: --compress gzip:LEVEL, else gzip's default.
    let level = match compress {
        volformats::convert::CompressArg::Gzip(l) => l,
        _ => 6,
    };
    let write = || -> Result<()> {
        let atomic = volformats::output::AtomicFile::create(output)?;
        let mut handle = std::io::BufWriter::new(atomic.handle()?);
        if output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gz"))
        {
            let mut gz = flate2::write::GzEncoder::new(handle, flate2::Compression::new(level));
            body(&mut gz)?;
            gz.finish()?.flush()?;
        } else {
            body(&mut handle)?;
            handle.flush()?;
        }
        atomic.commit()?;
        Ok(())
    };
    write().map_err(|e| anyhow!("{}: {e}", output.display()))
}
