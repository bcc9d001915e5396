//! The native `.vvol` format (specified in `FORMAT.md` beside this crate):
//! the header codec here, the trailer's in [`trailer`], writing in
//! [`write`], reading in [`read`].

pub mod part;
mod read;
mod slices;
pub mod trailer;
mod write;

pub use read::{
    from_bytes, open, open_stored, parallel_crc, read_header, read_header_from, read_stream,
    OpenOptions, Stored,
};
pub use slices::{vvol_stream, BorrowedReader, VolumeReader};
pub use trailer::{Trailer, TRAILER_LEN, TRAILER_MAGIC};
pub use write::{write, VvolWriter, WriteStats};

use crate::error::{Error, Result};
use trailer::FLAG_RANGE;
use volcore::grid::BrickEntry;
use volcore::{
    BrickGeometry, Compression, Dims, Geometry, Layout, LengthUnit, SampleType, ValueRange,
    VolumeMeta,
};

/// First eight bytes of every `.vvol` file.
pub const MAGIC: [u8; 8] = *b"\x89VVOL\r\n\x1a";
/// The format version this code writes (it reads 1, 2 and 3; 3 adds the
/// unit of length to version 2's geometry).
pub const VERSION: u16 = 3;
/// Size of the fixed header this code writes (versions 2 and 3).
pub const HEADER_LEN: u64 = 256;
/// Size of the version 1 header, and of the part every version shares.
pub const BASE_HEADER_LEN: u64 = 128;
/// Size of one brick table entry.
pub const ENTRY_LEN: u64 = 24;
/// Alignment of the data section and of uncompressed bricks.
pub const ALIGN: u64 = 64;

/// Where version 3 keeps the unit of length code ([`LengthUnit::code`]).
const UNIT_AT: usize = 224;

/// The decoded fixed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Volume metadata (range may be empty when the writer streamed).
    pub meta: VolumeMeta,
    /// Header length: 128 (version 1) or 256 (versions 2 and 3, with
    /// geometry).
    pub header_len: u64,
    /// Byte offset of the data section.
    pub data_offset: u64,
    /// Length of the data section in bytes.
    pub data_len: u64,
    /// Number of bricks (0 for sliced).
    pub brick_count: u64,
    /// Bytes from one uncompressed brick to the next (0 otherwise).
    pub brick_stride: u64,
}

fn align_up(v: u64) -> u64 {
    v.div_ceil(ALIGN) * ALIGN
}

impl Header {
    /// The header a writer uses for `meta` (range as given, may be empty).
    pub fn for_meta(meta: VolumeMeta) -> Result<Header> {
        Header::for_meta_len(meta, HEADER_LEN)
    }

    /// The header for `meta` with a header of `header_len` bytes.
    fn for_meta_len(meta: VolumeMeta, header_len: u64) -> Result<Header> {
        let size = meta.sample_type.size() as u64;
        match meta.layout {
            Layout::Sliced => {
                if meta.compression != Compression::None {
                    return Err(Error::invalid("sliced volumes cannot be compressed"));
                }
                Ok(Header {
                    meta,
                    header_len,
                    data_offset: header_len,
                    data_len: meta.dims.checked_bytes(size)?,
                    brick_count: 0,
                    brick_stride: 0,
                })
            }
            Layout::Bricked(g) => {
                let n = g.brick_count();
                let data_offset = n
                    .checked_mul(ENTRY_LEN)
                    .and_then(|table| table.checked_add(header_len))
                    .and_then(|end| end.checked_next_multiple_of(ALIGN))
                    .ok_or_else(|| Error::invalid("brick table size overflows"))?;
                let (stride, data_len) = match meta.compression {
                    Compression::None => {
                        let stride = align_up(g.stored_len() as u64 * size);
                        let len = stride
                            .checked_mul(n)
                            .ok_or_else(|| Error::invalid("data length overflows"))?;
                        (stride, len)
                    }
                    Compression::Zstd(_) => (0, 0), // known after writing
                };
                Ok(Header {
                    meta,
                    header_len,
                    data_offset,
                    data_len,
                    brick_count: n,
                    brick_stride: stride,
                })
            }
        }
    }

    /// Total file length this header implies.
    pub fn file_len(&self) -> Option<u64> {
        self.data_offset
            .checked_add(self.data_len)?
            .checked_add(TRAILER_LEN)
    }

