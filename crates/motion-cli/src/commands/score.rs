//! `motion-cli score`: NPSS (paper definition and the published code's variant), the protocol's
//! Euler error, NDMS and APD of predictions, from `.npy` arrays, exp-map text files or BVH files
//! (or folders of them).
//!
//! Inputs are read into `sequences x samples x frames x width` (samples = 1 for plain
//! sequences). In the exp-map space (the default for 99- and 117-dim data) NPSS and the Euler
//! error use the protocol's Euler sequences and NDMS/APD use FK positions; in the raw space the
//! numbers are used as given (positions `N x T x J x 3` for NDMS).
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use ndarray::{
    concatenate, s, Array2, Array3, Array4, ArrayD, ArrayView2, ArrayView3, Axis, Ix2, Ix3, Ix4,
    Ix5,
};
use serde_json::{json, Map, Value};

use crate::plot::{bin_points, per_frame_points, window_points, Chart, Series};
use motion_core::any_format::read_array;
use motion_core::file_sets::{check_paired_by_name, expand};
use motion_core::formats::bvh::read_bvh;
use motion_core::motion::Motion;
use motion_core::protocol::expmap_batch_to_euler_protocol;
use motion_core::skeleton::{
    CMU_FRAME_DIMS, H36M_FRAME_DIMS, H36M_JOINT_COUNT, H36M_PROTOCOL_FPS as PROTOCOL_FPS,
};
use motion_core::Skeleton;
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod, WordFrame};
use motion_metrics::npss::{Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
use motion_metrics::{
    apd_batch, euler_error, euler_error_at_horizons, MetricError, EULER_HORIZONS_MS,
};

use super::UsageError;

/// How the numbers of the inputs are read.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputSpace {
    /// Exp-map frames: Euler conversion for NPSS/Euler, FK positions for NDMS/APD.
    Expmap,
    /// As given: NPSS/Euler on the numbers, NDMS on positions `N x T x J x 3`.
    Raw,
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
The action-classifier protocol of paper 002 (--metric classifier --action NAME; definition in \
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
The reference statistics are read from the H3.6M data (--data, $MOTION_DATA_DIR, ../shared/data). \
The seed gives the drift's starting frame and the floor of foot_contact: --seed holds one \
sequence (N x T_s x 99) per --pred sequence, e.g. the 50 frames `predict` was seeded with.

Examples:
  motion-cli score --gt gt.npy --pred pred.npy --metric npss,euler --json
  motion-cli score --pred pred.npy --seed seed.npy --action walking --metric classifier --plot walking.svg
  motion-cli score --pred pred.npy --seed seed.npy --action walking --metric speed_ratio,drift,foot_contact
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
    /// Comma list of npss, npss-reference, euler, ndms, apd, classifier, speed_ratio, drift,
    /// foot_contact, or all (= every metric the inputs allow; classifier when --action is given,
    /// the last three when --action and --seed are given).
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
    #[arg(long, num_args = 1..)]
    pub seed: Vec<PathBuf>,
    /// The action the predictions should show (H3.6M name): speed_ratio and drift compare them
    /// with that action's real data.
    #[arg(long, value_name = "NAME")]
    pub action: Option<String>,
    /// Action classifier weights for --metric classifier (default: the built-in
    /// action_classifier.safetensors, paper 002's protocol).
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
    /// Paper 002's action-classifier probability.
    Classifier,
    /// Joint speed against the action's real data.
    #[value(name = "speed_ratio", alias = "speed-ratio")]
    SpeedRatio,
    /// Hip height and torso lean change since the seed.
    Drift,
    /// Fraction of frames with both feet off the floor.
    #[value(name = "foot_contact", alias = "foot-contact")]
    FootContact,
    /// Every metric the inputs allow.
    All,
}

const ALL_METRICS: [Metric; 9] = [
    Metric::Npss,
    Metric::NpssReference,
    Metric::Euler,
    Metric::Ndms,
    Metric::Apd,
    Metric::Classifier,
    Metric::SpeedRatio,
    Metric::Drift,
    Metric::FootContact,
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

/// Loaded data: `sequences x samples x frames x width`; `joints` is set for positions
/// (width = joints · 3).
#[derive(Debug, Clone)]
struct Batch {
    data: Array4<f64>,
    has_samples: bool,
    joints: Option<usize>,
    what: String,
}

fn usage(message: impl Into<String>) -> anyhow::Error {
    UsageError(message.into()).into()
}

fn metric_error(what: &str, err: MetricError) -> anyhow::Error {
    usage(format!("{what}: {err}"))
}

/// Runs the command.
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
    check_paired_by_name(&args.pred, &args.gt).context("--pred and --gt")?;
    check_paired_by_name(&args.pred, &args.seed).context("--pred and --seed")?;
    let pred_raw = load_group(&args.pred, "--pred")?;
    let space = args.input_space.unwrap_or_else(|| default_space(&pred_raw));
    let pred = classify_group(pred_raw, space, "--pred")?;
    let gt = if args.gt.is_empty() {
        None
    } else {
        Some(classify_group(
            load_group(&args.gt, "--gt")?,
            space,
            "--gt",
        )?)
    };
    if let Some(gt) = &gt {
        if gt.has_samples {
            return Err(usage(format!(
                "--gt must hold sequences (N x T x D), not samples: {}",
                gt.what
            )));
        }
    }
    let seed = if args.seed.is_empty() {
        None
    } else {
        Some(classify_group(
            load_group(&args.seed, "--seed")?,
            space,
            "--seed",
        )?)
    };

    let available = |m: Metric| match m {
        Metric::Npss | Metric::NpssReference | Metric::Euler => gt.is_some(),
        Metric::Ndms => !args.db.is_empty(),
        Metric::Apd => pred.has_samples,
        Metric::Classifier => action.is_some(),
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
            "nothing to score: give --gt (NPSS, Euler error), --db (NDMS), samples in --pred (APD) or --action with --seed (speed_ratio, drift, foot_contact)",
        ));
    }

    let mut report = Map::new();
    report.insert(
        "input_space".into(),
        json!(if space == InputSpace::Expmap {
            "expmap"
        } else {
            "raw"
        }),
    );
    report.insert("sequences".into(), json!(pred.data.dim().0));
    report.insert("samples".into(), json!(pred.data.dim().1));
    report.insert("frames".into(), json!(pred.data.dim().2));
    if let Some(gt) = &gt {
        score_against_ground_truth(&metrics, gt, &pred, space, &mut report)?;
    }
    if metrics.contains(&Metric::Ndms) {
        let method = match args.nn {
            NnChoice::BruteForce => NnMethod::BruteForce,
            NnChoice::PcaKdTree => NnMethod::PcaKdTree,
            NnChoice::PoseBound => NnMethod::PoseBound,
        };
        report.insert(
            "ndms".into(),
            score_ndms(
                &args.db,
                &pred,
                seed.as_ref(),
                method,
                args.skeleton.as_deref(),
            )?,
        );
    }
    if metrics.contains(&Metric::Apd) {
        let positions = sample_positions(&pred, space)?;
        let (n, s, t, w) = positions.dim();
        let flat = positions
            .into_shape_with_order((n, s, t * w))
            .expect("contiguous");
        let (per, mean) = apd_batch(flat.view()).map_err(|e| metric_error("APD", e))?;
        report.insert("apd".into(), json!(mean));
        report.insert("apd_per_sequence".into(), json!(per));
    }
    let mut classifier_table = None;
    if metrics.contains(&Metric::Classifier) {
        let action = action.expect("checked above");
        let classifier = crate::model_source::load_classifier(args.classifier.as_deref())?;
        let curve = score_classifier(&classifier, action, &pred, seed.as_ref())?;
        report.insert("action".into(), json!(action));
        classifier_table = Some(super::classifier::table(&curve));
        report.insert("classifier".into(), serde_json::to_value(&curve)?);
    }
    let mut plausibility_table = None;
    if metrics.iter().any(|m| m.is_plausibility()) {
        let (action, seed) = (
            action.expect("checked above"),
            seed.as_ref().expect("checked above"),
        );
        let dataset = super::eval::selection::resolve_dataset(args.data.as_deref())?;
        let plausibility = score_plausibility(&dataset, action, &pred, seed)?;
        report.insert("action".into(), json!(action));
        for (metric, key, value) in [
            (
                Metric::SpeedRatio,
                "speed_ratio",
                serde_json::to_value(&plausibility.speed_ratio)?,
            ),
            (
                Metric::Drift,
                "drift",
                serde_json::to_value(&plausibility.drift)?,
            ),
            (
                Metric::FootContact,
                "foot_contact",
                serde_json::to_value(&plausibility.foot_contact)?,
            ),
        ] {
            if metrics.contains(&metric) {
                report.insert(key.into(), value);
            }
        }
        plausibility_table = Some(super::plausibility::table(&plausibility));
    }

    let report = Value::Object(report);
    if let Some(plot) = &args.plot {
        let charts = charts(&report);
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
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", human_table(&report));
        if let Some(table) = classifier_table {
            print!("{table}");
        }
        if let Some(table) = plausibility_table {
            print!("{table}");
        }
    }
    Ok(())
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

