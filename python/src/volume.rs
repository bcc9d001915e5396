//! `volkit.open` and the `Volume` it returns: the metadata in numpy's axis
//! order (z, y, x) and `.array()`, a read-only view of a memory-mapped file
//! (no copy), else a new writable array.

use crate::errors;
use numpy::ndarray::{ArrayView3, ShapeBuilder};
use numpy::{Element, PyArray1, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use volcore::volume::TypedGrid;
use volcore::{Compression, Dims, Geometry, Sample, VolumeData, VoxelSource};
use volformats::raw::RawSpec;
use volformats::tiff::ChannelSel;
use volformats::ReadOptions;

/// An open volume: its metadata, in numpy's axis order (z, y, x), and its
/// samples through `array()` (a read-only view of a mapped file, else a new
/// writable array). `affine` is the 4x4 index-to-world matrix; `v[z0:z1,
/// y0:y1, x0:x1]` is a new Volume whose origin, spacing and direction
/// follow the slices; an integer index gives the plain array.
#[pyclass(name = "Volume", module = "volkit", frozen)]
pub struct PyVolume {
    /// The volume.
    pub vol: volcore::Volume,
    /// The file it was opened from and how, when it was (a volume made in
    /// memory has none).
    pub file: Option<(PathBuf, ReadOptions)>,
}

impl PyVolume {
    /// The file, when opening it with the tools' defaults gives this
    /// volume again (what `render` and `save` reopen, as the tools do).
    pub fn plain_file(&self) -> Option<&Path> {
        match &self.file {
            Some((p, o)) if o.raw == RawSpec::default() && o.time.is_none() => {
                (o.series.is_none() && o.channel == ChannelSel::Single).then_some(p.as_path())
            }
            _ => None,
        }
    }

    /// Voxels per axis, (z, y, x).
    pub fn shape_zyx(&self) -> (usize, usize, usize) {
        self.shape()
    }

    /// Spacing, (z, y, x).
    pub fn spacing_zyx(&self) -> [f64; 3] {
        let s = self.spacing();
        [s.0, s.1, s.2]
    }

    /// Origin, (z, y, x).
    pub fn origin_zyx(&self) -> [f64; 3] {
        let o = self.origin();
        [o.0, o.1, o.2]
    }

    /// Direction cosines, rows and columns in (z, y, x) order.
    pub fn direction_zyx(&self) -> [[f64; 3]; 3] {
        self.direction()
    }

    /// The name messages give the volume: its file, or `<array>`.
    pub fn name(&self) -> PathBuf {
        self.file
            .as_ref()
            .map_or_else(|| PathBuf::from("<array>"), |(p, _)| p.clone())
    }
}

/// `v` reversed: (x, y, z) to numpy's (z, y, x).
fn rev3<T: Copy>(v: [T; 3]) -> [T; 3] {
    [v[2], v[1], v[0]]
}

#[pymethods]
impl PyVolume {
    /// Voxels per axis, (z, y, x).
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        let d = self.vol.dims();
        (d.z as usize, d.y as usize, d.x as usize)
    }

    /// The numpy dtype of the samples (uint8, uint16, int16 or float32).
    #[getter]
    fn dtype<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let np = py.import("numpy")?;
        np.call_method1("dtype", (self.vol.meta.sample_type.long_name(),))
    }

    /// World distance between neighbouring voxels, (z, y, x).
    #[getter]
    fn spacing(&self) -> (f64, f64, f64) {
        let s = rev3(self.vol.meta.spacing);
        (s[0] as f64, s[1] as f64, s[2] as f64)
    }

    /// World position of voxel (0, 0, 0), (z, y, x) (the world frame is
    /// LPS, as in DICOM and ITK: these are its z, y and x coordinates).
    #[getter]
    fn origin(&self) -> (f64, f64, f64) {
        let o = rev3(self.vol.meta.geometry.origin);
        (o[0], o[1], o[2])
    }

    /// Direction cosines, 3x3, in numpy's order for rows and columns alike:
    /// column j is the world direction of array axis j (z, y, x), its rows
    /// the world z, y and x components.
    #[getter]
    fn direction(&self) -> [[f64; 3]; 3] {
        let d = self.vol.meta.geometry.direction;
        rev3([rev3(d[0]), rev3(d[1]), rev3(d[2])])
    }

    /// The unit of length of the spacing and origin, by its NGFF name
    /// (`"micrometer"`, `"millimeter"`, ...), or None when the file states
    /// none (raw data, plain TIFF).
    #[getter]
    fn unit(&self) -> Option<String> {
        self.vol.meta.geometry.unit.ngff_name().map(String::from)
    }

    /// The file the volume was opened from, or None (made in memory).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.file.as_ref().map(|(p, _)| p.clone())
    }

    /// How the samples are stored: `sliced` or `bricked:B`.
    #[getter]
    fn layout(&self) -> String {
        self.vol.meta.layout.describe()
    }

    /// Per-brick compression: `none` or `zstd:LEVEL`.
    #[getter]
    fn compression(&self) -> String {
        match self.vol.meta.compression {
            Compression::None => "none".into(),
            Compression::Zstd(l) => format!("zstd:{l}"),
        }
    }

    /// The smallest and largest sample, or None when unknown or all NaN.
    #[getter]
    fn range(&self) -> Option<(f64, f64)> {
        let r = self.vol.meta.range;
        (!r.is_empty()).then_some((r.min, r.max))
    }

    /// Whether the samples are a memory map of the file (so `array()` is
    /// a view of it).
    #[getter]
    fn mapped(&self) -> bool {
        sliced_data_mapped(&self.vol.data) == Some(true)
    }

    /// The samples as a numpy array of shape (z, y, x). A memory-mapped
    /// file (a sliced uncompressed .vvol, an uncompressed .nii, a .raw
    /// file: `mapped` is True) gives a read-only view of the map without a
    /// copy, so resident memory grows only with what is read; `.copy()` it
    /// to change it. Anything else (compressed, bricked and decoded
    /// formats, volumes made in memory) gives a new writable array, a copy
    /// that changing leaves the Volume as it was.
    fn array<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        crate::guard(|| array_of(slf))
    }

    /// numpy's hook: `np.asarray(volume)` is `volume.array()`.
    #[pyo3(signature = (dtype=None, copy=None))]
    fn __array__<'py>(
        slf: &Bound<'py, Self>,
        dtype: Option<&Bound<'py, PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mut a = crate::guard(|| array_of(slf))?;
        if let Some(t) = dtype {
            a = a.call_method1("astype", (t,))?;
        }
        if copy == Some(true) {
            a = a.call_method0("copy")?;
        }
        Ok(a)
    }

    /// The 4x4 affine from array index (z, y, x, 1) to world position
    /// (LPS z, y, x, 1): `direction` scaled by `spacing` (column j times
    /// spacing j), `origin` in the last column. napari's `affine`.
    #[getter]
    fn affine<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (d, s, o) = (self.direction(), self.spacing_zyx(), self.origin_zyx());
        let mut m = [[0.0; 4]; 4];
        for r in 0..3 {
            for j in 0..3 {
                m[r][j] = d[r][j] * s[j];
            }
            m[r][3] = o[r];
        }
        m[3][3] = 1.0;
        py.import("numpy")?.call_method1("array", (m,))
    }

    /// `v[z0:z1, y0:y1, x0:x1]`: slices (any steps; missing axes and `...`
    /// are whole) give a new Volume in memory whose geometry follows
    /// (see [`crate::slicing`]); any other key (an integer that drops an
    /// axis, `None`, an index array) gives the plain numpy array.
    fn __getitem__<'py>(
        slf: &Bound<'py, Self>,
        key: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        crate::guard(|| crate::slicing::get_item(slf, key))
    }

    fn __repr__(&self) -> String {
        let (z, y, x) = self.shape();
        let s = self.spacing();
        format!(
            "Volume(shape=({z}, {y}, {x}), dtype={}, spacing=({}, {}, {}), layout={}, path={})",
            self.vol.meta.sample_type.long_name(),
            s.0,
            s.1,
            s.2,
            self.layout(),
            self.file.as_ref().map_or_else(
                || "None".to_string(),
                |(p, _)| format!("{:?}", p.display().to_string())
            )
        )
    }
}

