//! Sharded index builds: shard `K` of `N` scans only the level-0 cell
//! layers it owns (plus the one slice of apron after them) into an
//! [`IndexPart`]; [`merge_parts`] joins the `N` parts into the index one
//! unsharded build makes, bit for bit.
//!
//! A part holds its layers' level-0 ranges and its share of the histogram:
//! exact per-value counts for integer samples (the unsharded build counts
//! the same way and rebins), and for `f32` the counts in the bins over the
//! volume's *recorded* value range (a `.vvol` header's), which is what the
//! unsharded build bins over once it knows the range. The merge checks that
//! the recorded range is the range the samples have. Each voxel is counted
//! by the shard whose layers hold it: the apron slice a shard reads for its
//! last layer's cells is counted by the next shard, not twice.
//!
//! The part file format (`.vidxpart`) is in `FORMAT.md` beside this crate.

use crate::build::{float_histogram, for_each_row, scan_walk, BuildOptions};
use crate::error::IndexError;
use crate::histogram::Histogram;
use crate::index::MinMaxIndex;
use crate::level::{level_shapes, Level};
use crate::scan::{Avx2, ScanSample};
use crate::walk::{BandWalk, BrickedWalk, CompressedWalk, SlicedBands, Walk, ZClip};
use std::io::{Read, Write};
use std::ops::Range;
use volcore::volume::TypedGrid;
use volcore::{Dims, SampleType, Shard, SliceOrder, ValueRange, Volume, VolumeData};

/// The file name extension of index part files.
pub const PART_EXTENSION: &str = "vidxpart";
const MAGIC: [u8; 8] = *b"VIDXPART";
const VERSION: u32 = 1;
const HEADER_LEN: usize = 128;

/// A part's share of the histogram.
#[derive(Clone, Debug, PartialEq)]
pub enum PartCounts {
    /// Integer samples: the count of every value, slot `s` holding value
    /// `type minimum + s`.
    Exact(Vec<u64>),
    /// `f32` samples: counts in equal bins over `[lo, hi]`, the volume's
    /// recorded value range.
    Binned {
        /// Lower edge of the first bin.
        lo: f64,
        /// Upper edge of the last bin.
        hi: f64,
        /// Count per bin.
        counts: Vec<u64>,
    },
}

/// One shard's share of an index (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct IndexPart {
    /// The whole volume's dimensions.
    pub dims: Dims,
    /// Its sample type.
    pub sample_type: SampleType,
    /// Level-0 cell edge.
    pub cell_edge: u32,
    /// Histogram bins asked for.
    pub bins: u32,
    /// The volume's fingerprint.
    pub fingerprint: u64,
    /// Which shard.
    pub shard: Shard,
    /// The level-0 cell layers (z) the part holds.
    pub layers: Range<u64>,
    /// Their cells' minima, x fastest.
    pub min: Vec<f32>,
    /// Their cells' maxima.
    pub max: Vec<f32>,
    /// The part's samples, counted.
    pub counts: PartCounts,
    /// NaN samples among them.
    pub nan_count: u64,
}

/// Level-0 cells per axis of a `dims` volume with cells of `edge`.
fn cells(dims: Dims, edge: u32) -> [u64; 3] {
    level_shapes(dims, edge)[0]
}

/// The count slots of an integer type (0 for `f32`).
fn exact_values(t: SampleType) -> usize {
    match t {
        SampleType::U8 => 1 << 8,
        SampleType::U16 | SampleType::I16 => 1 << 16,
        SampleType::F32 | SampleType::F64 => 0,
    }
}

/// The smallest value of an integer type.
fn type_min(t: SampleType) -> f64 {
    match t {
        SampleType::I16 => f64::from(i16::MIN),
        _ => 0.0,
    }
}

/// Build shard `shard`'s part of the index of `vol`. `f32` volumes need
/// their value range recorded (a `.vvol` written by volkit has it).
pub fn build_shard(
    vol: &Volume,
    opts: &BuildOptions,
    fingerprint: u64,
    shard: Shard,
) -> Result<IndexPart, IndexError> {
    opts.validate()?;
    let range = vol.meta.range;
    match &vol.data {
        VolumeData::U8(g) => shard_grid(g, opts, fingerprint, shard, range),
        VolumeData::U16(g) => shard_grid(g, opts, fingerprint, shard, range),
        VolumeData::I16(g) => shard_grid(g, opts, fingerprint, shard, range),
        VolumeData::F32(g) => shard_grid(g, opts, fingerprint, shard, range),
    }
}

