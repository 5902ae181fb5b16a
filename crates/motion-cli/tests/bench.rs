//! `motion-cli bench`, driven through the built binary with tiny step counts: checks the JSON
//! structure and the usage errors only (speed is measured, never asserted, in tests).
mod common;

use common::repo;
use std::path::Path;
use std::process::Command;

/// Runs `motion-cli bench ARGS`; returns (exit code, stdout, stderr).
fn bench(args: &[&str]) -> (i32, String, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .arg("bench")
        .args(args)
        .output()
        .expect("motion-cli runs");
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Checks one `results` row and returns (arch, hidden, batch).
fn check_row(row: &serde_json::Value) -> (String, u64, u64) {
    let us = row["us_per_step"]
        .as_f64()
        .expect("us_per_step is a number");
    let rate = row["char_steps_per_s"]
        .as_f64()
        .expect("char_steps_per_s is a number");
    assert!(us > 0.0 && rate > 0.0, "{row}");
    (
        row["arch"].as_str().expect("arch is a string").to_string(),
        row["hidden"].as_u64().expect("hidden is an integer"),
        row["batch"].as_u64().expect("batch is an integer"),
    )
}

#[test]
fn json_has_one_row_per_architecture_and_batch() {
    let (code, out, err) = bench(&["--hidden", "16", "--batch", "1,3", "--steps", "2", "--json"]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
    let rows: Vec<_> = report["results"]
        .as_array()
        .expect("results is an array")
        .iter()
        .map(check_row)
        .collect();
    let expected: Vec<(String, u64, u64)> =
        [("gru-d", 1), ("gru-d", 3), ("vgru-d", 1), ("vgru-d", 3)]
            .iter()
            .map(|&(a, b)| (a.to_string(), 16, b))
            .collect();
    assert_eq!(rows, expected);
    let peak = report["peak_rss_mb"]
        .as_f64()
        .expect("peak_rss_mb is a number");
    assert!(peak > 0.0);
}

#[test]
fn model_file_and_replanning_run() {
    let model = repo().join("tests/fixtures/parity/vgru_d.safetensors");
    let model = model.to_str().expect("utf-8 path");
    let (code, out, err) = bench(&[
        "--model",
        model,
        "--batch",
        "2",
        "--steps",
        "3",
        "--with-plan",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
    let rows = report["results"].as_array().expect("results is an array");
    assert_eq!(rows.len(), 1);
    assert_eq!(check_row(&rows[0]).0, "vgru-d");
}

#[test]
fn shards_are_reported_and_chosen() {
    // The default rule: one shard below 16 rows; `--shards` overrides it (at most one per row).
    let shards_of = |extra: &[&str]| -> Vec<(u64, u64)> {
        let mut args = vec![
            "--arch", "gru-d", "--hidden", "8", "--batch", "4,16", "--steps", "2",
        ];
        args.extend_from_slice(extra);
        args.push("--json");
        let (code, out, err) = bench(&args);
        assert_eq!(code, 0, "{err}");
        let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
        report["results"]
            .as_array()
            .expect("results is an array")
            .iter()
            .map(|row| {
                (
                    row["batch"].as_u64().expect("batch"),
                    row["shards"].as_u64().expect("shards is an integer"),
                )
            })
            .collect()
    };
    assert_eq!(shards_of(&["--shards", "1"]), [(4, 1), (16, 1)]);
    assert_eq!(shards_of(&["--shards", "3"]), [(4, 2), (16, 3)]);
    let default = shards_of(&[]);
    assert_eq!(default[0], (4, 1));
    assert!(default[1].1 >= 1, "{default:?}");
}

#[test]
fn repeats_report_the_steady_slowest_step() {
    // Per step index the fastest of the repeats, then the slowest index: never above the slowest
    // step of all runs, and without --repeats it is that run's own slowest step.
    let rows = |extra: &[&str]| -> Vec<serde_json::Value> {
        let mut args = vec![
            "--arch",
            "vgru-d",
            "--hidden",
            "8",
            "--batch",
            "1,3",
            "--steps",
            "5",
            "--with-plan",
        ];
        args.extend_from_slice(extra);
        args.push("--json");
        let (code, out, err) = bench(&args);
        assert_eq!(code, 0, "{err}");
        let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
        report["results"].as_array().expect("results").clone()
    };
    for row in rows(&["--repeats", "3"]) {
        assert_eq!(row["repeats"].as_u64(), Some(3), "{row}");
        let steady = row["steady_max_us"].as_f64().expect("steady_max_us");
        let steady_median = row["steady_median_us"].as_f64().expect("steady_median_us");
        let max = row["max_us"].as_f64().expect("max_us");
        assert!(
            0.0 < steady_median && steady_median <= steady && steady <= max,
            "{row}"
        );
    }
    for row in rows(&[]) {
        assert_eq!(row["repeats"].as_u64(), Some(1), "{row}");
        assert_eq!(
            row["steady_max_us"].as_f64(),
            row["max_us"].as_f64(),
            "{row}"
        );
    }
}

#[test]
fn text_table_names_the_columns() {
    let (code, out, err) = bench(&[
        "--arch", "gru-d", "--hidden", "8", "--batch", "1", "--steps", "1",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("µs/step") && out.contains("char-steps/s"),
        "{out}"
    );
    assert!(out.contains("peak RSS"), "{out}");
}

#[test]
fn bad_input_exits_2() {
    for args in [
        &["--steps", "0"][..],
        &["--batch", "0"][..],
        &["--arch", "lstm"][..],
        &["--model", "/nonexistent/w.safetensors", "--steps", "1"][..],
        &["--npss", "/nonexistent/gt.npy", "/nonexistent/pred.npy"][..],
        &["--shards", "0", "--steps", "1"][..],
        &["--repeats", "0", "--steps", "1"][..],
    ] {
        let (code, _, err) = bench(args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!err.is_empty());
    }
}

#[test]
fn npss_timing_reports_both_spectra() {
    use motion_core::formats::npy::write_npy;
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench-npss");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let gt = ndarray::Array3::from_shape_fn((3, 8, 2), |(i, t, d)| ((i + 2 * t + d) as f64).sin());
    let pred = gt.mapv(|v| 0.9 * v + 0.05);
    let (gt_path, pred_path) = (dir.join("gt.npy"), dir.join("pred.npy"));
    write_npy(&gt_path, &gt).unwrap();
    write_npy(&pred_path, &pred).unwrap();
    let (code, out, err) = bench(&[
        "--npss",
        gt_path.to_str().unwrap(),
        pred_path.to_str().unwrap(),
        "--reps",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
    let rows = report["npss"].as_array().expect("npss is an array");
    let metrics: Vec<&str> = rows.iter().map(|r| r["metric"].as_str().unwrap()).collect();
    assert_eq!(metrics, ["npss", "npss-reference"]);
    let expected = motion_metrics::npss::npss(gt.view(), pred.view()).unwrap();
    assert!((rows[0]["value"].as_f64().unwrap() - expected).abs() < 1e-12);
    assert!(rows[0]["median_ms"].as_f64().unwrap() >= 0.0);
}

#[test]
fn ndms_timing_scores_every_set_of_the_manifest() {
    use motion_core::formats::npy::write_npy;
    use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod};
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench-ndms");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // 32-joint positions with every joint moving: a database sequence and 2 forecasts per set.
    let motion = |frames: usize, salt: usize| {
        ndarray::Array3::from_shape_fn((frames, 32, 3), |(t, j, c)| {
            let phase = (salt * 97 + j * 3 + c) as f64;
            100.0 * (0.2 * t as f64 + phase).sin() + 10.0 * phase
        })
    };
    let mut expected = Vec::new();
    for set in 0..2 {
        let db = motion(40, set);
        let forecasts = ndarray::stack(
            ndarray::Axis(0),
            &[motion(12, 10 + set).view(), motion(12, 20 + set).view()],
        )
        .unwrap();
        write_npy(dir.join(format!("db{set}.npy")), &db).unwrap();
        write_npy(dir.join(format!("pred{set}.npy")), &forecasts).unwrap();
        let database =
            NdmsDatabase::from_sequences(NdmsConfig::h36m(), &[db.view()], NnMethod::BruteForce)
                .unwrap();
        let views: Vec<_> = forecasts.outer_iter().collect();
        expected.push(database.score_forecasts(&views, None).unwrap().mean);
    }
    let manifest = dir.join("manifest.json");
    std::fs::write(
        &manifest,
        r#"{"sets": [{"name": "a", "pred": "pred0.npy", "db": ["db0.npy"]},
                     {"name": "b", "pred": "pred1.npy", "db": ["db1.npy", "db1.npy"]}]}"#,
    )
    .unwrap();
    let (code, out, err) = bench(&[
        "--ndms",
        manifest.to_str().unwrap(),
        "--reps",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
    let ndms = &report["ndms"];
    let sets = ndms["sets"].as_array().expect("sets is an array");
    assert_eq!(sets.len(), 2);
    assert_eq!(sets[0]["name"], "a");
    assert_eq!(sets[0]["database_words"], 33);
    assert_eq!(sets[1]["database_words"], 66);
    assert_eq!(sets[0]["query_words"], 10);
    // A database holding its words twice has the same nearest neighbours.
    for (set, mean) in sets.iter().zip(&expected) {
        assert!(
            (set["mean"].as_f64().unwrap() - mean).abs() < 1e-12,
            "{set}"
        );
    }
    assert!(ndms["median_ms"].as_f64().unwrap() >= 0.0);
    assert_eq!(ndms["exact"], true);
    for phase in ["words", "index", "search", "similarity"] {
        assert!(ndms["phases_ms"][phase].as_f64().is_some(), "{ndms}");
    }

    // A manifest that is not one, or names a file that is not there: exit 2.
    std::fs::write(dir.join("bad.json"), r#"{"sets": []}"#).unwrap();
    std::fs::write(
        dir.join("missing.json"),
        r#"{"sets": [{"pred": "nothing.npy", "db": ["db0.npy"]}]}"#,
    )
    .unwrap();
    for name in ["bad.json", "missing.json", "absent.json"] {
        let (code, _, err) = bench(&["--ndms", dir.join(name).to_str().unwrap()]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(!err.is_empty());
    }
}

#[test]
fn sizes_past_the_memory_limits_exit_2_before_allocating() {
    for (args, said) in [
        (vec!["--batch", "1000000000"], "--batch 1000000000"),
        (vec!["--hidden", "65536"], "--hidden 65536"),
        (vec!["--steps", "1000000000000"], "--steps 1000000000000"),
    ] {
        let (code, stdout, stderr) = bench(&args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stdout.is_empty());
        assert!(
            stderr.contains(said) && stderr.contains("limit"),
            "{stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}
