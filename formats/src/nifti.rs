//! NIfTI-1 and NIfTI-2 (`.nii`, `.nii.gz`, `.hdr`/`.img`, `.img.gz`).
//!
//! The two headers are fixed binary records (348 and 540 bytes) that
//! volkit decodes and encodes here with `byteorder`; gzip goes through
//! `flate2`. (The `nifti` crate reads NIfTI-1 only, loads whole volumes
//! into `ndarray`s and needs `nalgebra` for the affine: this keeps the
//! converter streaming with bounded memory and covers NIfTI-2.)
//!
//! Reading: either byte order; types `uint8`, `int8`, `int16`, `uint16`,
//! `int32`, `uint32`, `float32`, `float64`; 2D or 3D, or one volume of a
//! 4D series picked with `--time-point T`. `scl_slope`/`scl_inter` are applied
//! (a slope of 0 or NaN means none), so integer data with an integer
//! rescale stays integer and the rest becomes float. Geometry: the sform
//! when its code is set, else the qform, else the voxel sizes alone; the
//! RAS affine is turned into volkit's LPS frame.
//!
//! Writing: NIfTI-1 (NIfTI-2 when a dimension passes 32767), one volume,
//! with the same affine as sform and qform, no rescale. The codes are a
//! NIfTI input's (see [`NiftiHeader::codes`]), else 1 (scanner
//! anatomical) for both. The unit of length is read from and written to
//! `xyzt_units` (m, mm, µm; none stated is code 0).

use crate::datafile::{DataSpec, DataStart, Encoding};
use crate::error::{Error, Result};
use crate::reader::NiftiCodes;
use crate::rescale::Rescale;
use crate::slice::SliceType;
use byteorder::{BigEndian, ByteOrder, LittleEndian};
use std::io::Read;
use std::path::{Path, PathBuf};
use volcore::{Dims, Geometry, LengthUnit, SampleType};

/// Size of a NIfTI-1 header.
pub const NIFTI1_LEN: usize = 348;

const NIFTI_UNITS_METER: i32 = 1;
const NIFTI_UNITS_MM: i32 = 2;
const NIFTI_UNITS_MICRON: i32 = 3;

/// The units of length NIfTI has codes for. A reader takes any other
/// code (nm included) as "unknown", which most read as millimetres: the
/// converter turns other units into the nearest of these first.
pub const UNITS: [LengthUnit; 3] = [
    LengthUnit::Meter,
    LengthUnit::Millimeter,
    LengthUnit::Micrometer,
];

/// The `xyzt_units` code of `unit` (0, "unknown", for a unit without one,
/// which [`UNITS`] keeps from reaching here).
fn unit_code(unit: LengthUnit) -> i32 {
    match unit {
        LengthUnit::Meter => NIFTI_UNITS_METER,
        LengthUnit::Millimeter => NIFTI_UNITS_MM,
        LengthUnit::Micrometer => NIFTI_UNITS_MICRON,
        _ => 0,
    }
}
/// Size of a NIfTI-2 header.
pub const NIFTI2_LEN: usize = 540;

/// The header fields volkit uses, from either version.
#[derive(Clone, Debug, PartialEq)]
pub struct NiftiHeader {
    /// 1 or 2.
    pub version: u8,
    /// Byte order of header and data.
    pub big_endian: bool,
    /// `dim[0..8]`.
    pub dim: [i64; 8],
    /// `pixdim[0..8]` (`pixdim[0]` is the qform's qfac).
    pub pixdim: [f64; 8],
    /// NIfTI datatype code.
    pub datatype: i16,
    /// Bytes before the data in its file.
    pub vox_offset: f64,
    /// Rescale slope and intercept.
    pub scl_slope: f64,
    /// See `scl_slope`.
    pub scl_inter: f64,
    /// qform code (0: none).
    pub qform_code: i32,
    /// sform code (0: none).
    pub sform_code: i32,
    /// Quaternion b, c, d and offsets x, y, z.
    pub quatern: [f64; 6],
    /// Rows of the sform affine.
    pub srow: [[f64; 4]; 3],
    /// `xyzt_units`: the unit of length in bits 0-2 (1 m, 2 mm, 3 µm; 0
    /// not stated), of time in bits 3-5.
    pub xyzt_units: i32,
    /// `ni1`/`ni2` (header and data in separate files) rather than `n+1`/`n+2`.
    pub pair: bool,
}

