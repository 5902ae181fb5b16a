//! The action-classifier protocol of Ghosh et al. 2017 (definition in `motion_metrics::classifier`) as
//! `score` and `eval` print it: errors as usage errors, the text table and the chart. No score is
//! computed here.
use anyhow::Result;
use ndarray::ArrayView3;

use motion_core::model::ActionClassifier;
use motion_metrics::{classifier_protocol, ClassifierCurve};

use crate::plot::{Chart, Series};

/// [`classifier_protocol`] with its errors as usage errors naming `what`.
pub fn curve(
    classifier: &ActionClassifier,
    seeds: Option<ArrayView3<'_, f64>>,
    predictions: ArrayView3<'_, f64>,
    action: &str,
    what: &str,
) -> Result<ClassifierCurve> {
    classifier_protocol(classifier, seeds, predictions, action)
        .map_err(|e| anyhow::Error::new(e).context(format!("{what}: action classifier")))
}

/// The class with the highest mean probability at window `k`.
fn most_likely(curve: &ClassifierCurve, k: usize) -> &str {
    let row = &curve.mean_probabilities[k];
    let best = (0..row.len())
        .max_by(|&a, &b| row[a].total_cmp(&row[b]))
        .unwrap_or(0);
    curve.classes.get(best).map_or("-", String::as_str)
}

/// The table of `score`: one row per window end.
pub fn table(curve: &ClassifierCurve) -> String {
    let mut out = format!(
        "action classifier (Ghosh et al. 2017): p({}) over {} predictions, {} s windows every second\n  {:>8} {:>10} {:>8}   most likely (mean p)\n",
        curve.action, curve.sequences, curve.window_s, "end (s)", "p(action)", "top-1"
    );
    for (k, t) in curve.times_s.iter().enumerate() {
        let best = most_likely(curve, k);
        let p = curve
            .classes
            .iter()
            .position(|c| c == best)
            .map_or(0.0, |i| curve.mean_probabilities[k][i]);
        out.push_str(&format!(
            "  {t:>8.1} {:>10.3} {:>8.3}   {best} ({p:.2})\n",
            curve.prob[k], curve.top1[k]
        ));
    }
    out
}

/// Ghosh et al. 2017 Figure 4 style: the probability of the action and the top-1 rate vs time.
pub fn chart(curve: &ClassifierCurve) -> Chart {
    let points = |values: &[f64]| -> Vec<(f64, f64)> {
        curve
            .times_s
            .iter()
            .zip(values)
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .map(|(&t, &v)| (t, v))
            .collect()
    };
    Chart {
        title: format!("action classifier: {}", curve.action),
        x_label: "window end (s after the seed)".into(),
        y_label: "probability".into(),
        series: vec![
            Series::new("p(action)", points(&curve.prob)),
            Series::new("top-1 rate", points(&curve.top1)).dashed(),
        ],
    }
}

/// The rows of `eval`: the probability of the action and the top-1 rate per window end for the
/// model, the zero-velocity baseline and the real continuation (with the number of real windows
/// covering each end).
pub fn comparison_rows(
    model: &ClassifierCurve,
    zero_velocity: &ClassifierCurve,
    real: &ClassifierCurve,
) -> String {
    let mut out = format!(
        "  action classifier: p({}) / top-1 per {} s window, ending at (s)\n  {:<12} {:>13} {:>13} {:>13}   real windows\n",
        model.action, model.window_s, "", "model", "zero-vel", "real"
    );
    let at = |curve: &ClassifierCurve, t: f64| {
        curve
            .times_s
            .iter()
            .position(|x| (x - t).abs() < 1e-9)
            .map(|k| (curve.prob[k], curve.top1[k], curve.sequences_per_window[k]))
    };
    let pair = |v: Option<(f64, f64, usize)>| {
        v.map_or_else(|| "-".to_string(), |(p, t, _)| format!("{p:.2} / {t:.2}"))
    };
    for &t in &model.times_s {
        let r = at(real, t);
        out.push_str(&format!(
            "  {:<12} {:>13} {:>13} {:>13}   {}\n",
            format!("{t:.0} s"),
            pair(at(model, t)),
            pair(at(zero_velocity, t)),
            pair(r),
            r.map_or(0, |v| v.2)
        ));
    }
    out
}
