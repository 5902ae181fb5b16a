//! Where the CLI gets its model: a weights file given with `--model PATH`, or the default weights
//! built into the binary (`weights/vgru_d_multi.safetensors`, embedded by `build.rs` when the
//! file existed at build time); and where it gets the action classifier of paper 002 (`--classifier
//! PATH`, or the built-in `weights/action_classifier.safetensors`).
use std::path::Path;
use std::sync::Arc;

use motion_core::model::{ActionClassifier, MotionModel, WeightStore};

use crate::commands::UsageError;

/// The file name of the default weights (as shipped in `weights/`).
pub const DEFAULT_WEIGHTS_NAME: &str = "vgru_d_multi.safetensors";

/// The embedded default weights, if the binary was built with them.
#[cfg(default_weights)]
const DEFAULT_WEIGHTS: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_WEIGHTS")));
#[cfg(not(default_weights))]
const DEFAULT_WEIGHTS: Option<&[u8]> = None;

/// The file name of the default action classifier (as shipped in `weights/`).
pub const DEFAULT_CLASSIFIER_NAME: &str = "action_classifier.safetensors";

#[cfg(default_classifier)]
const DEFAULT_CLASSIFIER: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_CLASSIFIER")));
#[cfg(not(default_classifier))]
const DEFAULT_CLASSIFIER: Option<&[u8]> = None;

/// Loads the action classifier of `--classifier PATH`, or the built-in one when `path` is `None`
/// (usage errors, exit 2, as [`load_model`]).
pub fn load_classifier(path: Option<&Path>) -> anyhow::Result<Arc<ActionClassifier>> {
    let classifier = match path {
        Some(path) => ActionClassifier::load(path),
        None => {
            let bytes = DEFAULT_CLASSIFIER.ok_or_else(|| {
                UsageError(
                    "no action classifier was built into this binary; pass --classifier FILE"
                        .into(),
                )
            })?;
            WeightStore::from_bytes(bytes, format!("<built-in {DEFAULT_CLASSIFIER_NAME}>"))
                .and_then(|store| ActionClassifier::from_store(&store))
        }
    };
    classifier
        .map(Arc::new)
        .map_err(|e| UsageError(format!("cannot load the action classifier: {e}")).into())
}

/// Whether this binary carries a built-in action classifier.
pub fn has_default_classifier() -> bool {
    DEFAULT_CLASSIFIER.is_some()
}

/// Loads the model of `--model PATH`, or the built-in default weights when `path` is `None`.
///
/// Errors (all [`UsageError`], exit code 2): the file is missing, unreadable or not a valid
/// motion-weights file (the message names the file and the problem), or `path` is `None` and no
/// default weights were built into this binary.
pub fn load_model(path: Option<&Path>) -> anyhow::Result<Arc<MotionModel>> {
    let model = match path {
        Some(path) => MotionModel::load(path),
        None => {
            let bytes = DEFAULT_WEIGHTS.ok_or_else(|| {
                UsageError(
                    "no default weights were built into this binary; pass --model FILE".into(),
                )
            })?;
            WeightStore::from_bytes(bytes, format!("<built-in {DEFAULT_WEIGHTS_NAME}>"))
                .and_then(|store| MotionModel::from_store(&store))
        }
    };
    model
        .map(Arc::new)
        .map_err(|e| UsageError(format!("cannot load the model: {e}")).into())
}

/// How to name the model's source in reports: the path given, or the built-in default.
pub fn describe(path: Option<&Path>) -> String {
    match path {
        Some(path) => path.display().to_string(),
        None => format!("built-in {DEFAULT_WEIGHTS_NAME}"),
    }
}
