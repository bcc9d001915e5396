//! vol-index: build the empty-space-skipping (majorant) index of a volume
//! and save it as a `.vidx` sidecar file, or check an existing one.

use anyhow::{anyhow, bail, Result};
use clap::Parser;
use serde_json::{json, Value};
use std::ffi::OsString;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Dims, SampleType, Shard};
use volformats::output::AtomicFile;
use volformats::{thesis, FileKind, ReadOptions};
use volindex::build::DEFAULT_CELL_EDGE;
use volindex::histogram::DEFAULT_BINS;
use volindex::shard::{IndexPart, PART_EXTENSION};
use volindex::{BuildOptions, IndexError, MinMaxIndex};
use volkit_cli::{noteln, outln, usage, Selection};

/// Build the min/max macrocell index of a volume (any format vol-convert
/// reads: .vvol, .vol, .raw, NRRD, MetaImage, NIfTI, DICOM, TIFF, OME-Zarr) and
/// write it next to the volume as a .vidx file, with the volume's value
/// range and histogram. The index does not depend on the transfer function,
/// the layout or the thread count, and records a fingerprint of its volume
/// so that a stale index is rejected. With --check, verify an existing
/// index against its volume instead (exit status 0 if it matches).
#[derive(Parser, Debug)]
#[command(name = "vol-index", version, after_help = EXAMPLES)]
struct Cli {
    /// The volume file (.vvol, .vol, .raw, NRRD, NIfTI, ...).
    #[arg(required_unless_present = "merge")]
    volume: Option<PathBuf>,
    /// Output index file (default: the volume's path with .vidx appended).
    #[arg(short, long, value_name = "FILE.vidx", conflicts_with = "check")]
    output: Option<PathBuf>,
    /// Check this existing index against VOLUME instead of building one:
    /// its fingerprint, dimensions, type and checksum.
    #[arg(long, value_name = "FILE.vidx")]
    check: Option<PathBuf>,
    /// Macrocell edge in voxels (2..=1024).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_CELL_EDGE, conflicts_with = "check")]
    cell: u32,
    /// Histogram bins (1..=65536): at most N bins, one per value when the
    /// sample type has no more than N values (u8 with the default).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_BINS, conflicts_with = "check")]
    bins: u32,
    /// Print the value range, histogram summary, cells per level and the
    /// empty fraction (on stdout). Without -o no index is written: the
    /// figures only (vol-info --stats gives a volume's statistics, mean
    /// and SD included, without building an index).
    #[arg(long)]
    stats: bool,
    /// Print one JSON object with the figures instead of text.
    #[arg(long)]
    json: bool,
    /// Print nothing on success unless --stats or --json asks for it.
    #[arg(short, long)]
    quiet: bool,
    /// Build only shard K of N (K from 0) into a part file (-o
    /// NAME.vidxpart): the macrocell layers it owns, reading only the
    /// bricks or slices those cover. Run the N shards anywhere, then
    /// --merge the parts. f32 volumes need their value range recorded (a
    /// .vvol has it).
    #[arg(long, value_name = "K/N", value_parser = volkit_cli::args::shard, conflicts_with = "check")]
    shard: Option<Shard>,
    /// Join the N part files of a sharded build (any order) into one index
    /// (-o OUT.vidx): bit for bit the unsharded build's.
    #[arg(long, value_name = "PART", num_args = 1.., conflicts_with_all = ["volume", "shard", "check", "cell", "bins", "stats"])]
    merge: Vec<PathBuf>,
    #[command(flatten, next_help_heading = "Input")]
    input_sel: Selection,
}

const EXAMPLES: &str = "Examples:
  vol-index shapes.vvol                      # writes shapes.vvol.vidx
  vol-index shapes.vvol --stats              # prints range, histogram, cells; writes nothing
  vol-index shapes.vvol --stats -o s.vidx    # prints them and writes s.vidx
  vol-index noise.vvol --cell 16 -o noise-16.vidx --json
  vol-index --check shapes.vvol.vidx shapes.vvol && echo fresh
  vol-index --raw-dims 256,256,256 --raw-type u16 scan.raw

Sharded (each shard reads only the bricks of its macrocell layers):
  for k in 0 1 2 3; do vol-index scan.vvol --shard $k/4 -o scan.$k.vidxpart; done
  vol-index --merge scan.*.vidxpart -o scan.vvol.vidx     # identical to the unsharded index