// ---------- loading ----------

/// The arrays of every file of a flag, as read.
fn load_group(paths: &[PathBuf], flag: &str) -> Result<Vec<(PathBuf, ArrayD<f64>)>> {
    let files = expand(paths)?;
    if files.is_empty() {
        return Err(usage(format!("{flag}: no files given")));
    }
    files
        .into_iter()
        .map(|path| {
            let array = read_array(&path, false)?;
            Ok((path, array))
        })
        .collect()
}

fn default_space(group: &[(PathBuf, ArrayD<f64>)]) -> InputSpace {
    let width = group
        .first()
        .map(|(_, a)| *a.shape().last().unwrap_or(&0))
        .unwrap_or(0);
    if width == H36M_FRAME_DIMS || width == CMU_FRAME_DIMS {
        InputSpace::Expmap
    } else {
        InputSpace::Raw
    }
}

/// Reads one array as `sequences x samples x frames x width` by its rank and the input space:
/// 2: `T x D`; 3: `N x T x D`; 4: positions `N x T x J x 3` (raw, last axis 3) or samples
/// `N x S x T x D`; 5: sample positions `N x S x T x J x 3` (raw).
fn classify(array: ArrayD<f64>, space: InputSpace, what: &str) -> Result<Batch> {
    let shape = array.shape().to_vec();
    let last = *shape.last().unwrap_or(&0);
    let bad = |expected: &str| usage(format!("{what}: shape {shape:?} is not {expected}"));
    let batch = match shape.len() {
        2 => {
            let a = array.into_dimensionality::<Ix2>().expect("rank 2");
            let (t, d) = a.dim();
            Batch { data: a.into_shape_with_order((1, 1, t, d)).expect("contiguous"), has_samples: false, joints: None, what: what.into() }
        }
        3 => {
            let a = array.into_dimensionality::<Ix3>().expect("rank 3").as_standard_layout().into_owned();
            let (n, t, d) = a.dim();
            Batch { data: a.into_shape_with_order((n, 1, t, d)).expect("contiguous"), has_samples: false, joints: None, what: what.into() }
        }
        4 if space == InputSpace::Raw && last == 3 => {
            let a = array.into_dimensionality::<Ix4>().expect("rank 4").as_standard_layout().into_owned();
            let (n, t, j, _) = a.dim();
            Batch { data: a.into_shape_with_order((n, 1, t, j * 3)).expect("contiguous"), has_samples: false, joints: Some(j), what: what.into() }
        }
        4 => {
            let a = array.into_dimensionality::<Ix4>().expect("rank 4").as_standard_layout().into_owned();
            Batch { data: a, has_samples: true, joints: None, what: what.into() }
        }
        5 if space == InputSpace::Raw && last == 3 => {
            let a = array.into_dimensionality::<Ix5>().expect("rank 5").as_standard_layout().into_owned();
            let (n, s, t, j, _) = a.dim();
            Batch { data: a.into_shape_with_order((n, s, t, j * 3)).expect("contiguous"), has_samples: true, joints: Some(j), what: what.into() }
        }
        _ => {
            return Err(bad(
                "T x D, N x T x D, N x S x T x D, or (raw space) positions N x T x J x 3 / N x S x T x J x 3",
            ))
        }
    };
    if space == InputSpace::Expmap && batch.joints.is_none() {
        let d = batch.data.dim().3;
        if d < 6 || d % 3 != 0 {
            return Err(usage(format!("{what}: {d} dims per frame is not an exp-map frame (3 + 3k); use --input-space raw")));
        }
    }
    Ok(batch)
}

