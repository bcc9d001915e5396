//! The native `.vvol` format (specified in `FORMAT.md` beside this crate).

use crate::error::{truncated, Error, Result};
use crate::output::Sink;
use crate::pipeline::{ordered, write_rows, ITEM_BYTES};
use memmap2::Mmap;
use rayon::prelude::*;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::Arc;
use volcore::grid::BrickEntry;
use volcore::region::{fill_brick, RegionSource};
use volcore::volume::{IntoVolumeData, TypedGrid};
use volcore::{
    BrickGeometry, BrickedGrid, CompressedGrid, Compression, Data, Dims, Layout, Sample,
    SampleType, SlicedGrid, ValueRange, Volume, VolumeMeta,
};

/// First eight bytes of every `.vvol` file.
pub const MAGIC: [u8; 8] = *b"\x89VVOL\r\n\x1a";
/// First eight bytes of the trailer.
pub const TRAILER_MAGIC: [u8; 8] = *b"VVOLEND\0";
/// The format version this code writes and reads.
pub const VERSION: u16 = 1;
/// Size of the fixed header.
pub const HEADER_LEN: u64 = 128;
/// Size of one brick table entry.
pub const ENTRY_LEN: u64 = 24;
/// Size of the trailer.
pub const TRAILER_LEN: u64 = 32;
/// Alignment of the data section and of uncompressed bricks.
pub const ALIGN: u64 = 64;

const FLAG_RANGE: u32 = 1;

/// The decoded fixed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Volume metadata (range may be empty when the writer streamed).
    pub meta: VolumeMeta,
    /// Byte offset of the data section.
    pub data_offset: u64,
    /// Length of the data section in bytes.
    pub data_len: u64,
    /// Number of bricks (0 for sliced).
    pub brick_count: u64,
    /// Bytes from one uncompressed brick to the next (0 otherwise).
    pub brick_stride: u64,
}

/// The decoded trailer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trailer {
    /// CRC-32 of the samples (sliced) or of the brick table (bricked).
    pub crc32: u32,
    /// Exact value range of the samples.
    pub range: ValueRange,
}

fn align_up(v: u64) -> u64 {
    v.div_ceil(ALIGN) * ALIGN
}

