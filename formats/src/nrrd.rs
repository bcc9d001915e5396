//! NRRD headers (`.nrrd` with attached data, `.nhdr` with a detached data
//! file), parsed with `nom`.
//!
//! Supported: 2 or 3 dimensions; types `int8`, `uint8`, `int16`,
//! `uint16`, `int32`, `uint32`, `float` and `double` (with their NRRD
//! aliases); `raw` and `gzip` encodings; `endian`; `byte skip` (including
//! -1 for raw data at the end of the file) and `line skip`; `spacings`, or
//! `space directions` with `space origin` for spacing, origin and axis
//! directions (signs kept; `space` `RAS`-like frames are turned into
//! volkit's LPS); one detached `data file`. File lists, format strings,
//! `ascii`, `hex` and `bzip2` data are reported as unsupported.
//!
//! [`write_header`] writes the header volkit's NRRD output uses.

use crate::datafile::{detached_file, DataSpec, DataStart, Encoding, HeaderSamples};
use crate::error::{Error, Result};
use crate::slice::SliceType;
use nom::bytes::complete::{tag, take_until};
use nom::combinator::rest;
use nom::{IResult, Parser};
use std::io::{BufRead, Read};
use std::path::Path;
use volcore::text::excerpt;
use volcore::Dims;
use volcore::{Geometry, LengthUnit};

/// The fields of a NRRD header volkit uses.
#[derive(Clone, Debug, PartialEq)]
pub struct NrrdHeader {
    /// Voxels per axis (a 2D image has z = 1).
    pub samples: HeaderSamples,
    /// Raw or gzip.
    pub encoding: Encoding,
    /// Detached data file, as written.
    pub data_file: Option<String>,
    /// `byte skip` (-1: raw data at the end of the file).
    pub byte_skip: i64,
    /// `line skip`.
    pub line_skip: u64,
}

/// One header line.
#[derive(Debug, PartialEq)]
enum Line<'a> {
    Comment,
    Field(&'a str, &'a str),
    KeyValue,
}

fn field(i: &str) -> IResult<&str, (&str, &str)> {
    (take_until(": "), tag(": "), rest)
        .map(|(k, _, v): (&str, &str, &str)| (k, v))
        .parse(i)
}

fn key_value(i: &str) -> IResult<&str, ()> {
    (take_until(":="), tag(":="), rest).map(|_| ()).parse(i)
}

fn line(i: &str) -> Option<Line<'_>> {
    if i.starts_with('#') {
        return Some(Line::Comment);
    }
    // `key:=value` is checked first: keys may not hold ": ", values may.
    let kv = key_value(i).ok();
    let f = field(i).ok();
    match (kv, f) {
        (Some(_), Some((_, (k, _)))) if !k.contains(":=") => f.map(|(_, (k, v))| Line::Field(k, v)),
        (Some(_), _) => Some(Line::KeyValue),
        (None, Some((_, (k, v)))) => Some(Line::Field(k, v)),
        (None, None) => None,
    }
}

fn magic(i: &str) -> IResult<&str, &str> {
    (tag("NRRD000"), nom::character::complete::one_of("12345"))
        .map(|(m, _): (&str, char)| m)
        .parse(i)
}

fn sample_type(t: &str) -> Result<SliceType> {
    match t.trim() {
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Ok(SliceType::U8),
        "signed char" | "int8" | "int8_t" => Ok(SliceType::I8),
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Ok(SliceType::I16)
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            Ok(SliceType::U16)
        }
        "int" | "signed int" | "int32" | "int32_t" => Ok(SliceType::I32),
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Ok(SliceType::U32),
        "float" => Ok(SliceType::F32),
        "double" => Ok(SliceType::F64),
        other => Err(Error::invalid(format!(
            "NRRD type '{}' is not supported (volkit reads 8, 16 and 32-bit integers, float and double)",
            excerpt(other)
        ))),
    }
}

/// The NRRD name of a type volkit writes.
pub fn type_name(t: volcore::SampleType) -> &'static str {
    match t {
        volcore::SampleType::U8 => "uint8",
        volcore::SampleType::U16 => "uint16",
        volcore::SampleType::I16 => "int16",
        volcore::SampleType::F32 => "float",
        volcore::SampleType::F64 => "double",
    }
}

