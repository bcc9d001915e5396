//! Reading TIFF pages as z slices.

use super::axes::imagej_unit;
use super::ifd_check::check_directories;
use super::ChannelSel;
use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use crate::stacks::Stacks;
use ::tiff::decoder::{Decoder, DecodingResult, Limits};
use ::tiff::tags::Tag;
use ::tiff::TiffError;
use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use volcore::Dims;

/// What one page holds, as far as a stack must agree on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PageInfo {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bits per sample.
    pub bits: u16,
    /// 1 unsigned, 2 signed, 3 float (the SampleFormat tag).
    pub format: u16,
    /// Samples per pixel.
    pub channels: u16,
}

impl PageInfo {
    fn describe(&self) -> String {
        let kind = match self.format {
            2 => "signed",
            3 => "float",
            _ => "unsigned",
        };
        format!(
            "{}x{} {}-bit {kind}, {} channel{}",
            self.width,
            self.height,
            self.bits,
            self.channels,
            if self.channels == 1 { "" } else { "s" }
        )
    }

    /// The sample type slices of this page become.
    pub fn sample_type(&self) -> Result<SliceType, String> {
        match (self.format, self.bits) {
            (1, 8) => Ok(SliceType::U8),
            (2, 8) => Ok(SliceType::I16), // widened
            (1, 16) => Ok(SliceType::U16),
            (2, 16) => Ok(SliceType::I16),
            (1, 32) => Ok(SliceType::U32),
            (2, 32) => Ok(SliceType::I32),
            (3, 32) => Ok(SliceType::F32),
            (3, 64) => Ok(SliceType::F64),
            _ => Err(format!(
                "{} samples are not supported (volkit reads 8, 16 and 32-bit integers and 32 and 64-bit floats)",
                self.describe()
            )),
        }
    }
}

/// Turn a decoder error into one line, naming truncation plainly.
pub(super) fn tiff_err(e: TiffError) -> Error {
    match e {
        TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            Error::invalid("file is truncated (it ends before the image data does)")
        }
        TiffError::IoError(io) => Error::Io(io),
        TiffError::LimitsExceeded => Error::invalid(
            "a directory describes more data than the file holds (damaged directory?)",
        ),
        other => Error::invalid(format!(
            "not a readable TIFF: {}",
            volcore::text::clip(&other.to_string(), 200)
        )),
    }
}

type Dec<R> = Decoder<R>;

/// A multipage file read through a buffered handle of its own per decoder
/// (not mapped: resident memory stays at the pages in flight).
type FileDec = Dec<BufReader<File>>;

/// How many times larger than its whole file one decoded page may be. No
/// compression the decoder reads expands more: deflate at most 1032:1,
/// LZW (12-bit codes of strings up to 4 KiB) about 2730:1, PackBits 64:1.
/// A directory whose width and height claim more is damaged.
pub const MAX_EXPANSION: u64 = 4096;

/// Decoder limits for a file of `file_len` bytes whose pages decode to
/// `page_bytes` each (`None` before the first directory is read): nothing
/// the file stores (a directory value, a compressed strip or tile) can be
/// larger than the file, and no decoded buffer larger than a page, or than
/// the file's values held as decoded values. A damaged count or offset is
/// then an error instead of an allocation of up to 2^64 bytes.
fn limits(file_len: u64, page_bytes: Option<u64>) -> Limits {
    let to_usize = |v: u64| usize::try_from(v).unwrap_or(usize::MAX);
    let value = std::mem::size_of::<::tiff::decoder::ifd::Value>() as u64;
    let values = file_len.saturating_mul(value);
    let page = page_bytes.unwrap_or_else(|| file_len.saturating_mul(MAX_EXPANSION));
    let mut l = Limits::default();
    l.decoding_buffer_size = to_usize(page.max(values));
    l.ifd_value_size = to_usize(file_len);
    l.intermediate_buffer_size = to_usize(file_len);
    l
}

impl PageInfo {
    /// Bytes of one decoded page, if that fits in 64 bits.
    fn bytes(&self) -> Option<u64> {
        (self.width as u64)
            .checked_mul(self.height as u64)?
            .checked_mul(self.channels as u64)?
            .checked_mul((self.bits as u64).div_ceil(8))
    }

