//! The metrics (motion-metrics), on numpy arrays.
use motion_core::protocol::expmap_batch_to_euler_protocol;
use motion_metrics::mpjpe::{score_mpjpe, MpjpeInput};
use motion_metrics::multimodal::{score_sample_sets, SampleSets};
use motion_metrics::npss::{Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
use motion_metrics::{
    apd, apd_batch, euler_error, JointMean, NdmsConfig, NdmsDatabase as Database, NnMethod,
};
use ndarray::{Array2, Array3, ArrayView3, Ix2, Ix3, Ix4};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::arrays::{dims, f64_array};
use crate::errors::{metric, value};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(npss, m)?)?;
    m.add_function(wrap_pyfunction!(npss_windows, m)?)?;
    m.add_function(wrap_pyfunction!(euler_error_per_frame, m)?)?;
    m.add_function(wrap_pyfunction!(apd_of, m)?)?;
    m.add_function(wrap_pyfunction!(mpjpe_of, m)?)?;
    m.add_function(wrap_pyfunction!(sample_set_metrics, m)?)?;
    m.add_class::<NdmsDatabase>()?;
    Ok(())
}

fn power(variant: &str) -> PyResult<SpectrumPower> {
    match variant {
        "paper" => Ok(SpectrumPower::Modulus),
        "reference" => Ok(SpectrumPower::RealPart),
        other => Err(value(format!(
            "variant {other:?}: expected \"paper\" (|DFT|^2, Gopalakrishnan et al. 2019) or \"reference\" (Re(DFT)^2, the published code)"
        ))),
    }
}

/// Runs `f` on the ground truth and prediction as given (`input_space="raw"`) or after the
/// protocol's exp-map → Euler conversion (`"expmap"`), with the GIL released.
fn on_pair<R: Send>(
    py: Python<'_>,
    gt: &Bound<'_, PyAny>,
    pred: &Bound<'_, PyAny>,
    input_space: &str,
    f: impl FnOnce(ArrayView3<'_, f64>, ArrayView3<'_, f64>) -> PyResult<R> + Send,
) -> PyResult<R> {
    let (gt, pred) = (f64_array(gt, "gt")?, f64_array(pred, "pred")?);
    let gt = dims::<Ix3>(gt.as_array(), "gt", "N x T x D")?;
    let pred = dims::<Ix3>(pred.as_array(), "pred", "N x T x D")?;
    match input_space {
        "raw" => py.detach(|| f(gt, pred)),
        "expmap" => py.detach(|| {
            let (g, p): (Array3<f64>, Array3<f64>) = (
                expmap_batch_to_euler_protocol(gt),
                expmap_batch_to_euler_protocol(pred),
            );
            f(g.view(), p.view())
        }),
        other => Err(value(format!(
            "input_space {other:?}: expected \"raw\" (arrays as given) or \"expmap\" (exp-map frames, converted to the protocol's Euler angles)"
        ))),
    }
}

/// NPSS (Gopalakrishnan et al. 2019) of `pred` against `gt`, both `N x T x D`.
#[pyfunction]
#[pyo3(signature = (gt, pred, variant = "paper", input_space = "raw"))]
fn npss(
    py: Python<'_>,
    gt: &Bound<'_, PyAny>,
    pred: &Bound<'_, PyAny>,
    variant: &str,
    input_space: &str,
) -> PyResult<f64> {
    let power = power(variant)?;
    on_pair(py, gt, pred, input_space, |g, p| {
        Npss::new()
            .score(g, p, power)
            .map_err(|e| metric("NPSS", e))
    })
}

/// NPSS over the protocol's windows (25 Hz frames): `{label: value}`.
#[pyfunction]
#[pyo3(signature = (gt, pred, variant = "paper", input_space = "raw"))]
fn npss_windows<'py>(
    py: Python<'py>,
    gt: &Bound<'py, PyAny>,
    pred: &Bound<'py, PyAny>,
    variant: &str,
    input_space: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let power = power(variant)?;
    let scores = on_pair(py, gt, pred, input_space, |g, p| {
        Npss::new()
            .score_windows(g, p, power, &NPSS_WINDOWS_25HZ)
            .map_err(|e| metric("NPSS", e))
    })?;
    let out = PyDict::new(py);
    for w in scores {
        out.set_item(w.window.label, w.value)?;
    }
    Ok(out)
}

