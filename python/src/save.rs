//! `volkit.save`: a numpy array or a `Volume` into any format vol-convert
//! writes, through the same conversion (`volformats::convert`), output
//! rules (`Target::for_output`) and atomic temporary-then-rename writers.

use crate::errors;
use crate::volume::{decode, geometry_of, spacing_of, PyVolume};
use numpy::{Element, PyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use volcore::volume::TypedGrid;
use volcore::{Dims, Geometry, Sample, VolumeData};
use volformats::convert::{
    self, CompressArg, OutputOptions, Plan, SliceData, SliceReader, Target, Window,
};
use volformats::reader::MemoryReader;

/// `samples` (x fastest) cut into z slices of `dims`, each wrapped by `wrap`.
fn slices_of<T: Copy>(dims: Dims, samples: &[T], wrap: fn(Vec<T>) -> SliceData) -> Vec<SliceData> {
    samples
        .chunks(dims.slice_len() as usize)
        .map(|c| wrap(c.to_vec()))
        .collect()
}

/// The slices of a numpy array of any type vol-convert reads.
fn array_slices(a: &Bound<'_, PyAny>) -> PyResult<(Dims, Vec<SliceData>)> {
    fn typed<T: Element + Copy>(
        a: &Bound<'_, PyArrayDyn<T>>,
        wrap: fn(Vec<T>) -> SliceData,
    ) -> PyResult<(Dims, Vec<SliceData>)> {
        let dims = crate::volume::dims_of(a.shape())?;
        let slices = crate::volume::with_c_order(a, |s| slices_of(dims, &s, wrap));
        Ok((dims, slices))
    }
    macro_rules! try_type {
        ($t:ty, $v:ident) => {
            if let Ok(x) = a.cast::<PyArrayDyn<$t>>() {
                return typed(x, SliceData::$v);
            }
        };
    }
    try_type!(u8, U8);
    try_type!(i8, I8);
    try_type!(u16, U16);
    try_type!(i16, I16);
    try_type!(u32, U32);
    try_type!(i32, I32);
    try_type!(f32, F32);
    try_type!(f64, F64);
    Err(errors::value(format!(
        "expected a Volume or a numpy array of (u)int8, (u)int16, (u)int32, float32 or float64, not {}",
        crate::volume::describe(a)
    )))
}

/// The slices of an open volume, decoded.
fn volume_slices(v: &volcore::Volume) -> Vec<SliceData> {
    fn typed<T: Sample>(
        g: &TypedGrid<T>,
        d: Dims,
        wrap: fn(Vec<T>) -> SliceData,
    ) -> Vec<SliceData> {
        let all = match g {
            TypedGrid::Sliced(s) => decode(s, d),
            TypedGrid::Bricked(b) => decode(b, d),
            TypedGrid::Compressed(c) => decode(c, d),
        };
        slices_of(d, &all, wrap)
    }
    let d = v.dims();
    match &v.data {
        VolumeData::U8(g) => typed(g, d, SliceData::U8),
        VolumeData::U16(g) => typed(g, d, SliceData::U16),
        VolumeData::I16(g) => typed(g, d, SliceData::I16),
        VolumeData::F32(g) => typed(g, d, SliceData::F32),
    }
}

/// Write a Volume or a numpy array (z, y, x) to `path`, in any format
/// vol-convert writes, chosen by the extension (.vvol, .vol, .raw, .tif,
/// .nii, .nii.gz, .hdr, .nrrd, .nhdr, .mha, .mhd, NAME.ome.zarr, DIR/),
/// with vol-convert's options and rules: `layout` (`sliced`,
/// `bricked:B`), `compress` (`zstd[:LEVEL]` for bricked .vvol, `gzip` for
/// the header formats), `type` and `window` (a narrowing type needs a
/// window, as `--window`), `pyramid`, `downsample` and `ngff` for OME-Zarr.
/// float64 is stored as it is; array types volkit does not store (int8,
/// (u)int32) become the smallest stored type that holds their values. `spacing`, `origin` and
/// `direction` are in numpy order (z, y, x) and replace the data's own.
/// Preprocessing in the same pass, by vol-convert's flag names:
/// `orient="RAS"`, `resample="spacing:1"` (or `"dims:NX,NY,NZ"`,
/// `"like:FILE"`), `kernel`, `no_antialias=True`, `background`,
/// `smooth="gauss:1"`, `median=1`, `clamp="-1000:2000"`,
/// `threshold="300:3000"`, `mask="FILE"`; the same stages, order and
/// bytes as the command line (see docs/convert.md, Preprocessing).
/// The file is written under a temporary name and renamed into place
/// only when complete. Returns what was written (shape, type, bytes).
#[pyfunction]
#[pyo3(signature = (data, path, *, spacing=None, origin=None, direction=None, layout="sliced",
    compress="none", r#type=None, window=None, pyramid=1, downsample="mean", ngff=None, **prep))]
#[allow(clippy::too_many_arguments)]
pub fn save<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    path: PathBuf,
    spacing: Option<[f64; 3]>,
    origin: Option<[f64; 3]>,
    direction: Option<[[f64; 3]; 3]>,
    layout: &str,
    compress: &str,
    r#type: Option<&str>,
    window: Option<&str>,
    pyramid: u32,
    downsample: &str,
    ngff: Option<&str>,
    prep: Option<&Bound<'py, pyo3::types::PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    crate::guard(|| {
        let flags = prep_of("save", prep)?;
        let bad = |what: &str, e: String| errors::value(format!("{what}: {e}"));
        let opts = OutputOptions {
            layout: convert::choose::layout(layout).map_err(|e| bad("layout", e))?,
            compress: CompressArg::parse(compress).map_err(|e| bad("compress", e))?,
            pyramid,
            downsample: downsample.parse().map_err(|e| bad("downsample", e))?,
            ngff: ngff
                .map(str::parse)
                .transpose()
                .map_err(|e| bad("ngff", e))?,
            shard: None,
        };
        if !(1..=16).contains(&pyramid) {
            return Err(bad("pyramid", format!("{pyramid} is not in 1..=16")));
        }
        let sample_type = r#type
            .map(|t| t.parse::<volcore::SampleType>())
            .transpose()
            .map_err(|e| bad("type", e))?;
        let window: Option<Window> = window
            .map(|w| w.parse())
            .transpose()
            .map_err(|e: String| bad("window", e))?;
        convert::check_window(window.as_ref(), sample_type).map_err(errors::value)?;
        let plan = Plan {
            sample_type,
            window,
            spacing: spacing.map(spacing_of).transpose()?,
            ..Plan::default()
        };
        let target = Target::for_output(&path, &opts, None).map_err(errors::value)?;
        target.preflight().map_err(errors::convert)?;
        let plan = Plan {
            prep: flags.resolve(&target.temp_dir()).map_err(errors::convert)?,
            ..plan
        };
        let reader = reader_for(py, data, origin, direction)?;
        let out = crate::run(py, convert::request_stop, || {
            convert::convert(reader, &plan, target, &|_| {})
        });
        // An interrupted conversion raised the process's stop flag: lower
        // it, so the next call runs.
        convert::clear_stop();
        let report = out?.map_err(errors::convert)?;
        let d = report.dims;
        let json = serde_json::json!({
            "output": path.display().to_string(),
            "shape": [d.z, d.y, d.x],
            "type": report.sample_type.name(),
            "layout": opts.layout.name(),
            "compression": opts.compress.name(),
            "bytes": report.bytes_out,
        });
        crate::value::to_py(py, &json)
    })
}