/// All files of a flag classified and stacked along the sequence axis.
fn classify_group(
    group: Vec<(PathBuf, ArrayD<f64>)>,
    space: InputSpace,
    flag: &str,
) -> Result<Batch> {
    let mut batches = Vec::new();
    for (path, array) in group {
        batches.push(classify(array, space, &path.display().to_string())?);
    }
    let first = batches[0].clone();
    for b in &batches[1..] {
        let (_, s, t, w) = b.data.dim();
        let (_, s0, t0, w0) = first.data.dim();
        if (s, t, w, b.joints) != (s0, t0, w0, first.joints) {
            return Err(usage(format!(
                "{flag}: {} has samples x frames x width {s} x {t} x {w} but {} has {s0} x {t0} x {w0}",
                b.what, first.what
            )));
        }
    }
    let views: Vec<_> = batches.iter().map(|b| b.data.view()).collect();
    let data = concatenate(Axis(0), &views).expect("checked shapes");
    let what = if batches.len() == 1 {
        first.what.clone()
    } else {
        format!("{flag} ({} files)", batches.len())
    };
    Ok(Batch {
        data,
        has_samples: first.has_samples,
        joints: first.joints,
        what,
    })
}

// ---------- NPSS and Euler error ----------

fn score_against_ground_truth(
    metrics: &[Metric],
    gt: &Batch,
    pred: &Batch,
    space: InputSpace,
    report: &mut Map<String, Value>,
) -> Result<()> {
    let (n, s, t, w) = pred.data.dim();
    let (gn, _, gt_frames, gw) = gt.data.dim();
    if (n, t, w) != (gn, gt_frames, gw) {
        return Err(usage(format!(
            "shape mismatch: --pred {} has {n} sequences x {t} frames x {w} dims but --gt {} has {gn} x {gt_frames} x {gw}",
            pred.what, gt.what
        )));
    }
    // Every sample is scored against its sequence's ground truth.
    let pred_flat = pred
        .data
        .to_shape((n * s, t, w))
        .expect("contiguous")
        .into_owned();
    let gt_seq = gt.data.index_axis(Axis(1), 0);
    let gt_flat: Array3<f64> = if s == 1 {
        gt_seq.to_owned()
    } else {
        let repeated: Vec<_> = gt_seq
            .outer_iter()
            .flat_map(|g| std::iter::repeat_n(g, s))
            .collect();
        ndarray::stack(Axis(0), &repeated).expect("same shapes")
    };
    let (gt_e, pred_e) = if space == InputSpace::Expmap {
        (
            expmap_batch_to_euler_protocol(gt_flat.view()),
            expmap_batch_to_euler_protocol(pred_flat.view()),
        )
    } else {
        (gt_flat, pred_flat)
    };
    let mut npss = Npss::new();
    let mut windows = Map::new();
    for (metric, key, power) in [
        (Metric::Npss, "npss", SpectrumPower::Modulus),
        (
            Metric::NpssReference,
            "npss_reference",
            SpectrumPower::RealPart,
        ),
    ] {
        if !metrics.contains(&metric) {
            continue;
        }
        let value = npss
            .score(gt_e.view(), pred_e.view(), power)
            .map_err(|e| metric_error("NPSS", e))?;
        report.insert(key.into(), json!(value));
        let per_window = npss
            .score_windows(gt_e.view(), pred_e.view(), power, &NPSS_WINDOWS_25HZ)
            .map_err(|e| metric_error("NPSS", e))?;
        let object: Map<String, Value> = per_window
            .iter()
            .map(|w| (w.window.label.to_string(), json!(w.value)))
            .collect();
        windows.insert(key.into(), Value::Object(object));
    }
    if !windows.is_empty() {
        report.insert("npss_windows".into(), Value::Object(windows));
    }
    if metrics.contains(&Metric::Euler) {
        let per_frame =
            euler_error(gt_e.view(), pred_e.view()).map_err(|e| metric_error("Euler error", e))?;
        let horizons: Map<String, Value> = euler_error_at_horizons(&per_frame)
            .iter()
            .map(|(ms, v)| (ms.to_string(), json!(v)))
            .collect();
        report.insert("euler_error".into(), json!(per_frame));
        report.insert("euler_error_ms".into(), Value::Object(horizons));
    }
    Ok(())
}

