//! `motion-cli eval`, driven through the built binary with the small parity fixture model
//! (`tests/fixtures/parity/vgru_d.safetensors`: random weights, 15 actions, 99 dims).
//!
//! The protocol run needs the H3.6M data in `MOTION_DATA_DIR` (default `<repo>/../shared/data`)
//! and is skipped with a visible message without it; the bad-input tests build their own
//! stand-in directories.
mod common;

use common::{data_dir, fixture_model, scratch};
use std::path::PathBuf;
use std::process::Command;

use motion_core::formats::npy::read_npy_dyn;
use motion_core::protocol::{expmap_batch_to_euler_protocol, load_action_windows, stack_sequences};
use motion_metrics::euler_error;
use ndarray::{s, Axis, Ix5};
use serde_json::Value;

/// Runs `motion-cli eval ARGS`; returns (exit code, stdout, stderr).
fn eval(args: &[&dyn AsRef<std::ffi::OsStr>]) -> (i32, String, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .arg("eval")
        .args(args.iter().map(|a| a.as_ref()))
        .output()
        .expect("runs motion-cli");
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn num(v: &Value) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("expected a number, found {v}"))
}

#[test]
fn walking_with_the_fixture_model_reproduces_the_zero_velocity_row() {
    let data = data_dir();
    let dataset = data.join("h3.6m/dataset");
    if !dataset.join("S5/walking_1.txt.gz").is_file() {
        eprintln!(
            "SKIPPED: eval on walking needs {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        return;
    }
    let dir = scratch("walking");
    let saved = dir.join("walking.npy");
    let (code, stdout, stderr) = eval(&[
        &"--data",
        &data,
        &"--model",
        &fixture_model(),
        &"--actions",
        &"walking",
        &"--json",
        &"--horizon",
        &"100",
        &"--samples",
        &"2",
        &"--save-predictions",
        &saved,
    ]);
    assert_eq!(code, 0, "eval failed: {stderr}");
    let report: Value = serde_json::from_str(&stdout).expect("one JSON object");

    // Structure.
    for key in [
        "model",
        "protocol",
        "method",
        "actions",
        "skipped",
        "mean_over_actions",
    ] {
        assert!(report.get(key).is_some(), "missing `{key}`");
    }
    let actions = report["actions"].as_array().unwrap();
    assert_eq!(actions.len(), 1);
    let walking = &actions[0];
    assert_eq!(walking["action"], "walking");
    assert_eq!(walking["windows"], 8);
    assert_eq!(walking["samples"], 2);
    for who in ["model", "zero_velocity"] {
        let m = &walking[who];
        for ms in ["80", "160", "320", "400", "560", "1000"] {
            num(&m["euler_error_ms"][ms]);
        }
        assert_eq!(m["euler_error_per_frame"].as_array().unwrap().len(), 100);
        for key in ["npss", "npss_reference"] {
            assert!(num(&m[key]["whole"]) >= 0.0);
            for w in ["0-1 s", "1-2 s", "2-4 s"] {
                assert!(num(&m[key]["windows"][w]) >= 0.0);
            }
        }
        let ndms = num(&m["ndms"]["mean"]);
        assert!((0.0..=1.0).contains(&ndms));
        assert_eq!(m["ndms"]["bins"].as_array().unwrap().len(), 10);
        assert_eq!(m["ndms"]["exact"], true);
        num(&m["mean_joint_speed_last_1s"]["world"]);
        num(&m["mean_joint_speed_last_1s"]["pose"]);
    }
    // Two different plan-noise samples: APD is reported and positive.
    assert!(num(&walking["model"]["apd"]) > 0.0);
    assert!(walking["zero_velocity"].get("apd").is_none());
    assert!(num(&walking["ground_truth"]["mean_joint_speed_last_1s"]["pose"]) > 1.0);
    // The baseline holds the root: no body motion and no world motion either (it used to glide at
    // the seed's last root velocity), and its NDMS against real walking words is near the floor.
    for kind in ["pose", "world"] {
        assert_eq!(
            num(&walking["zero_velocity"]["mean_joint_speed_last_1s"][kind]),
            0.0,
            "{kind}"
        );
    }
    let zv_ndms = num(&walking["zero_velocity"]["ndms"]["mean"]);
    assert!(zv_ndms < 0.1, "zero-velocity NDMS {zv_ndms}");
    assert!(num(&walking["ground_truth"]["mean_joint_speed_last_1s"]["world"]) > 1.0);
    // Real walking of the other subjects: far above the standing baseline, below the truth's 1
    // (its words are not in the S5 database).
    let real = &walking["ground_truth"]["real_motion_ndms"];
    assert_eq!(real["bins"].as_array().unwrap().len(), 10);
    assert!((0.3..0.95).contains(&num(&real["mean"])), "{real}");
    assert_eq!(
        report["mean_over_actions"]["real_motion"]["ndms"],
        real["mean"]
    );
    assert_eq!(
        num(&walking["published"]["paper000_table4_npss_reference_0_4s"]["VGRU-d"]),
        0.887
    );

    // The zero-velocity baseline reproduces Gopalakrishnan et al. 2019 Table 6 (printed with 2 decimals) and the
    // reference-variant NPSS the issue quotes (1.141).
    let zv = &walking["zero_velocity"];
    let table6 = &walking["published"]["paper000_table6_zero_velocity_euler"];
    for ms in ["80", "160", "320", "400"] {
        let ours = num(&zv["euler_error_ms"][ms]);
        let paper = num(&table6[ms]);
        assert!(
            (ours - paper).abs() <= 0.005,
            "zero-velocity at {ms} ms: {ours} vs Table 6 {paper}"
        );
    }
    assert!((num(&zv["npss_reference"]["whole"]) - 1.141).abs() < 5e-4);

    // The saved predictions: actions x 8 x K x horizon x 99, and exactly what was scored.
    assert_eq!(report["save_predictions"]["actions"][0], "walking");
    let saved = read_npy_dyn(&saved)
        .unwrap()
        .into_dimensionality::<Ix5>()
        .unwrap();
    assert_eq!(saved.shape(), &[1, 8, 2, 100, 99]);
    let windows = load_action_windows(&dataset, "walking", 100).unwrap();
    let gt: Vec<_> = windows.iter().map(|w| w.ground_truth.view()).collect();
    let gt_euler = expmap_batch_to_euler_protocol(stack_sequences(&gt).view());
    let mut mean = vec![0.0; 100];
    for k in 0..2 {
        let pred = saved.slice(s![0, .., k, .., ..]);
        let per_frame =
            euler_error(gt_euler.view(), expmap_batch_to_euler_protocol(pred).view()).unwrap();
        mean.iter_mut()
            .zip(per_frame)
            .for_each(|(m, e)| *m += e / 2.0);
    }
    let reported = walking["model"]["euler_error_per_frame"]
        .as_array()
        .unwrap();
    for (ours, theirs) in mean.iter().zip(reported) {
        assert!((ours - num(theirs)).abs() < 1e-9);
    }
    // The two samples differ (fresh plan noise per sample).
    let a = saved.index_axis(Axis(2), 0);
    let b = saved.index_axis(Axis(2), 1);
    assert!(a != b);
    // Nothing else was left in the directory (no temporary file).
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
}

/// A stand-in data root with an empty `h3.6m/dataset/S5`.
fn empty_dataset(name: &str) -> PathBuf {
    let root = scratch(name);
    std::fs::create_dir_all(root.join("h3.6m/dataset/S5")).unwrap();
    root
}

#[test]
fn an_unknown_action_exits_2_with_the_valid_list() {
    let root = empty_dataset("bad-action");
    let (code, stdout, stderr) = eval(&[
        &"--data",
        &root,
        &"--model",
        &fixture_model(),
        &"--actions",
        &"walking,jogging",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stdout.is_empty());
    assert!(stderr.contains("`jogging`"), "{stderr}");
    assert!(
        stderr.contains("valid actions: all, directions, discussion, eating"),
        "{stderr}"
    );
    assert!(stderr.contains("walkingtogether"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_missing_data_dir_exits_2() {
    let missing = scratch("missing-data").join("nowhere");
    let (code, _, stderr) = eval(&[
        &"--data",
        &missing,
        &"--model",
        &fixture_model(),
        &"--actions",
        &"walking",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("nowhere") && stderr.contains("does not exist"),
        "{stderr}"
    );
    // A directory without H3.6M data is bad input too, naming where it looked.
    let empty = scratch("no-h36m");
    let (code, _, stderr) = eval(&[&"--data", &empty, &"--model", &fixture_model()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("h3.6m/dataset/S5"), "{stderr}");
}

#[test]
fn actions_whose_files_are_missing_are_reported() {
    let root = empty_dataset("missing-files");
    let saved = root.join("never.npy");
    let (code, _, stderr) = eval(&[
        &"--data",
        &root.join("h3.6m/dataset"),
        &"--model",
        &fixture_model(),
        &"--actions",
        &"walking,directions",
        &"--save-predictions",
        &saved,
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("walking: missing") && stderr.contains("walking_1.txt.gz"),
        "{stderr}"
    );
    assert!(stderr.contains("directions: no test windows"), "{stderr}");
    assert!(!saved.exists());
}

#[test]
fn a_bad_model_file_exits_2_naming_it() {
    let root = empty_dataset("bad-model");
    let model = root.join("not-weights.safetensors");
    std::fs::write(&model, b"garbage").unwrap();
    let (code, _, stderr) = eval(&[&"--data", &root, &"--model", &model]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("not-weights.safetensors"), "{stderr}");
}

#[test]
fn plot_draws_every_action_and_a_bad_extension_fails_before_work() {
    let data = data_dir();
    if !data.join("h3.6m/dataset/S5/walking_1.txt.gz").is_file() {
        eprintln!("SKIPPED: eval --plot needs the H3.6M data (set MOTION_DATA_DIR)");
        return;
    }
    let dir = scratch("plot");
    let svg = dir.join("walking.svg");
    let (code, _, stderr) = eval(&[
        &"--data",
        &data,
        &"--model",
        &fixture_model(),
        &"--actions",
        &"walking",
        &"--horizon",
        &"25",
        &"--plot",
        &svg,
    ]);
    assert_eq!(code, 0, "stderr: {stderr}");
    let text = std::fs::read_to_string(&svg).unwrap();
    for title in ["walking: Euler error", "walking: NPSS", "walking: NDMS"] {
        assert!(
            text.to_lowercase().contains(&title.to_lowercase()),
            "{title} missing"
        );
    }

    let bad = dir.join("walking.jpg");
    let (code, _, stderr) = eval(&[
        &"--data",
        &data,
        &"--model",
        &fixture_model(),
        &"--plot",
        &bad,
    ]);
    assert_eq!(code, 2, "stderr: {stderr}");
    assert!(stderr.contains("walking.jpg") && stderr.contains(".svg or .png"));
    assert!(!bad.exists());
}

#[test]
fn a_horizon_past_60_s_exits_2_in_one_line() {
    let root = empty_dataset("long-horizon");
    let (code, stdout, stderr) = eval(&[
        &"--data",
        &root,
        &"--model",
        &fixture_model(),
        &"--horizon",
        &"1501",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stdout.is_empty());
    assert!(stderr.contains("--horizon must be 1..=1500"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_12_s_horizon_scores_ground_truth_where_the_files_cover_it() {
    let data = data_dir();
    if !data.join("h3.6m/dataset/S5/greeting_2.txt.gz").is_file() {
        eprintln!("SKIPPED: eval --horizon 300 needs the H3.6M data (set MOTION_DATA_DIR)");
        return;
    }
    let (code, stdout, stderr) = eval(&[
        &"--data",
        &data,
        &"--model",
        &fixture_model(),
        &"--actions",
        &"greeting",
        &"--horizon",
        &"300",
        &"--json",
    ]);
    assert_eq!(code, 0, "eval failed: {stderr}");
    let report: Value = serde_json::from_str(&stdout).expect("one JSON object");
    let greeting = &report["actions"][0];
    let coverage = &greeting["ground_truth_coverage"];
    let frames: Vec<u64> = coverage["frames_per_window"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    // greeting window 1 starts at frame 1448 of a 1600-frame file: 152 frames of truth.
    assert_eq!(frames.len(), 8);
    assert_eq!(frames[1], 152);
    let per_second: Vec<u64> = coverage["windows_per_second"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(per_second.len(), 12);
    assert_eq!(per_second[0], 8);
    assert!(per_second[11] < 8);
    assert_eq!(
        coverage["npss_whole_frames"].as_u64().unwrap(),
        *frames.iter().min().unwrap()
    );
    let covered = *frames.iter().max().unwrap() as usize;
    for who in ["model", "zero_velocity"] {
        let m = &greeting[who];
        assert_eq!(
            m["euler_error_per_frame"].as_array().unwrap().len(),
            covered
        );
        for w in ["0-1 s", "1-2 s", "2-4 s", "4-8 s", "8-12 s"] {
            assert!(num(&m["npss_reference"]["windows"][w]) >= 0.0, "{who} {w}");
        }
        // NDMS covers the whole horizon: 0.4 s bins of 12 s.
        assert_eq!(m["ndms"]["bins"].as_array().unwrap().len(), 30);
        // The plausibility measures cover the whole horizon, in four windows.
        let speed = m["speed_ratio"]["windows"].as_array().unwrap();
        assert_eq!(speed.len(), 4);
        assert_eq!(num(&speed[3]["end_s"]), 12.0);
        assert_eq!(speed[3]["sequences"], 8);
        assert_eq!(m["drift"]["windows"].as_array().unwrap().len(), 4);
        assert_eq!(m["foot_contact"]["windows"].as_array().unwrap().len(), 4);
        num(&m["drift"]["windows"][0]["hip_height_p95_mm"]);
    }
    // The frozen baseline does not move in the root frame.
    assert_eq!(
        num(&greeting["zero_velocity"]["speed_ratio"]["windows"][2]["ratio"]),
        0.0
    );
    // The real continuation: the windows each file covers.
    let real = &greeting["ground_truth"];
    let last = &real["speed_ratio"]["windows"][3];
    assert_eq!(
        last["sequences"].as_u64().unwrap(),
        frames.iter().filter(|&&f| f >= 300).count() as u64
    );
    assert!(num(&real["speed_ratio"]["windows"][0]["ratio"]) > 0.3);
    // The last-second speed of the truth: over the windows covering the whole horizon.
    assert!(num(&real["mean_joint_speed_last_1s"]["pose"]) > 1.0);
    // Ghosh et al. 2017's classifier curve (the built-in classifier): a window ending every second of the
    // 12 s, the real continuation counting the windows whose file reaches each end.
    for who in ["model", "zero_velocity", "ground_truth"] {
        let curve = &greeting[who]["classifier"];
        assert_eq!(curve["action"], "greeting", "{who}");
        assert_eq!(curve["times_s"].as_array().unwrap().len(), 12, "{who}");
        assert_eq!(num(&curve["times_s"][11]), 12.0);
    }
    let curve = |who: &str| &greeting[who]["classifier"];
    assert_eq!(
        curve("ground_truth")["sequences_per_window"][11]
            .as_u64()
            .unwrap(),
        frames.iter().filter(|&&f| f >= 300).count() as u64
    );
    assert_eq!(curve("model")["sequences_per_window"][11], 8);
    // Real greeting keeps more of its label over 8-12 s than the frozen baseline.
    let late = |who: &str| {
        let prob = curve(who)["prob"].as_array().unwrap();
        prob[8..].iter().map(num).sum::<f64>() / 4.0
    };
    assert!(
        late("ground_truth") > late("zero_velocity"),
        "real {} vs zero-velocity {}",
        late("ground_truth"),
        late("zero_velocity")
    );
}

#[test]
fn too_many_samples_exit_2_before_allocating() {
    let root = empty_dataset("too-many-samples");
    let (code, _, stderr) = eval(&[
        &"--data",
        &root,
        &"--model",
        &fixture_model(),
        &"--samples",
        &"100000",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("over the limit"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}