    /// Refuse a page that a file of `file_len` bytes cannot hold even
    /// compressed (see [`MAX_EXPANSION`]): its directory is damaged.
    fn check_fits(&self, file_len: u64) -> Result<u64, Error> {
        let limit = file_len.max(1).saturating_mul(MAX_EXPANSION);
        match self.bytes() {
            Some(b) if b <= limit => Ok(b),
            b => Err(Error::invalid(format!(
                "the directory describes {} pages of {} bytes, more than a file of {file_len} bytes can hold even compressed (damaged directory?)",
                self.describe(),
                b.map_or("more than 2^64".to_string(), |b| b.to_string())
            ))),
        }
    }
}

pub(super) fn page_info<R: Read + Seek>(d: &mut Dec<R>) -> Result<PageInfo, Error> {
    let (width, height) = d.dimensions().map_err(tiff_err)?;
    let tag = |d: &mut Dec<R>, t: Tag, default: u16| -> Result<u16, Error> {
        Ok(d.find_tag_unsigned::<u16>(t)
            .map_err(tiff_err)?
            .unwrap_or(default))
    };
    let channels = tag(d, Tag::SamplesPerPixel, 1)?;
    let bits = match d.find_tag(Tag::BitsPerSample).map_err(tiff_err)? {
        Some(v) => {
            let all = v.into_u16_vec().map_err(tiff_err)?;
            let first = all.first().copied().unwrap_or(1);
            if all.iter().any(|&b| b != first) {
                return Err(Error::invalid(format!(
                    "channels have different bit depths {all:?}"
                )));
            }
            first
        }
        None => 1,
    };
    let format = match d.find_tag(Tag::SampleFormat).map_err(tiff_err)? {
        Some(v) => v
            .into_u16_vec()
            .map_err(tiff_err)?
            .first()
            .copied()
            .unwrap_or(1),
        None => 1,
    };
    Ok(PageInfo {
        width,
        height,
        bits,
        format,
        channels,
    })
}

/// Spacing from the resolution tags and an ImageJ description (the
/// page's own, else `z_first`: the `spacing=` of the file's first page,
/// which is the only one ImageJ describes).
pub(super) fn spacing_of<R: Read + Seek>(d: &mut Dec<R>, z_first: Option<f32>) -> Option<[f32; 3]> {
    let res = |d: &mut Dec<R>, t: Tag| -> Option<f32> {
        match d.find_tag(t).ok()?? {
            ::tiff::decoder::ifd::Value::Rational(n, den) if n > 0 && den > 0 => {
                Some((den as f64 / n as f64) as f32)
            }
            v => {
                let r = v.into_f64().ok()?;
                (r > 0.0).then(|| (1.0 / r) as f32)
            }
        }
    };
    let sx = res(d, Tag::XResolution);
    let sy = res(d, Tag::YResolution);
    let sz = d
        .find_tag(Tag::ImageDescription)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok())
        .and_then(|s| imagej_spacing(&s))
        .or(z_first);
    if sx.is_none() && sy.is_none() && sz.is_none() {
        return None;
    }
    let ok = |v: Option<f32>| v.filter(|s| s.is_finite() && *s > 0.0).unwrap_or(1.0);
    // Without an ImageJ `spacing=`, z is taken equal to x: stacks from
    // other tools (ImageMagick writes 72 dpi) keep their proportions.
    Some([ok(sx), ok(sy.or(sx)), ok(sz.or(sx))])
}

/// The `spacing=` value of an ImageJ image description.
pub fn imagej_spacing(desc: &str) -> Option<f32> {
    if !desc.starts_with("ImageJ") {
        return None;
    }
    desc.lines()
        .find_map(|l| l.trim().strip_prefix("spacing="))
        .and_then(|v| v.trim().parse().ok())
}

/// Whether the current page is a reduced-resolution image (a thumbnail).
fn is_thumbnail<R: Read + Seek>(d: &mut Dec<R>) -> bool {
    matches!(d.find_tag_unsigned::<u32>(Tag::NewSubfileType), Ok(Some(v)) if v & 1 == 1)
}

