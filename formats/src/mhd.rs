//! MetaImage headers (`.mhd` with a separate data file, `.mha` with the
//! data after the header), parsed with `nom`.
//!
//! Supported: `NDims` 2 or 3, one channel, `ElementType` `MET_CHAR`,
//! `MET_UCHAR`, `MET_SHORT`, `MET_USHORT`, `MET_INT`, `MET_UINT`,
//! `MET_FLOAT`, `MET_DOUBLE`; `BinaryDataByteOrderMSB` (or `ByteOrderMSB`);
//! `CompressedData` (zlib); `HeaderSize` (including -1: data at the end of
//! the file); `ElementSpacing` (or `ElementSize`); `Offset` (or `Origin`,
//! `Position`) and `TransformMatrix` (or `Rotation`, `Orientation`) for
//! the origin and axis directions, in LPS as ITK writes them (each triple
//! of the matrix is one axis' direction); `ElementDataFile` as `LOCAL` or
//! one file name. File lists and patterns are reported as unsupported.
//!
//! [`write_header`] writes the header volkit's MetaImage output uses.

use crate::datafile::{detached_file, DataSpec, DataStart, Encoding, HeaderSamples};
use crate::error::{Error, Result};
use crate::slice::SliceType;
use nom::bytes::complete::{tag, take_till1};
use nom::character::complete::space0;
use nom::combinator::rest;
use nom::{IResult, Parser};
use std::io::BufRead;
use std::path::Path;
use volcore::text::excerpt;
use volcore::Geometry;
use volcore::{Dims, SampleType};

/// The MetaImage name of a type volkit writes.
pub fn type_name(t: SampleType) -> &'static str {
    match t {
        SampleType::U8 => "MET_UCHAR",
        SampleType::U16 => "MET_USHORT",
        SampleType::I16 => "MET_SHORT",
        SampleType::F32 => "MET_FLOAT",
        SampleType::F64 => "MET_DOUBLE",
    }
}

/// The header text of a MetaImage file volkit writes: `data_file` is
/// `LOCAL` (`.mha`, samples follow) or the data file's name (`.mhd`).
pub fn write_header(
    dims: Dims,
    t: SampleType,
    spacing: [f32; 3],
    geometry: &Geometry,
    compressed: bool,
    data_file: &str,
) -> String {
    let m: Vec<String> = (0..3)
        .flat_map(|a| geometry.axis(a))
        .map(|v| v.to_string())
        .collect();
    let o = geometry.origin;
    format!(
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = {}\nTransformMatrix = {}\nOffset = {} {} {}\nCenterOfRotation = 0 0 0\nAnatomicalOrientation = {}\nElementSpacing = {} {} {}\nDimSize = {} {} {}\nElementType = {}\nElementDataFile = {data_file}\n",
        if compressed { "True" } else { "False" },
        m.join(" "),
        o[0],
        o[1],
        o[2],
        geometry.orientation().chars().map(|c| match c { 'L' => 'R', 'R' => 'L', 'P' => 'A', 'A' => 'P', 'S' => 'I', _ => 'S' }).collect::<String>(),
        spacing[0],
        spacing[1],
        spacing[2],
        dims.x,
        dims.y,
        dims.z,
        type_name(t),
    )
}

/// The fields of a MetaImage header volkit uses.
#[derive(Clone, Debug, PartialEq)]
pub struct MhdHeader {
    /// Voxels per axis.
    pub samples: HeaderSamples,
    /// zlib-compressed data.
    pub compressed: bool,
    /// `ElementDataFile` (`LOCAL` for data after the header).
    pub data_file: String,
    /// `HeaderSize` (-1: data at the end of the file).
    pub header_size: i64,
}

/// `Key = Value` (spaces around `=` optional).
fn key_value(i: &str) -> IResult<&str, (&str, &str)> {
    (
        space0,
        take_till1(|c: char| c == '=' || c == ' ' || c == '\t'),
        space0,
        tag("="),
        space0,
        rest,
    )
        .map(|(_, k, _, _, _, v): (&str, &str, &str, &str, &str, &str)| (k, v.trim()))
        .parse(i)
}