/// Per-axis signs that turn a NRRD `space` into LPS (`None`: not a
/// patient frame, taken as is).
fn space_signs(space: &str) -> Result<[f64; 3]> {
    let code = match space.trim().to_ascii_lowercase().as_str() {
        "left-posterior-superior" | "lps" => "LPS",
        "right-anterior-superior" | "ras" => "RAS",
        "left-anterior-superior" | "las" => "LAS",
        "scanner-xyz" | "3d-right-handed" | "3d-left-handed" => "LPS",
        other if other.contains("time") => {
            return Err(Error::invalid(format!(
                "NRRD space '{}' with time is not supported (3D volumes only)",
                excerpt(other)
            )))
        }
        other => {
            return Err(Error::invalid(format!(
                "NRRD space '{}' is not supported (use RAS, LAS or LPS)",
                excerpt(other)
            )))
        }
    };
    let b = code.as_bytes();
    Ok([
        if b[0] == b'L' { 1.0 } else { -1.0 },
        if b[1] == b'P' { 1.0 } else { -1.0 },
        1.0,
    ])
}

/// `(a,b,c)`: a vector of three numbers.
fn vector(s: &str) -> Option<[f64; 3]> {
    let inner = s.trim().strip_prefix('(')?.strip_suffix(')')?;
    let c: Vec<f64> = inner
        .split(',')
        .map(|x| x.trim().parse().ok())
        .collect::<Option<_>>()?;
    match c[..] {
        [a, b, c] => Some([a, b, c]),
        [a, b] => Some([a, b, 0.0]),
        _ => None,
    }
}

fn numbers(v: &str) -> Vec<Option<f64>> {
    v.split_whitespace()
        .map(|s| s.parse::<f64>().ok())
        .collect()
}

