//! Converting volumes between formats, slice by slice, with bounded memory.
//!
//! An input is a [`SliceReader`] (TIFF stacks, raw files and streams,
//! NRRD, MetaImage, `.vvol`, `.vol`). [`convert`] crops, flips and converts
//! the sample type of each slice as it is read ([`Plan`]) and keeps only the
//! slices the output's next unit needs in a [`SliceWindow`]: a slab of
//! slices for sliced outputs, one layer of bricks plus the apron for
//! bricked ones. Random-access inputs decode the slices of a unit in
//! parallel; bricks are compressed in parallel by the `.vvol` writer.
//!
//! Every output file is written under a temporary name and renamed into
//! place only when complete, so a failed conversion leaves nothing behind.

pub mod choose;
pub mod dropped;
pub mod size;
pub mod spool;
pub mod stages;
pub mod units;
pub mod window;
mod writers;

pub use crate::reader::{Access, At, CResult, ConvertError, InputInfo, NiftiCodes, SliceReader};
pub use crate::slice::{SliceData, SliceSample, SliceType};
pub use choose::{CompressArg, LayoutArg, OutputOptions};
pub use size::{check_window, output_size, OutputSize};
pub use stages::{MaskInput, Preprocess, ResampleTo, Resampling};
pub use window::{fit_type, Histogram, Mapper, ValueMap, Window};
pub use writers::{MemorySlot, Target};

use crate::error::Error;
use rayon::prelude::*;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use volcore::{
    Dims, Geometry, LengthUnit, Narrowing, RegionSource, Sample, SampleType, ValueRange,
};
use volprep::chain::{ChainError, Source};
use volprep::{Chain, Grid, Stage};

/// What to do to the samples on the way.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// Keep only voxels `x0..x1, y0..y1, z0..z1` (input coordinates).
    pub crop: Option<[Range<u64>; 3]>,
    /// Mirror the (cropped) volume along x, y, z.
    pub flip: [bool; 3],
    /// Output sample type (`None`: the input's).
    pub sample_type: Option<SampleType>,
    /// How to map values when the type changes.
    pub window: Option<Window>,
    /// Output spacing (`None`: the input's, or 1,1,1), in the input's
    /// unit of length, or in `unit` when that is given.
    pub spacing: Option<[f32; 3]>,
    /// Output unit of length: the input's spacing and origin are
    /// converted to it (or, when the input states no unit, labelled with
    /// it). `None`: the input's.
    pub unit: Option<LengthUnit>,
    /// Directory for temporary files (spooled streams); `None`: the
    /// output's directory.
    pub temp_dir: Option<PathBuf>,
    /// The preprocessing stages (orient, resample, smooth, median, clamp,
    /// threshold, mask), after crop and units and before the type.
    pub prep: Preprocess,
}

/// A parsed `--crop`: per axis, optional bounds (`None`: the whole axis).
pub type CropSpec = [Option<(Option<u64>, Option<u64>)>; 3];

/// Parse `x0:x1,y0:y1,z0:z1` (half-open voxel ranges; an empty bound is
/// the volume's edge, `:` alone is the whole axis).
pub fn parse_crop(s: &str) -> std::result::Result<CropSpec, String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("'{s}' is not x0:x1,y0:y1,z0:z1"));
    }
    let mut out = [None; 3];
    for (a, p) in parts.iter().enumerate() {
        let p = p.trim();
        if p.is_empty() {
            continue;
        }
        let (lo, hi) = p
            .split_once(':')
            .ok_or_else(|| format!("'{s}': '{p}' is not lo:hi"))?;
        let num = |v: &str| -> std::result::Result<Option<u64>, String> {
            let v = v.trim();
            if v.is_empty() {
                Ok(None)
            } else {
                v.parse()
                    .map(Some)
                    .map_err(|_| format!("'{s}': '{v}' is not a whole number"))
            }
        };
        out[a] = Some((num(lo)?, num(hi)?));
    }
    Ok(out)
}

