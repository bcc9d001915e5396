//! `volkit.index`: the min/max macrocell index vol-index builds
//! (`volindex::MinMaxIndex::build_volume`), returned as an `Index` and
//! written as a `.vidx` file when asked.

use crate::errors;
use crate::volume::{volume_arg, PyVolume};
use numpy::PyArray1;
use pyo3::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use volindex::{BuildOptions, MinMaxIndex};

/// A volume's min/max macrocell index, its value range and histogram.
#[pyclass(name = "Index", module = "volkit", frozen)]
pub struct PyIndex {
    ix: MinMaxIndex,
}

#[pymethods]
impl PyIndex {
    /// Voxels per axis of the indexed volume, (z, y, x).
    #[getter]
    fn shape(&self) -> (u64, u64, u64) {
        let d = self.ix.dims();
        (d.z, d.y, d.x)
    }

    /// Macrocell edge in voxels.
    #[getter]
    fn cell(&self) -> u32 {
        self.ix.cell_edge()
    }

    /// Level-0 macrocells.
    #[getter]
    fn cells(&self) -> u64 {
        self.ix.stats().cells
    }

    /// Levels of the hierarchy.
    #[getter]
    fn levels(&self) -> usize {
        self.ix.stats().levels
    }

    /// The smallest and largest sample, or None when all are NaN.
    #[getter]
    fn range(&self) -> Option<(f64, f64)> {
        let (lo, hi) = self.ix.value_range();
        (lo <= hi).then_some((f64::from(lo), f64::from(hi)))
    }

    /// Fraction of level-0 cells that are empty (maximum <= 0).
    #[getter]
    fn empty_fraction(&self) -> f64 {
        self.ix.stats().empty_fraction
    }

    /// NaN samples in the volume.
    #[getter]
    fn nan_count(&self) -> u64 {
        self.ix.stats().nan_count
    }

    /// The fingerprint of the indexed file (0 for a volume in memory).
    #[getter]
    fn fingerprint(&self) -> u64 {
        self.ix.fingerprint()
    }

    /// The histogram: (counts, lo, hi), `counts` a numpy array of equal
    /// bins over [lo, hi).
    fn histogram<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<u64>>, f64, f64) {
        let h = self.ix.histogram();
        (PyArray1::from_slice(py, h.counts()), h.lo(), h.hi())
    }

    /// Write the index as a `.vidx` file (under a temporary name, renamed
    /// into place when complete); the bytes written.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        crate::guard(|| {
            py.detach(|| write_index(&self.ix, &path))
                .map_err(|e| errors::os(format!("{}: {e}", path.display())))
        })
    }

    fn __repr__(&self) -> String {
        let (z, y, x) = self.shape();
        format!(
            "Index(shape=({z}, {y}, {x}), cell={}, levels={})",
            self.cell(),
            self.levels()
        )
    }
}

/// Write `ix` to `path` through a temporary file; the bytes written.
fn write_index(ix: &MinMaxIndex, path: &Path) -> Result<u64, String> {
    let mut file = volformats::output::AtomicFile::create(path).map_err(|e| e.to_string())?;
    let bytes = {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file.file());
        ix.write_to(&mut w).map_err(|e| e.to_string())?;
        w.flush().map_err(|e| e.to_string())?;
        drop(w);
        file.file().metadata().map_err(|e| e.to_string())?.len()
    };
    file.commit().map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// Build the min/max macrocell index of `volume` (a path, a Volume or an
/// array) as vol-index does, with its value range and histogram; write it
/// as a .vidx file to `output` when given (True: the volume's path with
/// `.vidx` appended), which `render(..., index=...)` and vol-render read.
#[pyfunction]
#[pyo3(signature = (volume, output=None, *, cell=volindex::build::DEFAULT_CELL_EDGE, bins=volindex::histogram::DEFAULT_BINS))]
pub fn index<'py>(
    py: Python<'py>,
    volume: &Bound<'py, PyAny>,
    output: Option<&Bound<'py, PyAny>>,
    cell: u32,
    bins: u32,
) -> PyResult<PyIndex> {
    crate::guard(|| {
        let opts = BuildOptions {
            cell_edge: cell,
            histogram_bins: bins,
        };
        opts.validate().map_err(|e| errors::value(e.to_string()))?;
        let pv: Bound<'py, PyVolume> =
            if volume.is_instance_of::<pyo3::types::PyString>() || volume.hasattr("__fspath__")? {
                Bound::new(py, crate::volume::open(py, volume.extract()?, None)?)?
            } else {
                volume_arg(volume)?
            };
        let v = pv.get();
        let file = v.file.as_ref().map(|(p, _)| p.clone());
        let output: Option<PathBuf> = match output {
            None => None,
            Some(o) if o.is_instance_of::<pyo3::types::PyBool>() => match (o.extract::<bool>()?, &file) {
                (false, _) => None,
                (true, Some(p)) => {
                    let mut s = p.clone().into_os_string();
                    s.push(".");
                    s.push(volindex::vidx::EXTENSION);
                    Some(PathBuf::from(s))
                }
                (true, None) => {
                    return Err(errors::value(
                        "output=True names the index after the volume's file, and this volume has none: give a path",
                    ))
                }
            },
            Some(o) => Some(o.extract()?),
        };
        if let Some(o) = &output {
            if volformats::FileKind::of(o).is_some() {
                return Err(errors::value(format!(
                    "{}: refusing to write an index under a volume file name: use a .vidx name",
                    o.display()
                )));
            }
        }
        let name = v.name().display().to_string();
        let fingerprint =
            |p: &Path| volformats::fingerprint(p).map_err(|e| errors::os(format!("{name}: {e}")));
        let fp = match &file {
            Some(p) => fingerprint(p)?,
            None => 0,
        };
        let ix = crate::run(py, || {}, || MinMaxIndex::build_volume(&v.vol, &opts, fp))?
            .map_err(|e| errors::os(format!("{name}: {e}")))?;
        if let Some(e) = v.vol.error() {
            return Err(errors::os(format!("{name}: {e}")));
        }
        if let Some(p) = &file {
            if fingerprint(p)? != fp {
                return Err(errors::os(format!(
                    "{name}: the volume changed while it was being indexed: run vol-index again"
                )));
            }
        }
        if let Some(o) = &output {
            py.detach(|| write_index(&ix, o))
                .map_err(|e| errors::os(format!("{}: {e}", o.display())))?;
        }
        Ok(PyIndex { ix })
    })
}
