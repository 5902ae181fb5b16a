//! The typed report of `score` and its two readers besides the JSON: the human table and the
//! plots. The JSON is `serde_json::to_string_pretty(&ScoreReport)`.
//!
//! Fields are in alphabetical order: the JSON keeps the key order of the `serde_json::Map` this
//! report replaced (nested reports of `motion_metrics` keep their own field order).
use std::collections::BTreeMap;

use serde::Serialize;

use motion_metrics::plausibility::{DriftReport, FootContactReport, SpeedRatioReport};
use motion_metrics::{ClassifierCurve, PlausibilityReport, EULER_HORIZONS_MS};

use super::InputSpace;
use crate::plot::{bin_points, per_frame_points, window_points, Chart, Series};

/// Everything `score` measured; absent metrics are left out of the JSON.
#[derive(Debug, Clone, Serialize)]
pub struct ScoreReport {
    /// The action of the classifier protocol and the plausibility measures (`--action`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub action: Option<String>,
    /// APD: the mean over sequences of the average pairwise distance of their samples.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub apd: Option<f64>,
    /// APD of each sequence.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub apd_per_sequence: Option<Vec<f64>>,
    /// The action-classifier curve (Ghosh et al. 2017's protocol).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classifier: Option<ClassifierCurve>,
    /// `drift` (when asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift: Option<DriftReport>,
    /// Euler error per predicted frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub euler_error: Option<Vec<f64>>,
    /// Euler error at the papers' horizons, keyed by milliseconds (`null` past the frames).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub euler_error_ms: Option<BTreeMap<String, Option<f64>>>,
    /// `foot_contact` (when asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub foot_contact: Option<FootContactReport>,
    /// Frames per prediction.
    pub frames: usize,
    /// APD, ADE, FDE, MMADE, MMFDE of the sample sets, means over windows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multimodal: Option<motion_metrics::multimodal::SampleSetScores>,
    /// MPJPE per predicted frame and at 80-1000 ms (mm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mpjpe: Option<motion_metrics::mpjpe::MpjpeScores>,
    /// Posture realism per window after the seed (when asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub posture: Option<motion_metrics::evaluation::posture::PostureScore>,
    /// How the numbers were read.
    pub input_space: InputSpace,
    /// NDMS against the `--db` words.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ndms: Option<NdmsSummary>,
    /// NPSS with the paper's |DFT|² power.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub npss: Option<f64>,
    /// NPSS with the published code's Re(DFT)².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub npss_reference: Option<f64>,
    /// NPSS per window of the horizon, per variant.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub npss_windows: Option<NpssWindows>,
    /// Samples per sequence (1 for plain sequences).
    pub samples: usize,
    /// Prediction sequences.
    pub sequences: usize,
    /// `speed_ratio` (when asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_ratio: Option<SpeedRatioReport>,
    /// The whole plausibility report, read by the table (the JSON carries the measures asked for).
    #[serde(skip)]
    pub plausibility: Option<PlausibilityReport>,
}

/// NPSS per window label (`"0-1 s"`, ...), per variant computed.
#[derive(Debug, Clone, Default, Serialize)]
pub struct NpssWindows {
    /// The paper's |DFT|² variant.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub npss: Option<BTreeMap<String, f64>>,
    /// The published code's Re(DFT)² variant.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub npss_reference: Option<BTreeMap<String, f64>>,
}

/// NDMS of the predictions and how it was computed.
#[derive(Debug, Clone, Serialize)]
pub struct NdmsSummary {
    /// Means over 0.4 s bins by word end.
    pub bins: Vec<f64>,
    /// Motion words in the database.
    pub database_words: usize,
    /// The nearest neighbours were exact.
    pub exact: bool,
    /// The forecast frame at which the first word ends.
    pub first_word_end: usize,
    /// f_sim: the mean over all words of all forecasts.
    pub mean: f64,
    /// The nearest-neighbour search used.
    pub nearest_neighbour: &'static str,
    /// Mean over forecasts of each word's score.
    pub per_word: Vec<f64>,
    /// The frame words are expressed in.
    pub word_frame: &'static str,
}

