//! Inputs of a conversion, read slice by slice.
//!
//! A [`SliceReader`] hands out whole z slices. Random-access readers (files
//! of slices, raw data read at offsets, open volumes) may be asked for any
//! slice from any thread, so slices decode in parallel; sequential readers
//! (pipes, gzip streams) must be asked in increasing z order and skip what
//! is not asked for.

use super::slice::{SliceData, SliceSample};
use super::{At, CResult, ConvertError};
use crate::error::Error;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use volcore::{Dims, SampleType, Volume, VolumeVisitor, VoxelSource};

/// What an input holds.
#[derive(Clone, Debug, PartialEq)]
pub struct InputInfo {
    /// The input as named on the command line (`-` for standard input).
    pub path: PathBuf,
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type of the slices handed out.
    pub sample_type: SampleType,
    /// Voxel spacing, when the input records one.
    pub spacing: Option<[f32; 3]>,
    /// A short description of the input format, e.g. `tiff stack (512 files)`.
    pub format: String,
}

/// Whether slices can be read in any order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Any slice, from any thread.
    Random,
    /// Increasing z only, from one thread at a time.
    Sequential,
}

/// A source of whole z slices.
pub trait SliceReader: Send + Sync {
    /// Dimensions, type, spacing.
    fn info(&self) -> &InputInfo;
    /// Random or sequential access.
    fn access(&self) -> Access;
    /// Slice `z`, x fastest. Sequential readers need increasing `z`.
    fn read_slice(&self, z: u64) -> CResult<SliceData>;
    /// Like [`SliceReader::read_slice`], reusing the allocation of `reuse`
    /// where the reader can.
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let _ = reuse;
        self.read_slice(z)
    }
    /// Input bytes consumed so far (file sizes for files, bytes read for
    /// streams).
    fn bytes_in(&self) -> u64;
    /// Called once after the last slice: sequential readers read what is
    /// left (so a writer upstream in a pipe never sees a broken pipe) and
    /// check trailers.
    fn finish(&self) -> CResult<()> {
        Ok(())
    }
}

// ------------------------------------------------------------- raw file --

/// Headerless samples in a file at a byte offset, read slice by slice
/// with positioned reads (not mapped, so resident memory stays at the
/// slices in flight however large the file).
pub struct RawFileReader {
    info: InputInfo,
    path: PathBuf,
    file: std::fs::File,
    len: u64,
    offset: u64,
    big_endian: bool,
}

/// Read `count` samples of type `t` at byte `start` of `file`, converting
/// from the given byte order.
fn read_typed(
    file: &std::fs::File,
    t: SampleType,
    start: u64,
    count: usize,
    big_endian: bool,
    reuse: Option<SliceData>,
) -> std::io::Result<SliceData> {
    use std::os::unix::fs::FileExt;
    let mut s = SliceData::reuse(reuse, t, count);
    file.read_exact_at(s.as_bytes_mut(), start)?;
    if big_endian != cfg!(target_endian = "big") {
        s.swap_bytes();
    }
    Ok(s)
}

impl RawFileReader {
    /// Map `path`, whose samples start at `offset`; the file must hold at
    /// least the samples `dims` and `t` need (exactly, when `exact`).
    pub fn open(
        path: &Path,
        dims: Dims,
        t: SampleType,
        big_endian: bool,
        offset: u64,
        exact: bool,
        format: &str,
    ) -> CResult<RawFileReader> {
        let f = std::fs::File::open(path).at(path)?;
        let len = f.metadata().at(path)?.len();
        let need = dims.checked_bytes(t.size() as u64).at(path)?;
        let want = need.checked_add(offset);
        let fits = match want {
            Some(w) if exact => w == len,
            Some(w) => w <= len,
            None => false,
        };
        if !fits {
            return Err(ConvertError::new(
                path,
                Error::invalid(format!(
                    "{dims} {t} needs {need} bytes of samples after {offset} header bytes but the file has {len} bytes"
                )),
            ));
        }
        Ok(RawFileReader {
            info: InputInfo {
                path: path.to_path_buf(),
                dims,
                sample_type: t,
                spacing: None,
                format: format.to_string(),
            },
            path: path.to_path_buf(),
            file: f,
            len,
            offset,
            big_endian,
        })
    }

