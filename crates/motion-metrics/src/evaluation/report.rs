//! The typed evaluation report ([`EvalReport`], serialized as `motion-cli eval --json` prints
//! it): per action the model, the zero-velocity baseline, the real continuation and the published
//! numbers side by side, then the means over actions. Front ends print, plot or return it.
use std::collections::BTreeMap;

use serde::ser::SerializeStruct;
use serde::{Serialize, Serializer};

use super::published;
use crate::{ClassifierCurve, PlausibilityReport, EULER_HORIZONS_MS};

/// Everything `eval` measured, as `--json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct EvalReport {
    /// The evaluated model.
    pub model: ModelInfo,
    /// The dataset directory.
    pub data: String,
    /// The protocol's parameters.
    pub protocol: Protocol,
    /// How each number is computed, in words.
    pub method: Method,
    /// One result per evaluated action.
    pub actions: Vec<ActionResult>,
    /// Actions not evaluated, and why.
    pub skipped: Vec<Skipped>,
    /// The papers' published averages over actions.
    pub published_averages: published::Averages,
    /// Means over the evaluated actions of the headline numbers.
    pub mean_over_actions: MeansOverActions,
    /// Where `--save-predictions` wrote the predictions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub save_predictions: Option<SavedPredictions>,
}

/// The evaluated model.
#[derive(Debug, Clone, Serialize)]
pub struct ModelInfo {
    /// The weights file (or the built-in weights).
    pub source: String,
    /// The architecture's schema name.
    pub architecture: &'static str,
    /// Hidden units.
    pub hidden: usize,
    /// The model's action labels.
    pub actions: Vec<String>,
    /// The actions it was trained on.
    pub actions_trained: Vec<String>,
    /// Stochastic (samples differ) or deterministic.
    pub stochastic: bool,
    /// The plan horizon of VGRU-d (`null` for other architectures).
    pub plan_horizon: Option<usize>,
    /// The dtype the weights are stored in.
    pub stored_dtype: String,
    /// A remark on the run (identical samples of a deterministic model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<&'static str>,
}

/// The protocol's parameters.
#[derive(Debug, Clone, Serialize)]
pub struct Protocol {
    /// The test subject.
    pub subject: &'static str,
    /// Frames per second.
    pub fps: f64,
    /// Seed frames per window.
    pub seed_frames: usize,
    /// Predicted frames per window.
    pub horizon: usize,
    /// Which windows: `test` (the protocol's) or `validation` (disjoint from them, for choosing).
    pub windows: &'static str,
    /// Windows per action.
    pub windows_per_action: usize,
    /// Samples per window.
    pub samples: usize,
    /// Seed of the noise.
    pub rng_seed: u64,
}

/// How each number is computed, in words (one sentence per key).
#[derive(Debug, Clone, Serialize)]
pub struct Method {
    /// Posture realism and its reference.
    pub posture: &'static str,
    /// How samples are combined per metric.
    pub samples: &'static str,
    /// The two NPSS variants.
    pub npss: &'static str,
    /// The NDMS database and queries.
    pub ndms: &'static str,
    /// How positions are computed.
    pub positions: &'static str,
    /// The joint-speed check.
    pub mean_joint_speed_last_1s: &'static str,
    /// The zero-velocity baseline.
    pub zero_velocity: &'static str,
    /// Horizons past the ground truth.
    pub ground_truth_coverage: &'static str,
    /// The plausibility measures.
    pub plausibility: &'static str,
}

/// The results of one action.
#[derive(Debug, Clone, Serialize)]
pub struct ActionResult {
    /// The action.
    pub action: &'static str,
    /// The conditioning label (`null` for unconditioned models).
    pub label: Option<String>,
    /// Windows evaluated.
    pub windows: usize,
    /// Where each window's seed starts: `[subaction, first seed frame at 25 Hz]` of the S5 take.
    pub window_starts: Vec<(u8, usize)>,
    /// Samples per window.
    pub samples: usize,
    /// Predicted frames per window.
    pub horizon: usize,
    /// How much of the horizon the ground truth covers.
    pub ground_truth_coverage: CoverageReport,
    /// Motion words in the NDMS database.
    pub ndms_database_words: usize,
    /// The model's scores.
    pub model: ActionScores,
    /// The zero-velocity baseline's scores.
    pub zero_velocity: ActionScores,
    /// The plausibility of the model's predictions grounded (`motion_core::grounding`: what
    /// `predict` and the engines show by default) beside the raw ones of `model`.
    pub model_grounded: PlausibilityKeys,
    /// The real continuation.
    pub ground_truth: GroundTruth,
    /// Every published number for the action.
    pub published: published::ForAction,
    /// Posture realism per window (model grounded and raw, zero-velocity, real continuation)
    /// and the real-vs-real value.
    pub posture: Option<super::posture::ActionPosture>,
}