fn element_type(v: &str) -> Result<SliceType> {
    match v {
        "MET_UCHAR" => Ok(SliceType::U8),
        "MET_CHAR" => Ok(SliceType::I8),
        "MET_USHORT" => Ok(SliceType::U16),
        "MET_SHORT" => Ok(SliceType::I16),
        "MET_UINT" | "MET_ULONG" => Ok(SliceType::U32),
        "MET_INT" | "MET_LONG" => Ok(SliceType::I32),
        "MET_FLOAT" => Ok(SliceType::F32),
        "MET_DOUBLE" => Ok(SliceType::F64),
        other => Err(Error::invalid(format!(
            "MetaImage ElementType {} is not supported (volkit reads 8, 16 and 32-bit integers, MET_FLOAT and MET_DOUBLE)",
            excerpt(other)
        ))),
    }
}

fn is_true(v: &str) -> bool {
    v.eq_ignore_ascii_case("true") || v == "1"
}

/// Parse header lines; stops after `ElementDataFile`, which must be the
/// last field. Returns the header and the byte length of the text parsed.
pub fn parse(text: &str) -> Result<(MhdHeader, u64)> {
    let mut ndims = None;
    let mut size: Option<Vec<u64>> = None;
    let mut ty = None;
    let mut msb = false;
    let mut compressed = false;
    let mut spacing: Option<Vec<f64>> = None;
    let mut element_size: Option<Vec<f64>> = None;
    let mut header_size = 0i64;
    let mut offset: Option<Vec<f64>> = None;
    let mut matrix: Option<Vec<f64>> = None;
    let mut channels = 1u64;
    let mut data_file = None;
    let mut len = 0u64;
    for (n, raw) in text.split_inclusive('\n').enumerate() {
        len += raw.len() as u64;
        let l = raw.trim_end_matches(['\n', '\r']);
        if l.trim().is_empty() || l.trim_start().starts_with('#') {
            continue;
        }
        let (_, (k, v)) = key_value(l).map_err(|_| {
            Error::invalid(format!(
                "header line {} is not 'Key = Value': '{}'",
                n + 1,
                excerpt(l)
            ))
        })?;
        let bad = |what: &str| Error::invalid(format!("bad MetaImage {what}: '{}'", excerpt(v)));
        let floats = |what: &str| -> Result<Vec<f64>> {
            v.split_whitespace()
                .map(|s| s.parse::<f64>().map_err(|_| bad(what)))
                .collect()
        };
        match k {
            "ObjectType" if v != "Image" => {
                return Err(Error::invalid(format!(
                    "MetaImage ObjectType {} is not Image",
                    excerpt(v)
                )))
            }
            "NDims" => ndims = Some(v.parse::<u64>().map_err(|_| bad("NDims"))?),
            "DimSize" => {
                size = Some(
                    v.split_whitespace()
                        .map(|s| s.parse::<u64>().map_err(|_| bad("DimSize")))
                        .collect::<Result<_>>()?,
                )
            }
            "ElementType" => ty = Some(element_type(v)?),
            "BinaryDataByteOrderMSB" | "ByteOrderMSB" | "ElementByteOrderMSB" => msb = is_true(v),
            "BinaryData" if !is_true(v) => {
                return Err(Error::invalid("MetaImage ASCII data is not supported"))
            }
            "CompressedData" => compressed = is_true(v),
            "ElementSpacing" => spacing = Some(floats("ElementSpacing")?),
            "ElementSize" => element_size = Some(floats("ElementSize")?),
            "Offset" | "Origin" | "Position" => offset = Some(floats(k)?),
            "TransformMatrix" | "Rotation" | "Orientation" => matrix = Some(floats(k)?),
            "HeaderSize" => header_size = v.parse().map_err(|_| bad("HeaderSize"))?,
            "ElementNumberOfChannels" => {
                channels = v.parse().map_err(|_| bad("ElementNumberOfChannels"))?
            }
            "ElementDataFile" => {
                if v.starts_with("LIST") || v.split_whitespace().count() > 1 || v.contains('%') {
                    return Err(Error::invalid(
                        "MetaImage data file lists and patterns are not supported (one data file only)",
                    ));
                }
                data_file = Some(v.to_string());
                break;
            }
            _ => {}
        }
    }
    let data_file =
        data_file.ok_or_else(|| Error::invalid("MetaImage header has no ElementDataFile"))?;
    let sample_type = ty.ok_or_else(|| Error::invalid("MetaImage header has no ElementType"))?;
    let size = size.ok_or_else(|| Error::invalid("MetaImage header has no DimSize"))?;
    if let Some(nd) = ndims {
        if nd != size.len() as u64 {
            return Err(Error::invalid(format!(
                "MetaImage NDims {nd} does not match DimSize {size:?}"
            )));
        }
    }
    if channels != 1 {
        return Err(Error::invalid(format!(
            "MetaImage with {channels} channels: only scalar data is supported"
        )));
    }
    let dims = match size[..] {
        [x, y] => Dims::new(x, y, 1)?,
        [x, y, z] => Dims::new(x, y, z)?,
        _ => {
            return Err(Error::invalid(format!(
                "MetaImage with {} dimensions: only 2D and 3D data is supported",
                size.len()
            )))
        }
    };
    let spacing = spacing.or(element_size).map(|s| {
        let v = |i: usize| {
            s.get(i)
                .copied()
                .filter(|v| v.is_finite() && *v > 0.0)
                .unwrap_or(1.0) as f32
        };
        [v(0), v(1), v(2)]
    });
    if header_size < -1 {
        return Err(Error::invalid("MetaImage HeaderSize must be -1 or more"));
    }
    let origin = match offset.as_deref() {
        None => [0.0; 3],
        Some([x, y]) => [*x, *y, 0.0],
        Some([x, y, z]) => [*x, *y, *z],
        Some(_) => {
            return Err(Error::invalid(
                "MetaImage Offset does not have NDims values",
            ))
        }
    };
    let axes = match matrix.as_deref() {
        None => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        Some([a, b, c, d]) => [[*a, *b, 0.0], [*c, *d, 0.0], [0.0, 0.0, 1.0]],
        Some(m) if m.len() == 9 => [[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]],
        Some(_) => {
            return Err(Error::invalid(
                "MetaImage TransformMatrix does not have NDims² values",
            ))
        }
    };
    // MetaImage has no unit field: its readers (ITK) take millimetres, and
    // volkit's writer converts to them.
    let geometry = Geometry::from_axes(origin, axes)
        .map_err(|e| Error::invalid(format!("MetaImage geometry: {e}")))?
        .with_unit(volcore::LengthUnit::Millimeter);
    if header_size == -1 && compressed {
        return Err(Error::invalid(
            "MetaImage HeaderSize -1 works with uncompressed data only",
        ));
    }
    Ok((
        MhdHeader {
            samples: HeaderSamples {
                dims,
                sample_type,
                big_endian: msb,
                spacing,
                geometry,
            },
            compressed,
            data_file,
            header_size,
        },
        len,
    ))
}

