//! The one way every tool opens a volume: [`open_input`] for a slice
//! reader (what `vol-convert` streams), [`open`] for a whole [`Volume`]
//! (what the other tools sample). Both read every format volkit knows,
//! by existence, extension and first bytes.

use crate::convert::{self, Plan};
use crate::datafile::Encoding;
use crate::error::Error;
use crate::raw::{RawFileReader, RawSpec};
use crate::reader::{At, CResult, ConvertError, Described, SliceReader};
use crate::stream::{skip_bytes, Counted, SampleLayout, StreamEnd, StreamReader};
use crate::tiff::ChannelSel;
use crate::{thesis, vvol};
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};
use volcore::{SampleType, Volume};

/// How to read an input: what its file cannot say itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// Raw input description (used when any field is given, or for
    /// `.raw` files).
    pub raw: RawSpec,
    /// Channel choice: colour TIFF samples, or the C axis of an ImageJ
    /// hyperstack or OME-TIFF.
    pub channel: ChannelSel,
    /// Time point of an ImageJ hyperstack or OME-TIFF/OME-Zarr with a T
    /// axis.
    pub time: Option<u64>,
    /// DICOM: the series to read when the input holds several: its
    /// SeriesNumber, its SeriesInstanceUID or a unique prefix of it.
    pub series: Option<String>,
    /// DICOM: the echo to read of a series whose echoes are an axis of
    /// their own (multi-echo), from 0; refused for every other input.
    pub echo: Option<u64>,
    /// DICOM: the values of a Philips series with a private scale slope.
    pub philips: crate::dicom::PhilipsScale,
    /// OME-Zarr: the pyramid level to read (`None`: level 0, the full
    /// resolution); refused for every other input.
    pub level: Option<u32>,
    /// How to open `.vvol` files.
    pub vvol: vvol::OpenOptions,
}

impl ReadOptions {
    /// What these options pick of a DICOM input.
    pub fn dicom_pick(&self) -> crate::dicom::Pick<'_> {
        crate::dicom::Pick {
            series: self.series.as_deref(),
            echo: self.echo,
            time: self.time,
            philips: self.philips,
        }
    }
}