/// How much of the horizon the test windows' ground truth covers.
#[derive(Debug, Clone, Serialize)]
pub struct CoverageReport {
    /// Frames of ground truth per test window.
    pub frames_per_window: Vec<usize>,
    /// Per second of the horizon: windows covering all of it.
    pub windows_per_second: Vec<usize>,
    /// Frames every window covers (NPSS `whole` is over these).
    pub npss_whole_frames: usize,
    /// Per NPSS window label: the test windows covering it.
    pub npss_windows: BTreeMap<String, usize>,
}

/// The scores of the model or of the zero-velocity baseline on one action.
#[derive(Debug, Clone, Serialize)]
pub struct ActionScores {
    /// Euler error at the papers' horizons, keyed by milliseconds.
    pub euler_error_ms: BTreeMap<String, Option<f64>>,
    /// Euler error per predicted frame.
    pub euler_error_per_frame: Vec<f64>,
    /// NPSS, the paper's |DFT|² variant.
    pub npss: NpssReport,
    /// NPSS, the published code's Re(DFT)² variant.
    pub npss_reference: NpssReport,
    /// NDMS.
    pub ndms: NdmsScores,
    /// Mean joint speed over the last second.
    pub mean_joint_speed_last_1s: SpeedReport,
    /// APD (with 2+ samples).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub apd: Option<f64>,
    /// `speed_ratio`, `drift` and `foot_contact`.
    #[serde(flatten)]
    pub plausibility: PlausibilityKeys,
    /// The action-classifier curve (absent with `--no-classifier`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classifier: Option<ClassifierCurve>,
}

/// The real continuation of one action's test windows.
#[derive(Debug, Clone, Serialize)]
pub struct GroundTruth {
    /// Mean joint speed over the last second (`null` when the files end before it).
    pub mean_joint_speed_last_1s: Option<SpeedReport>,
    /// `speed_ratio`, `drift` and `foot_contact`.
    #[serde(flatten)]
    pub plausibility: PlausibilityKeys,
    /// The action-classifier curve (absent with `--no-classifier`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classifier: Option<ClassifierCurve>,
    /// NDMS of the other subjects' real motion of the action, scored as a forecast against the
    /// same database (`method.ndms`): what motion that is real, but not the test subject's
    /// continuation, scores here (`null` without a take long enough).
    pub real_motion_ndms: Option<NdmsScores>,
}

/// NPSS over the whole horizon and per window label.
#[derive(Debug, Clone, Serialize)]
pub struct NpssReport {
    /// Over the frames every window covers.
    pub whole: f64,
    /// Per window label (`"0-1 s"`, ...).
    pub windows: BTreeMap<String, f64>,
}

/// NDMS of a set of forecasts.
#[derive(Debug, Clone, Serialize)]
pub struct NdmsScores {
    /// f_sim: the mean over all words.
    pub mean: f64,
    /// Means per 0.4 s bin.
    pub bins: Vec<f64>,
    /// The forecast frame at which the first word ends.
    pub first_word_end: usize,
    /// The nearest neighbours were exact.
    pub exact: bool,
}

/// Mean joint speed in mm per 25 Hz frame.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SpeedReport {
    /// With the root trajectory.
    pub world: f64,
    /// Body motion only (root deltas zeroed).
    pub pose: f64,
}

/// A [`PlausibilityReport`] written as the `speed_ratio`, `drift`, `foot_contact` and `ground` keys of the
/// report holding it (the shapes `score` prints); the table reads the whole report.
#[derive(Debug, Clone)]
pub struct PlausibilityKeys(pub PlausibilityReport);

impl Serialize for PlausibilityKeys {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut keys = serializer.serialize_struct("PlausibilityKeys", 4)?;
        keys.serialize_field("speed_ratio", &self.0.speed_ratio)?;
        keys.serialize_field("drift", &self.0.drift)?;
        keys.serialize_field("foot_contact", &self.0.foot_contact)?;
        keys.serialize_field("ground", &self.0.ground)?;
        keys.end()
    }
}

