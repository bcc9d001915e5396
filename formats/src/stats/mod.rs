//! Statistics of a volume's samples, streamed slice by slice with bounded
//! memory: count, minimum, maximum, mean and standard deviation (in `f64`,
//! ddof 0 as numpy's `std()`), exact percentiles and a histogram, over
//! every voxel or inside a mask, and per label of a label volume (what
//! c3d's `-lstat` gives). `vol-info --stats` prints them.
//!
//! - Samples are read in the input's own type (`f64`, `i32`, ... as
//!   stored), through [`SliceReader`]s opened once per pass.
//! - NaN and infinite samples are counted apart and left out of
//!   everything else (moments, range, percentiles, histogram).
//! - Moments are computed per block of slices in two passes over the
//!   block (pairwise sums) and merged in block order ([`Moments`]); blocks
//!   depend on the dimensions only, so the figures are the same whatever
//!   the thread count.
//! - Percentiles are exact: the order statistics they need are found by
//!   radix selection on order-preserving keys of the samples, 16 bits a
//!   pass ([`passes`]: one pass for 8- and 16-bit types, two for 32-bit
//!   types, four for `f64`), then interpolated as numpy's default
//!   ('linear') method does, in `f64`.
//! - The histogram follows [`volcore::histogram`]'s rule, as the `.vidx`
//!   histogram of `vol-index` does: `bins` means the same in both tools.

mod moments;
mod read;
mod sample;
mod select;
#[cfg(test)]
mod tests;

pub use moments::Moments;
pub use read::{Inputs, OpenVolume, Opener};
pub use select::PERCENTILES;

use crate::reader::{At, ConvertError};
use crate::slice::{each_slice, SliceData, SliceType};
use read::Block;
use sample::StatSample;
use select::Rank;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use volcore::histogram::{self, Histogram};

/// The most distinct labels a label volume may hold.
pub const MAX_LABELS: usize = 65536;

/// Degrees of freedom the standard deviation subtracts (numpy's default:
/// the population standard deviation, divided by the count).
pub const DDOF: u64 = 0;

/// Why statistics could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum StatsError {
    /// A file could not be read, or holds what cannot be a label.
    #[error(transparent)]
    Read(#[from] ConvertError),
    /// The mask or labels do not have the volume's dimensions (a usage
    /// error: the files do not go together).
    #[error("{0}")]
    Mismatch(String),
    /// The label volume holds more than [`MAX_LABELS`] labels.
    #[error("{}: more than {MAX_LABELS} distinct labels (is it a label volume?)", .0.display())]
    TooManyLabels(PathBuf),
}

/// What to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// Histogram bins, as `vol-index --bins` ([`volcore::histogram`]).
    pub bins: u32,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            bins: histogram::DEFAULT_BINS,
        }
    }
}

/// Counts of the voxels of a set, finite or not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Voxels in the set (inside the mask, or with the label).
    pub voxels: u64,
    /// Of them, NaN samples.
    pub nan: u64,
    /// Of them, infinite samples (either sign).
    pub infinite: u64,
}

/// The statistics of one label.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelStats {
    /// The label value.
    pub label: i64,
    /// Its voxels (inside the mask, when there is one).
    pub counts: Counts,
    /// The moments of its finite samples.
    pub moments: Moments,
}

impl LabelStats {
    /// The label's physical volume: its voxels times the voxel volume
    /// (the product of `spacing`), in the spacing's unit cubed.
    pub fn volume(&self, spacing: [f64; 3]) -> f64 {
        self.counts.voxels as f64 * spacing[0] * spacing[1] * spacing[2]
    }
}

/// The statistics of a volume (inside its mask).
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    /// The samples' type as read.
    pub sample_type: SliceType,
    /// The voxels counted, NaN and infinite among them.
    pub counts: Counts,
    /// The moments of the finite samples (`count` of them).
    pub moments: Moments,
    /// [`PERCENTILES`] with their values; empty without finite samples.
    pub percentiles: Vec<(u32, f64)>,
    /// The finite samples' histogram (`None` without any); its NaN count
    /// is `counts.nan`.
    pub histogram: Option<Histogram>,
    /// Per label in increasing order, with a label volume.
    pub labels: Option<Vec<LabelStats>>,
}

