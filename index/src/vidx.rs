//! The `.vidx` sidecar file: an index saved next to its volume.
//!
//! Little-endian throughout: a 96-byte header, the histogram counts, then
//! each level's minima and maxima, then a CRC-32 of everything before it.
//! The full layout is in `index/FORMAT.md`. The reader validates every
//! header field and derives every length from checked arithmetic before
//! reading, allocates only as data actually arrives (a short file cannot
//! make it reserve gigabytes), and checks the fingerprint before reading
//! the levels.

use crate::error::IndexError;
use crate::histogram::{Histogram, MAX_BINS};
use crate::index::MinMaxIndex;
use crate::level::{cell_count, level_shapes, Level};
use byteorder::{ByteOrder, LittleEndian, ReadBytesExt, WriteBytesExt};
use std::io::{self, Read, Write};
use volcore::{Dims, SampleType, VolumeMeta};

/// The first eight bytes of every `.vidx` file.
pub const MAGIC: [u8; 8] = *b"VOLKIDX\0";
/// The format version this build writes and reads (2: level bounds in the
/// volume's own sample type; version 1 stored them all as f32).
pub const VERSION: u32 = 2;
/// Size of the fixed header in bytes.
pub const HEADER_LEN: usize = 96;
/// Conventional file extension (without the dot).
pub const EXTENSION: &str = "vidx";

/// Values per read or write of a level array.
const CHUNK: usize = 1 << 14;

/// A writer that keeps a CRC-32 of what passes through it.
struct CrcWriter<W> {
    inner: W,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for CrcWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// A reader that keeps a CRC-32 of what passes through it.
struct CrcReader<R> {
    inner: R,
    crc: crc32fast::Hasher,
}

impl<R: Read> Read for CrcReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }
}

/// Map a short read to [`IndexError::Truncated`] naming `section`.
fn section<T>(r: io::Result<T>, section: &'static str) -> Result<T, IndexError> {
    r.map_err(|e| match e.kind() {
        io::ErrorKind::UnexpectedEof => IndexError::Truncated(section),
        _ => IndexError::Io(e),
    })
}

/// Write level bounds as little-endian values of the volume's sample type
/// `t`, a chunk at a time. Bounds of integer volumes are sample values, so
/// narrowing them is exact (and makes a u8 index a quarter of the size).
fn write_bounds(w: &mut impl Write, values: &[f32], t: SampleType) -> io::Result<()> {
    let size = t.size();
    let mut buf = vec![0u8; size * CHUNK.min(values.len())];
    for part in values.chunks(CHUNK) {
        let bytes = &mut buf[..size * part.len()];
        match t {
            SampleType::U8 => {
                for (b, &v) in bytes.iter_mut().zip(part) {
                    *b = v as u8;
                }
            }
            SampleType::U16 => {
                for (b, &v) in bytes.chunks_exact_mut(2).zip(part) {
                    LittleEndian::write_u16(b, v as u16);
                }
            }
            SampleType::I16 => {
                for (b, &v) in bytes.chunks_exact_mut(2).zip(part) {
                    LittleEndian::write_i16(b, v as i16);
                }
            }
            SampleType::F32 => LittleEndian::write_f32_into(part, bytes),
            SampleType::F64 => {
                for (b, &v) in bytes.chunks_exact_mut(8).zip(part) {
                    LittleEndian::write_f64(b, f64::from(v));
                }
            }
        }
        w.write_all(bytes)?;
    }
    Ok(())
}