The fingerprint of a .vvol covers its header and its checksummed trailer, so
any change to the samples makes the index stale. .vol and .raw files carry no
checksums: their fingerprint covers the length, the modification time and
sampled blocks of data, which is weaker (copy them with their timestamps).";

/// Requested quantiles of the histogram, with their JSON names.
const PERCENTILES: [(&str, f64); 7] = [
    ("p1", 0.01),
    ("p5", 0.05),
    ("p25", 0.25),
    ("p50", 0.50),
    ("p75", 0.75),
    ("p95", 0.95),
    ("p99", 0.99),
];

/// How many of the fullest bins the summary lists.
const BUSIEST: usize = 5;

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-index") {
        Ok(c) => c,
        Err(code) => return code,
    };
    volkit_cli::run("vol-index", || {
        if !cli.merge.is_empty() {
            return merge(&cli);
        }
        let Some(volume) = &cli.volume else {
            return Err(usage("no VOLUME given (or --merge PARTS...)"));
        };
        match (&cli.check, cli.shard) {
            (Some(index), _) => check(&cli, volume, index),
            (None, Some(shard)) => build_shard(&cli, volume, shard),
            (None, None) => build(&cli, volume),
        }
    })
}

/// `name: error` from the error's own message. The formats and index
/// errors print their cause and also return it as their source, so the
/// usual context chain would repeat it on the one error line.
fn at<E: std::fmt::Display>(name: &str) -> impl FnOnce(E) -> anyhow::Error + '_ {
    move |e| anyhow!("{name}: {e}")
}

/// `path` as the user wrote it, for messages.
fn name(path: &Path) -> String {
    path.display().to_string()
}

/// The volume's path with `.vidx` appended (`a.vvol` → `a.vvol.vidx`).
fn default_output(volume: &Path) -> PathBuf {
    let mut s = OsString::from(volume.as_os_str());
    s.push(".");
    s.push(volindex::vidx::EXTENSION);
    PathBuf::from(s)
}

/// How to read the volume.
fn read_options(cli: &Cli, volume: &Path) -> Result<ReadOptions> {
    volkit_cli::select::read_options(&cli.input_sel, &[volume])
}

/// Streams have no fingerprint, and the index must name its file.
fn refuse_stream(volume: &Path) -> Result<()> {
    if volume.as_os_str() == "-" {
        bail!("-: vol-index needs a volume file, not a stream (the index is tied to the file)");
    }
    Ok(())
}

/// Figures of a build, for the report.
struct Timing {
    load_s: f64,
    build_s: f64,
    write_s: f64,
    seconds: f64,
    /// Bytes written, `None` when no index was written.
    bytes: Option<u64>,
}

/// The build options the flags ask for, checked, for a volume file.
fn build_options(cli: &Cli, volume: &Path) -> Result<BuildOptions> {
    let opts = BuildOptions {
        cell_edge: cli.cell,
        histogram_bins: cli.bins,
    };
    opts.validate().map_err(|e| anyhow!("{e}"))?;
    refuse_stream(volume)?;
    Ok(opts)
}

/// Refuse an output the index cannot be written to: stdout, a part file
/// name, a volume file name.
fn check_output(output: &Path) -> Result<()> {
    let oname = name(output);
    if output.as_os_str() == "-" {
        return Err(usage(
            "-: the index is written to a file, not to stdout: use -o FILE.vidx",
        ));
    }
    if output.extension().is_some_and(|e| e == PART_EXTENSION) {
        return Err(usage(format!(
            "{oname}: .{PART_EXTENSION} files are the parts of a sharded build: add --shard K/N"
        )));
    }
    if FileKind::of(output).is_some() {
        return Err(usage(format!(
            "{oname}: refusing to write an index under a volume file name: use a .vidx name"
        )));
    }
    Ok(())
}

