//! The H3.6M evaluation protocol as a library call: a model on subject 5's fixed test windows
//! (8 per action, 50 seed frames at 25 Hz), scored the way Gopalakrishnan et al. 2019 and Tanke et
//! al. 2021 do, beside the zero-velocity baseline, the real continuation and the papers' published
//! numbers. `motion-cli eval` and Python's `motion.evaluate` print or return the same
//! [`EvalReport`].
//!
//! ```no_run
//! use std::sync::Arc;
//! use motion_core::model::MotionModel;
//! use motion_metrics::evaluation::{evaluate, resolve_dataset, EvalOptions};
//!
//! let model = Arc::new(MotionModel::load("weights/vgru_d_multi.safetensors")?);
//! let mut options = EvalOptions::new(resolve_dataset(None)?, "weights/vgru_d_multi.safetensors");
//! options.actions = vec!["walking".into()];
//! let report = evaluate(&model, &options, &mut |_| {})?;
//! println!("{}", report.actions[0].model.npss.whole);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - [`selection`]: the dataset directory and the actions to run;
//! - [`published`]: the papers' tables as code;
//! - [`report`]: the typed report (what `--json` prints).
//!
//! The predictions can be kept ([`EvalOptions::save_predictions`]), written piece by piece
//! ([`motion_core::formats::npy_stream`]).
pub mod mpjpe;
pub mod posture;
pub mod published;
pub mod report;
pub mod selection;
pub mod stochastic;

use std::path::PathBuf;
use std::sync::Arc;

use ndarray::{s, Array3, Array4, ArrayView2};

use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::formats::npy_stream::NpyStream;
use motion_core::grounding::{ground_expmap_clip, ClipSpec, GroundingConfig, GroundingError};
use motion_core::model::{
    ActionClassifier, Architecture, BatchGenerator, GenerateError, MotionModel, Noise,
};
use motion_core::protocol::{
    load_action_windows_in, load_subject_sequences, WindowSet, ACTIONS, LONG_TERM_HORIZON,
    SEED_FRAMES, SUBJECTS, TEST_SUBJECT,
};
use motion_core::root::RootPose;
use motion_core::skeleton::{H36M_FRAME_DIMS, H36M_PROTOCOL_FPS};
use motion_core::FormatError;

use crate::error::MetricError;
use crate::ndms::NdmsReport;
use crate::plausibility::reference::ReferenceError;
use crate::plausibility::{
    action_reference, measure_sequences_after, measure_sequences_in_floor_frame, ActionReference,
    SequenceMeasures, MAX_HORIZON_FRAMES,
};
use crate::posture::PostureReference;
use crate::protocol::{ActionTruth, Coverage, NpssScores, ProtocolError, Scores, Speed};
use crate::{
    classifier_curve_pairs, classifier_protocol, euler_error_at_horizons, protocol_hop,
    ClassifierCurve, PlausibilityReport,
};
use posture::{action_posture, action_posture_reference, windows_posture, PostureWindow};
use report::{
    ActionResult, ActionScores, CoverageReport, EvalReport, GroundTruth, Means, MeansOverActions,
    Method, ModelInfo, NdmsScores, NpssReport, PlausibilityKeys, Protocol, RealMotionMeans,
    SavedPredictions, Skipped, SpeedReport,
};
pub use selection::resolve_dataset;
use selection::{Planned, Selection};

/// Test windows per action in the protocol.
pub const WINDOWS_PER_ACTION: usize = 8;

/// What to evaluate and how.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    /// The exp-map dataset directory (the one holding `S5/`; [`resolve_dataset`]).
    pub dataset: PathBuf,
    /// How the report names the model (its file, or "built-in ...").
    pub model_name: String,
    /// Actions to run, or `["all"]`: every action with test windows the model may be evaluated
    /// on.
    pub actions: Vec<String>,
    /// Predicted frames per window at 25 Hz (1 ..= [`MAX_HORIZON_FRAMES`]).
    pub horizon: usize,
    /// Samples per window (stochastic models draw new noise for each).
    pub samples: usize,
    /// Seed of the noise: sample k of window w of an action gets its own stream.
    pub rng_seed: u64,
    /// The action classifier of the Ghosh et al. 2017 protocol (`None`: skipped).
    pub classifier: Option<Arc<ActionClassifier>>,
    /// Evaluate a single-action model on other actions too.
    pub any_action: bool,
    /// Write the predictions here (`actions x 8 x K x horizon x 99`, float64 `.npy`).
    pub save_predictions: Option<PathBuf>,
    /// The protocol's test windows (report these) or validation windows disjoint from them
    /// (choose checkpoints and settings on these; `motion_core::protocol::validation`).
    pub windows: WindowSet,
}