/// The axis vectors of `space directions: (a,b,c) (d,e,f) (g,h,i)`
/// (`none` axes left out); a 2D image gets a third axis across its plane.
fn directions(v: &str) -> Result<[[f64; 3]; 3]> {
    let bad = || Error::invalid(format!("bad NRRD space directions: '{}'", excerpt(v)));
    let vecs: Vec<[f64; 3]> = v
        .split_whitespace()
        .filter(|s| *s != "none")
        .map(|s| vector(s).ok_or_else(bad))
        .collect::<Result<_>>()?;
    match vecs[..] {
        [a, b] => {
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            if n == 0.0 {
                return Err(bad());
            }
            Ok([a, b, c.map(|x| x / n)])
        }
        [a, b, c] => Ok([a, b, c]),
        _ => Err(bad()),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Parse the header text (up to, not including, the blank line).
pub fn parse(text: &str) -> Result<NrrdHeader> {
    let mut lines = text.lines();
    let first = lines.next().unwrap_or("");
    if magic(first).is_err() {
        return Err(Error::invalid("not a NRRD file (no NRRD000x magic line)"));
    }
    let mut ty = None;
    let mut dimension = None;
    let mut sizes: Option<Vec<u64>> = None;
    let mut endian = None;
    let mut encoding = None;
    let mut spacings = None;
    let mut dirs = None;
    let mut space = None;
    let mut units = None;
    let mut origin = None;
    let mut data_file = None;
    let mut byte_skip = 0i64;
    let mut line_skip = 0u64;
    for (n, l) in lines.enumerate() {
        let l = l.trim_end_matches('\r');
        if l.is_empty() {
            break;
        }
        let (k, v) = match line(l) {
            Some(Line::Field(k, v)) => (k.trim().to_ascii_lowercase(), v.trim()),
            Some(_) => continue,
            None => {
                return Err(Error::invalid(format!(
                    "header line {} is not 'field: value': '{}'",
                    n + 2,
                    excerpt(l)
                )))
            }
        };
        let bad = |what: &str| Error::invalid(format!("bad NRRD {what}: '{}'", excerpt(v)));
        match k.as_str() {
            "type" => ty = Some(sample_type(v)?),
            "dimension" => dimension = Some(v.parse::<u64>().map_err(|_| bad("dimension"))?),
            "sizes" => {
                sizes = Some(
                    v.split_whitespace()
                        .map(|s| s.parse::<u64>())
                        .collect::<std::result::Result<_, _>>()
                        .map_err(|_| bad("sizes"))?,
                )
            }
            "endian" => {
                endian = Some(match v {
                    "big" => true,
                    "little" => false,
                    _ => return Err(bad("endian")),
                })
            }
            "encoding" => {
                encoding = Some(match v {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    other => {
                        return Err(Error::invalid(format!(
                            "NRRD encoding '{}' is not supported (use raw or gzip)",
                            excerpt(other)
                        )))
                    }
                })
            }
            "spacings" => spacings = Some(numbers(v)),
            "space directions" => dirs = Some(directions(v)?),
            "space" => space = Some(space_signs(v)?),
            "space units" | "units" => units = Some(length_unit(v)?),
            "space origin" => {
                origin = Some(vector(v).ok_or_else(|| bad("space origin"))?);
            }
            "data file" | "datafile" => {
                if v.starts_with("LIST") || v.contains('%') || v.split_whitespace().count() > 1 {
                    return Err(Error::invalid(
                        "NRRD data file lists and patterns are not supported (one data file only)",
                    ));
                }
                data_file = Some(v.to_string());
            }
            "byte skip" | "byteskip" => byte_skip = v.parse().map_err(|_| bad("byte skip"))?,
            "line skip" | "lineskip" => line_skip = v.parse().map_err(|_| bad("line skip"))?,
            _ => {}
        }
    }
    let sample_type = ty.ok_or_else(|| Error::invalid("NRRD header has no type"))?;
    let sizes = sizes.ok_or_else(|| Error::invalid("NRRD header has no sizes"))?;
    let dim = dimension.unwrap_or(sizes.len() as u64);
    if dim != sizes.len() as u64 {
        return Err(Error::invalid(format!(
            "NRRD dimension {dim} does not match {} sizes",
            sizes.len()
        )));
    }
    let dims = match sizes[..] {
        [x, y] => Dims::new(x, y, 1)?,
        [x, y, z] => Dims::new(x, y, z)?,
        _ => {
            return Err(Error::invalid(format!(
                "NRRD with {dim} dimensions: only 2D and 3D scalar data is supported"
            )))
        }
    };
    let encoding = encoding.ok_or_else(|| Error::invalid("NRRD header has no encoding"))?;
    let big_endian = match endian {
        Some(b) => b,
        None if sample_type.size() > 1 => {
            return Err(Error::invalid(
                "NRRD header has no endian for multi-byte samples",
            ))
        }
        None => false,
    };
    let from_dirs = dirs.map(|d| d.map(|v| norm(v) as f32));
    let spacing = spacings
        .map(|s| {
            let v = |i: usize| {
                s.get(i)
                    .copied()
                    .flatten()
                    .filter(|v| v.is_finite() && *v > 0.0)
                    .unwrap_or(1.0) as f32
            };
            [v(0), v(1), if s.len() > 2 { v(2) } else { 1.0 }]
        })
        .or(from_dirs.filter(|d| d.iter().all(|v| v.is_finite() && *v > 0.0)));
    let signs = space.unwrap_or([1.0; 3]);
    let to_lps = |v: [f64; 3]| [v[0] * signs[0], v[1] * signs[1], v[2] * signs[2]];
    let axes = dirs.unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let geometry = Geometry::from_axes(to_lps(origin.unwrap_or([0.0; 3])), axes.map(to_lps))
        .map_err(|e| Error::invalid(format!("NRRD geometry: {e}")))?
        .with_unit(units.unwrap_or_default());
    if byte_skip < -1 {
        return Err(Error::invalid("NRRD byte skip must be -1 or more"));
    }
    if byte_skip == -1 && encoding != Encoding::Raw {
        return Err(Error::invalid(
            "NRRD byte skip -1 works with raw encoding only",
        ));
    }
    Ok(NrrdHeader {
        samples: HeaderSamples {
            dims,
            sample_type,
            big_endian,
            spacing,
            geometry,
        },
        encoding,
        data_file,
        byte_skip,
        line_skip,
    })
}

/// How a NRRD file written by volkit stores its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct NrrdOut {
    /// Dimensions.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: volcore::SampleType,
    /// Voxel spacing.
    pub spacing: [f32; 3],
    /// Origin and directions (written in LPS).
    pub geometry: Geometry,
    /// gzip-compressed samples.
    pub gzip: bool,
    /// Detached data file name (relative to the header), or attached.
    pub data_file: Option<String>,
}

/// The header text of a NRRD file volkit writes (little-endian, LPS,
/// ending with the blank line).
pub fn write_header(o: &NrrdOut) -> String {
    let g = &o.geometry;
    let vecs: Vec<String> = (0..3)
        .map(|a| {
            let v = g.axis(a).map(|c| c * o.spacing[a] as f64);
            format!("({},{},{})", v[0], v[1], v[2])
        })
        .collect();
    let mut h = format!(
        "NRRD0004\n# written by volkit\ntype: {}\ndimension: 3\nspace: left-posterior-superior\nsizes: {} {} {}\nspace directions: {}\nkinds: domain domain domain\nendian: little\nencoding: {}\nspace origin: ({},{},{})\n",
        type_name(o.sample_type),
        o.dims.x,
        o.dims.y,
        o.dims.z,
        vecs.join(" "),
        if o.gzip { "gzip" } else { "raw" },
        g.origin[0],
        g.origin[1],
        g.origin[2],
    );
    if let Some(u) = ascii_unit(g.unit) {
        h.push_str(&format!("space units: \"{u}\" \"{u}\" \"{u}\"\n"));
    }
    if let Some(f) = &o.data_file {
        h.push_str(&format!("data file: {f}\n"));
    }
    h.push('\n');
    h
}

/// The unit `space units` (or `units`) states: one unit of length for
/// every axis (`"mm" "mm" "mm"`; empty strings state none).
fn length_unit(v: &str) -> Result<LengthUnit> {
    let words: Vec<&str> = v
        .split('"')
        .map(str::trim)
        .enumerate()
        .filter(|(i, w)| i % 2 == 1 || !w.is_empty())
        .map(|(_, w)| w)
        .collect();
    let mut unit = None;
    for w in &words {
        let u = LengthUnit::parse(w).ok_or_else(|| {
            Error::invalid(format!(
                "NRRD space unit '{}' is not a unit of length volkit knows (m, cm, mm, um, nm, angstrom)",
                excerpt(w)
            ))
        })?;
        if unit.is_some_and(|seen| seen != u) {
            return Err(Error::invalid(format!(
                "NRRD space units '{}' differ between axes (volkit keeps one unit of length)",
                excerpt(v)
            )));
        }
        unit = Some(u);
    }
    Ok(unit.unwrap_or_default())
}

/// How volkit's NRRD output spells `unit` (ASCII; `None`: not stated).
fn ascii_unit(unit: LengthUnit) -> Option<&'static str> {
    Some(match unit {
        LengthUnit::Unknown => return None,
        LengthUnit::Micrometer => "um",
        LengthUnit::Angstrom => "angstrom",
        other => other.symbol(),
    })
}