fn shard_grid<T: ScanSample>(
    grid: &TypedGrid<T>,
    opts: &BuildOptions,
    fingerprint: u64,
    shard: Shard,
    range: ValueRange,
) -> Result<IndexPart, IndexError> {
    let edge = u64::from(opts.cell_edge);
    match grid {
        TypedGrid::Sliced(g) => match g.order() {
            SliceOrder::XFastest => shard_walk(
                &BandWalk::new(SlicedBands::new(g), edge),
                opts,
                fingerprint,
                shard,
                range,
            ),
            SliceOrder::ZFastest => Err(IndexError::Shard(
                "a z-fastest volume (thesis .vol) is indexed whole, not in shards: convert it to .vvol first".into(),
            )),
        },
        TypedGrid::Bricked(g) => shard_walk(&BrickedWalk::new(g), opts, fingerprint, shard, range),
        TypedGrid::Compressed(g) => {
            shard_walk(&CompressedWalk { grid: g }, opts, fingerprint, shard, range)
        }
    }
}

/// The `f32` binning range: the recorded range, as the unsharded build
/// will find it in the samples (`+ 0.0` makes a −0.0 bound +0.0).
fn binning_range(range: ValueRange) -> Result<(f32, f32), IndexError> {
    let (lo, hi) = (range.min as f32, range.max as f32);
    let exact = f64::from(lo) == range.min && f64::from(hi) == range.max;
    if range.is_empty() || !lo.is_finite() || !hi.is_finite() || lo > hi || !exact {
        return Err(IndexError::Shard(
            "an f32 volume is indexed in shards only when its file records a finite value range \
             (a .vvol written by vol-convert or vol-gen): convert it to .vvol, or index it whole"
                .into(),
        ));
    }
    Ok((lo + 0.0, hi + 0.0))
}

fn shard_walk<T: ScanSample>(
    walk: &dyn Walk<T>,
    opts: &BuildOptions,
    fingerprint: u64,
    shard: Shard,
    range: ValueRange,
) -> Result<IndexPart, IndexError> {
    let dims = walk.dims();
    let edge = u64::from(opts.cell_edge);
    let [nx, ny, nz] = cells(dims, opts.cell_edge);
    let layers = shard.units(nz);
    let binned = if T::EXACT_VALUES == 0 {
        Some(binning_range(range)?)
    } else {
        None
    };
    let bins = opts.histogram_bins as usize;
    let mut part = IndexPart {
        dims,
        sample_type: T::TYPE,
        cell_edge: opts.cell_edge,
        bins: opts.histogram_bins,
        fingerprint,
        shard,
        layers: layers.clone(),
        min: Vec::new(),
        max: Vec::new(),
        counts: match binned {
            None => PartCounts::Exact(vec![0; T::EXACT_VALUES]),
            Some((lo, hi)) => PartCounts::Binned {
                lo: f64::from(lo),
                hi: f64::from(hi),
                counts: vec![0; bins],
            },
        },
        nan_count: 0,
    };
    if layers.is_empty() {
        return Ok(part);
    }
    // The voxels of the shard's cells: its layers plus one slice of apron.
    let z0 = layers.start * edge;
    let apron = layers.end * edge;
    let z1 = (apron + 1).min(dims.z);
    let clip = ZClip::new(walk, z0..z1);
    let mut scanned = scan_walk(&clip, opts, Avx2::detect())?;
    let keep = ((layers.end - layers.start) * nx * ny) as usize;
    scanned.min.truncate(keep);
    scanned.max.truncate(keep);
    part.min = scanned.min;
    part.max = scanned.max;
    // The apron slice belongs to the next shard's counts.
    let apron_walk = (apron < dims.z).then(|| ZClip::new(walk, apron..apron + 1));
    match &mut part.counts {
        PartCounts::Exact(counts) => {
            *counts = scanned.counts.per_value();
            if let Some(w) = &apron_walk {
                for task in 0..w.tasks() {
                    for_each_row(w, task, |row| {
                        for v in row {
                            let slot = (f64::from(v.to_f32()) - T::TYPE_MIN) as usize;
                            counts[slot] -= 1;
                        }
                    })?;
                }
            }
        }
        PartCounts::Binned { counts, .. } => {
            let Some(r) = binned else {
                return Err(IndexError::Options(
                    "f32 range missing (internal error)".into(),
                ));
            };
            let h = float_histogram(&clip, r, opts.histogram_bins)?;
            counts.copy_from_slice(h.counts());
            part.nan_count = h.nan_count();
            if let Some(w) = &apron_walk {
                let a = float_histogram(w, r, opts.histogram_bins)?;
                for (c, s) in counts.iter_mut().zip(a.counts()) {
                    *c -= s;
                }
                part.nan_count -= a.nan_count();
            }
        }
    }
    Ok(part)
}

