//! The thesis generator's `.vol` format (8-bit samples).
//!
//! A 26-byte little-endian header: dimensions X, Y, Z (`u32` each), voxel
//! spacing x, y, z (`f32` each), a layout byte (1 = sliced, 2 = bricked) and
//! a brick-side byte (0 for sliced). Then `u8` samples, unaligned.
//! - Sliced: z fastest, x slowest: offset = z + Z·(y + Y·x).
//! - Bricked: bricks of `B³` voxels overlapping by one voxel (stride B−1),
//!   `n = ceil((dim − 1)/(B − 1))` bricks per axis (at least 1: the thesis
//!   formula gives none for an axis of one voxel), bricks in order bx, by, bz
//!   with bz fastest, and inside a brick i, j, k with k fastest; brick
//!   `(bx, by, bz)` position `(i, j, k)` holds voxel
//!   `(bx(B−1)+i, by(B−1)+j, bz(B−1)+k)`, and positions past the volume hold 0.

use crate::error::{truncated, Error, Result};
use crate::pipeline::ordered;
use crate::reader::{Access, At, CResult, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use memmap2::Mmap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;

use std::sync::Arc;
use volcore::region::{pack_sliced, RegionSource};
use volcore::volume::TypedGrid;
use volcore::{
    Data, Dims, SampleType, SliceOrder, SlicedGrid, ValueRange, Volume, VolumeData, VolumeMeta,
};

/// Size of the header.
pub const HEADER_LEN: u64 = 26;

/// The two layouts of the thesis format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThesisLayout {
    /// z-fastest array.
    Sliced,
    /// Overlapping bricks of this side (at least 2).
    Bricked(u8),
}

/// The decoded 26-byte header.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThesisHeader {
    /// Voxels per axis.
    pub dims: Dims,
    /// Voxel spacing ("voxel shape").
    pub spacing: [f32; 3],
    /// Sliced or bricked.
    pub layout: ThesisLayout,
}

impl ThesisHeader {
    /// Bricks per axis for side `b`.
    pub fn brick_counts(&self, b: u8) -> [u64; 3] {
        let s = b as u64 - 1;
        self.dims.as_array().map(|d| (d - 1).div_ceil(s).max(1))
    }

    /// Bytes of sample data the header implies.
    pub fn data_len(&self) -> Option<u64> {
        match self.layout {
            ThesisLayout::Sliced => self.dims.checked_count(),
            ThesisLayout::Bricked(b) => {
                let n = self.brick_counts(b);
                let b3 = (b as u64).pow(3);
                n[0].checked_mul(n[1])?.checked_mul(n[2])?.checked_mul(b3)
            }
        }
    }

    /// Encode as 26 bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN as usize] {
        let mut h = [0u8; HEADER_LEN as usize];
        for (a, d) in self.dims.as_array().iter().enumerate() {
            h[4 * a..4 * a + 4].copy_from_slice(&(*d as u32).to_le_bytes());
        }
        for (a, s) in self.spacing.iter().enumerate() {
            h[12 + 4 * a..16 + 4 * a].copy_from_slice(&s.to_le_bytes());
        }
        match self.layout {
            ThesisLayout::Sliced => h[24] = 1,
            ThesisLayout::Bricked(b) => {
                h[24] = 2;
                h[25] = b;
            }
        }
        h
    }

    /// Decode and validate 26 bytes.
    pub fn decode(h: &[u8]) -> Result<ThesisHeader> {
        if h.len() < HEADER_LEN as usize {
            return Err(Error::invalid(
                "file is truncated (shorter than the 26-byte header)",
            ));
        }
        let u = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]) as u64;
        let f = |o: usize| f32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
        let dims = Dims::new(u(0), u(4), u(8))?;
        let spacing = [f(12), f(16), f(20)];
        if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(Error::invalid(format!(
                "voxel shape {spacing:?} is not positive"
            )));
        }
        let layout = match (h[24], h[25]) {
            (1, _) => ThesisLayout::Sliced,
            (2, b) if b >= 2 => ThesisLayout::Bricked(b),
            (2, b) => return Err(Error::invalid(format!("brick side {b} is below 2"))),
            (l, _) => return Err(Error::invalid(format!("unknown layout byte {l}"))),
        };
        Ok(ThesisHeader {
            dims,
            spacing,
            layout,
        })
    }
}

