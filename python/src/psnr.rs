//! `volkit.psnr`: how far apart two images or two volumes are, by
//! volcompare, with the figures `vol-psnr --json` prints.

use crate::errors;
use crate::volume::{describe, volume_arg, PyVolume};
use numpy::{PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::path::PathBuf;
use volcompare::image::image_extension;
use volcompare::{compare_images, compare_volumes, Depth, Image, ImageOptions, VolumeOptions};

/// One side of a comparison.
enum Operand<'py> {
    Image(Image, String),
    Volume(Bound<'py, PyVolume>, String),
}

impl Operand<'_> {
    fn kind(&self) -> &'static str {
        match self {
            Operand::Image(..) => "an image",
            Operand::Volume(..) => "a volume",
        }
    }
    fn name(&self) -> &str {
        match self {
            Operand::Image(_, n) | Operand::Volume(_, n) => n,
        }
    }
}

/// A file as vol-psnr takes it: an image by its extension (.png, .pfm,
/// .exr), anything else a volume.
fn from_path<'py>(py: Python<'py>, p: PathBuf) -> PyResult<Operand<'py>> {
    let name = p.display().to_string();
    if image_extension(&p).is_some() {
        let img = py
            .detach(|| Image::load(&p))
            .map_err(|e| errors::os(format!("{name}: {e}")))?;
        return Ok(Operand::Image(img, name));
    }
    let vol = crate::volume::open(py, p, None)?;
    Ok(Operand::Volume(Bound::new(py, vol)?, name))
}

/// An image from a numpy array: (H, W) grey, or (H, W, 3) RGB and
/// (H, W, 4) RGBA; uint8 and uint16 keep their depth, floats are float.
fn image_of(a: &Bound<'_, PyAny>, name: &str) -> PyResult<Image> {
    let np = a.py().import("numpy")?;
    let arr = np.call_method1("asarray", (a,))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let dtype: String = arr.getattr("dtype")?.str()?.extract()?;
    let depth = match dtype.as_str() {
        "uint8" => Depth::U8,
        "uint16" => Depth::U16,
        "float32" | "float64" => Depth::F32,
        _ => {
            return Err(errors::value(format!(
                "{name}: an image is uint8, uint16 or float, not {dtype}"
            )))
        }
    };
    let (h, w, c) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, c] if c == 3 || c == 4 => (h, w, c),
        _ => {
            return Err(errors::value(format!(
                "{name}: an image is (H, W), (H, W, 3) or (H, W, 4), not {shape:?}"
            )))
        }
    };
    let flat = arr
        .call_method1("astype", ("float32",))?
        .call_method1("reshape", (-1,))?;
    let samples: Vec<f32> = flat
        .cast::<PyArrayDyn<f32>>()?
        .readonly()
        .as_array()
        .iter()
        .copied()
        .collect();
    let too_big = || errors::value(format!("{name}: image too large"));
    let (w, h) = (
        u32::try_from(w).map_err(|_| too_big())?,
        u32::try_from(h).map_err(|_| too_big())?,
    );
    let (color, alpha) = if c == 1 { (1, false) } else { (3, c == 4) };
    Image::new(w, h, color, alpha, depth, samples)
        .map_err(|e| errors::value(format!("{name}: {e}")))
}

/// Whether an array of `shape` is an image (`Some(true)`), a volume
/// (`Some(false)`), or could be either: (H, W) is an image; (N, M, 3) and
/// (N, M, 4) are an RGB(A) image or a volume of 3 or 4 slices along x, so
/// they need `kind` (or a Volume or path on the other side).
fn array_kind(shape: &[usize]) -> Option<bool> {
    match shape {
        [_, _] => Some(true),
        [_, _, 3 | 4] => None,
        _ => Some(false),
    }
}

/// What `v` is by itself: a path by its extension, a Volume a volume, an
/// array by [`array_kind`]; None when that cannot tell.
fn kind_of(v: &Bound<'_, PyAny>) -> PyResult<Option<bool>> {
    if v.is_instance_of::<PyString>() || v.hasattr("__fspath__")? {
        return Ok(Some(image_extension(&v.extract::<PathBuf>()?).is_some()));
    }
    if v.cast::<PyVolume>().is_ok() {
        return Ok(Some(false));
    }
    Ok(
        match v.getattr("shape").and_then(|s| s.extract::<Vec<usize>>()) {
            Ok(shape) => array_kind(&shape),
            Err(_) => None,
        },
    )
}