/// Resolve a parsed crop against the input dimensions.
pub fn resolve_crop(crop: &CropSpec, dims: Dims) -> std::result::Result<[Range<u64>; 3], String> {
    let d = dims.as_array();
    let mut r: [Range<u64>; 3] = [0..d[0], 0..d[1], 0..d[2]];
    for a in 0..3 {
        if let Some((lo, hi)) = crop[a] {
            let lo = lo.unwrap_or(0);
            let hi = hi.unwrap_or(d[a]);
            let axis = ["x", "y", "z"][a];
            if lo >= hi {
                return Err(format!("crop {axis} range {lo}:{hi} is empty"));
            }
            if hi > d[a] {
                return Err(format!(
                    "crop {axis} range {lo}:{hi} goes past the volume ({dims})"
                ));
            }
            r[a] = lo..hi;
        }
    }
    Ok(r)
}

/// What a conversion did.
#[derive(Clone, Debug)]
pub struct Report {
    /// Output dimensions.
    pub dims: Dims,
    /// Output sample type.
    pub sample_type: SampleType,
    /// Output spacing.
    pub spacing: [f32; 3],
    /// Output origin and axis directions.
    pub geometry: Geometry,
    /// The input's sample type.
    pub input_type: SliceType,
    /// Input bytes read.
    pub bytes_in: u64,
    /// Output bytes written.
    pub bytes_out: u64,
    /// Value range of the output samples, when the writer computed it.
    pub range: Option<ValueRange>,
    /// The value map used.
    pub map: ValueMap,
    /// Input description.
    pub input_format: String,
    /// Whether the input was copied to a temporary file first.
    pub spooled: bool,
    /// What the conversion changed that the user did not spell out
    /// (units converted for an output that cannot hold the input's), one
    /// line each, for stderr.
    pub notes: Vec<String>,
    /// Set when `f64` input was stored as `f32` without a window: how far
    /// rounding moved the values (in [`Report::notes`] too when `--type`
    /// asked for it; an in-memory volume records it in its metadata).
    pub narrowed: Option<Narrowing>,
}

/// Decodes input slices and turns them into output slices (crop, flip,
/// type conversion).
struct Loader<'a, T: Sample> {
    reader: &'a dyn SliceReader,
    crop: [Range<u64>; 3],
    flip: [bool; 3],
    mapper: Mapper<T>,
    in_dims: Dims,
    /// Output slices done with, for reuse (fresh allocations fault in
    /// new pages, which costs more than decoding plain slices).
    spare: std::sync::Mutex<Vec<Vec<T>>>,
    /// Input slices done with (when the type or shape changes).
    spare_in: std::sync::Mutex<Vec<SliceData>>,
}

impl<T: SliceSample> Loader<'_, T> {
    fn out_dims(&self) -> Dims {
        let c = &self.crop;
        Dims {
            x: c[0].end - c[0].start,
            y: c[1].end - c[1].start,
            z: c[2].end - c[2].start,
        }
    }

    fn input_z(&self, z: u64) -> u64 {
        let nz = self.crop[2].end - self.crop[2].start;
        self.crop[2].start + if self.flip[2] { nz - 1 - z } else { z }
    }

    fn recycle(&self, v: Vec<T>) {
        if let Ok(mut p) = self.spare.lock() {
            p.push(v);
        }
    }

    fn spare_out(&self) -> Option<Vec<T>> {
        self.spare.lock().ok().and_then(|mut p| p.pop())
    }

    fn load(&self, z: u64) -> CResult<Vec<T>> {
        check_stop(&self.reader.info().path)?;
        let zi = self.input_z(z);
        let d = self.in_dims;
        let od = self.out_dims();
        let whole_xy = od.x == d.x && od.y == d.y && !self.flip[0] && !self.flip[1];
        let direct = whole_xy && self.mapper.is_identity();
        let reuse = if direct {
            self.spare_out().map(T::wrap)
        } else {
            self.spare_in.lock().ok().and_then(|mut p| p.pop())
        };
        let s = self.reader.read_slice_into(zi, reuse)?;
        if s.len() as u64 != d.slice_len() || s.sample_type() != self.reader.info().sample_type {
            return Err(ConvertError::new(
                &self.reader.info().path,
                Error::invalid(format!(
                    "slice {zi} has the wrong size or type (internal error)"
                )),
            ));
        }
        if direct {
            if let Ok(v) = T::unwrap(s) {
                return Ok(v);
            }
            unreachable_type()
        } else {
            let n = od.slice_len() as usize;
            let mut out = self.spare_out().unwrap_or_default();
            out.resize(n, T::default());
            out.truncate(n);
            let (nx, ny) = (od.x as usize, od.y as usize);
            for (yo, row) in out.chunks_exact_mut(nx).enumerate() {
                let yi = self.crop[1].start as usize + if self.flip[1] { ny - 1 - yo } else { yo };
                let base = yi * d.x as usize + self.crop[0].start as usize;
                if self.flip[0] {
                    self.mapper.map_indexed(&s, (base..base + nx).rev(), row);
                } else {
                    self.mapper.map_indexed(&s, base..base + nx, row);
                }
            }
            if let Ok(mut p) = self.spare_in.lock() {
                p.push(s);
            }
            Ok(out)
        }
    }
}