/// Read `len` level bounds stored as sample type `t` (see
/// [`write_bounds`]), widened to f32, growing the vector only as data
/// arrives.
fn read_bounds(
    r: &mut impl Read,
    len: usize,
    t: SampleType,
    what: &'static str,
) -> Result<Vec<f32>, IndexError> {
    let size = t.size();
    let mut out = Vec::new();
    let mut buf = vec![0u8; size * CHUNK.min(len)];
    while out.len() < len {
        let n = CHUNK.min(len - out.len());
        let bytes = &mut buf[..size * n];
        section(r.read_exact(bytes), what)?;
        let start = out.len();
        out.resize(start + n, 0.0);
        let dst = &mut out[start..];
        match t {
            SampleType::U8 => {
                for (o, &b) in dst.iter_mut().zip(bytes.iter()) {
                    *o = f32::from(b);
                }
            }
            SampleType::U16 => {
                for (o, b) in dst.iter_mut().zip(bytes.chunks_exact(2)) {
                    *o = f32::from(LittleEndian::read_u16(b));
                }
            }
            SampleType::I16 => {
                for (o, b) in dst.iter_mut().zip(bytes.chunks_exact(2)) {
                    *o = f32::from(LittleEndian::read_i16(b));
                }
            }
            SampleType::F32 => LittleEndian::read_f32_into(bytes, dst),
            SampleType::F64 => {
                for (o, b) in dst.iter_mut().zip(bytes.chunks_exact(8)) {
                    *o = LittleEndian::read_f64(b) as f32;
                }
            }
        }
    }
    Ok(out)
}

/// The fixed header fields.
struct Header {
    sample_type: SampleType,
    dims: Dims,
    cell_edge: u32,
    level_count: u32,
    fingerprint: u64,
    range: (f32, f32),
    hist_lo: f64,
    hist_hi: f64,
    bins: u32,
    nan_count: u64,
}

impl Header {
    fn of(ix: &MinMaxIndex) -> Header {
        let h = ix.histogram();
        Header {
            sample_type: ix.sample_type(),
            dims: ix.dims(),
            cell_edge: ix.cell_edge(),
            level_count: ix.level_count() as u32,
            fingerprint: ix.fingerprint(),
            range: ix.value_range(),
            hist_lo: h.lo(),
            hist_hi: h.hi(),
            bins: h.bins() as u32,
            nan_count: h.nan_count(),
        }
    }

    fn write(&self, w: &mut impl Write) -> io::Result<()> {
        w.write_all(&MAGIC)?;
        w.write_u32::<LittleEndian>(VERSION)?;
        w.write_u8(self.sample_type.code())?;
        w.write_all(&[0; 3])?;
        for d in self.dims.as_array() {
            w.write_u64::<LittleEndian>(d)?;
        }
        w.write_u32::<LittleEndian>(self.cell_edge)?;
        w.write_u32::<LittleEndian>(self.level_count)?;
        w.write_u64::<LittleEndian>(self.fingerprint)?;
        w.write_f32::<LittleEndian>(self.range.0)?;
        w.write_f32::<LittleEndian>(self.range.1)?;
        w.write_f64::<LittleEndian>(self.hist_lo)?;
        w.write_f64::<LittleEndian>(self.hist_hi)?;
        w.write_u32::<LittleEndian>(self.bins)?;
        w.write_u32::<LittleEndian>(0)?;
        w.write_u64::<LittleEndian>(self.nan_count)
    }

    /// Read and validate the header (everything but the fingerprint).
    fn read(r: &mut impl Read) -> Result<Header, IndexError> {
        let mut b = [0u8; HEADER_LEN];
        // A file shorter than the magic is more likely not an index at all.
        let got = read_up_to(r, &mut b)?;
        if got < MAGIC.len() || b[..8] != MAGIC {
            return Err(if got < MAGIC.len() && MAGIC.starts_with(&b[..got]) {
                IndexError::Truncated("header")
            } else {
                IndexError::BadMagic
            });
        }
        let version = LittleEndian::read_u32(&b[8..12]);
        if got >= 12 && version != VERSION {
            return Err(IndexError::Version {
                found: version,
                supported: VERSION,
            });
        }
        if got < HEADER_LEN {
            return Err(IndexError::Truncated("header"));
        }
        let u64_at = |o: usize| LittleEndian::read_u64(&b[o..o + 8]);
        let u32_at = |o: usize| LittleEndian::read_u32(&b[o..o + 4]);
        let sample_type = SampleType::from_code(b[12])
            .ok_or_else(|| IndexError::Corrupt(format!("unknown sample type code {}", b[12])))?;
        let dims = Dims::new(u64_at(16), u64_at(24), u64_at(32))
            .map_err(|e| IndexError::Corrupt(e.to_string()))?;
        let h = Header {
            sample_type,
            dims,
            cell_edge: u32_at(40),
            level_count: u32_at(44),
            fingerprint: u64_at(48),
            range: (
                LittleEndian::read_f32(&b[56..60]),
                LittleEndian::read_f32(&b[60..64]),
            ),
            hist_lo: LittleEndian::read_f64(&b[64..72]),
            hist_hi: LittleEndian::read_f64(&b[72..80]),
            bins: u32_at(80),
            nan_count: u64_at(88),
        };
        h.validate()?;
        Ok(h)
    }

