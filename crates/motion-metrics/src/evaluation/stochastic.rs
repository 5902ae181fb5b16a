//! A **project variant** of the multi-sample protocol of DLow (Yuan and Kitani 2020) and BeLFusion
//! (Barquero et al. 2023) on the exp-map release: APD, ADE, FDE, MMADE and MMFDE
//! ([`crate::multimodal`]) of K samples per window, beside zero-velocity.
//!
//! It follows their recipe where the exp-map release allows it (`protocols_modern.md` §2-3) and
//! is never comparable with their published numbers, which are on the original 3-D positions
//! (per-subject skeletons, world heading):
//! - test subjects S9 and S11, every take present; windows every 25 frames at 50 Hz, 25 observed
//!   and 100 future frames (`i < L - 125`);
//! - positions by forward kinematics of the exp-map frames with dims 0..5 zeroed (the pelvis frame,
//!   one skeleton, no heading), DLow's 16 non-root joints of its 17, in metres; every distance is
//!   the norm of the 48-number pose vector;
//! - the models run at 25 Hz: each observes its own seed length of 25 Hz frames ending at the
//!   window's last observed frame (so windows with less history than that are left out) and
//!   predicts 50 frames; they are scored against the future's frames at the same instants (every
//!   second 50 Hz frame, the last one the window's last). ADE is therefore a mean over 50 instants,
//!   not 100;
//! - the multimodal ground truth pools every window of the run (all actions, both subjects):
//!   windows whose last observed poses are closer than 0.5 m;
//! - stochastic models draw `samples` samples per window (50 in the published tables),
//!   deterministic models and zero-velocity one.
use std::path::PathBuf;
use std::sync::Arc;

use ndarray::{Array2, Array3, Array4};
use serde::Serialize;

use motion_core::formats::h36m_text::read_expmap_text;
use motion_core::model::{BatchGenerator, MotionModel};
use motion_core::protocol::{sequence_file, ACTIONS};
use motion_core::skeleton::H36M_FRAME_DIMS;

use super::mpjpe::predict_chunk;
use super::selection::{select_actions_from, WindowSource};
use super::{check_model, noise_seed, EvalError, ModelInfo, Progress};
use crate::mpjpe::h36m_pelvis_positions;
use crate::multimodal::{
    mean_scores, multimodal_sets, score_windows, SampleSetScores, H36M_MULTIMODAL_THRESHOLD,
};

/// DLow's test subjects.
pub const STOCHASTIC_SUBJECTS: [&str; 2] = ["S9", "S11"];
/// Observed frames at 50 Hz.
pub const OBSERVED_50HZ: usize = 25;
/// Future frames at 50 Hz.
pub const FUTURE_50HZ: usize = 100;
/// Frames between window starts at 50 Hz.
pub const WINDOW_STRIDE_50HZ: usize = 25;
/// DLow's 16 scored joints (its 17 kept joints without the root), H3.6M indices.
pub const DLOW_JOINTS: [usize; 16] = [1, 2, 3, 6, 7, 8, 12, 13, 14, 15, 17, 18, 19, 25, 26, 27];
/// Samples per window of a stochastic model unless asked otherwise (the published tables' 50).
pub const DEFAULT_SAMPLES: usize = 50;
/// Rows (windows x samples) the model runs side by side.
const BATCH_ROWS: usize = 256;

/// What to evaluate and how.
#[derive(Debug, Clone)]
pub struct StochasticOptions {
    /// The exp-map dataset directory.
    pub dataset: PathBuf,
    /// How the report names the model.
    pub model_name: String,
    /// Actions to run, or `["all"]`.
    pub actions: Vec<String>,
    /// Samples per window of a stochastic model (deterministic models get one).
    pub samples: usize,
    /// Seed of the noise.
    pub rng_seed: u64,
    /// The multimodal threshold (metres).
    pub threshold: f64,
    /// Evaluate a single-action model on other actions too.
    pub any_action: bool,
}

impl StochasticOptions {
    /// Every action, 50 samples, noise seed 0, threshold 0.5 m.
    pub fn new(dataset: PathBuf, model_name: impl Into<String>) -> StochasticOptions {
        StochasticOptions {
            dataset,
            model_name: model_name.into(),
            actions: vec!["all".into()],
            samples: DEFAULT_SAMPLES,
            rng_seed: 0,
            threshold: H36M_MULTIMODAL_THRESHOLD,
            any_action: false,
        }
    }
}