/// The sample type of a datatype code.
fn slice_type(code: i16) -> Result<SliceType> {
    Ok(match code {
        2 => SliceType::U8,
        256 => SliceType::I8,
        4 => SliceType::I16,
        512 => SliceType::U16,
        8 => SliceType::I32,
        768 => SliceType::U32,
        16 => SliceType::F32,
        64 => SliceType::F64,
        other => {
            let name = match other {
                32 => "complex64",
                128 => "RGB24",
                1024 => "int64",
                1280 => "uint64",
                1536 => "float128",
                1792 => "complex128",
                2304 => "RGBA32",
                _ => "unknown",
            };
            return Err(Error::invalid(format!(
                "NIfTI datatype {other} ({name}) is not supported (volkit reads 8, 16 and 32-bit integers, float32 and float64)"
            )));
        }
    })
}

fn datatype_code(t: SampleType) -> (i16, i16) {
    match t {
        SampleType::U8 => (2, 8),
        SampleType::I16 => (4, 16),
        SampleType::U16 => (512, 16),
        SampleType::F32 => (16, 32),
        SampleType::F64 => (64, 64),
    }
}

impl NiftiHeader {
    /// Decode a header from its first bytes (at least 348, or 540 for
    /// NIfTI-2).
    pub fn decode(b: &[u8]) -> Result<NiftiHeader> {
        if b.len() < 4 {
            return Err(Error::invalid("file is truncated (no NIfTI header)"));
        }
        let (version, big) = match (LittleEndian::read_i32(b), BigEndian::read_i32(b)) {
            (348, _) => (1, false),
            (_, 348) => (1, true),
            (540, _) => (2, false),
            (_, 540) => (2, true),
            _ => {
                return Err(Error::invalid(
                    "not a NIfTI file (the header size is neither 348 nor 540)",
                ))
            }
        };
        let need = if version == 1 { NIFTI1_LEN } else { NIFTI2_LEN };
        if b.len() < need {
            return Err(Error::invalid(format!(
                "file is truncated (shorter than the {need}-byte NIfTI-{version} header)"
            )));
        }
        if big {
            Self::decode_as::<BigEndian>(b, version)
        } else {
            Self::decode_as::<LittleEndian>(b, version)
        }
    }

    fn decode_as<E: ByteOrder>(b: &[u8], version: u8) -> Result<NiftiHeader> {
        let big = E::read_u16(&[0, 1]) == 1;
        let h = if version == 1 {
            let magic = &b[344..348];
            let pair = match magic {
                b"n+1\0" => false,
                b"ni1\0" => true,
                _ => return Err(Error::invalid("not a NIfTI-1 file (bad magic)")),
            };
            let f = |o: usize| E::read_f32(&b[o..]) as f64;
            NiftiHeader {
                version,
                big_endian: big,
                dim: std::array::from_fn(|i| E::read_i16(&b[40 + 2 * i..]) as i64),
                pixdim: std::array::from_fn(|i| f(76 + 4 * i)),
                datatype: E::read_i16(&b[70..]),
                vox_offset: f(108),
                scl_slope: f(112),
                scl_inter: f(116),
                qform_code: E::read_i16(&b[252..]) as i32,
                sform_code: E::read_i16(&b[254..]) as i32,
                quatern: std::array::from_fn(|i| f(256 + 4 * i)),
                srow: std::array::from_fn(|r| std::array::from_fn(|c| f(280 + 16 * r + 4 * c))),
                xyzt_units: b[123] as i32,
                pair,
            }
        } else {
            let pair = match &b[4..8] {
                b"n+2\0" => false,
                b"ni2\0" => true,
                _ => return Err(Error::invalid("not a NIfTI-2 file (bad magic)")),
            };
            let f = |o: usize| E::read_f64(&b[o..]);
            NiftiHeader {
                version,
                big_endian: big,
                dim: std::array::from_fn(|i| E::read_i64(&b[16 + 8 * i..])),
                pixdim: std::array::from_fn(|i| f(104 + 8 * i)),
                datatype: E::read_i16(&b[12..]),
                vox_offset: E::read_i64(&b[168..]) as f64,
                scl_slope: f(176),
                scl_inter: f(184),
                qform_code: E::read_i32(&b[344..]),
                sform_code: E::read_i32(&b[348..]),
                quatern: std::array::from_fn(|i| f(352 + 8 * i)),
                srow: std::array::from_fn(|r| std::array::from_fn(|c| f(400 + 32 * r + 8 * c))),
                xyzt_units: E::read_i32(&b[500..]),
                pair,
            }
        };
        Ok(h)
    }