/// Where a [`SliceWindow`] gets the output slices it lacks: the input
/// read directly ([`Loader`]) or through preprocessing stages
/// ([`Staged`]).
trait Produce<T> {
    /// Output slices `zs`, in order.
    fn produce(&mut self, zs: Range<u64>) -> CResult<Vec<Vec<T>>>;
    /// A slice the window is done with, for reuse.
    fn recycle(&mut self, v: Vec<T>);
}

impl<T: SliceSample> Produce<T> for &Loader<'_, T> {
    fn produce(&mut self, zs: Range<u64>) -> CResult<Vec<Vec<T>>> {
        let loader: &Loader<'_, T> = self;
        match loader.reader.access() {
            Access::Random => zs.into_par_iter().map(|z| loader.load(z)).collect(),
            Access::Sequential => zs.map(|z| loader.load(z)).collect(),
        }
    }
    fn recycle(&mut self, v: Vec<T>) {
        Loader::recycle(self, v);
    }
}

/// Output slices from a chain of preprocessing stages: `f32` slices
/// rounded to the output type (or mapped by `--window lo:hi`).
struct Staged<'a, T> {
    chain: Chain<'a, ConvertError>,
    map: ValueMap,
    out_path: PathBuf,
    /// Output slices the window is done with, for reuse.
    spare: Vec<Vec<T>>,
}

impl<T: SliceSample> Produce<T> for Staged<'_, T> {
    fn produce(&mut self, zs: Range<u64>) -> CResult<Vec<Vec<T>>> {
        let map = self.map;
        let out_path = self.out_path.clone();
        let slab = self.chain.slices(zs.clone()).map_err(|e| match e {
            ChainError::Source(e) => e,
            ChainError::Stage(msg) => ConvertError::new(&out_path, Error::invalid(msg)),
            ChainError::Spill(dir, e) => ConvertError::new(
                &dir,
                Error::invalid(format!(
                    "cannot write the temporary copy a stage reads: {e}"
                )),
            ),
        })?;
        let want = (zs.end - zs.start) as usize;
        let mut bufs = self.spare.split_off(self.spare.len().saturating_sub(want));
        bufs.resize_with(want, Vec::new);
        Ok(bufs
            .into_par_iter()
            .enumerate()
            .map(|(i, mut out)| {
                let s = slab.slice(zs.start + i as u64);
                out.clear();
                match map {
                    ValueMap::Exact => out.extend(s.iter().map(|&v| T::from_f32(v))),
                    m => out.extend(s.iter().map(|&v| m.apply::<T>(v as f64))),
                }
                out
            })
            .collect())
    }
    fn recycle(&mut self, v: Vec<T>) {
        self.spare.push(v);
    }
}

#[cold]
fn unreachable_type<T>() -> CResult<T> {
    Err(ConvertError::new(
        Path::new("-"),
        Error::invalid("slice type changed (internal error)"),
    ))
}

/// The output slices one unit of a writer needs, held in memory: a
/// [`RegionSource`] over slices `first .. first + len`.
pub struct SliceWindow<T: Sample> {
    dims: Dims,
    first: u64,
    slices: Vec<Vec<T>>,
    missed: AtomicBool,
}