// ---------- positions (NDMS, APD) ----------

/// `T x J x 3` positions of one `T x W` sequence (FK of exp-map frames, or raw positions).
fn sequence_positions(
    frames: ArrayView2<'_, f64>,
    joints: Option<usize>,
    what: &str,
) -> Result<Array3<f64>> {
    match joints {
        Some(j) => Ok(frames
            .to_owned()
            .into_shape_with_order((frames.nrows(), j, 3))
            .expect("width = J·3")),
        // Exp-map frames at the protocol's 25 Hz, on the skeleton their width names.
        None => Motion::expmap_of_width(frames.to_owned(), PROTOCOL_FPS)
            .ok_or_else(|| {
                usage(format!(
                    "{what}: no built-in skeleton has {}-dim exp-map frames (99 = H3.6M, 117 = CMU); give positions with --input-space raw",
                    frames.ncols()
                ))
            })?
            .map(|motion| motion.positions())
            .map_err(|e| usage(format!("{what}: {e}"))),
    }
}

/// Positions of every sample: `N x S x T x (J·3)`.
fn sample_positions(batch: &Batch, space: InputSpace) -> Result<Array4<f64>> {
    if space == InputSpace::Raw {
        return Ok(batch.data.clone());
    }
    let (n, s, t, _) = batch.data.dim();
    let mut out: Option<Array4<f64>> = None;
    for i in 0..n {
        for k in 0..s {
            let p = sequence_positions(batch.data.slice(s![i, k, .., ..]), None, &batch.what)?;
            let width = p.dim().1 * 3;
            let target = out.get_or_insert_with(|| Array4::zeros((n, s, t, width)));
            target
                .slice_mut(s![i, k, .., ..])
                .assign(&p.into_shape_with_order((t, width)).expect("contiguous"));
        }
    }
    Ok(out.expect("at least one sample"))
}

