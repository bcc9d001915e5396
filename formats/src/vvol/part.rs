//! Part files: one shard of a `.vvol` conversion (`vol-convert --shard
//! K/N`), and assembling the parts into the `.vvol` one unsharded
//! conversion would have written (`vol-convert --merge`), byte for byte.
//!
//! A part holds the units its shard owns ([`Shard::units`] of the
//! volume's slices when sliced, of its brick layers when bricked): the
//! samples or (compressed) bricks exactly as the `.vvol` stores them, back
//! to back from [`DATA_OFFSET`], then (bricked) their brick table. Its
//! header carries the `.vvol` header of the whole volume with the part's
//! value range. The layout is specified in `FORMAT.md`.

use super::{decode_table, encode_table, Header, Trailer, ENTRY_LEN, HEADER_LEN};
use crate::error::{Error, Result};
use crate::reader::{At, CResult, ConvertError};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use volcore::grid::BrickEntry;
use volcore::{Compression, Layout, Shard, ValueRange, VolumeMeta};

/// First eight bytes of a part file.
pub const MAGIC: [u8; 8] = *b"VVOLPART";
/// The part format version this code writes and reads.
pub const VERSION: u32 = 1;
/// Bytes of the part's own fields before the embedded `.vvol` header.
const FIELDS_LEN: u64 = 64;
/// Where a part's data starts: its fields and the `.vvol` header.
pub const DATA_OFFSET: u64 = FIELDS_LEN + HEADER_LEN;
/// The file name extension of part files.
pub const EXTENSION: &str = "vpart";

/// The units a volume's writer works in: slices (sliced) or brick layers
/// (bricked).
pub fn unit_count(meta: &VolumeMeta) -> u64 {
    match meta.layout {
        Layout::Sliced => meta.dims.z,
        Layout::Bricked(g) => g.counts()[2],
    }
}

/// Bytes one unit of an uncompressed volume takes.
fn unit_bytes(h: &Header) -> u64 {
    let m = &h.meta;
    match m.layout {
        Layout::Sliced => m.dims.slice_len() * m.sample_type.size() as u64,
        Layout::Bricked(g) => g.counts()[0] * g.counts()[1] * h.brick_stride,
    }
}

/// Bricks per unit (0 when sliced).
fn bricks_per_unit(meta: &VolumeMeta) -> u64 {
    match meta.layout {
        Layout::Sliced => 0,
        Layout::Bricked(g) => g.counts()[0] * g.counts()[1],
    }
}

/// The decoded header of a part file.
#[derive(Clone, Debug, PartialEq)]
pub struct PartHeader {
    /// Which shard of how many.
    pub shard: Shard,
    /// The units the part holds.
    pub units: Range<u64>,
    /// Bytes of data from [`DATA_OFFSET`].
    pub data_len: u64,
    /// CRC-32 of the data (sliced) or of the part's brick table (bricked).
    pub crc32: u32,
    /// The whole volume's `.vvol` header, with this part's value range.
    pub volume: Header,
}

