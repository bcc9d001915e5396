//! Writing `.vvol` files and streams, all at once or unit by unit.

use super::{encode_table, part, Header, Trailer, ENTRY_LEN, HEADER_LEN, TRAILER_LEN};
use crate::error::{Error, Result};
use crate::output::Sink;
use crate::pipeline::{ordered, write_rows, ITEM_BYTES};
use std::io::{Seek, SeekFrom, Write};
use std::ops::Range;
use volcore::grid::BrickEntry;
use volcore::region::{fill_brick, RegionSource};
use volcore::{BrickGeometry, Compression, Layout, Sample, Shard, ValueRange, VolumeMeta};

/// What a writer did.
#[derive(Clone, Copy, Debug)]
pub struct WriteStats {
    /// Bytes written in all.
    pub bytes: u64,
    /// Exact value range of the samples written.
    pub range: ValueRange,
}

/// Write all of `src` as a `.vvol` with the layout and compression of
/// `meta` (dims and sample type must match `src`; the range is recomputed).
/// Sliced volumes may go to a stream; bricked ones need a file. `progress`
/// is called with the uncompressed sample bytes done.
pub fn write<'a, R: RegionSource>(
    src: &R,
    meta: VolumeMeta,
    sink: Sink<'a>,
    progress: &'a (dyn Fn(u64) + Sync),
) -> Result<WriteStats> {
    if meta.dims != src.dims() || meta.sample_type != R::Sample::TYPE {
        return Err(Error::invalid("writer metadata does not match its source"));
    }
    let mut w = VvolWriter::new(sink, meta, progress)?;
    w.write_rest(src)?;
    w.finish()
}

enum State {
    Sliced {
        crc: crc32fast::Hasher,
        next_z: u64,
    },
    Bricked {
        geom: BrickGeometry,
        entries: Vec<BrickEntry>,
        offset: u64,
        level: Option<i32>,
        next_layer: u64,
    },
}

/// An incremental `.vvol` writer. Each [`VvolWriter::write_next`] writes one
/// unit (a slab of slices, or one layer of bricks) and needs its source to
/// serve only the slices [`VvolWriter::next_slices`] names, so a converter
/// reading slices in order keeps just that window in memory.
pub struct VvolWriter<'a> {
    sink: Sink<'a>,
    header: Header,
    state: State,
    /// The units (slices when sliced, brick layers when bricked) this
    /// writer writes: all of them, or one shard's.
    units: Range<u64>,
    /// Writing one shard's part file rather than a whole `.vvol`.
    part: Option<Shard>,
    range: ValueRange,
    done_bytes: u64,
    progress: &'a (dyn Fn(u64) + Sync),
}

/// Slices per sliced unit: about 16 MiB, at least one slice.
fn slab_slices(meta: &VolumeMeta) -> u64 {
    let slice = meta.dims.slice_len() * meta.sample_type.size() as u64;
    ((16 * ITEM_BYTES) / slice.max(1)).max(1)
}

