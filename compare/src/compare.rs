//! Comparing two images or two volumes.

use crate::error::{Error, Result};
use crate::image::{Depth, Image};
use crate::metrics::{Accumulator, Metrics};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use volcore::{Sample, SampleType, ValueRange, Volume, VolumeVisitor, VoxelSource};

/// Rec. 709 luma weights for R, G, B.
pub const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Where the peak (data range) of a comparison came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeakSource {
    /// Given by the caller (`--range`).
    Given,
    /// The range of an integer sample type (255, 65535).
    Type,
    /// 1.0, the default for float images (and for float volumes whose
    /// reference is constant).
    FloatDefault,
    /// The reference (first) float volume's value range, max − min.
    ReferenceRange,
}

impl PeakSource {
    /// A short name for reports: `given`, `type`, `float-default`,
    /// `reference-range`.
    pub fn name(self) -> &'static str {
        match self {
            PeakSource::Given => "given",
            PeakSource::Type => "type",
            PeakSource::FloatDefault => "float-default",
            PeakSource::ReferenceRange => "reference-range",
        }
    }
}

fn given_range(range: Option<f64>) -> Result<Option<f64>> {
    match range {
        Some(r) if !(r.is_finite() && r > 0.0) => Err(Error::invalid(format!(
            "the range must be positive and finite, not {r}"
        ))),
        r => Ok(r),
    }
}

/// What to compare in two images.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageOptions {
    /// Peak (data range) for the PSNR; `None` takes the depth's: 255,
    /// 65535, or 1.0 for float images.
    pub range: Option<f64>,
    /// Compare the alpha channel too (when both images have one).
    pub alpha: bool,
    /// Also compare Rec. 709 luma Y' = 0.2126 R + 0.7152 G + 0.0722 B of
    /// the stored values (for grey images Y' is the grey channel); the
    /// error map then shows |ΔY'|.
    pub luma: bool,
    /// Build the per-pixel error map.
    pub error_map: bool,
}

/// How two images differ.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageComparison {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// The images' sample depth.
    pub depth: Depth,
    /// The compared channels' names (`Y` or `R G B`, then `A` with alpha).
    pub channels: Vec<&'static str>,
    /// The data range the PSNRs are relative to.
    pub peak: f64,
    /// Where `peak` came from.
    pub peak_source: PeakSource,
    /// Pooled over all compared channels: the figure that matches
    /// scikit-image's `peak_signal_noise_ratio`.
    pub pooled: Metrics,
    /// One entry per compared channel, in `channels` order.
    pub per_channel: Vec<Metrics>,
    /// Rec. 709 luma, when asked for.
    pub luma: Option<Metrics>,
    /// Per pixel, rows from the top down: the largest absolute error over
    /// the compared channels, or |ΔY'| with `luma` (+∞ where not finite).
    pub error_map: Option<Vec<f32>>,
}

impl ImageComparison {
    /// The headline figures: luma when asked for, else pooled.
    pub fn headline(&self) -> &Metrics {
        self.luma.as_ref().unwrap_or(&self.pooled)
    }
}

