//! Opening `.vvol` files and streams.

use super::trailer::FLAG_RANGE;
use super::{decode_entry, Header, Trailer, BASE_HEADER_LEN, ENTRY_LEN, HEADER_LEN, TRAILER_LEN};
use crate::error::{truncated, Error, Result};
use memmap2::Mmap;
use rayon::prelude::*;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;
use volcore::grid::BrickEntry;
use volcore::volume::{OpenSample, TypedGrid};
use volcore::VolumeData;
use volcore::{
    BrickGeometry, BrickedGrid, CompressedGrid, Compression, Data, Layout, Sample, SampleType,
    SlicedGrid, Volume,
};

/// How to open a `.vvol` file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OpenOptions {
    /// Check every checksum before returning (reads the whole file).
    pub verify: bool,
    /// Decoded bytes the brick cache of a compressed volume may hold.
    pub cache_bytes: usize,
    /// Copy the file into anonymous memory (backed by huge pages where the
    /// system allows) instead of mapping it: costs a read of the whole file
    /// at open, and saves the page-table misses that random access to a
    /// large mapped file makes (renderers jump across the whole volume).
    pub in_memory: bool,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            verify: false,
            cache_bytes: 512 << 20,
            in_memory: false,
        }
    }
}

/// Read and decode a header of either version from the start of `r`.
pub fn read_header_from(r: &mut dyn Read) -> Result<Header> {
    let mut b = [0u8; HEADER_LEN as usize];
    let base = BASE_HEADER_LEN as usize;
    r.read_exact(&mut b[..base])
        .map_err(truncated(".vvol header"))?;
    let len = Header::length_of(&b)? as usize;
    r.read_exact(&mut b[base..len])
        .map_err(truncated(".vvol header"))?;
    Header::decode(&b[..len])
}

/// Header and trailer of a file, checked against its length.
pub fn read_header(path: &Path) -> Result<(Header, Trailer)> {
    read_header_of(&mut File::open(path)?)
}