    fn validate(&self) -> Result<(), IndexError> {
        use crate::build::{MAX_CELL_EDGE, MIN_CELL_EDGE};
        let bad = |m: String| Err(IndexError::Corrupt(m));
        if !(MIN_CELL_EDGE..=MAX_CELL_EDGE).contains(&self.cell_edge) {
            return bad(format!("cell edge {} is out of range", self.cell_edge));
        }
        let levels = level_shapes(self.dims, self.cell_edge).len();
        if self.level_count as usize != levels {
            return bad(format!(
                "{} levels, but a {} volume with cell edge {} has {levels}",
                self.level_count, self.dims, self.cell_edge
            ));
        }
        if !(1..=MAX_BINS).contains(&self.bins) {
            return bad(format!("{} histogram bins is out of range", self.bins));
        }
        let (lo, hi) = self.range;
        let (hlo, hhi) = (self.hist_lo, self.hist_hi);
        if lo.is_nan() || hi.is_nan() || hlo.is_nan() || hhi.is_nan() || hlo > hhi {
            return bad("value range or histogram range is NaN or reversed".into());
        }
        Ok(())
    }
}

/// Fill as much of `buf` as the reader gives; the count read.
fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> Result<usize, IndexError> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(IndexError::Io(e)),
        }
    }
    Ok(got)
}

impl MinMaxIndex {
    /// Write the index in `.vidx` format. Writes in chunks; wrap files in a
    /// `BufWriter` anyway to keep the header's small writes cheap.
    pub fn write_to(&self, w: &mut impl Write) -> Result<(), IndexError> {
        let mut w = CrcWriter {
            inner: w,
            crc: crc32fast::Hasher::new(),
        };
        Header::of(self).write(&mut w)?;
        for &c in self.histogram().counts() {
            w.write_u64::<LittleEndian>(c)?;
        }
        let t = self.sample_type();
        for l in self.levels() {
            write_bounds(&mut w, l.min(), t)?;
            write_bounds(&mut w, l.max(), t)?;
        }
        let crc = w.crc.clone().finalize();
        w.inner.write_u32::<LittleEndian>(crc)?;
        Ok(())
    }

    /// Read an index in `.vidx` format. With `expected_fingerprint`, an
    /// index of another volume is rejected before its levels are read.
    pub fn read_from(
        r: &mut impl Read,
        expected_fingerprint: Option<u64>,
    ) -> Result<MinMaxIndex, IndexError> {
        read(r, expected_fingerprint, None)
    }

    /// Read the index of the volume described by `meta` with fingerprint
    /// `fingerprint`, rejecting one of other dimensions, sample type or
    /// fingerprint.
    pub fn read_for_volume(
        r: &mut impl Read,
        meta: &VolumeMeta,
        fingerprint: u64,
    ) -> Result<MinMaxIndex, IndexError> {
        read(r, Some(fingerprint), Some((meta.dims, meta.sample_type)))
    }
}