/// What kind of input a path names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// Standard input.
    Stdin,
    /// A directory of TIFF slices.
    TiffDir,
    /// A shell pattern matching TIFF slices.
    TiffGlob,
    /// A text file listing TIFF slices.
    TiffList,
    /// One TIFF file (multipage or single page).
    Tiff,
    /// NRRD (`.nrrd`, `.nhdr`).
    Nrrd,
    /// MetaImage (`.mhd`, `.mha`).
    Mhd,
    /// NIfTI-1 or NIfTI-2 (`.nii`, `.nii.gz`, `.hdr`/`.img`).
    Nifti,
    /// A directory of DICOM files (one series, or several with `--series`).
    DicomDir,
    /// One DICOM file, or a glob or list file naming DICOM files.
    Dicom,
    /// An OME-Zarr directory (NGFF 0.4 or 0.5).
    OmeZarr,
    /// Native `.vvol`.
    Vvol,
    /// Thesis `.vol`.
    ThesisVol,
    /// Headerless samples.
    Raw,
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// Decide what `path` is: by existence, extension, and first bytes.
pub fn input_kind(path: &Path, opts: &ReadOptions) -> CResult<InputKind> {
    if path.as_os_str() == "-" {
        return Ok(InputKind::Stdin);
    }
    if crate::omezarr::is_zarr(path) && path.is_dir() {
        return Ok(InputKind::OmeZarr);
    }
    if path.is_dir() {
        return dir_kind(path);
    }
    let name = path.to_string_lossy();
    if !path.exists() {
        if has_glob_chars(&name) {
            let files = crate::tiff::list_glob(path)?;
            return Ok(listed_kind(&files, InputKind::TiffGlob));
        }
        return Err(ConvertError::new(
            path,
            Error::invalid("no such file or directory"),
        ));
    }
    if crate::nifti::is_nifti_name(path) {
        return Ok(InputKind::Nifti);
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let by_ext = match ext.as_str() {
        "tif" | "tiff" | "btf" | "tf8" => Some(InputKind::Tiff),
        "nrrd" | "nhdr" => Some(InputKind::Nrrd),
        "mhd" | "mha" => Some(InputKind::Mhd),
        "vvol" => Some(InputKind::Vvol),
        "vol" => Some(InputKind::ThesisVol),
        "dcm" => Some(InputKind::Dicom),
        "raw" => Some(InputKind::Raw),
        "txt" | "lst" | "list" => Some(InputKind::TiffList),
        _ => None,
    };
    if by_ext == Some(InputKind::TiffList) {
        let files = crate::tiff::list_file(path)?;
        return Ok(listed_kind(&files, InputKind::TiffList));
    }
    if let Some(k) = by_ext {
        return Ok(k);
    }
    if opts.raw.is_given() {
        return Ok(InputKind::Raw);
    }
    let mut head = [0u8; 352];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .at(path)?;
    let head = &head[..n];
    if crate::nifti::NiftiHeader::decode(head).is_ok() {
        Ok(InputKind::Nifti)
    } else if crate::dicom::sniff(head) {
        Ok(InputKind::Dicom)
    } else if is_tiff(head) {
        Ok(InputKind::Tiff)
    } else if crate::nrrd::sniff(head) {
        Ok(InputKind::Nrrd)
    } else if head.starts_with(&crate::vvol::MAGIC) {
        Ok(InputKind::Vvol)
    } else {
        Err(ConvertError::new(
            path,
            Error::invalid(
                "unknown input type (expected NIfTI, NRRD, MetaImage, TIFF, .vvol, .vol, .raw with --raw-dims, a DICOM series, an OME-Zarr, or a directory of slices)",
            ),
        ))
    }
}

/// Files named by a glob or a list: DICOM when the first is, else `tiff`.
fn listed_kind(files: &[PathBuf], tiff: InputKind) -> InputKind {
    if files
        .first()
        .is_some_and(|f| crate::dicom::is_dicom_file(f))
    {
        InputKind::Dicom
    } else {
        tiff
    }
}

/// The files of a DICOM input of kind [`InputKind::DicomDir`] or
/// [`InputKind::Dicom`]: a directory's DICOM files, a glob's or a list
/// file's files, or the one file.
fn dicom_files(path: &Path, kind: InputKind) -> CResult<Vec<PathBuf>> {
    let listed = match kind {
        InputKind::DicomDir => None,
        _ if !path.exists() && has_glob_chars(&path.to_string_lossy()) => {
            Some(crate::tiff::list_glob(path)?)
        }
        _ if is_list_name(path) => Some(crate::tiff::list_file(path)?),
        _ => Some(vec![path.to_path_buf()]),
    };
    crate::dicom::list_files(path, listed)
}

/// Whether `path` is named like a list file (`.txt`, `.lst`, `.list`).
fn is_list_name(path: &Path) -> bool {
    path.extension().is_some_and(|e| {
        let e = e.to_string_lossy().to_ascii_lowercase();
        matches!(e.as_str(), "txt" | "lst" | "list")
    })
}

/// Read the headers of a DICOM input (a directory, a glob or list of
/// DICOM files, or one file) without opening a series: what `vol-info`
/// lists when the input holds several. Other inputs are an error.
pub fn dicom_scan(path: &Path, opts: &ReadOptions) -> CResult<crate::dicom::Scan> {
    let kind = input_kind(path, opts)?;
    if !matches!(kind, InputKind::DicomDir | InputKind::Dicom) {
        return Err(ConvertError::new(
            path,
            Error::invalid(format!("not a DICOM input but {}", kind.name())),
        ));
    }
    let files = dicom_files(path, kind)?;
    crate::dicom::Scan::new(path, &files)
}

/// A directory: TIFF slices or a DICOM series.
fn dir_kind(dir: &Path) -> CResult<InputKind> {
    let mut dicom = false;
    for (n, e) in std::fs::read_dir(dir).at(dir)?.enumerate() {
        let e = e.at(dir)?;
        let name = e.file_name().to_string_lossy().to_ascii_lowercase();
        if name.starts_with('.') {
            continue;
        }
        if name.ends_with(".tif") || name.ends_with(".tiff") {
            return Ok(InputKind::TiffDir);
        }
        // Sniffing every file of a large directory is cheap next to
        // reading it; stop at the first DICOM file after a few hundred.
        if !dicom && n < 100_000 && e.path().is_file() && crate::dicom::is_dicom_file(&e.path()) {
            dicom = true;
        }
    }
    if dicom {
        return Ok(InputKind::DicomDir);
    }
    Err(ConvertError::new(
        dir,
        Error::invalid("directory holds no .tif/.tiff slices and no DICOM files"),
    ))
}

impl InputKind {
    /// A short name for reports (`nrrd`, `tiff stack`, ...).
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Stdin => "stream",
            InputKind::TiffDir | InputKind::TiffGlob | InputKind::TiffList => "tiff stack",
            InputKind::Tiff => "tiff",
            InputKind::Nrrd => "nrrd",
            InputKind::Mhd => "metaimage",
            InputKind::Nifti => "nifti",
            InputKind::DicomDir | InputKind::Dicom => "dicom series",
            InputKind::OmeZarr => "ome-zarr",
            InputKind::Vvol => "vvol",
            InputKind::ThesisVol => "vol",
            InputKind::Raw => "raw",
        }
    }
}

