//! `eval --plot`: metric vs horizon per action (Euler error per frame, NPSS windows, NDMS bins),
//! the model as solid lines and the zero-velocity baseline dashed beside it.
use crate::plot::{bin_points, per_frame_points, window_points, Chart, Series};
use motion_metrics::evaluation::report::{ActionResult, ActionScores};

/// Three charts per evaluated action, built from the per-action results of the `eval` report.
pub fn charts(results: &[ActionResult]) -> Vec<Chart> {
    let mut charts = Vec::with_capacity(results.len() * 3);
    for result in results {
        let action = result.action;
        let pair = |name: &str, pick: &dyn Fn(&ActionScores) -> Vec<(f64, f64)>| {
            vec![
                Series::new(name, pick(&result.model)),
                Series::new("zero-velocity", pick(&result.zero_velocity)).dashed(),
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

fn euler_points(scores: &ActionScores) -> Vec<(f64, f64)> {
    per_frame_points(&scores.euler_error_per_frame)
}

fn npss_window_points(scores: &ActionScores) -> Vec<(f64, f64)> {
    window_points(
        scores
            .npss_reference
            .windows
            .iter()
            .map(|(label, v)| (label.as_str(), *v)),
    )
}

fn ndms_bin_points(scores: &ActionScores) -> Vec<(f64, f64)> {
    bin_points(&scores.ndms.bins)
}

#[cfg(test)]
mod tests {
    use super::super::table::fixtures;
    use super::*;
    use motion_metrics::evaluation::published;
    use motion_metrics::evaluation::report::{CoverageReport, GroundTruth};

    #[test]
    fn charts_per_action_with_baseline_dashed() {
        let scores = fixtures::scores(&[0.1, 0.2], &[("1-2 s", 0.3), ("0-1 s", 0.2)], &[0.9, 0.8]);
        let results = vec![ActionResult {
            action: "walking",
            label: None,
            windows: 8,
            window_starts: vec![(1, 16); 8],
            samples: 1,
            horizon: 2,
            ground_truth_coverage: CoverageReport {
                frames_per_window: vec![2; 8],
                windows_per_second: vec![8],
                npss_whole_frames: 2,
                npss_windows: Default::default(),
            },
            ndms_database_words: 1,
            model: scores.clone(),
            zero_velocity: scores.clone(),
            model_grounded: scores.plausibility.clone(),
            ground_truth: GroundTruth {
                mean_joint_speed_last_1s: None,
                plausibility: scores.plausibility.clone(),
                classifier: None,
                real_motion_ndms: None,
            },
            published: published::for_action("walking"),
            posture: None,
        }];
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