/// Whether sliced data is mapped; `None` for bricked volumes.
fn sliced_data_mapped(d: &VolumeData) -> Option<bool> {
    match d {
        VolumeData::U8(TypedGrid::Sliced(g)) => Some(g.is_mapped()),
        VolumeData::U16(TypedGrid::Sliced(g)) => Some(g.is_mapped()),
        VolumeData::I16(TypedGrid::Sliced(g)) => Some(g.is_mapped()),
        VolumeData::F32(TypedGrid::Sliced(g)) => Some(g.is_mapped()),
        _ => None,
    }
}

/// The samples of `slf` as `array()` gives them.
pub fn array_of<'py>(slf: &Bound<'py, PyVolume>) -> PyResult<Bound<'py, PyAny>> {
    let v = slf.get();
    match &v.vol.data {
        VolumeData::U8(g) => typed_array(slf, g),
        VolumeData::U16(g) => typed_array(slf, g),
        VolumeData::I16(g) => typed_array(slf, g),
        VolumeData::F32(g) => typed_array(slf, g),
    }
}

fn typed_array<'py, T: Sample + Element>(
    slf: &Bound<'py, PyVolume>,
    grid: &TypedGrid<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let py = slf.py();
    let vol = &slf.get().vol;
    let d = vol.dims();
    let shape = (d.z as usize, d.y as usize, d.x as usize);
    let samples = match grid {
        TypedGrid::Sliced(g) => {
            let [sx, sy, sz] = g.order().strides(d);
            let strides = (sz as usize, sy as usize, sx as usize);
            let data = g.samples();
            // SAFETY: the grid holds exactly dims.count() samples in this
            // order (checked when it was made), so every index of the view
            // is inside `data`; the view's base is the Volume object, which
            // owns the grid (and its memory map) and is immutable, so the
            // memory outlives the array and never changes under it; a
            // mapped file's view is read-only.
            let view = unsafe { ArrayView3::from_shape_ptr(shape.strides(strides), data.as_ptr()) };
            if !g.is_mapped() {
                // Samples in memory: a new, writable array (issue 53 §2).
                return Ok(PyArray3::from_array(py, &view).into_any());
            }
            let arr = unsafe { PyArray3::borrow_from_array(&view, slf.clone().into_any()) };
            let kw = PyDict::new(py);
            kw.set_item("write", false)?;
            arr.call_method("setflags", (), Some(&kw))?;
            return Ok(arr.into_any());
        }
        TypedGrid::Bricked(g) => py.detach(|| decode(g, d)),
        TypedGrid::Compressed(g) => py.detach(|| decode(g, d)),
    };
    if let Some(e) = vol.error() {
        return Err(errors::os(format!("{}: {e}", slf.get().name().display())));
    }
    let flat = PyArray1::from_vec(py, samples);
    Ok(flat.reshape([shape.0, shape.1, shape.2])?.into_any())
}