/// Read a `.mhd` or `.mha` header and locate its samples.
pub fn open(path: &Path) -> Result<DataSpec> {
    let f = std::fs::File::open(path)?;
    let mut r = std::io::BufReader::new(f);
    // Read lines up to ElementDataFile (binary data may follow in .mha).
    let mut text = String::new();
    // The header's length in the file's bytes: the text's own length
    // counts each byte that is not UTF-8 (a Latin-1 `µ` in a comment) as
    // the three of U+FFFD, which would shift an .mha's data.
    let mut file_len = 0u64;
    loop {
        let mut l = Vec::new();
        let n = r.take_line(&mut l)?;
        if n == 0 {
            break;
        }
        file_len += n as u64;
        let s = String::from_utf8_lossy(&l).into_owned();
        let last = s.trim_start().starts_with("ElementDataFile");
        text.push_str(&s);
        if last || text.len() > 1 << 20 {
            break;
        }
    }
    let (h, text_len) = parse(&text)?;
    // parse() counts through the ElementDataFile line, the last line read.
    let header_len = if text_len == text.len() as u64 {
        file_len
    } else {
        text_len
    };
    let local = h.data_file == "LOCAL";
    let (data_file, base) = if local {
        (path.to_path_buf(), header_len)
    } else {
        (detached_file(path, &h.data_file), 0)
    };
    let start = if h.header_size == -1 {
        DataStart::AtEnd
    } else {
        DataStart::At(base + h.header_size as u64)
    };
    Ok(DataSpec::unscaled(
        h.samples,
        data_file,
        start,
        if h.compressed {
            Encoding::Zlib
        } else {
            Encoding::Raw
        },
        format!(
            "metaimage ({}{})",
            if local { "mha" } else { "mhd" },
            if h.compressed { ", zlib" } else { "" }
        ),
    ))
}