/// Read header lines from `r` up to and including the blank line that
/// ends them (or the end of input). Returns the text and its byte length.
pub fn read_header_text(r: &mut dyn BufRead) -> Result<(String, u64)> {
    let mut text = String::new();
    let mut len = 0u64;
    loop {
        let mut l = Vec::new();
        let n = Read::take(&mut *r, 64 * 1024).read_until(b'\n', &mut l)?;
        if n == 0 {
            break;
        }
        len += n as u64;
        if len > 16 << 20 {
            return Err(Error::invalid(
                "header is longer than 16 MiB: not a header?",
            ));
        }
        let s = String::from_utf8_lossy(&l);
        let blank = s.trim_end_matches(['\n', '\r']).is_empty();
        text.push_str(&s);
        if blank {
            break;
        }
    }
    Ok((text, len))
}

/// Read and drop `lines` lines of `r` (without holding them: a "line" of
/// binary data may be long), returning the bytes dropped. Every line read
/// consumes input, so the loop ends with the input however many lines the
/// header asks for.
fn skip_lines_of(r: &mut dyn BufRead, lines: u64) -> Result<u64> {
    let mut dropped = 0u64;
    for done in 0..lines {
        loop {
            let buf = r.fill_buf()?;
            if buf.is_empty() {
                return Err(Error::invalid(format!(
                    "data ends after {done} of the {lines} lines to skip (line skip)"
                )));
            }
            let (n, end) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (buf.len(), false),
            };
            r.consume(n);
            dropped += n as u64;
            if end {
                break;
            }
        }
    }
    Ok(dropped)
}

