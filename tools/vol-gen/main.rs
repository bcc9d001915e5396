//! vol-gen: procedural test volumes, generated in parallel and streamed to
//! disk (or stdout) with bounded memory.

use anyhow::{bail, Context, Result};
use clap::Parser;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use volcore::scene::{Scene, SceneSource, SceneSpec};
use volcore::{BrickGeometry, Compression, Dims, Layout, Sample, SampleType, VolumeMeta};
use volformats::output::{AtomicFile, Sink};
use volformats::{thesis, vvol, FileKind};
use volkit_cli::args::{self, LayoutArg};
use volkit_cli::{json, noteln, usage};

/// Generate a procedural test volume.
///
/// The output format follows the extension: .vvol (native, sliced or
/// bricked, optional zstd per brick), .vol (the thesis format, u8 only),
/// .raw (x fastest, little-endian; the name must carry the dims and type,
/// NAME_XxYxZ_TYPE.raw, so that the next tool can read it), or - for a
/// sliced .vvol stream on stdout.
/// The same arguments and seed always give the same bytes, whatever the
/// number of threads.
#[derive(Parser, Debug)]
#[command(name = "vol-gen", version, after_help = EXAMPLES)]
struct Cli {
    /// Dimensions X,Y,Z in voxels.
    #[arg(long, value_parser = args::dims3)]
    dims: [u64; 3],
    /// Sample type (default: u8; i16 for phantom).
    #[arg(long = "type", value_parser = args::sample_type)]
    type_arg: Option<SampleType>,
    /// Voxel spacing x,y,z (world units between voxel centres).
    #[arg(long, default_value = "1,1,1", value_parser = args::spacing3)]
    spacing: [f32; 3],
    /// Storage layout: sliced, or bricked:B (cubic bricks of edge B).
    #[arg(long, default_value = "sliced", value_parser = args::layout)]
    layout: LayoutArg,
    /// Per-brick compression for bricked .vvol: none, zstd or zstd:LEVEL.
    #[arg(long, default_value = "none", value_parser = args::compression)]
    compress: Compression,
    /// The scene and its parameters (seed, count, size, value, ...: the
    /// scene options, in the order --help has always listed them).
    #[command(flatten)]
    spec: SceneSpec,
    /// Output path (.vvol, .vol, NAME_XxYxZ_TYPE.raw) or - for a sliced .vvol on stdout.
    #[arg(short, long)]
    output: PathBuf,
    /// Print one JSON object with the figures (to stderr when -o -).
    #[arg(long)]
    json: bool,
    /// Print nothing but errors (no progress bar, no summary).
    #[arg(short, long)]
    quiet: bool,
}

impl Cli {
    /// The sample type written: as given, else the scene's own.
    fn sample_type(&self) -> SampleType {
        self.spec.sample_type(self.type_arg)
    }
}

const EXAMPLES: &str = "Examples:
  vol-gen shapes --dims 800,800,800 --seed 2 --count 70 --size 70 --value 100 -o shapes.vvol
  vol-gen noise --dims 256,256,256 --layout bricked:32 --compress zstd -o noise.vvol
  vol-gen sphere --dims 64,64,64 --type f32 --radius 30 -o sphere.vvol
  vol-gen sphere --dims 96,96,96 --radius 36 --edge 4 -o ball.vvol
  vol-gen phantom --dims 256,256,256 --layout bricked:32 -o head.vvol
  vol-gen waves --dims 120,120,120 --type f32 --spacing 0.5,0.5,2 -o waves.vvol
  vol-gen shapes --dims 256,256,256 --layout bricked:16 -o thesis.vol
  vol-gen shapes --dims 128,128,128 -o - | vol-info -";

/// The checks that need more than one option (see [`SceneSpec::validate`]).
fn validate(cli: &Cli) -> Result<(), String> {
    let [x, y, z] = cli.dims;
    let dims = Dims::new(x, y, z).map_err(|e| e.to_string())?;
    cli.spec.validate(cli.sample_type(), dims)
}

fn main() -> ExitCode {
    let cli = match volkit_cli::parse::<Cli>("vol-gen") {
        Ok(c) => c,
        Err(code) => return code,
    };
    if let Err(e) = validate(&cli) {
        volkit_cli::run::report_error("vol-gen", &e);
        return ExitCode::from(volkit_cli::run::EXIT_USAGE);
    }
    volkit_cli::run("vol-gen", || generate(&cli))
}

