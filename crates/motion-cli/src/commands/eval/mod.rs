//! `motion-cli eval`: the H3.6M protocol of [`motion_metrics::evaluation`] (a model on subject
//! 5's test windows, scored beside the zero-velocity baseline and the papers' published numbers),
//! printed as a table (`table`), as JSON (`--json`) or drawn (`plots`, `--plot`). Nothing is
//! measured here.
mod mpjpe_table;
mod plots;
mod stochastic_table;
mod table;

use std::path::PathBuf;

use anyhow::Result;

use motion_core::protocol::{WindowSet, LONG_TERM_HORIZON};
use motion_metrics::evaluation::mpjpe::{
    check_mpjpe_request, evaluate_mpjpe, MpjpeOptions, MpjpeWindows,
};
use motion_metrics::evaluation::stochastic::{
    check_stochastic_request, evaluate_stochastic, StochasticOptions, DEFAULT_SAMPLES,
};
use motion_metrics::evaluation::{
    check_request, evaluate, resolve_dataset, EvalError, EvalOptions, Progress,
};
use motion_metrics::multimodal::H36M_MULTIMODAL_THRESHOLD;
use motion_metrics::JointMean;

use super::UsageError;
use crate::model_source::{self, BuiltIn};

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

--protocol mpjpe: the 3-D joint-position error (mm) of LTD, HRI and siMLPe, as their code computes it (motion_metrics::mpjpe, protocols_modern.md): positions by forward kinematics of the exp-map frames with dims 0..5 zeroed (the pelvis frame, one skeleton), the mean over all 32 joints, the error at single frames 80-1000 ms after the last observed one. Windows on S5 from numpy's RandomState(1234567890) drawn as the reference draws them: --windows 256 (HRI and siMLPe, the default), 8 (the Martinez set of LTD's table, the angle protocol's test windows) or all (every window of both takes, --stride frames apart). --input-frames (default 50) frames are observed, 25 predicted. --ltd-sampler places the windows as LTD's loader does (for 10 observed frames whatever --input-frames is). Beside the model: zero-velocity (the last observed pose repeated), HRI's published row per action, and the published 15-action averages of the same set. Four S5 takes are missing from the release here: the average then covers fewer actions and says which.

--protocol stochastic: APD, ADE, FDE, MMADE and MMFDE (motion_metrics::multimodal) in a project variant of DLow's and BeLFusion's protocol on the exp-map release, never comparable with their published numbers: S9 and S11, windows every 25 frames at 50 Hz with 25 observed and 100 future frames, DLow's 16 joints from forward kinematics in the pelvis frame (metres), the multimodal ground truth within 0.5 m of the last observed pose, pooled over all windows. The models run at 25 Hz: each observes its own seed ending at the last observed frame and its 50 predicted frames are scored at the same instants of the future. --samples K per window for stochastic models (default 50), one for deterministic ones and zero-velocity. docs/evaluation.md explains it.

Examples:
  motion-cli eval --data ../shared/data --actions walking,eating,smoking --samples 5
  motion-cli eval --model weights/vgru_d_multi.safetensors --actions all --json > eval.json
  motion-cli eval --actions walking --save-predictions walking.npy
  motion-cli eval --actions walking,greeting --horizon 300 --samples 5   # 12 s
  motion-cli eval --protocol mpjpe --windows 256 --json > mpjpe.json
  motion-cli eval --protocol mpjpe --windows all --stride 5 --actions walking
  motion-cli eval --protocol stochastic --model weights/intention.safetensors --samples 50

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
    /// the intention model its z). Default 1; 50 with --protocol stochastic.
    #[arg(long, value_name = "K")]
    pub samples: Option<usize>,
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
    /// Which protocol: h36m (Euler error, NPSS, NDMS, APD, plausibility, posture, the
    /// classifier), mpjpe (3-D joint-position error of LTD, HRI and siMLPe) or stochastic (APD,
    /// ADE, FDE, MMADE, MMFDE: a project variant of DLow's protocol on the exp-map release).
    #[arg(long, value_enum, default_value = "h36m")]
    pub protocol: ProtocolChoice,
    /// Which S5 windows. h36m: test (the protocol's 8 per action, = 8; the default) or
    /// validation (8 per action overlapping no test window: choose checkpoints and settings on
    /// these). mpjpe: 256 (the default), 8 or all.
    #[arg(long, value_enum)]
    pub windows: Option<Windows>,
    /// With --windows all: frames (25 Hz) between window starts.
    #[arg(long, value_name = "N")]
    pub stride: Option<usize>,
    /// mpjpe: observed frames per window (25 Hz).
    #[arg(long, value_name = "N")]
    pub input_frames: Option<usize>,
    /// mpjpe: place the windows as LTD's loader does (its sampler always gets 10 observed
    /// frames); without it, as HRI and siMLPe do.
    #[arg(long)]
    pub ltd_sampler: bool,
    /// mpjpe: the joints each frame's error averages: 32 (the reference's) or 22 (the predicted
    /// joints only, a variant).
    #[arg(long, value_name = "32|22")]
    pub joints: Option<String>,
    #[command(flatten)]
    pub reporting: crate::commands::output::Output,
    /// Also draw metric vs horizon per action (Euler error, NPSS windows, NDMS bins; the
    /// zero-velocity baseline dashed) to FILE.svg or FILE.png.
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub plot: Option<PathBuf>,
}

