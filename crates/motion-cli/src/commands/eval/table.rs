//! The human-readable form of an evaluation report: one block per action with the model, the
//! zero-velocity baseline and the published numbers side by side, then the means over actions.
//! The table, the JSON and the plots (`super::plots`) all read the same report.
use motion_metrics::evaluation::published::{self, TABLE6_HORIZONS_MS};
use motion_metrics::evaluation::report::*;
use motion_metrics::EULER_HORIZONS_MS;

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
        "{classifier}{}{}{}",
        super::super::plausibility::comparison_rows(
            &a.model.plausibility.0,
            &a.zero_velocity.plausibility.0,
            &a.ground_truth.plausibility.0,
        ),
        super::super::plausibility::ground_rows(
            &a.model.plausibility.0,
            &a.model_grounded.0,
            &a.ground_truth.plausibility.0,
        ),
        posture_rows(a)
    )
}

/// The posture-realism rows of one action (`motion_metrics::posture`): per window, the Fréchet
/// distance and the share of frames with an upper arm above the real p99, for the model raw
/// and grounded, zero-velocity and the real continuation, under the real-vs-real values.
fn posture_rows(a: &ActionResult) -> String {
    let Some(p) = &a.posture else {
        return String::new();
    };
    let real = p.real_vs_real.map_or("no S5 takes".to_string(), |r| {
        format!(
            "Fréchet {:.3}, arm EMD {:.1} deg, arms above p99 {:.2}",
            r.frechet, r.arm_elevation_emd_deg, r.arms_above_real_p99
        )
    });
    let mut out = format!(
        "  posture (real vs real, S5 takes: {real}; real arm p99 {:.0} deg)\n  {:<28} {:>8} {:>9} {:>9} {:>8}\n",
        p.real_arm_elevation_p99_deg, "", "model", "grounded", "zero-vel", "real"
    );
    type Pick = fn(&motion_metrics::evaluation::posture::PostureSummary) -> f64;
    let rows: [(&str, Pick, usize); 2] = [
        ("Fréchet", |s| s.frechet, 3),
        ("arms above p99", |s| s.arms_above_real_p99, 2),
    ];
    for (label, pick, decimals) in rows {
        for (i, w) in p.model.iter().enumerate() {
            if w.posture.is_none() {
                continue;
            }
            let at = |ws: &[motion_metrics::evaluation::posture::PostureWindow]| {
                ws.get(i)
                    .and_then(|w| w.posture.as_ref())
                    .map(|s| format!("{:.*}", decimals, pick(s)))
                    .unwrap_or_else(|| "-".into())
            };
            let line = format!(
                "  {:<28} {:>8} {:>9} {:>9} {:>8}",
                format!("{label} {} s", w.window),
                at(&p.model),
                at(&p.model_grounded),
                at(&p.zero_velocity),
                at(&p.ground_truth)
            );
            out.push_str(line.trim_end());
            out.push('\n');
        }
    }
    out
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
    use motion_metrics::PlausibilityReport;

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