/// Decode the current page into one channel of samples.
fn decode<R: Read + Seek>(
    d: &mut Dec<R>,
    expect: &PageInfo,
    chan: ChannelSel,
    reuse: Option<SliceData>,
) -> Result<SliceData, Error> {
    let got = page_info(d)?;
    if got != *expect {
        return Err(Error::invalid(format!(
            "slice is {} but the first slice is {}",
            got.describe(),
            expect.describe()
        )));
    }
    let planar = d
        .find_tag_unsigned::<u16>(Tag::PlanarConfiguration)
        .map_err(tiff_err)?
        .unwrap_or(1)
        == 2;
    let white_is_zero = d
        .find_tag_unsigned::<u16>(Tag::PhotometricInterpretation)
        .map_err(tiff_err)?
        == Some(0);
    let n = expect.width as usize * expect.height as usize;
    if expect.channels == 1 && !(expect.format == 2 && expect.bits == 8) {
        // One channel in a volkit type: decode straight into a slice
        // buffer, reusing the caller's allocation.
        let t = expect.sample_type().map_err(Error::invalid)?;
        let mut s = SliceData::reuse(reuse, t, n);
        d.read_image_bytes(s.as_bytes_mut()).map_err(tiff_err)?;
        if white_is_zero {
            invert(&mut s);
        }
        return Ok(s);
    }
    let mut buf = DecodingResult::U8(Vec::new());
    d.read_image_to_buffer(&mut buf).map_err(tiff_err)?;
    let c = expect.channels as usize;
    let pick = ChannelPick {
        n,
        c,
        planar,
        sel: chan,
    };
    let mut s = match buf {
        DecodingResult::U8(v) => SliceData::U8(pick.apply(&v)?),
        DecodingResult::I8(v) => {
            SliceData::I16(pick.apply(&v.iter().map(|&x| x as i16).collect::<Vec<_>>())?)
        }
        DecodingResult::U16(v) => SliceData::U16(pick.apply(&v)?),
        DecodingResult::I16(v) => SliceData::I16(pick.apply(&v)?),
        DecodingResult::F32(v) => SliceData::F32(pick.apply(&v)?),
        DecodingResult::U32(v) => SliceData::U32(pick.apply(&v)?),
        DecodingResult::I32(v) => SliceData::I32(pick.apply(&v)?),
        DecodingResult::F64(v) => SliceData::F64(pick.apply(&v)?),
        _ => {
            return Err(Error::invalid(format!(
                "{} samples are not supported",
                expect.describe()
            )))
        }
    };
    if white_is_zero {
        invert(&mut s);
    }
    Ok(s)
}

/// Undo PhotometricInterpretation WhiteIsZero for unsigned samples.
fn invert(s: &mut SliceData) {
    match s {
        SliceData::U8(v) => v.iter_mut().for_each(|x| *x = 255 - *x),
        SliceData::U16(v) => v.iter_mut().for_each(|x| *x = 65535 - *x),
        _ => {}
    }
}