/// Every sample of `src`, x fastest, read row by row in parallel.
pub fn decode<S: VoxelSource>(src: &S, d: Dims) -> Vec<S::Sample> {
    let (nx, ny) = (d.x as usize, d.y as usize);
    let mut out = vec![S::Sample::default(); d.count() as usize];
    out.par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, slab)| {
            for (y, row) in slab.chunks_exact_mut(nx).enumerate() {
                src.read_row(0, y as u64, z as u64, row);
            }
        });
    out
}

/// A selection option's value as text (a string as it is; a number or a
/// sequence of numbers as the command line writes it).
pub(crate) fn text_of(v: &Bound<'_, PyAny>) -> PyResult<String> {
    match crate::value::to_json(v)? {
        serde_json::Value::String(s) => Ok(s),
        serde_json::Value::Array(items) => Ok(items
            .iter()
            .map(|i| match i {
                serde_json::Value::String(s) => s.clone(),
                other => other.to_string(),
            })
            .collect::<Vec<_>>()
            .join(",")),
        other => Ok(other.to_string()),
    }
}

/// The keywords `open` takes beyond the input-selection flags: `shape`
/// (raw_dims in numpy's order), `luma` (colour TIFF as luminance) and
/// `in_memory` (read a .vvol into memory).
const PYTHON_ONLY: [&str; 3] = ["shape", "luma", "in_memory"];

/// The input-selection flags (`volformats::Selection`, the one definition
/// every tool flattens into its command line) as a clap command.
pub fn selection_command() -> clap::Command {
    use clap::Args;
    volformats::Selection::augment_args(clap::Command::new("open").no_binary_name(true))
}

