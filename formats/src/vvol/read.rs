//! Opening `.vvol` files and streams.

use super::{decode_table, Header, Trailer, BASE_HEADER_LEN, ENTRY_LEN, HEADER_LEN, TRAILER_LEN};
use crate::error::{truncated, Error, Result};
use memmap2::Mmap;
use rayon::prelude::*;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;
use volcore::grid::BrickEntry;
use volcore::volume::{IntoVolumeData, TypedGrid};
use volcore::{
    BrickedGrid, CompressedGrid, Compression, Data, Dims, Layout, Sample, SampleType, SlicedGrid,
    Volume,
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
    let mut f = File::open(path)?;
    let len = f.metadata()?.len();
    let h = read_header_from(&mut f)?;
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
    // A mapped file stays open beside its map for positioned reads.
    let (map, file) = if opts.in_memory {
        (copy_to_memory(file)?, None)
    } else {
        (unsafe { Mmap::map(&file)? }, Some(Arc::new(file)))
    };
    let map = Arc::new(map);
    let source = MapSource { map, file };
    let mut meta = h.meta;
    if meta.range.is_empty() {
        meta.range = t.range;
    }
    let table = match meta.layout {
        Layout::Sliced => Vec::new(),
        Layout::Bricked(_) => {
            let end = (h.header_len + h.brick_count * ENTRY_LEN) as usize;
            let raw = &source.map[h.header_len as usize..end];
            if opts.verify && crc32fast::hash(raw) != t.crc32 {
                return Err(Error::Checksum("brick table is damaged".into()));
            }
            decode_table(raw)
        }
    };
    let data = match meta.sample_type {
        SampleType::U8 => build::<u8>(&h, &t, source, table, opts)?,
        SampleType::U16 => build::<u16>(&h, &t, source, table, opts)?,
        SampleType::I16 => build::<i16>(&h, &t, source, table, opts)?,
        SampleType::F32 => build::<f32>(&h, &t, source, table, opts)?,
    };
    Ok(Volume { meta, data })
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

fn build<T: IntoVolumeData>(
    h: &Header,
    t: &Trailer,
    source: MapSource,
    table: Vec<BrickEntry>,
    opts: OpenOptions,
) -> Result<volcore::VolumeData> {
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
