//! `motion-cli score`: NPSS (paper definition and the published code's variant), the protocol's
//! Euler error, NDMS and APD of predictions, from `.npy` arrays, exp-map text files or BVH files
//! (or folders of them).
//!
//! The run is load ([`load`]: read and classify the inputs) → compute ([`compute`]: the metrics
//! into one typed [`report::ScoreReport`]) → report ([`report`]: the JSON, the table and the plots all
//! read that report).
//!
//! Inputs are read into `sequences x samples x frames x width` (samples = 1 for plain
//! sequences). In the exp-map space (the default for 99- and 117-dim data) NPSS and the Euler
//! error use the protocol's Euler sequences and NDMS/APD use FK positions; in the raw space the
//! numbers are used as given (positions `N x T x J x 3` for NDMS).
mod compute;
mod load;
pub mod report;

use std::path::PathBuf;

use anyhow::Result;
use motion_metrics::MetricError;
use serde::Serialize;

use super::UsageError;

/// How the numbers of the inputs are read.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum InputSpace {
    /// Exp-map frames: Euler conversion for NPSS/Euler, FK positions for NDMS/APD.
    Expmap,
    /// As given: NPSS/Euler on the numbers, NDMS on positions `N x T x J x 3`.
    Raw,
}

impl InputSpace {
    /// The name in reports: `expmap` or `raw`.
    pub fn name(self) -> &'static str {
        match self {
            InputSpace::Expmap => "expmap",
            InputSpace::Raw => "raw",
        }
    }
}

/// The exact nearest-neighbour strategy of NDMS.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum NnChoice {
    /// Blocked brute force as matrix products, exact re-checks.
    BruteForce,
    /// kd-tree over a PCA projection, exact re-ranking.
    PcaKdTree,
    /// Scan of mean-pose lower bounds, exact re-ranking.
    PoseBound,
}

/// The long help after the options.
const LONG_HELP: &str = "\
The action-classifier protocol of Ghosh et al. 2017 (--metric classifier --action NAME; definition in \
motion_metrics::classifier): a recurrent classifier of 2 s windows (the built-in \
action_classifier.safetensors, or --classifier FILE) slides over each prediction, windows ending \
every second after the seed (the first windows take the seed's last frames when --seed is given, \
else the first window ends at 2 s); per window end it reports the mean probability of NAME and the \
fraction of predictions classified as NAME (top-1). Real motion keeps it high; motion that \
freezes or degrades loses it. Frames: H3.6M 99-dim exp-map at 25 Hz.

Plausibility without ground truth (--action NAME, --seed, H3.6M 99-dim exp-map frames at 25 Hz; \
definitions in motion_metrics::plausibility), per window 0-2, 2-4, 4-8, 8-12 s after the seed \
(cut at the horizon):
  speed_ratio   mean joint speed in the root frame / the action's mean over its S5 files;
  drift         largest hip height change (mm) and torso lean change (Hips->Neck, degrees from \
vertical) since the seed's last frame, root integrated over seed + prediction; beside it the 95th \
percentile over real 12 s windows of the action (every subject) and the fraction of sequences \
within it;
  foot_contact  fraction of frames with both feet (ankle and toe joints) more than 100 mm above \
the seed's lowest foot joint.
Posture realism (--metric posture --action NAME, H3.6M exp-map frames at 25 Hz; definitions in \
motion_metrics::posture): per window after the seed (0-2, 2-4, 4-8, 8-12, 12-20 ... 50-60 s, cut at \
the horizon), the Fréchet distance of body-frame pose features, the upper-arm and thigh elevation \
histograms' EMD and the share of frames with an upper arm above the real p99, against the action's \
takes of S1, S6-S9, S11 (from frame 50); beside them the real-vs-real values of the test subject \
S5's takes. --seed or --seed-frames places the windows after the seed (else from the first frame).
The reference statistics are read from the H3.6M data (--data, $MOTION_DATA_DIR, ../shared/data). \
The seed gives the drift's starting frame and the floor of foot_contact: --seed holds one \
sequence (N x T_s x 99) per --pred sequence, e.g. the 50 frames `predict` was seeded with.

MPJPE (--metric mpjpe; motion_metrics::mpjpe): the mean over joints of the 3-D distance (mm), per predicted frame, averaged over sequences, and at 80-1000 ms when there are 25 frames at 25 Hz. Exp-map frames (N x T x 99) are put in the pelvis frame first (forward kinematics with dims 0..5 zeroed, as LTD, HRI and siMLPe do); raw positions (N x T x J x 3, or N x T x 3J) are used as given. A prediction of the 22 joints the reference models predict (N x T x 66) against 32-joint ground truth (N x T x 96) is completed from the truth the reference's way.

