//! The weights built into this library (feature `builtin-weights`, embedded by `build.rs` when
//! `weights/` held them at build time), the same bytes for every front end:
//! - the game default ([`game_model`]): what `Character`, `motion-cli predict`, the C ABI, Bevy,
//!   the web page and Python load when given no file; chosen for staying grounded, upright and
//!   moving for 60 s on every action under `set_action` (`training/select_game.py`);
//! - the forecasting default ([`forecast_model`]): what `motion-cli eval` and
//!   `motion.evaluate` score when given no file; chosen for the forecasting metrics (NPSS);
//! - the action classifier of Ghosh et al. 2017 ([`default_action_classifier`]).
use super::classifier::ActionClassifier;
use super::predictor::MotionModel;
use super::weights::{WeightStore, WeightsError};

/// The file name of the game default, as shipped in `weights/`.
pub const GAME_WEIGHTS_NAME: &str = "intention_actions.safetensors";
/// The file name of the forecasting default, as shipped in `weights/`.
pub const FORECAST_WEIGHTS_NAME: &str = "vgru_d_multi.safetensors";
/// The file name of the default action classifier, as shipped in `weights/`.
pub const DEFAULT_CLASSIFIER_NAME: &str = "action_classifier.safetensors";

#[cfg(game_weights)]
const GAME_WEIGHTS: Option<&[u8]> = Some(include_bytes!(env!("MOTION_GAME_WEIGHTS")));
#[cfg(not(game_weights))]
const GAME_WEIGHTS: Option<&[u8]> = None;

#[cfg(default_weights)]
const DEFAULT_WEIGHTS: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_WEIGHTS")));
#[cfg(not(default_weights))]
const DEFAULT_WEIGHTS: Option<&[u8]> = None;

#[cfg(default_classifier)]
const DEFAULT_CLASSIFIER: Option<&[u8]> = Some(include_bytes!(env!("MOTION_DEFAULT_CLASSIFIER")));
#[cfg(not(default_classifier))]
const DEFAULT_CLASSIFIER: Option<&[u8]> = None;

/// The embedded game default's bytes, if this build has them.
pub fn game_weights() -> Option<&'static [u8]> {
    GAME_WEIGHTS
}

/// The embedded forecasting default's bytes, if this build has them.
pub fn forecast_weights() -> Option<&'static [u8]> {
    DEFAULT_WEIGHTS
}

/// The embedded action classifier's bytes, if this build has them.
pub fn default_classifier() -> Option<&'static [u8]> {
    DEFAULT_CLASSIFIER
}

/// The game default, validated like a file; `None` when this build has it not embedded.
pub fn game_model() -> Option<Result<MotionModel, WeightsError>> {
    embedded(GAME_WEIGHTS, GAME_WEIGHTS_NAME)
}

/// The forecasting default, validated like a file; `None` when this build has it not embedded.
pub fn forecast_model() -> Option<Result<MotionModel, WeightsError>> {
    embedded(DEFAULT_WEIGHTS, FORECAST_WEIGHTS_NAME)
}

/// One of the two built-in models.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuiltIn {
    /// The game default ([`game_model`]).
    Game,
    /// The forecasting default ([`forecast_model`]).
    Forecast,
}

impl BuiltIn {
    /// Its file name as shipped in `weights/`.
    pub fn file_name(self) -> &'static str {
        match self {
            BuiltIn::Game => GAME_WEIGHTS_NAME,
            BuiltIn::Forecast => FORECAST_WEIGHTS_NAME,
        }
    }

    /// The model, validated like a file; `None` when this build has it not embedded.
    pub fn model(self) -> Option<Result<MotionModel, WeightsError>> {
        match self {
            BuiltIn::Game => game_model(),
            BuiltIn::Forecast => forecast_model(),
        }
    }
}

fn embedded(bytes: Option<&[u8]>, name: &str) -> Option<Result<MotionModel, WeightsError>> {
    bytes.map(|bytes| {
        WeightStore::from_bytes(bytes, format!("<built-in {name}>"))
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