fn build(cli: &Cli, volume: &Path) -> Result<()> {
    let start = Instant::now();
    let opts = build_options(cli, volume)?;
    let vname = name(volume);
    let output = cli.output.clone().unwrap_or_else(|| default_output(volume));
    let oname = name(&output);
    // --stats alone asks for figures, not for a file: the index is built
    // in memory, and written only when -o names a file.
    let write = !cli.stats || cli.output.is_some();
    if write {
        check_output(&output)?;
    }
    let read = read_options(cli, volume)?;

    // Fingerprint first: if the file is replaced before it is opened, the
    // index holds the new samples under the old fingerprint and is rejected
    // as stale, never accepted for the wrong samples.
    let fp = volformats::fingerprint(volume).map_err(at(&vname))?;
    let vol = volformats::open(volume, &read).map_err(|e| anyhow!("{e}"))?;
    let load_s = start.elapsed().as_secs_f64();
    if let (false, Some(note)) = (cli.quiet, vol.meta.narrowed.and_then(|n| n.note())) {
        noteln!("vol-index: {vname}: {note} (indexed as f32, as the renderer reads it)");
    }

    let t = Instant::now();
    let ix = MinMaxIndex::build_volume(&vol, &opts, fp).map_err(at(&vname))?;
    if let Some(e) = vol.error() {
        bail!("{vname}: {e}");
    }
    let build_s = t.elapsed().as_secs_f64();
    // Changed in place while we read it (same name, new contents)?
    let after = volformats::fingerprint(volume).map_err(at(&vname))?;
    if after != fp {
        bail!("{vname}: the volume changed while it was being indexed: run vol-index again");
    }
    drop(vol);

    let t = Instant::now();
    let bytes = if write {
        Some(write_index(&ix, &output).map_err(at(&oname))?)
    } else {
        None
    };
    let write_s = t.elapsed().as_secs_f64();
    let timing = Timing {
        load_s,
        build_s,
        write_s,
        seconds: start.elapsed().as_secs_f64(),
        bytes,
    };

    if cli.json {
        let mut v = summary(&ix, volume, &output);
        v["mode"] = json!("build");
        v["output"] = json!(write.then_some(&oname));
        if !write {
            v["index"] = Value::Null;
        }
        v["bytes"] = json!(timing.bytes);
        v["load_s"] = json!(timing.load_s);
        v["build_s"] = json!(timing.build_s);
        v["write_s"] = json!(timing.write_s);
        v["seconds"] = json!(timing.seconds);
        v["threads"] = json!(rayon::current_num_threads());
        outln!("{v}")?;
        return Ok(());
    }
    if cli.stats {
        print_stats(&ix, volume)?;
    }
    if cli.quiet {
        return Ok(());
    }
    let Some(bytes) = timing.bytes else {
        noteln!(
            "vol-index: no index written (--stats without -o; add -o FILE.vidx to keep one; \
             vol-info --stats gives the volume's statistics without an index)"
        );
        return Ok(());
    };
    let s = ix.stats();
    noteln!(
        "vol-index: wrote {oname} ({} bytes, {} cells of {}³, {} levels) in {:.3} s \
         (open {:.3} s, build {:.3} s, write {:.3} s)",
        bytes,
        s.cells,
        ix.cell_edge(),
        s.levels,
        timing.seconds,
        timing.load_s,
        timing.build_s,
        timing.write_s,
    );
    Ok(())
}

/// `--shard K/N`: build one shard's part of the index.
fn build_shard(cli: &Cli, volume: &Path, shard: Shard) -> Result<()> {
    let start = Instant::now();
    let opts = build_options(cli, volume)?;
    let vname = name(volume);
    let Some(output) = &cli.output else {
        return Err(usage(format!(
            "{vname}: --shard writes a part file: give -o NAME.{PART_EXTENSION}"
        )));
    };
    let oname = name(output);
    if output.extension().is_none_or(|e| e != PART_EXTENSION) {
        return Err(usage(format!(
            "{oname}: with --shard the output is one part of an index: name it NAME.{PART_EXTENSION} (then vol-index --merge the parts -o NAME.vidx)"
        )));
    }
    let fp = volformats::fingerprint(volume).map_err(at(&vname))?;
    let vol = volformats::open(volume, &read_options(cli, volume)?).map_err(|e| anyhow!("{e}"))?;
    let part = volindex::shard::build_shard(&vol, &opts, fp, shard).map_err(at(&vname))?;
    if let Some(e) = vol.error() {
        bail!("{vname}: {e}");
    }
    let after = volformats::fingerprint(volume).map_err(at(&vname))?;
    if after != fp {
        bail!("{vname}: the volume changed while it was being indexed: run vol-index again");
    }
    let bytes = write_atomic(output, |w| part.write_to(w)).map_err(at(&oname))?;
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let v = json!({
            "tool": "vol-index",
            "mode": "shard",
            "input": vname,
            "output": oname,
            "shard": shard.to_string(),
            "layers": [part.layers.start, part.layers.end],
            "cell": part.cell_edge,
            "bytes": bytes,
            "seconds": seconds,
            "threads": rayon::current_num_threads(),
        });
        outln!("{v}")?;
    } else if !cli.quiet {
        noteln!(
            "vol-index: wrote {oname} (shard {shard}: cell layers {}..{}, {bytes} bytes) in {seconds:.3} s",
            part.layers.start,
            part.layers.end
        );
    }
    Ok(())
}