/// The NDMS configuration for the predictions' joints.
///
/// FK of integrated root deltas lives in the tilted pelvis frame of wherever integration started
/// (the file for --db, the seed for a forecast): only a rigid per-word frame makes the same motion
/// give the same word. Raw positions are taken as gravity-aligned (metrics.md's recipe).
fn ndms_config(pred: &Batch, skeleton: Option<&Path>) -> Result<NdmsConfig> {
    match (pred.joints, skeleton) {
        (None, _) if pred.data.dim().3 == H36M_FRAME_DIMS => Ok(NdmsConfig::h36m_body_frame()),
        (Some(H36M_JOINT_COUNT), None) => Ok(NdmsConfig::h36m()),
        (Some(joints), Some(path)) => {
            let named = read_bvh(path)?.skeleton;
            let lookup = |j: usize| {
                let name = &Skeleton::h36m().joint(j).name.clone();
                named.joint_index(name).ok_or_else(|| {
                    usage(format!(
                        "{}: no joint named {name:?} (an NDMS joint)",
                        path.display()
                    ))
                })
            };
            if named.len() != joints {
                return Err(usage(format!(
                    "{}: {} joints but the positions of {} have {joints}",
                    path.display(),
                    named.len(),
                    pred.what
                )));
            }
            let h36m = NdmsConfig::h36m();
            Ok(NdmsConfig {
                joints: h36m
                    .joints
                    .iter()
                    .map(|&j| lookup(j))
                    .collect::<Result<_>>()?,
                left_hip: lookup(h36m.left_hip)?,
                right_hip: lookup(h36m.right_hip)?,
                ..h36m
            })
        }
        _ => Err(usage(format!(
            "NDMS: {} is not on the 32-joint H3.6M skeleton (99-dim exp-map or 32 x 3 positions); \
             name the joints of raw positions with --skeleton FILE.bvh",
            pred.what
        ))),
    }
}