The multi-sample metrics of DLow and BeLFusion (--metric multimodal; motion_metrics::multimodal): --pred holds K samples per window (N x K x T x D), --gt the real futures (N x T x D), --seed the observed frames (N x T_s x D; its last frame is the last observed pose). On the numbers as given (--input-space raw; e.g. 16 root-relative joints x 3 in metres as DLow uses): APD (mean distance over pairs of samples), ADE and FDE (the best sample's mean and last-frame distance), MMADE and MMFDE (the same against the futures of every window whose last observed pose lies within --multimodal-threshold, default 0.5), each distance the norm of the whole pose vector, then the mean over windows.

Examples:
  motion-cli score --gt gt.npy --pred pred.npy --metric npss,euler --json
  motion-cli score --gt gt.npy --pred pred.npy --metric mpjpe
  motion-cli score --pred pred.npy --seed seed.npy --action walking --metric classifier --plot walking.svg
  motion-cli score --pred pred.npy --seed seed.npy --action walking --metric speed_ratio,drift,foot_contact
  motion-cli score --pred pred.bvh --seed-frames 50 --action walking --metric posture
  motion-cli score --pred pred.npy --seed seed.npy --db S5/walking_1.txt.gz --action walking   # all

Exit status 2 for bad input (unreadable file, shapes, unknown action or metric, missing data).";

/// Arguments of `motion-cli score`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
pub struct Args {
    /// Ground truth: .npy (N x T x D), exp-map text (.txt/.txt.gz) or BVH files, or folders of them.
    #[arg(long, num_args = 1..)]
    pub gt: Vec<PathBuf>,
    /// Predictions, as --gt; for APD samples N x S x T x D (.npy). Used at their own frame rate:
    /// NDMS words are κ = 8 frames at 25 Hz, so give 25 Hz frames.
    #[arg(long, required = true, num_args = 1..)]
    pub pred: Vec<PathBuf>,
    /// Comma list of npss, npss-reference, euler, mpjpe, multimodal, ndms, apd, classifier,
    /// speed_ratio, drift, foot_contact, posture, or all (= every metric the inputs allow; classifier when --action is
    /// given, posture when --action is and the H3.6M data is found, speed_ratio, drift and
    /// foot_contact when --action and --seed are).
    #[arg(
        long,
        value_enum,
        default_value = "all",
        value_delimiter = ',',
        ignore_case = true
    )]
    pub metric: Vec<Metric>,
    /// NDMS reference sequences (the word database). Exp-map text files are taken as the dataset's
    /// 50 Hz files and downsampled to the protocol's 25 Hz; .npy and BVH are used at their rate.
    #[arg(long, num_args = 1..)]
    pub db: Vec<PathBuf>,
    /// Observed frames before each prediction (N x T_s x D): NDMS then prepends their last κ-1
    /// frames so that the first word straddles the seam; drift starts from their last frame and
    /// foot_contact's floor is their lowest foot joint (both need it).
    /// A BVH prediction after a BVH seed is read as its continuation (root motion from the
    /// seed's last pose) and must be in the seed's frame: `predict` writes its output in the
    /// seed's floor frame, so score a `predict` output with --seed-frames instead.
    #[arg(long, num_args = 1.., conflicts_with = "seed_frames")]
    pub seed: Vec<PathBuf>,
    /// The first N frames of each --pred file are its seed and the rest its prediction: what
    /// `predict` writes without --prediction-only (the seed, moved into its floor frame, then
    /// the continuation in the same frame), e.g. `--seed-frames 50` for the shipped models.
    #[arg(long, value_name = "N")]
    pub seed_frames: Option<usize>,
    /// The action the predictions should show (H3.6M name): speed_ratio and drift compare them
    /// with that action's real data.
    #[arg(long, value_name = "NAME")]
    pub action: Option<String>,
    /// Action classifier weights for --metric classifier (default: the built-in
    /// action_classifier.safetensors, Ghosh et al. 2017's protocol).
    #[arg(long, value_name = "FILE")]
    pub classifier: Option<PathBuf>,
    /// H3.6M data root (holding h3.6m/dataset) for the reference statistics of --action.
    /// Default: $MOTION_DATA_DIR, then ../shared/data.
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// How to read the numbers (default: expmap for 99- and 117-dim data, raw otherwise). NDMS
    /// words of H3.6M exp-maps use a rigid body frame (FK of integrated root deltas is tilted);
    /// raw positions (4-D, N x T x J x 3) are taken as gravity-aligned, y up (metrics.md's recipe).
    #[arg(long, value_enum)]
    pub input_space: Option<InputSpace>,
    /// --metric multimodal: the distance between last observed poses under which windows share
    /// their futures as multimodal ground truth (DLow's and BeLFusion's 0.5 on H3.6M, metres).
    #[arg(long, value_name = "D", default_value_t = motion_metrics::multimodal::H36M_MULTIMODAL_THRESHOLD)]
    pub multimodal_threshold: f64,
    /// NDMS nearest-neighbour search (all exact; the pose-bound scan is fastest on motion words).
    #[arg(long, value_enum, default_value = "pose-bound")]
    pub nn: NnChoice,
    /// A BVH whose hierarchy names the joints of raw positions (N x T x J x 3) that are not on the
    /// 32-joint H3.6M skeleton: NDMS finds its joints by the H3.6M names (LeftHand, RightHand,
    /// LeftForeArm, ..., LeftUpLeg, RightUpLeg, LeftLeg, RightLeg, LeftFoot, RightFoot).
    #[arg(long, value_name = "FILE.bvh")]
    pub skeleton: Option<PathBuf>,
    #[command(flatten)]
    pub reporting: super::output::Output,
    /// Also draw the per-horizon results (Euler error per frame, NPSS windows, NDMS 0.4 s bins;
    /// 25 Hz time axis) to FILE.svg or FILE.png.
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub plot: Option<PathBuf>,
}

