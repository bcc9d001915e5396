//! `volkit.render`: vol-render's options as keyword arguments, through the
//! one definition in volscene (`Request::from_pairs`), rendered by the
//! same library calls; the linear float image as a numpy array and the
//! `--json` figures as a dict.

use crate::errors;
use crate::volume::{decode, volume_arg, PyVolume};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use serde_json::Value;
use std::path::PathBuf;
use volcore::{Volume, VolumeData};
use volscene::report::Context;
use volscene::{Cancel, Error, ErrorKind, Image, Plan, Progress, Request, Source};

/// What to render: a file (opened as vol-render opens it) or a volume
/// already in memory (a copy of its samples).
enum Input {
    File,
    Memory(Box<Volume>, PathBuf),
}

/// An owned copy of `v` (sliced, in memory), for a render that needs the
/// volume by value while the caller keeps its own.
fn owned_copy(v: &Volume) -> PyResult<Volume> {
    let d = v.dims();
    let mut out = match &v.data {
        VolumeData::U8(g) => Volume::from_samples(d, typed(g, d)),
        VolumeData::U16(g) => Volume::from_samples(d, typed(g, d)),
        VolumeData::I16(g) => Volume::from_samples(d, typed(g, d)),
        VolumeData::F32(g) => Volume::from_samples(d, typed(g, d)),
    }
    .map_err(|e| errors::value(e.to_string()))?;
    out.meta.spacing = v.meta.spacing;
    out.meta.geometry = v.meta.geometry;
    Ok(out)
}

fn typed<T: volcore::Sample>(g: &volcore::volume::TypedGrid<T>, d: volcore::Dims) -> Vec<T> {
    use volcore::volume::TypedGrid;
    match g {
        TypedGrid::Sliced(s) => decode(s, d),
        TypedGrid::Bricked(b) => decode(b, d),
        TypedGrid::Compressed(c) => decode(c, d),
    }
}

/// The options that are points or directions: given in numpy's order
/// (z, y, x) from Python, as every other Python value is, and reversed
/// here to the command line's x,y,z (issue 53 §2). Scene files keep
/// their x,y,z.
pub const ZYX_OPTIONS: [&str; 4] = ["eye", "look_at", "up", "light"];

/// `pairs` with the [`ZYX_OPTIONS`] turned from (z, y, x) to x,y,z; such
/// an option given as text is refused (it would be ambiguous), except
/// `up="patient"`.
fn zyx_to_xyz(pairs: &mut [(String, Value)]) -> PyResult<()> {
    for (name, value) in pairs.iter_mut() {
        let id = volscene::pairs::id_of(name);
        if !ZYX_OPTIONS.contains(&id.as_str()) {
            continue;
        }
        match value {
            Value::Array(items) if items.len() == 3 => items.reverse(),
            Value::String(t) if id == "up" && t.trim() == "patient" => {}
            Value::Null => {}
            other => {
                return Err(errors::value(format!(
                    "{id}={other}: give (z, y, x), a sequence of three numbers in numpy's order"
                )))
            }
        }
    }
    Ok(())
}

/// What a render hands back from its worker thread.
struct Output {
    /// Rows from the top, `channels` floats per pixel.
    pixels: Vec<f32>,
    width: usize,
    height: usize,
    channels: usize,
    report: Value,
}