/// The report of the variant, as `--json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct StochasticReport {
    /// `stochastic (project variant on the exp-map release)`.
    pub protocol: &'static str,
    /// Why these numbers are not the published ones.
    pub not_comparable: &'static str,
    /// The evaluated model.
    pub model: ModelInfo,
    /// The dataset directory.
    pub data: String,
    /// Samples per window the model drew.
    pub samples: usize,
    /// The multimodal threshold (m).
    pub threshold: f64,
    /// Windows scored.
    pub windows: usize,
    /// The model's means over all windows.
    pub model_scores: SampleSetScores,
    /// Zero-velocity's (one sample: APD 0).
    pub zero_velocity: SampleSetScores,
    /// The mean size of the multimodal sets.
    pub mean_multimodal_set: f64,
    /// Per action: windows and the model's and zero-velocity's means.
    pub actions: Vec<StochasticAction>,
    /// Takes of S9 or S11 not in the data.
    pub missing_takes: Vec<String>,
    /// Actions not run, and why.
    pub skipped: Vec<super::report::Skipped>,
}

/// One action's means.
#[derive(Debug, Clone, Serialize)]
pub struct StochasticAction {
    /// The action.
    pub action: &'static str,
    /// Its windows.
    pub windows: usize,
    /// The model's.
    pub model: SampleSetScores,
    /// Zero-velocity's.
    pub zero_velocity: SampleSetScores,
}

/// One window: where its seed comes from and its positions.
struct Window {
    action: usize,
    label: Option<String>,
    /// The model's seed: 25 Hz exp-map frames ending at the last observed frame.
    seed: Array2<f64>,
}

/// Checks what is asked before anything is read: at least one sample, one window's predictions
/// within the sample limit, a finite threshold.
pub fn check_stochastic_request(samples: usize, threshold: f64) -> Result<(), EvalError> {
    if samples == 0 {
        return Err(EvalError::Invalid("--samples must be at least 1".into()));
    }
    motion_core::model::samples::check_sample_size(samples, FUTURE_50HZ, H36M_FRAME_DIMS)
        .map_err(|e| EvalError::Invalid(format!("--samples {samples}: {e}")))?;
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(EvalError::Invalid(format!(
            "the multimodal threshold must be a finite distance >= 0 (m), got {threshold:e}"
        )));
    }
    Ok(())
}