fn score_ndms(
    db_paths: &[PathBuf],
    pred: &Batch,
    seed: Option<&Batch>,
    method: NnMethod,
    skeleton: Option<&Path>,
) -> Result<Value> {
    let config = ndms_config(pred, skeleton)?;
    let mut references = Vec::new();
    for path in expand(db_paths)? {
        let array = read_array(&path, true)?;
        let what = path.display().to_string();
        // The database reads positions by shape: `T x J x 3` / `N x T x J x 3`; otherwise exp-map.
        let batch = if array.shape().last() == Some(&3) && array.ndim() >= 3 {
            let array = if array.ndim() == 3 {
                array.insert_axis(Axis(0))
            } else {
                array
            };
            classify(array, InputSpace::Raw, &what)?
        } else {
            classify(array, InputSpace::Expmap, &what)?
        };
        for sequence in batch.data.index_axis(Axis(1), 0).outer_iter() {
            references.push(sequence_positions(sequence, batch.joints, &what)?);
        }
    }
    let views: Vec<ArrayView3<'_, f64>> = references.iter().map(|r| r.view()).collect();
    let database = NdmsDatabase::from_sequences(config.clone(), &views, method)
        .map_err(|e| metric_error("NDMS database (--db)", e))?;

    let (n, s, t, _) = pred.data.dim();
    let prefix = config.kappa - 1;
    if let Some(seed) = seed {
        if seed.data.dim().0 != n
            || seed.has_samples
            || seed.joints != pred.joints
            || seed.data.dim().3 != pred.data.dim().3
        {
            return Err(usage(format!(
                "--seed {} must hold one sequence per --pred sequence ({n}) with the same frame width; found shape {:?}",
                seed.what,
                seed.data.shape()
            )));
        }
        if seed.data.dim().2 < prefix {
            return Err(usage(format!(
                "--seed {}: {} frames, NDMS needs the last κ-1 = {prefix}",
                seed.what,
                seed.data.dim().2
            )));
        }
    } else if t < config.kappa {
        return Err(metric_error(
            "NDMS",
            MetricError::TooShort {
                what: format!("--pred {}", pred.what),
                frames: t,
                kappa: config.kappa,
            },
        ));
    }
    // FK of seed + forecast together keeps the integrated root continuous across the seam.
    let mut forecasts = Vec::with_capacity(n * s);
    let mut seeds = Vec::with_capacity(n * s);
    for i in 0..n {
        for k in 0..s {
            let forecast = pred.data.slice(s![i, k, .., ..]);
            match seed {
                Some(seed) => {
                    let observed = seed.data.slice(s![i, 0, .., ..]);
                    let joined: Array2<f64> =
                        concatenate(Axis(0), &[observed, forecast]).expect("same width");
                    let positions = sequence_positions(joined.view(), pred.joints, &pred.what)?;
                    let split = observed.nrows();
                    seeds.push(
                        positions
                            .slice(s![split - prefix..split, .., ..])
                            .to_owned(),
                    );
                    forecasts.push(positions.slice(s![split.., .., ..]).to_owned());
                }
                None => forecasts.push(sequence_positions(forecast, pred.joints, &pred.what)?),
            }
        }
    }
    let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
    let seed_views: Vec<_> = seeds.iter().map(|f| f.view()).collect();
    let report = database
        .score_forecasts(&forecast_views, seed.map(|_| seed_views.as_slice()))
        .map_err(|e| metric_error("NDMS", e))?;
    Ok(json!({
        "mean": report.mean,
        "per_word": report.per_word,
        "bins": report.bins,
        "first_word_end": report.first_word_end,
        "exact": report.exact,
        "database_words": database.len(),
        "word_frame": match config.frame {
            WordFrame::Heading => "heading (metrics.md recipe)",
            WordFrame::Body { .. } => "body (rigid, first frame's hips and shoulders)",
        },
        "nearest_neighbour": match method { NnMethod::BruteForce => "brute-force", NnMethod::PcaKdTree => "pca-kd-tree", NnMethod::PoseBound => "pose-bound" },
    }))
}