thread_local! {
    /// The bytes of the file being decoded, reused per thread.
    static FILE_BYTES: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

struct ChannelPick {
    n: usize,
    c: usize,
    planar: bool,
    sel: ChannelSel,
}

/// Samples that can be averaged into a luma value.
trait Luma: Copy {
    fn luma(r: Self, g: Self, b: Self) -> Self;
}

macro_rules! luma_int {
    ($t:ty) => {
        impl Luma for $t {
            fn luma(r: $t, g: $t, b: $t) -> $t {
                (0.299 * r as f64 + 0.587 * g as f64 + 0.114 * b as f64).round() as $t
            }
        }
    };
}
luma_int!(u8);
luma_int!(u16);
luma_int!(i16);
luma_int!(u32);
luma_int!(i32);
impl Luma for f64 {
    fn luma(r: f64, g: f64, b: f64) -> f64 {
        0.299 * r + 0.587 * g + 0.114 * b
    }
}
impl Luma for f32 {
    fn luma(r: f32, g: f32, b: f32) -> f32 {
        (0.299 * r as f64 + 0.587 * g as f64 + 0.114 * b as f64) as f32
    }
}

impl ChannelPick {
    fn at<T: Copy>(&self, v: &[T], i: usize, ch: usize) -> T {
        if self.planar {
            v[ch * self.n + i]
        } else {
            v[i * self.c + ch]
        }
    }

    fn apply<T: Luma>(&self, v: &[T]) -> Result<Vec<T>, Error> {
        if v.len() < self.n * self.c {
            return Err(Error::invalid(format!(
                "decoded {} samples, expected {}",
                v.len(),
                self.n * self.c
            )));
        }
        match self.sel {
            _ if self.c == 1 => Ok(v[..self.n].to_vec()),
            ChannelSel::Single => Err(Error::invalid(format!(
                "slices have {} channels (colour?): pick one with --channel C",
                self.c
            ))),
            ChannelSel::Channel(k) if k as usize >= self.c => Err(Error::invalid(format!(
                "--channel {k} asked for, but slices have channels 0..{}",
                self.c - 1
            ))),
            ChannelSel::Channel(k) => Ok((0..self.n).map(|i| self.at(v, i, k as usize)).collect()),
            ChannelSel::Luma if self.c < 3 => Err(Error::invalid(format!(
                "--luma needs RGB slices, these have {} channels",
                self.c
            ))),
            ChannelSel::Luma => Ok((0..self.n)
                .map(|i| T::luma(self.at(v, i, 0), self.at(v, i, 1), self.at(v, i, 2)))
                .collect()),
        }
    }
}

/// Where the pages of a stack are.
enum Pages {
    /// One page (the first full-resolution one) of each file.
    Files(Vec<PathBuf>),
    /// The full-resolution pages (IFD indices) of one file, decoded by a
    /// pool of decoders over a shared map.
    Multi {
        path: PathBuf,
        ifds: Vec<usize>,
        pool: Mutex<Vec<FileDec>>,
    },
}

/// A TIFF stack as a [`SliceReader`]: random access, pages decoded in
/// parallel.
pub struct TiffStackReader {
    info: InputInfo,
    page: PageInfo,
    /// Bytes of one decoded page (the decoders' limit).
    page_bytes: u64,
    chan: ChannelSel,
    pages: Pages,
    /// Input bytes: the file's length for one file; for a stack of
    /// files, the bytes of the slice files read so far.
    bytes_in: std::sync::atomic::AtomicU64,
}

/// A decoder of the file at `path`, with limits from its length and, once
/// known, the stack's page size; its directories checked first
/// ([`check_directories`]).
pub(super) fn open_file(path: &Path, page_bytes: Option<u64>) -> CResult<FileDec> {
    let mut f = File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    // Checked unbuffered: a seek would empty a 256 KiB buffer per directory.
    check_directories(&mut f, len).at(path)?;
    f.rewind().at(path)?;
    new_decoder(BufReader::with_capacity(256 << 10, f), len, page_bytes).at(path)
}

/// [`open_file`] for a file whose directories were checked when its stack
/// was opened: another decoder for a reading thread, without walking a
/// chain of thousands of pages again.
fn reopen_file(path: &Path, page_bytes: Option<u64>) -> CResult<FileDec> {
    let f = File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    new_decoder(BufReader::with_capacity(256 << 10, f), len, page_bytes).at(path)
}

fn open_decoder<R: Read + Seek>(
    mut r: R,
    file_len: u64,
    page_bytes: Option<u64>,
) -> Result<Dec<R>, Error> {
    check_directories(&mut r, file_len)?;
    r.rewind()?;
    new_decoder(r, file_len, page_bytes)
}

/// The decoder of a file whose directories [`check_directories`] passed
/// (now or when its stack was opened).
fn new_decoder<R: Read + Seek>(
    r: R,
    file_len: u64,
    page_bytes: Option<u64>,
) -> Result<Dec<R>, Error> {
    // The limits apply from the first directory on.
    let limits = limits(file_len, page_bytes);
    Ok(Decoder::new(r).map_err(tiff_err)?.with_limits(limits))
}
/// Open a stack of files (one file may be a multipage TIFF; several files
/// each give their first full-resolution page).
pub fn open_files(
    input: &Path,
    files: Vec<PathBuf>,
    chan: ChannelSel,
    time: Option<u64>,
) -> CResult<TiffStackReader> {
    let first = files
        .first()
        .ok_or_else(|| ConvertError::new(input, Error::invalid("no slices")))?
        .clone();
    let mut d = open_file(&first, None)?;
    // Full-resolution pages of the first file.
    let mut ifds = Vec::new();
    let mut idx = 0usize;
    loop {
        if !is_thumbnail(&mut d) {
            ifds.push(idx);
        }
        if files.len() > 1 || !d.more_images() {
            break;
        }
        d.next_image().map_err(tiff_err).at(&first)?;
        idx += 1;
    }
    if ifds.is_empty() {
        return Err(ConvertError::new(
            &first,
            Error::invalid("file holds only reduced-resolution images"),
        ));
    }
    d.seek_to_image(ifds[0]).map_err(tiff_err).at(&first)?;
    // Hyperstacks and OME-TIFF: one 3D stack of many.
    let mut chan = chan;
    let mut axes_note = String::new();
    let mut axes_spacing = None;
    let mut axes_unit = None;
    let desc = d
        .find_tag(Tag::ImageDescription)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok());
    // A hyperstack's channel or time point may start on a later page,
    // which has no description of its own.
    let z_first = desc.as_deref().and_then(imagej_spacing);
    if files.len() == 1 && ifds.len() > 1 {
        if let Some(a) = desc.as_deref().and_then(super::axes::Axes::parse) {
            let c = match chan {
                ChannelSel::Channel(c) if a.c > 1 => Some(c as u64),
                _ => None,
            };
            let pick = a
                .pages(c, time, ifds.len())
                .map_err(Error::invalid)
                .at(&first)?;
            ifds = pick.into_iter().map(|i| ifds[i]).collect();
            if a.c > 1 {
                // The channel is a page of its own, not a sample.
                chan = ChannelSel::Single;
            }
            axes_spacing = a.spacing;
            axes_unit = Some(a.unit);
            axes_note = format!(", {} {}", a.source, a.names);
            d.seek_to_image(ifds[0]).map_err(tiff_err).at(&first)?;
        }
    }
    let page = page_info(&mut d).at(&first)?;
    let first_len = std::fs::metadata(&first).at(&first)?.len();
    let page_bytes = page.check_fits(first_len).at(&first)?;
    let mut d = d.with_limits(limits(first_len, Some(page_bytes)));
    let sample_type = page.sample_type().map_err(Error::invalid).at(&first)?;
    if page.channels > 1 && chan == ChannelSel::Single {
        return Err(ConvertError::new(
            &first,
            Error::invalid(format!(
                "slices have {} channels (colour?): pick one with --channel C",
                page.channels
            )),
        ));
    }
    let spacing = axes_spacing.or_else(|| spacing_of(&mut d, z_first));
    let unit = axes_unit.unwrap_or_else(|| desc.as_deref().map(imagej_unit).unwrap_or_default());
    let (z, pages, format, bytes_in) = if files.len() == 1 {
        let z = ifds.len() as u64;
        let len = std::fs::metadata(&first).at(&first)?.len();
        let mut head = [0u8; 4];
        let _ = File::open(&first).and_then(|mut f| f.read_exact(&mut head));
        let bigtiff = head[2..4] == [43, 0] || head[2..4] == [0, 43];
        let format = format!(
            "{} ({} page{}{axes_note})",
            if bigtiff { "bigtiff" } else { "tiff" },
            z,
            if z == 1 { "" } else { "s" }
        );
        // The probing decoder has walked the whole chain: keep it.
        if let Some(&last) = ifds.last() {
            d.seek_to_image(last).map_err(tiff_err).at(&first)?;
        }
        (
            z,
            Pages::Multi {
                path: first.clone(),
                ifds,
                pool: Mutex::new(vec![d]),
            },
            format,
            len,
        )
    } else {
        let z = files.len() as u64;
        (z, Pages::Files(files), format!("tiff stack ({z} files)"), 0)
    };
    let dims = Dims::new(page.width as u64, page.height as u64, z).at(&first)?;
    Ok(TiffStackReader {
        info: InputInfo {
            nifti_codes: None,
            path: input.to_path_buf(),
            dims,
            sample_type,
            spacing,
            geometry: volcore::Geometry::IDENTITY.with_unit(unit),
            format,
        },
        page,
        page_bytes,
        chan,
        pages,
        bytes_in: std::sync::atomic::AtomicU64::new(bytes_in),
    })
}