/// An open `.vol` file, memory-mapped; a [`RegionSource`] of `u8`.
pub struct ThesisFile {
    header: ThesisHeader,
    map: Arc<Mmap>,
    file: Arc<File>,
}

/// Open a `.vol` file, checking its length against the header.
pub fn open(path: &Path) -> Result<ThesisFile> {
    let mut f = File::open(path)?;
    let mut b = [0u8; HEADER_LEN as usize];
    f.read_exact(&mut b).map_err(truncated("26-byte header"))?;
    let header = ThesisHeader::decode(&b)?;
    let want = header
        .data_len()
        .and_then(|n| n.checked_add(HEADER_LEN))
        .ok_or_else(|| Error::invalid("data size overflows"))?;
    let len = f.metadata()?.len();
    if len != want {
        return Err(Error::invalid(format!(
            "header describes {} {:?} ({want} bytes) but the file has {len} bytes",
            header.dims, header.layout
        )));
    }
    // SAFETY: read-only map; the file must not be truncated meanwhile.
    let map = Arc::new(unsafe { Mmap::map(&f)? });
    Ok(ThesisFile {
        header,
        map,
        file: Arc::new(f),
    })
}

impl ThesisFile {
    /// The format's name in reports (`thesis .vol (sliced)`).
    pub fn format_name(&self) -> String {
        format!("thesis .vol ({:?})", self.header().layout).to_lowercase()
    }

    /// The header.
    pub fn header(&self) -> &ThesisHeader {
        &self.header
    }

    /// Byte offset of voxel `(x, y, z)`.
    #[inline]
    fn offset(&self, x: u64, y: u64, z: u64) -> usize {
        let d = self.header.dims;
        let o = match self.header.layout {
            ThesisLayout::Sliced => z + d.z * (y + d.y * x),
            ThesisLayout::Bricked(b) => {
                let n = self.header.brick_counts(b);
                let s = b as u64 - 1;
                let b = b as u64;
                let (bx, by, bz) = (
                    (x / s).min(n[0] - 1),
                    (y / s).min(n[1] - 1),
                    (z / s).min(n[2] - 1),
                );
                let (i, j, k) = (x - bx * s, y - by * s, z - bz * s);
                ((bx * n[1] + by) * n[2] + bz) * b * b * b + (i * b + j) * b + k
            }
        };
        (HEADER_LEN + o) as usize
    }

    /// The volume to sample: a sliced file in place, through its memory
    /// map in its own z-fastest order (no copy, so opening costs one pass
    /// for the value range); a bricked one copied into memory by
    /// [`ThesisFile::load`], as its overlapping bricks are not volkit's.
    pub fn volume(&self) -> Result<Volume> {
        let h = self.header;
        if h.layout != ThesisLayout::Sliced {
            return self.load();
        }
        let n = usize::try_from(h.dims.count())
            .map_err(|_| Error::invalid(format!("{} does not fit in memory", h.dims)))?;
        let data = Data::mapped_file(self.map.clone(), self.file.clone(), HEADER_LEN as usize, n)?;
        let range = range_in_place(&data);
        let grid = SlicedGrid::with_order(h.dims, SliceOrder::ZFastest, data)?;
        let mut meta = VolumeMeta::sliced(h.dims, SampleType::U8);
        meta.spacing = h.spacing;
        meta.range = range;
        Ok(Volume {
            meta,
            data: VolumeData::U8(TypedGrid::Sliced(grid)),
        })
    }

    /// The whole volume in memory, sliced (x fastest).
    pub fn load(&self) -> Result<Volume> {
        let samples = pack_sliced(self);
        let mut v = Volume::from_samples(self.header.dims, samples)?;
        v.meta.spacing = self.header.spacing;
        Ok(v)
    }
}

impl RegionSource for ThesisFile {
    type Sample = u8;
    fn dims(&self) -> Dims {
        self.header.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [u8]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.map[self.offset(x0 + i as u64, y, z)];
        }
    }
}

/// The smallest and largest of `data`, read in storage order in parallel
/// chunks (any order gives the same range).
fn range_in_place(data: &[u8]) -> ValueRange {
    use rayon::prelude::*;
    data.par_chunks(1 << 22)
        .map(ValueRange::of)
        .reduce(|| ValueRange::EMPTY, |a, b| a.merge(b))
}

