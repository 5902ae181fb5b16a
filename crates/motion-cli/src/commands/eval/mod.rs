//! `motion-cli eval`: runs a model on the standard H3.6M protocol's test windows (8 per action,
//! 50 seed frames at 25 Hz) and scores it the way Gopalakrishnan et al. 2019 and Tanke et al. 2021 do, beside the
//! zero-velocity baseline and the papers' published numbers.
//!
//! - [`selection`]: the dataset directory and the actions to run;
//! - [`scoring`]: every metric of one action's predictions;
//! - [`published`]: the papers' tables as code;
//! - [`report`]: the typed report (the JSON) and the human-readable table;
//! - `plots`: the charts of `--plot`, from the same report.
//!
//! `--save-predictions` is written piece by piece ([`motion_core::formats::npy_stream`]).
mod plots;
pub mod published;
pub mod report;
pub mod selection;

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result};

use ndarray::{s, Array3, Array4};

use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::{ground_expmap_clip, ClipSpec, GroundingConfig};
use motion_core::model::{ActionClassifier, BatchGenerator, MotionModel, Network, Noise};
use motion_core::protocol::{
    load_action_windows_covered, load_subject_sequences, ACTIONS, LONG_TERM_HORIZON, SEED_FRAMES,
    SUBJECTS, TEST_SUBJECT,
};
use motion_core::skeleton::{H36M_FRAME_DIMS, H36M_PROTOCOL_FPS};
use motion_metrics::euler_error_at_horizons;
use motion_metrics::plausibility::MAX_HORIZON_FRAMES;
use motion_metrics::{classifier_curve_pairs, protocol_hop, ClassifierCurve, PlausibilityReport};

use super::plausibility;
use super::UsageError;
use crate::model_source;
use motion_core::formats::npy_stream::NpyStream;
use motion_metrics::ndms::NdmsReport;
use motion_metrics::protocol::{ActionTruth, Coverage, NpssScores, Scores, Speed};
use report::{
    ActionResult, ActionScores, CoverageReport, EvalReport, GroundTruth, Means, MeansOverActions,
    Method, ModelInfo, NdmsScores, NpssReport, PlausibilityKeys, Protocol, RealMotionMeans,
    SavedPredictions, Skipped, SpeedReport,
};
use selection::{Planned, Selection};

/// Test windows per action in the protocol.
const WINDOWS_PER_ACTION: usize = 8;

/// The long help after the options.
const LONG_HELP: &str = "\
The protocol (h36m.md): subject 5, the 8 fixed test windows per action, 50 seed frames at 25 Hz \
and HORIZON predicted frames after them. Four actions (directions, discussion, sittingdown, \
waiting) have no windows because their S5 files are missing from the data release; actions whose \
files are missing are reported and skipped.

