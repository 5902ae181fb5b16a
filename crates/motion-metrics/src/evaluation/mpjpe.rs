//! The 3-D joint-position protocol of LTD (Mao et al. 2019), History Repeats Itself (HRI, Mao et al.
//! 2020) and siMLPe (Guo et al. 2023) on the exp-map release (`protocols_modern.md` §1): a model on
//! subject 5's sampled windows, MPJPE (mm, [`crate::mpjpe`]) at 80-1000 ms beside the
//! zero-velocity baseline and the published rows. `motion-cli eval --protocol mpjpe` and Python's
//! `motion.evaluate(protocol="mpjpe")` print or return the same [`MpjpeReport`].
//!
//! ```no_run
//! use std::sync::Arc;
//! use motion_core::model::MotionModel;
//! use motion_metrics::evaluation::mpjpe::{evaluate_mpjpe, MpjpeOptions, MpjpeWindows};
//! use motion_metrics::evaluation::resolve_dataset;
//!
//! let model = Arc::new(MotionModel::load("weights/vgru_d_multi.safetensors")?);
//! let mut options = MpjpeOptions::new(resolve_dataset(None)?, "vgru_d_multi");
//! options.windows = MpjpeWindows::Hri256;
//! let report = evaluate_mpjpe(&model, &options, &mut |_| {})?;
//! println!("{:?}", report.average.model);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Windows: numpy's `RandomState(1234567890)` per action, drawn as the reference draws them
//! ([`motion_core::protocol::sampler`]): the 8-window Martinez set, HRI and siMLPe's 256 windows,
//! or every window of both takes at a stated stride. The model observes `input_frames` 25 Hz
//! exp-map frames (dims 0..5 as in the file) and predicts 25; positions of its prediction and of
//! the truth come from forward kinematics with dims 0..5 zeroed. The per-action value at a horizon
//! is the mean over the action's windows; the average is the plain mean over the actions run, and
//! names them when they are not all 15.
use std::path::PathBuf;
use std::sync::Arc;

use ndarray::{s, Array3, Array4, Axis};
use serde::Serialize;

use motion_core::model::{BatchGenerator, MotionModel, Noise};
use motion_core::protocol::sampler::{
    sample_windows, SampledWindow, HRI_DRAWS, MARTINEZ_DRAWS, PREDICT_OFFSET, SAMPLER_SEED,
};
use motion_core::protocol::{read_take, sequence_file, ACTIONS, TEST_SUBJECT};
use motion_core::skeleton::H36M_FRAME_DIMS;

use super::published::{self, MpjpeRow};
use super::selection::{select_actions_from, WindowSource};
use super::{check_model, noise_seed, EvalError, ModelInfo, Progress};
use crate::mpjpe::{
    h36m_pelvis_positions, mpjpe_batch, JointMean, MPJPE_HORIZONS_MS, MPJPE_HORIZON_FRAMES,
    MPJPE_OUTPUT_FRAMES,
};

/// Frames between window starts of the `all` set when none is given: siMLPe's stride on AMASS and
/// 3DPW.
pub const DEFAULT_STRIDE: usize = 5;

/// Windows scored per model batch (the model runs them side by side).
const BATCH_WINDOWS: usize = 256;

/// Which windows of each action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MpjpeWindows {
    /// 4 draws per take: the Martinez set of LTD's table (the angle protocol's test windows).
    Martinez8,
    /// 128 draws per take: HRI's and siMLPe's 256 windows.
    Hri256,
    /// Every window of both takes whose first observed frame is a multiple of `stride`.
    All {
        /// Frames between window starts (25 Hz).
        stride: usize,
    },
}

impl MpjpeWindows {
    /// The set named `name` (`8`, `256`, `all`; `None`: 256); `stride` goes with `all` only
    /// (default [`DEFAULT_STRIDE`]).
    pub fn parse(name: Option<&str>, stride: Option<usize>) -> Result<MpjpeWindows, EvalError> {
        let windows = match name {
            None | Some("256") => MpjpeWindows::Hri256,
            Some("8") => MpjpeWindows::Martinez8,
            Some("all") => MpjpeWindows::All {
                stride: stride.unwrap_or(DEFAULT_STRIDE),
            },
            Some("validation") => {
                return Err(EvalError::Invalid(
                    "windows `validation`: the MPJPE protocol has test windows only; choose checkpoints with the h36m protocol's validation windows".into(),
                ))
            }
            Some(other) => {
                return Err(EvalError::Invalid(format!(
                    "windows `{other}`: name the MPJPE set: 8 (LTD's Martinez set), 256 (HRI, siMLPe) or all"
                )))
            }
        };
        if stride.is_some() && !matches!(windows, MpjpeWindows::All { .. }) {
            return Err(EvalError::Invalid(
                "a stride goes with the `all` windows".into(),
            ));
        }
        Ok(windows)
    }