/// The render itself, on the worker thread.
fn render_on(
    request: Request,
    input: Input,
    cancel: &Cancel,
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<Output, Error> {
    let request = request.with_scene_file()?;
    let (source, options, path) = match input {
        Input::File => {
            let path = request.volume()?;
            let options = request.into_options();
            let source = Source::open(&options, &path)?;
            (source, options, path)
        }
        Input::Memory(vol, name) => {
            let options = request.into_options();
            let source = Source::from_volume(&options, *vol, &name)?;
            (source, options, name)
        }
    };
    let plan = Plan::for_source(&options, &source)?;
    let rendered = volscene::render(&options, &source, &plan, cancel, progress)?;
    rendered.write_files(&options, options.output.as_deref())?;
    let scene = serde_json::to_value(&plan.scene)
        .map_err(|e| Error::new(ErrorKind::Render, e.to_string()))?;
    let cx = Context {
        options: &options,
        volume: &path,
        output: options.output.as_deref(),
        scene: &scene,
    };
    let report = rendered.report(&cx).json;
    let (width, height) = (rendered.width() as usize, rendered.height() as usize);
    let (pixels, channels) = match &rendered.image {
        Image::Frame(f) if options.alpha => (f.rgba.iter().flatten().copied().collect(), 4),
        _ => (rendered.linear_rgb(), 3),
    };
    Ok(Output {
        pixels,
        width,
        height,
        channels,
        report,
    })
}

/// Render a volume with vol-render's options, by the same names (`look-at`
/// as `look_at`; values as on the command line or as Python values:
/// `size="700x700"` or `size=(700, 700)`, `ortho=True`); points and
/// directions (`eye`, `look_at`, `up`, `light`) are (z, y, x) sequences,
/// numpy's order, where vol-render's flags take x,y,z,
/// checked and defaulted by vol-render's own definition. `volume` is a
/// path, a Volume or a (z, y, x) array; or leave it out and give
/// `scene="file.toml"`, whose options the keywords override. Ray casting
/// and path tracing (`mode="path"`, `spp`, `seed`, `accumulate=state`)
/// alike; `output`, `hdr`, `heatmap` and `variance` also write those files.
///
/// Returns (image, report): the linear float image as a float32 array of
/// shape (H, W, 3), rows from the top (what `--hdr` writes), or (H, W, 4)
/// with coverage alpha under `alpha=True`; and the figures
/// `vol-render --json` prints, as a dict. `progress=True` shows the
/// path-tracing passes on stderr; a callable gets (spp_added,
/// relative_error) after each pass. The GIL is released; Ctrl-C stops the
/// render at the next tile or pass and raises KeyboardInterrupt. Bad
/// options raise ValueError, unreadable files OSError, with vol-render's
/// one-line message.
#[pyfunction]
#[pyo3(signature = (volume=None, *, progress=None, **options))]
pub fn render<'py>(
    py: Python<'py>,
    volume: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    crate::guard(|| {
        let mut pairs = crate::value::pairs(options)?;
        zyx_to_xyz(&mut pairs)?;
        for (name, _) in &pairs {
            if matches!(name.as_str(), "volume" | "print_scene" | "print-scene") {
                return Err(errors::value(format!(
                    "option `{name}`: give the volume as render's first argument; print_scene does not apply here"
                )));
            }
        }
        let mut input = Input::File;
        match volume {
            None => {}
            Some(v) if v.is_instance_of::<PyString>() || v.hasattr("__fspath__")? => {
                let p: PathBuf = v.extract()?;
                pairs.push(("volume".into(), Value::String(p.display().to_string())));
            }
            Some(v) => {
                let pv: Bound<'py, PyVolume> = volume_arg(v)?;
                let pv = pv.get();
                match pv.plain_file() {
                    Some(p) => {
                        pairs.push(("volume".into(), Value::String(p.display().to_string())))
                    }
                    None => {
                        let copy = py.detach(|| owned_copy(&pv.vol))?;
                        input = Input::Memory(Box::new(copy), pv.name());
                    }
                }
            }
        }
        let request = Request::from_pairs(pairs).map_err(errors::scene)?;
        let threads = request.options().threads;
        let pool = match threads {
            Some(0) => return Err(errors::value("--threads must be at least 1")),
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| errors::os(format!("cannot start the worker threads: {e}")))?,
            ),
            None => None,
        };
        let cancel = Cancel::new();
        let show = progress_fn(progress)?;
        let work = || {
            let go = || render_on(request, input, &cancel, &show);
            match &pool {
                Some(p) => p.install(go),
                None => go(),
            }
        };
        let out = crate::run(py, || cancel.cancel(), work)?;
        if let Some(p) = progress {
            if p.is_truthy()? && !p.is_callable() {
                eprintln!();
            }
        }
        let out = out.map_err(errors::scene)?;
        let flat = PyArray1::from_vec(py, out.pixels);
        let image = flat.reshape([out.height, out.width, out.channels])?;
        let report = crate::value::to_py(py, &out.report)?;
        Ok((image.into_any(), report))
    })
}

/// The progress hook `progress` asks for: nothing (None or False), a line
/// on standard error (True), or a callable given (spp_added,
/// relative_error) after each path-traced pass.
fn progress_fn(progress: Option<&Bound<'_, PyAny>>) -> PyResult<impl Fn(&Progress) + Sync> {
    enum Show {
        None,
        Line,
        Call(Py<PyAny>),
    }
    let show = match progress {
        None => Show::None,
        Some(p) if p.is_callable() => Show::Call(p.clone().unbind()),
        Some(p) if p.is_truthy()? => Show::Line,
        Some(_) => Show::None,
    };
    Ok(move |p: &Progress| match &show {
        Show::None => {}
        Show::Line => {
            let err = p
                .relative_error
                .map_or(String::new(), |e| format!(", error {:.2}%", e * 100.0));
            eprint!("\rvolkit.render: path tracing: {} spp{err}   ", p.spp_added);
        }
        Show::Call(f) => Python::attach(|py| {
            if let Err(e) = f.call1(py, (p.spp_added, p.relative_error)) {
                e.print(py);
            }
        }),
    })
}