    /// Set the spacing the header recorded.
    pub fn with_spacing(mut self, spacing: Option<[f32; 3]>) -> Self {
        self.info.spacing = spacing;
        self
    }
}

impl SliceReader for RawFileReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        self.read_slice_into(z, None)
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let d = self.info.dims;
        let t = self.info.sample_type;
        let start = self.offset + z * d.slice_len() * t.size() as u64;
        read_typed(
            &self.file,
            t,
            start,
            d.slice_len() as usize,
            self.big_endian,
            reuse,
        )
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => ConvertError::new(
                &self.path,
                Error::invalid("file is truncated (shorter than when it was opened)"),
            ),
            _ => ConvertError::new(&self.path, e),
        })
    }
    fn bytes_in(&self) -> u64 {
        self.len
    }
}

// --------------------------------------------------------------- stream --

/// What follows the samples of a stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamEnd {
    /// Nothing: extra bytes are an error.
    Exact,
    /// Anything (ignored, but read so the writer upstream finishes).
    Ignore,
    /// A `.vvol` trailer whose CRC covers the samples.
    VvolTrailer,
}

struct StreamState {
    reader: Box<dyn Read + Send>,
    next_z: u64,
    crc: crc32fast::Hasher,
}

/// Dimensions, type and byte order of headerless samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleLayout {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SampleType,
    /// Big-endian samples.
    pub big_endian: bool,
}

/// Headerless samples read front to back from a stream (a pipe, standard
/// input, a decompressor).
pub struct StreamReader {
    info: InputInfo,
    path: PathBuf,
    big_endian: bool,
    end: StreamEnd,
    state: Mutex<StreamState>,
    read: std::sync::Arc<AtomicU64>,
}

/// A reader that counts the bytes passing through.
pub struct Counted<R> {
    inner: R,
    count: std::sync::Arc<AtomicU64>,
}

impl<R> Counted<R> {
    /// Count the bytes read from `inner`.
    pub fn new(inner: R) -> Counted<R> {
        Counted {
            inner,
            count: std::sync::Arc::new(AtomicU64::new(0)),
        }
    }
    /// The shared counter.
    pub fn counter(&self) -> std::sync::Arc<AtomicU64> {
        self.count.clone()
    }
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

impl StreamReader {
    /// Read `dims` samples of type `t` from `reader`; `counter` counts the
    /// input bytes consumed (see [`Counted`]).
    pub fn new(
        path: &Path,
        reader: Box<dyn Read + Send>,
        counter: std::sync::Arc<AtomicU64>,
        layout: SampleLayout,
        end: StreamEnd,
        format: &str,
    ) -> StreamReader {
        let SampleLayout {
            dims,
            sample_type: t,
            big_endian,
        } = layout;
        StreamReader {
            info: InputInfo {
                path: path.to_path_buf(),
                dims,
                sample_type: t,
                spacing: None,
                format: format.to_string(),
            },
            path: path.to_path_buf(),
            big_endian,
            end,
            state: Mutex::new(StreamState {
                reader,
                next_z: 0,
                crc: crc32fast::Hasher::new(),
            }),
            read: counter,
        }
    }

    /// Set the spacing the header recorded.
    pub fn with_spacing(mut self, spacing: Option<[f32; 3]>) -> Self {
        self.info.spacing = spacing;
        self
    }

    fn slice_bytes(&self) -> usize {
        (self.info.dims.slice_len() * self.info.sample_type.size() as u64) as usize
    }

    fn err(&self, msg: String) -> ConvertError {
        ConvertError::new(&self.path, Error::invalid(msg))
    }