/// An action that was not evaluated.
#[derive(Debug, Clone, Serialize)]
pub struct Skipped {
    /// The action.
    pub action: &'static str,
    /// Why.
    pub reason: String,
}

/// Means over the evaluated actions.
#[derive(Debug, Clone, Serialize)]
pub struct MeansOverActions {
    /// Evaluated actions.
    pub actions: usize,
    /// The model's means.
    pub model: Means,
    /// The zero-velocity baseline's means.
    pub zero_velocity: Means,
    /// The other subjects' real motion (`ground_truth.real_motion_ndms` of each action).
    pub real_motion: RealMotionMeans,
}

/// Means over actions of the real-motion NDMS (`null` unless every action has it).
#[derive(Debug, Clone, Serialize)]
pub struct RealMotionMeans {
    /// NDMS f_sim.
    pub ndms: Option<f64>,
    /// NDMS per 0.4 s bin.
    pub ndms_bins: Vec<Option<f64>>,
}

impl RealMotionMeans {
    /// The means of one real-motion NDMS per action.
    pub fn of(scores: &[Option<&NdmsScores>]) -> Self {
        // Every action must have the row; one missing leaves the means `None` (and no bins).
        let all: Vec<&NdmsScores> = scores
            .iter()
            .copied()
            .collect::<Option<_>>()
            .unwrap_or_default();
        let mean = |pick: &dyn Fn(&NdmsScores) -> Option<f64>| mean_of_all(&all, pick);
        let bins = all.first().map_or(0, |s| s.bins.len());
        Self {
            ndms: mean(&|s| Some(s.mean)),
            ndms_bins: (0..bins)
                .map(|i| mean(&|s| s.bins.get(i).copied()))
                .collect(),
        }
    }
}

/// Means over actions of the headline numbers (`null` unless every action has the number).
#[derive(Debug, Clone, Serialize)]
pub struct Means {
    /// NPSS reference variant, whole horizon.
    pub npss_reference: Option<f64>,
    /// NPSS paper variant, whole horizon.
    pub npss: Option<f64>,
    /// Euler error per horizon (ms).
    pub euler_error_ms: BTreeMap<String, Option<f64>>,
    /// NDMS f_sim.
    pub ndms: Option<f64>,
    /// NDMS per 0.4 s bin.
    pub ndms_bins: Vec<Option<f64>>,
    /// APD.
    pub apd: Option<f64>,
}

/// The mean of `pick` over `items`, `None` unless every item has a finite value (and there is one).
fn mean_of_all<T>(items: &[&T], pick: &dyn Fn(&T) -> Option<f64>) -> Option<f64> {
    let values: Vec<f64> = items
        .iter()
        .filter_map(|s| pick(s).filter(|v| v.is_finite()))
        .collect();
    (values.len() == items.len() && !values.is_empty())
        .then(|| values.iter().sum::<f64>() / values.len() as f64)
}

impl Means {
    /// The means of `scores` (one per action); a number missing or not finite in any action
    /// leaves its mean `None`.
    pub fn of(scores: &[&ActionScores]) -> Self {
        let mean = |pick: &dyn Fn(&ActionScores) -> Option<f64>| mean_of_all(scores, pick);
        let bins = scores.first().map_or(0, |s| s.ndms.bins.len());
        Means {
            npss_reference: mean(&|s| Some(s.npss_reference.whole)),
            npss: mean(&|s| Some(s.npss.whole)),
            euler_error_ms: EULER_HORIZONS_MS
                .iter()
                .map(|ms| {
                    let key = ms.to_string();
                    let value = mean(&|s| s.euler_error_ms.get(&key).copied().flatten());
                    (key, value)
                })
                .collect(),
            ndms: mean(&|s| Some(s.ndms.mean)),
            ndms_bins: (0..bins)
                .map(|i| mean(&|s| s.ndms.bins.get(i).copied()))
                .collect(),
            apd: mean(&|s| s.apd),
        }
    }
}

/// Where `--save-predictions` wrote the predictions.
#[derive(Debug, Clone, Serialize)]
pub struct SavedPredictions {
    /// The `.npy` file.
    pub path: String,
    /// Its shape.
    pub shape: [usize; 5],
    /// The names of its axes.
    pub axes: [&'static str; 5],
    /// The actions along the first axis, in order.
    pub actions: Vec<&'static str>,
}
