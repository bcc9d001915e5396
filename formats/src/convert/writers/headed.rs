//! The header formats (NIfTI, NRRD, MetaImage): a header and the samples,
//! in one file or two, raw or compressed.

use super::raw::Rows;
use super::{DataCodec, HeaderFormat, Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::output::AtomicFile;
use crate::reader::{At, CResult, ConvertError, NiftiCodes};
use crate::slice::SliceSample;
use std::io::{BufWriter, Write};
use std::ops::Range;
use std::path::PathBuf;
use volcore::Sample;

struct HeadedOut<'a> {
    /// The samples' encoder, writing to a handle on the header's file or
    /// the data file.
    enc: Box<dyn FinishWrite>,
    rows: Rows<'a>,
    head: AtomicFile,
    /// A detached data file and its path.
    data: Option<(AtomicFile, PathBuf)>,
    /// The header's path.
    path: PathBuf,
}

/// Write a header format and its samples; both files appear only when
/// complete: the data file first, then the header (the commit point; an
/// older header is removed before the data file is replaced).
pub(super) fn open<'a, T: SliceSample>(
    path: PathBuf,
    spec: &OutSpec<'a>,
    format: HeaderFormat,
    data: Option<PathBuf>,
    (codec, level): (DataCodec, u32),
) -> Opened<'a, T> {
    let data_name = data.as_ref().map(|d| {
        d.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    let header = header_bytes::<T>(format, spec, data_name.as_deref(), codec);
    let mut head = AtomicFile::create(&path).at(&path)?;
    let data = match data {
        Some(d) => Some((AtomicFile::create(&d).at(&d)?, d)),
        None => None,
    };
    let enc = match &data {
        Some((f, d)) => {
            head.file().write_all(&header).at(&path)?;
            encoder(Box::new(f.handle().at(d)?), (codec, level))
        }
        None => {
            let mut head_out = BufWriter::with_capacity(1 << 16, head.handle().at(&path)?);
            if format == HeaderFormat::Nifti {
                // A .nii.gz is one gzip stream of header and samples.
                let mut enc = encoder(Box::new(head_out), (codec, level));
                enc.write_all(&header).at(&path)?;
                enc
            } else {
                // Attached data: a plain header, then the samples.
                head_out.write_all(&header).at(&path)?;
                encoder(Box::new(head_out), (codec, level))
            }
        }
    };
    Ok(Box::new(HeadedOut {
        enc,
        rows: Rows::new::<T>(spec.dims, spec.progress),
        head,
        data,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for HeadedOut<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.rows.next_slices()
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        let path = match &self.data {
            Some((_, d)) => d,
            None => &self.path,
        };
        self.rows.write(win, &mut *self.enc, path)
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let HeadedOut {
            enc,
            head,
            data,
            path,
            ..
        } = *self;
        enc.finish_all()
            .at(data.as_ref().map_or(&path, |(_, d)| d))?;
        let mut bytes = 0;
        if let Some((f, d)) = data {
            // The header is the pair's commit point: data first, header
            // last. An older header goes before the data is replaced, so
            // that no moment shows it beside data it does not describe
            // (killed in between, the output is absent: a data file alone
            // is not one).
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(ConvertError::new(&path, e))
                }
                _ => {}
            }
            f.commit().at(&d)?;
            bytes += std::fs::metadata(&d).map(|m| m.len()).unwrap_or(0);
        }
        head.commit().at(&path)?;
        bytes += std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        Ok(Written { bytes, range: None })
    }
}

/// The header of a [`super::Target::Headed`] file for `T` samples;
/// `data_name` is the detached data file's name, relative to the header.
fn header_bytes<T: Sample>(
    format: HeaderFormat,
    spec: &OutSpec<'_>,
    data_name: Option<&str>,
    codec: DataCodec,
) -> Vec<u8> {
    match format {
        HeaderFormat::Nifti => {
            let layout = if data_name.is_some() {
                crate::nifti::NiftiLayout::Pair
            } else {
                crate::nifti::NiftiLayout::Single
            };
            crate::nifti::encode_header(
                spec.dims,
                T::TYPE,
                spec.spacing,
                &spec.geometry,
                spec.nifti_codes.unwrap_or(NiftiCodes::SCANNER),
                layout,
            )
        }
        HeaderFormat::Nrrd => crate::nrrd::write_header(&crate::nrrd::NrrdOut {
            dims: spec.dims,
            sample_type: T::TYPE,
            spacing: spec.spacing,
            geometry: spec.geometry,
            gzip: codec == DataCodec::Gzip,
            data_file: data_name.map(str::to_string),
        })
        .into_bytes(),
        HeaderFormat::MetaImage => crate::mhd::write_header(
            spec.dims,
            T::TYPE,
            spec.spacing,
            &spec.geometry,
            codec == DataCodec::Zlib,
            data_name.unwrap_or("LOCAL"),
        )
        .into_bytes(),
    }
}

/// `w` behind the codec's encoder.
fn encoder(w: Box<dyn Write + Send>, (codec, level): (DataCodec, u32)) -> Box<dyn FinishWrite> {
    let level = flate2::Compression::new(level);
    match codec {
        DataCodec::Raw => Box::new(BufWriter::with_capacity(1 << 20, w)),
        // Members compressed on every core (crate::gzip).
        DataCodec::Gzip => Box::new(crate::gzip::ParallelGz::new(
            BufWriter::with_capacity(1 << 20, w),
            level.level(),
        )),
        DataCodec::Zlib => Box::new(flate2::write::ZlibEncoder::new(w, level)),
    }
}

/// A writer that must be told when the data ends (compressors); done, it
/// has flushed everything to the file below.
trait FinishWrite: Write + Send {
    fn finish_all(self: Box<Self>) -> std::io::Result<()>;
}

impl<W: Write + Send> FinishWrite for BufWriter<W> {
    fn finish_all(mut self: Box<Self>) -> std::io::Result<()> {
        self.flush()
    }
}

impl<W: Write + Send> FinishWrite for crate::gzip::ParallelGz<W> {
    fn finish_all(self: Box<Self>) -> std::io::Result<()> {
        self.finish().and_then(|mut w| w.flush())
    }
}

impl<W: Write + Send> FinishWrite for flate2::write::ZlibEncoder<W> {
    fn finish_all(self: Box<Self>) -> std::io::Result<()> {
        self.finish().and_then(|mut w| w.flush())
    }
}