// ---------- the action-classifier protocol (paper 002) ----------

/// The classifier curve of every prediction sample (after its sequence's seed, when given).
fn score_classifier(
    classifier: &motion_core::model::ActionClassifier,
    action: &str,
    pred: &Batch,
    seed: Option<&Batch>,
) -> Result<motion_metrics::ClassifierCurve> {
    let frame_dims = classifier.config().frame_dims;
    for batch in std::iter::once(pred).chain(seed) {
        if batch.joints.is_some() || batch.data.dim().3 != frame_dims {
            return Err(usage(format!(
                "the action classifier reads H3.6M exp-map frames ({frame_dims} dims, {} Hz); {} has shape {:?}",
                classifier.config().fps,
                batch.what,
                batch.data.shape()
            )));
        }
    }
    let (n, samples, t, d) = pred.data.dim();
    if let Some(seed) = seed {
        if seed.data.dim().0 != n || seed.has_samples {
            return Err(usage(format!(
                "--seed {} must hold one sequence per --pred sequence ({n}); found shape {:?}",
                seed.what,
                seed.data.shape()
            )));
        }
    }
    let flat = pred
        .data
        .view()
        .into_shape_with_order((n * samples, t, d))
        .map_err(|e| usage(format!("{}: {e}", pred.what)))?;
    let seeds = seed.map(|seed| {
        let frames = seed.data.dim().2;
        ndarray::Array3::from_shape_fn((n * samples, frames, d), |(i, f, k)| {
            seed.data[[i / samples, 0, f, k]]
        })
    });
    super::classifier::curve(
        classifier,
        seeds.as_ref().map(|s| s.view()),
        flat,
        action,
        &pred.what,
    )
}

// ---------- plausibility (speed_ratio, drift, foot_contact) ----------

/// The plausibility report of every prediction sample after its sequence's seed.
fn score_plausibility(
    dataset: &Path,
    action: &str,
    pred: &Batch,
    seed: &Batch,
) -> Result<motion_metrics::PlausibilityReport> {
    for batch in [pred, seed] {
        if batch.joints.is_some() || batch.data.dim().3 != H36M_FRAME_DIMS {
            return Err(usage(format!(
                "speed_ratio, drift and foot_contact read H3.6M exp-map frames (99 dims, 25 Hz); {} has shape {:?}",
                batch.what,
                batch.data.shape()
            )));
        }
    }
    let (n, s, t, _) = pred.data.dim();
    if seed.data.dim().0 != n || seed.has_samples {
        return Err(usage(format!(
            "--seed {} must hold one sequence per --pred sequence ({n}); found shape {:?}",
            seed.what,
            seed.data.shape()
        )));
    }
    let reference = super::plausibility::reference(dataset, action)?;
    let pairs: Vec<_> = (0..n)
        .flat_map(|i| {
            (0..s).map(move |k| {
                (
                    seed.data.slice(s![i, 0, .., ..]),
                    pred.data.slice(s![i, k, .., ..]),
                )
            })
        })
        .collect();
    let measures = super::plausibility::measure(&pairs, &pred.what)?;
    Ok(super::plausibility::report(&measures, t, &reference))
}