/// Byte offset after `lines` lines of a file from `offset`.
fn skip_lines(path: &Path, offset: u64, lines: u64) -> Result<u64> {
    if lines == 0 {
        return Ok(offset);
    }
    let mut f = std::fs::File::open(path)?;
    use std::io::{Seek, SeekFrom};
    f.seek(SeekFrom::Start(offset))?;
    let mut r = std::io::BufReader::new(f);
    Ok(offset + skip_lines_of(&mut r, lines)?)
}

/// Read a `.nrrd` or `.nhdr` file's header and locate its samples.
pub fn open(path: &Path) -> Result<DataSpec> {
    let f = std::fs::File::open(path)?;
    let mut r = std::io::BufReader::new(f);
    let (text, header_len) = read_header_text(&mut r)?;
    let h = parse(&text)?;
    spec_for(path, &h, header_len)
}

/// Where the samples of header `h` (read from `path`, `header_len` bytes
/// long) are.
pub fn spec_for(path: &Path, h: &NrrdHeader, header_len: u64) -> Result<DataSpec> {
    let (data_file, base, detached) = match &h.data_file {
        Some(name) => (detached_file(path, name), 0, true),
        None => (path.to_path_buf(), header_len, false),
    };
    let start = skip_lines(&data_file, base, h.line_skip)?;
    let (start, skip_after) = match (h.encoding, h.byte_skip) {
        (Encoding::Raw, -1) => (DataStart::AtEnd, 0),
        (Encoding::Raw, s) => (DataStart::At(start + s as u64), 0),
        (_, s) => (DataStart::At(start), s.max(0) as u64),
    };
    let enc = match h.encoding {
        Encoding::Raw => "raw",
        _ => "gzip",
    };
    Ok(DataSpec {
        skip_after_decode: skip_after,
        ..DataSpec::unscaled(
            h.samples,
            data_file,
            start,
            h.encoding,
            format!(
                "nrrd ({}, {enc})",
                if detached { "detached" } else { "attached" }
            ),
        )
    })
}

/// Whether bytes start like a NRRD file.
pub fn sniff(b: &[u8]) -> bool {
    b.starts_with(b"NRRD000")
}