    /// The three spatial dimensions and the number of volumes (the 4th
    /// dimension); errors on other shapes.
    pub fn shape(&self) -> Result<(Dims, u64)> {
        let n = self.dim[0];
        if !(1..=7).contains(&n) {
            return Err(Error::invalid(format!(
                "NIfTI dim[0] = {n} is not a number of dimensions (1 to 7)"
            )));
        }
        let d = |i: usize| -> Result<u64> {
            if i as i64 > n {
                return Ok(1);
            }
            u64::try_from(self.dim[i])
                .ok()
                .filter(|&v| v >= 1)
                .ok_or_else(|| {
                    Error::invalid(format!("NIfTI dim[{i}] = {} is not positive", self.dim[i]))
                })
        };
        for i in 5..=7 {
            if d(i)? > 1 {
                return Err(Error::invalid(format!(
                    "NIfTI with {n} dimensions (dim {:?}): volkit reads 3D volumes and 4D series",
                    &self.dim[1..=n as usize]
                )));
            }
        }
        Ok((Dims::new(d(1)?, d(2)?, d(3)?)?, d(4)?))
    }

    /// Voxel spacing (the absolute `pixdim[1..4]`; 1 where not positive).
    pub fn spacing(&self) -> [f32; 3] {
        std::array::from_fn(|i| {
            let v = self.pixdim[i + 1].abs();
            if v.is_finite() && v > 0.0 {
                v as f32
            } else {
                1.0
            }
        })
    }

    /// The unit of length `xyzt_units` states (an unknown code, like 0,
    /// states none).
    pub fn unit(&self) -> LengthUnit {
        match self.xyzt_units & 0x07 {
            NIFTI_UNITS_METER => LengthUnit::Meter,
            NIFTI_UNITS_MM => LengthUnit::Millimeter,
            NIFTI_UNITS_MICRON => LengthUnit::Micrometer,
            _ => LengthUnit::Unknown,
        }
    }

    /// Spacing and LPS geometry (with the unit): from the sform when
    /// set, else the qform, else the voxel sizes alone.
    pub fn geometry(&self) -> Result<([f32; 3], Geometry)> {
        let (spacing, g) = self.geometry_numbers()?;
        Ok((spacing, g.with_unit(self.unit())))
    }

    fn geometry_numbers(&self) -> Result<([f32; 3], Geometry)> {
        let spacing = self.spacing();
        let ras = if self.sform_code > 0 {
            let s = &self.srow;
            let axes = [0, 1, 2].map(|c| [s[0][c], s[1][c], s[2][c]]);
            let sp = axes.map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() as f32);
            let g = Geometry::from_axes([s[0][3], s[1][3], s[2][3]], axes)
                .map_err(|e| Error::invalid(format!("NIfTI sform: {e}")))?;
            return Ok((sp.map(|v| if v > 0.0 { v } else { 1.0 }), g.flip_xy()));
        } else if self.qform_code > 0 {
            let [b, c, d, x, y, z] = self.quatern;
            let r = quaternion_matrix(b, c, d);
            let qfac = if self.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
            let axes = [0, 1, 2].map(|k| {
                let s = if k == 2 { qfac } else { 1.0 };
                [r[0][k] * s, r[1][k] * s, r[2][k] * s]
            });
            Geometry::from_axes([x, y, z], axes)
                .map_err(|e| Error::invalid(format!("NIfTI qform: {e}")))?
        } else {
            Geometry::IDENTITY
        };
        Ok((spacing, ras.flip_xy()))
    }

    /// The qform and sform codes a NIfTI output of this input keeps, or
    /// `None` when neither is set. Both transforms of an output hold the
    /// geometry volkit read (the sform's when its code is set): a qform
    /// that disagrees with that sform takes the sform's code, since it will
    /// hold the sform's affine. Codes past 5 (no space NIfTI defines)
    /// become 1.
    pub fn codes(&self) -> Option<NiftiCodes> {
        let clean = |c: i32| match c {
            ..=0 => 0,
            1..=5 => c as i16,
            _ => 1,
        };
        let (mut qform, sform) = (clean(self.qform_code), clean(self.sform_code));
        if qform == 0 && sform == 0 {
            return None;
        }
        if qform > 0 && sform > 0 {
            let mut q = self.clone();
            q.sform_code = 0;
            let same = match (self.geometry(), q.geometry()) {
                (Ok((ss, sg)), Ok((qs, qg))) => {
                    let near =
                        |a: f64, b: f64| (a - b).abs() <= 1e-4 * a.abs().max(b.abs()).max(1.0);
                    ss.iter().zip(&qs).all(|(a, b)| near(*a as f64, *b as f64))
                        && sg.origin.iter().zip(&qg.origin).all(|(a, b)| near(*a, *b))
                        && (0..3).all(|a| {
                            let (u, v) = (sg.axis(a), qg.axis(a));
                            (0..3).all(|i| (u[i] - v[i]).abs() <= 1e-4)
                        })
                }
                _ => false,
            };
            if !same {
                qform = sform;
            }
        }
        Some(NiftiCodes { qform, sform })
    }

    /// The rescale the header asks for, if any.
    pub fn rescale(&self) -> Option<Rescale> {
        let s = self.scl_slope;
        if s == 0.0 || !s.is_finite() {
            return None;
        }
        let i = if self.scl_inter.is_finite() {
            self.scl_inter
        } else {
            0.0
        };
        let m = Rescale {
            slope: s,
            intercept: i,
        };
        (!m.is_identity()).then_some(m)
    }
}