impl<'a> VvolWriter<'a> {
    /// Start a file or stream for `meta` (its range is ignored): writes
    /// the header and, for bricked files, room for the brick table.
    pub fn new(
        sink: Sink<'a>,
        meta: VolumeMeta,
        progress: &'a (dyn Fn(u64) + Sync),
    ) -> Result<VvolWriter<'a>> {
        VvolWriter::start(sink, meta, None, progress)
    }

    /// Start the part file of `shard` of the `.vvol` that `meta` describes
    /// (see [`super::part`]): it holds that shard's slices (sliced) or brick
    /// layers (bricked) and is assembled with the others by
    /// [`super::part::merge`]. Parts are files (`sink` a [`Sink::File`] or
    /// [`Sink::OwnedFile`]): the header is written last.
    pub fn new_part(
        sink: Sink<'a>,
        meta: VolumeMeta,
        shard: Shard,
        progress: &'a (dyn Fn(u64) + Sync),
    ) -> Result<VvolWriter<'a>> {
        if !sink.is_file() {
            return Err(Error::invalid(
                "a part is written to a file (internal error)",
            ));
        }
        VvolWriter::start(sink, meta, Some(shard), progress)
    }

    fn start(
        mut sink: Sink<'a>,
        meta: VolumeMeta,
        part: Option<Shard>,
        progress: &'a (dyn Fn(u64) + Sync),
    ) -> Result<VvolWriter<'a>> {
        let mut meta = meta;
        meta.range = ValueRange::EMPTY;
        let header = Header::for_meta(meta)?;
        let units = match part {
            Some(shard) => shard.units(part::unit_count(&meta)),
            None => 0..part::unit_count(&meta),
        };
        let state = match meta.layout {
            Layout::Sliced => State::Sliced {
                crc: crc32fast::Hasher::new(),
                next_z: units.start,
            },
            Layout::Bricked(geom) => {
                if !sink.is_file() {
                    return Err(Error::invalid(
                        "bricked .vvol files cannot be written to a stream; use a file or --layout sliced",
                    ));
                }
                State::Bricked {
                    geom,
                    entries: Vec::with_capacity(
                        ((units.end - units.start) * geom.counts()[0] * geom.counts()[1]) as usize,
                    ),
                    offset: match part {
                        Some(_) => part::DATA_OFFSET,
                        None => header.data_offset,
                    },
                    level: match meta.compression {
                        Compression::Zstd(l) => Some(l),
                        Compression::None => None,
                    },
                    next_layer: units.start,
                }
            }
        };
        let out = sink.writer();
        if part.is_some() {
            write_zeros(out, part::DATA_OFFSET)?;
        } else {
            out.write_all(&header.encode())?;
            if let State::Bricked { .. } = state {
                write_zeros(out, header.data_offset - header.header_len)?;
            }
        }
        Ok(VvolWriter {
            sink,
            header,
            state,
            units,
            part,
            range: ValueRange::EMPTY,
            done_bytes: 0,
            progress,
        })
    }

    /// The slices (z range, clamped to the volume) the next unit reads;
    /// empty when everything has been written.
    pub fn next_slices(&self) -> Range<u64> {
        let d = self.header.meta.dims;
        match &self.state {
            State::Sliced { next_z, .. } => {
                *next_z..(*next_z + slab_slices(&self.header.meta)).min(self.units.end)
            }
            State::Bricked {
                geom, next_layer, ..
            } => {
                if *next_layer >= self.units.end {
                    return d.z..d.z;
                }
                let b = geom.brick() as u64;
                let lo = (*next_layer * b).saturating_sub(volcore::brick::APRON_LO as u64);
                let hi = (*next_layer * b + b + volcore::brick::APRON_HI as u64).min(d.z);
                lo..hi
            }
        }
    }

    /// Write every unit not written yet from `src`, which must serve all
    /// their slices. Sliced output goes through one pipeline from the
    /// first slice to the last, so that producing slices overlaps writing
    /// them throughout instead of stopping at the end of every unit.
    pub fn write_rest<R: RegionSource>(&mut self, src: &R) -> Result<()> {
        if let State::Sliced { next_z, .. } = self.state {
            return self.write_slices(src, next_z..self.units.end);
        }
        while !self.next_slices().is_empty() {
            self.write_next(src)?;
        }
        Ok(())
    }

    /// Write slices `zs` of a sliced volume, the next ones due.
    fn write_slices<R: RegionSource>(&mut self, src: &R, zs: Range<u64>) -> Result<()> {
        let State::Sliced { crc, next_z } = &mut self.state else {
            return Err(Error::invalid(
                "slices written to a bricked .vvol (internal error)",
            ));
        };
        if zs.is_empty() {
            return Ok(());
        }
        let base = self.done_bytes;
        let progress = self.progress;
        let out = self.sink.writer();
        let d = self.header.meta.dims;
        let rows = (zs.start * d.y)..(zs.end * d.y);
        let w = write_rows(src, rows, out, &|n| progress(base + n))?;
        crc.combine(&w.crc);
        self.range = self.range.merge(w.range);
        self.done_bytes += w.bytes;
        *next_z = zs.end;
        Ok(())
    }

    /// Write the next unit from `src`, which must serve every row of the
    /// slices in [`VvolWriter::next_slices`].
    pub fn write_next<R: RegionSource>(&mut self, src: &R) -> Result<()> {
        let zs = self.next_slices();
        if zs.is_empty() {
            return Ok(());
        }
        match self.state {
            State::Sliced { .. } => self.write_slices(src, zs),
            State::Bricked { .. } => self.write_layer(src),
        }
    }

    /// Write the next layer of bricks of a bricked volume.
    fn write_layer<R: RegionSource>(&mut self, src: &R) -> Result<()> {
        let progress = self.progress;
        let out = self.sink.writer();
        let State::Bricked {
            geom,
            entries,
            offset,
            level,
            next_layer,
        } = &mut self.state
        else {
            return Err(Error::invalid(
                "bricks written to a sliced .vvol (internal error)",
            ));
        };
        let geom = *geom;
        let level = *level;
        let size = R::Sample::TYPE.size() as u64;
        let raw_len = geom.stored_len() as u64 * size;
        let stride = self.header.brick_stride;
        let per_layer = geom.counts()[0] * geom.counts()[1];
        let first = *next_layer * per_layer;
        let produce = |i: u64| -> Result<(Vec<u8>, ValueRange)> {
            let id = first + i;
            let mut samples = vec![R::Sample::default(); geom.stored_len()];
            fill_brick(src, &geom, geom.brick_coords(id), &mut samples);
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
        let range = &mut self.range;
        let done = &mut self.done_bytes;
        ordered(
            per_layer,
            batch,
            produce,
            |(bytes, r): (Vec<u8>, ValueRange)| {
                let len = if level.is_some() {
                    bytes.len() as u64
                } else {
                    raw_len
                };
                entries.push(BrickEntry {
                    offset: *offset,
                    length: len,
                    crc32: crc32fast::hash(&bytes[..len as usize]),
                });
                out.write_all(&bytes)?;
                *offset += bytes.len() as u64;
                *range = range.merge(r);
                *done += raw_len;
                progress(*done);
                Ok(())
            },
        )?;
        *next_layer += 1;
        Ok(())
    }

    /// Write the trailer, and for files complete the header (value range,
    /// data length) and the brick table. Fails if units are missing.
    pub fn finish(mut self) -> Result<WriteStats> {
        if !self.next_slices().is_empty() {
            return Err(Error::invalid(
                "writer finished before all samples were written",
            ));
        }
        if let Some(shard) = self.part {
            return self.finish_part(shard);
        }
        let mut h = self.header.clone();
        h.meta.range = self.range;
        let (crc32, table) = match &self.state {
            State::Sliced { crc, .. } => (crc.clone().finalize(), None),
            State::Bricked {
                entries, offset, ..
            } => {
                let table = encode_table(entries);
                debug_assert_eq!(table.len() as u64, h.brick_count * ENTRY_LEN);
                h.data_len = offset - h.data_offset;
                (crc32fast::hash(&table), Some(table))
            }
        };
        let trailer = Trailer {
            crc32,
            range: self.range,
        };
        self.sink.writer().write_all(&trailer.encode())?;
        if let Some(f) = self.sink.file() {
            f.seek(SeekFrom::Start(0))?;
            f.write_all(&h.encode())?;
            if let Some(t) = &table {
                f.write_all(t)?;
            }
            f.seek(SeekFrom::End(0))?;
        }
        self.sink.writer().flush()?;
        Ok(WriteStats {
            bytes: h.file_len().unwrap_or(0).max(HEADER_LEN + TRAILER_LEN),
            range: self.range,
        })
    }
}