impl PartHeader {
    /// Encode as the [`DATA_OFFSET`] bytes that start the file.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = vec![0u8; DATA_OFFSET as usize];
        b[0..8].copy_from_slice(&MAGIC);
        b[8..12].copy_from_slice(&VERSION.to_le_bytes());
        b[12..16].copy_from_slice(&self.shard.index.to_le_bytes());
        b[16..20].copy_from_slice(&self.shard.count.to_le_bytes());
        b[24..32].copy_from_slice(&self.units.start.to_le_bytes());
        b[32..40].copy_from_slice(&self.units.end.to_le_bytes());
        b[40..48].copy_from_slice(&self.data_len.to_le_bytes());
        b[48..52].copy_from_slice(&self.crc32.to_le_bytes());
        let crc = crc32fast::hash(&b[..60]);
        b[60..64].copy_from_slice(&crc.to_le_bytes());
        b[FIELDS_LEN as usize..].copy_from_slice(&self.volume.encode());
        b
    }

    /// Decode and check the first [`DATA_OFFSET`] bytes of a part.
    pub fn decode(b: &[u8]) -> Result<PartHeader> {
        if b.len() < DATA_OFFSET as usize {
            return Err(Error::invalid("not a volkit part file (too short)"));
        }
        if b[0..8] != MAGIC {
            return Err(Error::invalid("not a volkit part file (bad magic)"));
        }
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap_or_default());
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap_or_default());
        if u32_at(8) != VERSION {
            return Err(Error::invalid(format!(
                "unsupported part version {} (this build reads {VERSION})",
                u32_at(8)
            )));
        }
        if crc32fast::hash(&b[..60]) != u32_at(60) {
            return Err(Error::Checksum("part header is damaged".into()));
        }
        let shard = Shard::new(u32_at(12), u32_at(16)).ok_or_else(|| {
            Error::invalid(format!(
                "shard {}/{} does not exist",
                u32_at(12),
                u32_at(16)
            ))
        })?;
        let volume = Header::decode(&b[FIELDS_LEN as usize..DATA_OFFSET as usize])?;
        let units = u64_at(24)..u64_at(32);
        if units != shard.units(unit_count(&volume.meta)) {
            return Err(Error::invalid(format!(
                "shard {shard} holds units {}..{}, not its share of the volume",
                units.start, units.end
            )));
        }
        let h = PartHeader {
            shard,
            units,
            data_len: u64_at(40),
            crc32: u32_at(48),
            volume,
        };
        if h.volume.meta.compression == Compression::None {
            let n = h.units.end - h.units.start;
            if Some(h.data_len) != n.checked_mul(unit_bytes(&h.volume)) {
                return Err(Error::invalid(format!(
                    "{} bytes of data do not make {n} units of {}",
                    h.data_len, h.volume.meta
                )));
            }
        }
        Ok(h)
    }

    /// Bricks the part holds (0 when sliced).
    pub fn brick_count(&self) -> u64 {
        (self.units.end - self.units.start) * bricks_per_unit(&self.volume.meta)
    }

    /// The file length this header implies.
    pub fn file_len(&self) -> Option<u64> {
        DATA_OFFSET
            .checked_add(self.data_len)?
            .checked_add(self.brick_count().checked_mul(ENTRY_LEN)?)
    }

    /// The volume's metadata without the value range: what every part of
    /// one volume shares.
    fn shared_meta(&self) -> VolumeMeta {
        VolumeMeta {
            range: ValueRange::EMPTY,
            ..self.volume.meta
        }
    }
}

/// An open part file, its header checked against its length.
pub struct Part {
    /// Where it is.
    pub path: PathBuf,
    /// Its header.
    pub header: PartHeader,
    file: File,
}

impl Part {
    /// Open and check a part file.
    pub fn open(path: &Path) -> CResult<Part> {
        let mut file = File::open(path).at(path)?;
        let len = file.metadata().at(path)?.len();
        let mut b = vec![0u8; DATA_OFFSET as usize];
        let mut got = 0;
        while got < b.len() {
            match file.read(&mut b[got..]).at(path)? {
                0 => break,
                n => got += n,
            }
        }
        let header = PartHeader::decode(&b[..got]).at(path)?;
        if header.file_len() != Some(len) {
            return Err(ConvertError::new(
                path,
                Error::invalid(format!(
                    "part is {len} bytes long, its header says {} (truncated or damaged)",
                    header
                        .file_len()
                        .map_or("more than 2^64".into(), |l| l.to_string())
                )),
            ));
        }
        Ok(Part {
            path: path.to_path_buf(),
            header,
            file,
        })
    }

