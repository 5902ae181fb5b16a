//! The human-readable form of the stochastic variant's report: the model's and zero-velocity's
//! means over all windows, then per action.
use motion_metrics::evaluation::stochastic::StochasticReport;
use motion_metrics::multimodal::SampleSetScores;

fn scores(s: &SampleSetScores) -> String {
    format!(
        "{:>8.3}{:>8.3}{:>8.3}{:>8.3}{:>8.3}",
        s.apd, s.ade, s.fde, s.mmade, s.mmfde
    )
}

/// The table `eval --protocol stochastic` prints.
pub fn table(report: &StochasticReport) -> String {
    let mut out = format!(
        "{} of {}: {} windows of S9 and S11, {} sample(s) per window, multimodal threshold {} m (mean set {:.1} windows)\n",
        report.protocol,
        report.model.source,
        report.windows,
        report.samples,
        report.threshold,
        report.mean_multimodal_set
    );
    out.push_str(&format!(
        "{:<26}{:>8}{:>8}{:>8}{:>8}{:>8}\n",
        "", "APD", "ADE", "FDE", "MMADE", "MMFDE"
    ));
    out.push_str(&format!(
        "{:<26}{}\n",
        "model",
        scores(&report.model_scores)
    ));
    out.push_str(&format!(
        "{:<26}{}\n",
        "zero-velocity",
        scores(&report.zero_velocity)
    ));
    for a in &report.actions {
        out.push_str(&format!(
            "{:<26}{}\n{:<26}{}\n",
            format!("{} ({})", a.action, a.windows),
            scores(&a.model),
            "  zero-velocity",
            scores(&a.zero_velocity)
        ));
    }
    for m in &report.missing_takes {
        out.push_str(&format!("missing take: {m}\n"));
    }
    for s in &report.skipped {
        out.push_str(&format!("skipped {}: {}\n", s.action, s.reason));
    }
    out.push_str(&format!("{}\n", report.not_comparable));
    out
}
