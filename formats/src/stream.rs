//! Samples read front to back from a stream (a pipe, standard input, a
//! decompressor), slice by slice with bounded memory.

use crate::error::Error;
use crate::reader::{Access, At, CResult, ConvertError, Described, InputInfo, SliceReader};
use crate::slice::{SliceData, SliceType};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use volcore::{Dims, Geometry};

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
    pub sample_type: SliceType,
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
                nifti_codes: None,
                path: path.to_path_buf(),
                dims,
                sample_type: t,
                spacing: None,
                geometry: Geometry::IDENTITY,
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

impl Described for StreamReader {
    fn info_mut(&mut self) -> &mut InputInfo {
        &mut self.info
    }
}

impl SliceReader for StreamReader {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Sequential
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
                let mut t = [0u8; crate::vvol::trailer::TRAILER_LEN as usize];
                read_full(&mut st.reader, &mut t).map_err(|_| {
                    self.err("input is truncated: the .vvol trailer is missing".into())
                })?;
                let t = crate::vvol::trailer::Trailer::decode(&t).at(&self.path)?;
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