impl EvalOptions {
    /// Every action, 4 s (the long-term protocol), one sample, noise seed 0, no classifier.
    pub fn new(dataset: PathBuf, model_name: impl Into<String>) -> EvalOptions {
        EvalOptions {
            dataset,
            model_name: model_name.into(),
            actions: vec!["all".into()],
            horizon: LONG_TERM_HORIZON,
            samples: 1,
            rng_seed: 0,
            classifier: None,
            any_action: false,
            save_predictions: None,
            windows: WindowSet::Test,
        }
    }
}

/// Where an evaluation is (for a progress bar).
#[derive(Debug, Clone, Copy)]
pub enum Progress {
    /// About to run `actions` actions of 8 windows each.
    Start {
        /// Actions to run.
        actions: usize,
    },
    /// `action` moved on to a stage ("loading", "predicting", "scoring", "classifying").
    Stage {
        /// The action.
        action: &'static str,
        /// The stage.
        stage: &'static str,
    },
    /// One more window scored.
    Window,
}

/// Why an evaluation could not run or finish. Every variant is about what was given (options,
/// data, weights); writing the predictions can also fail for the machine's reasons (a full
/// disk), carried in [`EvalError::Format`]'s source.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// Options, data or weights that cannot be evaluated (an unknown action, no data directory, a
    /// model of another frame layout or rate, a horizon out of range).
    #[error("{0}")]
    Invalid(String),
    /// Reading the data or writing the predictions failed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The protocol's windows or scores could not be computed.
    #[error(transparent)]
    Protocol(#[from] ProtocolError),
    /// An action's reference statistics (plausibility) could not be computed.
    #[error("{action} reference statistics: {source}")]
    Reference {
        /// The action.
        action: &'static str,
        /// Why.
        source: ReferenceError,
    },
    /// The model failed to generate.
    #[error("{action}: {source}")]
    Generate {
        /// The action.
        action: &'static str,
        /// Why.
        source: GenerateError,
    },
    /// The predictions could not be grounded.
    #[error("{action}: grounding: {source}")]
    Grounding {
        /// The action.
        action: &'static str,
        /// Why.
        source: GroundingError,
    },
    /// A metric could not be computed.
    #[error("{what}: {source}")]
    Metric {
        /// What was measured.
        what: String,
        /// Why.
        source: MetricError,
    },
}

/// Measures every `(seed, motion)` pair (`what` names the input in errors).
fn measure(
    triples: &[(
        Option<RootPose>,
        ndarray::ArrayView2<'_, f64>,
        ndarray::ArrayView2<'_, f64>,
    )],
    what: &str,
) -> Result<Vec<SequenceMeasures>, EvalError> {
    measure_sequences_after(triples).map_err(|source| EvalError::Metric {
        what: what.to_string(),
        source,
    })
}

/// Checks what is asked before anything is read: the horizon, the sample count against the
/// memory limit, the predictions' file name.
pub fn check_request(
    horizon: usize,
    samples: usize,
    save_predictions: Option<&std::path::Path>,
) -> Result<(), EvalError> {
    if !(1..=MAX_HORIZON_FRAMES).contains(&horizon) {
        return Err(EvalError::Invalid(format!(
            "--horizon must be 1..={MAX_HORIZON_FRAMES} frames (60 s at 25 Hz; the test windows guarantee {LONG_TERM_HORIZON} frames of ground truth, the metrics that need it use what the files cover), got {horizon}"
        )));
    }
    // The predictions of one action (8 windows x samples x horizon x 99 values) are held at
    // once: refused before anything is allocated when they would pass the sample limit.
    motion_core::model::samples::check_sample_size(
        WINDOWS_PER_ACTION.saturating_mul(samples),
        horizon,
        H36M_FRAME_DIMS,
    )
    .map_err(|e| EvalError::Invalid(format!("--samples {samples} x 8 windows: {e}")))?;
    if samples == 0 {
        return Err(EvalError::Invalid("--samples must be at least 1".into()));
    }
    if let Some(out) = save_predictions {
        if out.extension().and_then(|e| e.to_str()) != Some("npy") {
            return Err(EvalError::Invalid(format!(
                "--save-predictions {}: the predictions are written as .npy; name the file FILE.npy",
                out.display()
            )));
        }
    }
    Ok(())
}