/// `--merge`: join part files into one index.
fn merge(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let Some(output) = &cli.output else {
        return Err(usage("--merge writes an index: give -o OUT.vidx"));
    };
    let oname = name(output);
    if output
        .extension()
        .is_none_or(|e| e != volindex::vidx::EXTENSION)
    {
        return Err(usage(format!(
            "{oname}: --merge writes an index: name it OUT.vidx"
        )));
    }
    let mut parts = Vec::with_capacity(cli.merge.len());
    for p in &cli.merge {
        let pname = name(p);
        let file = std::fs::File::open(p).map_err(at(&pname))?;
        let len = file.metadata().map_err(at(&pname))?.len();
        let part = IndexPart::read_from(&mut BufReader::with_capacity(1 << 20, file), len)
            .map_err(|e| match e {
                IndexError::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
                    anyhow!("{pname}: the part file is truncated")
                }
                other => at(&pname)(other),
            })?;
        parts.push(part);
    }
    let n = parts.len();
    let ix = volindex::shard::merge_parts(parts).map_err(|e| anyhow!("{oname}: {e}"))?;
    let bytes = write_index(&ix, output).map_err(at(&oname))?;
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let mut v = summary(&ix, Path::new(""), output);
        v["mode"] = json!("merge");
        v["parts"] = json!(n);
        v["input"] = Value::Null;
        v["output"] = json!(oname);
        v["bytes"] = json!(bytes);
        v["seconds"] = json!(seconds);
        outln!("{v}")?;
    } else if !cli.quiet {
        noteln!("vol-index: merged {n} parts into {oname} ({bytes} bytes) in {seconds:.3} s");
    }
    Ok(())
}

/// Write through `put` into a temporary file renamed to `path`; the bytes
/// written.
fn write_atomic(
    path: &Path,
    put: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> Result<(), IndexError>,
) -> Result<u64, IndexError> {
    let mut file = AtomicFile::create(path)?;
    let mut w = BufWriter::with_capacity(1 << 20, file.file());
    put(&mut w)?;
    w.flush()?;
    drop(w);
    let bytes = file.file().metadata()?.len();
    file.commit()?;
    Ok(bytes)
}

/// Write `ix` to `path` through a temporary file; the bytes written.
fn write_index(ix: &MinMaxIndex, path: &Path) -> Result<u64, IndexError> {
    write_atomic(path, |w| ix.write_to(w))
}

/// Dimensions and sample type of a volume, without reading its samples.
fn volume_shape(path: &Path, opts: &ReadOptions) -> Result<(Dims, SampleType)> {
    if FileKind::of(path) == Some(FileKind::ThesisVol) {
        // Opening would load the whole (z-fastest) file into memory.
        let h = *thesis::open(path).map_err(at(&name(path)))?.header();
        return Ok((h.dims, SampleType::U8));
    }
    let vol = volformats::open(path, opts).map_err(|e| anyhow!("{e}"))?;
    Ok((vol.meta.dims, vol.meta.sample_type))
}

fn check(cli: &Cli, volume: &Path, index: &Path) -> Result<()> {
    let start = Instant::now();
    refuse_stream(volume)?;
    let vname = name(volume);
    let iname = name(index);
    let opts = read_options(cli, volume)?;
    let fp = volformats::fingerprint(volume).map_err(at(&vname))?;
    let (dims, sample_type) = volume_shape(volume, &opts)?;
    let file = std::fs::File::open(index).map_err(at(&iname))?;
    let ix = MinMaxIndex::read_from(&mut BufReader::with_capacity(1 << 20, file), Some(fp))
        .and_then(|ix| ix.check_volume(dims, sample_type).map(|()| ix))
        .map_err(|e| match e {
            IndexError::Fingerprint { .. } => {
                anyhow!("{iname}: {e} (stale or foreign index: rebuild it with vol-index {vname})")
            }
            other => at(&iname)(other),
        })?;
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let mut v = summary(&ix, volume, index);
        v["mode"] = json!("check");
        v["ok"] = json!(true);
        v["bytes"] = json!(std::fs::metadata(index).map(|m| m.len()).ok());
        v["seconds"] = json!(seconds);
        outln!("{v}")?;
        return Ok(());
    }
    if cli.stats {
        print_stats(&ix, volume)?;
    }
    if !cli.quiet {
        outln!(
            "{iname}: ok, the index of {vname} ({} {}, cell {}, {} levels)",
            dims,
            sample_type,
            ix.cell_edge(),
            ix.level_count()
        )?;
    }
    Ok(())
}