/// `--protocol`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ProtocolChoice {
    /// The H3.6M protocol of the seed papers (angles, NDMS, plausibility, posture, classifier).
    H36m,
    /// The 3-D joint-position error of LTD, HRI and siMLPe.
    Mpjpe,
    /// The multi-sample metrics of DLow and BeLFusion, a project variant on the exp-map release.
    Stochastic,
}

/// `--windows`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Windows {
    /// The protocol's test windows.
    Test,
    /// Windows disjoint from the test windows.
    Validation,
    /// The 8-window Martinez set.
    #[value(name = "8")]
    Eight,
    /// HRI's and siMLPe's 256 windows.
    #[value(name = "256")]
    TwoFiftySix,
    /// Every window at --stride.
    All,
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    match args.protocol {
        ProtocolChoice::Mpjpe => return run_mpjpe(args),
        ProtocolChoice::Stochastic => return run_stochastic(args),
        ProtocolChoice::H36m => {}
    }
    refuse_given(
        &[
            (args.stride.is_some(), "--stride"),
            (args.input_frames.is_some(), "--input-frames"),
            (args.ltd_sampler, "--ltd-sampler"),
            (args.joints.is_some(), "--joints"),
        ],
        "belongs to --protocol mpjpe",
    )?;
    let windows = match args.windows {
        None | Some(Windows::Test) | Some(Windows::Eight) => WindowSet::Test,
        Some(Windows::Validation) => WindowSet::Validation,
        Some(other) => {
            return Err(UsageError(format!(
                "--windows {}: the h36m protocol has the 8 test windows per action (test, 8) or the validation windows; 256 and all belong to --protocol mpjpe",
                if other == Windows::All { "all" } else { "256" }
            ))
            .into())
        }
    };
    let samples = args.samples.unwrap_or(1);
    check_request(args.horizon, samples, args.save_predictions.as_deref()).map_err(usage)?;
    if let Some(plot) = &args.plot {
        crate::plot::check_extension(plot)?;
    }
    if let Some(out) = &args.save_predictions {
        let inputs: Vec<&std::path::Path> = [&args.model, &args.classifier]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        motion_core::clip::check_not_an_input(out, &inputs)?;
    }
    // Cheap checks first: the data directory and the options, before the model is built.
    let dataset = resolve_dataset(args.data.as_deref()).map_err(usage)?;
    let model = model_source::load_model(args.model.as_deref(), BuiltIn::Forecast)?;
    let classifier = if args.no_classifier {
        None
    } else {
        Some(model_source::load_classifier(args.classifier.as_deref())?)
    };
    let options = EvalOptions {
        dataset,
        model_name: model_source::describe(args.model.as_deref(), BuiltIn::Forecast),
        actions: args.actions.clone(),
        horizon: args.horizon,
        samples,
        rng_seed: args.rng_seed,
        classifier,
        any_action: args.any_action,
        save_predictions: args.save_predictions.clone(),
        windows,
    };
    let mut bar = None;
    let report = evaluate(&model, &options, &mut |p| match p {
        Progress::Start { actions } => {
            bar = Some(args.reporting.progress_bar(
                (actions * motion_metrics::evaluation::WINDOWS_PER_ACTION) as u64,
                "{bar:30} {pos}/{len} windows {elapsed} {msg}",
            ));
        }
        Progress::Stage { action, stage } => {
            if let Some(b) = &bar {
                b.set_message(format!("{action}: {stage}"));
            }
        }
        Progress::Window => {
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
    })
    .map_err(usage)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(plot) = &args.plot {
        crate::plot::write_charts(plot, &plots::charts(&report.actions), 3)?;
    }
    if args.reporting.json {
        args.reporting.print_json(&report)?;
    } else {
        print!("{}", table::table(&report));
    }
    Ok(())
}