/// [`read_header`] of an open file (read from its start).
fn read_header_of(f: &mut File) -> Result<(Header, Trailer)> {
    let len = f.metadata()?.len();
    f.seek(SeekFrom::Start(0))?;
    let h = read_header_from(f)?;
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

/// A `.vvol` file's samples as stored: a volume of a type the renderer
/// reads, or `f64` samples kept as they are (what conversions read).
pub enum Stored {
    /// A volume of a type the renderer reads.
    Volume(Volume),
    /// `f64` samples and their description.
    F64(volcore::VolumeMeta, TypedGrid<f64>),
}

/// Open a `.vvol` file: uncompressed layouts are memory-mapped and sampled
/// in place, compressed bricks are decoded on demand. `f64` samples open
/// as `f32`, converted once (see [`OpenSample`]); [`open_stored`] keeps
/// them.
pub fn open(path: &Path, opts: OpenOptions) -> Result<Volume> {
    match open_stored(path, opts)? {
        Stored::Volume(v) => Ok(v),
        Stored::F64(meta, grid) => Ok(f64::open_grid(meta, grid)?),
    }
}

/// [`open`], keeping `f64` samples as they are.
pub fn open_stored(path: &Path, opts: OpenOptions) -> Result<Stored> {
    // One open file for the header, the trailer and the map: a file
    // replaced (renamed over) meanwhile is never read half old, half new.
    let mut file = File::open(path)?;
    let (h, t) = read_header_of(&mut file)?;
    if opts.verify {
        t.check_range(&h)?;
    }
    // SAFETY: the map is read-only; like every reader of mapped files we
    // rely on the file not being truncated by another process meanwhile.
    // A mapped file stays open beside its map for positioned reads.
    let (map, file) = if opts.in_memory {
        (copy_to_memory(file)?, None)
    } else {
        (unsafe { Mmap::map(&file)? }, Some(Arc::new(file)))
    };
    if opts.verify {
        check_reserved(&map, &h)?;
    }
    let map = Arc::new(map);
    let source = MapSource { map, file };
    let mut meta = h.meta;
    if meta.range.is_empty() {
        meta.range = t.range;
    }
    let table = match meta.layout {
        Layout::Sliced => Vec::new(),
        Layout::Bricked(g) => {
            let raw = table_bytes(&h, &source.map)?;
            // Its layout first: a hostile table fails at its first bad
            // entry, without a pass over all of it.
            let table = read_table(&h, g, raw)?;
            if opts.verify && crc32fast::hash(raw) != t.crc32 {
                return Err(Error::Checksum("brick table is damaged".into()));
            }
            if opts.verify {
                check_reserved_entries(raw)?;
            }
            table
        }
    };
    let args = (&h, &t, source, table, opts);
    let as_is = |data| Ok(Stored::Volume(Volume { meta, data }));
    match meta.sample_type {
        SampleType::U8 => as_is(VolumeData::U8(grid::<u8>(args)?)),
        SampleType::U16 => as_is(VolumeData::U16(grid::<u16>(args)?)),
        SampleType::I16 => as_is(VolumeData::I16(grid::<i16>(args)?)),
        SampleType::F32 => as_is(VolumeData::F32(grid::<f32>(args)?)),
        SampleType::F64 => Ok(Stored::F64(meta, grid::<f64>(args)?)),
    }
}

/// The brick table's bytes in `map`: `brick_count` entries right after
/// the header, which must lie inside the file (the header was checked
/// against the file length, so this only guards that check).
fn table_bytes<'a>(h: &Header, map: &'a [u8]) -> Result<&'a [u8]> {
    let len = h.brick_count.checked_mul(ENTRY_LEN);
    let end = len.and_then(|l| l.checked_add(h.header_len));
    end.and_then(|end| map.get(h.header_len as usize..usize::try_from(end).ok()?))
        .ok_or_else(|| {
            Error::invalid(format!(
                "brick table of {} entries does not fit in the {}-byte file",
                h.brick_count,
                map.len()
            ))
        })
}

/// Decode and check a brick table as it is read, so a damaged or hostile
/// table fails at its first bad entry, before the whole of it is held.
///
/// Every entry must lie inside the data section. Uncompressed bricks sit
/// at their fixed places; zstd bricks lie back to back in brick order from
/// the data offset to the end of the data section (as FORMAT.md says and
/// the writers write), each no longer than zstd makes of one brick. So
/// every brick has bytes of its own: the brick count the dims imply is
/// tied to the data actually in the file, and a small file cannot make
/// many entries share one frame to decode to far more than it holds.
fn read_table(h: &Header, g: BrickGeometry, raw: &[u8]) -> Result<Vec<BrickEntry>> {
    let meta = &h.meta;
    let n = g.brick_count();
    if n != h.brick_count || raw.len() as u64 != n.saturating_mul(ENTRY_LEN) {
        return Err(Error::invalid(format!(
            "brick table has {} bytes but {} makes {n} bricks",
            raw.len(),
            meta.dims
        )));
    }
    let brick_bytes = (g.stored_len() as u64)
        .checked_mul(meta.sample_type.size() as u64)
        .ok_or_else(|| Error::invalid("one brick's size overflows"))?;
    let compressed = meta.compression != Compression::None;
    // The longest a brick can be stored: zstd's bound for one brick.
    let most = if compressed {
        let b = usize::try_from(brick_bytes)
            .map_err(|_| Error::invalid("one brick's size overflows"))?;
        zstd::zstd_safe::compress_bound(b) as u64
    } else {
        brick_bytes
    };
    let data_end = h
        .data_offset
        .checked_add(h.data_len)
        .ok_or_else(|| Error::invalid("data length overflows"))?;
    // Each compressed brick takes at least one byte of data: more bricks
    // than data bytes cannot be right, whatever the table says.
    if compressed && n > h.data_len {
        return Err(Error::invalid(format!(
            "{} makes {n} bricks, more than the {} bytes of compressed data can hold",
            meta.dims, h.data_len
        )));
    }
    // Grown as entries pass, not reserved for what the header claims.
    let mut entries: Vec<BrickEntry> = Vec::new();
    let mut at = h.data_offset;
    for (i, c) in raw.chunks_exact(ENTRY_LEN as usize).enumerate() {
        let e = decode_entry(c);
        let end = e.offset.checked_add(e.length);
        if e.offset < h.data_offset || end.is_none_or(|end| end > data_end) {
            return Err(Error::invalid(format!(
                "brick table entry {i} points outside the data ({} bytes at offset {})",
                e.length, e.offset
            )));
        }
        if !compressed {
            if e.offset != h.data_offset + i as u64 * h.brick_stride || e.length != brick_bytes {
                return Err(Error::invalid(format!(
                    "brick table entry {i} does not match the uncompressed layout"
                )));
            }
        } else if e.offset != at || e.length == 0 || e.length > most {
            return Err(Error::invalid(format!(
                "brick table entry {i} ({} bytes at offset {}) is not the next brick: zstd bricks lie back to back from offset {}, 1 to {most} bytes each",
                e.length, e.offset, h.data_offset
            )));
        }
        at = e.offset + e.length;
        entries.try_reserve(1).map_err(|_| {
            Error::invalid(format!(
                "a brick table of {n} entries does not fit in memory"
            ))
        })?;
        entries.push(e);
    }
    if compressed && at != data_end {
        return Err(Error::invalid(format!(
            "the bricks end at offset {at} but the data section ends at {data_end}"
        )));
    }
    Ok(entries)
}