impl<T: SliceSample> SliceWindow<T> {
    fn new(dims: Dims) -> SliceWindow<T> {
        SliceWindow {
            dims,
            first: 0,
            slices: Vec::new(),
            missed: AtomicBool::new(false),
        }
    }

    /// Slice `z` (output coordinates), if held.
    pub fn slice(&self, z: u64) -> Option<&[T]> {
        let i = z.checked_sub(self.first)? as usize;
        self.slices.get(i).map(|v| v.as_slice())
    }

    /// Hold exactly slices `zs`: drop those before, load those missing.
    fn advance(&mut self, zs: Range<u64>, src: &mut dyn Produce<T>) -> CResult<()> {
        let end = self.first + self.slices.len() as u64;
        let drop_n = if zs.start >= end || zs.start < self.first {
            self.slices.len()
        } else {
            (zs.start - self.first) as usize
        };
        for v in self.slices.drain(..drop_n) {
            src.recycle(v);
        }
        self.first = zs.start;
        let have = self.first + self.slices.len() as u64;
        let need = have.max(zs.start)..zs.end;
        if need.is_empty() {
            return Ok(());
        }
        let loaded = src.produce(need)?;
        self.slices.extend(loaded);
        Ok(())
    }

    fn check(&self) -> std::result::Result<(), Error> {
        if self.missed.load(Ordering::Relaxed) {
            return Err(Error::invalid(
                "a writer read a slice outside its window (internal error)",
            ));
        }
        Ok(())
    }
}

impl<T: SliceSample> RegionSource for SliceWindow<T> {
    type Sample = T;
    fn dims(&self) -> Dims {
        self.dims
    }
    fn fill_row(&self, x0: u64, y: u64, z: u64, out: &mut [T]) {
        match self.slice(z) {
            Some(s) => {
                let start = (y * self.dims.x + x0) as usize;
                out.copy_from_slice(&s[start..start + out.len()]);
            }
            None => {
                self.missed.store(true, Ordering::Relaxed);
                out.fill(T::default());
            }
        }
    }
}

/// Crop one input slice to the plan's x and y ranges (for statistics).
fn crop_xy(s: SliceData, dims: Dims, crop: &[Range<u64>; 3]) -> SliceData {
    if crop[0] == (0..dims.x) && crop[1] == (0..dims.y) {
        return s;
    }
    fn pick<T: Copy>(v: &[T], dims: Dims, crop: &[Range<u64>; 3]) -> Vec<T> {
        let mut out = Vec::new();
        for y in crop[1].clone() {
            let b = (y * dims.x) as usize;
            out.extend_from_slice(&v[b + crop[0].start as usize..b + crop[0].end as usize]);
        }
        out
    }
    crate::slice::map_slice!(s, v => pick(&v, dims, crop))
}

static STOP: AtomicBool = AtomicBool::new(false);

/// Ask running conversions to stop at the next slice: they fail with
/// "interrupted", and their output files are removed as for any other
/// failure. Only stores to an atomic, so a signal handler may call it.
pub fn request_stop() {
    STOP.store(true, Ordering::SeqCst);
}

/// Let conversions run again after [`request_stop`]: for a process that
/// goes on after an interrupted conversion (the Python package, where
/// Ctrl-C stops one call, not the interpreter).
pub fn clear_stop() {
    STOP.store(false, Ordering::SeqCst);
}

/// Whether [`request_stop`] was called.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

fn check_stop(path: &Path) -> CResult<()> {
    if stop_requested() {
        return Err(ConvertError::new(path, Error::invalid("interrupted")));
    }
    Ok(())
}

/// The largest z slice a conversion reads (bytes).
pub const MAX_SLICE_BYTES: u64 = 4 << 30;