/// Whether bytes start like a TIFF or BigTIFF file.
pub fn is_tiff(b: &[u8]) -> bool {
    matches!(
        b.get(..4),
        Some(b"II*\0") | Some(b"MM\0*") | Some(b"II+\0") | Some(b"MM\0+")
    )
}

/// The one line that refuses `--level N` for an input of `kind`, which
/// has no pyramid levels (only OME-Zarr has).
fn level_refusal(kind: InputKind, level: u32) -> String {
    format!(
        "--level {level}: a {} input has no pyramid levels (--level picks a level of an OME-Zarr pyramid)",
        kind.name()
    )
}

/// `--level` given for an input of `kind` that has no levels, or
/// `--echo` for one that has no echoes (only DICOM has): an error.
fn refuse_level(path: &Path, kind: InputKind, opts: &ReadOptions) -> CResult<()> {
    let dicom = matches!(kind, InputKind::DicomDir | InputKind::Dicom);
    match (opts.level, opts.echo) {
        (Some(n), _) if kind != InputKind::OmeZarr => Err(ConvertError::new(
            path,
            Error::invalid(level_refusal(kind, n)),
        )),
        (_, Some(e)) if !dicom => Err(ConvertError::new(
            path,
            Error::invalid(format!(
                "--echo {e}: a {} input has no echo axis (--echo picks an echo of a multi-echo DICOM series)",
                kind.name()
            )),
        )),
        _ => Ok(()),
    }
}

/// Refuse what `opts` asks of the input `path` names that it cannot
/// have (`--level` of anything but an OME-Zarr) before anything is read:
/// the tools exit 2 with it as a usage error, Python raises `ValueError`.
/// A path whose kind cannot be told is left to the open that follows,
/// which says why.
pub fn check_applies(path: &Path, opts: &ReadOptions) -> CResult<()> {
    if opts.level.is_none() && opts.echo.is_none() {
        return Ok(());
    }
    match input_kind(path, opts) {
        Ok(kind) => refuse_level(path, kind, opts),
        Err(_) => Ok(()),
    }
}