/// The preprocessing keywords of `kw` as flags (unknown ones refused,
/// naming the ones there are).
fn prep_of(
    what: &str,
    kw: Option<&Bound<'_, pyo3::types::PyDict>>,
) -> PyResult<volformats::PrepFlags> {
    let mut pairs = Vec::new();
    for (k, v) in kw.into_iter().flat_map(|d| d.iter()) {
        let key: String = k.extract()?;
        if !crate::prep::is_prep_keyword(&key) {
            return Err(errors::value(format!(
                "unknown option `{key}` ({what}'s preprocessing keywords are {})",
                crate::prep::prep_keywords().join(", ")
            )));
        }
        pairs.push((key, v));
    }
    crate::prep::prep_flags(&pairs)
}

/// A Volume or a numpy array (z, y, x) preprocessed in memory, with
/// save's preprocessing keywords (`orient`, `resample`, `kernel`,
/// `no_antialias`, `background`, `smooth`, `median`, `clamp`,
/// `threshold`, `mask`) and `type`: the samples `save` would write, as a
/// new Volume (u8, u16, i16 or float32) with its geometry.
#[pyfunction]
#[pyo3(signature = (data, *, r#type=None, **prep))]
pub fn preprocess(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    r#type: Option<&str>,
    prep: Option<&Bound<'_, pyo3::types::PyDict>>,
) -> PyResult<PyVolume> {
    crate::guard(|| {
        let flags = prep_of("preprocess", prep)?;
        let sample_type = r#type
            .map(|t| t.parse::<volcore::SampleType>())
            .transpose()
            .map_err(|e| errors::value(format!("type: {e}")))?;
        let temp = std::env::temp_dir();
        let plan = Plan {
            sample_type,
            temp_dir: Some(temp.clone()),
            prep: flags.resolve(&temp).map_err(errors::convert)?,
            ..Plan::default()
        };
        let reader = reader_for(py, data, None, None)?;
        let out = crate::run(py, convert::request_stop, || {
            volformats::open::load_with(reader, &plan)
        });
        convert::clear_stop();
        let vol = out?.map_err(errors::convert)?;
        Ok(PyVolume { vol, file: None })
    })
}

/// The slice reader for what is saved: a file-backed `Volume` is read
/// again from its file (as vol-convert would), anything else from memory.
fn reader_for(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    origin: Option<[f64; 3]>,
    direction: Option<[[f64; 3]; 3]>,
) -> PyResult<Box<dyn SliceReader>> {
    let moved = origin.is_some() || direction.is_some();
    let memory =
        |name: &Path, dims, slices, spacing, base: Geometry| -> PyResult<Box<dyn SliceReader>> {
            let geometry = geometry_of(origin, direction, base)?;
            let r = MemoryReader::from_slices(name, dims, slices, spacing, geometry)
                .map_err(|e| errors::value(format!("{}: {e}", name.display())))?;
            Ok(Box::new(r))
        };
    if let Ok(pv) = data.cast::<PyVolume>() {
        let v = pv.get();
        if let (Some((p, o)), false) = (&v.file, moved) {
            let r = py
                .detach(|| volformats::open_input(p, o))
                .map_err(errors::convert)?;
            return Ok(r);
        }
        let m = v.vol.meta;
        let slices = py.detach(|| volume_slices(&v.vol));
        return memory(&v.name(), m.dims, slices, Some(m.spacing), m.geometry);
    }
    let (dims, slices) = array_slices(data)?;
    memory(Path::new("<array>"), dims, slices, None, Geometry::IDENTITY)
}