/// Convert everything `reader` holds to `target` following `plan`.
/// `progress` gets the output sample bytes done so far.
pub fn convert(
    reader: Box<dyn SliceReader>,
    plan: &Plan,
    target: Target,
    progress: &(dyn Fn(u64) + Sync),
) -> CResult<Report> {
    let info = reader.info().clone();
    let in_path = info.path.clone();
    let d = info.dims;
    let crop = plan.crop.clone().unwrap_or([0..d.x, 0..d.y, 0..d.z]);
    // One slice is the unit of reading: refuse sizes no machine holds (a
    // damaged or hostile header) before allocating one.
    let slice_bytes = d.slice_len().saturating_mul(info.sample_type.size() as u64);
    if slice_bytes > MAX_SLICE_BYTES {
        return Err(ConvertError::new(
            &in_path,
            Error::invalid(format!(
                "one {}x{} slice of {} takes {slice_bytes} bytes, more than the {} GiB volkit reads at once",
                d.x,
                d.y,
                info.sample_type,
                MAX_SLICE_BYTES >> 30
            )),
        ));
    }
    let from = info.sample_type;
    // Geometry and units first: the preprocessing stages work on that grid.
    let (grid, stages, mut notes) = plan_stages(&info, &crop, plan, &target)?;
    if !stages.is_empty() {
        return convert_staged(reader, plan, target, progress, stages, grid, crop, notes);
    }
    let (spacing, geometry) = (grid.spacing_f32(), grid.geometry);
    // f64 into an output that holds no f64 (the renderer's memory) is f32.
    let asked = plan
        .sample_type
        .or_else(|| (from == SliceType::F64 && !target.holds_f64()).then_some(SampleType::F32));
    // Inputs narrowed by their values (i8, 32-bit integers; f64 to f32):
    // their range decides the output type or whether it fits, and f64
    // says how far rounding to f32 moved them.
    let wide = match asked {
        Some(t) => window::by_value(from, t),
        None => from.stored().is_none(),
    };
    let needs_stats = match plan.window {
        Some(Window::Auto(_)) => true,
        Some(Window::Full) => !from.is_integer() || from.size() == 4,
        None => wide && !asked.is_some_and(|t| window::is_exact(from, t)),
        _ => false,
    };
    // Fail early on a narrowing conversion without a window.
    if let (None, Some(t), Some(out), false) = (plan.window, from.stored(), asked, wide) {
        ValueMap::plan(t.into(), out, None, None).at(target.path())?;
    }
    let temp_dir = plan.temp_dir.clone().unwrap_or_else(|| target.temp_dir());
    let z_sel = crop[2].clone();
    let mut hist = needs_stats.then(|| Histogram::new(info.sample_type));
    let mut reader = reader;
    let mut spooled = false;
    if reader.access() == Access::Sequential && (plan.flip[2] || needs_stats) {
        let h = &mut hist;
        let mut z = 0u64;
        let sp = spool::Spooled::new(reader.as_ref(), &temp_dir, |s| {
            if let Some(h) = h.as_mut() {
                if z_sel.contains(&z) {
                    h.add(&crop_xy(s.clone(), d, &crop));
                }
            }
            z += 1;
        })?;
        reader = Box::new(sp);
        spooled = true;
    } else if let Some(h) = hist.take() {
        let t = info.sample_type;
        let r = reader.as_ref();
        let merged = z_sel
            .clone()
            .into_par_iter()
            .map(|z| {
                let mut one = Histogram::new(t);
                one.add(&crop_xy(r.read_slice(z)?, d, &crop));
                Ok(one)
            })
            .try_reduce(|| Histogram::new(t), |a, b| Ok(a.merge(b)))?;
        hist = Some(h.merge(merged));
    }
    let out_type = output_type(&info, asked, hist.as_ref()).at(&in_path)?;
    // f64 read for the renderer rounds to f32 whatever the values, like
    // an f64 .vvol opened (values past f32's range become infinite and
    // the narrowing says so): nothing to window in a tool without --window.
    let map = if plan.sample_type.is_none() && asked.is_some() && plan.window.is_none() {
        ValueMap::Exact
    } else {
        ValueMap::plan_stored(
            from,
            reader.stored_type(),
            out_type,
            plan.window,
            hist.as_ref(),
        )
        .at(&in_path)?
    };
    // f64 stored as f32 without a window: say by how much the values
    // moved (nothing when every value is an f32).
    let mut narrowed = None;
    if let (Some(h), ValueMap::Exact, SampleType::F32) = (hist.as_ref(), map, out_type) {
        if from == SliceType::F64 {
            let (lo, hi) = h.range().unwrap_or((0.0, 0.0));
            narrowed = Some(Narrowing {
                from: SampleType::F64,
                layout: volcore::Layout::Sliced,
                compression: volcore::Compression::None,
                largest_change: h.f32_error(),
                largest_magnitude: lo.abs().max(hi.abs()),
            });
        }
    }
    if let Some(note) = narrowed.and_then(|n| n.note()) {
        if plan.sample_type.is_some() {
            notes.push(note);
        }
    }
    let args = RunArgs {
        reader: reader.as_ref(),
        crop,
        flip: plan.flip,
        map,
        spacing,
        geometry,
        temp_dir,
    };
    let mut report = match out_type {
        SampleType::U8 => run::<u8>(&args, target, progress)?,
        SampleType::U16 => run::<u16>(&args, target, progress)?,
        SampleType::I16 => run::<i16>(&args, target, progress)?,
        SampleType::F32 => run::<f32>(&args, target, progress)?,
        SampleType::F64 => run::<f64>(&args, target, progress)?,
    };
    report.narrowed = narrowed;
    report.bytes_in = reader.bytes_in();
    report.input_format = info.format.clone();
    report.input_type = from;
    report.spooled = spooled;
    report.notes = notes;
    Ok(report)
}