    /// The name in reports: `8`, `256` or `all`.
    pub fn name(self) -> &'static str {
        match self {
            MpjpeWindows::Martinez8 => "8",
            MpjpeWindows::Hri256 => "256",
            MpjpeWindows::All { .. } => "all",
        }
    }
}

/// What to evaluate and how.
#[derive(Debug, Clone)]
pub struct MpjpeOptions {
    /// The exp-map dataset directory (the one holding `S5/`).
    pub dataset: PathBuf,
    /// How the report names the model.
    pub model_name: String,
    /// Actions to run, or `["all"]`.
    pub actions: Vec<String>,
    /// The window set.
    pub windows: MpjpeWindows,
    /// Observed 25 Hz frames fed to the model (50 in HRI and siMLPe, 10 in LTD).
    pub input_frames: usize,
    /// The input length the sampler places windows with: `None` = `input_frames` (HRI, siMLPe);
    /// `Some(10)` = LTD's loader, which always passes 10 (its quirk). With 50 observed frames
    /// and LTD's placement the predicted frames start 40 frames later.
    pub sampler_input: Option<usize>,
    /// The joints each frame's error averages.
    pub joints: JointMean,
    /// Seed of the noise of stochastic models (one sample per window).
    pub rng_seed: u64,
    /// Evaluate a single-action model on other actions too.
    pub any_action: bool,
}

impl MpjpeOptions {
    /// Every action, HRI's 256 windows, 50 observed frames, the 32-joint mean, noise seed 0.
    pub fn new(dataset: PathBuf, model_name: impl Into<String>) -> MpjpeOptions {
        MpjpeOptions {
            dataset,
            model_name: model_name.into(),
            actions: vec!["all".into()],
            windows: MpjpeWindows::Hri256,
            input_frames: 50,
            sampler_input: None,
            joints: JointMean::All32,
            rng_seed: 0,
            any_action: false,
        }
    }
}

/// Everything the MPJPE protocol measured, as `--json` prints it.
#[derive(Debug, Clone, Serialize)]
pub struct MpjpeReport {
    /// `mpjpe`.
    pub protocol: &'static str,
    /// The evaluated model.
    pub model: ModelInfo,
    /// The dataset directory.
    pub data: String,
    /// How the windows were chosen.
    pub windows: WindowsInfo,
    /// How each number is computed.
    pub method: MpjpeMethod,
    /// The horizons of every row (ms).
    pub horizons_ms: [u32; 8],
    /// One result per action run.
    pub actions: Vec<MpjpeAction>,
    /// Actions not run, and why.
    pub skipped: Vec<super::report::Skipped>,
    /// The mean over the actions run.
    pub average: MpjpeAverage,
    /// The published rows (15-action averages unless said), for the set they were measured on.
    pub published: Vec<PublishedMpjpe>,
}

/// How the windows were chosen.
#[derive(Debug, Clone, Serialize)]
pub struct WindowsInfo {
    /// `8`, `256` or `all`.
    pub set: &'static str,
    /// The test subject.
    pub subject: &'static str,
    /// Observed frames per window (25 Hz).
    pub input_frames: usize,
    /// Predicted frames per window (25 Hz).
    pub output_frames: usize,
    /// The input length the sampler placed the windows with (`null` for `all`).
    pub sampler_input: Option<usize>,
    /// The sampler's seed (`null` for `all`).
    pub sampler_seed: Option<u32>,
    /// Draws per take (`null` for `all`).
    pub draws_per_take: Option<usize>,
    /// Frames between window starts (`all` only).
    pub stride: Option<usize>,
}