    /// The part's brick table, checked: the entries must lie back to back
    /// in its data section, uncompressed ones at the fixed stride.
    fn table(&mut self) -> CResult<Vec<BrickEntry>> {
        let h = &self.header;
        let n = h.brick_count();
        let mut raw = vec![0u8; (n * ENTRY_LEN) as usize];
        self.file
            .seek(SeekFrom::Start(DATA_OFFSET + h.data_len))
            .at(&self.path)?;
        self.file.read_exact(&mut raw).at(&self.path)?;
        if crc32fast::hash(&raw) != h.crc32 {
            return Err(ConvertError::new(
                &self.path,
                Error::Checksum("the part's brick table is damaged".into()),
            ));
        }
        let entries = decode_table(&raw);
        let stride = h.volume.brick_stride;
        let mut at = DATA_OFFSET;
        for (i, e) in entries.iter().enumerate() {
            let step = if stride > 0 { stride } else { e.length };
            let fits = e.offset == at
                && (stride == 0 || e.length <= stride)
                && at
                    .checked_add(step)
                    .is_some_and(|end| end <= DATA_OFFSET + h.data_len);
            if !fits {
                return Err(ConvertError::new(
                    &self.path,
                    Error::invalid(format!("brick {i} of the part's table is out of place")),
                ));
            }
            at += step;
        }
        if at != DATA_OFFSET + h.data_len {
            return Err(ConvertError::new(
                &self.path,
                Error::invalid("the part's bricks do not fill its data section"),
            ));
        }
        Ok(entries)
    }
}

/// What [`merge`] wrote.
#[derive(Clone, Copy, Debug)]
pub struct MergeStats {
    /// Bytes of the `.vvol` written.
    pub bytes: u64,
    /// Its value range.
    pub range: ValueRange,
    /// Its metadata.
    pub meta: VolumeMeta,
}

/// Open the parts of one volume and check that they are all there: every
/// shard `0..N` exactly once, all of the same volume. Sorted by shard.
pub fn open_parts(paths: &[PathBuf]) -> CResult<Vec<Part>> {
    let Some(first) = paths.first() else {
        return Err(ConvertError::new(
            Path::new("--merge"),
            Error::invalid("no part files given"),
        ));
    };
    let mut parts = paths
        .iter()
        .map(|p| Part::open(p))
        .collect::<CResult<Vec<_>>>()?;
    parts.sort_by_key(|p| p.header.shard.index);
    let count = parts[0].header.shard.count;
    let meta = parts[0].header.shared_meta();
    for w in parts.windows(2) {
        if w[0].header.shard.index == w[1].header.shard.index {
            return Err(ConvertError::new(
                &w[1].path,
                Error::invalid(format!(
                    "shard {} is given twice (also {})",
                    w[1].header.shard,
                    w[0].path.display()
                )),
            ));
        }
    }
    for p in &parts {
        if p.header.shard.count != count {
            return Err(ConvertError::new(
                &p.path,
                Error::invalid(format!(
                    "shard {} is from a split into {} parts, {} from one into {count}",
                    p.header.shard,
                    p.header.shard.count,
                    parts[0].path.display()
                )),
            ));
        }
        if p.header.shared_meta() != meta {
            return Err(ConvertError::new(
                &p.path,
                Error::invalid(format!(
                    "a part of another volume ({}) than {} ({})",
                    p.header.volume.meta,
                    parts[0].path.display(),
                    meta
                )),
            ));
        }
    }
    if parts.len() != count as usize {
        let have: Vec<u32> = parts.iter().map(|p| p.header.shard.index).collect();
        let missing: Vec<String> = (0..count)
            .filter(|k| have.binary_search(k).is_err())
            .take(8)
            .map(|k| format!("{k}/{count}"))
            .collect();
        return Err(ConvertError::new(
            first,
            Error::invalid(format!(
                "{} of {count} parts given; missing shard {}{}",
                parts.len(),
                missing.join(", "),
                if count as usize - parts.len() > missing.len() {
                    ", ..."
                } else {
                    ""
                }
            )),
        ));
    }
    Ok(parts)
}

/// Bytes copied at once when merging sliced parts.
const COPY_CHUNK: u64 = 8 << 20;

