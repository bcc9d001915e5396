//! vol-convert: TIFF stacks, raw, NRRD, MetaImage, .vol and .vvol into
//! sliced or bricked .vvol (or back to TIFF, raw and .vol), streaming with
//! bounded memory.

use anyhow::{anyhow, bail, Result};
use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use volcore::{Compression, SampleType, Shard};
use volformats::convert::{self, CompressArg, OutputOptions, Plan, Target, ValueMap, Window};
use volformats::omezarr::{Downsample, Ngff};
use volformats::output::AtomicFile;
use volformats::tiff::ChannelSel;
use volformats::vvol::part;
use volformats::{open_input, PrepFlags};
use volkit_cli::args::{self, LayoutArg};
use volkit_cli::{json, noteln, usage, Selection};

/// Convert a volume between formats, slice by slice.
///
/// INPUT is a NIfTI file (.nii, .nii.gz, .hdr/.img), a TIFF file
/// (multipage or BigTIFF), a directory of TIFF slices (natural order:
/// slice2 before slice10), a glob such as 'scan/*.tif' (quote it), a
/// .txt/.lst file listing slices, a .raw file (dims and type from flags or
/// from NAME_XxYxZ_TYPE.raw), NRRD (.nrrd/.nhdr, raw or gzip), MetaImage
/// (.mhd/.mha), a DICOM series (a directory, or a glob or list of DICOM
/// files: files that join no series, such as a DICOMDIR, a report or a
/// capture without ImagePositionPatient, are skipped and counted; vol-info
/// lists them with their reasons), an OME-Zarr (NAME.ome.zarr), a thesis
/// .vol, a .vvol, or - for standard input (a .vvol stream, a NRRD with
/// attached data, or raw with --raw-dims).
///
/// 8, 16 and 32-bit integer and 32 and 64-bit float samples are read.
/// u8, u16, i16, f32 and f64 are kept as they are (f64 in every output
/// but the u8-only .vol); i8, u32 and i32 become the smallest of u8, u16,
/// i16, f32 that holds their values exactly, or need --type and --window.
/// --type f32 from f64 rounds each value to the nearest f32 and says the
/// largest change.
///
/// The output format follows OUTPUT: .vvol (sliced or bricked, optional
/// zstd per brick), .vol (thesis format, u8), .raw (little-endian, x
/// fastest), .tif/.tiff (one multipage file), .nii/.nii.gz/.hdr (NIfTI),
/// .nrrd/.nhdr (NRRD, attached or detached), .mha/.mhd (MetaImage),
/// NAME.ome.zarr (OME-Zarr with --pyramid N levels: NGFF 0.4 on Zarr v2,
/// or 0.5 on Zarr v3 with --ngff 0.5), a path
/// ending in / (a directory of TIFF slices), or - (a sliced .vvol stream on
/// stdout). Origin and axis directions are carried into every format that
/// stores them (.vvol, NIfTI, NRRD, MetaImage).
///
/// Type conversion never loses values silently: a narrowing --type needs
/// --window lo:hi (linear, clamped), auto[:P] (P-th and (100-P)-th
/// percentiles of the histogram, P = 0.5) or full (the input type's range;
/// for f32 input the data's min..max). Float to int rounds half away from
/// zero; NaN becomes the bottom of the output range (0 for u8/u16, -32768
/// for i16) and stays NaN for floats. With a window, f32 output spans 0..1.
///
/// The output appears only when complete: a failed conversion leaves no
/// file behind.
#[derive(Parser, Debug, Clone)]
#[command(name = "vol-convert", version, after_help = EXAMPLES)]
struct Cli {
    /// Input file, directory of slices, glob, list file, or -.
    #[arg(required_unless_present = "merge")]
    input: Option<PathBuf>,
    /// Output path (.vvol, .vol, .raw, .tif, .nii[.gz], .nrrd, .mha, DIR/, or -).
    #[arg(short, long)]
    output: PathBuf,
    /// Output layout: sliced, or bricked:B (.vvol and .vol).
    #[arg(long, default_value = "sliced", value_parser = args::layout)]
    layout: LayoutArg,
    /// Compression: none; zstd or zstd:LEVEL per brick for bricked .vvol;
    /// gzip or gzip:LEVEL (1 fastest to 9 smallest; gzip is 6) for NRRD
    /// (.nrrd, .nhdr), MetaImage (zlib: .mha, .mhd) and NIfTI .hdr/.img
    /// data (.nii.gz is gzip by its name; --compress gzip:1 sets its
    /// level). gzip is compressed on every core, as independent gzip
    /// members every reader accepts.
    #[arg(long, default_value = "none", value_parser = compress_arg)]
    compress: CompressArg,
    /// Output sample type: u8, u16, i16, f32, f64 (default: the input's).
    #[arg(long = "type", value_parser = args::sample_type)]
    sample_type: Option<SampleType>,
    /// Value window for --type: lo:hi, auto, auto:P or full.
    #[arg(long, allow_hyphen_values = true)]
    window: Option<String>,
    /// Voxel spacing x,y,z (default: from the input, else 1,1,1), in the
    /// unit of --units when given, else the input's.
    #[arg(long, value_parser = args::spacing3)]
    spacing: Option<[f32; 3]>,
    /// Unit of length of the output's spacing and origin: m, cm, mm, um,
    /// nm or angstrom. The input's are converted (and the factor said on
    /// stderr); an input that states no unit is labelled with it. Default:
    /// the input's unit, except that NIfTI (m, mm, um only) and MetaImage
    /// (mm, by ITK's convention) get the nearest unit they can state,
    /// converted and said.
    #[arg(long, value_name = "UNIT", value_parser = args::length_unit)]
    units: Option<volcore::LengthUnit>,
    /// Keep x0:x1,y0:y1,z0:z1 (half-open voxel ranges; empty bounds are the edges).
    #[arg(long)]
    crop: Option<String>,
    /// Mirror along these axes, e.g. z or x,y.
    #[arg(long, value_delimiter = ',', value_parser = ["x", "y", "z"])]
    flip: Vec<String>,
    /// OME-Zarr output: pyramid levels, the full resolution included. Each
    /// level halves the axes whose spacing is less than twice the finest
    /// (0.5,0.5,2 becomes 1,1,2, then 2,2,2, then 4,4,4); every level's
    /// scale is recorded. More levels than the volume makes is refused.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    pyramid: u32,
    /// OME-Zarr output: how each pyramid level's voxel is made from the
    /// full-resolution voxels it stands for: mean (rounded once, for
    /// integer types) or max.
    #[arg(long, default_value = "mean", value_parser = one_of::<Downsample>(["mean", "max"]))]
    downsample: Downsample,
    /// OME-Zarr output: NGFF 0.4 on Zarr v2 (the default: napari-ome-zarr,
    /// Fiji and every ome-zarr-py release read it) or 0.5 on Zarr v3 (read
    /// by ome-zarr-py 0.10 and later).
    #[arg(long, value_name = "VERSION", value_parser = one_of::<Ngff>(["0.4", "0.5"]))]
    ngff: Option<Ngff>,
    /// Convert only shard K of N (K from 0) into a part file (-o
    /// NAME.vpart): its share of the brick layers (bricked) or slices
    /// (sliced), reading only the input slices those need. Run the N shards
    /// anywhere (a Slurm array, GNU parallel), then --merge the parts. For
    /// OME-Zarr output (-o NAME.ome.zarr) every shard writes its chunk
    /// layers straight into the store, and the last to finish writes the
    /// metadata: no merge.
    #[arg(long, value_name = "K/N", value_parser = args::shard)]
    shard: Option<Shard>,
    /// Assemble the N part files of a sharded conversion (any order) into
    /// one .vvol (-o OUT.vvol): byte for byte what the unsharded conversion
    /// writes. Compressed bricks are copied, not recompressed; every
    /// brick's checksum is checked on the way.
    #[arg(long, value_name = "PART", num_args = 1.., conflicts_with_all = [
        "input", "shard", "layout", "compress", "sample_type", "window", "spacing", "crop",
        "flip", "channel", "luma", "pyramid", "downsample", "ngff", "time_point", "series",
        "units", "orient", "resample", "kernel", "no_antialias", "smooth", "median", "clamp",
        "threshold", "mask",
    ])]
    merge: Vec<PathBuf>,
    #[command(
        flatten,
        next_help_heading = "Preprocessing (in this order after --crop: orient, resample, smooth, median, clamp, threshold, mask)"
    )]
    prep: PrepFlags,
    #[command(flatten, next_help_heading = "Input")]
    input_sel: Selection,
    /// Colour TIFF: keep the luma 0.299 R + 0.587 G + 0.114 B (instead of
    /// one --channel).
    #[arg(long, conflicts_with = "channel", help_heading = "Input")]
    luma: bool,
    /// DICOM input: write what the series states about its acquisition
    /// (EchoTime, RepetitionTime, FlipAngle, ConvolutionKernel, ...) as
    /// a BIDS sidecar beside the output, as dcm2niix does: OUT.nii.gz gets
    /// OUT.json.
    #[arg(long)]
    sidecar: bool,
    /// Print one JSON object with what was done (to stderr when -o -).
    #[arg(long)]
    json: bool,
    /// Print nothing but errors (no progress bar, no summary).
    #[arg(short, long)]
    quiet: bool,
}