/// Runs the variant.
pub fn evaluate_stochastic(
    model: &Arc<MotionModel>,
    options: &StochasticOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<StochasticReport, EvalError> {
    check_stochastic_request(options.samples, options.threshold)?;
    // One window's samples run side by side at least, seed frames included.
    motion_core::model::samples::check_sample_size(
        options.samples,
        model.config().seed_frames.max(FUTURE_50HZ),
        H36M_FRAME_DIMS,
    )
    .map_err(|e| EvalError::Invalid(format!("--samples {}: {e}", options.samples)))?;
    check_model(model)?;
    let config = model.config();
    let samples = if config.architecture().is_stochastic() {
        options.samples
    } else {
        1
    };
    let seed_frames = config.seed_frames.max(1);
    let selection = select_actions_from(
        &options.actions,
        model,
        &options.dataset,
        options.any_action,
        WindowSource::Subjects(&STOCHASTIC_SUBJECTS),
    )?;
    progress(Progress::Start {
        actions: selection.planned.len(),
    });
    // Every window's seed, ground truth (50 instants) and last observed pose, all actions pooled.
    let mut windows: Vec<Window> = Vec::new();
    // Row-major `windows x 50 x 48` and `windows x 48`, one window appended at a time.
    let mut truth_values: Vec<f64> = Vec::new();
    let mut last_values: Vec<f64> = Vec::new();
    let mut missing = Vec::new();
    let predicted = FUTURE_50HZ / 2;
    for (a, planned) in selection.planned.iter().enumerate() {
        progress(Progress::Stage {
            action: planned.action,
            stage: "loading",
        });
        for subject in STOCHASTIC_SUBJECTS {
            for sub in [1u8, 2] {
                let path = sequence_file(&options.dataset, subject, planned.action, sub);
                if !path.is_file() {
                    missing.push(path.display().to_string());
                    continue;
                }
                let frames = read_expmap_text(&path)?;
                if frames.ncols() != H36M_FRAME_DIMS {
                    return Err(EvalError::Invalid(format!(
                        "{}: {} columns per frame; H3.6M exp-map frames have {H36M_FRAME_DIMS}",
                        path.display(),
                        frames.ncols()
                    )));
                }
                let positions =
                    h36m_pelvis_positions(frames.view()).map_err(|source| EvalError::Metric {
                        what: path.display().to_string(),
                        source,
                    })?;
                let len = frames.nrows();
                let mut i = 0;
                while i + OBSERVED_50HZ + FUTURE_50HZ < len {
                    let last = i + OBSERVED_50HZ - 1;
                    if last >= 2 * (seed_frames - 1) {
                        let seed =
                            Array2::from_shape_fn((seed_frames, H36M_FRAME_DIMS), |(k, d)| {
                                frames[[last - 2 * (seed_frames - 1 - k), d]]
                            });
                        windows.push(Window {
                            action: a,
                            label: planned.label.clone(),
                            seed,
                        });
                        let metres =
                            |f: usize, d: usize| positions[[f, DLOW_JOINTS[d / 3], d % 3]] / 1000.0;
                        for k in 0..predicted {
                            truth_values.extend((0..48).map(|d| metres(last + 2 * (k + 1), d)));
                        }
                        last_values.extend((0..48).map(|d| metres(last, d)));
                    }
                    i += WINDOW_STRIDE_50HZ;
                }
            }
        }
    }
    let n = windows.len();
    if n == 0 {
        return Err(EvalError::Invalid(format!(
            "no window of {OBSERVED_50HZ} + {FUTURE_50HZ} frames with {seed_frames} frames of history at 25 Hz in the takes of S9 and S11 under {}",
            options.dataset.display()
        )));
    }
    let truth = Array3::from_shape_vec((n, predicted, 48), truth_values).expect("48 per instant");
    let last = Array2::from_shape_vec((n, 48), last_values).expect("48 per window");
    let sets = multimodal_sets(last.view(), options.threshold);
    let zero = Array4::from_shape_fn((n, 1, predicted, 48), |(w, _, _, d)| last[[w, d]]);
    let zero_scores = score_windows(zero.view(), 0, truth.view(), &sets);
    drop(zero);

    // The model, a chunk of whole windows (all their samples) at a time.
    let per_chunk = (BATCH_ROWS / samples).max(1);
    let mut generator = BatchGenerator::new(Arc::clone(model), 1);
    let mut model_scores: Vec<SampleSetScores> = Vec::with_capacity(n);
    let mut start = 0;
    let mut current_action = usize::MAX;
    while start < n {
        // Chunks never mix actions (one label per batch of a conditioned model).
        let action = windows[start].action;
        if action != current_action {
            current_action = action;
            progress(Progress::Stage {
                action: selection.planned[action].action,
                stage: "predicting",
            });
        }
        let mut end = (start + per_chunk).min(n);
        if let Some(k) = (start..end).find(|&w| windows[w].action != action) {
            end = k;
        }
        let rows = (end - start) * samples;
        let seeds = Array3::from_shape_fn((rows, seed_frames, H36M_FRAME_DIMS), |(r, t, d)| {
            windows[start + r / samples].seed[[t, d]]
        });
        let action_index = ACTIONS
            .iter()
            .position(|a| *a == selection.planned[action].action)
            .unwrap_or(0);
        let noise = (0..rows)
            .map(|r| {
                noise_seed(
                    options.rng_seed,
                    action_index,
                    start + r / samples,
                    r % samples,
                )
            })
            .collect();
        let positions = predict_chunk(
            &mut generator,
            seeds,
            windows[start].label.as_deref(),
            noise,
            selection.planned[action].action,
            predicted,
        )?;
        let chunk = Array4::from_shape_fn((end - start, samples, predicted, 48), |(w, k, t, d)| {
            positions[[w * samples + k, t, DLOW_JOINTS[d / 3], d % 3]] / 1000.0
        });
        model_scores.extend(score_windows(chunk.view(), start, truth.view(), &sets));
        for _ in start..end {
            progress(Progress::Window);
        }
        start = end;
    }
    let actions = selection
        .planned
        .iter()
        .enumerate()
        .filter_map(|(a, planned)| {
            let members: Vec<usize> = (0..n).filter(|&w| windows[w].action == a).collect();
            (!members.is_empty()).then(|| StochasticAction {
                action: planned.action,
                windows: members.len(),
                model: mean_scores(&members.iter().map(|&w| model_scores[w]).collect::<Vec<_>>()),
                zero_velocity: mean_scores(
                    &members.iter().map(|&w| zero_scores[w]).collect::<Vec<_>>(),
                ),
            })
        })
        .collect();
    Ok(StochasticReport {
        protocol: "stochastic (project variant on the exp-map release)",
        not_comparable: "positions from exp-map FK in the pelvis frame (one skeleton, no heading), models at 25 Hz scored at 50 instants: not comparable with DLow's or BeLFusion's published numbers (original 3-D positions, per-subject skeletons, world heading, 100 frames at 50 Hz)",
        model: super::model_info(model, options.model_name.clone(), samples),
        data: options.dataset.display().to_string(),
        samples,
        threshold: options.threshold,
        windows: n,
        model_scores: mean_scores(&model_scores),
        zero_velocity: mean_scores(&zero_scores),
        mean_multimodal_set: sets.iter().map(Vec::len).sum::<usize>() as f64 / n as f64,
        actions,
        missing_takes: missing,
        skipped: selection
            .skipped
            .iter()
            .map(|(action, reason)| super::report::Skipped {
                action,
                reason: reason.clone(),
            })
            .collect(),
    })
}