/// How each number is computed, in words.
#[derive(Debug, Clone, Serialize)]
pub struct MpjpeMethod {
    /// Where the positions come from.
    pub positions: &'static str,
    /// The joints averaged.
    pub joint_mean: &'static str,
    /// The horizons.
    pub horizons: &'static str,
    /// The zero-velocity baseline.
    pub zero_velocity: &'static str,
    /// Stochastic models.
    pub samples: &'static str,
}

/// The results of one action.
#[derive(Debug, Clone, Serialize)]
pub struct MpjpeAction {
    /// The action.
    pub action: &'static str,
    /// The conditioning label (`null` for unconditioned models).
    pub label: Option<String>,
    /// Windows evaluated (duplicates kept).
    pub windows: usize,
    /// Where each window starts: `[subaction, first observed frame at 25 Hz]` of the S5 take, in
    /// the reference's draw order.
    pub window_starts: Vec<(u8, usize)>,
    /// The model's MPJPE at each horizon (mm).
    pub model: [f64; 8],
    /// The zero-velocity baseline's (mm).
    pub zero_velocity: [f64; 8],
    /// The model's MPJPE at each of the 25 predicted frames (mm).
    pub model_per_frame: Vec<f64>,
    /// The zero-velocity baseline's at each predicted frame (mm).
    pub zero_velocity_per_frame: Vec<f64>,
    /// HRI's released model on the 256-set for this action (`null` if not published or not the
    /// same window set).
    pub published_hri: Option<[f64; 8]>,
}

/// The mean over the actions run.
#[derive(Debug, Clone, Serialize)]
pub struct MpjpeAverage {
    /// The actions averaged.
    pub actions: Vec<&'static str>,
    /// `mean over 15 actions`, or which ones are missing.
    pub label: String,
    /// The model's (mm).
    pub model: [f64; 8],
    /// The zero-velocity baseline's (mm).
    pub zero_velocity: [f64; 8],
}

/// One published row beside the report.
#[derive(Debug, Clone, Serialize)]
pub struct PublishedMpjpe {
    /// The method and set, as the source names them.
    pub method: &'static str,
    /// `8` or `256`.
    pub set: &'static str,
    /// One value per horizon of [`MPJPE_HORIZONS_MS`] (`null` where none is published).
    pub values: [Option<f64>; 8],
    /// Where the number comes from.
    pub source: &'static str,
    /// Whether the row averages the same actions as this report's average.
    pub same_actions: bool,
}

/// Checks the options before anything is read.
pub fn check_mpjpe_request(options: &MpjpeOptions) -> Result<(), EvalError> {
    let limit = PREDICT_OFFSET + motion_core::protocol::sampler::LOWEST_DRAW;
    if !(1..=limit).contains(&options.input_frames) {
        return Err(EvalError::Invalid(format!(
            "--input-frames must be 1..={limit} (the sampler places the first observed frame at draw + 50 - input, draws start at 16), got {}",
            options.input_frames
        )));
    }
    if let Some(n) = options.sampler_input {
        if !(1..=limit).contains(&n) {
            return Err(EvalError::Invalid(format!(
                "the sampler's input length must be 1..={limit}, got {n}"
            )));
        }
    }
    if let MpjpeWindows::All { stride } = options.windows {
        if stride == 0 {
            return Err(EvalError::Invalid("--stride must be at least 1".into()));
        }
    }
    Ok(())
}