/// Compare image `b` against the reference `a`.
///
/// The two must have the same size, depth and number of colour channels;
/// with `alpha`, both or neither must have alpha. Without `alpha`, an alpha
/// channel in either image is ignored. Any other difference is an
/// [`Error::Mismatch`].
pub fn compare_images(a: &Image, b: &Image, opts: &ImageOptions) -> Result<ImageComparison> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::mismatch(format!(
            "sizes differ: A is {}x{}, B is {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    if a.depth != b.depth {
        return Err(Error::mismatch(format!(
            "sample types differ: A is {}, B is {}",
            a.format_name(),
            b.format_name()
        )));
    }
    if a.color != b.color {
        return Err(Error::mismatch(format!(
            "channel counts differ: A is {}, B is {}",
            a.format_name(),
            b.format_name()
        )));
    }
    if opts.alpha && a.alpha != b.alpha {
        return Err(Error::mismatch(format!(
            "--alpha needs alpha in both: A is {}, B is {}",
            a.format_name(),
            b.format_name()
        )));
    }
    let (peak, peak_source) = match (given_range(opts.range)?, a.depth.peak()) {
        (Some(r), _) => (r, PeakSource::Given),
        (None, Some(p)) => (p, PeakSource::Type),
        (None, None) => (1.0, PeakSource::FloatDefault),
    };
    let nc = a.color + (opts.alpha && a.alpha) as usize;
    let (sa, sb) = (a.channels(), b.channels());
    let w = a.width as usize;
    let color = a.color;

    struct Row {
        channels: Vec<Accumulator>,
        luma: Accumulator,
        map: Vec<f32>,
    }
    let rows: Vec<Row> = a
        .samples
        .par_chunks_exact(w * sa)
        .zip(b.samples.par_chunks_exact(w * sb))
        .map(|(ra, rb)| {
            let mut row = Row {
                channels: vec![Accumulator::default(); nc],
                luma: Accumulator::default(),
                map: Vec::with_capacity(if opts.error_map { w } else { 0 }),
            };
            for (pa, pb) in ra.chunks_exact(sa).zip(rb.chunks_exact(sb)) {
                let mut worst = 0f64;
                for (c, acc) in row.channels.iter_mut().enumerate() {
                    worst = worst.max(acc.add(pa[c] as f64, pb[c] as f64));
                }
                if opts.luma {
                    let y = |p: &[f32]| {
                        if color == 1 {
                            p[0] as f64
                        } else {
                            REC709[0] * p[0] as f64
                                + REC709[1] * p[1] as f64
                                + REC709[2] * p[2] as f64
                        }
                    };
                    worst = row.luma.add(y(pa), y(pb));
                }
                if opts.error_map {
                    row.map.push(worst as f32);
                }
            }
            row
        })
        .collect();

    let mut per_channel = vec![Accumulator::default(); nc];
    let mut pooled = Accumulator::default();
    let mut luma = Accumulator::default();
    let mut map = Vec::with_capacity(if opts.error_map { a.pixels() } else { 0 });
    for row in &rows {
        for (total, part) in per_channel.iter_mut().zip(&row.channels) {
            total.merge(part);
            pooled.merge(part);
        }
        luma.merge(&row.luma);
        map.extend_from_slice(&row.map);
    }
    Ok(ImageComparison {
        width: a.width,
        height: a.height,
        depth: a.depth,
        channels: a.channel_names()[..nc].to_vec(),
        peak,
        peak_source,
        pooled: pooled.finish(peak),
        per_channel: per_channel.iter().map(|c| c.finish(peak)).collect(),
        luma: opts.luma.then(|| luma.finish(peak)),
        error_map: opts.error_map.then_some(map),
    })
}

/// What to compare in two volumes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeOptions {
    /// Peak (data range) for the PSNR; `None` takes the reference's sample
    /// type range (255, 65535 for u16 and i16), or for f32 the reference's
    /// value range max − min (1.0 if the reference is constant).
    pub range: Option<f64>,
    /// Build the error map: for each (x, y), the largest |Δ| along z.
    pub error_map: bool,
}

/// How two volumes differ.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeComparison {
    /// Voxels per axis.
    pub dims: [u64; 3],
    /// The reference's sample type.
    pub type_a: SampleType,
    /// The other volume's sample type.
    pub type_b: SampleType,
    /// The data range the PSNR is relative to.
    pub peak: f64,
    /// Where `peak` came from.
    pub peak_source: PeakSource,
    /// The reference's smallest and largest finite value (`None` if it has
    /// none).
    pub reference_range: Option<(f64, f64)>,
    /// Pooled over every voxel.
    pub metrics: Metrics,
    /// `X × Y` values, x fastest: the largest |Δ| along z at each (x, y)
    /// (+∞ where a difference is not finite).
    pub error_map: Option<Vec<f32>>,
}

/// Rows per parallel task aim at this many samples.
const TASK_SAMPLES: usize = 1 << 18;

/// Compare volume `b` against the reference `a`, voxel by voxel, as `f64`
/// values of the samples (the sample types may differ).
///
/// The volumes are read row by row in parallel, so memory stays bounded
/// (one row per task, plus `X × Y` for the error map) whatever their size,
/// and memory-mapped volumes are never loaded whole. The result does not
/// depend on the number of threads. Dimensions that differ are an
/// [`Error::Mismatch`]; a stored brick that fails to decode is an
/// [`Error::Invalid`].
pub fn compare_volumes(a: &Volume, b: &Volume, opts: &VolumeOptions) -> Result<VolumeComparison> {
    let (da, db) = (a.dims(), b.dims());
    if da != db {
        return Err(Error::mismatch(format!(
            "dimensions differ: A is {}x{}x{}, B is {}x{}x{}",
            da.x, da.y, da.z, db.x, db.y, db.z
        )));
    }
    let given = given_range(opts.range)?;
    let plane = usize::try_from(da.x * da.y)
        .map_err(|_| Error::invalid("the volume is too large for this machine"))?;
    let map: Option<Vec<AtomicU32>> = opts
        .error_map
        .then(|| (0..plane).map(|_| AtomicU32::new(0)).collect());
    let map_ref = map.as_deref();
    let (acc, range) = a.visit(WithRows(|ra: &dyn Rows| {
        b.visit(WithRows(|rb: &dyn Rows| scan(ra, rb, map_ref)))
    }))?;
    for (name, v) in [("A", a), ("B", b)] {
        if let Some(e) = v.error() {
            return Err(Error::invalid(format!("{name}: {e}")));
        }
    }
    let reference_range = (!range.is_empty()).then_some((range.min, range.max));
    let type_a = a.meta.sample_type;
    let (peak, peak_source) = match (given, type_a.integer_range(), reference_range) {
        (Some(r), _, _) => (r, PeakSource::Given),
        (None, Some((lo, hi)), _) => (hi - lo, PeakSource::Type),
        (None, None, Some((lo, hi))) if hi > lo => (hi - lo, PeakSource::ReferenceRange),
        (None, None, _) => (1.0, PeakSource::FloatDefault),
    };
    Ok(VolumeComparison {
        dims: da.as_array(),
        type_a,
        type_b: b.meta.sample_type,
        peak,
        peak_source,
        reference_range,
        metrics: acc.finish(peak),
        error_map: map.map(|m| {
            m.into_iter()
                .map(|v| f32::from_bits(v.into_inner()))
                .collect()
        }),
    })
}

