//! DICOM series (a directory of files, a glob or a list file) read as one
//! volume, through dicom-rs (`dicom-object` for the data sets,
//! `dicom-pixeldata` for the pixel data and its codecs: native, RLE,
//! JPEG, deflate).
//!
//! - Files that hold no image are skipped (and counted): a `DICOMDIR`, and
//!   objects without Rows and Columns whose SOP class is no image storage
//!   class (structured reports, presentation states, RT structure sets,
//!   key object selections). Only an input left without images is refused.
//! - Files are grouped by SeriesInstanceUID ([`Scan`]); with several
//!   series `--series` picks one by its SeriesNumber, its whole UID or a
//!   unique prefix of it, and without it the error lists them.
//! - Slices are sorted by ImagePositionPatient projected on the slice
//!   normal (the cross product of the ImageOrientationPatient rows), not by
//!   file name or InstanceNumber.
//! - Spacing: PixelSpacing (rows, then columns) for y and x; z from the
//!   measured positions. Gaps that differ from the median by more than 1%
//!   (or 0.01 mm) are refused: a whole multiple of the spacing is reported
//!   as missing slices, anything else as uneven spacing. Positions that do
//!   not follow the normal (gantry tilt), mixed sizes or orientations, and
//!   two slices at one position are refused too.
//! - RescaleSlope/RescaleIntercept are applied per slice: CT pixels become
//!   Hounsfield units (integers, so `i16` when they fit, else `f32`).
//! - Geometry: origin at the first slice's ImagePositionPatient, axes
//!   along the row, column and normal directions (DICOM is LPS, like volkit).

use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, InputInfo, SliceReader};
use crate::rescale::Rescale;
use crate::slice::{SliceData, SliceType};
use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, OpenFileOptions};
use dicom_pixeldata::PixelDecoder;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use volcore::{Dims, Geometry};

/// Relative tolerance of slice gaps (and at least this many mm).
const GAP_TOLERANCE: f64 = 0.01;
const GAP_TOLERANCE_MM: f64 = 0.01;

/// Whether bytes start like a DICOM Part 10 file (`DICM` after the
/// 128-byte preamble).
pub fn sniff(b: &[u8]) -> bool {
    b.len() >= 132 && &b[128..132] == b"DICM"
}

/// Whether the file at `path` is a DICOM Part 10 file.
pub fn is_dicom_file(path: &Path) -> bool {
    use std::io::Read;
    let mut b = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut b))
        .map(|_| sniff(&b))
        .unwrap_or(false)
}

/// What one file of a series says about its slice.
#[derive(Clone, Debug)]
struct SliceHeader {
    path: PathBuf,
    series: String,
    series_number: Option<i64>,
    description: String,
    modality: String,
    rows: u16,
    cols: u16,
    position: [f64; 3],
    orientation: [f64; 6],
    pixel_spacing: [f64; 2],
    rescale: Rescale,
    bits_allocated: u16,
    bits_stored: u16,
    signed: bool,
    frames: u32,
}

fn text(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<String> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim().trim_end_matches('\0').to_string())
}

fn floats(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<Vec<f64>> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_multi_float64().ok())
}

fn int(obj: &DefaultDicomObject, tag: dicom_object::Tag) -> Option<i64> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_int::<i64>().ok())
}

fn bad(path: &Path, msg: impl Into<String>) -> ConvertError {
    ConvertError::new(path, Error::invalid(msg.into()))
}

/// Where [`check_lengths`] reads a data set from: the file, or the inflated
/// data set of the deflated transfer syntax.
trait Walk: std::io::Read {
    /// Pass `n` bytes of value; errors when fewer are left.
    fn skip(&mut self, n: u64) -> std::io::Result<()>;
}

/// A file, with its length: a value is skipped by seeking, after checking
/// that it ends inside the file.
struct FileWalk {
    r: std::io::BufReader<std::fs::File>,
    pos: u64,
    len: u64,
}

