//! Opening whatever the user named as input.

use super::input::{
    self, open_data, Counted, RawFileReader, SampleLayout, SliceReader, StreamEnd, StreamReader,
    ThesisReader, VolumeReader,
};
use super::{At, CResult, ConvertError};
use crate::error::Error;
use crate::tiff::ChannelSel;
use std::io::{BufRead, Read};
use std::path::Path;
use volcore::{Dims, SampleType};

/// How to read headerless raw input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawArgs {
    /// Voxels per axis (`None`: from the Open SciVis file name).
    pub dims: Option<Dims>,
    /// Sample type (`None`: from the file name).
    pub sample_type: Option<SampleType>,
    /// Big-endian samples.
    pub big_endian: bool,
    /// Bytes to skip before the samples.
    pub skip: u64,
}

/// Input options.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InputOptions {
    /// Raw input description, when any raw flag was given.
    pub raw: Option<RawArgs>,
    /// Channel choice for colour TIFFs.
    pub channel: ChannelSel,
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
pub fn input_kind(path: &Path, opts: &InputOptions) -> CResult<InputKind> {
    if path.as_os_str() == "-" {
        return Ok(InputKind::Stdin);
    }
    if path.is_dir() {
        return Ok(InputKind::TiffDir);
    }
    let name = path.to_string_lossy();
    if !path.exists() {
        if has_glob_chars(&name) {
            return Ok(InputKind::TiffGlob);
        }
        return Err(ConvertError::new(
            path,
            Error::invalid("no such file or directory"),
        ));
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
        "raw" => Some(InputKind::Raw),
        "txt" | "lst" | "list" => Some(InputKind::TiffList),
        _ => None,
    };
    if let Some(k) = by_ext {
        return Ok(k);
    }
    if opts.raw.is_some() {
        return Ok(InputKind::Raw);
    }
    let mut head = [0u8; 8];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .at(path)?;
    let head = &head[..n];
    if is_tiff(head) {
        Ok(InputKind::Tiff)
    } else if crate::nrrd::sniff(head) {
        Ok(InputKind::Nrrd)
    } else if head.starts_with(&crate::vvol::MAGIC) {
        Ok(InputKind::Vvol)
    } else {
        Err(ConvertError::new(
            path,
            Error::invalid(
                "unknown input type (expected TIFF, NRRD, MetaImage, .vvol, .vol, .raw with --raw-dims, or a directory of slices)",
            ),
        ))
    }
}

/// Whether bytes start like a TIFF or BigTIFF file.
pub fn is_tiff(b: &[u8]) -> bool {
    matches!(
        b.get(..4),
        Some(b"II*\0") | Some(b"MM\0*") | Some(b"II+\0") | Some(b"MM\0+")
    )
}

fn raw_spec(path: &Path, raw: Option<RawArgs>) -> CResult<(Dims, SampleType, bool, u64)> {
    let named = crate::raw::parse_name(path);
    let r = raw.unwrap_or(RawArgs {
        dims: None,
        sample_type: None,
        big_endian: false,
        skip: 0,
    });
    let dims = r.dims.or(named.map(|n| n.0));
    let t = r.sample_type.or(named.map(|n| n.1));
    match (dims, t) {
        (Some(d), Some(t)) => Ok((d, t, r.big_endian, r.skip)),
        (Some(d), None) => Ok((d, SampleType::U8, r.big_endian, r.skip)),
        _ => Err(ConvertError::new(
            path,
            Error::invalid(
                "raw input needs dims and type: pass --raw-dims X,Y,Z --raw-type T or name it NAME_XxYxZ_TYPE.raw",
            ),
        )),
    }
}

