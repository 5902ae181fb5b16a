//! The human-readable form of an MPJPE report: per action the model, zero-velocity and HRI's
//! published row at the 8 horizons, then the average beside the published averages.
use motion_metrics::evaluation::mpjpe::MpjpeReport;

fn values(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:>7.1}"))
        .collect::<Vec<_>>()
        .join("")
}

fn optional(v: &[Option<f64>]) -> String {
    v.iter()
        .map(|x| x.map_or_else(|| format!("{:>7}", "-"), |x| format!("{x:>7.1}")))
        .collect::<Vec<_>>()
        .join("")
}

/// The table `eval --protocol mpjpe` prints.
pub fn table(report: &MpjpeReport) -> String {
    let w = &report.windows;
    let mut out = format!(
        "MPJPE (mm) of {} on S5, {} windows per action ({}), {} observed + {} predicted frames at 25 Hz, {} joint mean\n",
        report.model.source,
        match w.set {
            "all" => format!("every window at stride {}", w.stride.unwrap_or(0)),
            set => set.to_string(),
        },
        match (w.sampler_seed, w.sampler_input) {
            (Some(seed), Some(input)) => format!("numpy RandomState({seed}), placed for {input} observed frames"),
            _ => "both takes".to_string(),
        },
        w.input_frames,
        w.output_frames,
        report.method.joint_mean.split(':').next().unwrap_or("")
    );
    out.push_str(&format!(
        "{:<26}{}\n",
        "ms",
        report
            .horizons_ms
            .iter()
            .map(|h| format!("{h:>7}"))
            .collect::<String>()
    ));
    for a in &report.actions {
        out.push_str(&format!("{} ({} windows)\n", a.action, a.windows));
        out.push_str(&format!("  {:<24}{}\n", "model", values(&a.model)));
        out.push_str(&format!(
            "  {:<24}{}\n",
            "zero-velocity",
            values(&a.zero_velocity)
        ));
        if let Some(hri) = &a.published_hri {
            out.push_str(&format!("  {:<24}{}\n", "HRI (published)", values(hri)));
        }
    }
    out.push_str(&format!("average: {}\n", report.average.label));
    out.push_str(&format!(
        "  {:<24}{}\n",
        "model",
        values(&report.average.model)
    ));
    out.push_str(&format!(
        "  {:<24}{}\n",
        "zero-velocity",
        values(&report.average.zero_velocity)
    ));
    if !report.published.is_empty() {
        out.push_str(if report.published.iter().all(|r| r.same_actions) {
            "published, 15-action averages (the same actions):\n"
        } else {
            "published, 15-action averages (this average is over fewer actions: compare per action):\n"
        });
    }
    for row in &report.published {
        out.push_str(&format!(
            "  {}\n  {:<24}{}\n",
            row.method,
            "",
            optional(&row.values)
        ));
    }
    for s in &report.skipped {
        out.push_str(&format!("skipped {}: {}\n", s.action, s.reason));
    }
    out.push_str(&format!("positions: {}\n", report.method.positions));
    out
}
