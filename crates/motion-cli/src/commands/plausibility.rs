//! The plausibility measures (`speed_ratio`, `drift`, `foot_contact`; definitions in
//! `motion_metrics::plausibility`) as `score` and `eval` print them: the action check, the
//! library's report of `(seed, motion)` pairs, and the text tables. No measure is computed here.
use std::path::Path;
use std::sync::Arc;

use anyhow::Result;
use ndarray::ArrayView2;

use motion_core::protocol::ACTIONS;
use motion_metrics::plausibility::{
    action_reference, measure_sequences, ActionReference, PlausibilityReport, SequenceMeasures,
};

use super::UsageError;

/// The H3.6M action named `raw` (case-insensitive), or a usage error listing the valid ones.
pub fn known_action(raw: &str) -> Result<&'static str, UsageError> {
    let name = raw.trim().to_lowercase();
    ACTIONS.iter().copied().find(|a| *a == name).ok_or_else(|| {
        UsageError(format!(
            "unknown action `{raw}`; valid actions: {}",
            ACTIONS.join(", ")
        ))
    })
}

/// The reference statistics of `action` in `dataset` (computed once per process); errors are
/// usage errors (exit 2) naming the directory or file.
pub fn reference(dataset: &Path, action: &str) -> Result<Arc<ActionReference>, UsageError> {
    action_reference(dataset, action)
        .map_err(|e| UsageError(format!("{action} reference statistics: {e}")))
}

/// Measures every `(seed, motion)` pair (`what` names the input in errors).
pub fn measure(
    pairs: &[(ArrayView2<'_, f64>, ArrayView2<'_, f64>)],
    what: &str,
) -> Result<Vec<SequenceMeasures>, UsageError> {
    measure_sequences(pairs).map_err(|e| UsageError(format!("{what}: {e}")))
}

fn cell(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "-".to_string(), |x| format!("{x:.decimals$}"))
}

fn window_label(start: f64, end: f64) -> String {
    format!("{start}-{end} s")
}

/// The table of one report (`score`): one column per window.
pub fn table(report: &PlausibilityReport) -> String {
    let speed = &report.speed_ratio;
    let mut out = format!(
        "plausibility vs {} data ({} sequences; speed reference {:.1} mm/s over S5, drift p95 over {} real 12 s windows)\n",
        speed.action,
        report.sequences,
        speed.reference_mean_speed_mm_s,
        report.drift.reference_windows
    );
    out.push_str(&format!("  {:<32}", "window"));
    for w in &speed.windows {
        out.push_str(&format!("{:>16}", window_label(w.start_s, w.end_s)));
    }
    out.push('\n');
    let mut line = |label: &str, cells: Vec<String>| {
        out.push_str(&format!("  {label:<32}"));
        for c in cells {
            out.push_str(&format!("{c:>16}"));
        }
        out.push('\n');
    };
    line(
        "speed_ratio",
        speed.windows.iter().map(|w| cell(w.ratio, 3)).collect(),
    );
    line(
        "drift hip height mm (p95)",
        report
            .drift
            .windows
            .iter()
            .map(|w| format!("{} ({:.0})", cell(w.hip_height_mm, 0), w.hip_height_p95_mm))
            .collect(),
    );
    line(
        "  within p95",
        report
            .drift
            .windows
            .iter()
            .map(|w| cell(w.hip_height_within_p95, 2))
            .collect(),
    );
    line(
        "drift lean deg (p95)",
        report
            .drift
            .windows
            .iter()
            .map(|w| format!("{} ({:.1})", cell(w.lean_deg, 1), w.lean_p95_deg))
            .collect(),
    );
    line(
        "  within p95",
        report
            .drift
            .windows
            .iter()
            .map(|w| cell(w.lean_within_p95, 2))
            .collect(),
    );
    line(
        "foot_contact (airborne fraction)",
        report
            .foot_contact
            .windows
            .iter()
            .map(|w| cell(w.airborne_fraction, 3))
            .collect(),
    );
    out
}