/// Open the input `path` names (see [`input_kind`]).
pub fn open_input(path: &Path, opts: &InputOptions) -> CResult<Box<dyn SliceReader>> {
    let kind = input_kind(path, opts)?;
    Ok(match kind {
        InputKind::Stdin => open_stdin(path, opts)?,
        InputKind::TiffDir => {
            let files = crate::tiff::list_dir(path)?;
            Box::new(crate::tiff::open_files(path, files, opts.channel)?)
        }
        InputKind::TiffGlob => {
            let files = crate::tiff::list_glob(path)?;
            Box::new(crate::tiff::open_files(path, files, opts.channel)?)
        }
        InputKind::TiffList => {
            let files = crate::tiff::list_file(path)?;
            Box::new(crate::tiff::open_files(path, files, opts.channel)?)
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
                .with_spacing(ij.spacing),
            ),
            None => Box::new(crate::tiff::open_files(
                path,
                vec![path.to_path_buf()],
                opts.channel,
            )?),
        },
        InputKind::Nrrd => {
            let spec = crate::nrrd::open(path).at(path)?;
            open_data(path, &spec)?
        }
        InputKind::Mhd => {
            let spec = crate::mhd::open(path).at(path)?;
            open_data(path, &spec)?
        }
        InputKind::Vvol => {
            let v = crate::vvol::open(path, crate::vvol::OpenOptions::default()).at(path)?;
            let format = format!("vvol ({})", v.meta.layout.describe());
            Box::new(VolumeReader::new(path, v, &format))
        }
        InputKind::ThesisVol => Box::new(ThesisReader::open(path)?),
        InputKind::Raw => {
            let (dims, t, be, skip) = raw_spec(path, opts.raw)?;
            Box::new(RawFileReader::open(path, dims, t, be, skip, true, "raw")?)
        }
    })
}

/// Standard input: a `.vvol` stream, a NRRD with attached data, or raw
/// samples with `--raw-dims`.
fn open_stdin(path: &Path, opts: &InputOptions) -> CResult<Box<dyn SliceReader>> {
    let mut r = std::io::BufReader::with_capacity(1 << 20, std::io::stdin());
    let head = r.fill_buf().at(path)?.to_vec();
    if head.is_empty() {
        return Err(ConvertError::new(
            path,
            Error::invalid("standard input is empty"),
        ));
    }
    if opts.raw.is_none() && head.starts_with(&crate::vvol::MAGIC) {
        return Ok(Box::new(input::vvol_stream(path, Box::new(r))?));
    }
    if opts.raw.is_none() && crate::nrrd::sniff(&head) {
        let mut c = Counted::new(r);
        let counter = c.counter();
        let mut br = std::io::BufReader::new(&mut c);
        let h = crate::nrrd::read_stream_header(&mut br).at(path)?;
        // The BufReader may hold data already: keep reading through it.
        let rest = br.buffer().to_vec();
        drop(br);
        let chained = std::io::Cursor::new(rest).chain(c);
        let mut data: Box<dyn Read + Send> = match h.encoding {
            input::Encoding::Raw => Box::new(chained),
            _ => Box::new(flate2::read::MultiGzDecoder::new(chained)),
        };
        if h.encoding != input::Encoding::Raw {
            input::skip_bytes(&mut data, h.byte_skip.max(0) as u64).at(path)?;
        }
        let end = if h.encoding == input::Encoding::Raw {
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
                    dims: h.dims,
                    sample_type: h.sample_type,
                    big_endian: h.big_endian,
                },
                end,
                "nrrd stream",
            )
            .with_spacing(h.spacing),
        ));
    }
    let raw = opts.raw.ok_or_else(|| {
        ConvertError::new(
            path,
            Error::invalid(
                "standard input is not a .vvol or NRRD stream: for raw samples pass --raw-dims X,Y,Z and --raw-type T",
            ),
        )
    })?;
    let dims = raw.dims.ok_or_else(|| {
        ConvertError::new(
            path,
            Error::invalid("raw input on standard input needs --raw-dims"),
        )
    })?;
    let mut c = Counted::new(r);
    let counter = c.counter();
    input::skip_bytes(&mut c, raw.skip).at(path)?;
    Ok(Box::new(StreamReader::new(
        path,
        Box::new(c),
        counter,
        SampleLayout {
            dims,
            sample_type: raw.sample_type.unwrap_or(SampleType::U8),
            big_endian: raw.big_endian,
        },
        StreamEnd::Exact,
        "raw stream",
    )))
}