    fn read_one(&self, st: &mut StreamState, buf: &mut [u8]) -> CResult<()> {
        let z = st.next_z;
        read_full(&mut st.reader, buf).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => self.err(format!(
                "input is truncated: it ends inside slice {z} of {} ({} {})",
                self.info.dims.z, self.info.dims, self.info.sample_type
            )),
            _ => ConvertError::new(&self.path, Error::Io(e)),
        })?;
        if self.end == StreamEnd::VvolTrailer {
            st.crc.update(buf);
        }
        st.next_z += 1;
        Ok(())
    }
}

fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> std::io::Result<()> {
    r.read_exact(buf)
}

impl SliceReader for StreamReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Sequential
    }
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        self.read_slice_into(z, None)
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let mut st = self
            .state
            .lock()
            .map_err(|_| self.err("reader poisoned".into()))?;
        if z < st.next_z {
            return Err(self.err(format!(
                "slice {z} asked for again from a stream (internal error)"
            )));
        }
        let n = self.info.dims.slice_len() as usize;
        let mut s = SliceData::reuse(reuse, self.info.sample_type, n);
        while st.next_z <= z {
            self.read_one(&mut st, s.as_bytes_mut())?;
        }
        if self.big_endian != cfg!(target_endian = "big") {
            s.swap_bytes();
        }
        Ok(s)
    }
    fn bytes_in(&self) -> u64 {
        self.read.load(Ordering::Relaxed)
    }
    fn finish(&self) -> CResult<()> {
        let mut st = self
            .state
            .lock()
            .map_err(|_| self.err("reader poisoned".into()))?;
        if st.next_z < self.info.dims.z {
            let mut buf = vec![0u8; self.slice_bytes()];
            while st.next_z < self.info.dims.z {
                self.read_one(&mut st, &mut buf)?;
            }
        }
        match self.end {
            StreamEnd::Exact => {
                let extra = std::io::copy(&mut st.reader, &mut std::io::sink()).at(&self.path)?;
                if extra > 0 {
                    return Err(self.err(format!(
                        "input has {extra} bytes more than {} {} needs",
                        self.info.dims, self.info.sample_type
                    )));
                }
            }
            StreamEnd::Ignore => {
                std::io::copy(&mut st.reader, &mut std::io::sink()).at(&self.path)?;
            }
            StreamEnd::VvolTrailer => {
                let mut t = [0u8; crate::vvol::TRAILER_LEN as usize];
                read_full(&mut st.reader, &mut t).map_err(|_| {
                    self.err("input is truncated: the .vvol trailer is missing".into())
                })?;
                let t = crate::vvol::Trailer::decode(&t).at(&self.path)?;
                let crc = st.crc.clone().finalize();
                if crc != t.crc32 {
                    return Err(ConvertError::new(
                        &self.path,
                        Error::Checksum(format!(
                            "sample data crc {crc:08x}, trailer says {:08x}",
                            t.crc32
                        )),
                    ));
                }
                std::io::copy(&mut st.reader, &mut std::io::sink()).at(&self.path)?;
            }
        }
        Ok(())
    }
}

/// Open a `.vvol` stream (as written by `vol-gen -o -`): the header is read
/// now, the samples slice by slice, and the trailer's checksum is checked
/// by [`SliceReader::finish`].
pub fn vvol_stream(path: &Path, reader: Box<dyn Read + Send>) -> CResult<StreamReader> {
    let mut r = Counted::new(reader);
    let counter = r.counter();
    let mut b = [0u8; crate::vvol::HEADER_LEN as usize];
    r.read_exact(&mut b)
        .map_err(crate::error::truncated("128-byte .vvol header"))
        .at(path)?;
    let h = crate::vvol::Header::decode(&b).at(path)?;
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
            sample_type: h.meta.sample_type,
            big_endian: false,
        },
        StreamEnd::VvolTrailer,
        "vvol stream",
    )
    .with_spacing(Some(h.meta.spacing)))
}

// --------------------------------------------------------------- volume --