/// Reads row (`y`, `z`) of a volume into the slice, as f32.
type RowReader<'a> = Box<dyn FnMut(u64, u64, &mut [f32]) + 'a>;

/// A volume's rows as f32, read by one task at a time: the one part of a
/// comparison specialised per sample type and layout (the scan itself is
/// compiled once, not once per pair of volumes' types).
trait Rows: Sync {
    /// The volume's dimensions.
    fn dims(&self) -> volcore::Dims;
    /// A reader of whole rows (`y`, `z`) into `out`, with its own buffer.
    fn reader(&self) -> RowReader<'_>;
}

/// The rows of one sample source.
struct SourceRows<'a, S>(&'a S);

impl<S: VoxelSource> Rows for SourceRows<'_, S> {
    fn dims(&self) -> volcore::Dims {
        self.0.dims()
    }
    fn reader(&self) -> RowReader<'_> {
        let mut buf = Vec::new();
        Box::new(move |y, z, out: &mut [f32]| {
            buf.resize(out.len(), S::Sample::default());
            self.0.read_row(0, y, z, &mut buf);
            for (o, v) in out.iter_mut().zip(&buf) {
                *o = v.to_f32();
            }
        })
    }
}

/// Visits a volume to hand its rows to `f`.
struct WithRows<F>(F);

impl<F, T> VolumeVisitor for WithRows<F>
where
    F: FnOnce(&dyn Rows) -> T,
{
    type Output = T;
    fn visit<S: VoxelSource>(self, src: &S) -> T {
        (self.0)(&SourceRows(src))
    }
}

/// Accumulate over every voxel, in tasks of whole rows; the partial sums are
/// merged in task order, so the figures do not depend on the thread count.
fn scan(
    a: &dyn Rows,
    b: &dyn Rows,
    map: Option<&[AtomicU32]>,
) -> Result<(Accumulator, ValueRange)> {
    let d = a.dims();
    let too_large = || Error::invalid("the volume is too large for this machine");
    let nx = usize::try_from(d.x).map_err(|_| too_large())?;
    let rows_per_task = (TASK_SAMPLES / nx).clamp(1, usize::try_from(d.y).unwrap_or(usize::MAX));
    let rows_per_task = rows_per_task as u64;
    let chunks_y = d.y.div_ceil(rows_per_task);
    let tasks = usize::try_from(d.z * chunks_y).map_err(|_| too_large())?;
    let partials: Vec<(Accumulator, ValueRange)> = (0..tasks)
        .into_par_iter()
        .map(|t| {
            let t = t as u64;
            let z = t / chunks_y;
            let y0 = (t % chunks_y) * rows_per_task;
            let y1 = (y0 + rows_per_task).min(d.y);
            let (mut read_a, mut read_b) = (a.reader(), b.reader());
            let mut ra = vec![0f32; nx];
            let mut rb = vec![0f32; nx];
            let mut acc = Accumulator::default();
            let mut range = ValueRange::EMPTY;
            for y in y0..y1 {
                read_a(y, z, &mut ra);
                read_b(y, z, &mut rb);
                let base = y as usize * nx;
                for (x, (&va, &vb)) in ra.iter().zip(&rb).enumerate() {
                    let (va, vb) = (va as f64, vb as f64);
                    if va.is_finite() {
                        range.add(va);
                    }
                    let e = acc.add(va, vb);
                    if e > 0.0 {
                        if let Some(m) = map {
                            // Non-negative floats order like their bits.
                            m[base + x].fetch_max((e as f32).to_bits(), Ordering::Relaxed);
                        }
                    }
                }
            }
            (acc, range)
        })
        .collect();
    let mut acc = Accumulator::default();
    let mut range = ValueRange::EMPTY;
    for (p, r) in &partials {
        acc.merge(p);
        range = range.merge(*r);
    }
    Ok((acc, range))
}

#[cfg(test)]
mod tests;