/// Join the parts of all `N` shards of one index (any order) into the
/// index the unsharded build makes.
pub fn merge_parts(mut parts: Vec<IndexPart>) -> Result<MinMaxIndex, IndexError> {
    let bad = IndexError::Shard;
    if parts.is_empty() {
        return Err(bad("no parts given".into()));
    }
    parts.sort_by_key(|p| p.shard.index);
    let p0 = &parts[0];
    let count = p0.shard.count;
    for w in parts.windows(2) {
        if w[0].shard == w[1].shard {
            return Err(bad(format!("shard {} is given twice", w[1].shard)));
        }
    }
    for p in &parts {
        let same = p.dims == p0.dims
            && p.sample_type == p0.sample_type
            && p.cell_edge == p0.cell_edge
            && p.bins == p0.bins
            && p.fingerprint == p0.fingerprint
            && p.shard.count == count;
        if !same {
            return Err(bad(format!(
                "shard {} is of another build ({} {}, cell {}, {} bins, fingerprint {:016x}, {} shards) \
                 than shard {} ({} {}, cell {}, {} bins, fingerprint {:016x}, {} shards)",
                p.shard, p.dims, p.sample_type, p.cell_edge, p.bins, p.fingerprint, p.shard.count,
                p0.shard, p0.dims, p0.sample_type, p0.cell_edge, p0.bins, p0.fingerprint, count
            )));
        }
    }
    if parts.len() != count as usize {
        let missing: Vec<String> = (0..count)
            .filter(|k| parts.binary_search_by_key(k, |p| p.shard.index).is_err())
            .take(8)
            .map(|k| format!("{k}/{count}"))
            .collect();
        return Err(bad(format!(
            "{} of {count} parts given; missing shard {}",
            parts.len(),
            missing.join(", ")
        )));
    }
    let (dims, edge) = (p0.dims, p0.cell_edge);
    let shape = cells(dims, edge);
    let total = (shape[0] * shape[1] * shape[2]) as usize;
    // Each part's cells are freed once copied: the merge holds the whole
    // level 0 and one part's cells at most, not two copies of everything.
    let mut min = Vec::with_capacity(total);
    let mut max = Vec::with_capacity(total);
    for p in &mut parts {
        min.extend_from_slice(&std::mem::take(&mut p.min));
        max.extend_from_slice(&std::mem::take(&mut p.max));
    }
    let p0 = &parts[0];
    if min.len() != total || max.len() != total {
        return Err(IndexError::Corrupt(
            "the parts' cells do not fill the volume".into(),
        ));
    }
    let shapes = level_shapes(dims, edge);
    let mut levels = vec![Level::from_parts(shape, u64::from(edge), min, max)?];
    while levels.len() < shapes.len() {
        let next = levels[levels.len() - 1].coarsen()?;
        levels.push(next);
    }
    let top = &levels[levels.len() - 1];
    let range = (top.min()[0], top.max()[0]);
    let mut nans = 0u64;
    let hist = match &p0.counts {
        PartCounts::Exact(first) => {
            let mut sum = vec![0u64; first.len()];
            for p in &parts {
                let PartCounts::Exact(c) = &p.counts else {
                    return Err(IndexError::Corrupt("parts count in different ways".into()));
                };
                for (s, v) in sum.iter_mut().zip(c) {
                    *s += v;
                }
            }
            Histogram::from_exact(type_min(p0.sample_type), &sum, p0.bins)
        }
        PartCounts::Binned { lo, hi, counts } => {
            let mut sum = vec![0u64; counts.len()];
            for p in &parts {
                match &p.counts {
                    PartCounts::Binned {
                        lo: l,
                        hi: h,
                        counts: c,
                    } if l == lo && h == hi => {
                        for (s, v) in sum.iter_mut().zip(c) {
                            *s += v;
                        }
                    }
                    _ => {
                        return Err(IndexError::Corrupt(
                            "parts binned over different ranges".into(),
                        ))
                    }
                }
                nans += p.nan_count;
            }
            let found = (f64::from(range.0) + 0.0, f64::from(range.1) + 0.0);
            if found != (*lo, *hi) {
                return Err(bad(format!(
                    "the volume's recorded value range {lo}..{hi} is not its samples' {}..{}: \
                     index it whole",
                    range.0, range.1
                )));
            }
            Histogram::from_parts(*lo, *hi, sum, 0)
        }
    };
    let mut hist = hist;
    hist.set_nan_count(nans);
    MinMaxIndex::from_parts(dims, p0.sample_type, p0.fingerprint, range, hist, levels)
}