/// Refuse an output name the tool cannot write, or a raw name the next
/// tool could not read back, before any work (usage errors).
fn check_output(cli: &Cli, dims: Dims) -> Result<()> {
    let out = &cli.output;
    if out.as_os_str() == "-" {
        return Ok(());
    }
    let name = out.display();
    match FileKind::of(out) {
        None => Err(usage(format!(
            "{name}: unknown output type: use a .vvol, .vol or .raw file name, or - for stdout"
        ))),
        Some(FileKind::Raw) => {
            let want = format!(
                "{}x{}x{}_{}",
                dims.x,
                dims.y,
                dims.z,
                cli.sample_type().long_name()
            );
            match volformats::raw::parse_name(out) {
                Some((d, t)) if d == dims && t == cli.sample_type() => Ok(()),
                Some(_) => Err(usage(format!(
                    "{name}: the name says other dims or type than --dims and --type: name it NAME_{want}.raw"
                ))),
                None => Err(usage(format!(
                    "{name}: a raw file does not record its dims and type: name it NAME_{want}.raw so the next tool can read it"
                ))),
            }
        }
        Some(_) => Ok(()),
    }
}

fn generate(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let [x, y, z] = cli.dims;
    let dims = Dims::new(x, y, z)?;
    check_output(cli, dims)?;
    let scene = cli.spec.build(dims);
    let stats = match cli.sample_type() {
        SampleType::U8 => write_as::<u8>(cli, dims, scene.as_ref()),
        SampleType::U16 => write_as::<u16>(cli, dims, scene.as_ref()),
        SampleType::I16 => write_as::<i16>(cli, dims, scene.as_ref()),
        SampleType::F32 => write_as::<f32>(cli, dims, scene.as_ref()),
        SampleType::F64 => write_as::<f64>(cli, dims, scene.as_ref()),
    }
    .with_context(|| cli.output.display().to_string())?;
    let seconds = start.elapsed().as_secs_f64();
    if cli.json {
        let v = serde_json::json!({
            "tool": "vol-gen",
            "scene": cli.spec.scene.name(),
            "output": cli.output.display().to_string(),
            "dims": cli.dims,
            "type": cli.sample_type().name(),
            "layout": match cli.layout { LayoutArg::Sliced => "sliced".to_string(), LayoutArg::Bricked(b) => format!("bricked:{b}") },
            "compression": match cli.compress { Compression::None => "none".to_string(), Compression::Zstd(l) => format!("zstd:{l}") },
            "seed": cli.spec.seed,
            "bytes": stats.bytes,
            "min": stats.min,
            "max": stats.max,
            "seconds": seconds,
            "threads": rayon::current_num_threads(),
        });
        json::emit(&v, cli.output.as_os_str() == "-")?;
    } else if !cli.quiet && cli.output.as_os_str() != "-" {
        noteln!(
            "vol-gen: wrote {} ({} bytes) in {:.2} s",
            cli.output.display(),
            stats.bytes,
            seconds
        );
    }
    Ok(())
}

/// Largest slab of slices held in memory while writing bricks.
const MAX_SLAB_BYTES: u64 = 1 << 30;

