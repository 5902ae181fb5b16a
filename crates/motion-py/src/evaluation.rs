//! `motion.evaluate`: the H3.6M protocol of `motion_metrics::evaluation`, returning the report
//! `motion-cli eval --json` prints, as a dict.
use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;

use motion_core::model::builtin::default_action_classifier;
use motion_core::model::ActionClassifier;
use motion_core::protocol::sampler::LTD_SAMPLER_INPUT;
use motion_core::protocol::WindowSet;
use motion_metrics::evaluation::mpjpe::{evaluate_mpjpe as run_mpjpe, MpjpeOptions, MpjpeWindows};
use motion_metrics::evaluation::stochastic::{
    evaluate_stochastic as run_stochastic, StochasticOptions,
};
use motion_metrics::evaluation::{
    check_request, evaluate as run, resolve_dataset, EvalError, EvalOptions,
};
use motion_metrics::JointMean;

use crate::errors::{format, value, weights};
use crate::model::{BuiltIn, Model};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(posture, m)?)?;
    Ok(())
}

fn eval_error(e: EvalError) -> PyErr {
    match e {
        EvalError::Format(f) => format(f),
        other => value(other),
    }
}

/// Runs `model` (default: the built-in one) on the H3.6M protocol's test windows of `actions`
/// (`"all"` or a list) in `data` (default: `$MOTION_DATA_DIR`, then `../shared/data`) and
/// returns the report of `motion-cli eval --json` as a dict: per action the model, the
/// zero-velocity baseline and the real continuation, every metric, beside the published numbers.
/// `classifier=True` runs the action-classifier protocol with the built-in classifier (a path
/// gives another), `False` skips it. `windows="validation"` runs the S5 windows disjoint from the
/// test windows (choose checkpoints and settings on those; report test windows); `any_action=True`
/// evaluates a single-action model on other actions too.
///
/// `protocol="mpjpe"` runs the 3-D joint-position protocol of LTD, HRI and siMLPe instead
/// (`motion-cli eval --protocol mpjpe --json`): `windows` 256 (default), 8 or `"all"` (with
/// `stride`, default 5), `input_frames` observed frames (50), `ltd_sampler=True` for LTD's window
/// placement, `joints` `"all-32"` (the reference's) or `"predicted-22"`. `protocol="stochastic"`
/// runs the multi-sample metrics in the project's variant of DLow's protocol
/// (`motion-cli eval --protocol stochastic --json`; `samples` default 50).
#[pyfunction]
#[pyo3(signature = (model = None, data = None, actions = None, horizon = 100, samples = None, rng_seed = 0, classifier = None, windows = None, any_action = false, protocol = "h36m", stride = None, input_frames = None, ltd_sampler = false, joints = "all-32"))]
#[allow(clippy::too_many_arguments)]
fn evaluate<'py>(
    py: Python<'py>,
    model: Option<&Model>,
    data: Option<PathBuf>,
    actions: Option<&Bound<'py, PyAny>>,
    horizon: usize,
    samples: Option<usize>,
    rng_seed: u64,
    classifier: Option<&Bound<'py, PyAny>>,
    windows: Option<&Bound<'py, PyAny>>,
    any_action: bool,
    protocol: &str,
    stride: Option<usize>,
    input_frames: Option<usize>,
    ltd_sampler: bool,
    joints: &str,
) -> PyResult<Bound<'py, PyAny>> {
    // `windows` may be a name or a number (8, 256).
    let windows: Option<String> = match windows {
        None => None,
        Some(w) => Some(match w.extract::<usize>() {
            Ok(n) => n.to_string(),
            Err(_) => w.extract::<String>()?,
        }),
    };
    let actions: Vec<String> = match actions {
        None => vec!["all".into()],
        Some(a) => match a.extract::<String>() {
            Ok(one) => vec![one],
            Err(_) => a.extract::<Vec<String>>()?,
        },
    };
    match protocol {
        "h36m" => {}
        "stochastic" => {
            if horizon != 100 || windows.is_some() || stride.is_some() || input_frames.is_some() || ltd_sampler || joints != "all-32" {
                return Err(value(
                    "protocol=\"stochastic\" has its own windows (S9 and S11, every 25 frames at 50 Hz, 2 s futures): give only model, data, actions, samples, rng_seed, any_action",
                ));
            }
            let (model, name) = resolve_model(model)?;
            let dataset = resolve_dataset(data.as_deref()).map_err(eval_error)?;
            let mut options = StochasticOptions::new(dataset, name);
            options.actions = actions;
            options.samples = samples.unwrap_or(options.samples);
            options.rng_seed = rng_seed;
            options.any_action = any_action;
            let report = py
                .detach(|| run_stochastic(&model, &options, &mut |_| {}))
                .map_err(eval_error)?;
            let json = serde_json::to_string(&report).map_err(value)?;
            return py.import("json")?.call_method1("loads", (json,));
        }
        "mpjpe" => {
            if samples.is_some_and(|k| k != 1) || horizon != 100 {
                return Err(value(
                    "protocol=\"mpjpe\" predicts 25 frames per window, one sample: leave horizon and samples at their defaults",
                ));
            }
            return evaluate_mpjpe(
                py,
                model,
                data,
                actions,
                MpjpeWindows::parse(windows.as_deref(), stride).map_err(eval_error)?,
                input_frames,
                ltd_sampler,
                joints,
                rng_seed,
                any_action,
            );
        }
        other => {
            return Err(value(format!(
                "protocol {other:?}: expected \"h36m\" (angles, NDMS, plausibility, posture, classifier), \"mpjpe\" (3-D joint-position error of LTD, HRI, siMLPe) or \"stochastic\" (APD, ADE, FDE, MMADE, MMFDE: a project variant)"
            )))
        }
    }
    if stride.is_some() || input_frames.is_some() || ltd_sampler || joints != "all-32" {
        return Err(value(
            "stride, input_frames, ltd_sampler and joints belong to protocol=\"mpjpe\"",
        ));
    }
    let samples = samples.unwrap_or(1);
    let windows = windows.as_deref().unwrap_or("test");
    let windows = WindowSet::from_name(windows).ok_or_else(|| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "windows={windows:?}: expected \"test\" (the protocol's test windows) or \"validation\" (S5 windows disjoint from them)"
        ))
    })?;
    let (model, name) = resolve_model(model)?;
    let classifier: Option<Arc<ActionClassifier>> = match classifier {
        None => builtin_classifier()?,
        Some(c) => match c.extract::<bool>() {
            Ok(true) => builtin_classifier()?,
            Ok(false) => None,
            Err(_) => {
                let path: PathBuf = c.extract()?;
                Some(Arc::new(
                    py.detach(|| ActionClassifier::load(&path))
                        .map_err(weights)?,
                ))
            }
        },
    };
    check_request(horizon, samples, None).map_err(eval_error)?;
    let dataset = resolve_dataset(data.as_deref()).map_err(eval_error)?;
    let mut options = EvalOptions::new(dataset, name);
    options.actions = actions;
    options.horizon = horizon;
    options.samples = samples;
    options.rng_seed = rng_seed;
    options.classifier = classifier;
    options.windows = windows;
    options.any_action = any_action;
    let report = py
        .detach(|| run(&model, &options, &mut |_| {}))
        .map_err(eval_error)?;
    let json = serde_json::to_string(&report).map_err(value)?;
    py.import("json")?.call_method1("loads", (json,))
}