fn read(
    r: &mut impl Read,
    fingerprint: Option<u64>,
    volume: Option<(Dims, SampleType)>,
) -> Result<MinMaxIndex, IndexError> {
    let mut r = CrcReader {
        inner: r,
        crc: crc32fast::Hasher::new(),
    };
    let h = Header::read(&mut r)?;
    if let Some(expected) = fingerprint {
        if h.fingerprint != expected {
            return Err(IndexError::Fingerprint {
                found: h.fingerprint,
                expected,
            });
        }
    }
    if let Some((dims, sample_type)) = volume {
        if h.dims != dims {
            return Err(IndexError::Dims {
                found: h.dims,
                expected: dims,
            });
        }
        if h.sample_type != sample_type {
            return Err(IndexError::SampleType {
                found: h.sample_type,
                expected: sample_type,
            });
        }
    }
    let mut counts = Vec::with_capacity(h.bins as usize);
    for _ in 0..h.bins {
        counts.push(section(r.read_u64::<LittleEndian>(), "histogram")?);
    }
    let shapes = level_shapes(h.dims, h.cell_edge);
    let mut levels = Vec::with_capacity(shapes.len());
    for (l, &cells) in shapes.iter().enumerate() {
        let n = cell_count(cells)?;
        let min = read_bounds(&mut r, n, h.sample_type, "level data")?;
        let max = read_bounds(&mut r, n, h.sample_type, "level data")?;
        levels.push(Level::from_parts(
            cells,
            u64::from(h.cell_edge) << l,
            min,
            max,
        )?);
    }
    let computed = r.crc.clone().finalize();
    let stored = section(r.inner.read_u32::<LittleEndian>(), "checksum")?;
    if stored != computed {
        return Err(IndexError::Corrupt(format!(
            "checksum {computed:08x} does not match the stored {stored:08x}"
        )));
    }
    check_contents(&h, &counts, &levels)?;
    let hist = Histogram::from_parts(h.hist_lo, h.hist_hi, counts, h.nan_count);
    MinMaxIndex::from_parts(h.dims, h.sample_type, h.fingerprint, h.range, hist, levels)
}