/// A metric of `--metric` (a clap value enum: the names below, `-` or `_` alike).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    /// NPSS with the paper's |DFT|² power.
    Npss,
    /// NPSS with the published code's Re(DFT)².
    #[value(name = "npss-reference", alias = "npss_reference")]
    NpssReference,
    /// The H3.6M protocol's Euler-angle error.
    Euler,
    /// NDMS against --db.
    Ndms,
    /// Average pairwise distance of samples.
    Apd,
    /// Ghosh et al. 2017's action-classifier probability.
    Classifier,
    /// Joint speed against the action's real data.
    #[value(name = "speed_ratio", alias = "speed-ratio")]
    SpeedRatio,
    /// Hip height and torso lean change since the seed.
    Drift,
    /// Fraction of frames with both feet off the floor.
    #[value(name = "foot_contact", alias = "foot-contact")]
    FootContact,
    /// Posture realism against the action's real takes (motion_metrics::posture).
    Posture,
    /// 3-D joint-position error (mm) of LTD, HRI and siMLPe (motion_metrics::mpjpe).
    Mpjpe,
    /// APD, ADE, FDE, MMADE and MMFDE of sample sets (DLow, BeLFusion; motion_metrics::multimodal).
    Multimodal,
    /// Every metric the inputs allow.
    All,
}

const ALL_METRICS: [Metric; 12] = [
    Metric::Npss,
    Metric::NpssReference,
    Metric::Euler,
    Metric::Ndms,
    Metric::Apd,
    Metric::Classifier,
    Metric::SpeedRatio,
    Metric::Drift,
    Metric::FootContact,
    Metric::Posture,
    Metric::Mpjpe,
    Metric::Multimodal,
];

impl Metric {
    fn name(self) -> &'static str {
        match self {
            Metric::Npss => "npss",
            Metric::NpssReference => "npss-reference",
            Metric::Euler => "euler",
            Metric::Ndms => "ndms",
            Metric::Apd => "apd",
            Metric::Classifier => "classifier",
            Metric::SpeedRatio => "speed_ratio",
            Metric::Drift => "drift",
            Metric::FootContact => "foot_contact",
            Metric::Posture => "posture",
            Metric::Mpjpe => "mpjpe",
            Metric::Multimodal => "multimodal",
            Metric::All => "all",
        }
    }

    /// Measured against the action's real data from the seed (no ground truth).
    fn is_plausibility(self) -> bool {
        matches!(
            self,
            Metric::SpeedRatio | Metric::Drift | Metric::FootContact
        )
    }
}

fn usage(message: impl Into<String>) -> anyhow::Error {
    UsageError(message.into()).into()
}

fn metric_error(what: &str, err: MetricError) -> anyhow::Error {
    usage(format!("{what}: {err}"))
}

