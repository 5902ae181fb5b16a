//! Python bindings of motion-core and motion-metrics (module `motion._motion`, re-exported by
//! the `motion` package in `python/`): numpy arrays in (viewed in place when they are float64,
//! any strides) and out, the GIL released while Rust computes, errors as `ValueError` (bad input)
//! or `OSError` (files) with the CLI's one-line messages.
use pyo3::prelude::*;

mod arrays;
mod character;
mod errors;
mod evaluation;
mod io;
mod metrics;
mod model;

/// The compiled module.
#[pymodule]
fn _motion(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    metrics::register(m)?;
    io::register(m)?;
    model::register(m)?;
    character::register(m)?;
    evaluation::register(m)?;
    m.add_function(wrap_pyfunction!(set_threads, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::data_address, m)?)?;
    Ok(())
}

/// Sets the number of threads the metrics and generators split work over (rayon's global pool;
/// call once, before the first computation). Default: one per core.
#[pyfunction]
fn set_threads(threads: usize) -> PyResult<()> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("set_threads: {e}")))
}