/// One chart per per-horizon result the report holds.
pub fn charts(report: &ScoreReport) -> Vec<Chart> {
    let mut charts = Vec::new();
    if let Some(per_frame) = &report.euler_error {
        charts.push(Chart {
            title: "Euler error".into(),
            x_label: "horizon (ms)".into(),
            y_label: "Euler error (rad)".into(),
            series: vec![Series::new("prediction", per_frame_points(per_frame))],
        });
    }
    if let Some(windows) = &report.npss_windows {
        let series = [
            (&windows.npss, "paper |DFT|^2"),
            (&windows.npss_reference, "reference Re(DFT)^2"),
        ]
        .into_iter()
        .filter_map(|(values, name)| {
            let values = values.as_ref()?;
            Some(Series::new(
                name,
                window_points(values.iter().map(|(label, v)| (label.as_str(), *v))),
            ))
        })
        .collect();
        charts.push(Chart {
            title: "NPSS per window".into(),
            x_label: "window centre (ms)".into(),
            y_label: "NPSS".into(),
            series,
        });
    }
    if let Some(curve) = &report.classifier {
        charts.push(super::super::classifier::chart(curve));
    }
    if let Some(ndms) = &report.ndms {
        charts.push(Chart {
            title: "NDMS per 0.4 s".into(),
            x_label: "bin end (ms)".into(),
            y_label: "NDMS".into(),
            series: vec![Series::new("prediction", bin_points(&ndms.bins))],
        });
    }
    charts
}

/// A number as the table prints it: 4 decimals, `-` when not finite (JSON `null`).
fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "-".to_string()
    }
}

/// The report as text: the metrics table, then the classifier and plausibility tables.
pub fn human_table(report: &ScoreReport) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "sequences {}  samples {}  frames {}  input space {}\n",
        report.sequences,
        report.samples,
        report.frames,
        report.input_space.name()
    ));
    if let Some(p) = &report.posture {
        out.push_str(&posture_rows(p));
    }
    let windows = report.npss_windows.as_ref();
    for (value, per_window, label) in [
        (
            report.npss,
            windows.and_then(|w| w.npss.as_ref()),
            "NPSS (|DFT|², paper)",
        ),
        (
            report.npss_reference,
            windows.and_then(|w| w.npss_reference.as_ref()),
            "NPSS (Re(DFT)², published code)",
        ),
    ] {
        if let Some(v) = value {
            out.push_str(&format!("{label:<36} {}\n", num(v)));
            for (window, value) in per_window.into_iter().flatten() {
                out.push_str(&format!("  {window:<34} {}\n", num(*value)));
            }
        }
    }
    if let Some(m) = &report.multimodal {
        out.push_str(&format!(
            "multi-sample (mean over windows)  APD {}  ADE {}  FDE {}  MMADE {}  MMFDE {}\n",
            num(m.apd),
            num(m.ade),
            num(m.fde),
            num(m.mmade),
            num(m.mmfde)
        ));
    }
    if let Some(m) = &report.mpjpe {
        match &m.horizons {
            Some(h) => {
                out.push_str("MPJPE (mm)       ");
                for ms in motion_metrics::mpjpe::MPJPE_HORIZONS_MS {
                    out.push_str(&format!("{:>8}", format!("{ms} ms")));
                }
                out.push_str("\n                 ");
                for v in h {
                    out.push_str(&format!("{v:>8.2}"));
                }
                out.push('\n');
            }
            None => {
                let mean = m.per_frame.iter().sum::<f64>() / m.per_frame.len() as f64;
                out.push_str(&format!(
                    "{:<36} {} (fewer than 25 frames: no horizons)\n",
                    "MPJPE (mm), mean over frames",
                    num(mean)
                ));
            }
        }
        if m.filled_from_truth {
            out.push_str("  (22 predicted joints, the rest from the ground truth)\n");
        }
    }
    if let Some(h) = &report.euler_error_ms {
        // The papers' column order.
        out.push_str("Euler error      ");
        for ms in EULER_HORIZONS_MS {
            out.push_str(&format!("{:>8}", format!("{ms} ms")));
        }
        out.push_str("\n                 ");
        for ms in EULER_HORIZONS_MS {
            let cell = h
                .get(&ms.to_string())
                .copied()
                .flatten()
                .filter(|v| v.is_finite())
                .map_or("-".to_string(), |v| format!("{v:.3}"));
            out.push_str(&format!("{cell:>8}"));
        }
        out.push('\n');
    }
    if let Some(ndms) = &report.ndms {
        out.push_str(&format!(
            "NDMS (exact NN, {} words in D)     {}\n  0.4 s bins: {}\n",
            ndms.database_words,
            num(ndms.mean),
            ndms.bins
                .iter()
                .map(|&b| num(b))
                .collect::<Vec<_>>()
                .join(" ")
        ));
    }
    if let Some(v) = report.apd {
        out.push_str(&format!("{:<36} {}\n", "APD", num(v)));
    }
    if let Some(curve) = &report.classifier {
        out.push_str(&super::super::classifier::table(curve));
    }
    if let Some(plausibility) = &report.plausibility {
        out.push_str(&super::super::plausibility::table(plausibility));
    }
    out
}