    /// Encode as the 256-byte version 3 header.
    pub fn encode(&self) -> [u8; HEADER_LEN as usize] {
        let m = &self.meta;
        let mut b = [0u8; HEADER_LEN as usize];
        b[0..8].copy_from_slice(&MAGIC);
        b[8..10].copy_from_slice(&VERSION.to_le_bytes());
        b[10..12].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        let flags = if m.range.is_empty() { 0 } else { FLAG_RANGE };
        b[12..16].copy_from_slice(&flags.to_le_bytes());
        for (a, v) in m.dims.as_array().iter().enumerate() {
            b[16 + 8 * a..24 + 8 * a].copy_from_slice(&v.to_le_bytes());
        }
        for (a, v) in m.spacing.iter().enumerate() {
            b[40 + 4 * a..44 + 4 * a].copy_from_slice(&v.to_le_bytes());
        }
        b[52] = m.sample_type.code();
        if let Layout::Bricked(g) = m.layout {
            b[53] = 1;
            b[56..60].copy_from_slice(&g.brick().to_le_bytes());
            b[60] = volcore::brick::APRON_LO as u8;
            b[61] = volcore::brick::APRON_HI as u8;
        }
        if let Compression::Zstd(level) = m.compression {
            b[54] = 1;
            b[55] = level.clamp(-128, 127) as i8 as u8;
        }
        b[64..72].copy_from_slice(&m.range.min.to_le_bytes());
        b[72..80].copy_from_slice(&m.range.max.to_le_bytes());
        b[80..88].copy_from_slice(&self.data_offset.to_le_bytes());
        b[88..96].copy_from_slice(&self.data_len.to_le_bytes());
        b[96..104].copy_from_slice(&self.brick_count.to_le_bytes());
        b[104..112].copy_from_slice(&self.brick_stride.to_le_bytes());
        let crc = crc32fast::hash(&b[..124]);
        b[124..128].copy_from_slice(&crc.to_le_bytes());
        let g = &m.geometry;
        for (a, v) in g.origin.iter().enumerate() {
            b[128 + 8 * a..136 + 8 * a].copy_from_slice(&v.to_le_bytes());
        }
        for (i, v) in g.direction.iter().flatten().enumerate() {
            b[152 + 8 * i..160 + 8 * i].copy_from_slice(&v.to_le_bytes());
        }
        b[UNIT_AT] = g.unit.code();
        let crc = crc32fast::hash(&b[128..252]);
        b[252..256].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// The length of the header that starts with `b` (at least 16 bytes):
    /// 128 for version 1, 256 for versions 2 and 3.
    pub fn length_of(b: &[u8]) -> Result<u64> {
        if b.len() < 16 {
            return Err(Error::invalid(
                "file is truncated (shorter than the .vvol header)",
            ));
        }
        if b[0..8] != MAGIC {
            return Err(Error::invalid("not a .vvol file (bad magic)"));
        }
        let version = u16::from_le_bytes([b[8], b[9]]);
        let len = u16::from_le_bytes([b[10], b[11]]) as u64;
        match (version, len) {
            (1, BASE_HEADER_LEN) | (2 | 3, HEADER_LEN) => Ok(len),
            (1..=3, other) => Err(Error::invalid(format!(
                "header size field {other} is wrong for .vvol version {version}"
            ))),
            (v, _) => Err(Error::invalid(format!(
                "unsupported .vvol version {v} (this build reads 1 to {VERSION})"
            ))),
        }
    }

    /// Decode and validate a header of either version (not yet against a
    /// file length); `b` holds at least [`Header::length_of`] bytes.
    pub fn decode(b: &[u8]) -> Result<Header> {
        let header_len = Header::length_of(b)?;
        if (b.len() as u64) < header_len {
            return Err(Error::invalid(format!(
                "file is truncated (shorter than the {header_len}-byte header)"
            )));
        }
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap_or_default());
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap_or_default());
        let f32_at = |o: usize| f32::from_bits(u32_at(o));
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        let crc = crc32fast::hash(&b[..124]);
        if crc != u32_at(124) {
            return Err(Error::Checksum("header is damaged".into()));
        }
        let geometry = if header_len == HEADER_LEN {
            if crc32fast::hash(&b[128..252]) != u32_at(252) {
                return Err(Error::Checksum("header geometry is damaged".into()));
            }
            let origin = [0, 1, 2].map(|a| f64_at(128 + 8 * a));
            let d = |i: usize| f64_at(152 + 8 * i);
            let axes = [0, 1, 2].map(|a| [d(a), d(3 + a), d(6 + a)]);
            let g = Geometry::from_axes(origin, axes)
                .map_err(|e| Error::invalid(format!("geometry: {e}")))?;
            // Version 2 holds no unit (its byte is reserved, 0).
            let unit = match u16::from_le_bytes([b[8], b[9]]) {
                2 => LengthUnit::Unknown,
                _ => LengthUnit::from_code(b[UNIT_AT]).ok_or_else(|| {
                    Error::invalid(format!("unknown unit of length code {}", b[UNIT_AT]))
                })?,
            };
            g.with_unit(unit)
        } else {
            Geometry::IDENTITY
        };
        let dims = Dims::new(u64_at(16), u64_at(24), u64_at(32))?;
        let spacing = [f32_at(40), f32_at(44), f32_at(48)];
        if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(Error::invalid(format!(
                "spacing {:?} is not positive and finite",
                spacing
            )));
        }
        let sample_type = SampleType::from_code(b[52])
            .ok_or_else(|| Error::invalid(format!("unknown sample type code {}", b[52])))?;
        let layout = match b[53] {
            0 => Layout::Sliced,
            1 => {
                if b[60] as u32 != volcore::brick::APRON_LO
                    || b[61] as u32 != volcore::brick::APRON_HI
                {
                    return Err(Error::invalid(format!(
                        "brick apron {}/{} is not the supported 1/2",
                        b[60], b[61]
                    )));
                }
                Layout::Bricked(BrickGeometry::new(dims, u32_at(56))?)
            }
            other => return Err(Error::invalid(format!("unknown layout code {other}"))),
        };
        let compression = match b[54] {
            0 => Compression::None,
            1 => Compression::Zstd(b[55] as i8 as i32),
            other => return Err(Error::invalid(format!("unknown compression code {other}"))),
        };
        let range = if u32_at(12) & FLAG_RANGE != 0 {
            ValueRange {
                min: f64_at(64),
                max: f64_at(72),
            }
        } else {
            ValueRange::EMPTY
        };
        let meta = VolumeMeta {
            dims,
            spacing,
            sample_type,
            range,
            layout,
            compression,
            geometry,
            narrowed: None,
        };
        let h = Header {
            meta,
            header_len,
            data_offset: u64_at(80),
            data_len: u64_at(88),
            brick_count: u64_at(96),
            brick_stride: u64_at(104),
        };
        // The layout fixes everything but the compressed data length.
        let expect = Header::for_meta_len(meta, header_len)?;
        let consistent = h.data_offset == expect.data_offset
            && h.brick_count == expect.brick_count
            && h.brick_stride == expect.brick_stride
            && (meta.compression != Compression::None || h.data_len == expect.data_len);
        if !consistent {
            return Err(Error::invalid(format!(
                "header fields disagree with {}: data offset {} / length {} / {} bricks",
                meta, h.data_offset, h.data_len, h.brick_count
            )));
        }
        if h.file_len().is_none() {
            return Err(Error::invalid("data length overflows"));
        }
        Ok(h)
    }
}