/// Open the input `path` names (see [`input_kind`]).
pub fn open_input(path: &Path, opts: &ReadOptions) -> CResult<Box<dyn SliceReader>> {
    let kind = input_kind(path, opts)?;
    refuse_level(path, kind, opts)?;
    Ok(match kind {
        InputKind::Stdin => open_stdin(path, opts)?,
        InputKind::TiffDir | InputKind::TiffGlob | InputKind::TiffList => {
            let files = match kind {
                InputKind::TiffDir => crate::tiff::list_dir(path)?,
                InputKind::TiffGlob => crate::tiff::list_glob(path)?,
                _ => crate::tiff::list_file(path)?,
            };
            Box::new(crate::tiff::open_files(
                path,
                files,
                opts.channel,
                opts.time,
            )?)
        }
        InputKind::DicomDir | InputKind::Dicom => {
            let files = dicom_files(path, kind)?;
            Box::new(crate::dicom::open(path, files, opts.dicom_pick())?)
        }
        InputKind::OmeZarr => {
            let c = match opts.channel {
                ChannelSel::Channel(c) => Some(c as u64),
                _ => None,
            };
            Box::new(crate::omezarr::open(path, c, opts.time, opts.level)?)
        }
        InputKind::Tiff => match crate::tiff::imagej_raw(path)? {
            Some(ij) => Box::new(
                RawFileReader::open(
                    path,
                    ij.dims,
                    ij.sample_type,
                    ij.big_endian,
                    ij.offset,
                    false,
                    "tiff (imagej stack, one directory)",
                )?
                .with_geometry(ij.spacing, volcore::Geometry::IDENTITY.with_unit(ij.unit)),
            ),
            None => Box::new(crate::tiff::open_files(
                path,
                vec![path.to_path_buf()],
                opts.channel,
                opts.time,
            )?),
        },
        InputKind::Nrrd => {
            let spec = crate::nrrd::open(path).at(path)?;
            crate::datafile::open_data(path, &spec)?
        }
        InputKind::Mhd => {
            let spec = crate::mhd::open(path).at(path)?;
            crate::datafile::open_data(path, &spec)?
        }
        InputKind::Nifti => {
            let spec = crate::nifti::open(path, opts.time).at(path)?;
            crate::datafile::open_data(path, &spec)?
        }
        InputKind::Vvol => {
            let v = vvol::open_stored(path, opts.vvol).at(path)?;
            let layout = match &v {
                vvol::Stored::Volume(v) => v.meta.layout,
                vvol::Stored::F64(meta, _) => meta.layout,
            };
            let format = vvol_format(layout);
            Box::new(vvol::VolumeReader::of_stored(path, v, &format))
        }
        InputKind::ThesisVol => Box::new(thesis::ThesisReader::open(path)?),
        InputKind::Raw => {
            let l = opts.raw.resolve(path).at(path)?;
            Box::new(RawFileReader::open(
                path,
                l.dims,
                l.sample_type,
                l.big_endian,
                l.skip,
                true,
                RAW_FORMAT,
            )?)
        }
    })
}