/// Runs the command: load → compute → report.
pub fn run(args: Args) -> Result<()> {
    if let Some(plot) = &args.plot {
        crate::plot::check_extension(plot)?;
    }
    let requested = parse_metrics(&args.metric)?;
    let action = args
        .action
        .as_deref()
        .map(super::plausibility::known_action)
        .transpose()?;
    let inputs = load::inputs(&args)?;
    let metrics = chosen_metrics(&args, requested, action, &inputs)?;
    let report = compute::compute(&args, &metrics, action, &inputs)?;
    drop(inputs);

    if let Some(plot) = &args.plot {
        let charts = report::charts(&report);
        if charts.is_empty() {
            return Err(UsageError(format!(
                "{}: nothing to plot (--plot draws euler, npss, classifier and ndms results)",
                plot.display()
            ))
            .into());
        }
        crate::plot::write_charts(plot, &charts, 3)?;
    }
    if args.reporting.json {
        args.reporting.print_json(&report)?;
    } else {
        print!("{}", report::human_table(&report));
    }
    Ok(())
}

/// The metrics to score: those asked for (each must be available for the inputs), or with `all`
/// every metric the inputs allow.
fn chosen_metrics(
    args: &Args,
    requested: Option<Vec<Metric>>,
    action: Option<&str>,
    inputs: &load::Inputs,
) -> Result<Vec<Metric>> {
    let (pred, gt, seed) = (&inputs.pred, &inputs.gt, &inputs.seed);
    let requested_posture = requested
        .as_ref()
        .is_some_and(|list| list.contains(&Metric::Posture));
    let asked_for_some = requested.is_some();
    let available = |m: Metric| match m {
        Metric::Npss | Metric::NpssReference | Metric::Euler => gt.is_some(),
        // With `all`: H3.6M exp-map frames or positions given as N x T x J x 3.
        Metric::Mpjpe if asked_for_some => gt.is_some(),
        Metric::Multimodal => {
            gt.is_some()
                && seed.is_some()
                && pred.has_samples
                && (asked_for_some || inputs.space == InputSpace::Raw)
        }
        Metric::Mpjpe => {
            gt.is_some()
                && (pred.joints.is_some()
                    || (inputs.space == InputSpace::Expmap
                        && pred.data.dim().3 == motion_core::skeleton::H36M_FRAME_DIMS))
        }
        Metric::Ndms => !args.db.is_empty(),
        Metric::Apd => pred.has_samples,
        Metric::Classifier => action.is_some(),
        // Posture reads the action's real takes: with `all`, only when the data is there.
        Metric::Posture => {
            action.is_some()
                && (requested_posture
                    || motion_metrics::evaluation::resolve_dataset(args.data.as_deref()).is_ok())
        }
        m if m.is_plausibility() => action.is_some() && seed.is_some(),
        _ => unreachable!("every metric is listed"),
    };
    let metrics: Vec<Metric> = match requested {
        None => ALL_METRICS.into_iter().filter(|&m| available(m)).collect(),
        Some(list) => {
            for &m in &list {
                if !available(m) {
                    let need = match m {
                        Metric::Ndms => "--db reference sequences",
                        Metric::Apd => "samples in --pred (N x S x T x D)",
                        Metric::Classifier => "--action NAME (the action whose probability is reported)",
                        Metric::Posture => "--action NAME (the action whose real takes are the reference)",
                        Metric::Multimodal => "--gt, --seed (its last frame is each window's last observed pose) and samples in --pred (N x S x T x D)",
                        m if m.is_plausibility() && action.is_none() => {
                            "--action NAME (the action whose real data is the reference)"
                        }
                        m if m.is_plausibility() => {
                            "--seed (the frames before each prediction: drift's start, the floor of foot_contact)"
                        }
                        _ => "--gt",
                    };
                    return Err(usage(format!("metric {} needs {need}", m.name())));
                }
            }
            list
        }
    };
    if metrics.is_empty() {
        return Err(usage(
            "nothing to score: give --gt (NPSS, Euler error, MPJPE), --db (NDMS), samples in --pred (APD) or --action with --seed (speed_ratio, drift, foot_contact)",
        ));
    }
    Ok(metrics)
}

/// `None` for `all` (every metric the inputs allow), else the metrics asked for, once each.
fn parse_metrics(list: &[Metric]) -> Result<Option<Vec<Metric>>> {
    if list.contains(&Metric::All) {
        return Ok(None);
    }
    let mut out: Vec<Metric> = Vec::new();
    for &m in list {
        if !out.contains(&m) {
            out.push(m);
        }
    }
    Ok(Some(out))
}