/// The MPJPE protocol's report as a dict (`motion-cli eval --protocol mpjpe --json`).
#[allow(clippy::too_many_arguments)]
fn evaluate_mpjpe<'py>(
    py: Python<'py>,
    model: Option<&Model>,
    data: Option<PathBuf>,
    actions: Vec<String>,
    windows: MpjpeWindows,
    input_frames: Option<usize>,
    ltd_sampler: bool,
    joints: &str,
    rng_seed: u64,
    any_action: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let joints = JointMean::from_name(joints).ok_or_else(|| {
        value(format!(
            "joints {joints:?}: expected \"all-32\" (the reference's mean over 32 joints) or \"predicted-22\""
        ))
    })?;
    let (model, name) = resolve_model(model)?;
    let dataset = resolve_dataset(data.as_deref()).map_err(eval_error)?;
    let mut options = MpjpeOptions::new(dataset, name);
    options.actions = actions;
    options.windows = windows;
    options.input_frames = input_frames.unwrap_or(options.input_frames);
    options.sampler_input = ltd_sampler.then_some(LTD_SAMPLER_INPUT);
    options.joints = joints;
    options.rng_seed = rng_seed;
    options.any_action = any_action;
    let report = py
        .detach(|| run_mpjpe(&model, &options, &mut |_| {}))
        .map_err(eval_error)?;
    let json = serde_json::to_string(&report).map_err(value)?;
    py.import("json")?.call_method1("loads", (json,))
}