/// The preprocessing stages of one conversion, in order.
type Stages = Vec<Box<dyn Stage>>;

/// The grid after crop, flips and units (the stages' input), the
/// preprocessing stages on it (none when nothing would change), and the
/// notes for the user.
fn plan_stages(
    info: &InputInfo,
    crop: &[Range<u64>; 3],
    plan: &Plan,
    target: &Target,
) -> CResult<(Grid, Stages, Vec<String>)> {
    let in_spacing = info.spacing.unwrap_or([1.0; 3]);
    let dims = [0, 1, 2].map(|a| crop[a].end - crop[a].start);
    let start = [0, 1, 2].map(|a| crop[a].start);
    let geometry = info.geometry.cropped(in_spacing, start, dims, plan.flip);
    let (spacing, geometry, mut notes) =
        units::resolve(in_spacing, geometry, plan, target).at(target.path())?;
    notes.extend(dropped::note(spacing, &geometry, target));
    let dims = Dims::new(dims[0], dims[1], dims[2]).at(&info.path)?;
    let grid = Grid::new(dims, spacing, geometry);
    let stages = if plan.prep.is_empty() {
        Vec::new()
    } else {
        plan.prep.stages(grid, &info.path, &mut notes)?
    };
    // The stages hold whole z slices as f32: refuse slices past the slab
    // budget before allocating one (a resample to dims:100000,100000,1).
    let grids = std::iter::once(grid).chain(stages.iter().map(|s| s.output()));
    for g in grids.filter(|_| !stages.is_empty()) {
        let bytes = g.dims.slice_len().saturating_mul(4);
        if bytes > volprep::SLAB_BUDGET {
            return Err(ConvertError::new(
                &info.path,
                Error::invalid(format!(
                    "the preprocessing stages hold z slices as f32: one {}x{} slice takes {bytes} bytes, more than the {} GiB slab budget",
                    g.dims.x,
                    g.dims.y,
                    volprep::SLAB_BUDGET >> 30
                )),
            ));
        }
    }
    Ok((grid, stages, notes))
}

/// The grid a conversion of `info`'s volume by `plan` writes (after crop,
/// units and the preprocessing stages) and its sample type, known before
/// any sample is read: for progress, disk space and pyramid checks.
pub fn output_grid(
    info: &InputInfo,
    plan: &Plan,
    target: &Target,
) -> CResult<(Grid, Option<SampleType>)> {
    let d = info.dims;
    let crop = plan.crop.clone().unwrap_or([0..d.x, 0..d.y, 0..d.z]);
    let (grid, stages, _) = plan_stages(info, &crop, plan, target)?;
    let out = stages.last().map_or(grid, |s| s.output());
    let t = match plan.sample_type {
        Some(t) => Some(t),
        None if !stages.is_empty() && plan.prep.makes_mask() => Some(SampleType::U8),
        None if !stages.is_empty() => Some(match info.sample_type.stored() {
            Some(SampleType::F64) | None => SampleType::F32,
            Some(t) => t,
        }),
        None => info.sample_type.stored(),
    };
    Ok((out, t))
}