/// The whole file in anonymous memory advised for transparent huge pages.
fn copy_to_memory(mut file: File) -> Result<Mmap> {
    let len = file.metadata()?.len() as usize;
    let mut anon = memmap2::MmapMut::map_anon(len.max(1))?;
    // Advice only: systems without transparent huge pages ignore it.
    #[cfg(target_os = "linux")]
    let _ = anon.advise(memmap2::Advice::HugePage);
    file.seek(SeekFrom::Start(0))?;
    file.read_exact(&mut anon[..len])?;
    Ok(anon.make_read_only()?)
}

/// A map of a whole file and, unless it is an in-memory copy, the file.
struct MapSource {
    map: Arc<Mmap>,
    file: Option<Arc<File>>,
}

impl MapSource {
    /// `len` samples at byte `offset`.
    fn data<T: Sample>(self, offset: u64, len: usize) -> Result<Data<T>> {
        let offset = offset as usize;
        Ok(match self.file {
            Some(file) => Data::mapped_file(self.map, file, offset, len)?,
            None => Data::mapped(self.map, offset, len)?,
        })
    }
}

/// What [`grid`] reads: the checked header and trailer, the map and the
/// brick table.
type GridArgs<'a> = (
    &'a Header,
    &'a Trailer,
    MapSource,
    Vec<BrickEntry>,
    OpenOptions,
);