/// The rotation of a NIfTI quaternion (b, c, d; a is implied).
fn quaternion_matrix(b: f64, c: f64, d: f64) -> [[f64; 3]; 3] {
    let a2 = 1.0 - (b * b + c * c + d * d);
    let (a, b, c, d) = if a2 < 1e-7 {
        // Not a unit quaternion: a = 0 and (b, c, d) renormalised.
        let n = (b * b + c * c + d * d).sqrt().max(1e-12);
        (0.0, b / n, c / n, d / n)
    } else {
        (a2.sqrt(), b, c, d)
    };
    [
        [
            a * a + b * b - c * c - d * d,
            2.0 * (b * c - a * d),
            2.0 * (b * d + a * c),
        ],
        [
            2.0 * (b * c + a * d),
            a * a + c * c - b * b - d * d,
            2.0 * (c * d - a * b),
        ],
        [
            2.0 * (b * d - a * c),
            2.0 * (c * d + a * b),
            a * a + d * d - c * c - b * b,
        ],
    ]
}

/// The quaternion (b, c, d) and qfac of a rotation or reflection matrix.
fn matrix_quaternion(m: [[f64; 3]; 3]) -> ([f64; 3], f64) {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let mut r = m;
    let qfac = if det < 0.0 {
        for row in r.iter_mut() {
            row[2] = -row[2];
        }
        -1.0
    } else {
        1.0
    };
    let t = r[0][0] + r[1][1] + r[2][2] + 1.0;
    let (a, b, c, d) = if t > 0.5 {
        let a = 0.5 * t.sqrt();
        (
            a,
            0.25 * (r[2][1] - r[1][2]) / a,
            0.25 * (r[0][2] - r[2][0]) / a,
            0.25 * (r[1][0] - r[0][1]) / a,
        )
    } else {
        let xd = 1.0 + r[0][0] - (r[1][1] + r[2][2]);
        let yd = 1.0 + r[1][1] - (r[0][0] + r[2][2]);
        let zd = 1.0 + r[2][2] - (r[0][0] + r[1][1]);
        if xd > 1.0 {
            let b = 0.5 * xd.sqrt();
            (
                0.25 * (r[2][1] - r[1][2]) / b,
                b,
                0.25 * (r[0][1] + r[1][0]) / b,
                0.25 * (r[0][2] + r[2][0]) / b,
            )
        } else if yd > 1.0 {
            let c = 0.5 * yd.sqrt();
            (
                0.25 * (r[0][2] - r[2][0]) / c,
                0.25 * (r[0][1] + r[1][0]) / c,
                c,
                0.25 * (r[1][2] + r[2][1]) / c,
            )
        } else {
            let d = 0.5 * zd.sqrt();
            (
                0.25 * (r[1][0] - r[0][1]) / d,
                0.25 * (r[0][2] + r[2][0]) / d,
                0.25 * (r[1][2] + r[2][1]) / d,
                d,
            )
        }
    };
    // a must not be negative.
    let s = if a < 0.0 { -1.0 } else { 1.0 };
    ([b * s, c * s, d * s], qfac)
}

/// Whether `path` names a NIfTI file by its extension (`.nii`, `.nii.gz`,
/// `.hdr`, `.img`, `.img.gz`).
pub fn is_nifti_name(path: &Path) -> bool {
    let n = path.to_string_lossy().to_ascii_lowercase();
    [".nii", ".nii.gz", ".hdr", ".img", ".img.gz"]
        .iter()
        .any(|e| n.ends_with(e))
}

