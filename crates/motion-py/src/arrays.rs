//! numpy in: a float64 array is viewed where it lies (any strides, no copy); anything else
//! (other dtypes, lists) is converted once by `numpy.asarray(x, dtype=float64)`.
use ndarray::{ArrayViewD, Dimension};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::value;

/// A read-only float64 view of `obj` (converted first when it is not a float64 array).
pub fn f64_array<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    if let Ok(array) = obj.extract::<PyReadonlyArrayDyn<'py, f64>>() {
        return Ok(array);
    }
    let numpy = obj.py().import("numpy")?;
    let converted = numpy
        .call_method1("asarray", (obj, numpy.getattr("float64")?))
        .map_err(|e| value(format!("{what}: not convertible to a float64 array ({e})")))?;
    converted
        .extract::<PyReadonlyArrayDyn<'py, f64>>()
        .map_err(|e| value(format!("{what}: {e}")))
}

/// `view` as `D` dimensions, or a `ValueError` naming `what` and the shape expected.
pub fn dims<'a, D: Dimension>(
    view: ArrayViewD<'a, f64>,
    what: &str,
    expected: &str,
) -> PyResult<ndarray::ArrayView<'a, f64, D>> {
    let shape = view.shape().to_vec();
    view.into_dimensionality::<D>()
        .map_err(|_| value(format!("{what}: expected {expected}, got shape {shape:?}")))
}

/// The address of the first element of `obj` as the bindings see it (after any conversion):
/// equal to `obj.ctypes.data` when a float64 array is used in place.
#[pyfunction]
pub fn data_address(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    let array = f64_array(obj, "array")?;
    let _ = array.shape();
    Ok(array.as_array().as_ptr() as usize)
}