/// Runs `model` on the protocol's windows of the selected actions and scores everything;
/// `progress` hears where it is.
pub fn evaluate(
    model: &Arc<MotionModel>,
    options: &EvalOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<EvalReport, EvalError> {
    check_request(
        options.horizon,
        options.samples,
        options.save_predictions.as_deref(),
    )?;
    check_model(model)?;
    if let Some(classifier) = &options.classifier {
        check_classifier(classifier)?;
    }
    let dataset = &options.dataset;
    let selection =
        selection::select_actions(&options.actions, model, dataset, options.any_action)?;
    let (samples, horizon) = (options.samples, options.horizon);
    let shape = [
        selection.planned.len(),
        WINDOWS_PER_ACTION,
        samples,
        horizon,
        H36M_FRAME_DIMS,
    ];
    let mut saver = match &options.save_predictions {
        Some(path) => Some(NpyStream::create(path, &shape)?),
        None => None,
    };
    progress(Progress::Start {
        actions: selection.planned.len(),
    });
    let mut generator = BatchGenerator::new(Arc::clone(model), WINDOWS_PER_ACTION * samples);
    let mut results = Vec::new();
    for planned in &selection.planned {
        let action = planned.action;
        let stage = |stage| Progress::Stage { action, stage };
        progress(stage("loading"));
        let windows = load_action_windows_in(
            dataset,
            action,
            horizon,
            options.windows,
            WINDOWS_PER_ACTION,
        )?;
        if windows.len() != WINDOWS_PER_ACTION {
            return Err(EvalError::Invalid(format!(
                "{action}: {} {} windows, the evaluation needs {WINDOWS_PER_ACTION}",
                windows.len(),
                options.windows.name()
            )));
        }
        let references = load_subject_sequences(dataset, TEST_SUBJECT, action)?;
        let truth = ActionTruth::new(windows, &references, horizon)?;
        drop(references);
        let mut others = Vec::new();
        for subject in SUBJECTS.iter().filter(|&&s| s != TEST_SUBJECT) {
            others.extend(load_subject_sequences(dataset, subject, action)?);
        }
        let real_motion_ndms = truth.real_motion_ndms(&others)?;
        drop(others);
        let reference = action_reference(dataset, action)
            .map_err(|source| EvalError::Reference { action, source })?;
        let (posture_reference, real_vs_real) =
            action_posture_reference(dataset, action, TEST_SUBJECT)
                .map_err(|source| EvalError::Reference { action, source })?;

        progress(stage("predicting"));
        let predictions = predict(
            &mut generator,
            &truth,
            planned,
            samples,
            horizon,
            options.rng_seed,
        )?;
        if let Some(saver) = saver.as_mut() {
            saver.write(predictions.iter().copied())?;
        }
        progress(stage("scoring"));
        let model_scores = truth.score(predictions.view(), || progress(Progress::Window))?;
        let baseline = truth.zero_velocity();
        let baseline_scores = truth.score(baseline.view(), || {})?;
        // The real continuation of each window after its seed (files may end before the horizon).
        let real_pairs: Vec<_> = truth
            .windows()
            .iter()
            .map(|w| (w.root_before, w.seed.view(), w.ground_truth.view()))
            .collect();
        let (grounded, grounded_clips) =
            grounded_plausibility(&truth, &predictions, action, &reference)?;
        let posture_of = |clips: &[(Option<RootPose>, ArrayView2<'_, f64>, usize)]| {
            windows_posture(&posture_reference, clips, H36M_PROTOCOL_FPS).map_err(|source| {
                EvalError::Metric {
                    what: format!("{action}: posture"),
                    source,
                }
            })
        };
        let real_clips: Vec<ndarray::Array2<f64>> = real_pairs
            .iter()
            .map(|(_, seed, motion)| {
                ndarray::concatenate(ndarray::Axis(0), &[*seed, *motion]).expect("same width")
            })
            .collect();
        let posture = action_posture(
            &posture_reference,
            real_vs_real,
            [
                posture_of(
                    &grounded_clips
                        .iter()
                        .map(|(c, n)| (None, c.view(), *n))
                        .collect::<Vec<_>>(),
                )?,
                prediction_posture(&truth, &predictions, &posture_reference, action)?,
                prediction_posture(&truth, &baseline, &posture_reference, action)?,
                posture_of(
                    &real_clips
                        .iter()
                        .zip(&real_pairs)
                        .map(|(c, (root, seed, _))| (*root, c.view(), seed.nrows()))
                        .collect::<Vec<_>>(),
                )?,
            ],
        );
        drop(grounded_clips);
        let mut measured = Plausibility {
            classifier: None,
            model: plausibility_of(&truth, &predictions, &reference, "the model's predictions")?,
            grounded,
            zero_velocity: plausibility_of(&truth, &baseline, &reference, "zero-velocity")?,
            real: PlausibilityReport::new(&measure(&real_pairs, action)?, horizon, &reference),
        };
        progress(stage("classifying"));
        measured.classifier = match &options.classifier {
            Some(classifier) => Some(Curves {
                model: curve_of(classifier, &truth, &predictions, action)?,
                zero_velocity: curve_of(classifier, &truth, &baseline, action)?,
                real: classifier_curve_pairs(
                    classifier,
                    &real_pairs
                        .iter()
                        .map(|&(_, seed, motion)| (seed, motion))
                        .collect::<Vec<_>>(),
                    action,
                    protocol_hop(classifier),
                )
                .map_err(|source| EvalError::Metric {
                    what: format!("{action}: action classifier"),
                    source,
                })?,
            }),
            None => None,
        };
        drop(predictions);
        let mut result = action_result(
            planned,
            &truth,
            &model_scores,
            &baseline_scores,
            measured,
            samples,
            horizon,
        );
        result.ground_truth.real_motion_ndms = real_motion_ndms.as_ref().map(ndms_scores);
        result.posture = Some(posture);
        results.push(result);
    }
    let saved = match (saver, &options.save_predictions) {
        (Some(saver), Some(path)) => {
            saver.finish()?;
            Some(SavedPredictions {
                path: path.display().to_string(),
                shape,
                axes: ["action", "window", "sample", "frame", "dim"],
                actions: selection.planned.iter().map(|p| p.action).collect(),
            })
        }
        _ => None,
    };
    Ok(full_report(
        options, model, dataset, &selection, results, saved,
    ))
}

/// `eval` runs the H3.6M protocol: the model must take 99-dim H3.6M frames at 25 Hz.
fn check_model(model: &MotionModel) -> Result<(), EvalError> {
    let config = model.config();
    if config.frame_dims != H36M_FRAME_DIMS {
        return Err(EvalError::Invalid(format!(
            "{}: the model's frames have {} dims; the H3.6M protocol needs {H36M_FRAME_DIMS}",
            model.path().display(),
            config.frame_dims
        )));
    }
    if (config.fps - H36M_PROTOCOL_FPS).abs() > 1e-9 {
        return Err(EvalError::Invalid(format!(
            "{}: the model runs at {} fps; the H3.6M protocol is {H36M_PROTOCOL_FPS} fps",
            model.path().display(),
            config.fps
        )));
    }
    Ok(())
}

/// A well-mixed 64-bit seed for the noise (VGRU-d plan noise, intention z) of (action, window,
/// sample): SplitMix64 steps.
fn noise_seed(rng_seed: u64, action: usize, window: usize, sample: usize) -> u64 {
    let mut z = rng_seed;
    for part in [action as u64, window as u64, sample as u64] {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_add(part);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    z
}

/// Runs the model on all windows x samples of one action as one batch:
/// `8 x K x horizon x 99` un-normalized frames.
fn predict(
    generator: &mut BatchGenerator,
    truth: &ActionTruth,
    planned: &Planned,
    samples: usize,
    horizon: usize,
    rng_seed: u64,
) -> Result<Array4<f64>, EvalError> {
    let windows = truth.windows();
    let rows = windows.len() * samples;
    if generator.batch() != rows {
        *generator = BatchGenerator::new(Arc::clone(generator.model()), rows);
    }
    let seeds = Array3::from_shape_fn((rows, SEED_FRAMES, H36M_FRAME_DIMS), |(r, t, d)| {
        windows[r / samples].seed[[t, d]]
    });
    let action_index = ACTIONS
        .iter()
        .position(|a| *a == planned.action)
        .expect("selected from ACTIONS");
    let noise: Vec<Noise<'_>> = (0..rows)
        .map(|r| Noise::Seed(noise_seed(rng_seed, action_index, r / samples, r % samples)))
        .collect();
    let labels: Vec<&str> = planned.label.iter().map(String::as_str).collect();
    generator
        .start(seeds.view(), &labels, &noise)
        .map_err(|source| EvalError::Generate {
            action: planned.action,
            source,
        })?;
    let mut out = Array4::zeros((windows.len(), samples, horizon, H36M_FRAME_DIMS));
    for t in 0..horizon {
        let frames = generator.step().map_err(|source| EvalError::Generate {
            action: planned.action,
            source,
        })?;
        for (r, frame) in frames.outer_iter().enumerate() {
            out.slice_mut(s![r / samples, r % samples, t, ..])
                .iter_mut()
                .zip(frame.iter())
                .for_each(|(o, v)| *o = f64::from(*v));
        }
    }
    Ok(out)
}

/// The classifier curves of one action: model, zero-velocity baseline, real continuation.
struct Curves {
    model: ClassifierCurve,
    zero_velocity: ClassifierCurve,
    real: ClassifierCurve,
}

/// The classifier curve of `8 x K x horizon x 99` predictions after their windows' seeds.
fn curve_of(
    classifier: &ActionClassifier,
    truth: &ActionTruth,
    predictions: &Array4<f64>,
    action: &'static str,
) -> Result<ClassifierCurve, EvalError> {
    let (windows, samples, horizon, dims) = predictions.dim();
    let flat = predictions
        .view()
        .into_shape_with_order((windows * samples, horizon, dims))
        .expect("a standard-layout array");
    let seed_frames = truth.windows()[0].seed.nrows();
    let seeds = Array3::from_shape_fn((windows * samples, seed_frames, dims), |(i, f, d)| {
        truth.windows()[i / samples].seed[[f, d]]
    });
    classifier_protocol(classifier, Some(seeds.view()), flat, action).map_err(|source| {
        EvalError::Metric {
            what: format!("{action}: action classifier"),
            source,
        }
    })
}

/// `eval` feeds the classifier 25 Hz H3.6M frames.
fn check_classifier(classifier: &ActionClassifier) -> Result<(), EvalError> {
    let c = classifier.config();
    if c.frame_dims != H36M_FRAME_DIMS || (c.fps - 25.0).abs() > 1e-9 {
        return Err(EvalError::Invalid(format!(
            "{}: eval needs an action classifier of {H36M_FRAME_DIMS}-dim frames at 25 Hz; this one reads {} dims at {} Hz",
            classifier.path().display(),
            c.frame_dims,
            c.fps
        )));
    }
    Ok(())
}

/// The plausibility reports of one action: model, zero-velocity baseline, real continuation.
struct Plausibility {
    model: PlausibilityReport,
    /// The model's predictions grounded.
    grounded: PlausibilityReport,
    zero_velocity: PlausibilityReport,
    real: PlausibilityReport,
    /// The action classifier's curves (absent with `--no-classifier`).
    classifier: Option<Curves>,
}

/// The plausibility report of `8 x K x horizon x 99` predictions after their windows' seeds.
fn plausibility_of(
    truth: &ActionTruth,
    predictions: &Array4<f64>,
    reference: &ActionReference,
    what: &str,
) -> Result<PlausibilityReport, EvalError> {
    let (_, samples, horizon, _) = predictions.dim();
    let pairs: Vec<_> = truth
        .windows()
        .iter()
        .enumerate()
        .flat_map(|(w, window)| {
            (0..samples).map(move |k| {
                (
                    window.root_before,
                    window.seed.view(),
                    predictions.slice(s![w, k, .., ..]),
                )
            })
        })
        .collect();
    Ok(PlausibilityReport::new(
        &measure(&pairs, what)?,
        horizon,
        reference,
    ))
}

/// A grounded clip (seed, then prediction) and its seed frame count.
type GroundedClip = (ndarray::Array2<f64>, usize);

/// The plausibility report of the predictions grounded after their windows' seeds (the seed's
/// floor, levelled; the lean limit of `action`): each window's seed and prediction are grounded
/// as one clip, as `predict` writes it.
fn grounded_plausibility(
    truth: &ActionTruth,
    predictions: &Array4<f64>,
    action: &'static str,
    reference: &ActionReference,
) -> Result<(PlausibilityReport, Vec<GroundedClip>), EvalError> {
    let (_, samples, horizon, _) = predictions.dim();
    let mut clips = Vec::with_capacity(truth.windows().len() * samples);
    for (w, window) in truth.windows().iter().enumerate() {
        let seed_frames = window.seed.nrows();
        for k in 0..samples {
            let whole = ndarray::concatenate(
                ndarray::Axis(0),
                &[window.seed.view(), predictions.slice(s![w, k, .., ..])],
            )
            .expect("same width");
            let spec = ClipSpec {
                root_before: window.root_before,
                ..ClipSpec::new(
                    ExpMapTarget::H36m,
                    H36M_PROTOCOL_FPS,
                    0..seed_frames,
                    Some(action),
                    GroundingConfig::default(),
                )
            };
            let clip = ground_expmap_clip(whole.view(), &spec)
                .map_err(|source| EvalError::Grounding { action, source })?;
            clips.push((clip.frames, seed_frames));
        }
    }
    // The grounded clips' roots are re-encoded from the identity (their first delta holds the
    // absolute pose) in the floor frame grounding levelled them into: measured on that floor.
    let pairs: Vec<_> = clips
        .iter()
        .map(|(f, n)| (f.slice(s![..*n, ..]), f.slice(s![*n.., ..])))
        .collect();
    let measured =
        measure_sequences_in_floor_frame(&pairs).map_err(|source| EvalError::Metric {
            what: "the grounded predictions".to_string(),
            source,
        })?;
    Ok((
        PlausibilityReport::new(&measured, horizon, reference),
        clips,
    ))
}

/// The posture windows of `8 x K x horizon x 99` predictions after their windows' seeds.
fn prediction_posture(
    truth: &ActionTruth,
    predictions: &Array4<f64>,
    reference: &PostureReference,
    action: &'static str,
) -> Result<Vec<PostureWindow>, EvalError> {
    let samples = predictions.dim().1;
    let clips: Vec<ndarray::Array2<f64>> = truth
        .windows()
        .iter()
        .enumerate()
        .flat_map(|(w, window)| {
            (0..samples).map(move |k| {
                ndarray::concatenate(
                    ndarray::Axis(0),
                    &[window.seed.view(), predictions.slice(s![w, k, .., ..])],
                )
                .expect("same width")
            })
        })
        .collect();
    let views: Vec<_> = clips
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let window = &truth.windows()[i / samples];
            (window.root_before, c.view(), window.seed.nrows())
        })
        .collect();
    windows_posture(reference, &views, H36M_PROTOCOL_FPS).map_err(|source| EvalError::Metric {
        what: format!("{action}: posture"),
        source,
    })
}

fn coverage_report(coverage: Coverage) -> CoverageReport {
    CoverageReport {
        frames_per_window: coverage.frames_per_window,
        windows_per_second: coverage.windows_per_second,
        npss_whole_frames: coverage.npss_whole_frames,
        npss_windows: coverage.npss_windows.into_iter().collect(),
    }
}

fn npss_report(scores: &NpssScores) -> NpssReport {
    NpssReport {
        whole: scores.whole,
        windows: scores
            .windows
            .iter()
            .map(|(label, v)| (label.to_string(), *v))
            .collect(),
    }
}

fn speed_report(speed: &Speed) -> SpeedReport {
    SpeedReport {
        world: speed.world,
        pose: speed.pose,
    }
}

fn ndms_scores(report: &NdmsReport) -> NdmsScores {
    NdmsScores {
        mean: report.mean,
        bins: report.bins.clone(),
        first_word_end: report.first_word_end,
        exact: report.exact,
    }
}

/// The scores of the model or the baseline beside its plausibility report and classifier curve.
fn action_scores(
    scores: &Scores,
    plausibility: PlausibilityReport,
    classifier: Option<ClassifierCurve>,
) -> ActionScores {
    ActionScores {
        euler_error_ms: euler_error_at_horizons(&scores.euler_per_frame)
            .iter()
            .map(|(ms, v)| (ms.to_string(), *v))
            .collect(),
        euler_error_per_frame: scores.euler_per_frame.clone(),
        npss: npss_report(&scores.npss),
        npss_reference: npss_report(&scores.npss_reference),
        ndms: ndms_scores(&scores.ndms),
        mean_joint_speed_last_1s: speed_report(&scores.speed_last_second),
        apd: scores.apd,
        plausibility: PlausibilityKeys(plausibility),
        classifier,
    }
}

/// The result of one action: speed_ratio, drift, foot_contact for the model, the zero-velocity
/// baseline and the real continuation (`ground_truth`) in the shapes of `score`, and the
/// classifier curve beside them.
fn action_result(
    planned: &Planned,
    truth: &ActionTruth,
    model: &Scores,
    baseline: &Scores,
    plausibility: Plausibility,
    samples: usize,
    horizon: usize,
) -> ActionResult {
    let Plausibility {
        model: model_plausibility,
        grounded,
        zero_velocity,
        real,
        classifier,
    } = plausibility;
    let (model_curve, baseline_curve, real_curve) = match classifier {
        Some(c) => (Some(c.model), Some(c.zero_velocity), Some(c.real)),
        None => (None, None, None),
    };
    ActionResult {
        action: planned.action,
        label: planned.label.clone(),
        windows: truth.windows().len(),
        window_starts: truth
            .windows()
            .iter()
            .map(|w| (w.window.subaction, w.window.seed_start))
            .collect(),
        samples,
        horizon,
        ground_truth_coverage: coverage_report(truth.coverage()),
        ndms_database_words: truth.database_words(),
        model: action_scores(model, model_plausibility, model_curve),
        zero_velocity: action_scores(baseline, zero_velocity, baseline_curve),
        model_grounded: PlausibilityKeys(grounded),
        ground_truth: GroundTruth {
            mean_joint_speed_last_1s: truth.speed_last_second.as_ref().map(speed_report),
            plausibility: PlausibilityKeys(real),
            classifier: real_curve,
            real_motion_ndms: None, // set by the caller: the other subjects' takes
        },
        published: published::for_action(planned.action),
        posture: None, // set by the caller
    }
}

/// The report's description of `model` (named `source`), run with `samples` samples per window.
fn model_info(model: &MotionModel, source: String, samples: usize) -> ModelInfo {
    let config = model.config();
    let stochastic = config.architecture().is_stochastic();
    ModelInfo {
        source,
        architecture: config.architecture().name(),
        hidden: config.hidden,
        actions: config.actions.clone(),
        actions_trained: selection::trained_actions(model),
        stochastic,
        plan_horizon: (config.architecture() == Architecture::VgruD).then_some(config.horizon),
        stored_dtype: model.stored_dtype().to_string(),
        note: (!stochastic && samples > 1)
            .then_some("deterministic model: the K samples are identical (APD is 0)"),
    }
}

fn full_report(
    options: &EvalOptions,
    model: &MotionModel,
    dataset: &std::path::Path,
    selection: &Selection,
    results: Vec<ActionResult>,
    saved: Option<SavedPredictions>,
) -> EvalReport {
    let mean_over_actions = MeansOverActions {
        actions: results.len(),
        model: Means::of(&results.iter().map(|r| &r.model).collect::<Vec<_>>()),
        zero_velocity: Means::of(&results.iter().map(|r| &r.zero_velocity).collect::<Vec<_>>()),
        real_motion: RealMotionMeans::of(
            &results
                .iter()
                .map(|r| r.ground_truth.real_motion_ndms.as_ref())
                .collect::<Vec<_>>(),
        ),
    };
    EvalReport {
        model: model_info(model, options.model_name.clone(), options.samples),
        data: dataset.display().to_string(),
        protocol: Protocol {
            subject: TEST_SUBJECT,
            fps: H36M_PROTOCOL_FPS,
            seed_frames: SEED_FRAMES,
            horizon: options.horizon,
            windows: options.windows.name(),
            windows_per_action: WINDOWS_PER_ACTION,
            samples: options.samples,
            rng_seed: options.rng_seed,
        },
        method: METHOD,
        actions: results,
        skipped: selection
            .skipped
            .iter()
            .map(|(action, reason)| Skipped {
                action,
                reason: reason.clone(),
            })
            .collect(),
        published_averages: published::averages(),
        mean_over_actions,
        save_predictions: saved,
    }
}

/// How each number of the report is computed.
const METHOD: Method = Method {
    samples: "Euler error: mean over all 8 x K sequences; NPSS: each sample index scored as a set of the 8 windows, then the mean over the K sets; NDMS: f_sim over all words of all 8 x K forecasts; APD: per window over its K samples (world positions of all 32 joints, mm), mean over windows",
    npss: "npss = |DFT|² (Gopalakrishnan et al. 2019's definition); npss_reference = Re(DFT)² (the published code, which every published NPSS used)",
    ndms: "database = every motion word (kappa 8, stride 1) of the action's S5 files at 25 Hz; queries = forecasts with the last 7 seed frames prepended; exact nearest neighbour (brute force); bins of 0.4 s by word end; ground_truth.real_motion_ndms = the same score of real motion that is not the truth: one clip (seed + horizon) per test window from the action's takes of the other subjects (S1, S6, S7, S8, S9, S11), clip i from the (i mod n)-th take long enough, evenly spread within it (motion_metrics::protocol::real_motion_clips)",
    positions: "FK of seed + forecast with the root integrated (each 25 Hz root delta applied twice)",
    mean_joint_speed_last_1s: "mean displacement per 25 Hz frame (mm) of the 12 NDMS joints over the last 25 frame steps; world = with the root trajectory, pose = root deltas zeroed (body motion only)",
    zero_velocity: "the last seed pose repeated with the root held (root deltas 0: no translation, no turning); its joint angles are the protocol's repeated last frame, so its Euler error and NPSS are Gopalakrishnan et al. 2019 Table 6's zero-velocity baseline",
    ground_truth_coverage: "horizons past 100 frames: a window's ground truth ends with its S5 file; Euler error per frame = mean over the windows covering the frame (dims chosen over each window's covered frames); NPSS whole over the frames all windows cover (npss_whole_frames), each NPSS window over the windows covering it completely (npss_windows); windows_per_second = windows covering each second of the horizon",
    posture: "posture realism (motion_metrics::posture: Fréchet distance of body-frame pose features, upper-arm and thigh elevation histogram EMD, share of frames with an upper arm above the real p99) per plausibility window, the frames after the seed of all 8 x K sequences pooled per window, against the action's takes of S1, S6, S7, S8, S9, S11 from frame 50; real_vs_real = the test subject S5's takes of the action (from frame 50) against the same reference",
    plausibility: "speed_ratio, drift, foot_contact (motion_metrics::plausibility) per window 0-2, 2-4, 4-8, 8-12 s for model (all 8 x K), zero_velocity and ground_truth (the real continuation; each window counts the test windows whose file covers it); speed reference = mean root-frame joint speed over the action's S5 files; drift p95 over real 12 s windows of the action, every subject, seeded by the 50 frames before each",
};