impl std::io::Read for FileWalk {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.r.read(buf)?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl Walk for FileWalk {
    fn skip(&mut self, n: u64) -> std::io::Result<()> {
        if n > self.len.saturating_sub(self.pos) {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        let off = i64::try_from(n).map_err(|_| std::io::ErrorKind::UnexpectedEof)?;
        self.r.seek_relative(off)?;
        self.pos += n;
        Ok(())
    }
}

/// An inflated stream: a value is skipped by reading it (its end is only
/// known by reaching it).
struct StreamWalk<R>(R);

impl<R: std::io::Read> std::io::Read for StreamWalk<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl<R: std::io::Read> Walk for StreamWalk<R> {
    fn skip(&mut self, n: u64) -> std::io::Result<()> {
        let mut part = std::io::Read::take(&mut self.0, n);
        let got = std::io::copy(&mut part, &mut std::io::sink())?;
        if got < n {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        Ok(())
    }
}

/// Read exactly `buf.len()` bytes; `false` at a clean end of the data
/// (no byte left), an error at a partial read.
fn read_or_end(r: &mut dyn Walk, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) if got == 0 => return Ok(false),
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

const UNDEFINED: u32 = u32::MAX;
const ITEM: (u16, u16) = (0xfffe, 0xe000);
const SEQUENCE_END: (u16, u16) = (0xfffe, 0xe0dd);

/// Whether explicit-VR elements of value representation `vr` carry a
/// 16-bit length: dicom-rs reads one for these and a 32-bit one (after
/// two reserved bytes) for every other, unknown VRs included (as UN).
fn short_length_vr(vr: &[u8; 2]) -> bool {
    matches!(
        vr,
        b"AE"
            | b"AS"
            | b"AT"
            | b"CS"
            | b"DA"
            | b"DS"
            | b"DT"
            | b"FL"
            | b"FD"
            | b"IS"
            | b"LO"
            | b"LT"
            | b"PN"
            | b"SH"
            | b"SL"
            | b"SS"
            | b"ST"
            | b"TM"
            | b"UI"
            | b"UL"
            | b"US"
    )
}

/// Walk the data elements of one encoding (explicit or implicit VR, byte
/// order) to the end of `r`, stepping into sequences and items and over
/// every other value (and pixel data fragments); the first value that
/// runs past the end of the data is an error.
fn walk_elements(r: &mut dyn Walk, explicit: bool, big: bool) -> Result<(), String> {
    let u16_of = |b: [u8; 2]| {
        if big {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        }
    };
    let u32_of = |b: [u8; 4]| {
        if big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    let mut fragments = false;
    let mut pending: Option<(u16, u16)> = None;
    loop {
        let tag = match pending.take() {
            Some(t) => t,
            None => {
                let mut b = [0u8; 4];
                match read_or_end(r, &mut b) {
                    Ok(true) => (u16_of([b[0], b[1]]), u16_of([b[2], b[3]])),
                    // A data set that stops inside a tag is dicom-rs's to report.
                    _ => return Ok(()),
                }
            }
        };
        let name = format!("({:04X},{:04X})", tag.0, tag.1);
        let short = |r: &mut dyn Walk| -> Result<u32, String> {
            let mut b = [0u8; 2];
            r.read_exact(&mut b)
                .map_err(|_| format!("element {name} is truncated"))?;
            Ok(u16_of(b) as u32)
        };
        let long = |r: &mut dyn Walk| -> Result<u32, String> {
            let mut b = [0u8; 4];
            r.read_exact(&mut b)
                .map_err(|_| format!("element {name} is truncated"))?;
            Ok(u32_of(b))
        };
        // Items and delimiters have no VR, in either encoding.
        if tag.0 == 0xfffe {
            let len = long(r)?;
            if tag == ITEM && fragments && len != UNDEFINED {
                r.skip(len as u64).map_err(|_| {
                    format!("a pixel data fragment claims {len} bytes, past the end of the data")
                })?;
            } else if tag == SEQUENCE_END {
                fragments = false;
            }
            continue;
        }
        let (vr, len) = if explicit {
            let mut v = [0u8; 2];
            r.read_exact(&mut v)
                .map_err(|_| format!("element {name} is truncated"))?;
            let wide = !short_length_vr(&v);
            let len = if wide {
                short(r)?;
                long(r)?
            } else {
                short(r)?
            };
            (Some(v), len)
        } else {
            (None, long(r)?)
        };
        if len == UNDEFINED {
            // As dicom-rs reads it: undefined-length pixel data holds
            // fragments, any other undefined-length element (whatever its
            // VR) a sequence in the same encoding; items follow up to a
            // sequence delimiter.
            if tag == (0x7fe0, 0x0010) {
                fragments = true;
            }
            continue;
        }
        if vr.as_ref() == Some(b"SQ") {
            continue;
        }
        if vr.is_none() && len >= 8 {
            // Implicit VR: a value that starts with an item is a sequence.
            let mut b = [0u8; 4];
            r.read_exact(&mut b).map_err(|_| {
                format!("element {name} claims {len} bytes, past the end of the data")
            })?;
            let t = (u16_of([b[0], b[1]]), u16_of([b[2], b[3]]));
            if t == ITEM {
                pending = Some(t);
                continue;
            }
            r.skip(len as u64 - 4).map_err(|_| {
                format!("element {name} claims {len} bytes, past the end of the data")
            })?;
            continue;
        }
        // dicom-rs reads whole numbers of a binary VR's values: the
        // bytes of a length that is no multiple of their size are left
        // for the next element's header.
        let size = match vr.as_ref().map(|v| &v[..]) {
            Some(b"US" | b"OW" | b"SS") => 2,
            Some(b"FL" | b"OF" | b"SL" | b"OL" | b"UL" | b"AT") => 4,
            Some(b"FD" | b"OD" | b"SV" | b"OV" | b"UV") => 8,
            _ => 1,
        };
        r.skip(u64::from(len - len % size))
            .map_err(|_| format!("element {name} claims {len} bytes, past the end of the data"))?;
    }
}

/// Refuse a file any of whose data elements claims more bytes than the
/// file holds (more than its inflated data set, for the deflated transfer
/// syntax). dicom-rs reserves and zero-fills a value's declared length
/// before reading it: unchecked, a 600-byte file claiming a 4 GiB element
/// would take 4 GiB of memory.
fn check_lengths(path: &Path) -> CResult<()> {
    use std::io::{Read, Seek, SeekFrom};
    let f = std::fs::File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    let mut w = FileWalk {
        r: std::io::BufReader::new(f),
        pos: 0,
        len,
    };
    // The preamble and DICM, then the meta group (explicit VR little endian).
    if len < 132 {
        return Ok(());
    }
    w.r.seek(SeekFrom::Start(132)).at(path)?;
    w.pos = 132;
    let fail = |e: String| bad(path, format!("damaged DICOM file: {e}"));
    // The meta group as dicom-rs reads it: elements while fewer bytes
    // than (0002,0000) gives have been read, whatever their tags.
    let mut head = [0u8; 12];
    if w.read_exact(&mut head).is_err() || head[..8] != [2, 0, 0, 0, b'U', b'L', 4, 0] {
        return Ok(());
    }
    let group_len = u64::from(u32::from_le_bytes([head[8], head[9], head[10], head[11]]));
    let mut ts = None;
    let mut read = 0u64;
    while read < group_len {
        let mut h = [0u8; 8];
        if w.read_exact(&mut h).is_err() {
            return Ok(());
        }
        let tag = (
            u16::from_le_bytes([h[0], h[1]]),
            u16::from_le_bytes([h[2], h[3]]),
        );
        let short = short_length_vr(&[h[4], h[5]]) && tag.0 != 0xfffe;
        let (len, header) = if short {
            (u32::from(u16::from_le_bytes([h[6], h[7]])), 8)
        } else {
            let mut l = [0u8; 4];
            if w.read_exact(&mut l).is_err() {
                return Ok(());
            }
            (u32::from_le_bytes(l), 12)
        };
        if len == UNDEFINED {
            return Ok(());
        }
        let name = format!("({:04X},{:04X})", tag.0, tag.1);
        let past = || {
            fail(format!(
                "element {name} claims {len} bytes, past the end of the data"
            ))
        };
        if tag == (0x0002, 0x0010) && len <= 64 {
            let mut b = vec![0u8; len as usize];
            w.read_exact(&mut b).map_err(|_| past())?;
            ts = Some(
                String::from_utf8_lossy(&b)
                    .trim_end_matches(['\0', ' '])
                    .to_string(),
            );
        } else {
            w.skip(u64::from(len)).map_err(|_| past())?;
        }
        read += header + u64::from(len);
    }
    let ts = ts.unwrap_or_default();
    match ts.as_str() {
        "1.2.840.10008.1.2" => walk_elements(&mut w, false, false),
        "1.2.840.10008.1.2.2" => walk_elements(&mut w, true, true),
        "1.2.840.10008.1.2.1.99" | "1.2.840.10008.1.2.4.95" => {
            let mut s = StreamWalk(flate2::read::DeflateDecoder::new(w.r));
            walk_elements(&mut s, true, false)
        }
        _ => walk_elements(&mut w, true, false),
    }
    .map_err(fail)?;
    Ok(())
}

/// A file of a DICOM input that holds no image, skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// What it holds: `DICOMDIR` or its SOP class's name.
    pub what: String,
}

/// What one file of an input is.
enum Header {
    /// A slice of an image series.
    Image(SliceHeader),
    /// Anything else.
    Other(Skipped),
}

/// The Media Storage Directory (`DICOMDIR`) SOP class.
const DICOMDIR_CLASS: &str = "1.2.840.10008.1.3.10";

/// What `obj` holds when it is no image, `None` for an image: a DICOMDIR
/// (by its SOP class or its name), or an object without Rows and Columns
/// whose SOP class is not an image storage class. An image class without
/// Rows stays an image, to be refused as damaged.
fn non_image(path: &Path, obj: &DefaultDicomObject) -> Option<String> {
    use dicom_core::dictionary::UidDictionary;
    let class = text(obj, tags::SOP_CLASS_UID)
        .filter(|c| !c.is_empty())
        .unwrap_or_else(|| {
            obj.meta()
                .media_storage_sop_class_uid()
                .trim_end_matches(['\0', ' '])
                .to_string()
        });
    let named_dicomdir = path
        .file_name()
        .is_some_and(|n| n.eq_ignore_ascii_case("DICOMDIR"));
    if class == DICOMDIR_CLASS || named_dicomdir {
        return Some("DICOMDIR".into());
    }
    let name = dicom_dictionary_std::StandardSopClassDictionary
        .by_uid(&class)
        .map(|e| e.name.to_string());
    let has_size = int(obj, tags::ROWS).is_some() && int(obj, tags::COLUMNS).is_some();
    let image_class = name.as_deref().is_some_and(|n| n.contains("Image"));
    if has_size || image_class {
        return None;
    }
    Some(name.unwrap_or_else(|| {
        if class.is_empty() {
            "an object without SOP class".into()
        } else {
            format!("SOP class {class}")
        }
    }))
}

/// Read the data set of one file up to (not including) its pixel data.
fn read_header(path: &Path) -> CResult<Header> {
    check_lengths(path)?;
    let obj = OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .open_file(path)
        .map_err(|e| bad(path, format!("not a readable DICOM file: {e}")))?;
    if let Some(what) = non_image(path, &obj) {
        return Ok(Header::Other(Skipped {
            path: path.to_path_buf(),
            what,
        }));
    }
    let need = |tag, name: &str| -> CResult<Vec<f64>> {
        floats(&obj, tag).ok_or_else(|| bad(path, format!("DICOM image without {name}")))
    };
    let series = text(&obj, tags::SERIES_INSTANCE_UID)
        .ok_or_else(|| bad(path, "DICOM file without SeriesInstanceUID"))?;
    let rows = int(&obj, tags::ROWS).unwrap_or(0);
    let cols = int(&obj, tags::COLUMNS).unwrap_or(0);
    if !(1..=65535).contains(&rows) || !(1..=65535).contains(&cols) {
        return Err(bad(path, "DICOM image without Rows and Columns"));
    }
    let p = need(tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
    let o = need(tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
    let s = floats(&obj, tags::PIXEL_SPACING).unwrap_or_else(|| vec![1.0, 1.0]);
    if p.len() != 3 || o.len() != 6 || s.len() != 2 {
        return Err(bad(
            path,
            "DICOM ImagePositionPatient, ImageOrientationPatient or PixelSpacing has the wrong number of values",
        ));
    }
    if p.iter().chain(&o).chain(&s).any(|v| !v.is_finite()) || s.iter().any(|v| *v <= 0.0) {
        return Err(bad(
            path,
            "DICOM position, orientation or spacing is not finite and positive",
        ));
    }
    let spp = int(&obj, tags::SAMPLES_PER_PIXEL).unwrap_or(1);
    if spp != 1 {
        return Err(bad(
            path,
            format!("DICOM image with {spp} samples per pixel (colour): volkit reads grey images"),
        ));
    }
    let bits_allocated = int(&obj, tags::BITS_ALLOCATED).unwrap_or(16) as u16;
    if !matches!(bits_allocated, 8 | 16 | 32) {
        return Err(bad(
            path,
            format!("DICOM BitsAllocated {bits_allocated} is not supported (8, 16 or 32)"),
        ));
    }
    let bits_stored = (int(&obj, tags::BITS_STORED).unwrap_or(bits_allocated as i64) as u16)
        .clamp(1, bits_allocated);
    let slope = floats(&obj, tags::RESCALE_SLOPE)
        .and_then(|v| v.first().copied())
        .unwrap_or(1.0);
    let intercept = floats(&obj, tags::RESCALE_INTERCEPT)
        .and_then(|v| v.first().copied())
        .unwrap_or(0.0);
    if !(slope.is_finite() && intercept.is_finite()) || slope == 0.0 {
        return Err(bad(
            path,
            "DICOM RescaleSlope or RescaleIntercept is not usable",
        ));
    }
    let ts = obj
        .meta()
        .transfer_syntax()
        .trim_end_matches('\0')
        .to_string();
    check_transfer_syntax(path, &ts)?;
    Ok(Header::Image(SliceHeader {
        path: path.to_path_buf(),
        series,
        series_number: int(&obj, tags::SERIES_NUMBER),
        description: text(&obj, tags::SERIES_DESCRIPTION).unwrap_or_default(),
        modality: text(&obj, tags::MODALITY).unwrap_or_default(),
        rows: rows as u16,
        cols: cols as u16,
        position: [p[0], p[1], p[2]],
        orientation: [o[0], o[1], o[2], o[3], o[4], o[5]],
        pixel_spacing: [s[0], s[1]],
        rescale: Rescale { slope, intercept },
        bits_allocated,
        bits_stored,
        signed: int(&obj, tags::PIXEL_REPRESENTATION) == Some(1),
        frames: int(&obj, tags::NUMBER_OF_FRAMES).unwrap_or(1).max(1) as u32,
    }))
}

/// Fail clearly on a transfer syntax this build cannot decode.
fn check_transfer_syntax(path: &Path, uid: &str) -> CResult<()> {
    use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};
    match TransferSyntaxRegistry.get(uid) {
        Some(ts) if ts.can_decode_all() => Ok(()),
        Some(ts) => Err(bad(
            path,
            format!(
                "DICOM transfer syntax {} ({uid}) cannot be decoded by volkit: convert the series to an uncompressed, RLE or JPEG transfer syntax first (e.g. with dcmdjpeg or gdcmconv --raw)",
                ts.name()
            ),
        )),
        None => Err(bad(path, format!("unknown DICOM transfer syntax {uid}"))),
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The files of a DICOM input: a directory (every regular, non-hidden
/// file that is DICOM), a glob or a list file.
pub fn list_files(input: &Path, files: Option<Vec<PathBuf>>) -> CResult<Vec<PathBuf>> {
    let files = match files {
        Some(f) => f,
        None => {
            let mut v = Vec::new();
            for e in std::fs::read_dir(input).at(input)? {
                let e = e.at(input)?;
                let hidden = e.file_name().to_string_lossy().starts_with('.');
                if !hidden && e.path().is_file() && is_dicom_file(&e.path()) {
                    v.push(e.path());
                }
            }
            v
        }
    };
    if files.is_empty() {
        return Err(bad(input, "holds no DICOM files"));
    }
    Ok(files)
}

/// A DICOM series, read slice by slice (any slice from any thread).
pub struct DicomReader {
    info: InputInfo,
    slices: Vec<SliceHeader>,
    bytes: u64,
    skipped: Vec<Skipped>,
}

/// One series of a DICOM input, as listed.
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesInfo {
    /// SeriesInstanceUID.
    pub uid: String,
    /// SeriesNumber, when the files give one.
    pub number: Option<i64>,
    /// SeriesDescription (empty when none).
    pub description: String,
    /// Modality (empty when none).
    pub modality: String,
    /// Image files.
    pub images: usize,
    /// Columns, rows and images.
    pub dims: [u64; 3],
}

impl SeriesInfo {
    /// `#N UID (CT, 10 images of 16x12)`, for messages.
    pub fn describe(&self) -> String {
        format!(
            "{}{} ({}{} images of {}x{})",
            self.number.map(|n| format!("#{n} ")).unwrap_or_default(),
            self.uid,
            if self.modality.is_empty() {
                String::new()
            } else {
                format!("{}, ", self.modality)
            },
            self.images,
            self.dims[0],
            self.dims[1]
        )
    }
}

/// The files of a DICOM input read up to their pixel data: the images
/// grouped by series (in order of SeriesNumber, then UID), and the files
/// skipped as no image.
pub struct Scan {
    input: PathBuf,
    series: Vec<(SeriesInfo, Vec<SliceHeader>)>,
    skipped: Vec<Skipped>,
}

impl Scan {
    /// Read the headers of `files` (from `input`, named in errors); an
    /// input whose files hold no image at all is an error.
    pub fn new(input: &Path, files: &[PathBuf]) -> CResult<Scan> {
        use rayon::prelude::*;
        let headers: Vec<Header> = files
            .par_iter()
            .map(|f| read_header(f))
            .collect::<CResult<_>>()?;
        let mut by_series: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
        let mut skipped = Vec::new();
        for h in headers {
            match h {
                Header::Image(h) => by_series.entry(h.series.clone()).or_default().push(h),
                Header::Other(s) => skipped.push(s),
            }
        }
        if by_series.is_empty() {
            return Err(bad(
                input,
                format!(
                    "holds no DICOM image: {} skipped",
                    skipped_summary(&skipped)
                ),
            ));
        }
        let mut series: Vec<(SeriesInfo, Vec<SliceHeader>)> = by_series
            .into_iter()
            .map(|(uid, v)| {
                let first = &v[0];
                let info = SeriesInfo {
                    number: v.iter().find_map(|h| h.series_number),
                    description: first.description.clone(),
                    modality: first.modality.clone(),
                    images: v.len(),
                    dims: [first.cols as u64, first.rows as u64, v.len() as u64],
                    uid,
                };
                (info, v)
            })
            .collect();
        series.sort_by(|a, b| (a.0.number, &a.0.uid).cmp(&(b.0.number, &b.0.uid)));
        Ok(Scan {
            input: input.to_path_buf(),
            series,
            skipped,
        })
    }

    /// The series found.
    pub fn series(&self) -> Vec<SeriesInfo> {
        self.series.iter().map(|(s, _)| s.clone()).collect()
    }

    /// The files skipped as no image.
    pub fn skipped(&self) -> &[Skipped] {
        &self.skipped
    }

    /// What the user should hear of: how many files were skipped (what
    /// [`DicomReader`]'s notes say too).
    pub fn notes(&self) -> Vec<String> {
        skipped_notes(&self.input, &self.skipped)
    }

    /// The index of the series `sel` names, tried in this order: its
    /// whole UID, its SeriesNumber, a prefix of one UID only; with `None`,
    /// the only series. Anything else is an error listing the candidates.
    fn select(&self, sel: Option<&str>) -> CResult<usize> {
        let list = |idx: &[usize]| {
            idx.iter()
                .map(|&i| self.series[i].0.describe())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let all: Vec<usize> = (0..self.series.len()).collect();
        let Some(sel) = sel else {
            if self.series.len() == 1 {
                return Ok(0);
            }
            return Err(bad(
                &self.input,
                format!(
                    "holds {} DICOM series: pick one with --series (its number, UID or a unique UID prefix): {}",
                    self.series.len(),
                    list(&all)
                ),
            ));
        };
        if let Some(i) = self.series.iter().position(|(s, _)| s.uid == sel) {
            return Ok(i);
        }
        let pick = |found: Vec<usize>, how: &str| -> CResult<Option<usize>> {
            match found.len() {
                0 => Ok(None),
                1 => Ok(Some(found[0])),
                n => Err(bad(
                    &self.input,
                    format!(
                        "--series {sel} is ambiguous: {n} series {how}: {}; give more of the UID",
                        list(&found)
                    ),
                )),
            }
        };
        if let Ok(number) = sel.parse::<i64>() {
            let found = all
                .iter()
                .copied()
                .filter(|&i| self.series[i].0.number == Some(number))
                .collect();
            if let Some(i) = pick(found, "have this number")? {
                return Ok(i);
            }
        }
        let found = all
            .iter()
            .copied()
            .filter(|&i| !sel.is_empty() && self.series[i].0.uid.starts_with(sel))
            .collect();
        if let Some(i) = pick(found, "have UIDs starting so")? {
            return Ok(i);
        }
        Err(bad(
            &self.input,
            format!("no series {sel}; the input holds {}", list(&all)),
        ))
    }

    /// Open the series `sel` names (see [`Scan::select`]).
    pub fn open(mut self, sel: Option<&str>) -> CResult<DicomReader> {
        let i = self.select(sel)?;
        let (_, slices) = self.series.swap_remove(i);
        let mut r = DicomReader::new(&self.input, slices)?;
        r.skipped = self.skipped;
        Ok(r)
    }
}

/// `3 files (1 DICOMDIR, 2 Basic Text SR Storage)`: how many files were
/// skipped and what they hold.
fn skipped_summary(skipped: &[Skipped]) -> String {
    let mut kinds: BTreeMap<&str, usize> = BTreeMap::new();
    for s in skipped {
        *kinds.entry(s.what.as_str()).or_default() += 1;
    }
    format!(
        "{} file{} ({})",
        skipped.len(),
        if skipped.len() == 1 { "" } else { "s" },
        kinds
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// `input: skipped 2 files (...) that hold no image`, or nothing.
fn skipped_notes(input: &Path, skipped: &[Skipped]) -> Vec<String> {
    if skipped.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "{}: skipped {} that hold{} no image",
        input.display(),
        skipped_summary(skipped),
        if skipped.len() == 1 { "s" } else { "" }
    )]
}

/// Open the series in `files` (from `input`): the one `series` names
/// (see [`Scan`]), or the only one.
pub fn open(input: &Path, files: Vec<PathBuf>, series: Option<&str>) -> CResult<DicomReader> {
    Scan::new(input, &files)?.open(series)
}

impl DicomReader {
    fn new(input: &Path, mut slices: Vec<SliceHeader>) -> CResult<DicomReader> {
        let first = slices[0].clone();
        for s in &slices {
            if (s.rows, s.cols) != (first.rows, first.cols) {
                return Err(bad(
                    &s.path,
                    format!(
                        "image is {}x{} but {} is {}x{}: mixed sizes in one series",
                        s.cols,
                        s.rows,
                        first.path.display(),
                        first.cols,
                        first.rows
                    ),
                ));
            }
            if s.orientation
                .iter()
                .zip(&first.orientation)
                .any(|(a, b)| (a - b).abs() > 1e-4)
            {
                return Err(bad(
                    &s.path,
                    "ImageOrientationPatient differs from the rest of the series",
                ));
            }
            if s.pixel_spacing
                .iter()
                .zip(&first.pixel_spacing)
                .any(|(a, b)| (a - b).abs() > 1e-4)
            {
                return Err(bad(
                    &s.path,
                    "PixelSpacing differs from the rest of the series",
                ));
            }
            if (s.bits_allocated, s.signed) != (first.bits_allocated, first.signed) {
                return Err(bad(
                    &s.path,
                    "pixel type differs from the rest of the series",
                ));
            }
            if s.frames != 1 {
                return Err(bad(
                    &s.path,
                    format!("multi-frame DICOM image ({} frames): volkit reads series of single-frame images", s.frames),
                ));
            }
        }
        let o = first.orientation;
        let row = [o[0], o[1], o[2]];
        let col = [o[3], o[4], o[5]];
        let normal = cross(row, col);
        let geometry_axes = |n: [f64; 3]| [row, col, n];
        let nn = dot(normal, normal).sqrt();
        if nn < 1e-6 {
            return Err(bad(
                &first.path,
                "ImageOrientationPatient rows are parallel",
            ));
        }
        let normal = normal.map(|v| v / nn);
        slices.sort_by(|a, b| dot(a.position, normal).total_cmp(&dot(b.position, normal)));
        let along: Vec<f64> = slices.iter().map(|s| dot(s.position, normal)).collect();
        let spacing_z = check_gaps(input, &slices, &along)?;
        if slices.len() > 1 {
            // Gantry tilt: the slices' origins leave the normal.
            let span = sub3(slices[slices.len() - 1].position, slices[0].position);
            let d = dot(span, normal);
            let lateral = sub3(span, normal.map(|v| v * d));
            let off = dot(lateral, lateral).sqrt();
            if off > (0.01 * d.abs()).max(0.01) {
                return Err(bad(
                    input,
                    format!(
                        "slice positions drift {off:.3} mm sideways over {:.3} mm (gantry tilt): volkit reads series whose slices stack along their normal; resample the series first",
                        d.abs()
                    ),
                ));
            }
        }
        let geometry = Geometry::from_axes(slices[0].position, geometry_axes(normal))
            .map_err(|e| bad(&first.path, format!("DICOM geometry: {e}")))?
            // DICOM states every position and spacing in millimetres.
            .with_unit(volcore::LengthUnit::Millimeter);
        let stored = stored_type(first.bits_allocated, first.signed);
        let out = slices
            .iter()
            .map(|s| {
                if s.rescale.is_identity() {
                    stored
                } else {
                    s.rescale.output_type(stored)
                }
            })
            .fold(stored, widest);
        let dims =
            Dims::new(first.cols as u64, first.rows as u64, slices.len() as u64).at(input)?;
        let bytes = slices
            .iter()
            .map(|s| std::fs::metadata(&s.path).map(|m| m.len()).unwrap_or(0))
            .sum();
        Ok(DicomReader {
            skipped: Vec::new(),
            info: InputInfo {
                nifti_codes: None,
                path: input.to_path_buf(),
                dims,
                sample_type: out,
                spacing: Some([
                    first.pixel_spacing[1] as f32,
                    first.pixel_spacing[0] as f32,
                    spacing_z as f32,
                ]),
                geometry,
                format: format!(
                    "dicom series ({}{} images)",
                    if first.modality.is_empty() {
                        String::new()
                    } else {
                        format!("{}, ", first.modality)
                    },
                    slices.len()
                ),
            },
            slices,
            bytes,
        })
    }
}

/// The slice spacing of sorted positions `along` the normal, or an error
/// naming the first bad gap.
fn check_gaps(input: &Path, slices: &[SliceHeader], along: &[f64]) -> CResult<f64> {
    if along.len() < 2 {
        return Ok(1.0);
    }
    let gaps: Vec<f64> = along.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = gaps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    for (k, &g) in gaps.iter().enumerate() {
        let (a, b) = (&slices[k], &slices[k + 1]);
        if g <= GAP_TOLERANCE_MM {
            return Err(bad(
                input,
                format!(
                    "{} and {} lie at the same position ({:.3} mm along the normal)",
                    a.path.display(),
                    b.path.display(),
                    along[k]
                ),
            ));
        }
        let tol = (median * GAP_TOLERANCE).max(GAP_TOLERANCE_MM);
        if (g - median).abs() > tol {
            let ratio = g / median;
            let whole = ratio.round();
            if whole >= 2.0 && (g - whole * median).abs() <= tol * whole {
                return Err(bad(
                    input,
                    format!(
                        "{} slice{} missing between {:.3} mm and {:.3} mm along the normal (gap {:.3} mm, spacing {:.3} mm; after {})",
                        whole as u64 - 1,
                        if whole as u64 == 2 { " is" } else { "s are" },
                        along[k],
                        along[k + 1],
                        g,
                        median,
                        a.path.display()
                    ),
                ));
            }
            return Err(bad(
                input,
                format!(
                    "uneven slice spacing: gap of {g:.3} mm between {} and {} where the series spaces slices {median:.3} mm apart",
                    a.path.display(),
                    b.path.display()
                ),
            ));
        }
    }
    Ok(median)
}

fn stored_type(bits: u16, signed: bool) -> SliceType {
    match (bits, signed) {
        (8, false) => SliceType::U8,
        (8, true) => SliceType::I8,
        (16, false) => SliceType::U16,
        (16, true) => SliceType::I16,
        (_, false) => SliceType::U32,
        (_, true) => SliceType::I32,
    }
}

/// The type that holds both (for slices rescaled differently).
fn widest(a: SliceType, b: SliceType) -> SliceType {
    if a == b {
        a
    } else if a.is_integer() && b.is_integer() {
        SliceType::I32
    } else {
        SliceType::F64
    }
}

impl DicomReader {
    fn decode(&self, s: &SliceHeader) -> CResult<SliceData> {
        let obj = dicom_object::open_file(&s.path)
            .map_err(|e| bad(&s.path, format!("not a readable DICOM file: {e}")))?;
        let t = stored_type(s.bits_allocated, s.signed);
        let n = s.rows as usize * s.cols as usize;
        let rle;
        let px;
        let bytes: &[u8] = if obj.meta().transfer_syntax().trim_end_matches('\0') == RLE_LOSSLESS {
            // Decoded here: dicom-rs's RLE decoder panics on damaged
            // segment tables and short segments.
            let frame = obj
                .element(tags::PIXEL_DATA)
                .ok()
                .and_then(|e| e.value().fragments())
                .and_then(|f| f.first())
                .ok_or_else(|| bad(&s.path, "RLE pixel data without fragments"))?;
            rle = decode_rle(frame, n, t.size())
                .map_err(|e| bad(&s.path, format!("cannot decode the RLE pixel data: {e}")))?;
            &rle
        } else {
            px = obj
                .decode_pixel_data()
                .map_err(|e| bad(&s.path, format!("cannot decode the pixel data: {e}")))?;
            px.frame_data(0)
                .map_err(|e| bad(&s.path, format!("cannot decode the pixel data: {e}")))?
        };
        if bytes.len() < n * t.size() {
            return Err(bad(
                &s.path,
                format!(
                    "pixel data holds {} bytes, {}x{} {}-bit pixels need {}",
                    bytes.len(),
                    s.cols,
                    s.rows,
                    s.bits_allocated,
                    n * t.size()
                ),
            ));
        }
        let mut d = SliceData::from_bytes(t, &bytes[..n * t.size()], false);
        mask_bits(&mut d, s.bits_stored);
        let d = if s.rescale.is_identity() {
            d
        } else {
            s.rescale.apply(&d)
        };
        Ok(to_type(d, self.info.sample_type))
    }
}

/// The RLE Lossless transfer syntax.
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// Decode one RLE Lossless frame of `pixels` grey samples of `size` bytes
/// into little-endian samples (DICOM PS3.5 annex G): a 64-byte header of
/// the segment count and up to 15 offsets, then one PackBits segment per
/// byte of a sample, the most significant first. Every offset and run is
/// checked against the frame.
fn decode_rle(frame: &[u8], pixels: usize, size: usize) -> Result<Vec<u8>, String> {
    let word = |i: usize| -> u32 {
        frame
            .get(4 * i..4 * i + 4)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if frame.len() < 64 {
        return Err(format!(
            "a frame of {} bytes has no RLE header",
            frame.len()
        ));
    }
    let segments = word(0) as usize;
    if segments != size {
        return Err(format!(
            "{segments} segments for {}-bit samples (expected {size})",
            size * 8
        ));
    }
    let mut out = vec![0u8; pixels * size];
    for seg in 0..segments {
        let start = word(1 + seg) as usize;
        let end = if seg + 1 < segments {
            word(2 + seg) as usize
        } else {
            frame.len()
        };
        if start < 64 || start > end || end > frame.len() {
            return Err(format!(
                "segment {seg} at bytes {start}..{end} lies outside the {}-byte frame",
                frame.len()
            ));
        }
        // Segment 0 holds the most significant bytes.
        let byte = size - 1 - seg;
        let mut data = &frame[start..end];
        let mut p = 0usize;
        while p < pixels {
            let Some((&h, rest)) = data.split_first() else {
                return Err(format!("segment {seg} ends after {p} of {pixels} samples"));
            };
            data = rest;
            let h = h as i8;
            if h >= 0 {
                let n = h as usize + 1;
                let lit = data
                    .get(..n)
                    .ok_or_else(|| format!("segment {seg} ends inside a literal run"))?;
                for &b in lit.iter().take(pixels - p) {
                    out[p * size + byte] = b;
                    p += 1;
                }
                data = &data[n..];
            } else if h != -128 {
                let n = 1 - h as isize;
                let (&b, rest) = data
                    .split_first()
                    .ok_or_else(|| format!("segment {seg} ends inside a repeat run"))?;
                data = rest;
                for _ in 0..(n as usize).min(pixels - p) {
                    out[p * size + byte] = b;
                    p += 1;
                }
            }
        }
    }
    Ok(out)
}

/// Keep the BitsStored low bits (sign-extended for signed pixels).
fn mask_bits(d: &mut SliceData, bits: u16) {
    macro_rules! unsigned {
        ($v:expr, $w:expr) => {
            if (bits as u32) < $w {
                let m = (1u64 << bits) - 1;
                $v.iter_mut().for_each(|x| *x = (*x as u64 & m) as _);
            }
        };
    }
    macro_rules! signed {
        ($v:expr, $t:ty, $w:expr) => {
            if (bits as u32) < $w {
                let sh = $w - bits as u32;
                $v.iter_mut().for_each(|x| *x = ((*x << sh) as $t) >> sh);
            }
        };
    }
    match d {
        SliceData::U8(v) => unsigned!(v, 8),
        SliceData::U16(v) => unsigned!(v, 16),
        SliceData::U32(v) => unsigned!(v, 32),
        SliceData::I8(v) => signed!(v, i8, 8),
        SliceData::I16(v) => signed!(v, i16, 16),
        SliceData::I32(v) => signed!(v, i32, 32),
        _ => {}
    }
}

/// `d` as type `t` (same values; `t` is at least as wide).
fn to_type(d: SliceData, t: SliceType) -> SliceData {
    if d.sample_type() == t {
        return d;
    }
    let n = d.len();
    match t {
        SliceType::I32 => SliceData::I32((0..n).map(|i| d.value(i) as i32).collect()),
        _ => SliceData::F64((0..n).map(|i| d.value(i)).collect()),
    }
}

impl SliceReader for DicomReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        let s = self.slices.get(z as usize).ok_or_else(|| {
            bad(
                &self.info.path,
                format!("slice {z} out of range (internal error)"),
            )
        })?;
        self.decode(s)
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
    fn notes(&self) -> Vec<String> {
        skipped_notes(&self.info.path, &self.skipped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_widen_to_hold_every_slice() {
        assert_eq!(widest(SliceType::I32, SliceType::U16), SliceType::I32);
        assert_eq!(widest(SliceType::I32, SliceType::F64), SliceType::F64);
        assert_eq!(widest(SliceType::I16, SliceType::I16), SliceType::I16);
        let mut d = SliceData::I16(vec![0x0fff, 0x0800, 0x07ff]);
        mask_bits(&mut d, 12);
        assert_eq!(d, SliceData::I16(vec![-1, -2048, 2047]));
        let mut d = SliceData::U16(vec![0xf0ff]);
        mask_bits(&mut d, 12);
        assert_eq!(d, SliceData::U16(vec![0x00ff]));
    }
}