/// The output sample type: the one asked for, else the input's stored
/// type, else (wide inputs) the smallest stored type holding the values.
pub fn output_type(
    info: &InputInfo,
    asked: Option<SampleType>,
    stats: Option<&Histogram>,
) -> crate::error::Result<SampleType> {
    if let Some(t) = asked.or(info.sample_type.stored()) {
        return Ok(t);
    }
    let range = stats.and_then(|h| h.range());
    fit_type(info.sample_type, range).ok_or_else(|| {
        let (lo, hi) = range.unwrap_or((0.0, 0.0));
        Error::invalid(format!(
            "{} values {lo}..{hi} fit no stored type exactly: pass --type and --window",
            info.sample_type
        ))
    })
}

struct RunArgs<'a> {
    reader: &'a dyn SliceReader,
    crop: [Range<u64>; 3],
    flip: [bool; 3],
    map: ValueMap,
    spacing: [f32; 3],
    geometry: Geometry,
    temp_dir: PathBuf,
}

fn run<T: SliceSample>(
    args: &RunArgs<'_>,
    target: Target,
    progress: &(dyn Fn(u64) + Sync),
) -> CResult<Report> {
    let info = args.reader.info();
    let loader = Loader::<T> {
        reader: args.reader,
        crop: args.crop.clone(),
        flip: args.flip,
        mapper: Mapper::new(info.sample_type, args.map),
        in_dims: info.dims,
        spare: Default::default(),
        spare_in: Default::default(),
    };
    let dims = loader.out_dims();
    let mut src = &loader;
    write_all(
        args,
        &mut src,
        dims,
        (args.spacing, args.geometry),
        target,
        progress,
    )
}

/// [`convert`] through preprocessing stages: the input is read as `f32`
/// (cropped and flipped), the stages run in a [`Chain`], and their
/// output is rounded to the output type (half away from zero, clamped to
/// its range, NaN to 0 for integers) or mapped by `--window lo:hi`.
#[allow(clippy::too_many_arguments)]
fn convert_staged(
    reader: Box<dyn SliceReader>,
    plan: &Plan,
    target: Target,
    progress: &(dyn Fn(u64) + Sync),
    stages: Vec<Box<dyn Stage>>,
    grid: Grid,
    crop: [Range<u64>; 3],
    mut notes: Vec<String>,
) -> CResult<Report> {
    let info = reader.info().clone();
    let in_path = info.path.clone();
    let from = info.sample_type;
    let out_type = match plan.sample_type {
        Some(t) => t,
        None if plan.prep.makes_mask() => SampleType::U8,
        None => match from.stored() {
            Some(SampleType::F64) => {
                notes.push(
                    "the preprocessing stages compute in f32: the output is f32 (--type f64 stores those values as f64)"
                        .into(),
                );
                SampleType::F32
            }
            Some(t) => t,
            None => SampleType::F32,
        },
    };
    let map = match plan.window {
        None => ValueMap::Exact,
        Some(w @ Window::Range(..)) => {
            ValueMap::plan(SliceType::F32, out_type, Some(w), None).at(&in_path)?
        }
        Some(_) => {
            return Err(ConvertError::new(
                &in_path,
                Error::invalid(
                    "--window auto and full read the input's histogram, which the preprocessing stages change: give --window lo:hi",
                ),
            ))
        }
    };
    let temp_dir = plan.temp_dir.clone().unwrap_or_else(|| target.temp_dir());
    let mut reader = reader;
    let mut spooled = false;
    // A stream read backwards (a flip of z, an orientation that reverses
    // or moves z) is copied to disk first.
    if reader.access() == Access::Sequential && (plan.flip[2] || plan.prep.orient.is_some()) {
        reader = Box::new(spool::Spooled::new(reader.as_ref(), &temp_dir, |_| {})?);
        spooled = true;
    }
    let args = RunArgs {
        reader: reader.as_ref(),
        crop,
        flip: plan.flip,
        map,
        spacing: grid.spacing_f32(),
        geometry: grid.geometry,
        temp_dir,
    };
    let mut report = match out_type {
        SampleType::U8 => run_staged::<u8>(&args, stages, grid, target, progress)?,
        SampleType::U16 => run_staged::<u16>(&args, stages, grid, target, progress)?,
        SampleType::I16 => run_staged::<i16>(&args, stages, grid, target, progress)?,
        SampleType::F32 => run_staged::<f32>(&args, stages, grid, target, progress)?,
        SampleType::F64 => run_staged::<f64>(&args, stages, grid, target, progress)?,
    };
    report.bytes_in = reader.bytes_in();
    report.input_format = info.format.clone();
    report.input_type = from;
    report.spooled = spooled;
    report.notes = notes;
    Ok(report)
}