/// The channels and time points of a stack of files (see
/// [`crate::stacks`]): those of a multipage file's hyperstack or OME-TIFF
/// axes, as [`open_files`] finds them, else the samples per pixel of the
/// first page (colour).
pub fn stacks(input: &Path, files: &[PathBuf]) -> CResult<Stacks> {
    let first = files
        .first()
        .ok_or_else(|| ConvertError::new(input, Error::invalid("no slices")))?;
    let mut d = open_file(first, None)?;
    // The first two full-resolution pages: a file's axes count only when
    // it has more than one.
    let mut full = Vec::new();
    let mut idx = 0usize;
    loop {
        if !is_thumbnail(&mut d) {
            full.push(idx);
        }
        if files.len() > 1 || full.len() > 1 || !d.more_images() {
            break;
        }
        d.next_image().map_err(tiff_err).at(first)?;
        idx += 1;
    }
    let Some(&page0) = full.first() else {
        return Err(ConvertError::new(
            first,
            Error::invalid("file holds only reduced-resolution images"),
        ));
    };
    d.seek_to_image(page0).map_err(tiff_err).at(first)?;
    let page = page_info(&mut d).at(first)?;
    let colour = Stacks {
        channels: page.channels as u64,
        ..Stacks::default()
    };
    if files.len() > 1 || full.len() < 2 {
        return Ok(colour);
    }
    let desc = d
        .find_tag(Tag::ImageDescription)
        .ok()
        .flatten()
        .and_then(|v| v.into_string().ok());
    let Some(desc) = desc else {
        return Ok(colour);
    };
    let Some(a) = super::axes::Axes::parse(&desc) else {
        return Ok(colour);
    };
    let (time_step, time_unit) = if a.t > 1 {
        super::axes::time_step(&desc)
    } else {
        (None, None)
    };
    Ok(Stacks {
        channels: if a.c > 1 { a.c } else { colour.channels },
        time_points: a.t,
        time_step,
        time_unit,
        ..Stacks::default()
    })
}