/// The protocol's Euler-angle error per predicted frame (exp-map `N x T x D` inputs).
#[pyfunction]
#[pyo3(name = "euler_error")]
fn euler_error_per_frame<'py>(
    py: Python<'py>,
    gt: &Bound<'py, PyAny>,
    pred: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let per_frame = on_pair(py, gt, pred, "expmap", |g, p| {
        euler_error(g, p).map_err(|e| metric("Euler error", e))
    })?;
    Ok(per_frame.into_pyarray(py))
}

/// MPJPE (mm; `motion_metrics::mpjpe`) of `pred` against `gt` per predicted frame, averaged over
/// sequences. `input_space="expmap"`: H3.6M exp-map frames `N x T x 99`, put in the pelvis frame
/// (forward kinematics with dims 0..5 zeroed, as LTD, HRI and siMLPe do); `"positions"`: `N x T x
/// J x 3` or `N x T x 3J` as given; a 22-joint prediction against 32-joint truth is completed from
/// the truth. `joints`: `"all-32"` (the reference's mean) or `"predicted-22"`. The 80-1000 ms values
/// are `result[[1, 3, 7, 9, 13, 17, 21, 24]]` at 25 Hz.
#[pyfunction]
#[pyo3(name = "mpjpe", signature = (gt, pred, input_space = "expmap", joints = "all-32"))]
fn mpjpe_of<'py>(
    py: Python<'py>,
    gt: &Bound<'py, PyAny>,
    pred: &Bound<'py, PyAny>,
    input_space: &str,
    joints: &str,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let input = match input_space {
        "expmap" => MpjpeInput::Expmap,
        "positions" | "raw" => MpjpeInput::Positions,
        other => {
            return Err(value(format!(
                "input_space {other:?}: expected \"expmap\" (H3.6M exp-map frames) or \"positions\" (N x T x J x 3)"
            )))
        }
    };
    let joints = JointMean::from_name(joints).ok_or_else(|| {
        value(format!(
            "joints {joints:?}: expected \"all-32\" or \"predicted-22\""
        ))
    })?;
    let (gt, pred) = (f64_array(gt, "gt")?, f64_array(pred, "pred")?);
    let (gt, pred) = (gt.as_array(), pred.as_array());
    let scores = py
        .detach(|| score_mpjpe(pred, gt, input, joints))
        .map_err(|e| metric("MPJPE", e))?;
    Ok(ndarray::Array1::from(scores.per_frame).into_pyarray(py))
}

/// The multi-sample metrics of DLow and BeLFusion (`motion_metrics::multimodal`): `samples`
/// `N x K x T x D`, `gt` `N x T x D`, `last_observed` `N x D`; distances are norms of whole
/// D-dim poses. Returns a dict of the means over windows (`apd`, `ade`, `fde`, `mmade`,
/// `mmfde`), `per_window` (a list of such dicts) and `multimodal_set_sizes`.
#[pyfunction]
#[pyo3(signature = (samples, gt, last_observed, threshold = 0.5))]
fn sample_set_metrics<'py>(
    py: Python<'py>,
    samples: &Bound<'py, PyAny>,
    gt: &Bound<'py, PyAny>,
    last_observed: &Bound<'py, PyAny>,
    threshold: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let samples = f64_array(samples, "samples")?;
    let gt = f64_array(gt, "gt")?;
    let last = f64_array(last_observed, "last_observed")?;
    let sets = SampleSets {
        samples: dims::<Ix4>(samples.as_array(), "samples", "N x K x T x D")?,
        truth: dims::<Ix3>(gt.as_array(), "gt", "N x T x D")?,
        last_observed: dims::<Ix2>(last.as_array(), "last_observed", "N x D")?,
        threshold,
    };
    let report = py
        .detach(|| score_sample_sets(sets))
        .map_err(|e| metric("multi-sample metrics", e))?;
    let mut json = serde_json::to_value(report.mean).map_err(value)?;
    json["per_window"] = serde_json::to_value(&report.windows).map_err(value)?;
    json["multimodal_set_sizes"] =
        serde_json::to_value(&report.multimodal_set_sizes).map_err(value)?;
    py.import("json")?
        .call_method1("loads", (json.to_string(),))
}