/// The grid of samples a checked header and map describe.
fn grid<T: Sample>((h, t, source, table, opts): GridArgs<'_>) -> Result<TypedGrid<T>> {
    let map = &source.map;
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
            let data = source.data(h.data_offset, meta.dims.count() as usize)?;
            TypedGrid::Sliced(SlicedGrid::new(meta.dims, data)?)
        }
        // The table was checked against the data section as it was read
        // (read_table).
        Layout::Bricked(g) => match meta.compression {
            Compression::None => {
                if opts.verify {
                    verify_bricks(map, &table)?;
                }
                let len = (h.data_len / size) as usize;
                let data = source.data(h.data_offset, len)?;
                let stride = (h.brick_stride / size) as usize;
                TypedGrid::Bricked(BrickedGrid::new(g, stride, data)?)
            }
            Compression::Zstd(_) => {
                if opts.verify {
                    verify_bricks(map, &table)?;
                }
                let len = map.len();
                let source = source.data::<u8>(0, len)?;
                let grid = CompressedGrid::<T>::new(g, source, table, opts.cache_bytes)?;
                if opts.verify {
                    (0..g.brick_count())
                        .into_par_iter()
                        .try_for_each(|i| grid.decode(i).map(|_| ()))
                        .map_err(Error::Invalid)?;
                }
                TypedGrid::Compressed(grid)
            }
        },
    };
    Ok(grid)
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
    let h = read_header_from(r)?;
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
    t.check_range(&h)?;
    let crc = parallel_crc(&bytes);
    if crc != t.crc32 {
        return Err(Error::Checksum(format!(
            "sample data crc {crc:08x}, trailer says {:08x}",
            t.crc32
        )));
    }
    let mut meta = h.meta;
    meta.range = t.range;
    match meta.sample_type {
        SampleType::U8 => from_bytes::<u8>(meta, bytes),
        SampleType::U16 => from_bytes::<u16>(meta, bytes),
        SampleType::I16 => from_bytes::<i16>(meta, bytes),
        SampleType::F32 => from_bytes::<f32>(meta, bytes),
        SampleType::F64 => from_bytes::<f64>(meta, bytes),
    }
}

/// The volume `meta` describes from its samples as little-endian bytes,
/// in an owned sliced grid (`f64` samples open as `f32`).
pub fn from_bytes<T: OpenSample>(meta: volcore::VolumeMeta, bytes: Vec<u8>) -> Result<Volume> {
    let mut v: Vec<T> = match bytemuck::try_cast_vec(bytes) {
        Ok(v) => v,
        Err((_, bytes)) => bytemuck::pod_collect_to_vec(&bytes),
    };
    T::slice_from_le(&mut v);
    let grid = TypedGrid::Sliced(SlicedGrid::new(meta.dims, Data::Owned(v))?);
    Ok(T::open_grid(meta, grid)?)
}

/// `--verify`: no flag bit this reader does not know and no reserved byte
/// other than 0 (FORMAT.md), in the header and the trailer of the mapped
/// file `map` (the brick table's: [`check_reserved_entries`]); the error
/// names the field.
fn check_reserved(map: &[u8], h: &Header) -> Result<()> {
    let field = |at: usize, what: &str| -> Result<()> {
        let flags = u32::from_le_bytes(map[at..at + 4].try_into().unwrap_or_default());
        if flags & !FLAG_RANGE != 0 {
            return Err(Error::invalid(format!(
                "{what} flags {flags:#010x}: bits this reader does not know (only bit 0, the value range, is defined)"
            )));
        }
        Ok(())
    };
    let zero = |range: std::ops::Range<usize>, what: &str| -> Result<()> {
        match map[range.clone()].iter().position(|&b| b != 0) {
            Some(i) => Err(Error::invalid(format!(
                "{what} byte {} is {:#04x}: reserved bytes must be 0",
                range.start + i,
                map[range.start + i]
            ))),
            None => Ok(()),
        }
    };
    field(12, "header")?;
    zero(62..64, "header reserved")?;
    zero(112..124, "header reserved")?;
    let version = u16::from_le_bytes([map[8], map[9]]);
    match version {
        1 => {}
        // Version 2 holds no unit: its byte is reserved too.
        2 => zero(224..252, "header reserved")?,
        _ => zero(225..252, "header reserved")?,
    }
    let trailer = (h.data_offset + h.data_len) as usize;
    field(trailer + 12, "trailer")
}

/// `--verify`: the reserved bytes of every entry of the brick table `raw`
/// (checked against the data section first, so a hostile table has
/// failed before this pass) are 0.
fn check_reserved_entries(raw: &[u8]) -> Result<()> {
    match raw
        .chunks_exact(ENTRY_LEN as usize)
        .position(|entry| entry[20..24] != [0; 4])
    {
        Some(i) => Err(Error::invalid(format!(
            "brick table entry {i}: its reserved bytes 20..24 must be 0"
        ))),
        None => Ok(()),
    }
}