/// Passes over the input that the statistics of samples of type `t` take
/// (when there are finite samples): one for 8- and 16-bit types, two for
/// 32-bit types, four for `f64` (16 bits of the percentiles' keys each).
pub fn passes(t: SliceType) -> u32 {
    sample::key_bits(t) / 16
}

/// Compute the statistics of `inputs` (see the module docs). `progress`
/// is called from the calling thread with the slices done since its last
/// call, [`passes`] times the depth in all.
pub fn compute(
    inputs: &Inputs,
    opts: &Options,
    progress: &dyn Fn(u64),
) -> Result<Stats, StatsError> {
    let mut first = First::new();
    let t = read::run_pass(inputs, &|b| first_block(b), &mut |p| first.add(p), progress)?;
    let counts = first.counts;
    let moments = Moments::merge_all(&first.moments);
    let labels = inputs.labels.is_some().then(|| {
        first
            .labels
            .into_iter()
            .map(|(label, l)| LabelStats {
                label,
                counts: l.counts,
                moments: l.moments,
            })
            .collect()
    });
    let mut stats = Stats {
        sample_type: t,
        counts,
        moments,
        percentiles: Vec::new(),
        histogram: None,
        labels,
    };
    let Some((min, max)) = moments.range() else {
        return Ok(stats);
    };
    let n = moments.count;
    let positions: Vec<(u64, u64, f64)> = PERCENTILES
        .iter()
        .map(|&p| select::position(n, p))
        .collect();
    let mut ranks: Vec<Rank> = positions
        .iter()
        .flat_map(|&(lo, hi, _)| [Rank::new(lo), Rank::new(hi)])
        .collect();
    for r in &mut ranks {
        r.descend(&first.digits);
    }
    let layout = match sample::value_slots(t) {
        Some((start, len, type_min)) => {
            let mut h =
                Histogram::from_exact(type_min, &first.digits[start..start + len], opts.bins);
            h.set_nan_count(counts.nan);
            stats.histogram = Some(h);
            None
        }
        None => Some(Layout::of(t, min, max, opts.bins)),
    };
    for digits in 1..passes(t) {
        let mut prefixes: Vec<u64> = ranks.iter().map(|r| r.prefix().0).collect();
        prefixes.sort_unstable();
        prefixes.dedup();
        let display = layout.filter(|_| digits == 1);
        let job = Later {
            prefixes: &prefixes,
            digits,
            display,
        };
        let mut sum = LaterPart::new(prefixes.len(), display);
        read::run_pass(inputs, &|b| job.block(b), &mut |p| sum.add(p), progress)?;
        for r in &mut ranks {
            if let Ok(i) = prefixes.binary_search(&r.prefix().0) {
                r.descend(&sum.hists[i]);
            }
        }
        if let Some(l) = display {
            let mut h = Histogram::from_parts(l.lo, l.hi, sum.display, 0);
            h.set_nan_count(counts.nan);
            stats.histogram = Some(h);
        }
    }
    let value = |r: &Rank| sample::from_key(t, r.key());
    stats.percentiles = PERCENTILES
        .iter()
        .zip(positions.iter().zip(ranks.chunks(2)))
        .map(|(&p, (&(_, _, gamma), r))| (p, select::lerp(value(&r[0]), value(&r[1]), gamma)))
        .collect();
    Ok(stats)
}

/// The bins of the histogram of a type whose values do not each get a
/// slot of the first pass (32- and 64-bit types): integer widths from
/// the minimum for integers, `bins` equal bins over the range for floats
/// ([`volcore::histogram`]).
#[derive(Clone, Copy, Debug)]
struct Layout {
    lo: f64,
    hi: f64,
    bins: usize,
}

impl Layout {
    fn of(t: SliceType, min: f64, max: f64, bins: u32) -> Layout {
        let bins = bins.max(1) as u64;
        if t.is_integer() {
            let span = (max - min) as u64 + 1;
            let width = span.div_ceil(bins);
            let n = span.div_ceil(width);
            Layout {
                lo: min,
                hi: min + (n * width) as f64,
                bins: n as usize,
            }
        } else {
            Layout {
                lo: min,
                hi: max,
                bins: bins as usize,
            }
        }
    }
}

