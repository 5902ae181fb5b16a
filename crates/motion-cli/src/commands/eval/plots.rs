//! `eval --plot`: metric vs horizon per action (Euler error per frame, NPSS windows, NDMS bins),
//! the model as solid lines and the zero-velocity baseline dashed beside it.
use serde_json::Value;

use crate::plot::{Chart, Series};

/// Milliseconds per predicted frame at the protocol's 25 Hz.
const MS_PER_FRAME: f64 = 40.0;
/// Words per NDMS bin (0.4 s at 25 Hz).
const NDMS_BIN_MS: f64 = 400.0;

/// Three charts per evaluated action, built from the per-action JSON results of `eval`.
pub fn charts(results: &[Value]) -> Vec<Chart> {
    let mut charts = Vec::with_capacity(results.len() * 3);
    for result in results {
        let action = result["action"].as_str().unwrap_or("?");
        let pair = |name: &str, pick: &dyn Fn(&Value) -> Vec<(f64, f64)>| {
            vec![
                Series::new(name, pick(&result["model"])),
                Series::new("zero-velocity", pick(&result["zero_velocity"])).dashed(),
            ]
        };
        charts.push(Chart {
            title: format!("{action}: Euler error"),
            x_label: "horizon (ms)".into(),
            y_label: "Euler error (rad)".into(),
            series: pair("model", &euler_points),
        });
        charts.push(Chart {
            title: format!("{action}: NPSS (reference variant)"),
            x_label: "window centre (ms)".into(),
            y_label: "NPSS".into(),
            series: pair("model", &npss_window_points),
        });
        charts.push(Chart {
            title: format!("{action}: NDMS per 0.4 s"),
            x_label: "bin end (ms)".into(),
            y_label: "NDMS".into(),
            series: pair("model", &ndms_bin_points),
        });
    }
    charts
}

/// Predicted frame `i` (0-based) ends at `(i + 1) * 40` ms.
fn euler_points(scores: &Value) -> Vec<(f64, f64)> {
    numbers(&scores["euler_error_per_frame"])
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64 * MS_PER_FRAME, v))
        .collect()
}

/// NPSS windows are labelled `"A-B s"`; each is drawn at its centre.
fn npss_window_points(scores: &Value) -> Vec<(f64, f64)> {
    let Some(windows) = scores["npss_reference"]["windows"].as_object() else {
        return Vec::new();
    };
    let mut points: Vec<(f64, f64)> = windows
        .iter()
        .filter_map(|(label, value)| Some((window_centre_ms(label)?, value.as_f64()?)))
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points
}

fn window_centre_ms(label: &str) -> Option<f64> {
    let span = label.trim_end_matches('s').trim();
    let (start, end) = span.split_once('-')?;
    let start: f64 = start.trim().parse().ok()?;
    let end: f64 = end.trim().parse().ok()?;
    Some((start + end) * 500.0)
}

fn ndms_bin_points(scores: &Value) -> Vec<(f64, f64)> {
    numbers(&scores["ndms"]["bins"])
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64 * NDMS_BIN_MS, v))
        .collect()
}

fn numbers(value: &Value) -> impl Iterator<Item = f64> + '_ {
    value
        .as_array()
        .into_iter()
        .flatten()
        .map(|v| v.as_f64().unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn charts_per_action_with_baseline_dashed() {
        let scores = json!({
            "euler_error_per_frame": [0.1, 0.2],
            "npss_reference": { "windows": { "1-2 s": 0.3, "0-1 s": 0.2 } },
            "ndms": { "bins": [0.9, 0.8] },
        });
        let results = vec![json!({
            "action": "walking", "model": scores, "zero_velocity": scores,
        })];
        let charts = charts(&results);
        assert_eq!(charts.len(), 3);
        assert_eq!(charts[0].series[0].points, vec![(40.0, 0.1), (80.0, 0.2)]);
        assert!(charts[0].series[1].dashed);
        assert_eq!(
            charts[1].series[0].points,
            vec![(500.0, 0.2), (1500.0, 0.3)]
        );
        assert_eq!(charts[2].series[0].points, vec![(400.0, 0.9), (800.0, 0.8)]);
    }
}
