//! volkit in Python: the `volkit._volkit` extension module. Every function
//! here calls the library the command-line tools call (volformats,
//! volscene, volcompare, volindex), so Python gets the tools' exact
//! results and one-line messages; `volkit/__init__.py` re-exports it.
//!
//! Long calls run on a worker thread with the GIL released while the
//! calling thread waits and checks for signals ([`run`]), so Ctrl-C
//! raises `KeyboardInterrupt` between tiles, passes or slices. A Rust
//! panic never reaches Python as one: it becomes a `RuntimeError`.

mod errors;
mod generate;
mod index;
mod keywords;
mod options_doc;
mod prep;
mod psnr;
mod render;
mod save;
mod slicing;
mod value;
mod volume;

use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

pub use errors::internal;

/// How often a waiting call wakes up to look for signals (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(20);

/// Run `work` on a worker thread with the GIL released, waking every
/// [`SIGNAL_POLL`] to run Python's signal handlers. When one raises
/// (`KeyboardInterrupt` on Ctrl-C), `on_signal` is called once (it asks
/// the work to stop: a render's cancel flag, a conversion's stop
/// request), the work is waited for, and the handler's exception is
/// raised. A panic in `work` is a `RuntimeError`.
pub fn run<T: Send>(
    py: Python<'_>,
    on_signal: impl Fn(),
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let done = Arc::new(AtomicBool::new(false));
    let waiter = std::thread::current();
    std::thread::scope(|s| {
        let flag = done.clone();
        let handle = s.spawn(move || {
            let out = catch_unwind(AssertUnwindSafe(work));
            flag.store(true, Ordering::Release);
            waiter.unpark();
            out
        });
        let mut raised: Option<PyErr> = None;
        while !done.load(Ordering::Acquire) {
            py.detach(|| {
                if !done.load(Ordering::Acquire) {
                    std::thread::park_timeout(SIGNAL_POLL);
                }
            });
            if raised.is_none() {
                if let Err(e) = py.check_signals() {
                    on_signal();
                    raised = Some(e);
                }
            }
        }
        let joined = py.detach(|| handle.join());
        if let Some(e) = raised {
            return Err(e);
        }
        match joined {
            Ok(Ok(v)) => Ok(v),
            Ok(Err(payload)) | Err(payload) => Err(internal(payload.as_ref())),
        }
    })
}

/// Run `f` (on the calling thread, with the GIL), turning a panic into a
/// `RuntimeError` instead of letting it reach Python.
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => Err(internal(payload.as_ref())),
    }
}

/// The extension module.
#[pymodule]
fn _volkit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<volume::PyVolume>()?;
    m.add_class::<index::PyIndex>()?;
    m.add_function(wrap_pyfunction!(volume::open, m)?)?;
    m.add_function(wrap_pyfunction!(volume::from_array, m)?)?;
    m.add_function(wrap_pyfunction!(save::save, m)?)?;
    m.add_function(wrap_pyfunction!(save::preprocess, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(options_doc::render_options, m)?)?;
    m.add_function(wrap_pyfunction!(keywords::python_words_py, m)?)?;
    m.add_function(wrap_pyfunction!(psnr::psnr, m)?)?;
    m.add_function(wrap_pyfunction!(index::index, m)?)?;
    m.add_function(wrap_pyfunction!(generate::generate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
