//! `eval --plot`: metric vs horizon per action (Euler error per frame, NPSS windows, NDMS bins),
//! the model as solid lines and the zero-velocity baseline dashed beside it.
use serde_json::Value;

use crate::plot::{bin_points, per_frame_points, window_points, Chart, Series};

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

fn euler_points(scores: &Value) -> Vec<(f64, f64)> {
    per_frame_points(&scores["euler_error_per_frame"])
}

fn npss_window_points(scores: &Value) -> Vec<(f64, f64)> {
    window_points(&scores["npss_reference"]["windows"])
}

fn ndms_bin_points(scores: &Value) -> Vec<(f64, f64)> {
    bin_points(&scores["ndms"]["bins"])
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
