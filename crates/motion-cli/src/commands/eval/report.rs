//! The typed `eval` report ([`EvalReport`], serialized as the `--json` output) and its
//! human-readable form: one block per action with the model, the zero-velocity baseline and the
//! published numbers side by side, then the means over actions. The table, the JSON and the plots
//! ([`super::plots`]) all read the same report.
use std::collections::BTreeMap;

use serde::ser::SerializeStruct;
use serde::{Serialize, Serializer};

use super::published::{self, TABLE6_HORIZONS_MS};
use motion_metrics::{ClassifierCurve, PlausibilityReport, EULER_HORIZONS_MS};

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
    /// Test windows per action.
    pub windows_per_action: usize,
    /// Samples per window.
    pub samples: usize,
    /// Seed of the noise.
    pub rng_seed: u64,
}

/// How each number is computed, in words (one sentence per key).
#[derive(Debug, Clone, Serialize)]
pub struct Method {
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
    /// Test windows.
    pub windows: usize,
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

/// A number cell: 3 decimals, `-` when absent or not finite (JSON `null`).
fn cell(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or_else(|| "-".to_string(), |x| format!("{x:.3}"))
}

fn cells(values: impl IntoIterator<Item = Option<f64>>) -> String {
    values.into_iter().map(cell).collect::<Vec<_>>().join(" ")
}

/// The NDMS 0.4 s bins of model and baseline, then Tanke et al. 2021's "Ours" row for `action` (Table 2;
/// `average` for the mean over 15 actions) followed by `note`.
fn ndms_bins(out: &mut String, model: &str, baseline: &str, real: &str, action: &str, note: &str) {
    out.push_str(&format!(
        "  NDMS 0.4 s bins   model    {model}\n                    zero-vel {baseline}\n"
    ));
    if !real.is_empty() {
        out.push_str(&format!(
            "                    real     {real} (other subjects' motion, not the truth)\n"
        ));
    }
    for r in published::ndms_rows(action) {
        if r.method.starts_with("Ours") {
            let bins: Vec<String> = r
                .bins
                .iter()
                .map(|b| b.map_or("-".into(), |v| format!("{v:.3}")))
                .collect();
            out.push_str(&format!(
                "                    Tanke et al. 2021 {}{note}\n",
                bins.join(" ")
            ));
        }
    }
}

/// `VGRU-d 0.887  GRU-d 0.931` for the values that exist.
fn published_pairs(pairs: &[(&str, Option<f64>)]) -> String {
    pairs
        .iter()
        .filter_map(|(name, v)| v.map(|v| format!("{name} {v:.3}")))
        .collect::<Vec<_>>()
        .join("  ")
}

fn row(out: &mut String, label: &str, model: Option<f64>, baseline: Option<f64>, published: &str) {
    let line = format!(
        "  {label:<28} {:>8} {:>9}   {published}",
        cell(model),
        cell(baseline)
    );
    out.push_str(line.trim_end());
    out.push('\n');
}

fn action_block(out: &mut String, a: &ActionResult) {
    let action = a.action;
    let (m, z) = (&a.model, &a.zero_velocity);
    out.push_str(&format!(
        "\n{action}: {} windows x {} samples, horizon {} frames; NDMS database {} words (exact NN)\n",
        a.windows, a.samples, a.horizon, a.ndms_database_words
    ));
    out.push_str(&format!(
        "  {:<28} {:>8} {:>9}   published\n",
        "", "model", "zero-vel"
    ));
    let coverage = &a.ground_truth_coverage;
    if coverage.windows_per_second.iter().any(|&n| n != a.windows) {
        let per_second = coverage
            .windows_per_second
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(" ");
        out.push_str(&format!(
            "  ground truth (S5 file ends): windows covering each second {per_second}; NPSS whole over the first {} frames\n",
            coverage.npss_whole_frames
        ));
    }
    let windows = ["0-1 s", "1-2 s", "2-4 s", "4-8 s", "8-12 s"];
    for (m_npss, z_npss, name, with_published) in [
        (
            &m.npss_reference,
            &z.npss_reference,
            "NPSS reference Re(DFT)²",
            true,
        ),
        (&m.npss, &z.npss, "NPSS paper |DFT|²", false),
    ] {
        // The published numbers are over 4 s: beside a longer `whole` they would mislead.
        let whole_is_4s = coverage.npss_whole_frames <= 100;
        let whole_published = if with_published && whole_is_4s {
            published_pairs(&[
                ("VGRU-d", published::table4_npss("VGRU-d", action)),
                ("GRU-d", published::table4_npss("GRU-d", action)),
            ])
        } else {
            String::new()
        };
        row(
            out,
            &format!("{name} whole"),
            Some(m_npss.whole),
            Some(z_npss.whole),
            &whole_published,
        );
        for (i, w) in windows.iter().enumerate() {
            let Some(&model_value) = m_npss.windows.get(*w) else {
                continue;
            };
            let text = if with_published && i < 3 {
                let p003 = (i == 2)
                    .then(|| {
                        a.published
                            .paper003_table1_npss_reference_2_4s
                            .as_ref()
                            .and_then(|t| t.get("Ours (paper 003)").copied())
                    })
                    .flatten();
                published_pairs(&[
                    ("VGRU-d", published::table5_npss("VGRU-d", action, i)),
                    ("GRU-d", published::table5_npss("GRU-d", action, i)),
                    ("Tanke et al. 2021", p003),
                ])
            } else {
                String::new()
            };
            let label = match coverage.npss_windows.get(*w) {
                Some(&n) if n != a.windows => format!("  {w} ({n} windows)"),
                _ => format!("  {w}"),
            };
            row(
                out,
                &label,
                Some(model_value),
                z_npss.windows.get(*w).copied(),
                &text,
            );
        }
    }
    let zv_table = published::table6_zero_velocity(action);
    for (i, ms) in EULER_HORIZONS_MS.iter().enumerate() {
        let key = ms.to_string();
        let zv = TABLE6_HORIZONS_MS
            .iter()
            .position(|h| h == ms)
            .and_then(|j| zv_table.map(|t| t[j]));
        let text = published_pairs(&[
            ("zero-vel (T6)", zv),
            (
                "VGRU-d",
                published::table7_euler("VGRU-d", action).map(|t| t[i]),
            ),
            (
                "GRU-d",
                published::table7_euler("GRU-d", action).map(|t| t[i]),
            ),
            (
                "DAE-LSTM (p002 T2)",
                published::table2_p002("DAE-LSTM", action, *ms),
            ),
            ("LSTM3LR", published::table2_p002("LSTM3LR", action, *ms)),
        ]);
        let label = if i == 0 {
            format!("Euler error {ms} ms")
        } else {
            format!("            {ms} ms")
        };
        row(
            out,
            &label,
            m.euler_error_ms.get(&key).copied().flatten(),
            z.euler_error_ms.get(&key).copied().flatten(),
            &text,
        );
    }
    row(out, "NDMS f_sim", Some(m.ndms.mean), Some(z.ndms.mean), "");
    ndms_bins(
        out,
        &cells(m.ndms.bins.iter().copied().map(Some)),
        &cells(z.ndms.bins.iter().copied().map(Some)),
        &a.ground_truth
            .real_motion_ndms
            .as_ref()
            .map_or(String::new(), |r| cells(r.bins.iter().copied().map(Some))),
        action,
        "",
    );
    if m.apd.is_some() {
        row(out, "APD (mm)", m.apd, None, "");
    }
    let gt = a.ground_truth.mean_joint_speed_last_1s;
    for (kind, pick) in [
        (
            "world",
            (|s: &SpeedReport| s.world) as fn(&SpeedReport) -> f64,
        ),
        ("pose", |s: &SpeedReport| s.pose),
    ] {
        out.push_str(&format!(
            "  joint speed last 1 s, {kind:<5} {:>8} {:>9}   ground truth {} mm/frame\n",
            cell(Some(pick(&m.mean_joint_speed_last_1s))),
            cell(Some(pick(&z.mean_joint_speed_last_1s))),
            cell(gt.as_ref().map(pick))
        ));
    }
}

/// The classifier and plausibility rows of one action: model, zero-velocity, real continuation.
fn plausibility_rows(a: &ActionResult) -> String {
    let classifier = match (
        &a.model.classifier,
        &a.zero_velocity.classifier,
        &a.ground_truth.classifier,
    ) {
        (Some(m), Some(z), Some(r)) => super::super::classifier::comparison_rows(m, z, r),
        _ => String::new(),
    };
    format!(
        "{classifier}{}{}",
        super::super::plausibility::comparison_rows(
            &a.model.plausibility.0,
            &a.zero_velocity.plausibility.0,
            &a.ground_truth.plausibility.0,
        ),
        super::super::plausibility::ground_rows(
            &a.model.plausibility.0,
            &a.model_grounded.0,
            &a.ground_truth.plausibility.0,
        )
    )
}

/// The report as text.
pub fn table(report: &EvalReport) -> String {
    let mut out = String::new();
    let model = &report.model;
    let protocol = &report.protocol;
    out.push_str(&format!(
        "model {} ({}, hidden {}, {}); data {}\n",
        model.source,
        model.architecture,
        model.hidden,
        if model.stochastic {
            "stochastic"
        } else {
            "deterministic"
        },
        report.data
    ));
    out.push_str(&format!(
        "protocol: S5, 8 windows per action, {} seed frames at 25 Hz, horizon {}, {} samples, rng seed {}\n",
        protocol.seed_frames, protocol.horizon, protocol.samples, protocol.rng_seed
    ));
    if let Some(note) = model.note {
        out.push_str(&format!("note: {note}\n"));
    }
    for a in &report.actions {
        action_block(&mut out, a);
        out.push_str(&plausibility_rows(a));
    }
    let means = &report.mean_over_actions;
    out.push_str(&format!(
        "\nmean over {} actions         {:>8} {:>9}\n",
        means.actions, "model", "zero-vel"
    ));
    let (m, z) = (&means.model, &means.zero_velocity);
    for (label, model_mean, baseline_mean) in [
        ("NPSS reference whole", m.npss_reference, z.npss_reference),
        ("NPSS paper whole", m.npss, z.npss),
        ("NDMS f_sim", m.ndms, z.ndms),
    ] {
        row(&mut out, label, model_mean, baseline_mean, "");
    }
    ndms_bins(
        &mut out,
        &cells(m.ndms_bins.iter().copied()),
        &cells(z.ndms_bins.iter().copied()),
        &if means.real_motion.ndms_bins.is_empty() {
            String::new()
        } else {
            cells(means.real_motion.ndms_bins.iter().copied())
        },
        "average",
        " (average of 15 actions)",
    );
    if m.apd.is_some_and(f64::is_finite) {
        let paper: Vec<String> = published::P003_TABLE5_APD_H36M
            .iter()
            .map(|(m, v)| format!("{m} {v:.2}"))
            .collect();
        row(
            &mut out,
            "APD (mm)",
            m.apd,
            None,
            &format!(
                "Tanke et al. 2021 Table 5 (unit unstated): {}",
                paper.join(", ")
            ),
        );
    }
    for ms in EULER_HORIZONS_MS {
        let key = ms.to_string();
        row(
            &mut out,
            &format!("Euler error {ms} ms"),
            m.euler_error_ms.get(&key).copied().flatten(),
            z.euler_error_ms.get(&key).copied().flatten(),
            "",
        );
    }
    for s in &report.skipped {
        out.push_str(&format!("skipped {}: {}\n", s.action, s.reason));
    }
    if let Some(saved) = &report.save_predictions {
        out.push_str(&format!(
            "predictions: {} (shape [{}]; actions in order: {})\n",
            saved.path,
            saved
                .shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(","),
            saved.actions.join(", ")
        ));
    }
    out
}

/// A small report for the tests of this module and of the plots.
#[cfg(test)]
pub(super) mod fixtures {
    use super::*;
    use motion_metrics::plausibility::{
        DriftReport, FootContactReport, GroundReport, RealRanges, SpeedRatioReport,
    };