/// `eval --protocol mpjpe`.
fn run_mpjpe(args: Args) -> Result<()> {
    refuse_given(
        &[
            (args.samples.is_some_and(|k| k != 1), "--samples"),
            (args.horizon != LONG_TERM_HORIZON, "--horizon"),
            (args.save_predictions.is_some(), "--save-predictions"),
            (args.plot.is_some(), "--plot"),
        ],
        "belongs to --protocol h36m; mpjpe predicts 25 frames per window, one sample",
    )?;
    let name = args.windows.map(|w| match w {
        Windows::Test => "test",
        Windows::Validation => "validation",
        Windows::Eight => "8",
        Windows::TwoFiftySix => "256",
        Windows::All => "all",
    });
    let windows = MpjpeWindows::parse(name, args.stride).map_err(usage)?;
    let joints = match args.joints.as_deref() {
        None => JointMean::All32,
        Some(name) => JointMean::from_name(name).ok_or_else(|| {
            UsageError(format!("--joints {name}: use 32 (all joints, the reference's) or 22 (the predicted joints)"))
        })?,
    };
    // The options first, then the data directory (cheap checks before anything is looked up).
    let mut options = MpjpeOptions::new(
        PathBuf::new(),
        model_source::describe(args.model.as_deref(), BuiltIn::Forecast),
    );
    options.actions = args.actions.clone();
    options.windows = windows;
    options.input_frames = args.input_frames.unwrap_or(options.input_frames);
    options.sampler_input = args
        .ltd_sampler
        .then_some(motion_core::protocol::sampler::LTD_SAMPLER_INPUT);
    options.joints = joints;
    options.rng_seed = args.rng_seed;
    options.any_action = args.any_action;
    check_mpjpe_request(&options).map_err(usage)?;
    options.dataset = resolve_dataset(args.data.as_deref()).map_err(usage)?;
    let model = model_source::load_model(args.model.as_deref(), BuiltIn::Forecast)?;
    let mut bar = ActionBar::default();
    let report =
        evaluate_mpjpe(&model, &options, &mut |p| bar.hear(&args.reporting, p)).map_err(usage)?;
    bar.finish();
    if args.reporting.json {
        args.reporting.print_json(&report)?;
    } else {
        print!("{}", mpjpe_table::table(&report));
    }
    Ok(())
}

/// `eval --protocol stochastic`.
fn run_stochastic(args: Args) -> Result<()> {
    refuse_given(
        &[
            (args.horizon != LONG_TERM_HORIZON, "--horizon"),
            (args.save_predictions.is_some(), "--save-predictions"),
            (args.plot.is_some(), "--plot"),
            (args.windows.is_some(), "--windows"),
            (args.stride.is_some(), "--stride"),
            (args.input_frames.is_some(), "--input-frames"),
            (args.ltd_sampler, "--ltd-sampler"),
            (args.joints.is_some(), "--joints"),
        ],
        "does not apply to --protocol stochastic (S9 and S11, windows every 25 frames at 50 Hz, 2 s futures)",
    )?;
    let samples = args.samples.unwrap_or(DEFAULT_SAMPLES);
    check_stochastic_request(samples, H36M_MULTIMODAL_THRESHOLD).map_err(usage)?;
    let dataset = resolve_dataset(args.data.as_deref()).map_err(usage)?;
    let mut options = StochasticOptions::new(
        dataset,
        model_source::describe(args.model.as_deref(), BuiltIn::Forecast),
    );
    options.actions = args.actions.clone();
    options.samples = samples;
    options.rng_seed = args.rng_seed;
    options.any_action = args.any_action;
    let model = model_source::load_model(args.model.as_deref(), BuiltIn::Forecast)?;
    let mut bar = ActionBar::default();
    let report = evaluate_stochastic(&model, &options, &mut |p| bar.hear(&args.reporting, p))
        .map_err(usage)?;
    bar.finish();
    if args.reporting.json {
        args.reporting.print_json(&report)?;
    } else {
        print!("{}", stochastic_table::table(&report));
    }
    Ok(())
}

/// Refuses the first option given (`true`) that the chosen protocol does not take: `{option} {why}`.
fn refuse_given(options: &[(bool, &str)], why: &str) -> Result<()> {
    match options.iter().find(|(given, _)| *given) {
        Some((_, name)) => Err(UsageError(format!("{name} {why}")).into()),
        None => Ok(()),
    }
}

/// A progress bar over actions (the MPJPE and stochastic protocols): it moves on when an action
/// starts loading and shows the action's stage.
#[derive(Default)]
struct ActionBar {
    bar: Option<indicatif::ProgressBar>,
    started: u64,
}

impl ActionBar {
    fn hear(&mut self, reporting: &crate::commands::output::Output, progress: Progress) {
        match progress {
            Progress::Start { actions } => {
                self.bar = Some(reporting.progress_bar(
                    actions as u64,
                    "{bar:30} {pos}/{len} actions {elapsed} {msg}",
                ));
            }
            Progress::Stage { action, stage } => {
                if let Some(b) = &self.bar {
                    if stage == "loading" {
                        self.started += 1;
                        b.set_position(self.started - 1);
                    }
                    b.set_message(format!("{action}: {stage}"));
                }
            }
            Progress::Window => {}
        }
    }

    fn finish(self) {
        if let Some(b) = self.bar {
            b.finish_and_clear();
        }
    }
}

/// An evaluation error as the CLI reports it: options, data and weights are the user's to fix
/// (exit 2, [`UsageError`]); failures reading or writing files keep their typed source.
fn usage(e: EvalError) -> anyhow::Error {
    match e {
        EvalError::Invalid(problem) => UsageError(problem).into(),
        other => anyhow::Error::new(other),
    }
}