/// The model to evaluate and its name in the report (default: the built-in forecasting model).
fn resolve_model(
    model: Option<&Model>,
) -> PyResult<(Arc<motion_core::model::MotionModel>, String)> {
    Ok(match model {
        Some(m) => (Arc::clone(&m.model), m.model.path().display().to_string()),
        None => (
            Model::builtin(BuiltIn::Forecast)?.model,
            format!("built-in {}", BuiltIn::Forecast.file_name()),
        ),
    })
}

fn builtin_classifier() -> PyResult<Option<Arc<ActionClassifier>>> {
    match default_action_classifier() {
        Some(Ok(c)) => Ok(Some(Arc::new(c))),
        Some(Err(e)) => Err(weights(e)),
        None => Ok(None),
    }
}

/// Posture realism (`motion_metrics::posture`) of H3.6M predictions of `action`: `predictions`
/// (`T x 99`, `N x T x 99` or `N x S x T x 99` exp-map frames at 25 Hz), each after its seed in
/// `seeds` (`N x T_s x 99`, one per sequence; `None`: windows from the first frame), measured per
/// window after the seed (0-2 s ... 50-60 s) against the action's takes of S1, S6-S9 and S11 in
/// `data`, beside the real-vs-real value of S5's takes. Returns the dict `motion-cli score
/// --metric posture --json` prints under `posture`.
#[pyfunction]
#[pyo3(signature = (predictions, action, seeds = None, data = None))]
fn posture<'py>(
    py: Python<'py>,
    predictions: &Bound<'py, PyAny>,
    action: &str,
    seeds: Option<&Bound<'py, PyAny>>,
    data: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let bad = |m: String| pyo3::exceptions::PyValueError::new_err(m);
    let pred = crate::arrays::f64_array(predictions, "predictions")?;
    let pred = pred.as_array();
    let pred = match pred.ndim() {
        2 => pred
            .insert_axis(ndarray::Axis(0))
            .insert_axis(ndarray::Axis(0)),
        3 => pred.insert_axis(ndarray::Axis(1)),
        4 => pred,
        _ => {
            return Err(bad(format!(
                "predictions: shape {:?}, expected T x 99, N x T x 99 or N x S x T x 99",
                pred.shape()
            )))
        }
    }
    .into_dimensionality::<ndarray::Ix4>()
    .map_err(|e| bad(e.to_string()))?;
    let (n, s, _, d) = pred.dim();
    if d != motion_core::skeleton::H36M_FRAME_DIMS {
        return Err(bad(format!(
            "predictions: {d} values per frame, posture reads 99-dim H3.6M exp-map frames"
        )));
    }
    let seed_array = seeds
        .map(|s| crate::arrays::f64_array(s, "seeds"))
        .transpose()?;
    let seed_view = match &seed_array {
        Some(a) => {
            let v = a.as_array();
            let v = if v.ndim() == 2 {
                v.insert_axis(ndarray::Axis(0))
            } else {
                v
            };
            let v = v
                .into_dimensionality::<ndarray::Ix3>()
                .map_err(|e| bad(format!("seeds: {e}")))?;
            if v.dim().0 != n || v.dim().2 != d {
                return Err(bad(format!(
                    "seeds: shape {:?}, expected {n} x T_s x {d}",
                    v.shape()
                )));
            }
            Some(v)
        }
        None => None,
    };
    let clips: Vec<(ndarray::Array2<f64>, usize)> = (0..n)
        .flat_map(|i| (0..s).map(move |k| (i, k)))
        .map(|(i, k)| {
            let motion = pred.slice(ndarray::s![i, k, .., ..]);
            match &seed_view {
                Some(seed) => {
                    let seed = seed.slice(ndarray::s![i, .., ..]);
                    (
                        ndarray::concatenate(ndarray::Axis(0), &[seed, motion])
                            .expect("same width"),
                        seed.nrows(),
                    )
                }
                None => (motion.to_owned(), 0),
            }
        })
        .collect();
    let dataset = resolve_dataset(data.as_deref()).map_err(eval_error)?;
    let report = py
        .detach(|| {
            let views: Vec<_> = clips.iter().map(|(c, n)| (None, c.view(), *n)).collect();
            motion_metrics::evaluation::posture::score_posture(&dataset, action, &views)
        })
        .map_err(value)?;
    let json = serde_json::to_string(&report).map_err(value)?;
    py.import("json")?.call_method1("loads", (json,))
}