impl TiffStackReader {
    fn read_multi(
        &self,
        path: &Path,
        ifds: &[usize],
        pool: &Mutex<Vec<FileDec>>,
        z: u64,
        reuse: Option<SliceData>,
    ) -> CResult<SliceData> {
        let taken = pool.lock().ok().and_then(|mut p| p.pop());
        let mut d = match taken {
            Some(d) => d,
            None => {
                let mut d = reopen_file(path, Some(self.page_bytes))?;
                // Walk the chain once so later seeks go straight to a page.
                if let Some(&last) = ifds.last() {
                    d.seek_to_image(last).map_err(tiff_err).at(path)?;
                }
                d
            }
        };
        let ifd = ifds[z as usize];
        let r = d
            .seek_to_image(ifd)
            .map_err(tiff_err)
            .and_then(|_| decode(&mut d, &self.page, self.chan, reuse))
            .map_err(|e| ConvertError::new(path, page_err(e, z)));
        if let Ok(mut p) = pool.lock() {
            p.push(d);
        }
        r
    }
}

fn page_err(e: Error, z: u64) -> Error {
    match e {
        Error::Invalid(m) => Error::Invalid(format!("page {z}: {m}")),
        other => other,
    }
}

impl SliceReader for TiffStackReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        match &self.pages {
            Pages::Files(files) => {
                let path = &files[z as usize];
                FILE_BYTES.with(|cell| {
                    let mut bytes = cell.borrow_mut();
                    bytes.clear();
                    File::open(path)
                        .and_then(|mut f| f.read_to_end(&mut bytes))
                        .at(path)?;
                    let len = bytes.len() as u64;
                    self.bytes_in
                        .fetch_add(len, std::sync::atomic::Ordering::Relaxed);
                    let mut d =
                        open_decoder(Cursor::new(bytes.as_slice()), len, Some(self.page_bytes))
                            .at(path)?;
                    if is_thumbnail(&mut d) {
                        // The full-resolution page follows a leading thumbnail.
                        d.next_image().map_err(tiff_err).at(path)?;
                    }
                    decode(&mut d, &self.page, self.chan, reuse).at(path)
                })
            }
            Pages::Multi { path, ifds, pool } => self.read_multi(path, ifds, pool, z, reuse),
        }
    }
    fn bytes_in(&self) -> u64 {
        self.bytes_in.load(std::sync::atomic::Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn page(width: u32, height: u32, bits: u16, channels: u16) -> PageInfo {
        PageInfo {
            width,
            height,
            bits,
            format: 1,
            channels,
        }
    }

    #[test]
    fn pages_larger_than_the_file_can_expand_to_are_damaged() {
        assert_eq!(page(512, 512, 16, 1).check_fits(600_000).unwrap(), 524_288);
        // 100 bytes hold at most 409,600 decoded bytes.
        assert!(page(640, 640, 8, 1).check_fits(100).is_ok());
        let e = page(641, 640, 8, 1)
            .check_fits(100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("damaged directory"), "{e}");
        let e = page(u32::MAX, u32::MAX, 32, 4)
            .check_fits(1 << 40)
            .unwrap_err();
        assert!(e.to_string().contains("more than 2^64"), "{e}");
    }

    #[test]
    fn limits_follow_the_file_and_the_page() {
        let l = limits(1000, Some(64));
        assert_eq!(l.ifd_value_size, 1000);
        assert_eq!(l.intermediate_buffer_size, 1000);
        // Directory values decode to larger structures than they take in
        // the file: the buffer limit leaves room for them.
        assert!(l.decoding_buffer_size >= 1000);
        let l = limits(1000, Some(1 << 30));
        assert_eq!(l.decoding_buffer_size, 1 << 30);
        let l = limits(u64::MAX, None);
        assert_eq!(l.decoding_buffer_size, usize::MAX);
    }
}
