//! Where the CLI gets its model: a weights file given with `--model PATH`, or one of the two
//! models built into the binary (`motion_core::model::builtin`: the game default for `predict`, the
//! forecasting default for `eval`); and where it gets the action classifier of Ghosh et al. 2017 (`--classifier
//! PATH`, or the built-in `weights/action_classifier.safetensors`).
use std::path::Path;
use std::sync::Arc;

use motion_core::model::{builtin, ActionClassifier, MotionModel};

use crate::usage::UsageError;

pub use motion_core::model::builtin::BuiltIn;

/// Loads the action classifier of `--classifier PATH`, or the built-in one when `path` is `None`
/// (usage errors, exit 2, as [`load_model`]).
pub fn load_classifier(path: Option<&Path>) -> anyhow::Result<Arc<ActionClassifier>> {
    let classifier = match path {
        Some(path) => ActionClassifier::load(path),
        None => builtin::default_action_classifier().ok_or_else(|| {
            UsageError(
                "no action classifier was built into this binary; pass --classifier FILE".into(),
            )
        })?,
    };
    classifier
        .map(Arc::new)
        .map_err(|e| anyhow::Error::new(e).context("cannot load the action classifier"))
}

/// Whether this binary carries a built-in action classifier.
pub fn has_default_classifier() -> bool {
    builtin::default_classifier().is_some()
}

/// Loads the model of `--model PATH`, or the built-in model `default` when `path` is `None`.
///
/// Errors (exit code 2: a [`UsageError`] or the loader's typed `WeightsError` as the source): the file is missing, unreadable or not a valid
/// motion-weights file (the message names the file and the problem), or `path` is `None` and no
/// default weights were built into this binary.
pub fn load_model(path: Option<&Path>, default: BuiltIn) -> anyhow::Result<Arc<MotionModel>> {
    let model = match path {
        Some(path) => MotionModel::load(path),
        None => default.model().ok_or_else(|| {
            UsageError(format!(
                "no built-in {} in this binary; pass --model FILE",
                default.file_name()
            ))
        })?,
    };
    model
        .map(Arc::new)
        .map_err(|e| anyhow::Error::new(e).context("cannot load the model"))
}

/// How to name the model's source in reports: the path given, or the built-in model `default`.
pub fn describe(path: Option<&Path>, default: BuiltIn) -> String {
    match path {
        Some(path) => path.display().to_string(),
        None => format!("built-in {}", default.file_name()),
    }
}