/// Runs `model` on the MPJPE protocol's windows of the selected actions.
pub fn evaluate_mpjpe(
    model: &Arc<MotionModel>,
    options: &MpjpeOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<MpjpeReport, EvalError> {
    check_mpjpe_request(options)?;
    check_model(model)?;
    let selection = select_actions_from(
        &options.actions,
        model,
        &options.dataset,
        options.any_action,
        WindowSource::BothTakes,
    )?;
    progress(Progress::Start {
        actions: selection.planned.len(),
    });
    let mut generator = BatchGenerator::new(Arc::clone(model), 1);
    let mut actions = Vec::new();
    for planned in &selection.planned {
        let action = planned.action;
        progress(Progress::Stage {
            action,
            stage: "loading",
        });
        let mut takes = Vec::new();
        for sub in [1u8, 2] {
            let path = sequence_file(&options.dataset, TEST_SUBJECT, action, sub);
            let take = read_take(&path)?;
            let positions =
                h36m_pelvis_positions(take.frames.view()).map_err(|source| EvalError::Metric {
                    what: path.display().to_string(),
                    source,
                })?;
            takes.push((path, take.frames, positions));
        }
        let windows = windows_of(options, takes[0].1.nrows(), takes[1].1.nrows()).map_err(|e| {
            EvalError::Invalid(format!(
                "{action} ({}, {}): {e}",
                takes[0].0.display(),
                takes[1].0.display()
            ))
        })?;
        progress(Progress::Stage {
            action,
            stage: "predicting",
        });
        let action_index = ACTIONS.iter().position(|a| *a == action).unwrap_or(0);
        let mut model_sum = vec![0.0; MPJPE_OUTPUT_FRAMES];
        let mut zero_sum = vec![0.0; MPJPE_OUTPUT_FRAMES];
        for (chunk_index, chunk) in windows.chunks(BATCH_WINDOWS).enumerate() {
            let n = chunk.len();
            let input = options.input_frames;
            let seeds = Array3::from_shape_fn((n, input, H36M_FRAME_DIMS), |(w, t, d)| {
                let window = &chunk[w];
                takes[usize::from(window.subaction - 1)].1[[window.seed_start + t, d]]
            });
            let truth = Array4::from_shape_fn((n, MPJPE_OUTPUT_FRAMES, 32, 3), |(w, t, j, c)| {
                let window = &chunk[w];
                takes[usize::from(window.subaction - 1)].2[[window.predict_start + t, j, c]]
            });
            let zero = Array4::from_shape_fn((n, MPJPE_OUTPUT_FRAMES, 32, 3), |(w, _, j, c)| {
                let window = &chunk[w];
                takes[usize::from(window.subaction - 1)].2[[window.predict_start - 1, j, c]]
            });
            let predicted = predict_chunk(
                &mut generator,
                seeds,
                planned.label.as_deref(),
                (0..n)
                    .map(|w| {
                        noise_seed(
                            options.rng_seed,
                            action_index,
                            chunk_index * BATCH_WINDOWS + w,
                            0,
                        )
                    })
                    .collect(),
                action,
                MPJPE_OUTPUT_FRAMES,
            )?;
            let metric = |what: &str, source| EvalError::Metric {
                what: format!("{action}: {what}"),
                source,
            };
            let model_errors = mpjpe_batch(predicted.view(), truth.view(), options.joints)
                .map_err(|e| metric("the model's prediction", e))?;
            let zero_errors = mpjpe_batch(zero.view(), truth.view(), options.joints)
                .map_err(|e| metric("zero-velocity", e))?;
            for (sum, errors) in [(&mut model_sum, model_errors), (&mut zero_sum, zero_errors)] {
                for (s, v) in sum.iter_mut().zip(errors.sum_axis(Axis(0))) {
                    *s += v;
                }
            }
            for _ in 0..n {
                progress(Progress::Window);
            }
        }
        let count = windows.len() as f64;
        let model_per_frame: Vec<f64> = model_sum.iter().map(|v| v / count).collect();
        let zero_velocity_per_frame: Vec<f64> = zero_sum.iter().map(|v| v / count).collect();
        actions.push(MpjpeAction {
            action,
            label: planned.label.clone(),
            windows: windows.len(),
            window_starts: windows
                .iter()
                .map(|w| (w.subaction, w.seed_start))
                .collect(),
            model: MPJPE_HORIZON_FRAMES.map(|f| model_per_frame[f]),
            zero_velocity: MPJPE_HORIZON_FRAMES.map(|f| zero_velocity_per_frame[f]),
            model_per_frame,
            zero_velocity_per_frame,
            published_hri: match options.windows {
                MpjpeWindows::Hri256 => published::hri_256_action(action),
                _ => None,
            },
        });
    }
    let average = average_of(&actions);
    let same_actions = average.actions.len() == ACTIONS.len();
    Ok(MpjpeReport {
        protocol: "mpjpe",
        model: super::model_info(model, options.model_name.clone(), 1),
        data: options.dataset.display().to_string(),
        windows: windows_info(options),
        method: MpjpeMethod {
            positions: "exp-map release (not D3_Positions): forward kinematics of the 25 Hz frames with dims 0..5 (root translation and rotation) set to zero, one skeleton for every subject, mm (the pelvis frame of LTD, HRI and siMLPe)",
            joint_mean: match options.joints {
                JointMean::All32 => "all-32: the mean over all 32 joints, as LTD, HRI and siMLPe compute it (the four constant joints count as zero, the six joints on another joint repeat it)",
                JointMean::Predicted22 => "predicted-22: the mean over the 22 joints the reference models predict (a variant, not the published convention)",
            },
            horizons: "the error at one predicted frame (80 ms = frame 2 of 25), not a mean up to it; per action the mean over its windows; the average the plain mean over the actions run",
            zero_velocity: "the last observed pose repeated",
            samples: "one sample per window; a stochastic model draws its noise from --rng-seed, window by window",
        },
        horizons_ms: MPJPE_HORIZONS_MS,
        actions,
        skipped: selection
            .skipped
            .iter()
            .map(|(action, reason)| super::report::Skipped {
                action,
                reason: reason.clone(),
            })
            .collect(),
        average,
        published: published::MPJPE_ROWS
            .iter()
            .filter(|row| row.set == options.windows.name())
            .map(|row: &MpjpeRow| PublishedMpjpe {
                method: row.method,
                set: row.set,
                values: row.values,
                source: row.source,
                same_actions,
            })
            .collect(),
    })
}

/// The windows of one action, from takes of `frames_1` and `frames_2` 25 Hz frames.
pub fn windows_of(
    options: &MpjpeOptions,
    frames_1: usize,
    frames_2: usize,
) -> Result<Vec<SampledWindow>, String> {
    let input = options.input_frames;
    let draws = match options.windows {
        MpjpeWindows::Martinez8 => MARTINEZ_DRAWS,
        MpjpeWindows::Hri256 => HRI_DRAWS,
        MpjpeWindows::All { stride } => {
            let mut out = Vec::new();
            for (sub, frames) in [(1u8, frames_1), (2, frames_2)] {
                let last = frames.checked_sub(input + MPJPE_OUTPUT_FRAMES);
                for (draw, seed_start) in (0..=last.unwrap_or(0))
                    .step_by(stride)
                    .enumerate()
                    .take_while(|_| last.is_some())
                {
                    out.push(SampledWindow {
                        subaction: sub,
                        draw,
                        seed_start,
                        predict_start: seed_start + input,
                    });
                }
            }
            return if out.is_empty() {
                Err(format!(
                    "the takes ({frames_1} and {frames_2} frames at 25 Hz) hold no window of {input} + {MPJPE_OUTPUT_FRAMES} frames"
                ))
            } else {
                Ok(out)
            };
        }
    };
    let placed_with = options.sampler_input.unwrap_or(input);
    let mut windows =
        sample_windows(frames_1, frames_2, draws, placed_with).map_err(|e| e.to_string())?;
    for w in &mut windows {
        // The sampler's window is `placed_with` observed frames then the prediction; LTD's
        // quirk observes `input` frames from the same first frame.
        w.predict_start = w.seed_start + input;
    }
    Ok(windows)
}

fn windows_info(options: &MpjpeOptions) -> WindowsInfo {
    let (sampled, stride) = match options.windows {
        MpjpeWindows::Martinez8 => (Some(MARTINEZ_DRAWS), None),
        MpjpeWindows::Hri256 => (Some(HRI_DRAWS), None),
        MpjpeWindows::All { stride } => (None, Some(stride)),
    };
    WindowsInfo {
        set: options.windows.name(),
        subject: TEST_SUBJECT,
        input_frames: options.input_frames,
        output_frames: MPJPE_OUTPUT_FRAMES,
        sampler_input: sampled.map(|_| options.sampler_input.unwrap_or(options.input_frames)),
        sampler_seed: sampled.map(|_| SAMPLER_SEED),
        draws_per_take: sampled,
        stride,
    }
}

/// Runs the model on a chunk of seeds for `frames` steps: `n x frames x 32 x 3` pelvis-frame
/// positions of its prediction ([`h36m_pelvis_positions`]).
pub(super) fn predict_chunk(
    generator: &mut BatchGenerator,
    seeds: Array3<f64>,
    label: Option<&str>,
    noise_seeds: Vec<u64>,
    action: &'static str,
    frames_out: usize,
) -> Result<Array4<f64>, EvalError> {
    let n = seeds.dim().0;
    if generator.batch() != n {
        *generator = BatchGenerator::new(Arc::clone(generator.model()), n);
    }
    let noise: Vec<Noise<'_>> = noise_seeds.into_iter().map(Noise::Seed).collect();
    let labels: Vec<&str> = label.into_iter().collect();
    let generate = |source| EvalError::Generate { action, source };
    generator
        .start(seeds.view(), &labels, &noise)
        .map_err(generate)?;
    let mut frames = Array3::zeros((n, frames_out, H36M_FRAME_DIMS));
    for t in 0..frames_out {
        let step = generator.step().map_err(generate)?;
        for (w, frame) in step.outer_iter().enumerate() {
            frames
                .slice_mut(s![w, t, ..])
                .iter_mut()
                .zip(frame.iter())
                .for_each(|(o, v)| *o = f64::from(*v));
        }
    }
    let mut out = Array4::zeros((n, frames_out, 32, 3));
    for w in 0..n {
        let positions = h36m_pelvis_positions(frames.index_axis(Axis(0), w)).map_err(|source| {
            EvalError::Metric {
                what: format!("{action}: the model's prediction"),
                source,
            }
        })?;
        out.index_axis_mut(Axis(0), w).assign(&positions);
    }
    Ok(out)
}

fn average_of(actions: &[MpjpeAction]) -> MpjpeAverage {
    let n = actions.len().max(1) as f64;
    let mean = |f: fn(&MpjpeAction) -> [f64; 8]| {
        let mut out = [0.0; 8];
        for a in actions {
            for (o, v) in out.iter_mut().zip(f(a)) {
                *o += v / n;
            }
        }
        out
    };
    let names: Vec<&'static str> = actions.iter().map(|a| a.action).collect();
    let missing: Vec<&str> = ACTIONS
        .iter()
        .copied()
        .filter(|a| !names.contains(a))
        .collect();
    let label = if missing.is_empty() {
        format!("mean over all {} actions", ACTIONS.len())
    } else {
        format!(
            "mean over {} of {} actions (without {}): not comparable with a 15-action average",
            names.len(),
            ACTIONS.len(),
            missing.join(", ")
        )
    };
    MpjpeAverage {
        actions: names,
        label,
        model: mean(|a| a.model),
        zero_velocity: mean(|a| a.zero_velocity),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(windows: MpjpeWindows) -> MpjpeOptions {
        let mut o = MpjpeOptions::new(PathBuf::from("."), "test");
        o.windows = windows;
        o
    }

    #[test]
    fn the_sets_have_their_sizes_and_the_ltd_quirk_moves_the_prediction() {
        let hri = windows_of(&options(MpjpeWindows::Hri256), 1638, 1166).unwrap();
        assert_eq!(hri.len(), 256);
        let mut ltd = options(MpjpeWindows::Martinez8);
        ltd.sampler_input = Some(10);
        let quirk = windows_of(&ltd, 1638, 1166).unwrap();
        let plain = windows_of(&options(MpjpeWindows::Martinez8), 1638, 1166).unwrap();
        for (q, p) in quirk.iter().zip(&plain) {
            assert_eq!(q.seed_start, p.seed_start + 40);
            assert_eq!(q.predict_start, p.predict_start + 40);
        }
        let all = windows_of(&options(MpjpeWindows::All { stride: 10 }), 100, 75).unwrap();
        // Take 1: starts 0, 10, 20 (<= 25); take 2: start 0 only.
        let starts: Vec<(u8, usize)> = all.iter().map(|w| (w.subaction, w.seed_start)).collect();
        assert_eq!(starts, vec![(1, 0), (1, 10), (1, 20), (2, 0)]);
        assert!(windows_of(&options(MpjpeWindows::All { stride: 10 }), 60, 70).is_err());
    }

    #[test]
    fn bad_options_are_refused() {
        let mut o = options(MpjpeWindows::Hri256);
        o.input_frames = 0;
        assert!(check_mpjpe_request(&o).is_err());
        o.input_frames = 67;
        assert!(check_mpjpe_request(&o).is_err());
        o.input_frames = 50;
        o.sampler_input = Some(10);
        assert!(
            check_mpjpe_request(&o).is_ok(),
            "LTD's placement with 50 observed frames"
        );
        o.sampler_input = Some(67);
        assert!(check_mpjpe_request(&o).is_err());
        assert!(check_mpjpe_request(&options(MpjpeWindows::All { stride: 0 })).is_err());
    }
}