/// Every keyword `open` takes: each visible selection flag by its long
/// name in snake case, then the Python-only ones.
pub fn selection_keywords() -> Vec<String> {
    let cmd = selection_command();
    let mut names: Vec<String> = cmd
        .get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter_map(|a| a.get_long())
        .map(|l| l.replace('-', "_"))
        .collect();
    names.extend(PYTHON_ONLY.iter().map(|s| s.to_string()));
    names
}

/// The read options the selection keywords ask for: the command line's
/// input-selection flags by their long names in snake case (`raw_dims`,
/// `raw_type`, `raw_endian`, `raw_skip`, `series`, `channel`,
/// `time_point`, `level`), parsed by the tools' own definition, so a keyword
/// means what its flag means; plus [`PYTHON_ONLY`]. The old `time` is
/// refused as the command line refuses `--time`.
pub fn read_options(sel: Option<&Bound<'_, PyDict>>) -> PyResult<ReadOptions> {
    let Some(sel) = sel else {
        return Ok(ReadOptions::default());
    };
    let known = selection_keywords();
    let mut argv: Vec<String> = Vec::new();
    let (mut shape, mut luma, mut in_memory) = (None, false, false);
    for (k, v) in sel.iter() {
        let key: String = k.extract()?;
        let key = key.replace('-', "_");
        if key == "time" {
            return Err(errors::value(volformats::select::TIME_RENAMED));
        }
        if !known.contains(&key) {
            return Err(errors::value(format!(
                "unknown option `{key}` (open takes {})",
                known.join(", ")
            )));
        }
        if v.is_none() {
            continue;
        }
        match key.as_str() {
            "shape" => {
                let s: Vec<u64> = v.extract()?;
                let [z, y, x] = s[..] else {
                    return Err(errors::value("shape: expected (z, y, x)"));
                };
                shape = Some(Dims::new(x, y, z).map_err(|e| errors::value(format!("shape: {e}")))?);
            }
            "luma" => luma = v.extract()?,
            "in_memory" => in_memory = v.extract()?,
            flag => {
                argv.push(format!("--{}", flag.replace('_', "-")));
                argv.push(text_of(&v)?);
            }
        }
    }
    let matches = selection_command()
        .try_get_matches_from(&argv)
        .map_err(|e| {
            // clap's first line, without its `error: ` prefix or styling.
            let text = e.render().to_string();
            let line = text.lines().next().unwrap_or("").trim();
            errors::value(line.strip_prefix("error: ").unwrap_or(line).to_string())
        })?;
    let selection = <volformats::Selection as clap::FromArgMatches>::from_arg_matches(&matches)
        .map_err(|e| errors::value(e.to_string()))?;
    let mut o = selection.read_options().map_err(errors::value)?;
    if let Some(d) = shape {
        if o.raw.dims.is_some() {
            return Err(errors::value("give shape or raw_dims, not both"));
        }
        o.raw.dims = Some(d);
    }
    o.vvol.in_memory = in_memory;
    if luma {
        if matches!(o.channel, ChannelSel::Channel(_)) {
            return Err(errors::value("give channel or luma, not both"));
        }
        o.channel = ChannelSel::Luma;
    }
    Ok(o)
}