impl IndexPart {
    /// Write the part file's bytes.
    pub fn write_to(&self, w: &mut impl Write) -> Result<(), IndexError> {
        let mut h = [0u8; HEADER_LEN];
        h[0..8].copy_from_slice(&MAGIC);
        h[8..12].copy_from_slice(&VERSION.to_le_bytes());
        h[12] = self.sample_type.code();
        for (a, v) in self.dims.as_array().iter().enumerate() {
            h[16 + 8 * a..24 + 8 * a].copy_from_slice(&v.to_le_bytes());
        }
        h[40..44].copy_from_slice(&self.cell_edge.to_le_bytes());
        h[44..48].copy_from_slice(&self.bins.to_le_bytes());
        h[48..56].copy_from_slice(&self.fingerprint.to_le_bytes());
        h[56..60].copy_from_slice(&self.shard.index.to_le_bytes());
        h[60..64].copy_from_slice(&self.shard.count.to_le_bytes());
        h[64..72].copy_from_slice(&self.layers.start.to_le_bytes());
        h[72..80].copy_from_slice(&self.layers.end.to_le_bytes());
        let (kind, lo, hi, counts) = match &self.counts {
            PartCounts::Exact(c) => (0u32, 0.0, 0.0, c),
            PartCounts::Binned { lo, hi, counts } => (1, *lo, *hi, counts),
        };
        h[80..84].copy_from_slice(&kind.to_le_bytes());
        h[88..96].copy_from_slice(&lo.to_le_bytes());
        h[96..104].copy_from_slice(&hi.to_le_bytes());
        h[104..112].copy_from_slice(&(counts.len() as u64).to_le_bytes());
        h[112..120].copy_from_slice(&self.nan_count.to_le_bytes());
        let crc = crc32fast::hash(&h[..124]);
        h[124..128].copy_from_slice(&crc.to_le_bytes());
        w.write_all(&h)?;
        let mut body = crc32fast::Hasher::new();
        let mut put = |w: &mut dyn Write, b: &[u8]| -> std::io::Result<()> {
            body.update(b);
            w.write_all(b)
        };
        for c in counts {
            put(w, &c.to_le_bytes())?;
        }
        for v in self.min.iter().chain(&self.max) {
            put(w, &v.to_le_bytes())?;
        }
        w.write_all(&body.finalize().to_le_bytes())?;
        Ok(())
    }

