//! `motion.evaluate`: the H3.6M protocol of `motion_metrics::evaluation`, returning the report
//! `motion-cli eval --json` prints, as a dict.
use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;

use motion_core::model::builtin::default_action_classifier;
use motion_core::model::ActionClassifier;
use motion_core::protocol::WindowSet;
use motion_metrics::evaluation::{
    check_request, evaluate as run, resolve_dataset, EvalError, EvalOptions,
};

use crate::errors::{format, value, weights};
use crate::model::{BuiltIn, Model};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
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
#[pyfunction]
#[pyo3(signature = (model = None, data = None, actions = None, horizon = 100, samples = 1, rng_seed = 0, classifier = None, windows = "test", any_action = false))]
#[allow(clippy::too_many_arguments)]
fn evaluate<'py>(
    py: Python<'py>,
    model: Option<&Model>,
    data: Option<PathBuf>,
    actions: Option<&Bound<'py, PyAny>>,
    horizon: usize,
    samples: usize,
    rng_seed: u64,
    classifier: Option<&Bound<'py, PyAny>>,
    windows: &str,
    any_action: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let windows = WindowSet::from_name(windows).ok_or_else(|| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "windows={windows:?}: expected \"test\" (the protocol's test windows) or \"validation\" (S5 windows disjoint from them)"
        ))
    })?;
    let (model, name) = match model {
        Some(m) => (Arc::clone(&m.model), m.model.path().display().to_string()),
        None => (
            Model::builtin(BuiltIn::Forecast)?.model,
            format!("built-in {}", BuiltIn::Forecast.file_name()),
        ),
    };
    let actions: Vec<String> = match actions {
        None => vec!["all".into()],
        Some(a) => match a.extract::<String>() {
            Ok(one) => vec![one],
            Err(_) => a.extract::<Vec<String>>()?,
        },
    };
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

fn builtin_classifier() -> PyResult<Option<Arc<ActionClassifier>>> {
    match default_action_classifier() {
        Some(Ok(c)) => Ok(Some(Arc::new(c))),
        Some(Err(e)) => Err(weights(e)),
        None => Ok(None),
    }
}
