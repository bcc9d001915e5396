//! `.vvol` output: a file, one shard's part file, or a sliced stream.

use super::{Opened, OutSpec, SliceWriter, Written};
use crate::convert::SliceWindow;
use crate::error::Error;
use crate::output::{AtomicFile, Sink};
use crate::reader::{At, CResult};
use crate::slice::SliceSample;
use crate::vvol::VvolWriter;
use std::io::Write;
use std::ops::Range;
use std::path::PathBuf;
use volcore::{BrickGeometry, Compression, Layout, Sample, Shard, ValueRange, VolumeMeta};

struct VvolOut<'a> {
    w: VvolWriter<'a>,
    /// The output file, renamed into place when complete (`None`: a
    /// stream).
    file: Option<AtomicFile>,
    path: PathBuf,
}

/// A `.vvol` file, sliced (`brick: None`) or bricked; with `shard`, that
/// shard's part file.
pub(super) fn open<'a, T: SliceSample>(
    path: PathBuf,
    spec: &OutSpec<'a>,
    brick: Option<u32>,
    compression: Compression,
    shard: Option<Shard>,
) -> Opened<'a, T> {
    let meta = meta::<T>(spec, brick, compression).at(&path)?;
    let file = AtomicFile::create(&path).at(&path)?;
    let sink = Sink::OwnedFile(file.handle().at(&path)?);
    let w = match shard {
        None => VvolWriter::new(sink, meta, spec.progress),
        Some(shard) => VvolWriter::new_part(sink, meta, shard, spec.progress),
    }
    .at(&path)?;
    Ok(Box::new(VvolOut {
        w,
        file: Some(file),
        path,
    }))
}

/// A sliced `.vvol` stream.
pub(super) fn open_stream<'a, T: SliceSample>(
    out: Box<dyn Write + Send>,
    spec: &OutSpec<'a>,
) -> Opened<'a, T> {
    let path = PathBuf::from("-");
    let meta = meta::<T>(spec, None, Compression::None).at(&path)?;
    let w = VvolWriter::new(Sink::OwnedStream(out), meta, spec.progress).at(&path)?;
    Ok(Box::new(VvolOut {
        w,
        file: None,
        path,
    }))
}

impl<T: SliceSample> SliceWriter<T> for VvolOut<'_> {
    fn next_slices(&self) -> Range<u64> {
        self.w.next_slices()
    }
    fn write_next(&mut self, win: &SliceWindow<T>) -> CResult<()> {
        self.w.write_next(win).at(&self.path)
    }
    fn finish(self: Box<Self>) -> CResult<Written> {
        let VvolOut { w, file, path } = *self;
        let stats = w.finish().at(&path)?;
        if let Some(file) = file {
            file.commit().at(&path)?;
        }
        Ok(Written {
            bytes: stats.bytes,
            range: Some(stats.range),
        })
    }
}

fn meta<T: Sample>(
    spec: &OutSpec<'_>,
    brick: Option<u32>,
    compression: Compression,
) -> crate::error::Result<VolumeMeta> {
    let layout = match brick {
        None => Layout::Sliced,
        Some(b) => Layout::Bricked(BrickGeometry::new(spec.dims, b)?),
    };
    if layout == Layout::Sliced && compression != Compression::None {
        return Err(Error::invalid(
            "--compress needs --layout bricked:B (compression is per brick)",
        ));
    }
    Ok(VolumeMeta {
        dims: spec.dims,
        spacing: spec.spacing,
        sample_type: T::TYPE,
        range: ValueRange::EMPTY,
        layout,
        compression,
        geometry: spec.geometry,
        narrowed: None,
    })
}
