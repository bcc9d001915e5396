//! `.vvol` inputs read slice by slice: open files (any layout) and
//! streams (sliced, from a pipe).

use super::read::Stored;
use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, Described, InputInfo, SliceReader};
use crate::slice::SliceData;
use crate::stream::{Counted, SampleLayout, StreamEnd, StreamReader};
use std::io::Read;
use std::path::{Path, PathBuf};
use volcore::volume::TypedGrid;
use volcore::{SampleType, Volume, VolumeVisitor, VoxelSource};

/// Open a `.vvol` stream (as written by `vol-gen -o -`): the header is read
/// now, the samples slice by slice, and the trailer's checksum is checked
/// by [`SliceReader::finish`].
pub fn vvol_stream(path: &Path, reader: Box<dyn Read + Send>) -> CResult<StreamReader> {
    let mut r = Counted::new(reader);
    let counter = r.counter();
    let h = super::read::read_header_from(&mut r).at(path)?;
    if h.meta.layout != volcore::Layout::Sliced {
        return Err(ConvertError::new(
            path,
            Error::invalid("only sliced .vvol data can be read from a stream"),
        ));
    }
    Ok(StreamReader::new(
        path,
        Box::new(r),
        counter,
        SampleLayout {
            dims: h.meta.dims,
            sample_type: h.meta.sample_type.into(),
            big_endian: false,
        },
        StreamEnd::VvolTrailer,
        "vvol stream",
    )
    .with_geometry(Some(h.meta.spacing), h.meta.geometry))
}

/// An open volume (`.vvol`, `.vol`) read slice by slice.
pub struct VolumeReader {
    info: InputInfo,
    path: PathBuf,
    volume: Stored,
    bytes: u64,
}

impl VolumeReader {
    /// Wrap an open volume read from `path`.
    pub fn new(path: &Path, volume: Volume, format: &str) -> VolumeReader {
        VolumeReader::of_stored(path, Stored::Volume(volume), format)
    }

    /// Wrap an open `.vvol` file's samples as stored (`f64` kept).
    pub fn of_stored(path: &Path, volume: Stored, format: &str) -> VolumeReader {
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        let meta = match &volume {
            Stored::Volume(v) => v.meta,
            Stored::F64(meta, _) => *meta,
        };
        VolumeReader {
            info: info_of(path, &meta, format),
            path: path.to_path_buf(),
            volume,
            bytes,
        }
    }
}

/// What a reader of a volume described by `meta` read from `path` hands
/// out.
fn info_of(path: &Path, meta: &volcore::VolumeMeta, format: &str) -> InputInfo {
    InputInfo {
        nifti_codes: None,
        path: path.to_path_buf(),
        dims: meta.dims,
        sample_type: meta.sample_type.into(),
        spacing: Some(meta.spacing),
        geometry: meta.geometry,
        format: format.to_string(),
    }
}

/// An open volume read slice by slice without being owned: a second
/// look at a volume already read, as from standard input, which cannot
/// be read again.
pub struct BorrowedReader<'a> {
    info: InputInfo,
    volume: &'a Volume,
}

impl<'a> BorrowedReader<'a> {
    /// Read `volume` (read from `path`) slice by slice.
    pub fn new(path: &Path, volume: &'a Volume, format: &str) -> BorrowedReader<'a> {
        BorrowedReader {
            info: info_of(path, &volume.meta, format),
            volume,
        }
    }
}

impl SliceReader for BorrowedReader<'_> {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        let s = self.volume.visit(ReadSlice(z));
        match self.volume.error() {
            Some(e) => Err(ConvertError::new(&self.info.path, Error::invalid(e))),
            None => Ok(s),
        }
    }
    fn bytes_in(&self) -> u64 {
        0
    }
}

struct ReadSlice(u64);

impl VolumeVisitor for ReadSlice {
    type Output = SliceData;
    fn visit<S: VoxelSource>(self, src: &S) -> SliceData {
        let d = src.dims();
        let mut v = vec![S::Sample::default(); d.slice_len() as usize];
        for (y, row) in v.chunks_exact_mut(d.x as usize).enumerate() {
            src.read_row(0, y as u64, self.0, row);
        }
        to_slice_data(v)
    }
}

/// Wrap samples of any volcore sample type.
fn to_slice_data<T: volcore::Sample>(v: Vec<T>) -> SliceData {
    match T::TYPE {
        SampleType::U8 => SliceData::U8(cast_vec_or_copy(v)),
        SampleType::U16 => SliceData::U16(cast_vec_or_copy(v)),
        SampleType::I16 => SliceData::I16(cast_vec_or_copy(v)),
        SampleType::F32 => SliceData::F32(cast_vec_or_copy(v)),
        SampleType::F64 => SliceData::F64(cast_vec_or_copy(v)),
    }
}

/// `v` reinterpreted (same size and alignment), else copied.
fn cast_vec_or_copy<A: bytemuck::Pod, B: bytemuck::Pod>(v: Vec<A>) -> Vec<B> {
    match bytemuck::try_cast_vec(v) {
        Ok(b) => b,
        Err((_, v)) => bytemuck::pod_collect_to_vec(&v),
    }
}

impl SliceReader for VolumeReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, _reuse: Option<SliceData>) -> CResult<SliceData> {
        let (s, e) = match &self.volume {
            Stored::Volume(v) => (v.visit(ReadSlice(z)), v.error()),
            Stored::F64(_, TypedGrid::Sliced(g)) => (ReadSlice(z).visit(g), g.error()),
            Stored::F64(_, TypedGrid::Bricked(g)) => (ReadSlice(z).visit(g), g.error()),
            Stored::F64(_, TypedGrid::Compressed(g)) => (ReadSlice(z).visit(g), g.error()),
        };
        if let Some(e) = e {
            return Err(ConvertError::new(&self.path, Error::invalid(e)));
        }
        Ok(s)
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
}