/// Standard input: a `.vvol` stream, a NRRD with attached data, or raw
/// samples with `--raw-dims`.
fn open_stdin(path: &Path, opts: &ReadOptions) -> CResult<Box<dyn SliceReader>> {
    let mut r = std::io::BufReader::with_capacity(1 << 20, std::io::stdin());
    let head = r.fill_buf().at(path)?.to_vec();
    if head.is_empty() {
        return Err(ConvertError::new(
            path,
            Error::invalid("standard input is empty"),
        ));
    }
    if !opts.raw.is_given() && head.starts_with(&vvol::MAGIC) {
        return Ok(Box::new(vvol::vvol_stream(path, Box::new(r))?));
    }
    if !opts.raw.is_given() && crate::nrrd::sniff(&head) {
        let mut c = Counted::new(r);
        let counter = c.counter();
        let mut br = std::io::BufReader::new(&mut c);
        let h = crate::nrrd::read_stream_header(&mut br).at(path)?;
        // The BufReader may hold data already: keep reading through it.
        let rest = br.buffer().to_vec();
        drop(br);
        let chained = std::io::Cursor::new(rest).chain(c);
        let mut data: Box<dyn Read + Send> = match h.encoding {
            Encoding::Raw => Box::new(chained),
            _ => Box::new(flate2::read::MultiGzDecoder::new(chained)),
        };
        if h.encoding != Encoding::Raw {
            skip_bytes(&mut data, h.byte_skip.max(0) as u64).at(path)?;
        }
        let end = if h.encoding == Encoding::Raw {
            StreamEnd::Exact
        } else {
            StreamEnd::Ignore
        };
        return Ok(Box::new(
            StreamReader::new(
                path,
                data,
                counter,
                SampleLayout {
                    dims: h.samples.dims,
                    sample_type: h.samples.sample_type,
                    big_endian: h.samples.big_endian,
                },
                end,
                "nrrd stream",
            )
            .with_geometry(h.samples.spacing, h.samples.geometry),
        ));
    }
    if !opts.raw.is_given() {
        return Err(ConvertError::new(
            path,
            Error::invalid(
                "standard input is not a .vvol or NRRD stream: for raw samples pass --raw-dims X,Y,Z and --raw-type T",
            ),
        ));
    }
    let l = opts.raw.resolve(path).at(path)?;
    let mut c = Counted::new(r);
    let counter = c.counter();
    skip_bytes(&mut c, l.skip).at(path)?;
    Ok(Box::new(StreamReader::new(
        path,
        Box::new(c),
        counter,
        SampleLayout {
            dims: l.dims,
            sample_type: l.sample_type,
            big_endian: l.big_endian,
        },
        StreamEnd::Exact,
        "raw stream",
    )))
}

/// Open any input as a whole [`Volume`]: `.vvol` files are memory-mapped
/// (compressed bricks decoded on demand), raw files of a stored type,
/// uncompressed NIfTI files whose samples can be used as stored (see
/// [`crate::datafile::open_mapped`]) and sliced thesis `.vol` files (in
/// their z-fastest order) mapped too, everything else read into memory
/// through [`open_input`]
/// (wider sample types become the smallest stored type that holds their
/// values, as `vol-convert` would pick). Origin and directions are kept.
pub fn open(path: &Path, opts: &ReadOptions) -> CResult<Volume> {
    open_described(path, opts).map(|(v, _)| v)
}

/// [`open`], and the name of the file's format as `vol-convert` reports
/// it (`nifti-1 (nii, gzip)`, `vvol (sliced)`, `tiff (60 pages)`): the
/// reader's [`InputInfo::format`](crate::reader::InputInfo), so every
/// tool names a format the same way.
pub fn open_described(path: &Path, opts: &ReadOptions) -> CResult<(Volume, String)> {
    if path.as_os_str() != "-" {
        let kind = input_kind(path, opts)?;
        refuse_level(path, kind, opts)?;
        match kind {
            InputKind::Vvol => {
                let v = vvol::open(path, opts.vvol).at(path)?;
                let format = vvol_format(v.meta.layout);
                return Ok((v, format));
            }
            InputKind::ThesisVol => {
                let f = thesis::open(path).at(path)?;
                return Ok((f.volume().at(path)?, f.format_name()));
            }
            InputKind::Raw => {
                let l = opts.raw.resolve(path).at(path)?;
                if l.sample_type.stored().is_some() && l.skip == 0 {
                    return Ok((crate::raw::open(path, l).at(path)?, RAW_FORMAT.into()));
                }
            }
            InputKind::Nifti => {
                let spec = crate::nifti::open(path, opts.time).at(path)?;
                let format = spec.format.clone();
                if let Some(v) = crate::datafile::open_mapped(&spec).at(&spec.data_file)? {
                    return Ok((v, format));
                }
                return Ok((
                    load(crate::datafile::open_data(path, &spec)?, None)?,
                    format,
                ));
            }
            _ => {}
        }
    }
    let reader = open_input(path, opts)?;
    let format = reader.info().format.clone();
    Ok((load(reader, None)?, format))
}

/// The format name of a raw file.
const RAW_FORMAT: &str = "raw";

