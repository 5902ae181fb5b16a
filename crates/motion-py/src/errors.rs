//! Rust errors as Python exceptions: `OSError` for files that cannot be read or written,
//! `ValueError` for everything about the input's content.
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

/// A `ValueError` with `message`.
pub fn value(message: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(message.to_string())
}

/// A metric's error, prefixed with the metric's name as the CLI prints it.
pub fn metric(what: &str, err: motion_metrics::MetricError) -> PyErr {
    value(format!("{what}: {err}"))
}

/// A file error: `OSError` when reading or writing failed, `ValueError` when the content is bad.
pub fn format(err: motion_core::error::FormatError) -> PyErr {
    match err {
        motion_core::error::FormatError::Io { .. }
        | motion_core::error::FormatError::Write { .. } => PyOSError::new_err(err.to_string()),
        other => value(other),
    }
}

/// A weights-file error (`OSError` when unreadable).
pub fn weights(err: motion_core::model::weights::WeightsError) -> PyErr {
    match err {
        motion_core::model::weights::WeightsError::Io { .. } => PyOSError::new_err(err.to_string()),
        other => value(other),
    }
}

/// A seed-loading error.
pub fn seed(err: motion_core::seed::SeedError) -> PyErr {
    match err {
        motion_core::seed::SeedError::Format(e) => format(e),
        other => value(other),
    }
}