impl Header {
    /// The header a writer uses for `meta` (range as given, may be empty).
    pub fn for_meta(meta: VolumeMeta) -> Result<Header> {
        let size = meta.sample_type.size() as u64;
        match meta.layout {
            Layout::Sliced => {
                if meta.compression != Compression::None {
                    return Err(Error::invalid("sliced volumes cannot be compressed"));
                }
                Ok(Header {
                    meta,
                    data_offset: HEADER_LEN,
                    data_len: meta.dims.checked_bytes(size)?,
                    brick_count: 0,
                    brick_stride: 0,
                })
            }
            Layout::Bricked(g) => {
                let n = g.brick_count();
                let table = n
                    .checked_mul(ENTRY_LEN)
                    .ok_or_else(|| Error::invalid("brick table size overflows"))?;
                let data_offset = align_up(HEADER_LEN + table);
                let (stride, data_len) = match meta.compression {
                    Compression::None => {
                        let stride = align_up(g.stored_len() as u64 * size);
                        (stride, stride * n)
                    }
                    Compression::Zstd(_) => (0, 0), // known after writing
                };
                Ok(Header {
                    meta,
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

    /// Encode as the 128-byte header.
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
        b
    }

    /// Decode and validate a 128-byte header (not yet against a file length).
    pub fn decode(b: &[u8]) -> Result<Header> {
        if b.len() < HEADER_LEN as usize {
            return Err(Error::invalid(
                "file is truncated (shorter than the 128-byte header)",
            ));
        }
        if b[0..8] != MAGIC {
            return Err(Error::invalid("not a .vvol file (bad magic)"));
        }
        let u16_at = |o: usize| u16::from_le_bytes([b[o], b[o + 1]]);
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap_or_default());
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap_or_default());
        let f32_at = |o: usize| f32::from_bits(u32_at(o));
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        let version = u16_at(8);
        if version != VERSION {
            return Err(Error::invalid(format!(
                "unsupported .vvol version {version} (this build reads {VERSION})"
            )));
        }
        if u16_at(10) as u64 != HEADER_LEN {
            return Err(Error::invalid("header size field is not 128"));
        }
        let crc = crc32fast::hash(&b[..124]);
        if crc != u32_at(124) {
            return Err(Error::Checksum("header is damaged".into()));
        }
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
        };
        let h = Header {
            meta,
            data_offset: u64_at(80),
            data_len: u64_at(88),
            brick_count: u64_at(96),
            brick_stride: u64_at(104),
        };
        // The layout fixes everything but the compressed data length.
        let expect = Header::for_meta(meta)?;
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

impl Trailer {
    /// Encode as 32 bytes.
    pub fn encode(&self) -> [u8; TRAILER_LEN as usize] {
        let mut b = [0u8; TRAILER_LEN as usize];
        b[0..8].copy_from_slice(&TRAILER_MAGIC);
        b[8..12].copy_from_slice(&self.crc32.to_le_bytes());
        let flags = if self.range.is_empty() { 0 } else { FLAG_RANGE };
        b[12..16].copy_from_slice(&flags.to_le_bytes());
        b[16..24].copy_from_slice(&self.range.min.to_le_bytes());
        b[24..32].copy_from_slice(&self.range.max.to_le_bytes());
        b
    }

    /// Decode 32 bytes.
    pub fn decode(b: &[u8]) -> Result<Trailer> {
        if b.len() < TRAILER_LEN as usize || b[0..8] != TRAILER_MAGIC {
            return Err(Error::invalid(
                "trailer is missing or damaged (file truncated?)",
            ));
        }
        let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or_default());
        let flags = u32::from_le_bytes([b[12], b[13], b[14], b[15]]);
        Ok(Trailer {
            crc32: u32::from_le_bytes([b[8], b[9], b[10], b[11]]),
            range: if flags & FLAG_RANGE != 0 {
                ValueRange {
                    min: f(16),
                    max: f(24),
                }
            } else {
                ValueRange::EMPTY
            },
        })
    }
}

fn encode_table(entries: &[BrickEntry]) -> Vec<u8> {
    let mut t = Vec::with_capacity(entries.len() * ENTRY_LEN as usize);
    for e in entries {
        t.extend_from_slice(&e.offset.to_le_bytes());
        t.extend_from_slice(&e.length.to_le_bytes());
        t.extend_from_slice(&e.crc32.to_le_bytes());
        t.extend_from_slice(&0u32.to_le_bytes());
    }
    t
}

fn decode_table(b: &[u8]) -> Vec<BrickEntry> {
    b.chunks_exact(ENTRY_LEN as usize)
        .map(|c| BrickEntry {
            offset: u64::from_le_bytes(c[0..8].try_into().unwrap_or_default()),
            length: u64::from_le_bytes(c[8..16].try_into().unwrap_or_default()),
            crc32: u32::from_le_bytes(c[16..20].try_into().unwrap_or_default()),
        })
        .collect()
}

// ---------------------------------------------------------------- writing --

/// What a writer did.
#[derive(Clone, Copy, Debug)]
pub struct WriteStats {
    /// Bytes written in all.
    pub bytes: u64,
    /// Exact value range of the samples written.
    pub range: ValueRange,
}

/// Write `src` as a `.vvol` with the layout and compression of `meta`
/// (its dims and sample type must match `src`; its range is ignored and
/// recomputed). Sliced volumes may go to a stream; bricked ones need a
/// file. `progress` is called with the uncompressed sample bytes done.
pub fn write<R: RegionSource>(
    src: &R,
    meta: VolumeMeta,
    sink: Sink<'_>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WriteStats> {
    if meta.dims != src.dims() || meta.sample_type != R::Sample::TYPE {
        return Err(Error::invalid("writer metadata does not match its source"));
    }
    let mut meta = meta;
    meta.range = ValueRange::EMPTY;
    match meta.layout {
        Layout::Sliced => write_sliced(src, meta, sink, progress),
        Layout::Bricked(g) => match sink {
            Sink::File(f) => write_bricked(src, meta, g, f, progress),
            Sink::Stream(_) => Err(Error::invalid(
                "bricked .vvol files cannot be written to a stream; use a file or --layout sliced",
            )),
        },
    }
}

fn write_sliced<R: RegionSource>(
    src: &R,
    meta: VolumeMeta,
    sink: Sink<'_>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WriteStats> {
    let header = Header::for_meta(meta)?;
    match sink {
        Sink::Stream(s) => write_sliced_body(src, &header, s, progress),
        Sink::File(f) => {
            let stats = write_sliced_body(src, &header, f, progress)?;
            // Now that the range is known, put it in the header too.
            let mut h = header;
            h.meta.range = stats.range;
            f.seek(SeekFrom::Start(0))?;
            f.write_all(&h.encode())?;
            f.seek(SeekFrom::End(0))?;
            Ok(stats)
        }
    }
}

fn write_sliced_body<R: RegionSource, W: Write + Send + ?Sized>(
    src: &R,
    header: &Header,
    out: &mut W,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WriteStats> {
    out.write_all(&header.encode())?;
    let rows = write_rows(src, out, progress)?;
    let trailer = Trailer {
        crc32: rows.crc32,
        range: rows.range,
    };
    out.write_all(&trailer.encode())?;
    out.flush()?;
    Ok(WriteStats {
        bytes: HEADER_LEN + rows.bytes + TRAILER_LEN,
        range: rows.range,
    })
}

fn write_bricked<R: RegionSource>(
    src: &R,
    meta: VolumeMeta,
    geom: BrickGeometry,
    file: &mut File,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<WriteStats> {
    let header = Header::for_meta(meta)?;
    let n = geom.brick_count();
    let size = R::Sample::TYPE.size() as u64;
    let raw_len = geom.stored_len() as u64 * size;
    // Header and a placeholder table first; both are rewritten at the end.
    file.write_all(&header.encode())?;
    let table_len = n * ENTRY_LEN;
    write_zeros(file, header.data_offset - HEADER_LEN)?;
    debug_assert!(header.data_offset >= HEADER_LEN + table_len);
    let mut entries: Vec<BrickEntry> = Vec::with_capacity(n as usize);
    let mut offset = header.data_offset;
    let mut range = ValueRange::EMPTY;
    let level = match meta.compression {
        Compression::Zstd(l) => Some(l),
        Compression::None => None,
    };
    let stride = header.brick_stride;
    let produce = |i: u64| -> Result<(Vec<u8>, ValueRange)> {
        let mut samples = vec![R::Sample::default(); geom.stored_len()];
        fill_brick(src, &geom, geom.brick_coords(i), &mut samples);
        let range = ValueRange::of(&samples);
        let bytes: &[u8] = bytemuck::cast_slice(&samples);
        let out = match level {
            Some(l) => compress(bytes, l)?,
            None => {
                let mut v = Vec::with_capacity(stride as usize);
                v.extend_from_slice(bytes);
                v.resize(stride as usize, 0);
                v
            }
        };
        Ok((out, range))
    };
    let batch = ((16 * ITEM_BYTES) / raw_len.max(1)).clamp(2, 4096) as usize;
    ordered(n, batch, produce, |(bytes, r): (Vec<u8>, ValueRange)| {
        let len = match level {
            Some(_) => bytes.len() as u64,
            None => raw_len,
        };
        entries.push(BrickEntry {
            offset,
            length: len,
            crc32: crc32fast::hash(&bytes[..len as usize]),
        });
        file.write_all(&bytes)?;
        offset += bytes.len() as u64;
        range = range.merge(r);
        progress(entries.len() as u64 * raw_len);
        Ok(())
    })?;
    let table = encode_table(&entries);
    let trailer = Trailer {
        crc32: crc32fast::hash(&table),
        range,
    };
    file.write_all(&trailer.encode())?;
    let mut h = header;
    h.meta.range = range;
    h.data_len = offset - h.data_offset;
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&h.encode())?;
    file.write_all(&table)?;
    file.seek(SeekFrom::End(0))?;
    file.flush()?;
    Ok(WriteStats {
        bytes: offset + TRAILER_LEN,
        range,
    })
}

/// zstd-compress with a per-thread compressor: creating a context for each
/// brick costs as much as compressing a sparse one.
fn compress(bytes: &[u8], level: i32) -> std::io::Result<Vec<u8>> {
    thread_local! {
        static COMPRESSOR: std::cell::RefCell<Option<(i32, zstd::bulk::Compressor<'static>)>> =
            const { std::cell::RefCell::new(None) };
    }
    COMPRESSOR.with(|cell| {
        let mut slot = cell.borrow_mut();
        if !matches!(&*slot, Some((l, _)) if *l == level) {
            *slot = Some((level, zstd::bulk::Compressor::new(level)?));
        }
        match slot.as_mut() {
            Some((_, c)) => c.compress(bytes),
            None => zstd::bulk::compress(bytes, level),
        }
    })
}

fn write_zeros(w: &mut impl Write, mut n: u64) -> std::io::Result<()> {
    let zeros = [0u8; 64 * 1024];
    while n > 0 {
        let k = n.min(zeros.len() as u64) as usize;
        w.write_all(&zeros[..k])?;
        n -= k as u64;
    }
    Ok(())
}

// ---------------------------------------------------------------- reading --

/// How to open a `.vvol` file.
#[derive(Clone, Copy, Debug)]
pub struct OpenOptions {
    /// Check every checksum before returning (reads the whole file).
    pub verify: bool,
    /// Decoded bytes the brick cache of a compressed volume may hold.
    pub cache_bytes: usize,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            verify: false,
            cache_bytes: 512 << 20,
        }
    }
}

/// Header and trailer of a file, checked against its length.
pub fn read_header(path: &Path) -> Result<(Header, Trailer)> {
    let mut f = File::open(path)?;
    let len = f.metadata()?.len();
    let mut b = [0u8; HEADER_LEN as usize];
    f.read_exact(&mut b).map_err(truncated("128-byte header"))?;
    let h = Header::decode(&b)?;
    check_len(&h, len)?;
    f.seek(SeekFrom::Start(h.data_offset + h.data_len))?;
    let mut t = [0u8; TRAILER_LEN as usize];
    f.read_exact(&mut t).map_err(truncated("trailer"))?;
    Ok((h, Trailer::decode(&t)?))
}

fn check_len(h: &Header, len: u64) -> Result<()> {
    let want = h.file_len().unwrap_or(u64::MAX);
    if want != len {
        return Err(Error::invalid(format!(
            "header describes {} ({} bytes with header and trailer) but the file has {len} bytes",
            h.meta, want
        )));
    }
    Ok(())
}

/// Open a `.vvol` file: uncompressed layouts are memory-mapped and sampled
/// in place, compressed bricks are decoded on demand.
pub fn open(path: &Path, opts: OpenOptions) -> Result<Volume> {
    let (h, t) = read_header(path)?;
    let file = File::open(path)?;
    // SAFETY: the map is read-only; like every reader of mapped files we
    // rely on the file not being truncated by another process meanwhile.
    let map = Arc::new(unsafe { Mmap::map(&file)? });
    let mut meta = h.meta;
    if meta.range.is_empty() {
        meta.range = t.range;
    }
    let table = match meta.layout {
        Layout::Sliced => Vec::new(),
        Layout::Bricked(_) => {
            let end = (HEADER_LEN + h.brick_count * ENTRY_LEN) as usize;
            let raw = &map[HEADER_LEN as usize..end];
            if opts.verify && crc32fast::hash(raw) != t.crc32 {
                return Err(Error::Checksum("brick table is damaged".into()));
            }
            decode_table(raw)
        }
    };
    let data = match meta.sample_type {
        SampleType::U8 => build::<u8>(&h, &t, map, table, opts)?,
        SampleType::U16 => build::<u16>(&h, &t, map, table, opts)?,
        SampleType::I16 => build::<i16>(&h, &t, map, table, opts)?,
        SampleType::F32 => build::<f32>(&h, &t, map, table, opts)?,
    };
    Ok(Volume { meta, data })
}

fn build<T: IntoVolumeData>(
    h: &Header,
    t: &Trailer,
    map: Arc<Mmap>,
    table: Vec<BrickEntry>,
    opts: OpenOptions,
) -> Result<volcore::VolumeData> {
    let meta = &h.meta;
    let size = std::mem::size_of::<T>() as u64;
    let data_end = h.data_offset + h.data_len;
    let grid = match meta.layout {
        Layout::Sliced => {
            if opts.verify {
                let bytes = &map[h.data_offset as usize..data_end as usize];
                let crc = parallel_crc(bytes);
                if crc != t.crc32 {
                    return Err(Error::Checksum(format!(
                        "sample data crc {crc:08x}, trailer says {:08x}",
                        t.crc32
                    )));
                }
            }
            let data = Data::mapped(map, h.data_offset as usize, meta.dims.count() as usize)?;
            TypedGrid::Sliced(SlicedGrid::new(meta.dims, data)?)
        }
        Layout::Bricked(g) => {
            for (i, e) in table.iter().enumerate() {
                let inside = e.offset >= h.data_offset
                    && e.offset
                        .checked_add(e.length)
                        .is_some_and(|end| end <= data_end);
                if !inside {
                    return Err(Error::invalid(format!(
                        "brick table entry {i} points outside the data ({} bytes at offset {})",
                        e.length, e.offset
                    )));
                }
            }
            match meta.compression {
                Compression::None => {
                    let raw = g.stored_len() as u64 * size;
                    for (i, e) in table.iter().enumerate() {
                        if e.offset != h.data_offset + i as u64 * h.brick_stride || e.length != raw
                        {
                            return Err(Error::invalid(format!(
                                "brick table entry {i} does not match the uncompressed layout"
                            )));
                        }
                    }
                    if opts.verify {
                        verify_bricks(&map, &table)?;
                    }
                    let len = (h.data_len / size) as usize;
                    let data = Data::mapped(map, h.data_offset as usize, len)?;
                    let stride = (h.brick_stride / size) as usize;
                    TypedGrid::Bricked(BrickedGrid::new(g, stride, data)?)
                }
                Compression::Zstd(_) => {
                    if opts.verify {
                        verify_bricks(&map, &table)?;
                    }
                    let len = map.len();
                    let source = Data::<u8>::mapped(map, 0, len)?;
                    let grid = CompressedGrid::<T>::new(g, source, table, opts.cache_bytes)?;
                    if opts.verify {
                        (0..g.brick_count())
                            .into_par_iter()
                            .try_for_each(|i| grid.decode(i).map(|_| ()))
                            .map_err(Error::Invalid)?;
                    }
                    TypedGrid::Compressed(grid)
                }
            }
        }
    };
    Ok(T::into_data(grid))
}

fn verify_bricks(map: &[u8], table: &[BrickEntry]) -> Result<()> {
    table.par_iter().enumerate().try_for_each(|(i, e)| {
        let bytes = &map[e.offset as usize..(e.offset + e.length) as usize];
        let crc = crc32fast::hash(bytes);
        if crc == e.crc32 {
            Ok(())
        } else {
            Err(Error::Checksum(format!(
                "brick {i} crc {crc:08x}, table says {:08x}",
                e.crc32
            )))
        }
    })
}

/// CRC-32 of a large buffer, computed in parallel pieces and combined.
pub fn parallel_crc(bytes: &[u8]) -> u32 {
    let parts: Vec<crc32fast::Hasher> = bytes
        .par_chunks(4 << 20)
        .map(|c| {
            let mut h = crc32fast::Hasher::new();
            h.update(c);
            h
        })
        .collect();
    let mut all = crc32fast::Hasher::new();
    for p in &parts {
        all.combine(p);
    }
    all.finalize()
}

/// Read a sliced, uncompressed `.vvol` from a stream (such as a pipe) into
/// memory, checking its trailer checksum. Memory grows with the data that
/// actually arrives, never with what a header claims.
pub fn read_stream(r: &mut dyn Read) -> Result<Volume> {
    let mut b = [0u8; HEADER_LEN as usize];
    r.read_exact(&mut b).map_err(truncated("128-byte header"))?;
    let h = Header::decode(&b)?;
    if h.meta.layout != Layout::Sliced {
        return Err(Error::invalid(
            "only sliced uncompressed .vvol data can be read from a stream",
        ));
    }
    let mut bytes: Vec<u8> = Vec::with_capacity(h.data_len.min(64 << 20) as usize);
    let got = r.take(h.data_len).read_to_end(&mut bytes)?;
    if got as u64 != h.data_len {
        return Err(Error::invalid(format!(
            "stream is truncated: header describes {} ({} bytes of samples) but only {got} arrived",
            h.meta, h.data_len
        )));
    }
    let mut t = [0u8; TRAILER_LEN as usize];
    r.read_exact(&mut t).map_err(truncated("trailer"))?;
    let t = Trailer::decode(&t)?;
    let crc = parallel_crc(&bytes);
    if crc != t.crc32 {
        return Err(Error::Checksum(format!(
            "sample data crc {crc:08x}, trailer says {:08x}",
            t.crc32
        )));
    }
    let mut meta = h.meta;
    meta.range = t.range;
    let data = match meta.sample_type {
        SampleType::U8 => from_bytes::<u8>(meta.dims, bytes)?,
        SampleType::U16 => from_bytes::<u16>(meta.dims, bytes)?,
        SampleType::I16 => from_bytes::<i16>(meta.dims, bytes)?,
        SampleType::F32 => from_bytes::<f32>(meta.dims, bytes)?,
    };
    Ok(Volume { meta, data })
}

/// Samples from little-endian bytes into an owned sliced grid.
pub fn from_bytes<T: IntoVolumeData>(dims: Dims, bytes: Vec<u8>) -> Result<volcore::VolumeData> {
    let mut v: Vec<T> = match bytemuck::try_cast_vec(bytes) {
        Ok(v) => v,
        Err((_, bytes)) => bytemuck::pod_collect_to_vec(&bytes),
    };
    T::slice_from_le(&mut v);
    Ok(T::into_data(TypedGrid::Sliced(SlicedGrid::new(
        dims,
        Data::Owned(v),
    )?)))
}