fn gz(path: &Path) -> bool {
    path.to_string_lossy().to_ascii_lowercase().ends_with(".gz")
}

/// The header file and data file of a NIfTI input named by any of its
/// files.
fn pair_paths(path: &Path) -> (PathBuf, PathBuf) {
    let s = path.to_string_lossy();
    let l = s.to_ascii_lowercase();
    let swap = |from: &str, to: &str| PathBuf::from(format!("{}{to}", &s[..s.len() - from.len()]));
    if l.ends_with(".hdr") {
        let img = swap(".hdr", ".img");
        let img = if img.exists() {
            img
        } else {
            swap(".hdr", ".img.gz")
        };
        (path.to_path_buf(), img)
    } else if l.ends_with(".img.gz") {
        (swap(".img.gz", ".hdr"), path.to_path_buf())
    } else if l.ends_with(".img") {
        (swap(".img", ".hdr"), path.to_path_buf())
    } else {
        (path.to_path_buf(), path.to_path_buf())
    }
}

/// Read the first bytes of a header file (decompressed when `.gz`).
fn read_head(path: &Path) -> Result<Vec<u8>> {
    let f = std::fs::File::open(path)?;
    let mut r: Box<dyn Read> = if gz(path) {
        Box::new(flate2::read::MultiGzDecoder::new(std::io::BufReader::new(
            f,
        )))
    } else {
        Box::new(f)
    };
    let mut b = Vec::with_capacity(NIFTI2_LEN);
    r.by_ref()
        .take(NIFTI2_LEN as u64)
        .read_to_end(&mut b)
        .map_err(|e| Error::invalid(format!("not a readable NIfTI file: {e}")))?;
    Ok(b)
}

/// The header of the NIfTI input `path` names (either file of a pair).
pub fn read_header(path: &Path) -> Result<NiftiHeader> {
    let (hdr, _) = pair_paths(path);
    NiftiHeader::decode(&read_head(&hdr)?)
}

/// Read a NIfTI header and locate its samples (volume `time` of a 4D
/// series; required when there are several).
pub fn open(path: &Path, time: Option<u64>) -> Result<DataSpec> {
    let (hdr, img) = pair_paths(path);
    let head = read_head(&hdr)?;
    let h = NiftiHeader::decode(&head)?;
    let t = slice_type(h.datatype)?;
    let (dims, volumes) = h.shape()?;
    let pick = match (time, volumes) {
        (Some(t), n) if t < n => t,
        (Some(t), n) => {
            return Err(Error::invalid(format!(
                "--time-point {t} asked for, but the series has volumes 0..{}",
                n - 1
            )))
        }
        (None, 1) => 0,
        (None, n) => {
            return Err(Error::invalid(format!(
                "4D NIfTI with {n} volumes of {dims}: pick one with --time-point T (0..{})",
                n - 1
            )))
        }
    };
    let (spacing, geometry) = h.geometry()?;
    let volume_bytes = dims.checked_bytes(t.size() as u64)?;
    let skip = pick
        .checked_mul(volume_bytes)
        .ok_or_else(|| Error::invalid("NIfTI volume offset overflows"))?;
    let base = if h.pair && hdr != img {
        0
    } else {
        let v = h.vox_offset;
        if !(0.0..1e15).contains(&v) {
            return Err(Error::invalid(format!(
                "NIfTI vox_offset {v} is not an offset"
            )));
        }
        let min = if h.version == 1 {
            NIFTI1_LEN
        } else {
            NIFTI2_LEN
        } as f64;
        if v < min && hdr == img {
            return Err(Error::invalid(format!(
                "NIfTI vox_offset {v} lies inside the {min}-byte header"
            )));
        }
        v as u64
    };
    let compressed = gz(&img);
    let first = base.checked_add(skip).ok_or_else(|| {
        Error::invalid(format!(
            "the time point asked for starts past any file (offset {base} + {skip} bytes)"
        ))
    })?;
    let (start, skip_after_decode) = if compressed {
        (DataStart::At(0), first)
    } else {
        (DataStart::At(first), 0)
    };
    Ok(DataSpec {
        nifti_codes: h.codes(),
        dims,
        sample_type: t,
        big_endian: h.big_endian,
        spacing: Some(spacing),
        geometry,
        rescale: h.rescale(),
        data_file: img,
        start,
        encoding: if compressed {
            Encoding::Gzip
        } else {
            Encoding::Raw
        },
        skip_after_decode,
        format: format!(
            "nifti-{} ({}{})",
            h.version,
            if hdr != path || h.pair {
                "hdr/img"
            } else {
                "nii"
            },
            if compressed { ", gzip" } else { "" }
        ),
    })
}