// ---------- output ----------

/// One chart per per-horizon result the report holds.
fn charts(report: &Value) -> Vec<Chart> {
    let mut charts = Vec::new();
    if report.get("euler_error").is_some() {
        charts.push(Chart {
            title: "Euler error".into(),
            x_label: "horizon (ms)".into(),
            y_label: "Euler error (rad)".into(),
            series: vec![Series::new(
                "prediction",
                per_frame_points(&report["euler_error"]),
            )],
        });
    }
    if let Some(windows) = report.get("npss_windows") {
        let series = [
            ("npss", "paper |DFT|^2"),
            ("npss_reference", "reference Re(DFT)^2"),
        ]
        .iter()
        .filter(|(key, _)| windows.get(key).is_some())
        .map(|(key, name)| Series::new(*name, window_points(&windows[key])))
        .collect();
        charts.push(Chart {
            title: "NPSS per window".into(),
            x_label: "window centre (ms)".into(),
            y_label: "NPSS".into(),
            series,
        });
    }
    if let Some(curve) = report.get("classifier") {
        charts.push(super::classifier::chart(curve));
    }
    if let Some(bins) = report.get("ndms").and_then(|n| n.get("bins")) {
        charts.push(Chart {
            title: "NDMS per 0.4 s".into(),
            x_label: "bin end (ms)".into(),
            y_label: "NDMS".into(),
            series: vec![Series::new("prediction", bin_points(bins))],
        });
    }
    charts
}

fn human_table(report: &Value) -> String {
    let mut out = String::new();
    let num = |v: &Value| {
        v.as_f64()
            .map_or_else(|| "-".to_string(), |x| format!("{x:.4}"))
    };
    out.push_str(&format!(
        "sequences {}  samples {}  frames {}  input space {}\n",
        report["sequences"],
        report["samples"],
        report["frames"],
        report["input_space"].as_str().unwrap_or("")
    ));
    for (key, label) in [
        ("npss", "NPSS (|DFT|², paper)"),
        ("npss_reference", "NPSS (Re(DFT)², published code)"),
    ] {
        if let Some(v) = report.get(key) {
            out.push_str(&format!("{label:<36} {}\n", num(v)));
            if let Some(Value::Object(w)) = report.get("npss_windows").and_then(|w| w.get(key)) {
                for (window, value) in w {
                    out.push_str(&format!("  {window:<34} {}\n", num(value)));
                }
            }
        }
    }
    if let Some(h) = report.get("euler_error_ms") {
        // The papers' column order (JSON objects sort their keys).
        out.push_str("Euler error      ");
        for ms in EULER_HORIZONS_MS {
            out.push_str(&format!("{:>8}", format!("{ms} ms")));
        }
        out.push_str("\n                 ");
        for ms in EULER_HORIZONS_MS {
            let cell = h[ms.to_string()]
                .as_f64()
                .map_or("-".to_string(), |v| format!("{v:.3}"));
            out.push_str(&format!("{cell:>8}"));
        }
        out.push('\n');
    }
    if let Some(ndms) = report.get("ndms") {
        out.push_str(&format!(
            "NDMS (exact NN, {} words in D)     {}\n  0.4 s bins: {}\n",
            ndms["database_words"],
            num(&ndms["mean"]),
            ndms["bins"].as_array().map_or(String::new(), |b| b
                .iter()
                .map(&num)
                .collect::<Vec<_>>()
                .join(" "))
        ));
    }
    if let Some(v) = report.get("apd") {
        out.push_str(&format!("{:<36} {}\n", "APD", num(v)));
    }
    out
}