impl VvolWriter<'_> {
    /// [`VvolWriter::finish`] for a part file: the brick table (bricked)
    /// after the data, then the part header in front.
    fn finish_part(mut self, shard: Shard) -> Result<WriteStats> {
        let (data_len, crc32, table) = match &self.state {
            State::Sliced { crc, .. } => (self.done_bytes, crc.clone().finalize(), Vec::new()),
            State::Bricked {
                entries, offset, ..
            } => {
                let table = encode_table(entries);
                (*offset - part::DATA_OFFSET, crc32fast::hash(&table), table)
            }
        };
        let mut meta = self.header.meta;
        meta.range = self.range;
        let head = part::PartHeader {
            shard,
            units: self.units.clone(),
            data_len,
            crc32,
            volume: Header::for_meta(meta)?,
        };
        let Some(f) = self.sink.file() else {
            return Err(Error::invalid(
                "a part is written to a file (internal error)",
            ));
        };
        f.write_all(&table)?;
        f.seek(SeekFrom::Start(0))?;
        f.write_all(&head.encode())?;
        f.seek(SeekFrom::End(0))?;
        f.flush()?;
        Ok(WriteStats {
            bytes: part::DATA_OFFSET + data_len + table.len() as u64,
            range: self.range,
        })
    }
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

fn write_zeros(w: &mut (dyn Write + Send), mut n: u64) -> std::io::Result<()> {
    let zeros = [0u8; 64 * 1024];
    while n > 0 {
        let k = n.min(zeros.len() as u64) as usize;
        w.write_all(&zeros[..k])?;
        n -= k as u64;
    }
    Ok(())
}