/// The format name of a `.vvol` file of `layout`.
fn vvol_format(layout: volcore::Layout) -> String {
    format!("vvol ({})", layout.describe())
}

/// Read everything `reader` holds into memory, as `sample_type` (or the
/// input's own type, or the smallest stored type holding its values;
/// `f64` as `f32`, recorded in [`volcore::VolumeMeta::narrowed`]).
pub fn load(reader: Box<dyn SliceReader>, sample_type: Option<SampleType>) -> CResult<Volume> {
    let plan = Plan {
        sample_type,
        temp_dir: Some(std::env::temp_dir()),
        ..Plan::default()
    };
    load_with(reader, &plan)
}

/// Read everything `reader` holds into memory through `plan` (crop,
/// preprocessing stages, type): what `vol-convert` would write, as a
/// [`Volume`] (whose types are u8, u16, i16 and f32).
pub fn load_with(reader: Box<dyn SliceReader>, plan: &Plan) -> CResult<Volume> {
    let slot = convert::MemorySlot::default();
    let report = convert::convert(reader, plan, convert::Target::Memory(slot.clone()), &|_| {})?;
    let mut v = slot.take().ok_or_else(|| {
        ConvertError::new(
            Path::new("-"),
            Error::invalid("nothing was read (internal error)"),
        )
    })?;
    v.meta.narrowed = v.meta.narrowed.or(report.narrowed);
    Ok(v)
}

/// [`open`] with the options of the `.vvol` reader and an optional raw
/// description; errors name no path (callers add it).
pub fn open_volume(
    path: &Path,
    opts: vvol::OpenOptions,
    raw: Option<RawSpec>,
) -> crate::error::Result<Volume> {
    let opts = ReadOptions {
        raw: raw.unwrap_or_default(),
        vvol: opts,
        ..ReadOptions::default()
    };
    open(path, &opts).map_err(|e| {
        if e.path == path {
            e.error
        } else {
            Error::invalid(e.to_string())
        }
    })
}

/// The channels and time points of the input `path` names (see
/// [`input_kind`]); 1 and 1 for formats without such axes (NRRD,
/// MetaImage, DICOM, raw, `.vvol`, `.vol`, standard input). An error only
/// where the input's header cannot be read.
pub fn stacks(path: &Path, opts: &ReadOptions) -> CResult<crate::stacks::Stacks> {
    use crate::stacks::{step, Stacks, TimeUnit};
    let kind = input_kind(path, opts)?;
    match kind {
        // An ImageJ stack of one directory is read as raw images: z only.
        InputKind::Tiff if crate::tiff::imagej_raw(path)?.is_some() => Ok(Stacks::default()),
        InputKind::Tiff => crate::tiff::stacks(path, &[path.to_path_buf()]),
        InputKind::TiffDir | InputKind::TiffGlob | InputKind::TiffList => {
            let files = match kind {
                InputKind::TiffDir => crate::tiff::list_dir(path)?,
                InputKind::TiffGlob => crate::tiff::list_glob(path)?,
                _ => crate::tiff::list_file(path)?,
            };
            crate::tiff::stacks(path, &files)
        }
        InputKind::OmeZarr => crate::omezarr::stacks(path),
        InputKind::Nifti => {
            let h = crate::nifti::read_header(path).at(path)?;
            let (_, volumes) = h.shape().at(path)?;
            if volumes < 2 {
                return Ok(Stacks::default());
            }
            // xyzt_units bits 3-5: 8 s, 16 ms, 24 µs (32 and up are Hz,
            // ppm, rad/s: not times).
            let time_unit = match h.xyzt_units & 0x38 {
                8 => Some(TimeUnit::Second),
                16 => Some(TimeUnit::Millisecond),
                24 => Some(TimeUnit::Microsecond),
                _ => None,
            };
            Ok(Stacks {
                time_points: volumes,
                time_step: step(h.pixdim[4]),
                time_unit,
                ..Stacks::default()
            })
        }
        _ => Ok(Stacks::default()),
    }
}