/// An open volume (`.vvol`, `.vol`) read slice by slice.
pub struct VolumeReader {
    info: InputInfo,
    path: PathBuf,
    volume: Volume,
    bytes: u64,
}

impl VolumeReader {
    /// Wrap an open volume read from `path`.
    pub fn new(path: &Path, volume: Volume, format: &str) -> VolumeReader {
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        VolumeReader {
            info: InputInfo {
                path: path.to_path_buf(),
                dims: volume.meta.dims,
                sample_type: volume.meta.sample_type,
                spacing: Some(volume.meta.spacing),
                format: format.to_string(),
            },
            path: path.to_path_buf(),
            volume,
            bytes,
        }
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
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        let s = self.volume.visit(ReadSlice(z));
        if let Some(e) = self.volume.error() {
            return Err(ConvertError::new(&self.path, Error::invalid(e)));
        }
        Ok(s)
    }
    fn bytes_in(&self) -> u64 {
        self.bytes
    }
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
                path: path.to_path_buf(),
                dims: h.dims,
                sample_type: SampleType::U8,
                spacing: Some(h.spacing),
                format: format!("thesis .vol ({:?})", h.layout).to_lowercase(),
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
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
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

// ---------------------------------------------------------------- spool --

/// A sequential input copied to a temporary file first, so that it can be
/// read in any order (for flipping z) or twice (for an automatic window).
/// Memory stays bounded: the copy lives on disk.
pub struct Spooled {
    info: InputInfo,
    inner_bytes: u64,
    file: tempfile::NamedTempFile,
}

impl Spooled {
    /// Copy all slices of `inner` (in order) to a temporary file in `dir`,
    /// calling `each` with every slice as it passes.
    pub fn new(
        inner: &dyn SliceReader,
        dir: &Path,
        mut each: impl FnMut(&SliceData),
    ) -> CResult<Spooled> {
        let info = inner.info().clone();
        let mut file = tempfile::Builder::new()
            .prefix(".vol-convert-spool.")
            .tempfile_in(dir)
            .at(dir)?;
        {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, file.as_file_mut());
            for z in 0..info.dims.z {
                let s = inner.read_slice(z)?;
                each(&s);
                w.write_all(s.as_bytes()).at(dir)?;
            }
            w.flush().at(dir)?;
        }
        inner.finish()?;
        Ok(Spooled {
            inner_bytes: inner.bytes_in(),
            info,
            file,
        })
    }
}

impl SliceReader for Spooled {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        self.read_slice_into(z, None)
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let t = self.info.sample_type;
        let n = self.info.dims.slice_len();
        read_typed(
            self.file.as_file(),
            t,
            z * n * t.size() as u64,
            n as usize,
            cfg!(target_endian = "big"),
            reuse,
        )
        .at(self.file.path())
    }
    fn bytes_in(&self) -> u64 {
        self.inner_bytes
    }
}

/// Slices of one type as a [`SliceReader`] (tests and small volumes).
pub struct MemoryReader {
    info: InputInfo,
    slices: Vec<SliceData>,
}

impl MemoryReader {
    /// A reader over samples of type `T` in sliced order.
    pub fn new<T: SliceSample>(dims: Dims, samples: &[T]) -> MemoryReader {
        let n = dims.slice_len() as usize;
        MemoryReader {
            info: InputInfo {
                path: PathBuf::from("memory"),
                dims,
                sample_type: T::TYPE,
                spacing: None,
                format: "memory".into(),
            },
            slices: samples.chunks(n).map(|c| T::wrap(c.to_vec())).collect(),
        }
    }
}

impl SliceReader for MemoryReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice(&self, z: u64) -> CResult<SliceData> {
        Ok(self.slices[z as usize].clone())
    }
    fn bytes_in(&self) -> u64 {
        self.slices.iter().map(|s| s.as_bytes().len() as u64).sum()
    }
}

// ------------------------------------------------- headers with raw data --

/// How the samples after a header are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Plain samples.
    Raw,
    /// A gzip stream (NRRD `encoding: gzip`).
    Gzip,
    /// A zlib stream (MetaImage `CompressedData = True`).
    Zlib,
}