/// Open anything vol-convert reads (.vvol, .vol, .raw, NIfTI, NRRD,
/// MetaImage, TIFF files and stacks, DICOM series, OME-Zarr) as a Volume.
/// Selection, by vol-convert's names: `raw_dims="X,Y,Z"` (the command
/// line's order; or `shape=(z, y, x)`), `raw_type`, `raw_endian`,
/// `raw_skip`, `channel` or `luma` (colour TIFF, hyperstacks, OME),
/// `time_point` (4D data), `series` (a DICOM series: number, UID or
/// unique UID prefix), `level` (an OME-Zarr pyramid level: 0, the full
/// resolution, by default), and
/// `in_memory` (read a .vvol into memory instead of mapping it). A keyword
/// the input has nothing to pick with (`channel` of a NIfTI file, `series`
/// of anything but DICOM, `level` of anything but OME-Zarr) raises
/// ValueError. A sliced uncompressed .vvol, an uncompressed .nii and a
/// .raw file are memory-mapped: opening costs milliseconds whatever the
/// size, and `array()` is a read-only view.
#[pyfunction]
#[pyo3(signature = (path, **selection))]
pub fn open(
    py: Python<'_>,
    path: PathBuf,
    selection: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyVolume> {
    crate::guard(|| {
        let opts = read_options(selection)?;
        volformats::open::check_applies(&path, &opts).map_err(|e| errors::value(e.to_string()))?;
        refuse_unused_selection(&path, &opts)?;
        let vol = crate::run(py, volformats::convert::request_stop, || {
            volformats::open(&path, &opts)
        });
        // An interrupted read raised the process's stop flag: lower it.
        volformats::convert::clear_stop();
        let vol = vol?.map_err(errors::convert)?;
        Ok(PyVolume {
            vol,
            file: Some((path, opts)),
        })
    })
}

/// Refuse a selection keyword the input cannot use (`channel` of a
/// NIfTI file, `series` of anything but DICOM), as `time_point` past a
/// 3D file's single volume and `level` of anything but OME-Zarr
/// (`volformats::open::check_applies`) are refused, naming the keyword
/// and the format.
fn refuse_unused_selection(path: &Path, o: &ReadOptions) -> PyResult<()> {
    use volformats::open::{input_kind, InputKind as K};
    // A path that cannot be classified fails in `open` with its message.
    let Ok(kind) = input_kind(path, o) else {
        return Ok(());
    };
    let stack = matches!(kind, K::Tiff | K::TiffDir | K::TiffGlob | K::TiffList);
    let (dicom, zarr, raw) = (
        matches!(kind, K::Dicom | K::DicomDir),
        kind == K::OmeZarr,
        matches!(kind, K::Raw | K::Stdin),
    );
    let refuse = |given: String, takes: &str| {
        Err(errors::value(format!(
            "{given}: a {} input has none to pick ({takes})",
            kind.name()
        )))
    };
    if let Some(s) = &o.series {
        if !dicom {
            return refuse(format!("series={s:?}"), "series picks a DICOM series");
        }
    }
    let channels = "channels: colour TIFF, ImageJ hyperstacks, OME-TIFF, OME-Zarr";
    match o.channel {
        ChannelSel::Channel(c) if !(stack || zarr) => {
            return refuse(format!("channel={c}"), channels)
        }
        ChannelSel::Luma if !stack => return refuse("luma=True".into(), "luma reads colour TIFF"),
        _ => {}
    }
    if let Some(t) = o.time {
        if !(stack || zarr || kind == K::Nifti) {
            return refuse(
                format!("time_point={t}"),
                "time points: 4D NIfTI, ImageJ hyperstacks, OME-TIFF, OME-Zarr",
            );
        }
    }
    if o.raw != RawSpec::default() && !raw {
        return refuse(
            "raw_dims/raw_type/raw_endian/raw_skip".into(),
            "they describe headerless .raw data",
        );
    }
    Ok(())
}

/// The geometry from numpy-ordered origin (z, y, x) and direction (rows
/// and columns in z, y, x order), each optional.
pub fn geometry_of(
    origin: Option<[f64; 3]>,
    direction: Option<[[f64; 3]; 3]>,
    base: Geometry,
) -> PyResult<Geometry> {
    let origin = origin.map_or(base.origin, rev3);
    let direction = direction.map_or(base.direction, |d| {
        rev3([rev3(d[0]), rev3(d[1]), rev3(d[2])])
    });
    let axes = [0, 1, 2].map(|a| [direction[0][a], direction[1][a], direction[2][a]]);
    Geometry::from_axes(origin, axes)
        .map(|g| g.with_unit(base.unit))
        .map_err(|e| errors::value(format!("direction: {e}")))
}

/// Spacing from numpy order (z, y, x) to volkit's (x, y, z), checked.
pub fn spacing_of(s: [f64; 3]) -> PyResult<[f32; 3]> {
    if s.iter().any(|v| !v.is_finite() || *v <= 0.0) {
        return Err(errors::value(format!(
            "spacing {s:?}: spacing must be positive and finite"
        )));
    }
    let s = rev3(s);
    Ok([s[0] as f32, s[1] as f32, s[2] as f32])
}

/// The (x, y, z) dims of a (z, y, x) shape (a 2D array is one slice).
pub fn dims_of(shape: &[usize]) -> PyResult<Dims> {
    let (z, y, x) = match *shape {
        [z, y, x] => (z, y, x),
        [y, x] => (1, y, x),
        _ => {
            return Err(errors::value(format!(
                "a volume is a 3D array (z, y, x), not {}D",
                shape.len()
            )))
        }
    };
    Dims::new(x as u64, y as u64, z as u64).map_err(|e| errors::value(e.to_string()))
}

/// Calls `f` with the samples of `a` in logical C order (the last axis
/// fastest: x fastest, as volumes store them): borrowed when `a` is
/// C-contiguous, else copied in that order. Every entry point that takes
/// an array's samples goes through here. numpy's own `as_slice` also
/// borrows Fortran-contiguous arrays, in memory order (the first axis
/// fastest), which silently transposed them (issue 53); ndarray's
/// `as_slice` of the view borrows only the standard (C) layout, and the
/// view's iterator walks any strides (negative, zero) in logical order.
pub fn with_c_order<T: Element + Copy, R>(
    a: &Bound<'_, numpy::PyArrayDyn<T>>,
    f: impl FnOnce(Cow<'_, [T]>) -> R,
) -> R {
    let ro = a.readonly();
    let view = ro.as_array();
    match view.as_slice() {
        Some(s) => f(Cow::Borrowed(s)),
        None => f(Cow::Owned(view.iter().copied().collect())),
    }
}

/// A Volume in memory from a numpy array (z, y, x) of uint8, uint16,
/// int16 or float32 (copied in logical order, whatever the array's memory
/// layout; a 2D array is one slice), with spacing, origin and direction in
/// numpy order (z, y, x): unset, spacing 1, origin 0 and the identity
/// (rows and columns z, y, x; column j is array axis j's direction).
/// What render, save, index and psnr make of an array.
#[pyfunction]
#[pyo3(signature = (array, spacing=None, origin=None, direction=None))]
pub fn from_array(
    array: &Bound<'_, PyAny>,
    spacing: Option<[f64; 3]>,
    origin: Option<[f64; 3]>,
    direction: Option<[[f64; 3]; 3]>,
) -> PyResult<PyVolume> {
    crate::guard(|| {
        let mut vol = volume_of_array(array)?;
        if let Some(s) = spacing {
            vol.meta.spacing = spacing_of(s)?;
        }
        vol.meta.geometry = geometry_of(origin, direction, vol.meta.geometry)?;
        Ok(PyVolume { vol, file: None })
    })
}

/// A sliced in-memory volume holding a copy of `array`'s samples.
pub fn volume_of_array(array: &Bound<'_, PyAny>) -> PyResult<volcore::Volume> {
    fn typed<T: Element + volcore::volume::IntoVolumeData>(
        a: &Bound<'_, numpy::PyArrayDyn<T>>,
    ) -> PyResult<volcore::Volume> {
        let dims = dims_of(a.shape())?;
        let samples = with_c_order(a, |s| s.into_owned());
        volcore::Volume::from_samples(dims, samples).map_err(|e| errors::value(e.to_string()))
    }
    if let Ok(a) = array.cast::<numpy::PyArrayDyn<u8>>() {
        return typed(a);
    }
    if let Ok(a) = array.cast::<numpy::PyArrayDyn<u16>>() {
        return typed(a);
    }
    if let Ok(a) = array.cast::<numpy::PyArrayDyn<i16>>() {
        return typed(a);
    }
    if let Ok(a) = array.cast::<numpy::PyArrayDyn<f32>>() {
        return typed(a);
    }
    Err(errors::value(format!(
        "expected a numpy array of uint8, uint16, int16 or float32 (volkit's sample types), not {}",
        describe(array)
    )))
}

/// What a Python value is, for messages: `a float64 array` or its type.
pub fn describe(v: &Bound<'_, PyAny>) -> String {
    if let Ok(dt) = v.getattr("dtype") {
        if let Ok(name) = dt.str() {
            return format!("a {name} array");
        }
    }
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an object".into())
}

/// A `Volume` (as is) or an array (as a new in-memory volume).
pub fn volume_arg<'py>(v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyVolume>> {
    if let Ok(pv) = v.cast::<PyVolume>() {
        return Ok(pv.clone());
    }
    let vol = volume_of_array(v)?;
    Bound::new(v.py(), PyVolume { vol, file: None })
}