// Beside the header it is checked against (the codec is in trailer.rs).
impl Trailer {
    /// Check that this trailer's value range is the header's, when the
    /// header has one (a streamed writer leaves it empty): a file has one
    /// range, and two that disagree mean one of them is damaged.
    pub fn check_range(&self, header: &Header) -> Result<()> {
        let (h, t) = (header.meta.range, self.range);
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
        if h.is_empty() || (same(h.min, t.min) && same(h.max, t.max)) {
            return Ok(());
        }
        let show = |r: ValueRange| {
            if r.is_empty() {
                "none".to_string()
            } else {
                format!("[{}, {}]", r.min, r.max)
            }
        };
        Err(Error::invalid(format!(
            "value ranges disagree: header {}, trailer {} (damaged header or trailer?)",
            show(h),
            show(t)
        )))
    }
}

pub(crate) fn encode_table(entries: &[BrickEntry]) -> Vec<u8> {
    let mut t = Vec::with_capacity(entries.len() * ENTRY_LEN as usize);
    for e in entries {
        t.extend_from_slice(&e.offset.to_le_bytes());
        t.extend_from_slice(&e.length.to_le_bytes());
        t.extend_from_slice(&e.crc32.to_le_bytes());
        t.extend_from_slice(&0u32.to_le_bytes());
    }
    t
}

pub(crate) fn decode_table(b: &[u8]) -> Vec<BrickEntry> {
    b.chunks_exact(ENTRY_LEN as usize)
        .map(decode_entry)
        .collect()
}

/// One brick table entry from its 24 bytes.
pub(crate) fn decode_entry(c: &[u8]) -> BrickEntry {
    let u64_at = |o: usize| {
        u64::from_le_bytes(
            c.get(o..o + 8)
                .and_then(|b| b.try_into().ok())
                .unwrap_or_default(),
        )
    };
    BrickEntry {
        offset: u64_at(0),
        length: u64_at(8),
        crc32: u32::from_le_bytes(
            c.get(16..20)
                .and_then(|b| b.try_into().ok())
                .unwrap_or_default(),
        ),
    }
}
