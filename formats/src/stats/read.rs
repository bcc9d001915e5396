//! The inputs of the statistics read together, block by block: the
//! volume, and its mask and labels slice for slice.

use super::{labels_of, mask_of, StatsError};
use crate::reader::{Access, CResult, SliceReader};
use crate::slice::{SliceData, SliceType};
use crate::vvol::BorrowedReader;
use rayon::prelude::*;
use std::ops::Range;
use std::path::PathBuf;
use volcore::Volume;

/// Opens a reader of one input; called once per pass, so a stream that
/// cannot be read twice needs an opener over a copy ([`OpenVolume`]).
/// Closures returning a reader are openers.
pub trait Opener: Sync {
    /// A new reader of the input, from its first slice.
    fn open(&self) -> CResult<Box<dyn SliceReader + '_>>;
}

impl<F: Fn() -> CResult<Box<dyn SliceReader>> + Sync> Opener for F {
    fn open(&self) -> CResult<Box<dyn SliceReader + '_>> {
        self()
    }
}

/// A volume already open (read from standard input, say) as an
/// [`Opener`]: each pass reads it again where it is.
pub struct OpenVolume<'v> {
    /// The name it was read from, for messages.
    pub path: PathBuf,
    /// The volume.
    pub volume: &'v Volume,
}

impl Opener for OpenVolume<'_> {
    fn open(&self) -> CResult<Box<dyn SliceReader + '_>> {
        Ok(Box::new(BorrowedReader::new(
            &self.path,
            self.volume,
            "open volume",
        )))
    }
}

/// The files the statistics read.
pub struct Inputs<'a> {
    /// The volume.
    pub values: &'a dyn Opener,
    /// A volume of the same dimensions: only voxels where it is non-zero
    /// are counted.
    pub mask: Option<&'a dyn Opener>,
    /// A volume of whole numbers of the same dimensions: figures per label.
    pub labels: Option<&'a dyn Opener>,
}

/// Voxels a block of slices holds at least (whole slices): large enough
/// that a block's histograms cost little next to its samples.
const BLOCK_VOXELS: u64 = 1 << 20;

/// Consecutive slices of the inputs.
pub(crate) struct Block {
    /// The volume's slices.
    pub values: Vec<SliceData>,
    /// The mask's, as keep flags (empty without a mask).
    pub mask: Vec<Vec<bool>>,
    /// The labels' (empty without labels).
    pub labels: Vec<Vec<i64>>,
    /// The label volume's path, for messages.
    pub labels_path: PathBuf,
}

/// The readers of one pass.
struct Open<'a> {
    values: Box<dyn SliceReader + 'a>,
    mask: Option<Box<dyn SliceReader + 'a>>,
    labels: Option<Box<dyn SliceReader + 'a>>,
    labels_path: PathBuf,
}

impl<'a> Open<'a> {
    fn new(inputs: &Inputs<'a>) -> Result<Open<'a>, StatsError> {
        let values = inputs.values.open()?;
        let open_same = |o: Option<&'a dyn Opener>, what: &str| -> Result<_, StatsError> {
            let Some(o) = o else { return Ok(None) };
            let r = o.open()?;
            let (a, b) = (r.info(), values.info());
            if a.dims != b.dims {
                return Err(StatsError::Mismatch(format!(
                    "{}: the {what} has {} voxels but {} has {}: they must match",
                    a.path.display(),
                    a.dims,
                    b.path.display(),
                    b.dims
                )));
            }
            Ok(Some(r))
        };
        let mask = open_same(inputs.mask, "mask")?;
        let labels = open_same(inputs.labels, "label volume")?;
        let labels_path = labels
            .as_ref()
            .map(|r| r.info().path.clone())
            .unwrap_or_default();
        Ok(Open {
            values,
            mask,
            labels,
            labels_path,
        })
    }

    fn readers(&self) -> impl Iterator<Item = &(dyn SliceReader + 'a)> {
        std::iter::once(self.values.as_ref())
            .chain(self.mask.as_deref())
            .chain(self.labels.as_deref())
    }

    fn random(&self) -> bool {
        self.readers().all(|r| r.access() == Access::Random)
    }

    fn read(&self, zs: Range<u64>) -> Result<Block, StatsError> {
        let mut b = Block {
            values: Vec::new(),
            mask: Vec::new(),
            labels: Vec::new(),
            labels_path: self.labels_path.clone(),
        };
        for z in zs {
            b.values.push(self.values.read_slice(z)?);
            if let Some(m) = &self.mask {
                b.mask.push(mask_of(&m.read_slice(z)?));
            }
            if let Some(l) = &self.labels {
                b.labels
                    .push(labels_of(&l.read_slice(z)?, &self.labels_path)?);
            }
        }
        Ok(b)
    }

    fn finish(&self) -> Result<(), StatsError> {
        for r in self.readers() {
            r.finish()?;
        }
        Ok(())
    }
}

/// One pass: `work` on every block (in parallel), `sink` on what it
/// returns in block order; `progress` after each group of blocks with
/// their slices. Returns the type of the volume's samples.
pub(crate) fn run_pass<P: Send>(
    inputs: &Inputs,
    work: &(dyn Fn(&Block) -> Result<P, StatsError> + Sync),
    sink: &mut dyn FnMut(P) -> Result<(), StatsError>,
    progress: &dyn Fn(u64),
) -> Result<SliceType, StatsError> {
    let open = Open::new(inputs)?;
    let info = open.values.info();
    let d = info.dims;
    let per_block = (BLOCK_VOXELS / d.slice_len().max(1)).max(1);
    let blocks: Vec<Range<u64>> = (0..d.z)
        .step_by(per_block as usize)
        .map(|z| z..(z + per_block).min(d.z))
        .collect();
    // Blocks in flight: enough for every thread, few enough for memory.
    let group = 2 * rayon::current_num_threads().max(1);
    let random = open.random();
    for g in blocks.chunks(group) {
        let parts: Vec<Result<P, StatsError>> = if random {
            g.par_iter()
                .map(|zs| open.read(zs.clone()).and_then(|b| work(&b)))
                .collect()
        } else {
            let read = g
                .iter()
                .map(|zs| open.read(zs.clone()))
                .collect::<Result<Vec<_>, _>>()?;
            read.par_iter().map(work).collect()
        };
        for p in parts {
            sink(p?)?;
        }
        progress(g.iter().map(|zs| zs.end - zs.start).sum());
    }
    open.finish()?;
    Ok(info.sample_type)
}
