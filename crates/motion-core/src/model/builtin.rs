//! The weights built into this library (feature `builtin-weights`, embedded by `build.rs` when
//! `weights/` held them at build time): the shipped default model and the action classifier, the
//! same bytes for every front end (CLI, C ABI, web page).
use super::classifier::ActionClassifier;
use super::predictor::MotionModel;
use super::weights::{WeightStore, WeightsError};

/// The file name of the default weights, as shipped in `weights/`.
pub const DEFAULT_WEIGHTS_NAME: &str = "vgru_d_multi.safetensors";
/// The file name of the default action classifier, as shipped in `weights/`.
pub const DEFAULT_CLASSIFIER_NAME: &str = "action_classifier.safetensors";

#[cfg(default_weights)]
const DEFAULT_WEIGHTS: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_WEIGHTS")));
#[cfg(not(default_weights))]
const DEFAULT_WEIGHTS: Option<&[u8]> = None;

#[cfg(default_classifier)]
const DEFAULT_CLASSIFIER: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_CLASSIFIER")));
#[cfg(not(default_classifier))]
const DEFAULT_CLASSIFIER: Option<&[u8]> = None;

/// The embedded default weights' bytes, if this build has them.
pub fn default_weights() -> Option<&'static [u8]> {
    DEFAULT_WEIGHTS
}

/// The embedded action classifier's bytes, if this build has them.
pub fn default_classifier() -> Option<&'static [u8]> {
    DEFAULT_CLASSIFIER
}

/// The default model, validated like a file; `None` when this build has no embedded weights.
pub fn default_model() -> Option<Result<MotionModel, WeightsError>> {
    DEFAULT_WEIGHTS.map(|bytes| {
        WeightStore::from_bytes(bytes, format!("<built-in {DEFAULT_WEIGHTS_NAME}>"))
            .and_then(|store| MotionModel::from_store(&store))
    })
}

/// The default action classifier; `None` when this build has none embedded.
pub fn default_action_classifier() -> Option<Result<ActionClassifier, WeightsError>> {
    DEFAULT_CLASSIFIER.map(|bytes| {
        WeightStore::from_bytes(bytes, format!("<built-in {DEFAULT_CLASSIFIER_NAME}>"))
            .and_then(|store| ActionClassifier::from_store(&store))
    })
}