const EXAMPLES: &str = "Examples:
  vol-convert scan/ -o scan.vvol
  vol-convert 'scan/*.tif' --layout bricked:32 --compress zstd -o scan.vvol
  vol-convert ct.tif --type u8 --window -1000:2000 --crop 0:512,0:512,100:400 -o ct.vvol
  vol-convert bonsai_256x256x256_uint8.raw --flip z -o bonsai.vvol
  vol-convert head.nrrd --type u8 --window auto -o head.vol
  vol-convert scan.vvol -o slices/
  vol-convert ct.nii.gz --pyramid 4 -o ct.ome.zarr            # NGFF 0.4, Zarr v2
  vol-convert ct.nii.gz --pyramid 4 --ngff 0.5 -o ct.ome.zarr # NGFF 0.5, Zarr v3
  vol-convert ct.ome.zarr --level 2 -o ct-quarter.nii.gz      # read pyramid level 2
  vol-gen shapes --dims 256,256,256 -o - | vol-convert - --layout bricked:32 -o out.vvol

Preprocessing (one pass; the stages apply in the order of the help's heading):
  vol-convert ct/ --series 3 --orient RAS --resample spacing:1 -o ct-1mm.nii.gz
  vol-convert fmri/ --time-point all --orient RAS -o run.nii.gz       # every volume, one 4D NIfTI
  vol-convert export/ --series all -o 'nifti/{number}_{description}.nii.gz'   # every series
  vol-convert ct.nii --resample spacing:0.5,0.5,1 --kernel bspline3 -o fine.nii
  vol-convert labels.nii --resample like:ct-1mm.nii.gz --kernel label -o labels-1mm.nii
  vol-convert ct.nii --smooth gauss:1 --clamp -1000:2000 -o smooth.nii
  vol-convert ct.nii --median 1 --threshold 300:3000 -o bone-mask.nii
  vol-convert ct.nii --mask bone-mask.nii --background -1024 -o bone.nii
  vol-convert ct.nii --orient RAS -o - | vol-convert - --smooth gauss:2 -o ras-smooth.nii   # another order

Sharded (each shard reads only the slices its brick layers need):
  for k in 0 1 2 3; do vol-convert scan/ --layout bricked:32 --shard $k/4 -o scan.$k.vpart; done
  vol-convert --merge scan.*.vpart -o scan.vvol          # identical to the unsharded scan.vvol";

/// Keep freed buffers in the process. Slices and write chunks of a few
/// hundred KiB to a few MiB are allocated and freed for every unit, and
/// glibc would hand such blocks back to the kernel (they are above its
/// mmap threshold) and fault fresh zeroed pages in again: about a third of
/// the CPU time of a plain TIFF-to-.vvol conversion. Memory stays bounded
/// by what the conversion holds at once.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn tune_malloc() {
    extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }
    const M_TRIM_THRESHOLD: i32 = -1;
    const M_MMAP_THRESHOLD: i32 = -3;
    // SAFETY: mallopt only sets allocator parameters; called before any
    // thread is started.
    unsafe {
        mallopt(M_MMAP_THRESHOLD, 64 << 20);
        mallopt(M_TRIM_THRESHOLD, 256 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_malloc() {}

/// On Ctrl-C or SIGTERM, stop the conversion at the next slice so that
/// the temporary output is removed on the way out; a second signal exits
/// at once.
#[cfg(unix)]
fn stop_on_signals() {
    extern "C" {
        fn signal(signum: i32, handler: usize) -> usize;
        fn _exit(status: i32) -> !;
    }
    extern "C" fn on_signal(_: i32) {
        if convert::stop_requested() {
            // SAFETY: _exit is async-signal-safe.
            unsafe { _exit(130) }
        }
        convert::request_stop();
    }
    const SIGINT: i32 = 2;
    const SIGTERM: i32 = 15;
    // SAFETY: the handler only touches an atomic (or calls _exit).
    unsafe {
        signal(SIGINT, on_signal as extern "C" fn(i32) as usize);
        signal(SIGTERM, on_signal as extern "C" fn(i32) as usize);
    }
}

#[cfg(not(unix))]
fn stop_on_signals() {}

mod export;
mod sidecar;
mod time_series;

fn main() -> ExitCode {
    tune_malloc();
    stop_on_signals();
    let cli = match volkit_cli::parse::<Cli>("vol-convert") {
        Ok(c) => c,
        Err(code) => return code,
    };
    volkit_cli::run("vol-convert", || {
        if cli.merge.is_empty() {
            convert_cmd(&cli)
        } else {
            merge_cmd(&cli)
        }
    })
}

/// `--merge`: assemble part files into one `.vvol`.
fn merge_cmd(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let out = &cli.output;
    let is_vvol = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vvol"));
    if !is_vvol {
        return Err(usage_at(
            out,
            "--merge writes a .vvol file: name it OUT.vvol",
        ));
    }
    let mut parts = part::open_parts(&cli.merge)?;
    // The parts' data lengths come from their headers: add them checked.
    let data = parts
        .iter()
        .try_fold(0u64, |n, p| n.checked_add(p.header.data_len))
        .ok_or_else(|| at(out, "the parts' data lengths add up past 2^64 bytes"))?;
    volformats::output::check_space(out, data).map_err(|e| at(out, e))?;
    let bar = volkit_cli::progress::bytes_bar(data, "vol-convert", cli.quiet);
    let mut file = AtomicFile::create(out).map_err(|e| at(out, e))?;
    let stats = part::merge(&mut parts, file.file(), out, &|n| bar.set_position(n))?;
    file.commit().map_err(|e| at(out, e))?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let m = &stats.meta;
    if cli.json {
        let (min, max) = if stats.range.is_empty() {
            (None, None)
        } else {
            (Some(stats.range.min), Some(stats.range.max))
        };
        let d = m.dims;
        let v = serde_json::json!({
            "tool": "vol-convert",
            "mode": "merge",
            "parts": parts.len(),
            "output": out.display().to_string(),
            "dims": [d.x, d.y, d.z],
            "type": m.sample_type.name(),
            "spacing": m.spacing,
            "layout": match m.layout { volcore::Layout::Sliced => "sliced".to_string(), volcore::Layout::Bricked(g) => format!("bricked:{}", g.brick()) },
            "compression": match m.compression { Compression::None => "none".to_string(), Compression::Zstd(l) => format!("zstd:{l}") },
            "bytes": stats.bytes,
            "min": min,
            "max": max,
            "seconds": seconds,
        });
        json::emit(&v, false)?;
    } else if !cli.quiet {
        noteln!(
            "vol-convert: merged {} parts into {} ({} {}, {} bytes) in {:.2} s",
            parts.len(),
            out.display(),
            m.dims,
            m.sample_type,
            stats.bytes,
            seconds
        );
    }
    Ok(())
}

/// An error about `path`, as `path: message`.
fn at(path: &Path, msg: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("{}: {msg}", path.display())
}

/// A usage error about `path` (exit status 2).
fn usage_at(path: &Path, msg: impl std::fmt::Display) -> anyhow::Error {
    usage(format!("{}: {msg}", path.display()))
}

/// A value among `names` (listed in the help and in clap's error),
/// parsed by its type's `FromStr` (the rules the Python package follows).
fn one_of<T>(names: [&'static str; 2]) -> impl clap::builder::TypedValueParser<Value = T>
where
    T: std::str::FromStr<Err = String> + Clone + Send + Sync + 'static,
{
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names).try_map(|s| s.parse::<T>())
}

fn compress_arg(s: &str) -> Result<CompressArg, String> {
    CompressArg::parse(s)
}

/// The output target `-o` and the output options name (usage errors when
/// they do not go together): the rules live with the writers.
fn target(cli: &Cli, opts: &OutputOptions) -> Result<Target> {
    let stdout: Option<Box<dyn std::io::Write + Send>> = if cli.output.as_os_str() == "-" {
        Some(Box::new(volkit_cli::stdout_file()?))
    } else {
        None
    };
    Target::for_output(&cli.output, opts, stdout).map_err(usage)
}

/// The output options the flags name.
fn output_options(cli: &Cli) -> OutputOptions {
    OutputOptions {
        layout: cli.layout,
        compress: cli.compress,
        pyramid: cli.pyramid,
        downsample: cli.downsample,
        ngff: cli.ngff,
        shard: cli.shard,
    }
}

fn convert_cmd(cli: &Cli) -> Result<()> {
    let start = Instant::now();
    let Some(input) = &cli.input else {
        return Err(usage("no INPUT given (or --merge PARTS...)"));
    };
    if cli.input_sel.series.as_deref() == Some("all") {
        return export::convert_all_series(cli, input);
    }
    if cli.input_sel.time_point == Some(volformats::TimePoint::All) {
        let w = time_series::convert(cli, input, None, &cli.output)?;
        return time_series::report(cli, input, &w, start);
    }
    // Check the output first: a bad output name should not cost a scan.
    let (window, target) = prepare_output(cli, input)?;
    let mut opts = volkit_cli::select::read_options(&cli.input_sel, &[input])?;
    if cli.luma {
        opts.channel = ChannelSel::Luma;
    }
    let reader = open_input(input, &opts)?;
    convert_opened(cli, input, reader, window, target, start)
}

/// The output side of a conversion, checked before any input is read:
/// the window's syntax and the target (`-o` with the output options).
fn prepare_output(cli: &Cli, input: &Path) -> Result<(Option<Window>, Target)> {
    let window: Option<Window> = match &cli.window {
        Some(w) => Some(
            w.parse()
                .map_err(|e| usage_at(input, format!("--window {e}")))?,
        ),
        None => None,
    };
    // Malformed values and a missing companion flag are usage errors
    // (exit 2), as clap's own are.
    convert::check_window(window.as_ref(), cli.sample_type).map_err(|e| usage_at(input, e))?;
    let out_opts = output_options(cli);
    let target = target(cli, &out_opts)?;
    target.preflight().map_err(anyhow::Error::new)?;
    Ok((window, target))
}

/// Convert the volume `reader` opened from `input` into `target`, as the
/// flags say, and report it.
fn convert_opened(
    cli: &Cli,
    input: &Path,
    reader: Box<dyn volformats::convert::SliceReader>,
    window: Option<Window>,
    target: Target,
    start: Instant,
) -> Result<()> {
    let out_opts = output_options(cli);
    let acquisition = match cli.sidecar {
        true => Some(sidecar_fields(cli, input, reader.as_ref())?),
        false => None,
    };
    // Told once the conversion succeeds: an error stays one line.
    let notes = reader.notes();
    let info = reader.info().clone();
    let crop = match &cli.crop {
        Some(s) => {
            let parsed = convert::parse_crop(s).map_err(|e| usage_at(input, e))?;
            Some(convert::resolve_crop(&parsed, info.dims).map_err(|e| at(input, e))?)
        }
        None => None,
    };
    let flip = ["x", "y", "z"].map(|a| cli.flip.iter().any(|f| f == a));
    let prep = cli
        .prep
        .resolve(&target.temp_dir())
        .map_err(anyhow::Error::new)?;
    let plan = Plan {
        crop,
        flip,
        sample_type: cli.sample_type,
        window,
        spacing: cli.spacing,
        unit: cli.units,
        temp_dir: None,
        prep,
    };
    // The grid, type and bytes the output will have (crop, units,
    // stages, the shard's share); checks an OME-Zarr pyramid fits.
    let total = convert::output_size(&info, &plan, &target, &cli.output, &out_opts)
        .map_err(anyhow::Error::new)?
        .bytes;
    // The samples alone must fit where the output goes (bricks add their
    // aprons; compressed bricks may take less, so they are not checked).
    if cli.output.as_os_str() != "-" && matches!(cli.compress, CompressArg::Vvol(Compression::None))
    {
        volformats::output::check_space(&cli.output, total).map_err(|e| at(&cli.output, e))?;
    }
    let bar = volkit_cli::progress::bytes_bar(total, "vol-convert", cli.quiet);
    let progress = |n: u64| bar.set_position(n);
    let report = convert::convert(reader, &plan, target, &progress).map_err(|e| {
        // The output is written under a temporary name, removed on failure.
        let e = anyhow::Error::new(e);
        if volkit_cli::run::is_disk_full(&e) {
            e.context("out of space: the partial output was removed")
        } else {
            e
        }
    })?;
    bar.finish_and_clear();
    if !cli.quiet {
        for note in &notes {
            noteln!("vol-convert: {note}");
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let to_stdout = cli.output.as_os_str() == "-";
    if cli.json {
        let window = match report.map {
            ValueMap::Exact => serde_json::Value::Null,
            ValueMap::Linear { lo, hi } => serde_json::json!([lo, hi]),
        };
        let (min, max) = match report.range {
            Some(r) if !r.is_empty() => (Some(r.min), Some(r.max)),
            _ => (None, None),
        };
        let d = report.dims;
        let g = &report.geometry;
        let v = serde_json::json!({
            "tool": "vol-convert",
            "input": input.display().to_string(),
            "format": report.input_format,
            "input_type": report.input_type.name(),
            "output": cli.output.display().to_string(),
            "dims": [d.x, d.y, d.z],
            "type": report.sample_type.name(),
            "spacing": report.spacing,
            "unit": json::unit(g.unit),
            "origin": g.origin,
            "direction": g.direction,
            "orientation": g.orientation(),
            "layout": match cli.layout { LayoutArg::Sliced => "sliced".to_string(), LayoutArg::Bricked(b) => format!("bricked:{b}") },
            "compression": cli.compress.name(),
            "window": window,
            "bytes": report.bytes_out,
            "bytes_in": report.bytes_in,
            "min": min,
            "max": max,
            "spooled": report.spooled,
            "shard": cli.shard.map(|s| s.to_string()),
            "seconds": seconds,
            "threads": rayon::current_num_threads(),
        });
        json::emit(&v, to_stdout)?;
    } else if !cli.quiet && !to_stdout {
        noteln!(
            "vol-convert: wrote {} ({} {}, {} bytes) in {:.2} s",
            cli.output.display(),
            report.dims,
            report.sample_type,
            report.bytes_out,
            seconds
        );
    }
    // A shard past the last unit has nothing to write, by design.
    if report.bytes_out == 0 && cli.shard.is_none() {
        bail!("{}: nothing was written", cli.output.display());
    }
    if !cli.quiet {
        for n in &report.notes {
            noteln!("vol-convert: note: {}: {n}", cli.output.display());
        }
    }
    raw_note(cli, &report);
    if let Some(fields) = acquisition {
        sidecar::write(&cli.output, fields)?;
    }
    Ok(())
}

/// What `reader` states of its acquisition, for `--sidecar`; a usage
/// error for inputs that state none or an output on stdout.
fn sidecar_fields(
    cli: &Cli,
    input: &Path,
    reader: &dyn volformats::convert::SliceReader,
) -> Result<serde_json::Map<String, serde_json::Value>> {
    if cli.output.as_os_str() == "-" {
        return Err(usage(
            "--sidecar writes a file beside the output: give -o a file",
        ));
    }
    reader.sidecar().ok_or_else(|| {
        usage_at(
            input,
            "--sidecar writes what a DICOM series states about its acquisition; this input states none",
        )
    })
}

/// A raw output whose name does not say its dims and type: tell how to
/// read it back.
fn raw_note(cli: &Cli, report: &convert::Report) {
    let is_raw = cli
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("raw"));
    if !is_raw || cli.quiet || volformats::raw::parse_name(&cli.output).is_some() {
        return;
    }
    let d = report.dims;
    let t = report.sample_type;
    noteln!(
        "vol-convert: note: {} holds {d} {t} little-endian without a header: read it with --raw-dims {},{},{} --raw-type {t}, or name it NAME_{}x{}x{}_{}.raw",
        cli.output.display(),
        d.x,
        d.y,
        d.z,
        d.x,
        d.y,
        d.z,
        t.long_name()
    );
}