/// Write a `.vvol` file. Bricked layouts are written one brick layer at a
/// time from a slab of whole slices generated with full-length rows: far
/// cheaper than evaluating the scene in short brick rows (and the aprons
/// twice). Memory: the slices of one brick layer plus its aprons, B + 3 of
/// them; when that would exceed 1 GiB the scene is evaluated per brick.
fn write_vvol_file<T: Sample>(
    src: &SceneSource<'_, T>,
    meta: VolumeMeta,
    file: &mut std::fs::File,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<vvol::WriteStats> {
    let slab_bytes = match meta.layout {
        Layout::Bricked(g) => {
            meta.dims.slice_len() * g.stored_edge() as u64 * T::TYPE.size() as u64
        }
        Layout::Sliced => u64::MAX,
    };
    if slab_bytes > MAX_SLAB_BYTES {
        return Ok(vvol::write(src, meta, Sink::File(file), progress)?);
    }
    let mut w = vvol::VvolWriter::new(Sink::File(file), meta, progress)?;
    let mut buffer = Vec::new();
    loop {
        let zs = w.next_slices();
        if zs.is_empty() {
            break;
        }
        let slab = volcore::region::Slab::fill(src, zs, buffer);
        w.write_next(&slab)?;
        buffer = slab.into_buffer();
    }
    Ok(w.finish()?)
}

struct Written {
    bytes: u64,
    min: Option<f64>,
    max: Option<f64>,
}

fn write_as<T: Sample>(cli: &Cli, dims: Dims, scene: &dyn Scene) -> Result<Written> {
    let src = SceneSource::<T>::new(scene);
    let total = dims.checked_bytes(T::TYPE.size() as u64)?;
    let bar = volkit_cli::progress::bytes_bar(total, "vol-gen", cli.quiet);
    let progress = |n: u64| bar.set_position(n);
    let to_stdout = cli.output.as_os_str() == "-";
    let kind = FileKind::of(&cli.output).with_context(|| {
        "unknown output type: use a .vvol, .vol or .raw file name, or - for stdout"
    })?;
    let layout = match cli.layout {
        LayoutArg::Sliced => Layout::Sliced,
        LayoutArg::Bricked(b) => Layout::Bricked(BrickGeometry::new(dims, b)?),
    };
    if kind != FileKind::Vvol && cli.compress != Compression::None {
        bail!("--compress applies to .vvol output only");
    }
    if matches!(layout, Layout::Sliced) && cli.compress != Compression::None {
        bail!("--compress needs --layout bricked:B (compression is per brick)");
    }
    if to_stdout && !matches!(layout, Layout::Sliced) {
        bail!("stdout takes a sliced stream only: drop --layout or write to a file");
    }
    let meta = VolumeMeta {
        dims,
        spacing: cli.spacing,
        sample_type: T::TYPE,
        range: volcore::ValueRange::EMPTY,
        layout,
        compression: cli.compress,
        geometry: volcore::Geometry::IDENTITY,
        narrowed: None,
    };
    let range_of = |r: volcore::ValueRange| {
        if r.is_empty() {
            (None, None)
        } else {
            (Some(r.min), Some(r.max))
        }
    };
    if to_stdout {
        // Write to the descriptor directly: Rust's stdout is line-buffered
        // and would scan every binary chunk for newlines.
        let mut out = volkit_cli::stdout_file()?;
        let s = vvol::write(&src, meta, Sink::Stream(&mut out), &progress)?;
        out.flush()?;
        bar.finish_and_clear();
        let (min, max) = range_of(s.range);
        return Ok(Written {
            bytes: s.bytes,
            min,
            max,
        });
    }
    // What the output kind refuses, and whether the output fits on its
    // file system, before a byte is written.
    let thesis_layout = match cli.layout {
        LayoutArg::Sliced => thesis::ThesisLayout::Sliced,
        LayoutArg::Bricked(b) if b <= 255 => thesis::ThesisLayout::Bricked(b as u8),
        LayoutArg::Bricked(b) if kind == FileKind::ThesisVol => {
            bail!("the thesis .vol format takes bricks up to 255, not {b}")
        }
        LayoutArg::Bricked(_) => thesis::ThesisLayout::Sliced,
    };
    let expected = match kind {
        // Compressed bricks: only the header and brick table are known.
        FileKind::Vvol => vvol::Header::for_meta(meta)?.file_len(),
        FileKind::ThesisVol => {
            if T::TYPE != SampleType::U8 {
                bail!("the thesis .vol format holds u8 samples only: use --type u8");
            }
            let h = thesis::ThesisHeader {
                dims,
                spacing: cli.spacing,
                layout: thesis_layout,
            };
            h.data_len().and_then(|n| n.checked_add(thesis::HEADER_LEN))
        }
        FileKind::Raw => {
            if !matches!(layout, Layout::Sliced) {
                bail!(".raw output is sliced only: drop --layout");
            }
            Some(total)
        }
    };
    volformats::output::check_space(&cli.output, expected.unwrap_or(u64::MAX))?;
    let mut file = AtomicFile::create(&cli.output)?;
    let result = (|| -> Result<Written> {
        Ok(match kind {
            FileKind::Vvol => {
                let s = write_vvol_file(&src, meta, file.file(), &progress)?;
                let (min, max) = range_of(s.range);
                Written {
                    bytes: s.bytes,
                    min,
                    max,
                }
            }
            FileKind::ThesisVol => {
                let src8 = SceneSource::<u8>::new(scene);
                let bytes =
                    thesis::write(&src8, cli.spacing, thesis_layout, file.file(), &progress)?;
                Written {
                    bytes,
                    min: None,
                    max: None,
                }
            }
            FileKind::Raw => {
                let bytes = volformats::raw::write(&src, file.file(), &progress)?;
                Written {
                    bytes,
                    min: None,
                    max: None,
                }
            }
        })
    })();
    let written = match result {
        Ok(w) => w,
        Err(e) => return Err(discard_when_full(e, file)),
    };
    file.commit()
        .map_err(|e| full_disk_note(anyhow::Error::new(e), Ok(())))?;
    bar.finish_and_clear();
    Ok(written)
}

/// A write that failed on a full disk: remove the partial output now and
/// say so. Other errors leave the removal to the file's drop.
fn discard_when_full(e: anyhow::Error, file: AtomicFile) -> anyhow::Error {
    if volkit_cli::run::is_disk_full(&e) {
        let removed = file.discard();
        full_disk_note(e, removed)
    } else {
        e
    }
}

/// Name a full disk in the message, and what became of the partial file.
fn full_disk_note(e: anyhow::Error, removed: std::io::Result<()>) -> anyhow::Error {
    if !volkit_cli::run::is_disk_full(&e) {
        return e;
    }
    match removed {
        Ok(()) => e.context("out of space: the partial output was removed"),
        Err(r) => e.context(format!(
            "out of space, and the partial output could not be removed ({r})"
        )),
    }
}
