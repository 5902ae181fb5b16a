//! `motion-cli eval`: the H3.6M protocol of [`motion_metrics::evaluation`] (a model on subject
//! 5's test windows, scored beside the zero-velocity baseline and the papers' published numbers),
//! printed as a table (`table`), as JSON (`--json`) or drawn (`plots`, `--plot`). Nothing is
//! measured here.
mod plots;
mod table;

use std::path::PathBuf;

use anyhow::Result;

use motion_core::protocol::{WindowSet, LONG_TERM_HORIZON};
use motion_metrics::evaluation::{
    check_request, evaluate, resolve_dataset, EvalError, EvalOptions, Progress,
};

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
    /// Which S5 windows: the protocol's 8 test windows per action (report these), or 8
    /// validation windows per action that overlap no test window (choose checkpoints and settings
    /// on these, the same windows as training/data.py's validation set).
    #[arg(long, value_enum, default_value = "test")]
    pub windows: Windows,
    #[command(flatten)]
    pub reporting: crate::commands::output::Output,
    /// Also draw metric vs horizon per action (Euler error, NPSS windows, NDMS bins; the
    /// zero-velocity baseline dashed) to FILE.svg or FILE.png.
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub plot: Option<PathBuf>,
}

/// `--windows`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Windows {
    /// The protocol's test windows.
    Test,
    /// Windows disjoint from the test windows.
    Validation,
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    check_request(args.horizon, args.samples, args.save_predictions.as_deref()).map_err(usage)?;
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
        samples: args.samples,
        rng_seed: args.rng_seed,
        classifier,
        any_action: args.any_action,
        save_predictions: args.save_predictions.clone(),
        windows: match args.windows {
            Windows::Test => WindowSet::Test,
            Windows::Validation => WindowSet::Validation,
        },
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

/// An evaluation error as the CLI reports it: options, data and weights are the user's to fix
/// (exit 2, [`UsageError`]); failures reading or writing files keep their typed source.
fn usage(e: EvalError) -> anyhow::Error {
    match e {
        EvalError::Invalid(problem) => UsageError(problem).into(),
        other => anyhow::Error::new(other),
    }
}
