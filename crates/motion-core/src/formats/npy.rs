//! `.npy` arrays of motion data (ndarray-npy): frames x channels (2-D), positions T x J x 3 or
//! N x T x D (3-D), and 4-D/5-D stacks. Always `f64` in memory; `float32` files are accepted and
//! widened, so are Fortran-ordered ones. Writes `float64`, C order, atomically.
use std::io::Cursor;
use std::path::Path;

use ndarray::{Array, ArrayBase, ArrayD, Data, Dimension, IxDyn};
use ndarray_npy::npy::header::Header;
use ndarray_npy::{ReadNpyExt, WriteNpyExt};

use crate::error::FormatError;
use crate::formats::h36m_text::write_atomically;

fn invalid(path: &Path, problem: String) -> FormatError {
    FormatError::Invalid {
        path: path.to_path_buf(),
        problem,
    }
}

/// Reads a `.npy` array of any rank as `f64` (from `float64` or `float32` data).
///
/// Errors: missing file ([`FormatError::Io`]); a bad header, another dtype, or data shorter or
/// longer than the header's shape ([`FormatError::Invalid`]). The declared shape is checked
/// against the file size before anything is allocated.
pub fn read_npy_dyn(path: impl AsRef<Path>) -> Result<ArrayD<f64>, FormatError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut cursor = Cursor::new(&bytes[..]);
    let header = Header::from_reader(&mut cursor)
        .map_err(|e| invalid(path, format!("not a valid .npy header: {e}")))?;
    let descr = header.type_descriptor.to_string();
    let elem = match descr.trim_matches(|c| c == '\'' || c == '"') {
        "<f8" | "=f8" | "f8" | "float64" => 8,
        "<f4" | "=f4" | "f4" | "float32" => 4,
        other => {
            return Err(invalid(
                path,
                format!("expected float64 or float32 little-endian data, found dtype {other}"),
            ))
        }
    };
    let data_len = bytes.len() - cursor.position() as usize;
    let needed = header
        .shape
        .iter()
        .try_fold(elem, |acc: usize, &d| acc.checked_mul(d));
    if needed != Some(data_len) {
        return Err(invalid(
            path,
            format!(
                "header shape {:?} needs {} bytes of data, file has {data_len}",
                header.shape,
                needed.map_or_else(|| "too many".to_string(), |n| n.to_string())
            ),
        ));
    }
    let parse_err = |e: ndarray_npy::ReadNpyError| invalid(path, format!("bad .npy data: {e}"));
    if elem == 8 {
        ArrayD::<f64>::read_npy(&bytes[..]).map_err(parse_err)
    } else {
        Ok(ArrayD::<f32>::read_npy(&bytes[..])
            .map_err(parse_err)?
            .mapv(f64::from))
    }
}

/// Reads a `.npy` array that must have rank `D` (e.g. `Ix2` for frames x channels, `Ix3` for
/// positions); the error names the expected and found shapes.
pub fn read_npy_as<D: Dimension>(path: impl AsRef<Path>) -> Result<Array<f64, D>, FormatError> {
    let path = path.as_ref();
    let array = read_npy_dyn(path)?;
    let found = array.shape().to_vec();
    array.into_dimensionality::<D>().map_err(|_| {
        invalid(
            path,
            format!(
                "expected a {}-D array, found shape {found:?}",
                D::NDIM.map_or_else(|| "n".to_string(), |n| n.to_string())
            ),
        )
    })
}

/// Reads `frames x channels` (2-D).
pub fn read_npy_frames(path: impl AsRef<Path>) -> Result<ndarray::Array2<f64>, FormatError> {
    read_npy_as::<ndarray::Ix2>(path)
}

/// Reads joint positions `frames x joints x 3` (3-D whose last axis is 3).
pub fn read_npy_positions(path: impl AsRef<Path>) -> Result<ndarray::Array3<f64>, FormatError> {
    let path = path.as_ref();
    let array = read_npy_as::<ndarray::Ix3>(path)?;
    if array.shape()[2] != 3 {
        return Err(invalid(
            path,
            format!(
                "expected positions of shape [frames, joints, 3], found {:?}",
                array.shape()
            ),
        ));
    }
    Ok(array)
}

/// Writes any `f64` array as a `float64`, C-order `.npy` (via a temporary file and rename).
pub fn write_npy<S, D>(path: impl AsRef<Path>, array: &ArrayBase<S, D>) -> Result<(), FormatError>
where
    S: Data<Elem = f64>,
    D: Dimension,
{
    let path = path.as_ref();
    let standard = array.as_standard_layout().into_dimensionality::<IxDyn>();
    let standard = standard.expect("any dimension converts to IxDyn");
    write_atomically(path, |w| {
        standard
            .write_npy(&mut *w)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}