/// APD: `S x F` samples of one forecast → its APD; `N x S x ...` → the mean over the `N`
/// forecasts (and with `per_sequence=True`, also each forecast's).
#[pyfunction]
#[pyo3(name = "apd", signature = (samples, per_sequence = false))]
fn apd_of<'py>(
    py: Python<'py>,
    samples: &Bound<'py, PyAny>,
    per_sequence: bool,
) -> PyResult<Py<PyAny>> {
    let array = f64_array(samples, "samples")?;
    let view = array.as_array();
    match view.ndim() {
        2 => {
            let view = dims::<Ix2>(view, "samples", "S x F")?;
            let value = py.detach(|| apd(view)).map_err(|e| metric("APD", e))?;
            Ok(value.into_pyobject(py)?.into_any().unbind())
        }
        n if n >= 3 => {
            let shape = view.shape().to_vec();
            let flat: usize = shape[2..].iter().product();
            let owned;
            let flat_view = match view.to_shape((shape[0], shape[1], flat)) {
                Ok(v) => v,
                Err(_) => {
                    owned = view.to_owned();
                    owned
                        .to_shape((shape[0], shape[1], flat))
                        .expect("contiguous")
                }
            };
            let flat_view = flat_view.view();
            let (per, mean) = py
                .detach(|| apd_batch(flat_view))
                .map_err(|e| metric("APD", e))?;
            if per_sequence {
                Ok((mean, per.into_pyarray(py))
                    .into_pyobject(py)?
                    .into_any()
                    .unbind())
            } else {
                Ok(mean.into_pyobject(py)?.into_any().unbind())
            }
        }
        _ => Err(value(format!(
            "samples: expected S x F or N x S x ..., got shape {:?}",
            view.shape()
        ))),
    }
}

/// An NDMS database (Tanke et al. 2021) of reference motions: every motion word of the given
/// positions, with an exact nearest-neighbour index; `score` scores forecasts against it.
#[pyclass(module = "motion._motion", frozen)]
pub struct NdmsDatabase {
    database: Database,
    method: String,
}

fn nn_method(name: &str) -> PyResult<NnMethod> {
    match name {
        "pose-bound" => Ok(NnMethod::PoseBound),
        "pca-kd-tree" => Ok(NnMethod::PcaKdTree),
        "brute-force" => Ok(NnMethod::BruteForce),
        other => Err(value(format!(
            "method {other:?}: expected \"pose-bound\", \"pca-kd-tree\" or \"brute-force\" (all exact)"
        ))),
    }
}