/// Write `src` as a `.vol` file with the given spacing and layout.
/// Returns the bytes written.
pub fn write<R: RegionSource<Sample = u8>>(
    src: &R,
    spacing: [f32; 3],
    layout: ThesisLayout,
    out: &mut (dyn Write + Send),
    progress: &(dyn Fn(u64) + Sync),
) -> Result<u64> {
    let d = src.dims();
    if d.as_array().iter().any(|&n| n > u32::MAX as u64) {
        return Err(Error::invalid(format!(
            "{d} does not fit the .vol header (u32 per axis)"
        )));
    }
    let header = ThesisHeader {
        dims: d,
        spacing,
        layout,
    };
    out.write_all(&header.encode())?;
    let mut written = HEADER_LEN;
    let mut sink = |bytes: Vec<u8>| -> Result<()> {
        out.write_all(&bytes)?;
        written += bytes.len() as u64;
        progress(written);
        Ok(())
    };
    match layout {
        ThesisLayout::Sliced => {
            // Items are slabs of x (the slowest axis), each gathered from
            // rows of the slab's width and transposed to z fastest.
            let plane = d.y * d.z;
            let width = ((32u64 << 20) / plane).clamp(1, d.x);
            let items = d.x.div_ceil(width);
            ordered(
                items,
                2,
                |item| {
                    let x0 = item * width;
                    let w = width.min(d.x - x0) as usize;
                    let mut slab = vec![0u8; w * plane as usize];
                    let mut row = vec![0u8; w];
                    for z in 0..d.z {
                        for y in 0..d.y {
                            src.fill_row(x0, y, z, &mut row);
                            for (xi, &v) in row.iter().enumerate() {
                                slab[((xi as u64 * d.y + y) * d.z + z) as usize] = v;
                            }
                        }
                    }
                    Ok(slab)
                },
                &mut sink,
            )?;
        }
        ThesisLayout::Bricked(b) => {
            let n = header.brick_counts(b);
            let (s, bu) = (b as u64 - 1, b as usize);
            let count = n[0] * n[1] * n[2];
            ordered(
                count,
                256,
                |id| {
                    let (bx, by, bz) = (id / (n[1] * n[2]), (id / n[2]) % n[1], id % n[2]);
                    let origin = [bx * s, by * s, bz * s];
                    let mut brick = vec![0u8; bu * bu * bu];
                    let w = (d.x - origin[0]).min(b as u64) as usize;
                    let mut row = vec![0u8; w];
                    for k in 0..bu {
                        let z = origin[2] + k as u64;
                        for j in 0..bu {
                            let y = origin[1] + j as u64;
                            if y >= d.y || z >= d.z {
                                continue;
                            }
                            src.fill_row(origin[0], y, z, &mut row);
                            for (i, &v) in row.iter().enumerate() {
                                brick[(i * bu + j) * bu + k] = v;
                            }
                        }
                    }
                    Ok(brick)
                },
                &mut sink,
            )?;
        }
    }
    out.flush()?;
    Ok(written)
}

/// The thesis `.vol` file read slice by slice.
pub struct ThesisReader {
    info: InputInfo,
    file: crate::thesis::ThesisFile,
    bytes: u64,
}

impl ThesisReader {
    /// Open a `.vol` file.
    pub fn open(path: &Path) -> CResult<ThesisReader> {
        let file = crate::thesis::open(path).at(path)?;
        let h = *file.header();
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        Ok(ThesisReader {
            info: InputInfo {
                nifti_codes: None,
                path: path.to_path_buf(),
                dims: h.dims,
                sample_type: SliceType::U8,
                spacing: Some(h.spacing),
                geometry: volcore::Geometry::IDENTITY,
                format: file.format_name(),
            },
            file,
            bytes,
        })
    }
}

impl SliceReader for ThesisReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        use volcore::RegionSource;
        let d = self.info.dims;
        let mut v = vec![0u8; d.slice_len() as usize];
        for (y, row) in v.chunks_exact_mut(d.x as usize).enumerate() {
            self.file.fill_row(0, y as u64, z, row);
        }
        Ok(SliceData::U8(v))
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
}