/// The posture rows of `score` (per window after the seed, under the real-vs-real values).
fn posture_rows(p: &motion_metrics::evaluation::posture::PostureScore) -> String {
    let mut out = format!(
        "posture realism against {} takes of {} ({} frames; real arm p99 {:.0} deg)\n",
        p.action,
        p.reference_subjects.join(", "),
        p.reference_frames,
        p.real_arm_elevation_p99_deg
    );
    out.push_str(&format!(
        "  {:<20} {:>9} {:>13} {:>15} {:>15}\n",
        "", "Fréchet", "arm EMD deg", "thigh EMD deg", "arms above p99"
    ));
    let mut line = |label: &str, s: &motion_metrics::evaluation::posture::PostureSummary| {
        out.push_str(&format!(
            "  {:<20} {:>9.3} {:>13.1} {:>15.1} {:>15.2}\n",
            label,
            s.frechet,
            s.arm_elevation_emd_deg,
            s.thigh_elevation_emd_deg,
            s.arms_above_real_p99
        ));
    };
    if let Some(real) = &p.real_vs_real {
        line("real vs real (S5)", real);
    }
    for w in &p.windows {
        if let Some(s) = &w.posture {
            line(&format!("{} s", w.window), s);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The JSON keys of a report are the ones `score` has always written, in the same order.
    #[test]
    fn json_keys_and_types_are_the_former_ones() {
        let mut windows = BTreeMap::new();
        windows.insert("1-2 s".to_string(), 0.5);
        windows.insert("0-1 s".to_string(), 0.25);
        let report = ScoreReport {
            action: None,
            apd: Some(f64::NAN),
            apd_per_sequence: Some(vec![1.0]),
            classifier: None,
            drift: None,
            euler_error: Some(vec![0.1, 0.2]),
            euler_error_ms: Some(
                EULER_HORIZONS_MS
                    .iter()
                    .map(|ms| (ms.to_string(), (*ms == 80).then_some(0.2)))
                    .collect(),
            ),
            foot_contact: None,
            frames: 2,
            mpjpe: None,
            multimodal: None,
            posture: None,
            input_space: InputSpace::Expmap,
            ndms: None,
            npss: Some(0.0),
            npss_reference: None,
            npss_windows: Some(NpssWindows {
                npss: Some(windows),
                npss_reference: None,
            }),
            samples: 1,
            sequences: 3,
            speed_ratio: None,
            plausibility: None,
        };
        let text = serde_json::to_string(&report).unwrap();
        assert_eq!(
            text,
            "{\"apd\":null,\"apd_per_sequence\":[1.0],\"euler_error\":[0.1,0.2],\
             \"euler_error_ms\":{\"1000\":null,\"160\":null,\"320\":null,\"400\":null,\"560\":null,\"80\":0.2},\
             \"frames\":2,\"input_space\":\"expmap\",\"npss\":0.0,\
             \"npss_windows\":{\"npss\":{\"0-1 s\":0.25,\"1-2 s\":0.5}},\"samples\":1,\"sequences\":3}"
        );
        let charts = charts(&report);
        assert_eq!(charts.len(), 2);
        assert_eq!(
            charts[1].series[0].points,
            vec![(500.0, 0.25), (1500.0, 0.5)]
        );
        let table = human_table(&report);
        assert!(table.starts_with("sequences 3  samples 1  frames 2  input space expmap\n"));
        assert!(
            table.contains("APD                                  -\n"),
            "{table}"
        );
    }
}