/// `T x J x 3` arrays from a list of them or one `N x T x J x 3` array (copied: positions are
/// gathered into words anyway).
fn position_sequences(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Array3<f64>>> {
    if let Ok(list) = obj.cast::<PyList>() {
        return list
            .iter()
            .enumerate()
            .map(|(i, item)| {
                let name = format!("{what}[{i}]");
                let a = f64_array(&item, &name)?;
                Ok(dims::<Ix3>(a.as_array(), &name, "T x J x 3")?.to_owned())
            })
            .collect();
    }
    let a = f64_array(obj, what)?;
    let view = a.as_array();
    match view.ndim() {
        3 => Ok(vec![dims::<Ix3>(view, what, "T x J x 3")?.to_owned()]),
        _ => Ok(
            dims::<Ix4>(view, what, "N x T x J x 3 or a list of T x J x 3")?
                .outer_iter()
                .map(|s| s.to_owned())
                .collect(),
        ),
    }
}

/// Tanke et al. 2021's H3.6M setting with κ = `word_len`.
fn ndms_config(word_len: usize) -> PyResult<NdmsConfig> {
    if word_len < 2 {
        return Err(value(format!("word_len {word_len}: at least 2 frames")));
    }
    Ok(NdmsConfig {
        kappa: word_len,
        ..NdmsConfig::h36m()
    })
}

#[pymethods]
impl NdmsDatabase {
    /// `positions`: reference motions, a list of `T x J x 3` arrays (or one `N x T x J x 3`)
    /// of world positions on the 32-joint H3.6M skeleton (y up); `word_len`: κ frames per word.
    #[new]
    #[pyo3(signature = (positions, word_len = 8, method = "pose-bound"))]
    fn new(
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        word_len: usize,
        method: &str,
    ) -> PyResult<Self> {
        let sequences = position_sequences(positions, "positions")?;
        let method_name = method;
        let method = nn_method(method)?;
        let config = ndms_config(word_len)?;
        let database = py
            .detach(|| {
                let views: Vec<_> = sequences.iter().map(|s| s.view()).collect();
                Database::from_sequences(config, &views, method)
            })
            .map_err(|e| metric("NDMS database", e))?;
        Ok(NdmsDatabase {
            database,
            method: method_name.to_owned(),
        })
    }

    /// A database from another's [`words`](Self::words) (the index is rebuilt, the words are
    /// not recomputed): how a database travels between processes (pickle, Ray's object store).
    #[staticmethod]
    #[pyo3(signature = (words, word_len = 8, method = "pose-bound"))]
    fn from_words(
        py: Python<'_>,
        words: &Bound<'_, PyAny>,
        word_len: usize,
        method: &str,
    ) -> PyResult<Self> {
        let array = f64_array(words, "words")?;
        let words = dims::<Ix2>(array.as_array(), "words", "W x word_dims")?;
        let flat: Vec<f64> = words.iter().copied().collect();
        let config = ndms_config(word_len)?;
        if words.ncols() != config.word_len() {
            return Err(value(format!(
                "words: {} numbers per word, a κ = {word_len} word on this skeleton has {}",
                words.ncols(),
                config.word_len()
            )));
        }
        let nn = nn_method(method)?;
        let database = py
            .detach(|| Database::from_words(config, flat, nn))
            .map_err(|e| metric("NDMS database", e))?;
        Ok(NdmsDatabase {
            database,
            method: method.to_owned(),
        })
    }

    /// Every normalized motion word, `W x word_dims`.
    fn words<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let len = self.database.config().word_len();
        let words = self.database.words();
        Array2::from_shape_vec((words.len() / len, len), words.to_vec())
            .expect("whole words")
            .into_pyarray(py)
    }

    /// Pickling: the words, κ and the index method (see [`from_words`](Self::from_words)).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let this = slf.get();
        let rebuild = py.get_type::<NdmsDatabase>().getattr("from_words")?;
        let args = (
            this.words(py),
            this.database.config().kappa,
            this.method.clone(),
        );
        (rebuild, args).into_pyobject(py).map(|t| t.into_any())
    }

    /// Number of motion words.
    fn __len__(&self) -> usize {
        self.database.len()
    }

    /// κ, frames per word.
    #[getter]
    fn word_len(&self) -> usize {
        self.database.config().kappa
    }

    /// Scores `forecasts` (a list of `F x J x 3` or one `N x F x J x 3`): with `seeds` (one
    /// `>= κ-1 x J x 3` per forecast, continuous with it) the first word straddles the seam.
    /// Returns `{"mean", "per_word" (array), "bins" (0.4 s at 25 Hz), "first_word_end"}`.
    #[pyo3(signature = (forecasts, seeds = None))]
    fn score<'py>(
        &self,
        py: Python<'py>,
        forecasts: &Bound<'py, PyAny>,
        seeds: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let forecasts = position_sequences(forecasts, "forecasts")?;
        let seeds = seeds.map(|s| position_sequences(s, "seeds")).transpose()?;
        let report = py
            .detach(|| {
                let f: Vec<_> = forecasts.iter().map(|s| s.view()).collect();
                let s: Option<Vec<_>> =
                    seeds.as_ref().map(|s| s.iter().map(|x| x.view()).collect());
                self.database.score_forecasts(&f, s.as_deref())
            })
            .map_err(|e| metric("NDMS", e))?;
        let out = PyDict::new(py);
        out.set_item("mean", report.mean)?;
        out.set_item("per_word", report.per_word.into_pyarray(py))?;
        out.set_item("bins", report.bins)?;
        out.set_item("first_word_end", report.first_word_end)?;
        Ok(out)
    }
}