/// Where the samples a header describes start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataStart {
    /// At this byte offset of the data file.
    At(u64),
    /// At the end of the data file: the last `size` bytes (raw only).
    AtEnd,
}

/// What a NRRD or MetaImage header says about its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct DataSpec {
    /// Voxels per axis.
    pub dims: Dims,
    /// Sample type.
    pub sample_type: SampleType,
    /// Byte order of the samples.
    pub big_endian: bool,
    /// Voxel spacing, when given.
    pub spacing: Option<[f32; 3]>,
    /// The file holding the samples.
    pub data_file: PathBuf,
    /// Where in it the (possibly compressed) data starts.
    pub start: DataStart,
    /// Raw or compressed.
    pub encoding: Encoding,
    /// Decompressed bytes to skip before the samples (NRRD `byte skip`
    /// with compressed encodings).
    pub skip_after_decode: u64,
    /// Format name for reports.
    pub format: String,
}

/// A reader for the samples a header describes; `input` is the header's
/// path (named in errors about the header, while errors about the data
/// name the data file).
pub fn open_data(input: &Path, spec: &DataSpec) -> CResult<Box<dyn SliceReader>> {
    let path = &spec.data_file;
    let size = spec
        .dims
        .checked_bytes(spec.sample_type.size() as u64)
        .at(input)?;
    match spec.encoding {
        Encoding::Raw => {
            let (offset, exact) = match spec.start {
                DataStart::At(o) => (o, false),
                DataStart::AtEnd => {
                    let len = std::fs::metadata(path).at(path)?.len();
                    let o = len.checked_sub(size).ok_or_else(|| {
                        ConvertError::new(
                            path,
                            Error::invalid(format!(
                                "{} {} needs {size} bytes but the file has {len}",
                                spec.dims, spec.sample_type
                            )),
                        )
                    })?;
                    (o, true)
                }
            };
            let r = RawFileReader::open(
                path,
                spec.dims,
                spec.sample_type,
                spec.big_endian,
                offset,
                exact,
                &spec.format,
            )?
            .with_spacing(spec.spacing);
            let mut r = r;
            r.info.path = input.to_path_buf();
            Ok(Box::new(r))
        }
        Encoding::Gzip | Encoding::Zlib => {
            let offset = match spec.start {
                DataStart::At(o) => o,
                DataStart::AtEnd => {
                    return Err(ConvertError::new(
                        input,
                        Error::invalid("compressed data cannot be located from the file's end"),
                    ))
                }
            };
            let mut f = std::fs::File::open(path).at(path)?;
            use std::io::Seek;
            f.seek(std::io::SeekFrom::Start(offset)).at(path)?;
            let counted = Counted::new(std::io::BufReader::with_capacity(1 << 20, f));
            let counter = counted.counter();
            let mut dec: Box<dyn Read + Send> = match spec.encoding {
                Encoding::Gzip => Box::new(flate2::read::MultiGzDecoder::new(counted)),
                _ => Box::new(flate2::read::ZlibDecoder::new(counted)),
            };
            skip_bytes(&mut dec, spec.skip_after_decode).at(path)?;
            let r = StreamReader::new(
                path,
                dec,
                counter,
                SampleLayout {
                    dims: spec.dims,
                    sample_type: spec.sample_type,
                    big_endian: spec.big_endian,
                },
                StreamEnd::Ignore,
                &spec.format,
            )
            .with_spacing(spec.spacing);
            Ok(Box::new(r))
        }
    }
}

/// Read and drop `n` bytes.
pub fn skip_bytes(r: &mut dyn Read, n: u64) -> std::io::Result<()> {
    let got = std::io::copy(&mut r.take(n), &mut std::io::sink())?;
    if got < n {
        return Err(std::io::Error::new(
            std::io::ErrorKind::UnexpectedEof,
            "data ends inside the bytes to skip",
        ));
    }
    Ok(())
}