/// What one label gathered.
#[derive(Clone, Copy, Debug, Default)]
struct LabelPart {
    counts: Counts,
    moments: Moments,
}

/// The first pass's figures for one block.
struct FirstPart {
    counts: Counts,
    moments: Moments,
    /// Finite samples per first key digit.
    digits: Vec<u64>,
    labels: BTreeMap<i64, LabelPart>,
    labels_path: PathBuf,
}

/// The first pass's figures so far, blocks added in order.
struct First {
    counts: Counts,
    moments: Vec<Moments>,
    digits: Vec<u64>,
    labels: BTreeMap<i64, LabelPart>,
}

impl First {
    fn new() -> First {
        First {
            counts: Counts::default(),
            moments: Vec::new(),
            digits: vec![0; 1 << 16],
            labels: BTreeMap::new(),
        }
    }

    fn add(&mut self, p: FirstPart) -> Result<(), StatsError> {
        add_counts(&mut self.counts, &p.counts);
        self.moments.push(p.moments);
        for (a, b) in self.digits.iter_mut().zip(&p.digits) {
            *a += b;
        }
        for (label, l) in p.labels {
            let e = self.labels.entry(label).or_default();
            add_counts(&mut e.counts, &l.counts);
            e.moments = e.moments.merge(&l.moments);
        }
        if self.labels.len() > MAX_LABELS {
            return Err(StatsError::TooManyLabels(p.labels_path));
        }
        Ok(())
    }
}

fn add_counts(a: &mut Counts, b: &Counts) {
    a.voxels += b.voxels;
    a.nan += b.nan;
    a.infinite += b.infinite;
}

/// The finite samples of a label in one block, and its counts.
#[derive(Default)]
struct LabelValues {
    counts: Counts,
    values: Vec<f64>,
}

/// A block's samples gathered for the first pass.
struct Gather {
    counts: Counts,
    values: Vec<f64>,
    digits: Vec<u64>,
    /// Labels in the order met, and where each is in `per_label`.
    per_label: Vec<(i64, LabelValues)>,
    index: HashMap<i64, usize>,
    last: Option<(i64, usize)>,
}

impl Gather {
    /// The values gathered for `label`; `None` past [`MAX_LABELS`].
    fn label(&mut self, label: i64) -> Option<&mut LabelValues> {
        let i = match self.last {
            Some((l, i)) if l == label => i,
            _ => {
                let next = self.per_label.len();
                let i = *self.index.entry(label).or_insert(next);
                if i == next {
                    if next >= MAX_LABELS {
                        return None;
                    }
                    self.per_label.push((label, LabelValues::default()));
                }
                self.last = Some((label, i));
                i
            }
        };
        Some(&mut self.per_label[i].1)
    }

    fn slice<T: StatSample>(
        &mut self,
        v: &[T],
        keep: Option<&[bool]>,
        labels: Option<&[i64]>,
    ) -> bool {
        for (i, &x) in v.iter().enumerate() {
            if keep.is_some_and(|k| !k[i]) {
                continue;
            }
            let f = x.f64();
            let finite = x.finite();
            count(&mut self.counts, f, finite);
            if finite {
                self.values.push(f);
                self.digits[(x.key() >> 48) as usize] += 1;
            }
            if let Some(l) = labels {
                let Some(lv) = self.label(l[i]) else {
                    return false;
                };
                count(&mut lv.counts, f, finite);
                if finite {
                    lv.values.push(f);
                }
            }
        }
        true
    }
}

/// Count one sample of a set.
#[inline]
fn count(c: &mut Counts, f: f64, finite: bool) {
    c.voxels += 1;
    if !finite {
        if f.is_nan() {
            c.nan += 1;
        } else {
            c.infinite += 1;
        }
    }
}

