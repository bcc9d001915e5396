//! Parallel production, in-order writing.

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::sync::mpsc::sync_channel;

/// Produce items `0..count` in parallel batches of `batch` and hand them to
/// `consume` strictly in index order, on a separate thread, so that
/// producing the next batch overlaps writing the last. At most about three
/// batches are alive at once. The first error from either side stops both.
pub fn ordered<I, P, C>(count: u64, batch: usize, produce: P, mut consume: C) -> Result<()>
where
    I: Send,
    P: Fn(u64) -> Result<I> + Sync,
    C: FnMut(I) -> Result<()> + Send,
{
    let batch = batch.max(1) as u64;
    let (tx, rx) = sync_channel::<Vec<I>>(1);
    std::thread::scope(|scope| {
        let writer = scope.spawn(move || -> Result<()> {
            for items in rx {
                for item in items {
                    consume(item)?;
                }
            }
            Ok(())
        });
        let mut start = 0;
        let mut produced: Result<()> = Ok(());
        while start < count {
            let end = (start + batch).min(count);
            match (start..end)
                .into_par_iter()
                .map(&produce)
                .collect::<Result<Vec<I>>>()
            {
                Ok(items) => {
                    if tx.send(items).is_err() {
                        break; // the writer failed; its error is reported below
                    }
                }
                Err(e) => {
                    produced = Err(e);
                    break;
                }
            }
            start = end;
        }
        drop(tx);
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(Error::invalid("writer thread panicked")));
        produced.and(written)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_order_and_reports_errors() {
        let mut seen = Vec::new();
        ordered(
            1000,
            7,
            |i| Ok(i * 2),
            |v| {
                seen.push(v);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(seen, (0..1000).map(|i| i * 2).collect::<Vec<_>>());

        let r = ordered(
            100,
            3,
            |i| {
                if i == 50 {
                    Err(Error::invalid("boom"))
                } else {
                    Ok(i)
                }
            },
            |_| Ok(()),
        );
        assert!(r.is_err());
        let r = ordered(100, 3, Ok, |v| {
            if v == 10 {
                Err(Error::invalid("disk full"))
            } else {
                Ok(())
            }
        });
        assert!(r.unwrap_err().to_string().contains("disk full"));
    }
}

/// Target bytes produced per work item.
pub const ITEM_BYTES: u64 = 1 << 20;
/// Items per parallel batch.
pub const BATCH_ITEMS: usize = 16;

/// What [`write_rows`] wrote.
#[derive(Clone, Debug)]
pub struct RowsWritten {
    /// Sample bytes written.
    pub bytes: u64,
    /// CRC-32 state over those bytes (combinable with other runs).
    pub crc: crc32fast::Hasher,
    /// Value range of the samples (NaN ignored).
    pub range: volcore::ValueRange,
}

struct Chunk {
    /// Sample storage as 8-byte words (aligned for every sample type).
    words: Vec<u64>,
    /// Bytes of samples in `words`.
    bytes: usize,
    crc: crc32fast::Hasher,
    range: volcore::ValueRange,
}

/// Write buffers kept for reuse by every [`write_rows`] call in the
/// process: fresh allocations of this size are new pages each time, and
/// faulting them in costs more than generating simple scenes. Stored as
/// `u64` words so one pool serves every sample type.
static POOL: std::sync::Mutex<Vec<Vec<u64>>> = std::sync::Mutex::new(Vec::new());
/// Buffers the pool keeps at most (a few batches' worth).
const POOL_MAX: usize = 4 * BATCH_ITEMS;

fn take_buffer(bytes: usize) -> Vec<u64> {
    let mut v = POOL
        .lock()
        .ok()
        .and_then(|mut p| p.pop())
        .unwrap_or_default();
    let words = bytes.div_ceil(8);
    if v.len() < words {
        v.resize(words, 0);
    } else {
        v.truncate(words);
    }
    v
}

fn give_buffer(v: Vec<u64>) {
    if let Ok(mut p) = POOL.lock() {
        if p.len() < POOL_MAX {
            p.push(v);
        }
    }
}

/// Write rows `rows` of `src` (row `r` is `(y, z) = (r % Y, r / Y)`) in
/// sliced order (x fastest), little-endian, produced in parallel and written
/// in order. `progress` gets the bytes written so far by this call.
pub fn write_rows<R, W>(
    src: &R,
    rows: std::ops::Range<u64>,
    out: &mut W,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RowsWritten>
where
    R: volcore::RegionSource,
    W: std::io::Write + Send + ?Sized,
{
    use volcore::Sample;
    let d = src.dims();
    let row_bytes = d.x * R::Sample::TYPE.size() as u64;
    let row0 = rows.start;
    let rows = rows.end.saturating_sub(rows.start);
    let rows_per_item = (ITEM_BYTES / row_bytes).max(1);
    let items = rows.div_ceil(rows_per_item);
    let mut crc = crc32fast::Hasher::new();
    let mut range = volcore::ValueRange::EMPTY;
    let mut written = 0u64;
    let size = R::Sample::TYPE.size();
    let produce = |item: u64| -> Result<Chunk> {
        let first = item * rows_per_item;
        let n = rows_per_item.min(rows - first);
        let len = (n * d.x) as usize;
        let mut words = take_buffer(len * size);
        let samples: &mut [R::Sample] =
            &mut bytemuck::cast_slice_mut::<u64, R::Sample>(&mut words)[..len];
        for (r, row) in samples.chunks_exact_mut(d.x as usize).enumerate() {
            let row_id = row0 + first + r as u64;
            src.fill_row(0, row_id % d.y, row_id / d.y, row);
        }
        let mut h = crc32fast::Hasher::new();
        h.update(bytemuck::cast_slice(samples));
        let range = volcore::ValueRange::of(samples);
        Ok(Chunk {
            words,
            bytes: len * size,
            crc: h,
            range,
        })
    };
    ordered(items, BATCH_ITEMS, produce, |c: Chunk| {
        out.write_all(&bytemuck::cast_slice::<u64, u8>(&c.words)[..c.bytes])?;
        crc.combine(&c.crc);
        range = range.merge(c.range);
        written += c.bytes as u64;
        progress(written);
        give_buffer(c.words);
        Ok(())
    })?;
    Ok(RowsWritten {
        bytes: written,
        crc,
        range,
    })
}