/// A value for JSON: `null` when the range is empty (only NaNs).
fn range_json(ix: &MinMaxIndex) -> (Value, Value) {
    let (lo, hi) = ix.value_range();
    if lo <= hi {
        (json!(f64::from(lo)), json!(f64::from(hi)))
    } else {
        (Value::Null, Value::Null)
    }
}

/// The figures both modes report, as a JSON object.
fn summary(ix: &MinMaxIndex, volume: &Path, index: &Path) -> Value {
    let s = ix.stats();
    let h = ix.histogram();
    let (min, max) = range_json(ix);
    let total = h.total().max(1) as f64;
    let busiest: Vec<Value> = h.busiest(BUSIEST)
        .into_iter()
        .map(|i| {
            let (a, b) = h.bin_edges(i);
            json!({"lo": a, "hi": b, "count": h.counts()[i], "fraction": h.counts()[i] as f64 / total})
        })
        .collect();
    let mut pct = serde_json::Map::new();
    for (k, q) in PERCENTILES {
        pct.insert(k.to_string(), json!(h.quantile(q)));
    }
    json!({
        "tool": "vol-index",
        "input": name(volume),
        "index": name(index),
        "dims": ix.dims().as_array(),
        "type": ix.sample_type().name(),
        "fingerprint": format!("{:016x}", ix.fingerprint()),
        "cell": ix.cell_edge(),
        "cells": s.cells,
        "levels": s.levels,
        "level_cells": ix.levels().iter().map(|l| l.cells()).collect::<Vec<_>>(),
        "empty_fraction": s.empty_fraction,
        "min": min,
        "max": max,
        "nan_count": s.nan_count,
        "histogram": {
            "lo": h.lo(),
            "hi": h.hi(),
            "bins": h.bins(),
            "bin_width": (h.hi() - h.lo()) / h.bins() as f64,
            "busiest": busiest,
        },
        "percentiles": Value::Object(pct),
    })
}

/// The --stats text.
fn print_stats(ix: &MinMaxIndex, volume: &Path) -> std::io::Result<()> {
    let s = ix.stats();
    let h = ix.histogram();
    outln!(
        "{}: {} {}, cell {}",
        name(volume),
        ix.dims(),
        ix.sample_type(),
        ix.cell_edge()
    )?;
    let (lo, hi) = s.value_range;
    if lo <= hi {
        outln!("  values {lo} .. {hi}, {} NaN", s.nan_count)?;
    } else {
        outln!("  values: none ({} NaN)", s.nan_count)?;
    }
    let total = h.total();
    if total > 0 {
        let exact = if h.unit_bins() { "" } else { " (bin starts)" };
        let p: Vec<String> = PERCENTILES
            .iter()
            .filter_map(|&(k, q)| h.quantile(q).map(|v| format!("{k} {}", v as f32)))
            .collect();
        outln!("  percentiles{exact}: {}", p.join(", "))?;
        let b: Vec<String> = h
            .busiest(BUSIEST)
            .into_iter()
            .map(|i| {
                let pc = 100.0 * h.counts()[i] as f64 / total as f64;
                format!("{} {pc:.1}%", h.bin_label(i))
            })
            .collect();
        outln!(
            "  histogram: {} bins over [{}, {}); busiest: {}",
            h.bins(),
            h.lo() as f32,
            h.hi() as f32,
            b.join(", ")
        )?;
    }
    for (l, lv) in ix.levels().iter().enumerate() {
        let [x, y, z] = lv.cells();
        outln!(
            "  level {l}: {x}x{y}x{z} = {} cells of {}³ voxels",
            lv.len(),
            lv.edge()
        )?;
    }
    outln!(
        "  empty at threshold 0: {:.1}% of {} level-0 cells",
        100.0 * s.empty_fraction,
        s.cells
    )?;
    Ok(())
}