/// Checks a checksum cannot make: the histogram accounts for every voxel
/// and no cell bound is NaN.
fn check_contents(h: &Header, counts: &[u64], levels: &[Level]) -> Result<(), IndexError> {
    let total = counts
        .iter()
        .try_fold(h.nan_count, |a, &c| a.checked_add(c));
    if total != Some(h.dims.count()) {
        return Err(IndexError::Corrupt(format!(
            "histogram counts {} samples, the volume has {}",
            total.map_or("more than 2^64".into(), |t| t.to_string()),
            h.dims.count()
        )));
    }
    for (l, lv) in levels.iter().enumerate() {
        if lv.min().iter().chain(lv.max()).any(|v| v.is_nan()) {
            return Err(IndexError::Corrupt(format!("level {l} holds NaN bounds")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{random_samples, volume};
    use crate::BuildOptions;

    /// Bounds narrow to the sample type exactly as Rust's saturating casts
    /// would, at the type's ends, past them, at infinities and NaN.
    #[test]
    fn bounds_narrow_like_saturating_casts() {
        let v = [
            f32::NEG_INFINITY,
            -1e9,
            -32769.0,
            -32768.0,
            -1.0,
            -0.5,
            0.0,
            0.5,
            1.0,
            254.9,
            255.0,
            256.0,
            32767.0,
            32768.0,
            65535.0,
            65536.0,
            1e9,
            f32::INFINITY,
            f32::NAN,
        ];
        let encode = |t| {
            let mut out = Vec::new();
            write_bounds(&mut out, &v, t).unwrap();
            out
        };
        let u8s: Vec<u8> = v.iter().map(|&x| x as u8).collect();
        assert_eq!(encode(SampleType::U8), u8s);
        let u16s: Vec<u8> = v.iter().flat_map(|&x| (x as u16).to_le_bytes()).collect();
        assert_eq!(encode(SampleType::U16), u16s);
        let i16s: Vec<u8> = v.iter().flat_map(|&x| (x as i16).to_le_bytes()).collect();
        assert_eq!(encode(SampleType::I16), i16s);
    }

    fn sample_index(fingerprint: u64) -> (MinMaxIndex, Vec<u8>) {
        let dims = Dims::new(19, 11, 7).unwrap();
        let vol = volume::<f32>(dims, random_samples(dims, 4, 0));
        let opts = BuildOptions {
            cell_edge: 4,
            ..BuildOptions::default()
        };
        let ix = MinMaxIndex::build_volume(&vol, &opts, fingerprint).unwrap();
        let mut bytes = Vec::new();
        ix.write_to(&mut bytes).unwrap();
        (ix, bytes)
    }

    fn same(a: &MinMaxIndex, b: &MinMaxIndex) {
        assert_eq!(a.dims(), b.dims());
        assert_eq!(a.sample_type(), b.sample_type());
        assert_eq!(a.fingerprint(), b.fingerprint());
        assert_eq!(a.cell_edge(), b.cell_edge());
        assert_eq!(a.histogram(), b.histogram());
        let bits = |v: (f32, f32)| (v.0.to_bits(), v.1.to_bits());
        assert_eq!(bits(a.value_range()), bits(b.value_range()));
        assert_eq!(a.level_count(), b.level_count());
        for (x, y) in a.levels().iter().zip(b.levels()) {
            assert_eq!((x.cells(), x.edge()), (y.cells(), y.edge()));
            let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(x.min()), bits(y.min()));
            assert_eq!(bits(x.max()), bits(y.max()));
        }
    }

    #[test]
    fn round_trip_keeps_every_bit() {
        let (ix, bytes) = sample_index(0xDEAD_BEEF_0123_4567);
        let cells: usize = ix.levels().iter().map(|l| l.len()).sum();
        assert_eq!(
            bytes.len(),
            HEADER_LEN + 8 * ix.histogram().bins() + 8 * cells + 4
        );
        assert_eq!(&bytes[..8], b"VOLKIDX\0");
        let back = MinMaxIndex::read_from(&mut &bytes[..], Some(0xDEAD_BEEF_0123_4567)).unwrap();
        same(&ix, &back);
        let back = MinMaxIndex::read_from(&mut &bytes[..], None).unwrap();
        let mut again = Vec::new();
        back.write_to(&mut again).unwrap();
        assert!(again == bytes);
    }

    #[test]
    fn round_trip_for_integer_types() {
        let dims = Dims::new(9, 1, 9).unwrap();
        let vols = [
            volume::<u8>(dims, random_samples(dims, 1, 0)),
            volume::<u16>(dims, random_samples(dims, 1, 1)),
            volume::<i16>(dims, random_samples(dims, 1, 1)),
        ];
        for vol in &vols {
            let ix = MinMaxIndex::build_volume(vol, &BuildOptions::default(), 3).unwrap();
            let mut bytes = Vec::new();
            ix.write_to(&mut bytes).unwrap();
            let back = MinMaxIndex::read_for_volume(&mut &bytes[..], &vol.meta, 3).unwrap();
            same(&ix, &back);
            // Level bounds take the sample type's size, not an f32's.
            let cells: usize = ix.levels().iter().map(|l| l.min().len()).sum();
            let bins = ix.histogram().counts().len();
            let size = vol.meta.sample_type.size();
            assert_eq!(bytes.len(), HEADER_LEN + 8 * bins + 2 * cells * size + 4);
        }
    }

    #[test]
    fn truncated_files_are_rejected() {
        let (_, bytes) = sample_index(1);
        for len in 0..bytes.len() {
            let err = MinMaxIndex::read_from(&mut &bytes[..len], Some(1)).unwrap_err();
            assert!(matches!(err, IndexError::Truncated(_)), "{len}: {err}");
        }
        let err = MinMaxIndex::read_from(&mut &bytes[..HEADER_LEN + 3], None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "index file is truncated: it ends inside the histogram"
        );
    }

    #[test]
    fn wrong_fingerprint_dims_or_type_is_rejected() {
        let (ix, bytes) = sample_index(1);
        let err = MinMaxIndex::read_from(&mut &bytes[..], Some(2)).unwrap_err();
        assert!(matches!(
            err,
            IndexError::Fingerprint {
                found: 1,
                expected: 2
            }
        ));
        assert!(err.to_string().contains("another volume"), "{err}");
        // The levels are not read: a file cut after the header still says so.
        let err = MinMaxIndex::read_from(&mut &bytes[..HEADER_LEN], Some(2)).unwrap_err();
        assert!(matches!(err, IndexError::Fingerprint { .. }));

        let mut meta = VolumeMeta::sliced(Dims::new(19, 11, 8).unwrap(), SampleType::F32);
        let err = MinMaxIndex::read_for_volume(&mut &bytes[..], &meta, 1).unwrap_err();
        assert_eq!(
            err.to_string(),
            "index is for a 19x11x7 volume, but the volume is 19x11x8"
        );
        meta.dims = ix.dims();
        meta.sample_type = SampleType::U16;
        let err = MinMaxIndex::read_for_volume(&mut &bytes[..], &meta, 1).unwrap_err();
        assert!(matches!(err, IndexError::SampleType { .. }), "{err}");
        assert!(ix.check_volume(ix.dims(), SampleType::U16).is_err());
        assert!(ix.check_volume(ix.dims(), SampleType::F32).is_ok());
    }

    #[test]
    fn bad_magic_version_fields_and_checksum_are_rejected() {
        let (_, bytes) = sample_index(1);
        let read = |b: &[u8]| MinMaxIndex::read_from(&mut &b[..], None).unwrap_err();
        let patched = |off: usize, v: &[u8]| {
            let mut b = bytes.clone();
            b[off..off + v.len()].copy_from_slice(v);
            b
        };
        assert!(matches!(
            read(&patched(0, b"VOLKVOL\0")),
            IndexError::BadMagic
        ));
        assert!(matches!(read(b"hello"), IndexError::BadMagic));
        assert!(matches!(
            read(&patched(8, &1u32.to_le_bytes())),
            IndexError::Version { found: 1, .. }
        ));
        let corrupt = |b: &[u8]| matches!(read(b), IndexError::Corrupt(_));
        assert!(corrupt(&patched(12, &[9]))); // sample type code
        assert!(corrupt(&patched(16, &0u64.to_le_bytes()))); // zero dimension
        assert!(corrupt(&patched(16, &(1u64 << 40).to_le_bytes()))); // huge dimension
        assert!(corrupt(&patched(40, &1u32.to_le_bytes()))); // cell edge
        assert!(corrupt(&patched(44, &9u32.to_le_bytes()))); // level count
        assert!(corrupt(&patched(80, &0u32.to_le_bytes()))); // no bins
        assert!(corrupt(&patched(80, &u32::MAX.to_le_bytes()))); // too many bins
        let last = bytes.len() - 10;
        let flipped = patched(last, &[bytes[last] ^ 1]);
        let err = read(&flipped);
        assert!(err.to_string().contains("checksum"), "{err}");
    }

    #[test]
    fn huge_claimed_sizes_fail_without_huge_allocations() {
        // A header claiming a 2^24 x 2^20 x 2 volume (2^40 cells of edge 2)
        // followed by nothing must fail as truncated, not abort.
        let (_, bytes) = sample_index(1);
        let mut b = bytes[..HEADER_LEN].to_vec();
        b[16..24].copy_from_slice(&(1u64 << 24).to_le_bytes());
        b[24..32].copy_from_slice(&(1u64 << 20).to_le_bytes());
        b[32..40].copy_from_slice(&2u64.to_le_bytes());
        b[40..44].copy_from_slice(&2u32.to_le_bytes());
        b[44..48].copy_from_slice(&24u32.to_le_bytes());
        b.extend(std::iter::repeat_n(0, 8 * 256 + 1000));
        let err = MinMaxIndex::read_from(&mut &b[..], None).unwrap_err();
        assert!(matches!(err, IndexError::Truncated("level data")), "{err}");
    }
}