/// The first pass over one block: counts, moments, the first key digits
/// and the labels' figures.
fn first_block(b: &Block) -> Result<FirstPart, StatsError> {
    let mut g = Gather {
        counts: Counts::default(),
        values: Vec::new(),
        digits: vec![0; 1 << 16],
        per_label: Vec::new(),
        index: HashMap::new(),
        last: None,
    };
    for (k, s) in b.values.iter().enumerate() {
        let keep = b.mask.get(k).map(Vec::as_slice);
        let labels = b.labels.get(k).map(Vec::as_slice);
        if !each_slice!(s, v => g.slice(v, keep, labels)) {
            return Err(StatsError::TooManyLabels(b.labels_path.clone()));
        }
    }
    let labels = g
        .per_label
        .into_iter()
        .map(|(label, lv)| {
            let part = LabelPart {
                counts: lv.counts,
                moments: Moments::of(&lv.values),
            };
            (label, part)
        })
        .collect();
    Ok(FirstPart {
        counts: g.counts,
        moments: Moments::of(&g.values),
        digits: g.digits,
        labels,
        labels_path: b.labels_path.clone(),
    })
}

/// A later pass: the next key digit of the samples under each prefix
/// the percentiles are in, and (on the second pass) the histogram.
struct Later<'a> {
    prefixes: &'a [u64],
    digits: u32,
    display: Option<Layout>,
}

/// What a later pass counted.
struct LaterPart {
    hists: Vec<Vec<u64>>,
    display: Vec<u64>,
}

impl LaterPart {
    fn new(prefixes: usize, display: Option<Layout>) -> LaterPart {
        LaterPart {
            hists: vec![vec![0; 1 << 16]; prefixes],
            display: vec![0; display.map_or(0, |l| l.bins)],
        }
    }

    fn add(&mut self, p: LaterPart) -> Result<(), StatsError> {
        for (a, b) in self.hists.iter_mut().zip(&p.hists) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        for (x, y) in self.display.iter_mut().zip(&p.display) {
            *x += y;
        }
        Ok(())
    }
}

impl Later<'_> {
    fn block(&self, b: &Block) -> Result<LaterPart, StatsError> {
        let mut part = LaterPart::new(self.prefixes.len(), self.display);
        for (k, s) in b.values.iter().enumerate() {
            let keep = b.mask.get(k).map(Vec::as_slice);
            each_slice!(s, v => self.slice(v, keep, &mut part));
        }
        Ok(part)
    }

    fn slice<T: StatSample>(&self, v: &[T], keep: Option<&[bool]>, part: &mut LaterPart) {
        let shift = 64 - 16 * self.digits;
        for (i, &x) in v.iter().enumerate() {
            if keep.is_some_and(|k| !k[i]) || !x.finite() {
                continue;
            }
            let key = x.key();
            if let Ok(j) = self.prefixes.binary_search(&(key >> shift)) {
                part.hists[j][select::digit(key, self.digits)] += 1;
            }
            if let Some(l) = self.display {
                part.display[histogram::bin_of(x.f64(), l.lo, l.hi, l.bins)] += 1;
            }
        }
    }
}

/// Whether a block's slice `s` of a mask keeps each voxel (non-zero).
fn mask_of(s: &SliceData) -> Vec<bool> {
    fn nonzero<T: StatSample>(v: &[T]) -> Vec<bool> {
        v.iter().map(|x| x.f64() != 0.0).collect()
    }
    each_slice!(s, v => nonzero(v))
}

/// The labels of a block's slice `s` of a label volume read from `path`:
/// whole numbers, else an error naming the first value that is not.
fn labels_of(s: &SliceData, path: &Path) -> Result<Vec<i64>, ConvertError> {
    fn whole<T: StatSample>(v: &[T]) -> Result<Vec<i64>, f64> {
        // Integers of up to 32 bits, and floats holding whole numbers
        // exactly representable in both f64 and i64.
        const LIMIT: f64 = 9_007_199_254_740_992.0; // 2^53
        v.iter()
            .map(|x| {
                let f = x.f64();
                if f.fract() == 0.0 && f.abs() <= LIMIT {
                    Ok(f as i64)
                } else {
                    Err(f)
                }
            })
            .collect()
    }
    each_slice!(s, v => whole(v))
        .map_err(|bad| {
            crate::error::Error::invalid(format!(
                "label value {bad} is not a whole number (a label volume holds integers)"
            ))
        })
        .at(path)
}