/// How a written file stores header and data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NiftiLayout {
    /// `.nii`: header, 4 bytes of extension flag, data at 352 (544).
    Single,
    /// `.hdr` + `.img`: data at 0 of its own file.
    Pair,
}

/// NIFTI_UNITS_SEC: time in seconds, in bits 3-5 of `xyzt_units`.
const NIFTI_UNITS_SEC: u8 = 8;

/// `header` (a little-endian NIfTI-1 or NIfTI-2 header as
/// [`encode_header`] writes it, up to its data) made 4D: `count` volumes
/// along `dim[4]`, `step_s` seconds apart in `pixdim[4]` (with seconds as
/// the time unit; none stated without a step). The spatial fields are
/// kept; the data that follows is the volumes one after another.
pub fn with_time_axis(header: &[u8], count: u64, step_s: Option<f64>) -> Result<Vec<u8>> {
    let h = NiftiHeader::decode(header)?;
    if h.big_endian || h.dim[0] != 3 {
        return Err(Error::invalid(
            "a time axis is added to volkit's own little-endian 3D NIfTI headers only",
        ));
    }
    let mut b = header.to_vec();
    let step = step_s.filter(|s| s.is_finite() && *s > 0.0).unwrap_or(0.0);
    let units = if h.version == 1 {
        if count > i16::MAX as u64 {
            return Err(Error::invalid(format!(
                "{count} volumes do not fit NIfTI-1's 16-bit dim[4] (at most {})",
                i16::MAX
            )));
        }
        LittleEndian::write_i16(&mut b[40..], 4);
        LittleEndian::write_i16(&mut b[48..], count as i16);
        LittleEndian::write_f32(&mut b[92..], step as f32);
        123
    } else {
        LittleEndian::write_i64(&mut b[16..], 4);
        LittleEndian::write_i64(&mut b[48..], count as i64);
        LittleEndian::write_f64(&mut b[136..], step);
        500
    };
    let time = if step > 0.0 { NIFTI_UNITS_SEC } else { 0 };
    b[units] = (b[units] & 0x07) | time;
    Ok(b)
}