/// Assemble checked `parts` (see [`open_parts`]) into the `.vvol` that one
/// unsharded conversion would have written, into `out` (a new, empty
/// file), checking every brick's (or the samples') CRC on the way.
/// Compressed bricks are copied, not recompressed. `progress` gets the
/// data bytes copied so far.
pub fn merge(
    parts: &mut [Part],
    out: &mut File,
    out_path: &Path,
    progress: &dyn Fn(u64),
) -> CResult<MergeStats> {
    let Some(p0) = parts.first() else {
        return Err(ConvertError::new(
            out_path,
            Error::invalid("no part files given"),
        ));
    };
    let mut meta = p0.header.shared_meta();
    meta.range = parts.iter().fold(ValueRange::EMPTY, |r, p| {
        r.merge(p.header.volume.meta.range)
    });
    let mut h = Header::for_meta(meta).at(out_path)?;
    let data_len = parts
        .iter()
        .try_fold(0u64, |n, p| n.checked_add(p.header.data_len))
        .ok_or_else(|| ConvertError::new(out_path, Error::invalid("data length overflows")))?;
    if meta.compression == Compression::None && data_len != h.data_len {
        return Err(ConvertError::new(
            out_path,
            Error::invalid("the parts' data does not add up to the volume (internal error)"),
        ));
    }
    h.data_len = data_len;
    let mut done = 0u64;
    let mut buf = Vec::new();
    let mut out = std::io::BufWriter::with_capacity(1 << 20, out);
    let trailer_crc = match meta.layout {
        Layout::Sliced => {
            out.write_all(&h.encode()).at(out_path)?;
            let mut all = crc32fast::Hasher::new();
            for p in parts.iter_mut() {
                p.file.seek(SeekFrom::Start(DATA_OFFSET)).at(&p.path)?;
                let mut mine = crc32fast::Hasher::new();
                let mut left = p.header.data_len;
                while left > 0 {
                    let n = left.min(COPY_CHUNK) as usize;
                    buf.resize(n, 0);
                    p.file.read_exact(&mut buf).at(&p.path)?;
                    mine.update(&buf);
                    all.update(&buf);
                    out.write_all(&buf).at(out_path)?;
                    left -= n as u64;
                    done += n as u64;
                    progress(done);
                }
                if mine.finalize() != p.header.crc32 {
                    return Err(ConvertError::new(
                        &p.path,
                        Error::Checksum("the part's samples are damaged".into()),
                    ));
                }
            }
            all.finalize()
        }
        Layout::Bricked(_) => {
            let mut tables = Vec::with_capacity(parts.len());
            let mut entries = Vec::with_capacity(h.brick_count as usize);
            let mut at = h.data_offset;
            for p in parts.iter_mut() {
                let t = p.table()?;
                for e in &t {
                    entries.push(BrickEntry {
                        offset: at + (e.offset - DATA_OFFSET),
                        ..*e
                    });
                }
                at += p.header.data_len;
                tables.push(t);
            }
            if entries.len() as u64 != h.brick_count {
                return Err(ConvertError::new(
                    out_path,
                    Error::invalid(
                        "the parts' bricks do not add up to the volume (internal error)",
                    ),
                ));
            }
            let table = encode_table(&entries);
            out.write_all(&h.encode()).at(out_path)?;
            out.write_all(&table).at(out_path)?;
            let pad = h.data_offset - HEADER_LEN - table.len() as u64;
            out.write_all(&vec![0u8; pad as usize]).at(out_path)?;
            for (p, t) in parts.iter_mut().zip(&tables) {
                p.file.seek(SeekFrom::Start(DATA_OFFSET)).at(&p.path)?;
                let mut r = std::io::BufReader::with_capacity(1 << 20, &p.file);
                let end = DATA_OFFSET + p.header.data_len;
                for (i, e) in t.iter().enumerate() {
                    let next = t.get(i + 1).map_or(end, |n| n.offset);
                    buf.resize((next - e.offset) as usize, 0);
                    r.read_exact(&mut buf).at(&p.path)?;
                    if crc32fast::hash(&buf[..e.length as usize]) != e.crc32 {
                        return Err(ConvertError::new(
                            &p.path,
                            Error::Checksum(format!("brick {i} of the part is damaged")),
                        ));
                    }
                    out.write_all(&buf).at(out_path)?;
                    done += buf.len() as u64;
                    progress(done);
                }
            }
            crc32fast::hash(&table)
        }
    };
    let trailer = Trailer {
        crc32: trailer_crc,
        range: meta.range,
    };
    out.write_all(&trailer.encode()).at(out_path)?;
    out.flush().at(out_path)?;
    drop(out);
    Ok(MergeStats {
        bytes: h.file_len().unwrap_or(0),
        range: meta.range,
        meta,
    })
}
