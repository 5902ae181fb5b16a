//! Files and forward kinematics: BVH, exp-map text / `.npy`, world positions.
use std::path::PathBuf;

use motion_core::formats::bvh::{read_bvh as read_bvh_file, write_bvh as write_bvh_file};
use motion_core::formats::expmap_bvh::{bvh_to_expmap, expmap_to_bvh, ExpMapTarget};
use motion_core::formats::h36m_text::read_expmap_text;
use motion_core::formats::npy::read_npy_frames;
use motion_core::formats::FileFormat;
use motion_core::Motion;
use ndarray::{Array2, Ix2};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{dims, f64_array};
use crate::errors::{format, value};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_bvh, m)?)?;
    m.add_function(wrap_pyfunction!(write_bvh, m)?)?;
    m.add_function(wrap_pyfunction!(read_expmap, m)?)?;
    m.add_function(wrap_pyfunction!(expmap_to_positions, m)?)?;
    Ok(())
}

/// A BVH file: `{"channels": T x C, "fps", "joints", "parents", "offsets": J x 3,
/// "expmap": T x 99 exp-map frames when it is on the H3.6M skeleton, else None}`.
#[pyfunction]
fn read_bvh<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let bvh = py.detach(|| read_bvh_file(&path)).map_err(format)?;
    let out = PyDict::new(py);
    let joints = bvh.skeleton.joints();
    out.set_item("fps", bvh.fps())?;
    out.set_item(
        "joints",
        joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>(),
    )?;
    out.set_item(
        "parents",
        joints
            .iter()
            .map(|j| j.parent.map_or(-1, |p| p as i64))
            .collect::<Vec<_>>(),
    )?;
    let offsets = Array2::from_shape_fn((joints.len(), 3), |(j, k)| joints[j].offset[k]);
    out.set_item("offsets", offsets.into_pyarray(py))?;
    let expmap = bvh_to_expmap(&bvh, ExpMapTarget::H36m)
        .ok()
        .map(|m| m.into_frames().into_pyarray(py));
    out.set_item("expmap", expmap)?;
    out.set_item("channels", bvh.frames.into_pyarray(py))?;
    Ok(out)
}

/// Exp-map `frames` (`T x 99` H3.6M or `T x 117` CMU) at `fps` written as a BVH file.
#[pyfunction]
#[pyo3(signature = (path, frames, fps = 25.0))]
fn write_bvh(py: Python<'_>, path: PathBuf, frames: &Bound<'_, PyAny>, fps: f64) -> PyResult<()> {
    let array = f64_array(frames, "frames")?;
    let frames = dims::<Ix2>(array.as_array(), "frames", "T x D exp-map frames")?.to_owned();
    if !(fps.is_finite() && fps > 0.0) {
        return Err(value(format!("fps {fps}: must be positive")));
    }
    let width = frames.ncols();
    let motion = Motion::expmap_of_width(frames, fps)
        .ok_or_else(|| value(format!("frames: no built-in skeleton has {width}-dim exp-map frames (99 = H3.6M, 117 = CMU)")))?
        .map_err(value)?;
    let bvh = expmap_to_bvh(&motion).map_err(value)?;
    py.detach(|| write_bvh_file(&path, &bvh)).map_err(format)
}

/// Exp-map frames of a `.txt`, `.txt.gz` or `.npy` file (`T x D`, at the file's rate: 50 Hz
/// for H3.6M text).
#[pyfunction]
fn read_expmap<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let frames = py
        .detach(|| match FileFormat::from_path(&path)? {
            FileFormat::Npy => read_npy_frames(&path),
            FileFormat::ExpMapText => read_expmap_text(&path),
            FileFormat::Bvh => Err(motion_core::error::FormatError::Invalid {
                path: path.clone(),
                problem: "a BVH file: use read_bvh".into(),
            }),
        })
        .map_err(format)?;
    Ok(frames.into_pyarray(py))
}

/// World joint positions (`T x J x 3`, millimetres, y up) of exp-map frames (`T x 99` or
/// `T x 117`) at `fps` (25 Hz: the protocol's rate; H3.6M root deltas are per 50 Hz source
/// frame, so the rate scales the root's path).
#[pyfunction]
#[pyo3(signature = (frames, fps = 25.0))]
fn expmap_to_positions<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    fps: f64,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let array = f64_array(frames, "frames")?;
    let frames = dims::<Ix2>(array.as_array(), "frames", "T x D exp-map frames")?.to_owned();
    if !(fps.is_finite() && fps > 0.0) {
        return Err(value(format!("fps {fps}: must be positive")));
    }
    let width = frames.ncols();
    let positions = py.detach(|| {
        Motion::expmap_of_width(frames, fps)
            .ok_or_else(|| format!("frames: no built-in skeleton has {width}-dim exp-map frames (99 = H3.6M, 117 = CMU)"))?
            .map(|m| m.positions())
            .map_err(|e| e.to_string())
    });
    Ok(positions.map_err(value)?.into_pyarray(py))
}