Per action it reports, for the model and the zero-velocity baseline (the last seed pose \
repeated, the root held in place: no translation, no turning): the Euler error at 80-1000 ms; NPSS with the paper's |DFT|² and with the published \
code's Re(DFT)² (the variant the papers' tables were computed with) over the whole horizon and \
0-1 s, 1-2 s, 2-4 s; NDMS (database: every motion word of the action's S5 files, exact nearest \
neighbour; queries include the last 7 seed frames; every word is put in the rigid body frame of \
its first frame (hips and shoulders), because positions integrated from H3.6M's root deltas carry an \
arbitrary tilt of the starting frame; mean and 0.4 s bins); APD with 2+ samples; \
and the mean joint speed of the last second vs the ground truth (to catch freezing). Beside them: \
Gopalakrishnan et al. 2019 Tables 4-7 and Tanke et al. 2021 Tables 1-2.

Plausibility without ground truth (motion_metrics::plausibility), per window 0-2, 2-4, 4-8, 8-12 s \
of the horizon, for the model, the zero-velocity baseline and the real S5 continuation (the \
floor and the ceiling): speed_ratio (joint speed in the root frame / the action's S5 mean), \
drift (largest hip height and torso lean change since the last seed frame, beside the p95 over \
real 12 s windows of the action, every subject) and foot_contact (fraction of frames with both \
feet over 100 mm above the seed's lowest foot joint).

Horizons past 100 frames (up to 300 = 12 s, Ghosh et al. 2017's): some S5 files end before the window's \
horizon does. The metrics that need ground truth (Euler error, NPSS) then use the part each file \
covers: the Euler error of a frame is the mean over the windows covering it, NPSS whole is over \
the frames all 8 windows cover, each NPSS window (adding 4-8 s and 8-12 s) over the windows \
covering it; the report gives the windows covering each second. NDMS, APD and the plausibility \
measures of the model and the baseline cover the whole horizon; the real continuation's \
plausibility counts the windows whose file covers each window.

With K samples: the Euler error is the mean over all 8 x K sequences; NPSS scores each sample \
index as a set of 8 windows and averages over the K sets; NDMS is f_sim over all words of all \
8 x K forecasts; APD is per window over its K samples, then the mean over windows.

Examples:
  motion-cli eval --data ../shared/data --actions walking,eating,smoking --samples 5
  motion-cli eval --model weights/vgru_d_multi.safetensors --actions all --json > eval.json
  motion-cli eval --actions walking --save-predictions walking.npy
  motion-cli eval --actions walking,greeting --horizon 300 --samples 5   # 12 s

Exit status 2 for bad input (unknown action, missing data directory, unreadable model).";

/// Arguments of `motion-cli eval`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
pub struct Args {
    /// Data root (holding h3.6m/dataset) or the exp-map dataset directory itself (holding S5/).
    /// Default: $MOTION_DATA_DIR, then ../shared/data.
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Weights file (default: the weights built into this binary).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Comma list of actions, or `all` (every action with test windows that the model may be
    /// evaluated on).
    #[arg(long, value_delimiter = ',', default_value = "all")]
    pub actions: Vec<String>,
    /// Predicted frames per window at 25 Hz (1..=1500; 100 = 4 s, the long-term protocol; 300 =
    /// 12 s, Ghosh et al. 2017's horizon; 1500 = 60 s for the plausibility measures, raw and grounded
    /// side by side; ground-truth metrics use what the S5 files cover).
    #[arg(long, default_value_t = LONG_TERM_HORIZON)]
    pub horizon: usize,
    /// Samples per window (stochastic models draw new noise for each: VGRU-d its plan noise,
    /// the intention model its z).
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub samples: usize,
    /// Seed of the noise; sample k of window w of an action gets its own stream.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub rng_seed: u64,
    /// Write the predictions (actions x 8 x K x horizon x 99, float64, un-normalized exp-map frames).
    #[arg(long, value_name = "FILE.npy")]
    pub save_predictions: Option<PathBuf>,
    /// Action classifier weights for the Ghosh et al. 2017 protocol (default: the built-in
    /// action_classifier.safetensors).
    #[arg(long, value_name = "FILE")]
    pub classifier: Option<PathBuf>,
    /// Skip the action-classifier protocol (no `classifier` keys or rows).
    #[arg(long, conflicts_with = "classifier")]
    pub no_classifier: bool,
    /// Evaluate a single-action model on other actions too.
    #[arg(long)]
    pub any_action: bool,
    #[command(flatten)]
    pub reporting: crate::commands::output::Output,
    /// Also draw metric vs horizon per action (Euler error, NPSS windows, NDMS bins; the
    /// zero-velocity baseline dashed) to FILE.svg or FILE.png.
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub plot: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    if !(1..=MAX_HORIZON_FRAMES).contains(&args.horizon) {
        return Err(UsageError(format!(
            "--horizon must be 1..={MAX_HORIZON_FRAMES} frames (60 s at 25 Hz; the test windows guarantee {LONG_TERM_HORIZON} frames of ground truth, the metrics that need it use what the files cover), got {}",
            args.horizon
        ))
        .into());
    }
    // The predictions of one action (8 windows x samples x horizon x 99 values) are held at
    // once: refused before anything is allocated when they would pass the sample limit.
    motion_core::model::samples::check_sample_size(
        WINDOWS_PER_ACTION.saturating_mul(args.samples),
        args.horizon,
        H36M_FRAME_DIMS,
    )
    .map_err(|e| UsageError(format!("--samples {} x 8 windows: {e}", args.samples)))?;
    if args.samples == 0 {
        return Err(UsageError("--samples must be at least 1".into()).into());
    }
    if let Some(out) = &args.save_predictions {
        if out.extension().and_then(|e| e.to_str()) != Some("npy") {
            return Err(UsageError(format!(
                "--save-predictions {}: the predictions are written as .npy; name the file FILE.npy",
                out.display()
            ))
            .into());
        }
        let inputs: Vec<&std::path::Path> = [&args.model, &args.classifier]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        motion_core::clip::check_not_an_input(out, &inputs)?;
    }
    if let Some(plot) = &args.plot {
        crate::plot::check_extension(plot)?;
    }
    // Cheap checks first: the data and the actions, before the model is built.
    let dataset = selection::resolve_dataset(args.data.as_deref())?;
    let model = model_source::load_model(args.model.as_deref())?;
    check_model(&model)?;
    let classifier = if args.no_classifier {
        None
    } else {
        let classifier = model_source::load_classifier(args.classifier.as_deref())?;
        check_classifier(&classifier)?;
        Some(classifier)
    };
    let selection = selection::select_actions(&args.actions, &model, &dataset, args.any_action)?;

    let samples = args.samples;
    let horizon = args.horizon;
    let mut saver = match &args.save_predictions {
        Some(path) => Some(NpyStream::create(
            path,
            &[
                selection.planned.len(),
                WINDOWS_PER_ACTION,
                samples,
                horizon,
                H36M_FRAME_DIMS,
            ],
        )?),
        None => None,
    };

    let progress = args.reporting.progress_bar(
        (selection.planned.len() * WINDOWS_PER_ACTION) as u64,
        "{bar:30} {pos}/{len} windows {elapsed} {msg}",
    );
    let mut generator = BatchGenerator::new(Arc::clone(&model), WINDOWS_PER_ACTION * samples);
    let mut results = Vec::new();
    for planned in &selection.planned {
        progress.set_message(format!("{}: loading", planned.action));
        let windows = load_action_windows_covered(&dataset, planned.action, horizon)?;
        if windows.len() != WINDOWS_PER_ACTION {
            return Err(anyhow::anyhow!(
                "{}: {} test windows, the protocol has {WINDOWS_PER_ACTION}",
                planned.action,
                windows.len()
            ));
        }
        let references = load_subject_sequences(&dataset, TEST_SUBJECT, planned.action)?;
        let truth = ActionTruth::new(windows, &references, horizon)?;
        drop(references);
        let mut others = Vec::new();
        for subject in SUBJECTS.iter().filter(|&&s| s != TEST_SUBJECT) {
            others.extend(load_subject_sequences(&dataset, subject, planned.action)?);
        }
        let real_motion_ndms = truth.real_motion_ndms(&others)?;
        drop(others);
        let reference = plausibility::reference(&dataset, planned.action)?;

        progress.set_message(format!("{}: predicting", planned.action));
        let predictions = predict(
            &mut generator,
            &truth,
            planned,
            samples,
            horizon,
            args.rng_seed,
        )?;
        if let Some(saver) = saver.as_mut() {
            saver.write(predictions.iter().copied())?;
        }
        progress.set_message(format!("{}: scoring", planned.action));
        let model_scores = truth.score(predictions.view(), || progress.inc(1))?;
        let baseline = truth.zero_velocity();
        let baseline_scores = truth.score(baseline.view(), || {})?;
        // The real continuation of each window after its seed (files may end before the horizon).
        let real_pairs: Vec<_> = truth
            .windows()
            .iter()
            .map(|w| (w.seed.view(), w.ground_truth.view()))
            .collect();
        let mut measured = Plausibility {
            classifier: None,
            model: plausibility_of(&truth, &predictions, &reference, "the model's predictions")?,
            grounded: grounded_plausibility(&truth, &predictions, planned.action, &reference)?,
            zero_velocity: plausibility_of(&truth, &baseline, &reference, "zero-velocity")?,
            real: plausibility::report(
                &plausibility::measure(&real_pairs, planned.action)?,
                horizon,
                &reference,
            ),
        };
        progress.set_message(format!("{}: classifying", planned.action));
        measured.classifier = match &classifier {
            Some(classifier) => Some(Curves {
                model: curve_of(classifier, &truth, &predictions, planned.action)?,
                zero_velocity: curve_of(classifier, &truth, &baseline, planned.action)?,
                real: {
                    classifier_curve_pairs(
                        classifier,
                        &real_pairs,
                        planned.action,
                        protocol_hop(classifier),
                    )
                    .map_err(|e| {
                        UsageError(format!("{}: action classifier: {e}", planned.action))
                    })?
                },
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
        results.push(result);
    }
    progress.finish_and_clear();

    let saved = match (saver, &args.save_predictions) {
        (Some(saver), Some(path)) => {
            saver.finish()?;
            Some(SavedPredictions {
                path: path.display().to_string(),
                shape: [
                    selection.planned.len(),
                    WINDOWS_PER_ACTION,
                    samples,
                    horizon,
                    H36M_FRAME_DIMS,
                ],
                axes: ["action", "window", "sample", "frame", "dim"],
                actions: selection.planned.iter().map(|p| p.action).collect(),
            })
        }
        _ => None,
    };
    let report = full_report(&args, &model, &dataset, &selection, results, saved);
    if let Some(plot) = &args.plot {
        crate::plot::write_charts(plot, &plots::charts(&report.actions), 3)?;
    }
    if args.reporting.json {
        args.reporting.print_json(&report)?;
    } else {
        print!("{}", report::table(&report));
    }
    Ok(())
}

/// `eval` runs the H3.6M protocol: the model must take 99-dim H3.6M frames at 25 Hz.
fn check_model(model: &MotionModel) -> Result<(), UsageError> {
    let config = model.config();
    if config.frame_dims != H36M_FRAME_DIMS {
        return Err(UsageError(format!(
            "{}: the model's frames have {} dims; the H3.6M protocol needs {H36M_FRAME_DIMS}",
            model.path().display(),
            config.frame_dims
        )));
    }
    if (config.fps - H36M_PROTOCOL_FPS).abs() > 1e-9 {
        return Err(UsageError(format!(
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
) -> Result<Array4<f64>> {
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
        .with_context(|| planned.action.to_string())?;
    let mut out = Array4::zeros((windows.len(), samples, horizon, H36M_FRAME_DIMS));
    for t in 0..horizon {
        let frames = generator
            .step()
            .with_context(|| format!("{}: frame {t}", planned.action))?;
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
    action: &str,
) -> Result<ClassifierCurve> {
    let (windows, samples, horizon, dims) = predictions.dim();
    let flat = predictions
        .view()
        .into_shape_with_order((windows * samples, horizon, dims))
        .map_err(|e| anyhow::anyhow!("predictions: {e}"))?;
    let seed_frames = truth.windows()[0].seed.nrows();
    let seeds = Array3::from_shape_fn((windows * samples, seed_frames, dims), |(i, f, d)| {
        truth.windows()[i / samples].seed[[f, d]]
    });
    super::classifier::curve(classifier, Some(seeds.view()), flat, action, action)
}

/// `eval` feeds the classifier 25 Hz H3.6M frames.
fn check_classifier(classifier: &ActionClassifier) -> Result<(), UsageError> {
    let c = classifier.config();
    if c.frame_dims != H36M_FRAME_DIMS || (c.fps - 25.0).abs() > 1e-9 {
        return Err(UsageError(format!(
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
    reference: &motion_metrics::ActionReference,
    what: &str,
) -> Result<PlausibilityReport> {
    let (_, samples, horizon, _) = predictions.dim();
    let pairs: Vec<_> = truth
        .windows()
        .iter()
        .enumerate()
        .flat_map(|(w, window)| {
            (0..samples).map(move |k| (window.seed.view(), predictions.slice(s![w, k, .., ..])))
        })
        .collect();
    Ok(plausibility::report(
        &plausibility::measure(&pairs, what)?,
        horizon,
        reference,
    ))
}

/// The plausibility report of the predictions grounded after their windows' seeds (the seed's
/// floor, levelled; the lean limit of `action`): each window's seed and prediction are grounded
/// as one clip, as `predict` writes it.
fn grounded_plausibility(
    truth: &ActionTruth,
    predictions: &Array4<f64>,
    action: &str,
    reference: &motion_metrics::ActionReference,
) -> Result<PlausibilityReport> {
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
            let spec = ClipSpec::new(
                ExpMapTarget::H36m,
                H36M_PROTOCOL_FPS,
                0..seed_frames,
                Some(action),
                GroundingConfig::default(),
            );
            let clip = ground_expmap_clip(whole.view(), &spec)
                .map_err(|e| UsageError(format!("{action}: grounding: {e}")))?;
            clips.push((clip.frames, seed_frames));
        }
    }
    let pairs: Vec<_> = clips
        .iter()
        .map(|(f, n)| (f.slice(s![..*n, ..]), f.slice(s![*n.., ..])))
        .collect();
    Ok(plausibility::report(
        &plausibility::measure(&pairs, "the grounded predictions")?,
        horizon,
        reference,
    ))
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
    }
}

fn full_report(
    args: &Args,
    model: &MotionModel,
    dataset: &std::path::Path,
    selection: &Selection,
    results: Vec<ActionResult>,
    saved: Option<SavedPredictions>,
) -> EvalReport {
    let config = model.config();
    let stochastic = config.architecture.is_stochastic();
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
        model: ModelInfo {
            source: model_source::describe(args.model.as_deref()),
            architecture: config.architecture.name(),
            hidden: config.hidden,
            actions: config.actions.clone(),
            actions_trained: selection::trained_actions(model),
            stochastic,
            plan_horizon: matches!(model.network(), Network::Vgru(_)).then_some(config.horizon),
            stored_dtype: model.stored_dtype().to_string(),
            note: (!stochastic && args.samples > 1)
                .then_some("deterministic model: the K samples are identical (APD is 0)"),
        },
        data: dataset.display().to_string(),
        protocol: Protocol {
            subject: TEST_SUBJECT,
            fps: H36M_PROTOCOL_FPS,
            seed_frames: SEED_FRAMES,
            horizon: args.horizon,
            windows_per_action: WINDOWS_PER_ACTION,
            samples: args.samples,
            rng_seed: args.rng_seed,
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
    plausibility: "speed_ratio, drift, foot_contact (motion_metrics::plausibility) per window 0-2, 2-4, 4-8, 8-12 s for model (all 8 x K), zero_velocity and ground_truth (the real continuation; each window counts the test windows whose file covers it); speed reference = mean root-frame joint speed over the action's S5 files; drift p95 over real 12 s windows of the action, every subject, seeded by the 50 frames before each",
};