/// One side of the comparison. What an array is: `kind` when given, else
/// its shape, else `other` (what the other side is).
fn operand<'py>(
    v: &Bound<'py, PyAny>,
    name: &str,
    kind: Option<bool>,
    other: Option<bool>,
) -> PyResult<Operand<'py>> {
    let py = v.py();
    if v.is_instance_of::<PyString>() || v.hasattr("__fspath__")? {
        return from_path(py, v.extract::<PathBuf>()?);
    }
    if let Ok(pv) = v.cast::<PyVolume>() {
        return Ok(Operand::Volume(
            pv.clone(),
            pv.get().name().display().to_string(),
        ));
    }
    let shape: Vec<usize> = match v.getattr("shape") {
        Ok(s) => s.extract()?,
        Err(_) => {
            return Err(errors::value(format!(
                "{name}: expected a path, a Volume or a numpy array, not {}",
                describe(v)
            )))
        }
    };
    let Some(image) = kind.or_else(|| array_kind(&shape)).or(other) else {
        return Err(errors::value(format!(
            "{name}: a {shape:?} array is an RGB(A) image or a volume: pass kind='image' or kind='volume'"
        )));
    };
    if image {
        Ok(Operand::Image(image_of(v, name)?, name.to_string()))
    } else {
        Ok(Operand::Volume(volume_arg(v)?, name.to_string()))
    }
}

/// PSNR, MSE, maximum error and differing elements of `b` against the
/// reference `a`, as vol-psnr computes them, as the dict `vol-psnr --json`
/// prints (`psnr` is None when the inputs are identical). Each input is a
/// path (images by their extension: .png, .pfm, .exr; anything else a
/// volume), a Volume (a volume), or a numpy array: (H, W) is an image
/// (uint8, uint16 or float), (Z, Y, X) a volume; an (N, M, 3) or (N, M, 4)
/// array could be either, so it is what the other side is (a Volume or a
/// path), else `kind` ("image" or "volume") must say, and `kind` decides
/// for every array. `range` is the peak, as
/// `--range`; `alpha` and `luma` as vol-psnr's.
#[pyfunction]
#[pyo3(signature = (a, b, *, range=None, alpha=false, luma=false, kind=None))]
pub fn psnr<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    range: Option<f64>,
    alpha: bool,
    luma: bool,
    kind: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    crate::guard(|| {
        if let Some(r) = range {
            if !(r.is_finite() && r > 0.0) {
                return Err(errors::value(format!(
                    "range: '{r}' is not a positive number"
                )));
            }
        }
        let image = match kind {
            Some("image") => Some(true),
            Some("volume") => Some(false),
            Some(other) => {
                return Err(errors::value(format!(
                    "kind: '{other}' is not image or volume"
                )))
            }
            None => None,
        };
        let (oa, ob) = (
            operand(a, "A", image, kind_of(b)?)?,
            operand(b, "B", image, kind_of(a)?)?,
        );
        let mut json = match (&oa, &ob) {
            (Operand::Image(ia, _), Operand::Image(ib, _)) => {
                let opts = ImageOptions {
                    range,
                    alpha,
                    luma,
                    error_map: false,
                };
                let c = py
                    .detach(|| compare_images(ia, ib, &opts))
                    .map_err(|e| compare_error(e, oa.name(), ob.name()))?;
                let mut j = c.headline().figures();
                j["kind"] = "image".into();
                j["channels"] = c.channels.len().into();
                j["peak_source"] = c.peak_source.name().into();
                j
            }
            (Operand::Volume(va, _), Operand::Volume(vb, _)) => {
                if alpha || luma {
                    return Err(errors::value("alpha and luma apply to images only"));
                }
                let opts = VolumeOptions {
                    range,
                    error_map: false,
                };
                let (va, vb) = (&va.get().vol, &vb.get().vol);
                let c = crate::run(py, || {}, || compare_volumes(va, vb, &opts))?
                    .map_err(|e| compare_error(e, oa.name(), ob.name()))?;
                let mut j = c.metrics.figures();
                j["kind"] = "volume".into();
                j["peak_source"] = c.peak_source.name().into();
                j
            }
            _ => {
                return Err(errors::value(format!(
                    "{} is {} but {} is {}: compare images with images, volumes with volumes",
                    oa.name(),
                    oa.kind(),
                    ob.name(),
                    ob.kind()
                )))
            }
        };
        json["a"] = oa.name().into();
        json["b"] = ob.name().into();
        crate::value::to_py(py, &json)
    })
}

/// volcompare's error as vol-psnr reports it: inputs that cannot be
/// compared are a `ValueError`, a decode error names the file (`OSError`).
fn compare_error(e: volcompare::Error, a: &str, b: &str) -> PyErr {
    match e {
        volcompare::Error::Mismatch(m) => errors::value(m),
        volcompare::Error::Invalid(m) => {
            let named = match (m.strip_prefix("A: "), m.strip_prefix("B: ")) {
                (Some(rest), _) => format!("{a}: {rest}"),
                (_, Some(rest)) => format!("{b}: {rest}"),
                _ => m,
            };
            errors::os(named)
        }
        volcompare::Error::Io(e) => errors::os(e.to_string()),
    }
}
