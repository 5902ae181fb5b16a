//! The human-readable form of the `eval` report: one block per action with the model, the
//! zero-velocity baseline and the published numbers side by side, then the means over actions.
use serde_json::Value;

use super::published::{self, TABLE6_HORIZONS_MS};
use motion_metrics::EULER_HORIZONS_MS;

/// A number cell: 3 decimals, `-` when absent.
fn cell(v: &Value) -> String {
    v.as_f64()
        .map_or_else(|| "-".to_string(), |x| format!("{x:.3}"))
}

fn cells_int(values: &Value) -> String {
    values
        .as_array()
        .map(|a| {
            a.iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_default()
}

fn cells(values: &Value) -> String {
    values
        .as_array()
        .map(|a| a.iter().map(cell).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

/// The NDMS 0.4 s bins of model and baseline, then paper 003's "Ours" row for `action` (Table 2;
/// `average` for the mean over 15 actions) followed by `note`.
fn ndms_bins(out: &mut String, model: &Value, baseline: &Value, action: &str, note: &str) {
    out.push_str(&format!(
        "  NDMS 0.4 s bins   model    {}\n                    zero-vel {}\n",
        cells(model),
        cells(baseline)
    ));
    for r in published::ndms_rows(action) {
        if r.method.starts_with("Ours") {
            let bins: Vec<String> = r
                .bins
                .iter()
                .map(|b| b.map_or("-".into(), |v| format!("{v:.3}")))
                .collect();
            out.push_str(&format!(
                "                    paper 003 {}{note}\n",
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

fn row(out: &mut String, label: &str, model: &Value, baseline: &Value, published: &str) {
    let line = format!(
        "  {label:<28} {:>8} {:>9}   {published}",
        cell(model),
        cell(baseline)
    );
    out.push_str(line.trim_end());
    out.push('\n');
}

fn action_block(out: &mut String, a: &Value) {
    let action = a["action"].as_str().unwrap_or("");
    let (m, z) = (&a["model"], &a["zero_velocity"]);
    out.push_str(&format!(
        "\n{action}: {} windows x {} samples, horizon {} frames; NDMS database {} words (exact NN)\n",
        a["windows"], a["samples"], a["horizon"], a["ndms_database_words"]
    ));
    out.push_str(&format!(
        "  {:<28} {:>8} {:>9}   published\n",
        "", "model", "zero-vel"
    ));
    let coverage = &a["ground_truth_coverage"];
    let per_second = cells_int(&coverage["windows_per_second"]);
    if coverage["windows_per_second"]
        .as_array()
        .is_some_and(|s| s.iter().any(|n| n.as_u64() != a["windows"].as_u64()))
    {
        out.push_str(&format!(
            "  ground truth (S5 file ends): windows covering each second {per_second}; NPSS whole over the first {} frames\n",
            coverage["npss_whole_frames"]
        ));
    }
    let windows = ["0-1 s", "1-2 s", "2-4 s", "4-8 s", "8-12 s"];
    for (key, name, with_published) in [
        ("npss_reference", "NPSS reference Re(DFT)²", true),
        ("npss", "NPSS paper |DFT|²", false),
    ] {
        // The published numbers are over 4 s: beside a longer `whole` they would mislead.
        let whole_is_4s = coverage["npss_whole_frames"]
            .as_u64()
            .is_none_or(|f| f <= 100);
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
            &m[key]["whole"],
            &z[key]["whole"],
            &whole_published,
        );
        for (i, w) in windows.iter().enumerate() {
            if m[key]["windows"].get(w).is_none() {
                continue;
            }
            let text = if with_published && i < 3 {
                let p003 = (i == 2)
                    .then(|| {
                        a["published"]["paper003_table1_npss_reference_2_4s"]["Ours (paper 003)"]
                            .as_f64()
                    })
                    .flatten();
                published_pairs(&[
                    ("VGRU-d", published::table5_npss("VGRU-d", action, i)),
                    ("GRU-d", published::table5_npss("GRU-d", action, i)),
                    ("paper 003", p003),
                ])
            } else {
                String::new()
            };
            let covering = &coverage["npss_windows"][w];
            let label = match covering.as_u64() {
                Some(n) if Some(n) != a["windows"].as_u64() => format!("  {w} ({n} windows)"),
                _ => format!("  {w}"),
            };
            row(
                out,
                &label,
                &m[key]["windows"][w],
                &z[key]["windows"][w],
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
            &m["euler_error_ms"][&key],
            &z["euler_error_ms"][&key],
            &text,
        );
    }
    row(
        out,
        "NDMS f_sim",
        &m["ndms"]["mean"],
        &z["ndms"]["mean"],
        "",
    );
    ndms_bins(out, &m["ndms"]["bins"], &z["ndms"]["bins"], action, "");
    if m.get("apd").is_some() {
        row(out, "APD (mm)", &m["apd"], &Value::Null, "");
    }
    let gt = &a["ground_truth"]["mean_joint_speed_last_1s"];
    for kind in ["world", "pose"] {
        out.push_str(&format!(
            "  joint speed last 1 s, {kind:<5} {:>8} {:>9}   ground truth {} mm/frame\n",
            cell(&m["mean_joint_speed_last_1s"][kind]),
            cell(&z["mean_joint_speed_last_1s"][kind]),
            cell(&gt[kind])
        ));
    }
}

/// The report as text; `plausibility` holds each action's plausibility rows (in the order of
/// `report["actions"]`), made from the same typed reports as the JSON.
pub fn table(report: &Value, plausibility: &[String]) -> String {
    let mut out = String::new();
    let model = &report["model"];
    let protocol = &report["protocol"];
    out.push_str(&format!(
        "model {} ({}, hidden {}, {}); data {}\n",
        model["source"].as_str().unwrap_or(""),
        model["architecture"].as_str().unwrap_or(""),
        model["hidden"],
        if model["stochastic"].as_bool() == Some(true) {
            "stochastic"
        } else {
            "deterministic"
        },
        report["data"].as_str().unwrap_or("")
    ));
    out.push_str(&format!(
        "protocol: S5, 8 windows per action, {} seed frames at 25 Hz, horizon {}, {} samples, rng seed {}\n",
        protocol["seed_frames"], protocol["horizon"], protocol["samples"], protocol["rng_seed"]
    ));
    if let Some(note) = model["note"].as_str() {
        out.push_str(&format!("note: {note}\n"));
    }
    for (i, a) in report["actions"]
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
    {
        action_block(&mut out, a);
        if let Some(rows) = plausibility.get(i) {
            out.push_str(rows);
        }
    }
    let means = &report["mean_over_actions"];
    out.push_str(&format!(
        "\nmean over {} actions         {:>8} {:>9}\n",
        means["actions"], "model", "zero-vel"
    ));
    for (label, pointer) in [
        ("NPSS reference whole", "/npss_reference"),
        ("NPSS paper whole", "/npss"),
        ("NDMS f_sim", "/ndms"),
    ] {
        row(
            &mut out,
            label,
            means["model"].pointer(pointer).unwrap_or(&Value::Null),
            means["zero_velocity"]
                .pointer(pointer)
                .unwrap_or(&Value::Null),
            "",
        );
    }
    ndms_bins(
        &mut out,
        &means["model"]["ndms_bins"],
        &means["zero_velocity"]["ndms_bins"],
        "average",
        " (average of 15 actions)",
    );
    if means["model"]["apd"].is_number() {
        let paper: Vec<String> = published::P003_TABLE5_APD_H36M
            .iter()
            .map(|(m, v)| format!("{m} {v:.2}"))
            .collect();
        row(
            &mut out,
            "APD (mm)",
            &means["model"]["apd"],
            &Value::Null,
            &format!("paper 003 Table 5 (unit unstated): {}", paper.join(", ")),
        );
    }
    for ms in EULER_HORIZONS_MS {
        let key = ms.to_string();
        row(
            &mut out,
            &format!("Euler error {ms} ms"),
            &means["model"]["euler_error_ms"][&key],
            &means["zero_velocity"]["euler_error_ms"][&key],
            "",
        );
    }
    for s in report["skipped"].as_array().into_iter().flatten() {
        out.push_str(&format!(
            "skipped {}: {}\n",
            s["action"].as_str().unwrap_or(""),
            s["reason"].as_str().unwrap_or("")
        ));
    }
    if let Some(saved) = report.get("save_predictions") {
        out.push_str(&format!(
            "predictions: {} (shape {}; actions in order: {})\n",
            saved["path"].as_str().unwrap_or(""),
            saved["shape"],
            saved["actions"]
                .as_array()
                .map(|a| a
                    .iter()
                    .filter_map(Value::as_str)
                    .collect::<Vec<_>>()
                    .join(", "))
                .unwrap_or_default()
        ));
    }
    out
}