    /// Scores with the given per-frame Euler error, NPSS reference windows and NDMS bins.
    pub fn scores(euler: &[f64], windows: &[(&str, f64)], bins: &[f64]) -> ActionScores {
        let plausibility = PlausibilityReport {
            horizon_frames: euler.len(),
            sequences: 8,
            speed_ratio: SpeedRatioReport {
                action: "walking".into(),
                reference_mean_speed_mm_s: 1.0,
                windows: Vec::new(),
            },
            drift: DriftReport {
                action: "walking".into(),
                reference_windows: 0,
                windows: Vec::new(),
            },
            foot_contact: FootContactReport {
                clearance_mm: 100.0,
                windows: Vec::new(),
            },
            ground: GroundReport {
                real: RealRanges {
                    lean_p95_deg: 20.0,
                    hip_height_p5_mm: 800.0,
                    hip_height_p95_mm: 1000.0,
                    on_floor_fraction: 1.0,
                    penetration_fraction: 0.0,
                    skating_fraction: 0.1,
                    s5_skating_fraction: 0.1,
                },
                windows: Vec::new(),
            },
        };
        let npss = NpssReport {
            whole: 0.5,
            windows: windows.iter().map(|(l, v)| (l.to_string(), *v)).collect(),
        };
        ActionScores {
            euler_error_ms: EULER_HORIZONS_MS
                .iter()
                .map(|ms| (ms.to_string(), None))
                .collect(),
            euler_error_per_frame: euler.to_vec(),
            npss: npss.clone(),
            npss_reference: npss,
            ndms: NdmsScores {
                mean: 0.9,
                bins: bins.to_vec(),
                first_word_end: 0,
                exact: true,
            },
            mean_joint_speed_last_1s: SpeedReport {
                world: 1.0,
                pose: 2.0,
            },
            apd: None,
            plausibility: PlausibilityKeys(plausibility),
            classifier: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scores of an action keep the keys `eval` has always written plus `ground` (the
    /// floor-frame measures), the plausibility measures beside the metrics (not nested), `apd`
    /// and `classifier` only when present.
    #[test]
    fn scores_json_keys_are_the_former_ones() {
        let scores = fixtures::scores(&[0.1], &[("0-1 s", 0.2)], &[0.9]);
        let json = serde_json::to_value(&scores).unwrap();
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        assert_eq!(
            keys,
            [
                "drift",
                "euler_error_ms",
                "euler_error_per_frame",
                "foot_contact",
                "ground",
                "mean_joint_speed_last_1s",
                "ndms",
                "npss",
                "npss_reference",
                "speed_ratio"
            ]
        );
        assert_eq!(json["npss_reference"]["windows"]["0-1 s"], 0.2);
        assert!(json["euler_error_ms"]["80"].is_null());
        assert_eq!(json["ndms"]["exact"], true);
        assert_eq!(json["drift"]["reference_windows"], 0);
    }

    fn ndms(mean: f64, bins: &[f64]) -> NdmsScores {
        NdmsScores {
            mean,
            bins: bins.to_vec(),
            first_word_end: 0,
            exact: true,
        }
    }

    /// The real-motion means need every action's score; the bins row prints only with them.
    #[test]
    fn real_motion_means_need_every_action_and_print_a_bins_row() {
        let (a, b) = (ndms(0.4, &[0.5, 0.3]), ndms(0.2, &[0.3, 0.1]));
        let means = RealMotionMeans::of(&[Some(&a), Some(&b)]);
        assert_eq!(means.ndms, Some(0.30000000000000004));
        assert_eq!(means.ndms_bins, vec![Some(0.4), Some(0.2)]);
        let partial = RealMotionMeans::of(&[Some(&a), None]);
        assert_eq!((partial.ndms, partial.ndms_bins.len()), (None, 0));
        assert_eq!(RealMotionMeans::of(&[]).ndms, None);
        let mut out = String::new();
        ndms_bins(&mut out, "0.1", "0.0", "0.400 0.200", "walking", "");
        assert!(out.contains("real     0.400 0.200 (other subjects' motion, not the truth)"));
        let mut out = String::new();
        ndms_bins(&mut out, "0.1", "0.0", "", "walking", "");
        assert!(!out.contains("real"));
    }
}