/// The rows of `eval`: each measure per window for the model, the zero-velocity baseline and
/// the real continuation side by side (`real` may cover fewer windows: its sequence counts are
/// shown).
pub fn comparison_rows(
    model: &PlausibilityReport,
    zero_velocity: &PlausibilityReport,
    real: &PlausibilityReport,
) -> String {
    let mut out = format!(
        "  plausibility (speed ref {:.1} mm/s; drift p95 over {} real 12 s windows)\n  {:<28} {:>8} {:>9} {:>8}   real windows / p95\n",
        model.speed_ratio.reference_mean_speed_mm_s,
        model.drift.reference_windows,
        "",
        "model",
        "zero-vel",
        "real"
    );
    let mut row =
        |label: String, m: Option<f64>, z: Option<f64>, r: Option<f64>, d: usize, tail: String| {
            let line = format!(
                "  {label:<28} {:>8} {:>9} {:>8}   {tail}",
                cell(m, d),
                cell(z, d),
                cell(r, d)
            );
            out.push_str(line.trim_end());
            out.push('\n');
        };
    for (i, w) in model.speed_ratio.windows.iter().enumerate() {
        let label = window_label(w.start_s, w.end_s);
        let count = real.speed_ratio.windows[i].sequences;
        row(
            format!("speed_ratio {label}"),
            w.ratio,
            zero_velocity.speed_ratio.windows[i].ratio,
            real.speed_ratio.windows[i].ratio,
            3,
            format!("{count}"),
        );
    }
    for (i, w) in model.drift.windows.iter().enumerate() {
        let label = window_label(w.start_s, w.end_s);
        let (z, r) = (&zero_velocity.drift.windows[i], &real.drift.windows[i]);
        row(
            format!("drift hip mm {label}"),
            w.hip_height_mm,
            z.hip_height_mm,
            r.hip_height_mm,
            0,
            format!(
                "{}  p95 {:.0}, model within {}",
                r.sequences,
                w.hip_height_p95_mm,
                cell(w.hip_height_within_p95, 2)
            ),
        );
        row(
            format!("drift lean deg {label}"),
            w.lean_deg,
            z.lean_deg,
            r.lean_deg,
            1,
            format!(
                "{}  p95 {:.1}, model within {}",
                r.sequences,
                w.lean_p95_deg,
                cell(w.lean_within_p95, 2)
            ),
        );
    }
    for (i, w) in model.foot_contact.windows.iter().enumerate() {
        let label = window_label(w.start_s, w.end_s);
        row(
            format!("foot_contact {label}"),
            w.airborne_fraction,
            zero_velocity.foot_contact.windows[i].airborne_fraction,
            real.foot_contact.windows[i].airborne_fraction,
            3,
            format!("{}", real.foot_contact.windows[i].sequences),
        );
    }
    out
}

/// [`PlausibilityReport::new`] of measured sequences (re-exported for the commands).
pub fn report(
    measures: &[SequenceMeasures],
    horizon: usize,
    reference: &ActionReference,
) -> PlausibilityReport {
    PlausibilityReport::new(measures, horizon, reference)
}

/// One floor-frame row: label, the value of a window, decimals.
type GroundRow = (
    &'static str,
    fn(&motion_metrics::plausibility::GroundWindow) -> Option<f64>,
    usize,
);

/// The floor-frame rows of `eval`: per window, the model's raw and grounded predictions and the
/// real continuation (lowest foot on the floor, penetration, skating, lean p95), with the real
/// ranges of the action's first 2 s after a seed.
pub fn ground_rows(
    model: &PlausibilityReport,
    grounded: &PlausibilityReport,
    real: &PlausibilityReport,
) -> String {
    let ranges = &model.ground.real;
    let mut out = format!(
        "  floor frame (real, first 2 s after a seed: lean p95 {:.1} deg, hips {:.0}-{:.0} mm, on the floor {:.2}, skating {:.2})\n  {:<28} {:>8} {:>9} {:>8}\n",
        ranges.lean_p95_deg,
        ranges.hip_height_p5_mm,
        ranges.hip_height_p95_mm,
        ranges.on_floor_fraction,
        ranges.skating_fraction,
        "",
        "model",
        "grounded",
        "real"
    );
    let rows: [GroundRow; 4] = [
        ("on the floor", |w| w.on_floor_fraction, 2),
        ("penetrating", |w| w.penetration_fraction, 2),
        ("skating", |w| w.skating_fraction, 2),
        ("lean p95 deg", |w| w.lean_p95_deg, 1),
    ];
    for (label, pick, decimals) in rows {
        for (i, w) in model.ground.windows.iter().enumerate() {
            let at = |r: &PlausibilityReport| r.ground.windows.get(i).and_then(pick);
            let line = format!(
                "  {:<28} {:>8} {:>9} {:>8}",
                format!("{label} {}", window_label(w.start_s, w.end_s)),
                cell(pick(w), decimals),
                cell(at(grounded), decimals),
                cell(at(real), decimals)
            );
            out.push_str(line.trim_end());
            out.push('\n');
        }
    }
    out
}