/// Read a NRRD header from a stream and skip the lines and (raw) bytes it
/// asks to; the samples (attached) follow in `r`. For gzip data the byte
/// skip applies to the decompressed stream and is left to the caller.
pub fn read_stream_header(r: &mut dyn BufRead) -> Result<NrrdHeader> {
    let (text, _) = read_header_text(r)?;
    let h = parse(&text)?;
    if h.data_file.is_some() {
        return Err(Error::invalid(
            "a NRRD header on standard input must have its data attached",
        ));
    }
    skip_lines_of(r, h.line_skip)?;
    if h.encoding == Encoding::Raw {
        if h.byte_skip < 0 {
            return Err(Error::invalid(
                "byte skip -1 cannot be used on standard input",
            ));
        }
        crate::stream::skip_bytes(r, h.byte_skip as u64)?;
    }
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_typical_header() {
        let text = "NRRD0004\n# Complete NRRD file format specification at:\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 64 32 16\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\nkinds: domain domain domain\nendian: big\nencoding: gzip\nspace origin: (0,0,0)\nmy key:=a: b\n\n";
        let h = parse(text).unwrap();
        assert_eq!(h.samples.dims, Dims::new(64, 32, 16).unwrap());
        assert_eq!(h.samples.sample_type, SliceType::I16);
        assert!(h.samples.big_endian);
        assert_eq!(h.encoding, Encoding::Gzip);
        assert_eq!(h.samples.spacing, Some([0.5, 0.5, 2.0]));
        assert_eq!(h.data_file, None);
        assert!(h.samples.geometry.is_identity());
    }

    #[test]
    fn geometry_signs_and_origin() {
        let text = "NRRD0004\ntype: int\ndimension: 3\nspace: right-anterior-superior\nsizes: 4 4 4\nspace directions: (-0.5,0,0) (0,-0.5,0) (0,0,2)\nendian: little\nencoding: raw\nspace origin: (10,20,30)\n";
        let h = parse(text).unwrap();
        assert_eq!(h.samples.sample_type, SliceType::I32);
        assert_eq!(h.samples.spacing, Some([0.5, 0.5, 2.0]));
        // RAS (-x, -y) is LPS (+x, +y); the origin flips to (-10, -20, 30).
        assert_eq!(h.samples.geometry.origin, [-10.0, -20.0, 30.0]);
        assert_eq!(h.samples.geometry.axis(0), [1.0, 0.0, 0.0]);
        let out = NrrdOut {
            dims: Dims::new(4, 4, 4).unwrap(),
            sample_type: volcore::SampleType::I16,
            spacing: [0.5, 0.5, 2.0],
            geometry: h.samples.geometry,
            gzip: true,
            data_file: Some("x.raw.gz".into()),
        };
        let back = parse(&write_header(&out)).unwrap();
        assert_eq!(back.samples.geometry, h.samples.geometry);
        assert_eq!(back.samples.spacing, h.samples.spacing);
        assert_eq!(back.data_file.as_deref(), Some("x.raw.gz"));
        for t in ["int8", "uint32", "double"] {
            let text = format!("NRRD0004\ntype: {t}\nsizes: 2 2 2\nendian: big\nencoding: raw\n");
            assert!(parse(&text).is_ok(), "{t}");
        }
    }

    #[test]
    fn detached_and_spacings() {
        let text = "NRRD0005\ntype: unsigned char\nsizes: 4 4\nspacings: 0.25 nan\nencoding: raw\ndata file: ./vol.raw\nbyte skip: -1\n";
        let h = parse(text).unwrap();
        assert_eq!(h.samples.dims, Dims::new(4, 4, 1).unwrap());
        assert_eq!(h.samples.spacing, Some([0.25, 1.0, 1.0]));
        assert_eq!(h.data_file.as_deref(), Some("./vol.raw"));
        assert_eq!(h.byte_skip, -1);
    }

    #[test]
    fn line_skip_ends_with_the_input() {
        let head = "NRRD0004\ntype: uchar\nsizes: 2 2 1\nencoding: raw\nline skip: 4294967295\n\n";
        let mut r = std::io::Cursor::new(format!("{head}a\nb\n").into_bytes());
        let e = read_stream_header(&mut r).unwrap_err().to_string();
        assert!(e.contains("after 2 of the 4294967295 lines"), "{e}");
        // Lines of any length are skipped without being held.
        let long = "x".repeat(200_000);
        let text = format!("NRRD0004\ntype: uchar\nsizes: 2 2 1\nencoding: raw\nline skip: 2\n\n{long}\n\n\x01\x02\x03\x04");
        let mut r = std::io::Cursor::new(text.into_bytes());
        read_stream_header(&mut r).unwrap();
        let mut rest = Vec::new();
        r.read_to_end(&mut rest).unwrap();
        assert_eq!(rest, [1, 2, 3, 4]);
    }

    #[test]
    fn rejects_clearly() {
        assert!(parse("P5\n").unwrap_err().to_string().contains("NRRD"));
        let e = parse("NRRD0004\ntype: long\nsizes: 2 2 2\nencoding: raw\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("long"), "{e}");
        let e = parse("NRRD0004\ntype: short\nsizes: 2 2 2\nencoding: raw\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("endian"), "{e}");
        let e = parse("NRRD0004\ntype: uchar\nsizes: 2 2 2\nencoding: bzip2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bzip2"), "{e}");
        let e = parse("NRRD0004\ntype: uchar\nsizes: 2 2 2\nencoding: raw\ndata file: LIST\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("lists"), "{e}");
        assert!(parse("NRRD0004\ngarbage line\n").is_err());
    }
}