    /// Read and check a part file of `len` bytes.
    pub fn read_from(r: &mut impl Read, len: u64) -> Result<IndexPart, IndexError> {
        let corrupt = |m: &str| IndexError::Corrupt(m.to_string());
        let mut h = [0u8; HEADER_LEN];
        if len < HEADER_LEN as u64 {
            return Err(corrupt("not a volkit index part (too short)"));
        }
        r.read_exact(&mut h)?;
        if h[0..8] != MAGIC {
            return Err(corrupt("not a volkit index part (bad magic)"));
        }
        let u32_at = |o: usize| u32::from_le_bytes(h[o..o + 4].try_into().unwrap_or_default());
        let u64_at = |o: usize| u64::from_le_bytes(h[o..o + 8].try_into().unwrap_or_default());
        if u32_at(8) != VERSION {
            return Err(IndexError::Version {
                found: u32_at(8),
                supported: VERSION,
            });
        }
        if crc32fast::hash(&h[..124]) != u32_at(124) {
            return Err(corrupt("index part header is damaged"));
        }
        let sample_type = SampleType::from_code(h[12])
            .ok_or_else(|| corrupt("unknown sample type in the part header"))?;
        let dims = Dims::new(u64_at(16), u64_at(24), u64_at(32))
            .map_err(|e| IndexError::Corrupt(format!("part dims: {e}")))?;
        let (cell_edge, bins) = (u32_at(40), u32_at(44));
        BuildOptions {
            cell_edge,
            histogram_bins: bins,
        }
        .validate()?;
        let shard = Shard::new(u32_at(56), u32_at(60))
            .ok_or_else(|| corrupt("the part header names a shard that does not exist"))?;
        let [nx, ny, nz] = cells(dims, cell_edge);
        let layers = u64_at(64)..u64_at(72);
        if layers != shard.units(nz) {
            return Err(corrupt("the part's cell layers are not its shard's"));
        }
        let kind = u32_at(80);
        let n_counts = u64_at(104);
        let want_counts = match (kind, exact_values(sample_type)) {
            (0, v) if v > 0 => v as u64,
            (1, 0) => u64::from(bins),
            _ => {
                return Err(corrupt(
                    "the part's histogram kind does not suit its sample type",
                ))
            }
        };
        if n_counts != want_counts {
            return Err(corrupt(
                "the part's histogram has the wrong number of slots",
            ));
        }
        let n_cells = (layers.end - layers.start)
            .checked_mul(nx)
            .and_then(|v| v.checked_mul(ny))
            .ok_or_else(|| corrupt("cell count overflows"))?;
        let expect = n_counts
            .checked_mul(8)
            .and_then(|c| n_cells.checked_mul(8).and_then(|m| m.checked_add(c)))
            .and_then(|b| b.checked_add(HEADER_LEN as u64 + 4));
        if expect != Some(len) {
            return Err(corrupt(
                "the part file's length does not match its header (truncated or damaged)",
            ));
        }
        let mut body = vec![0u8; (len - HEADER_LEN as u64) as usize];
        r.read_exact(&mut body)?;
        let (data, crc) = body.split_at(body.len() - 4);
        if crc32fast::hash(data) != u32::from_le_bytes(crc.try_into().unwrap_or_default()) {
            return Err(corrupt("the index part's data is damaged"));
        }
        let (cb, cells_b) = data.split_at(n_counts as usize * 8);
        let counts: Vec<u64> = cb
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
            .collect();
        let floats: Vec<f32> = cells_b
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap_or_default()))
            .collect();
        let (min, max) = floats.split_at(n_cells as usize);
        let counts = if kind == 0 {
            PartCounts::Exact(counts)
        } else {
            PartCounts::Binned {
                lo: f64::from_le_bytes(h[88..96].try_into().unwrap_or_default()),
                hi: f64::from_le_bytes(h[96..104].try_into().unwrap_or_default()),
                counts,
            }
        };
        Ok(IndexPart {
            dims,
            sample_type,
            cell_edge,
            bins,
            fingerprint: u64_at(48),
            shard,
            layers,
            min: min.to_vec(),
            max: max.to_vec(),
            counts,
            nan_count: u64_at(112),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{odd_dims, random_samples, volume, RandomSample};
    use volcore::region::{pack_bricks, Rows};
    use volcore::{BrickGeometry, BrickedGrid, Data, SlicedGrid, ValueRange};

    fn to_bytes(ix: &MinMaxIndex) -> Vec<u8> {
        let mut out = Vec::new();
        ix.write_to(&mut out).unwrap();
        out
    }

    /// Through the part file codec and back.
    fn round_trip(p: IndexPart) -> IndexPart {
        let mut b = Vec::new();
        p.write_to(&mut b).unwrap();
        let back = IndexPart::read_from(&mut &b[..], b.len() as u64).unwrap();
        assert_eq!(back, p);
        back
    }

    /// `samples` sliced and as bricks of 8, the range recorded.
    fn volumes<T: RandomSample + ScanSample>(dims: Dims, samples: Vec<T>) -> Vec<Volume> {
        let sliced = SlicedGrid::new(dims, Data::Owned(samples.clone())).unwrap();
        let geom = BrickGeometry::new(dims, 8).unwrap();
        let packed = pack_bricks(&Rows(&sliced), &geom);
        let bricked = BrickedGrid::new(geom, geom.stored_len(), Data::Owned(packed)).unwrap();
        let mut out = vec![
            volume(dims, samples),
            Volume {
                meta: volcore::VolumeMeta::sliced(dims, T::TYPE),
                data: T::into_data(TypedGrid::Bricked(bricked)),
            },
        ];
        for v in &mut out {
            let ix = MinMaxIndex::build_volume(v, &BuildOptions::default(), 0).unwrap();
            let (lo, hi) = ix.value_range();
            v.meta.range = ValueRange {
                min: f64::from(lo),
                max: f64::from(hi),
            };
        }
        out
    }

    fn check<T: RandomSample + ScanSample>(kind: u8) {
        let mut all = odd_dims();
        all.push(Dims::new(19, 11, 53).unwrap());
        for dims in all {
            let opts = BuildOptions {
                cell_edge: 4,
                histogram_bins: 64,
            };
            for vol in volumes::<T>(dims, random_samples(dims, 7, kind)) {
                let whole = to_bytes(&MinMaxIndex::build_volume(&vol, &opts, 42).unwrap());
                for n in [1, 2, 3, 5, 40] {
                    let parts: Vec<IndexPart> = (0..n)
                        .rev()
                        .map(|k| {
                            round_trip(
                                build_shard(&vol, &opts, 42, Shard::new(k, n).unwrap()).unwrap(),
                            )
                        })
                        .collect();
                    let merged = to_bytes(&merge_parts(parts).unwrap());
                    assert!(
                        merged == whole,
                        "{} {dims} kind {kind} in {n} shards",
                        T::TYPE
                    );
                }
            }
        }
    }

    /// Every shard count, through the part file codec, gives the
    /// unsharded index's bytes (sliced and bricked, each sample type).
    #[test]
    fn merged_shards_equal_the_whole_build() {
        for kind in 0..3 {
            check::<u8>(kind);
            check::<u16>(kind);
            check::<i16>(kind);
        }
        // f32 with NaN and -0.0 (kind 2 adds infinities: refused below).
        check::<f32>(0);
        check::<f32>(1);
    }

    #[test]
    fn merge_refuses_incomplete_doubled_and_foreign_parts() {
        let dims = Dims::new(19, 11, 53).unwrap();
        let opts = BuildOptions::default();
        let vol = volume(dims, random_samples::<u16>(dims, 3, 0));
        let part = |k, n, fp| build_shard(&vol, &opts, fp, Shard::new(k, n).unwrap()).unwrap();
        let msg = |parts| merge_parts(parts).unwrap_err().to_string();
        assert!(msg(vec![part(0, 3, 1), part(2, 3, 1)]).contains("missing shard 1/3"));
        assert!(msg(vec![part(0, 2, 1), part(0, 2, 1)]).contains("twice"));
        assert!(msg(vec![part(0, 2, 1), part(1, 2, 9)]).contains("another build"));
        assert!(msg(vec![part(0, 2, 1), part(1, 3, 1)]).contains("another build"));
        // A part file cut short or damaged is refused before use.
        let mut b = Vec::new();
        part(0, 2, 1).write_to(&mut b).unwrap();
        let cut = &b[..b.len() - 1];
        assert!(IndexPart::read_from(&mut &cut[..], cut.len() as u64).is_err());
        let mut bad = b.clone();
        let last = bad.len() - 10;
        bad[last] ^= 1;
        assert!(IndexPart::read_from(&mut &bad[..], bad.len() as u64)
            .unwrap_err()
            .to_string()
            .contains("damaged"));
    }

    #[test]
    fn f32_shards_need_a_recorded_range_that_matches() {
        let dims = Dims::new(19, 11, 53).unwrap();
        let opts = BuildOptions::default();
        let mut vol = volume(dims, random_samples::<f32>(dims, 5, 0));
        vol.meta.range = ValueRange::EMPTY;
        let s = Shard::new(0, 2).unwrap();
        assert!(build_shard(&vol, &opts, 1, s)
            .unwrap_err()
            .to_string()
            .contains("records a finite value range"));
        // Infinite samples: their range is recorded but not finite.
        let mut inf = volumes::<f32>(dims, random_samples(dims, 5, 2)).remove(0);
        assert!(inf.meta.range.max.is_infinite() || inf.meta.range.min.is_infinite());
        assert!(build_shard(&inf, &opts, 1, s).is_err());
        inf.meta.range = ValueRange::EMPTY;
        // A recorded range wider than the samples' is caught at the merge.
        let whole = MinMaxIndex::build_volume(&vol, &opts, 1).unwrap();
        let (lo, hi) = whole.value_range();
        vol.meta.range = ValueRange {
            min: f64::from(lo) - 1.0,
            max: f64::from(hi),
        };
        let parts = (0..2)
            .map(|k| build_shard(&vol, &opts, 1, Shard::new(k, 2).unwrap()).unwrap())
            .collect();
        assert!(merge_parts(parts)
            .unwrap_err()
            .to_string()
            .contains("recorded value range"));
    }
}