/// Encode the header volkit writes for a volume: NIfTI-1, or NIfTI-2 when
/// a dimension does not fit 16 bits. Returns the header bytes (with the
/// 4-byte extension flag for [`NiftiLayout::Single`]) — the data follows.
pub fn encode_header(
    dims: Dims,
    t: SampleType,
    spacing: [f32; 3],
    geometry: &Geometry,
    codes: NiftiCodes,
    layout: NiftiLayout,
) -> Vec<u8> {
    let (code, bitpix) = datatype_code(t);
    let ras = geometry.flip_xy();
    let d = dims.as_array();
    let v2 = d.iter().any(|&v| v > i16::MAX as u64);
    let axes = [0, 1, 2].map(|a| ras.axis(a));
    let srow: [[f64; 4]; 3] = std::array::from_fn(|r| {
        [
            axes[0][r] * spacing[0] as f64,
            axes[1][r] * spacing[1] as f64,
            axes[2][r] * spacing[2] as f64,
            ras.origin[r],
        ]
    });
    let rot = [0, 1, 2].map(|r| [axes[0][r], axes[1][r], axes[2][r]]);
    let (q, qfac) = matrix_quaternion(rot);
    let dim = [3, d[0] as i64, d[1] as i64, d[2] as i64, 1, 1, 1, 1];
    let pixdim = [
        qfac,
        spacing[0] as f64,
        spacing[1] as f64,
        spacing[2] as f64,
        0.0,
        0.0,
        0.0,
        0.0,
    ];
    let single = layout == NiftiLayout::Single;
    if !v2 {
        let mut b = vec![0u8; NIFTI1_LEN + if single { 4 } else { 0 }];
        LittleEndian::write_i32(&mut b[0..], 348);
        b[38] = b'r';
        for (i, v) in dim.iter().enumerate() {
            LittleEndian::write_i16(&mut b[40 + 2 * i..], *v as i16);
        }
        LittleEndian::write_i16(&mut b[70..], code);
        LittleEndian::write_i16(&mut b[72..], bitpix);
        for (i, v) in pixdim.iter().enumerate() {
            LittleEndian::write_f32(&mut b[76 + 4 * i..], *v as f32);
        }
        LittleEndian::write_f32(&mut b[108..], if single { 352.0 } else { 0.0 });
        LittleEndian::write_f32(&mut b[112..], 1.0);
        b[123] = unit_code(geometry.unit) as u8;
        let descrip = b"volkit";
        b[148..148 + descrip.len()].copy_from_slice(descrip);
        LittleEndian::write_i16(&mut b[252..], codes.qform);
        LittleEndian::write_i16(&mut b[254..], codes.sform);
        let quatern = [
            q[0],
            q[1],
            q[2],
            ras.origin[0],
            ras.origin[1],
            ras.origin[2],
        ];
        for (i, v) in quatern.iter().enumerate() {
            LittleEndian::write_f32(&mut b[256 + 4 * i..], *v as f32);
        }
        for (r, row) in srow.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                LittleEndian::write_f32(&mut b[280 + 16 * r + 4 * c..], *v as f32);
            }
        }
        b[344..348].copy_from_slice(if single { b"n+1\0" } else { b"ni1\0" });
        b
    } else {
        let mut b = vec![0u8; NIFTI2_LEN + if single { 4 } else { 0 }];
        LittleEndian::write_i32(&mut b[0..], 540);
        b[4..12].copy_from_slice(if single {
            b"n+2\0\r\n\x1a\n"
        } else {
            b"ni2\0\r\n\x1a\n"
        });
        LittleEndian::write_i16(&mut b[12..], code);
        LittleEndian::write_i16(&mut b[14..], bitpix);
        for (i, v) in dim.iter().enumerate() {
            LittleEndian::write_i64(&mut b[16 + 8 * i..], *v);
        }
        for (i, v) in pixdim.iter().enumerate() {
            LittleEndian::write_f64(&mut b[104 + 8 * i..], *v);
        }
        LittleEndian::write_i64(&mut b[168..], if single { 544 } else { 0 });
        LittleEndian::write_f64(&mut b[176..], 1.0);
        let descrip = b"volkit";
        b[240..240 + descrip.len()].copy_from_slice(descrip);
        LittleEndian::write_i32(&mut b[344..], i32::from(codes.qform));
        LittleEndian::write_i32(&mut b[348..], i32::from(codes.sform));
        let quatern = [
            q[0],
            q[1],
            q[2],
            ras.origin[0],
            ras.origin[1],
            ras.origin[2],
        ];
        for (i, v) in quatern.iter().enumerate() {
            LittleEndian::write_f64(&mut b[352 + 8 * i..], *v);
        }
        for (r, row) in srow.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                LittleEndian::write_f64(&mut b[400 + 32 * r + 8 * c..], *v);
            }
        }
        LittleEndian::write_i32(&mut b[500..], unit_code(geometry.unit));
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_gains_a_time_axis_and_keeps_its_space_unit() {
        let g = Geometry::default().with_unit(LengthUnit::Millimeter);
        for dims in [Dims::new(4, 3, 2).unwrap(), Dims::new(40000, 2, 2).unwrap()] {
            let b = encode_header(
                dims,
                SampleType::U16,
                [1.0, 1.0, 2.0],
                &g,
                NiftiCodes::SCANNER,
                NiftiLayout::Single,
            );
            let four = NiftiHeader::decode(&with_time_axis(&b, 120, Some(2.0)).unwrap()).unwrap();
            assert_eq!((four.dim[0], four.dim[4]), (4, 120));
            assert_eq!(four.pixdim[4], 2.0);
            assert_eq!(four.xyzt_units, NIFTI_UNITS_MM | i32::from(NIFTI_UNITS_SEC));
            assert_eq!(four.shape().unwrap(), (dims, 120));
            assert_eq!(four.vox_offset, NiftiHeader::decode(&b).unwrap().vox_offset);
            let none = NiftiHeader::decode(&with_time_axis(&b, 3, None).unwrap()).unwrap();
            assert_eq!((none.pixdim[4], none.xyzt_units), (0.0, NIFTI_UNITS_MM));
        }
        let small = encode_header(
            Dims::new(4, 3, 2).unwrap(),
            SampleType::U16,
            [1.0; 3],
            &g,
            NiftiCodes::SCANNER,
            NiftiLayout::Single,
        );
        assert!(with_time_axis(&small, 40_000, None).is_err());
        assert!(with_time_axis(&small[..100], 2, None).is_err());
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    #[test]
    fn headers_round_trip_with_geometry() {
        let g = Geometry::from_axes(
            [90.0, 126.0, -72.0],
            [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        for (dims, version) in [
            (Dims::new(181, 217, 181).unwrap(), 1),
            (Dims::new(40000, 2, 2).unwrap(), 2),
        ] {
            let b = encode_header(
                dims,
                SampleType::I16,
                [1.0, 1.0, 2.5],
                &g,
                NiftiCodes::SCANNER,
                NiftiLayout::Single,
            );
            let h = NiftiHeader::decode(&b).unwrap();
            assert_eq!(h.version, version);
            assert_eq!(h.shape().unwrap(), (dims, 1));
            assert_eq!(slice_type(h.datatype).unwrap(), SliceType::I16);
            let (sp, back) = h.geometry().unwrap();
            assert_eq!(sp, [1.0, 1.0, 2.5]);
            assert!(close(back.origin, g.origin));
            for a in 0..3 {
                assert!(close(back.axis(a), g.axis(a)), "{back:?}");
            }
            // The qform alone gives the same geometry.
            let mut q = h.clone();
            q.sform_code = 0;
            let (_, back) = q.geometry().unwrap();
            for a in 0..3 {
                assert!(close(back.axis(a), g.axis(a)), "{back:?}");
            }
            assert!(close(back.origin, g.origin));
        }
    }

    #[test]
    fn codes_are_kept_and_a_disagreeing_qform_takes_the_sforms() {
        let g = Geometry::from_axes(
            [10.0, -20.0, 30.0],
            [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        for dims in [Dims::new(8, 7, 6).unwrap(), Dims::new(40000, 2, 2).unwrap()] {
            let aligned = NiftiCodes { qform: 1, sform: 2 };
            let b = encode_header(
                dims,
                SampleType::U8,
                [0.5, 0.75, 1.5],
                &g,
                aligned,
                NiftiLayout::Single,
            );
            let h = NiftiHeader::decode(&b).unwrap();
            assert_eq!((h.qform_code, h.sform_code), (1, 2));
            assert_eq!(h.codes(), Some(aligned));
            // An sform moved away from the qform: the qform written from it
            // is in the sform's space.
            let mut moved = h.clone();
            moved.srow[0][3] += 5.0;
            assert_eq!(moved.codes(), Some(NiftiCodes { qform: 2, sform: 2 }));
            let mut none = h.clone();
            (none.qform_code, none.sform_code) = (0, 0);
            assert_eq!(none.codes(), None);
            let mut odd = h;
            (odd.qform_code, odd.sform_code) = (0, 9);
            assert_eq!(odd.codes(), Some(NiftiCodes { qform: 0, sform: 1 }));
        }
    }

    #[test]
    fn quaternions_of_rotations_and_reflections() {
        let cases = [
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
            [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        ];
        for m in cases {
            let (q, qfac) = matrix_quaternion(m);
            let r = quaternion_matrix(q[0], q[1], q[2]);
            for (row, want) in r.iter().zip(&m) {
                let got = [row[0], row[1], row[2] * qfac];
                assert!(close(got, *want), "{m:?} -> {r:?} qfac {qfac}");
            }
        }
    }

    #[test]
    fn rejects_clearly() {
        assert!(NiftiHeader::decode(&[0u8; 10])
            .unwrap_err()
            .to_string()
            .contains("not a NIfTI"));
        let mut b = encode_header(
            Dims::new(2, 2, 2).unwrap(),
            SampleType::U8,
            [1.0; 3],
            &Geometry::IDENTITY,
            NiftiCodes::SCANNER,
            NiftiLayout::Single,
        );
        assert!(NiftiHeader::decode(&b[..100])
            .unwrap_err()
            .to_string()
            .contains("truncated"));
        LittleEndian::write_i16(&mut b[70..], 128);
        let h = NiftiHeader::decode(&b).unwrap();
        assert!(slice_type(h.datatype)
            .unwrap_err()
            .to_string()
            .contains("RGB24"));
        LittleEndian::write_i16(&mut b[40..], 5);
        LittleEndian::write_i16(&mut b[48..], 3);
        LittleEndian::write_i16(&mut b[50..], 2);
        let h = NiftiHeader::decode(&b).unwrap();
        assert!(h.shape().is_err());
        b[344] = b'x';
        assert!(NiftiHeader::decode(&b)
            .unwrap_err()
            .to_string()
            .contains("magic"));
    }
}