/// [`run`] through a chain of stages on `grid` (the cropped input's).
fn run_staged<T: SliceSample>(
    args: &RunArgs<'_>,
    stages: Vec<Box<dyn Stage>>,
    grid: Grid,
    target: Target,
    progress: &(dyn Fn(u64) + Sync),
) -> CResult<Report> {
    let info = args.reader.info();
    let loader = Loader::<f32> {
        reader: args.reader,
        crop: args.crop.clone(),
        flip: args.flip,
        mapper: Mapper::new(info.sample_type, ValueMap::Exact),
        in_dims: info.dims,
        spare: Default::default(),
        spare_in: Default::default(),
    };
    let access = args.reader.access();
    let source: Source<'_, ConvertError> = Box::new(|zs: Range<u64>| match access {
        Access::Random => zs.into_par_iter().map(|z| loader.load(z)).collect(),
        Access::Sequential => zs.map(|z| loader.load(z)).collect(),
    });
    let chain = Chain::new(grid, source, stages, &args.temp_dir)
        .with_recycler(Box::new(|v: Vec<f32>| loader.recycle(v)));
    let out = chain.output();
    let spacing = out.spacing_f32();
    if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(ConvertError::new(
            target.path(),
            Error::invalid(format!(
                "the output spacing {spacing:?} is not a positive, finite f32"
            )),
        ));
    }
    let mut src = Staged::<T> {
        chain,
        map: args.map,
        out_path: target.path().to_path_buf(),
        spare: Vec::new(),
    };
    write_all(
        args,
        &mut src,
        out.dims,
        (spacing, out.geometry),
        target,
        progress,
    )
}

/// Write `target` from the output slices `src` produces (a grid of
/// `dims` at `place`: spacing and geometry), each writer unit's slices
/// in a [`SliceWindow`]; the input's rest is read (and a stream's trailer
/// checked) before the output is committed.
fn write_all<T: SliceSample>(
    args: &RunArgs<'_>,
    src: &mut dyn Produce<T>,
    dims: Dims,
    place: ([f32; 3], Geometry),
    target: Target,
    progress: &(dyn Fn(u64) + Sync),
) -> CResult<Report> {
    let info = args.reader.info();
    let out_path = target.path().to_path_buf();
    let mut drive = |sink: &mut dyn writers::SliceWriter<T>| -> CResult<()> {
        let mut window = SliceWindow::<T>::new(dims);
        loop {
            let zs = sink.next_slices();
            if zs.is_empty() {
                break;
            }
            window.advance(zs, src)?;
            sink.write_next(&window)?;
            window.check().at(&out_path)?;
            check_stop(&out_path)?;
        }
        // A damaged input must leave no output.
        args.reader.finish()
    };
    let (spacing, geometry) = place;
    let spec = writers::OutSpec {
        dims,
        spacing,
        geometry,
        nifti_codes: info.nifti_codes,
        temp_dir: &args.temp_dir,
        progress,
    };
    let writers::Written {
        bytes: bytes_out,
        range,
    } = writers::run_target::<T>(target, &spec, &mut drive)?;
    Ok(Report {
        dims,
        sample_type: T::TYPE,
        spacing,
        geometry,
        input_type: info.sample_type,
        bytes_in: 0,
        bytes_out,
        range,
        map: args.map,
        input_format: String::new(),
        spooled: false,
        notes: Vec::new(),
        narrowed: None,
    })
}

#[cfg(test)]
mod tests;