trait TakeLine {
    fn take_line(&mut self, out: &mut Vec<u8>) -> std::io::Result<usize>;
}

impl<R: BufRead> TakeLine for R {
    fn take_line(&mut self, out: &mut Vec<u8>) -> std::io::Result<usize> {
        use std::io::Read;
        self.take(64 * 1024).read_until(b'\n', out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_mhd_and_mha() {
        let text = "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = False\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nElementSpacing = 0.5 0.5 1.25\nDimSize = 10 20 30\nElementType = MET_SHORT\nElementDataFile = scan.raw\n";
        let (h, len) = parse(text).unwrap();
        assert_eq!(len, text.len() as u64);
        assert_eq!(h.samples.dims, Dims::new(10, 20, 30).unwrap());
        assert_eq!(h.samples.sample_type, SliceType::I16);
        assert_eq!(h.samples.spacing, Some([0.5, 0.5, 1.25]));
        assert!(h.samples.geometry.is_identity());
        assert_eq!(h.data_file, "scan.raw");
        let mha = "NDims=2\nDimSize=4 4\nElementType=MET_UCHAR\nCompressedData=True\nElementDataFile=LOCAL\n\x00\x01binary";
        let (h, len) = parse(mha).unwrap();
        assert!(h.compressed);
        assert_eq!(h.samples.dims.z, 1);
        assert_eq!(len, mha.find('\x00').unwrap() as u64);
    }

    #[test]
    fn mha_data_starts_after_the_header_bytes_even_when_not_utf8() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("latin1.mha");
        let mut bytes = b"ObjectType = Image\n# acquired at 20 \xb5m (Latin-1)\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n".to_vec();
        let header = bytes.len() as u64;
        bytes.extend(0u8..8);
        std::fs::write(&p, &bytes).unwrap();
        let spec = open(&p).unwrap();
        assert_eq!(spec.start, DataStart::At(header));
    }

    #[test]
    fn geometry_round_trips() {
        let g = Geometry::from_axes(
            [1.5, -2.0, 30.0],
            [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        let text = write_header(
            Dims::new(3, 4, 5).unwrap(),
            SampleType::I16,
            [0.5, 0.75, 2.0],
            &g,
            true,
            "x.zraw",
        );
        let (h, _) = parse(&text).unwrap();
        // MetaImage has no unit field: its lengths are millimetres.
        let mm = Geometry {
            unit: volcore::LengthUnit::Millimeter,
            ..g
        };
        assert_eq!(h.samples.geometry, mm);
        assert_eq!(h.samples.spacing, Some([0.5, 0.75, 2.0]));
        assert!(h.compressed);
        let (h, _) = parse(
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_DOUBLE\nElementDataFile = a.raw\n",
        )
        .unwrap();
        assert_eq!(h.samples.sample_type, SliceType::F64);
    }

    #[test]
    fn rejects_clearly() {
        let e = parse(
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_LONG_LONG\nElementDataFile = a.raw\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("MET_LONG_LONG"), "{e}");
        let e = parse("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("ElementDataFile"), "{e}");
        let e =
            parse("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LIST\n")
                .unwrap_err()
                .to_string();
        assert!(e.contains("lists"), "{e}");
        assert!(parse("what is this\n").is_err());
    }
}
