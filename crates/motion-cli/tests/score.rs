//! `motion-cli score` driven as a binary: the zero-velocity acceptance check on the protocol's test
//! windows (needs MOTION_DATA_DIR), identities on generated inputs, and bad input (exit code 2).
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use motion_core::formats::npy::write_npy;
use motion_core::protocol::{dataset_dir, load_action_windows, LONG_TERM_HORIZON};
use motion_metrics::baselines::zero_velocity;
use ndarray::{Array2, Array3, Array4, Axis};
use serde_json::Value;

/// A scratch directory removed on drop.
struct Scratch(PathBuf);
impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("motion-cli-score-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
}
impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn score(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .arg("score")
        .args(args)
        .output()
        .expect("the binary runs")
}

fn json_of(output: &Output) -> Value {
    assert!(
        output.status.success(),
        "exit {:?}, stderr: {}",
        output.status.code(),
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("one JSON object")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn data_root() -> PathBuf {
    std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

/// Gopalakrishnan et al. 2019 Table 6, zero-velocity row: Euler error at 80, 160, 320, 400 ms.
const TABLE_6_ZERO_VELOCITY: [(&str, [f64; 4]); 3] = [
    ("walking", [0.39, 0.68, 0.99, 1.15]),
    ("eating", [0.27, 0.48, 0.73, 0.86]),
    ("smoking", [0.26, 0.48, 0.97, 0.95]),
];

#[test]
fn zero_velocity_reproduces_paper_000_table_6() {
    let dataset = dataset_dir(&data_root());
    if !dataset.join("S5").is_dir() {
        eprintln!(
            "SKIPPED: zero-velocity acceptance check: no H3.6M data at {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        return;
    }
    let dir = Scratch::new("zv");
    for (action, expected) in TABLE_6_ZERO_VELOCITY {
        let windows = load_action_windows(&dataset, action, LONG_TERM_HORIZON).unwrap();
        assert_eq!(windows.len(), 8);
        let gt: Vec<_> = windows.iter().map(|w| w.ground_truth.view()).collect();
        let zv: Vec<Array2<f64>> = windows
            .iter()
            .map(|w| zero_velocity(w.seed.view(), LONG_TERM_HORIZON))
            .collect();
        let zv_views: Vec<_> = zv.iter().map(|z| z.view()).collect();
        let gt = ndarray::stack(Axis(0), &gt).unwrap();
        let zv = ndarray::stack(Axis(0), &zv_views).unwrap();
        assert_eq!(gt.dim(), (8, 100, 99));
        let (gt_path, zv_path) = (
            dir.path(&format!("{action}_gt.npy")),
            dir.path(&format!("{action}_zv.npy")),
        );
        write_npy(&gt_path, &gt).unwrap();
        write_npy(&zv_path, &zv).unwrap();
        let report = json_of(&score(&[
            "--gt",
            p(&gt_path),
            "--pred",
            p(&zv_path),
            "--json",
        ]));
        let measured: Vec<f64> = ["80", "160", "320", "400"]
            .iter()
            .map(|ms| report["euler_error_ms"][*ms].as_f64().unwrap())
            .collect();
        eprintln!(
            "{action}: zero-velocity Euler error {measured:.4?}; NPSS over 4 s: reference variant {:.4}, paper {:.4}; windows {}",
            report["npss_reference"].as_f64().unwrap(),
            report["npss"].as_f64().unwrap(),
            report["npss_windows"]
        );
        for (m, e) in measured.iter().zip(expected) {
            let rounded = (m * 100.0).round() / 100.0;
            assert!(
                (rounded - e).abs() <= 0.005,
                "{action}: measured {measured:?}, paper {expected:?}"
            );
        }
    }
}

/// Smooth motion of 32 joints where every joint always moves (mm).
fn moving_positions(frames: usize, phase: f64) -> Array3<f64> {
    Array3::from_shape_fn((frames, 32, 3), |(t, j, c)| {
        let t = t as f64;
        100.0 * (j as f64)
            + 40.0 * (0.3 * t + phase + j as f64 + 2.0 * c as f64).sin()
            + 7.0 * t * (c as f64 + 1.0)
    })
}

#[test]
fn identical_inputs_score_perfectly() {
    let dir = Scratch::new("identity");
    // Exp-map sequences: NPSS 0 and Euler error 0 against themselves.
    let seq = Array3::from_shape_fn((2, 20, 99), |(i, t, d)| {
        0.01 * ((i + 1) * (d + 1)) as f64 * (0.2 * t as f64).sin()
    });
    let path = dir.path("seq.npy");
    write_npy(&path, &seq).unwrap();
    let report = json_of(&score(&["--gt", p(&path), "--pred", p(&path), "--json"]));
    assert_eq!(report["npss"].as_f64(), Some(0.0));
    assert_eq!(report["npss_reference"].as_f64(), Some(0.0));
    assert!(report["euler_error"]
        .as_array()
        .unwrap()
        .iter()
        .all(|v| v.as_f64() == Some(0.0)));
    assert!(report["euler_error_ms"]["1000"].is_null()); // 20 frames: no 1 s horizon
    assert!(report.get("ndms").is_none() && report.get("apd").is_none());

    // Raw positions: NDMS of the reference itself is 1, APD of identical samples 0.
    let positions = moving_positions(40, 0.0);
    let db = dir.path("db.npy");
    write_npy(&db, &positions).unwrap();
    let pred = positions.clone().insert_axis(Axis(0));
    let pred_path = dir.path("pred.npy");
    write_npy(&pred_path, &pred).unwrap();
    let report = json_of(&score(&[
        "--pred",
        p(&pred_path),
        "--db",
        p(&db),
        "--input-space",
        "raw",
        "--json",
    ]));
    let ndms = &report["ndms"];
    assert!(
        (ndms["mean"].as_f64().unwrap() - 1.0).abs() < 1e-12,
        "{ndms}"
    );
    assert_eq!(ndms["exact"], Value::Bool(true));
    assert_eq!(ndms["per_word"].as_array().unwrap().len(), 40 - 8 + 1);
    let samples = Array4::from_shape_fn((2, 3, 10, 6), |(i, _, t, d)| (i * 100 + t * 6 + d) as f64);
    let samples_path = dir.path("samples.npy");
    write_npy(&samples_path, &samples).unwrap();
    let report = json_of(&score(&[
        "--pred",
        p(&samples_path),
        "--metric",
        "apd",
        "--json",
    ]));
    assert_eq!(report["apd"].as_f64(), Some(0.0));
}

#[test]
fn exp_map_ndms_with_seed_and_both_indexes() {
    let dir = Scratch::new("ndms");
    // A 99-dim exp-map "walk": joints swing, root moves forward; FK gives the positions.
    let frames = Array2::from_shape_fn((60, 99), |(t, d)| match d {
        2 => 10.0,
        0 | 1 | 3..=5 => 0.0,
        _ => 0.3 * (0.25 * t as f64 + d as f64).sin(),
    });
    let db = dir.path("db.npy");
    write_npy(&db, &frames).unwrap();
    let seed = dir.path("seed.npy");
    write_npy(
        &seed,
        &frames
            .slice(ndarray::s![..20, ..])
            .to_owned()
            .insert_axis(Axis(0)),
    )
    .unwrap();
    let pred = dir.path("pred.npy");
    write_npy(
        &pred,
        &frames
            .slice(ndarray::s![20..45, ..])
            .to_owned()
            .insert_axis(Axis(0)),
    )
    .unwrap();
    let mut means = Vec::new();
    for nn in ["brute-force", "pca-kd-tree"] {
        let report = json_of(&score(&[
            "--pred",
            p(&pred),
            "--seed",
            p(&seed),
            "--db",
            p(&db),
            "--nn",
            nn,
            "--json",
        ]));
        let ndms = &report["ndms"];
        assert_eq!(ndms["per_word"].as_array().unwrap().len(), 25, "{ndms}");
        assert_eq!(ndms["first_word_end"].as_u64(), Some(0));
        means.push(ndms["mean"].as_f64().unwrap());
    }
    // The forecast continues the reference exactly: every word (seam included) is in D.
    assert!((means[0] - 1.0).abs() < 1e-9, "{means:?}");
    assert_eq!(means[0], means[1]);
}

fn assert_usage_error(output: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains(needle), "expected {needle:?} in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_input_exits_with_2_and_a_clear_message() {
    let dir = Scratch::new("bad");
    let a = dir.path("a.npy");
    write_npy(&a, &Array3::<f64>::ones((2, 10, 99))).unwrap();
    let b = dir.path("b.npy");
    write_npy(&b, &Array3::<f64>::ones((2, 12, 99))).unwrap();
    assert_usage_error(&score(&["--gt", p(&a), "--pred", p(&b)]), "shape mismatch");

    let mut nan = Array3::<f64>::ones((2, 10, 99));
    nan[[1, 3, 7]] = f64::NAN;
    let nan_path = dir.path("nan.npy");
    write_npy(&nan_path, &nan).unwrap();
    assert_usage_error(
        &score(&["--gt", p(&a), "--pred", p(&nan_path)]),
        "[1, 3, 7]",
    );

    let empty = dir.path("empty.npy");
    write_npy(&empty, &Array3::<f64>::zeros((0, 10, 99))).unwrap();
    assert_usage_error(&score(&["--gt", p(&a), "--pred", p(&empty)]), "empty");

    let db = dir.path("db.npy");
    write_npy(&db, &moving_positions(20, 0.0)).unwrap();
    let short = dir.path("short.npy");
    write_npy(&short, &moving_positions(5, 1.0).insert_axis(Axis(0))).unwrap();
    assert_usage_error(
        &score(&["--pred", p(&short), "--db", p(&db), "--input-space", "raw"]),
        "κ = 8",
    );

    assert_usage_error(&score(&["--pred", p(&a), "--metric", "ndms"]), "needs --db");
    assert_usage_error(
        &score(&["--pred", p(&a), "--metric", "fid"]),
        "invalid value 'fid'",
    );
    assert_usage_error(&score(&["--pred", p(&a)]), "nothing to score");
    assert_usage_error(
        &score(&["--gt", p(&a), "--pred", p(&dir.path("missing.npy"))]),
        "missing.npy",
    );
    let text = dir.path("ragged.txt");
    std::fs::write(&text, "1,2,3\n4,5\n").unwrap();
    assert_usage_error(
        &score(&["--gt", p(&text), "--pred", p(&text)]),
        "ragged.txt:2",
    );
    // All-zero ground truth (zero power everywhere): NPSS is undefined, which is said.
    let zeros = dir.path("zeros.npy");
    write_npy(&zeros, &Array3::<f64>::zeros((2, 10, 99))).unwrap();
    assert_usage_error(
        &score(&["--gt", p(&zeros), "--pred", p(&a), "--metric", "npss"]),
        "undefined",
    );
}

#[test]
fn ndms_on_s5_walking_scores_ground_truth_1_and_zero_velocity_lower() {
    let dataset = dataset_dir(&data_root());
    if !dataset.join("S5").is_dir() {
        eprintln!(
            "SKIPPED: NDMS on S5 walking: no H3.6M data at {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        return;
    }
    let dir = Scratch::new("ndms-s5");
    let windows = load_action_windows(&dataset, "walking", LONG_TERM_HORIZON).unwrap();
    let seeds: Vec<_> = windows.iter().map(|w| w.seed.view()).collect();
    let gt: Vec<_> = windows.iter().map(|w| w.ground_truth.view()).collect();
    let zv: Vec<Array2<f64>> = windows
        .iter()
        .map(|w| zero_velocity(w.seed.view(), LONG_TERM_HORIZON))
        .collect();
    let zv: Vec<_> = zv.iter().map(|z| z.view()).collect();
    let paths = [("seed", &seeds), ("gt", &gt), ("zv", &zv)].map(|(name, list)| {
        let path = dir.path(&format!("{name}.npy"));
        write_npy(&path, &ndarray::stack(Axis(0), list).unwrap()).unwrap();
        path
    });
    let db1 = motion_core::protocol::sequence_file(&dataset, "S5", "walking", 1);
    let db2 = motion_core::protocol::sequence_file(&dataset, "S5", "walking", 2);
    let mut means = Vec::new();
    for pred in [&paths[1], &paths[2]] {
        let report = json_of(&score(&[
            "--pred",
            p(pred),
            "--seed",
            p(&paths[0]),
            "--db",
            p(&db1),
            p(&db2),
            "--metric",
            "ndms",
            "--json",
        ]));
        let ndms = &report["ndms"];
        eprintln!(
            "S5 walking NDMS of {}: mean {:.4}, 0.4 s bins {}, {} words in D",
            pred.file_name().unwrap().to_string_lossy(),
            ndms["mean"].as_f64().unwrap(),
            ndms["bins"],
            ndms["database_words"]
        );
        assert_eq!(ndms["bins"].as_array().unwrap().len(), 10);
        means.push(ndms["mean"].as_f64().unwrap());
    }
    // The ground truth's words are in D: exact search finds them, whatever frame the root's
    // integration started from (rigid per-word body frame), so they score 1.
    assert!(
        (means[0] - 1.0).abs() < 1e-6 && means[1] < means[0],
        "{means:?}"
    );
}

#[test]
fn bvh_input_scores_like_its_exp_map_source() {
    use motion_core::formats::bvh::write_bvh;
    use motion_core::formats::expmap_bvh::expmap_to_bvh;
    let dir = Scratch::new("bvh");
    // 25 Hz H3.6M exp-map frames with moderate angles and a moving root.
    let frames = Array2::from_shape_fn((40, 99), |(t, d)| match d {
        0..=2 => 5.0 + d as f64,
        3..=5 => 0.01,
        _ => 0.4 * (0.2 * t as f64 + d as f64).sin(),
    });
    let motion = motion_core::Motion::h36m(frames.clone(), 25.0).unwrap();
    let bvh = dir.path("walk.bvh");
    write_bvh(&bvh, &expmap_to_bvh(&motion).unwrap()).unwrap();
    let npy = dir.path("walk.npy");
    write_npy(&npy, &frames.insert_axis(Axis(0))).unwrap();
    // BVH vs its own source: the Euler sequences agree up to the text round trip.
    let report = json_of(&score(&["--gt", p(&npy), "--pred", p(&bvh), "--json"]));
    assert!(report["npss"].as_f64().unwrap() < 1e-6, "{report}");
    let worst = report["euler_error"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "{worst}");
}

#[test]
fn raw_positions_of_another_joint_order_are_named_by_a_bvh_skeleton() {
    use motion_core::formats::bvh::write_bvh;
    use motion_core::formats::expmap_bvh::expmap_to_bvh;
    use motion_core::kinematics::channel_positions;
    let dir = Scratch::new("skeleton");
    let frames = Array2::from_shape_fn((40, 99), |(t, d)| match d {
        0..=2 => 5.0 + d as f64,
        3..=5 => 0.01,
        _ => 0.4 * (0.2 * t as f64 + d as f64).sin(),
    });
    let bvh = expmap_to_bvh(&motion_core::Motion::h36m(frames, 25.0).unwrap()).unwrap();
    let bvh_path = dir.path("skeleton.bvh");
    write_bvh(&bvh_path, &bvh).unwrap();
    // Positions in the BVH's joint order (End Sites included), y up.
    let positions = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    let db = dir.path("db.npy");
    write_npy(&db, &positions).unwrap();
    let pred = dir.path("pred.npy");
    write_npy(
        &pred,
        &positions
            .slice(ndarray::s![10..30, .., ..])
            .to_owned()
            .insert_axis(Axis(0)),
    )
    .unwrap();
    let args = [
        "--pred",
        p(&pred),
        "--db",
        p(&db),
        "--input-space",
        "raw",
        "--json",
    ];
    if positions.dim().1 != 32 {
        // Without names the joints of this layout are unknown.
        assert_usage_error(&score(&args), "--skeleton");
    }
    let mut named = args.to_vec();
    named.extend(["--skeleton", p(&bvh_path)]);
    let report = json_of(&score(&named));
    assert!(
        (report["ndms"]["mean"].as_f64().unwrap() - 1.0).abs() < 1e-9,
        "{report}"
    );
}

#[test]
fn plot_draws_the_per_horizon_results() {
    let dir = Scratch::new("plot");
    let gt = Array3::from_shape_fn((2, 100, 99), |(i, t, d)| {
        0.01 * ((i + 1) * (d + 1)) as f64 * (0.2 * t as f64).sin()
    });
    let pred = gt.mapv(|v| 0.9 * v);
    let (gt_path, pred_path) = (dir.path("gt.npy"), dir.path("pred.npy"));
    write_npy(&gt_path, &gt).unwrap();
    write_npy(&pred_path, &pred).unwrap();
    let svg = dir.path("scores.svg");
    let output = score(&[
        "--gt",
        p(&gt_path),
        "--pred",
        p(&pred_path),
        "--plot",
        p(&svg),
    ]);
    assert!(output.status.success(), "{output:?}");
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("Euler error") && text.contains("NPSS per window"));

    // A plot format we don't write fails before any work, and leaves nothing behind.
    let bad = dir.path("scores.jpg");
    let output = score(&[
        "--gt",
        p(&gt_path),
        "--pred",
        p(&pred_path),
        "--plot",
        p(&bad),
    ]);
    assert_usage_error(&output, "scores.jpg");
    assert!(!bad.exists());
}

#[test]
fn plausibility_of_s5_walking_real_vs_zero_velocity() {
    let root = data_root();
    let dataset = dataset_dir(&root);
    if !dataset.join("S5/walking_1.txt.gz").is_file() {
        eprintln!(
            "SKIPPED: speed_ratio, drift and foot_contact need the H3.6M data at {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        return;
    }
    let dir = Scratch::new("plausibility");
    let windows = load_action_windows(&dataset, "walking", LONG_TERM_HORIZON).unwrap();
    let seeds: Vec<_> = windows.iter().map(|w| w.seed.view()).collect();
    let gt: Vec<_> = windows.iter().map(|w| w.ground_truth.view()).collect();
    let zv: Vec<Array2<f64>> = windows
        .iter()
        .map(|w| zero_velocity(w.seed.view(), LONG_TERM_HORIZON))
        .collect();
    let zv: Vec<_> = zv.iter().map(|z| z.view()).collect();
    let [seed, real_path, frozen_path] =
        [("seed", &seeds), ("gt", &gt), ("zv", &zv)].map(|(name, list)| {
            let path = dir.path(&format!("{name}.npy"));
            write_npy(&path, &ndarray::stack(Axis(0), list).unwrap()).unwrap();
            path
        });
    let run = |pred: &Path, metric: &str| {
        json_of(&score(&[
            "--pred",
            p(pred),
            "--seed",
            p(&seed),
            "--action",
            "walking",
            "--data",
            p(&root),
            "--metric",
            metric,
            "--json",
        ]))
    };
    let real = run(&real_path, "speed_ratio,drift,foot_contact");
    let frozen = run(&frozen_path, "all");
    for report in [&real, &frozen] {
        for key in ["speed_ratio", "drift", "foot_contact"] {
            let windows = report[key]["windows"].as_array().unwrap();
            // 100 frames: the 0-2 s and 2-4 s windows.
            assert_eq!(windows.len(), 2, "{key}");
            assert_eq!(windows[1]["start_s"], 2.0);
            assert_eq!(windows[1]["end_s"], 4.0);
            assert_eq!(windows[1]["sequences"], 8);
        }
    }
    let ratio = |r: &Value, i: usize| r["speed_ratio"]["windows"][i]["ratio"].as_f64().unwrap();
    eprintln!(
        "S5 walking speed_ratio: real {:.3} {:.3}, zero-velocity {:.3} {:.3}",
        ratio(&real, 0),
        ratio(&real, 1),
        ratio(&frozen, 0),
        ratio(&frozen, 1)
    );
    assert!((0.5..2.0).contains(&ratio(&real, 0)));
    assert_eq!(ratio(&frozen, 0), 0.0);
    let drift = &real["drift"]["windows"][0];
    assert!(drift["hip_height_p95_mm"].as_f64().unwrap() > 0.0);
    assert!(drift["hip_height_within_p95"].as_f64().unwrap() >= 0.5);
    assert!(
        real["speed_ratio"]["reference_mean_speed_mm_s"]
            .as_f64()
            .unwrap()
            > 100.0
    );
    // `all` with --action and --seed includes them; the table prints them too.
    let text = score(&[
        "--pred",
        p(&frozen_path),
        "--seed",
        p(&seed),
        "--action",
        "walking",
        "--data",
        p(&root),
    ]);
    let stdout = String::from_utf8_lossy(&text.stdout);
    assert!(stdout.contains("speed_ratio"), "{stdout}");
    assert!(stdout.contains("foot_contact"), "{stdout}");
}

#[test]
fn plausibility_needs_action_seed_and_data() {
    let dir = Scratch::new("plausibility-bad");
    let pred = dir.path("pred.npy");
    write_npy(&pred, &Array3::<f64>::zeros((2, 10, 99))).unwrap();
    let seed = dir.path("seed.npy");
    write_npy(&seed, &Array3::<f64>::zeros((2, 5, 99))).unwrap();
    assert_usage_error(
        &score(&["--pred", p(&pred), "--seed", p(&seed), "--metric", "drift"]),
        "needs --action",
    );
    assert_usage_error(
        &score(&[
            "--pred",
            p(&pred),
            "--action",
            "walking",
            "--metric",
            "speed_ratio",
        ]),
        "needs --seed",
    );
    assert_usage_error(
        &score(&[
            "--pred",
            p(&pred),
            "--seed",
            p(&seed),
            "--action",
            "jogging",
        ]),
        "unknown action `jogging`",
    );
    let nowhere = dir.path("nowhere");
    let out = score(&[
        "--pred",
        p(&pred),
        "--seed",
        p(&seed),
        "--action",
        "walking",
        "--data",
        p(&nowhere),
        "--metric",
        "foot_contact",
    ]);
    assert_usage_error(&out, "does not exist");
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    // A data root without the action's files: one line naming the directory.
    let empty = dir.path("data");
    std::fs::create_dir_all(empty.join("h3.6m/dataset/S5")).unwrap();
    assert_usage_error(
        &score(&[
            "--pred",
            p(&pred),
            "--seed",
            p(&seed),
            "--action",
            "walking",
            "--data",
            p(&empty),
            "--metric",
            "speed_ratio",
        ]),
        "no S5 file of walking",
    );
    // Seeds must pair with predictions.
    let one_seed = dir.path("one_seed.npy");
    write_npy(&one_seed, &Array3::<f64>::zeros((1, 5, 99))).unwrap();
    assert_usage_error(
        &score(&[
            "--pred",
            p(&pred),
            "--seed",
            p(&one_seed),
            "--action",
            "walking",
            "--data",
            p(&empty),
            "--metric",
            "drift",
        ]),
        "one sequence per --pred sequence",
    );
}

fn fixture_classifier() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/fixtures/parity/action_classifier.safetensors")
}

/// `--metric classifier`: the JSON shape of the issue, one window end per hop, probabilities in
/// [0, 1]; bad input exits 2.
#[test]
fn classifier_metric_reports_a_curve() {
    let dir = Scratch::new("classifier");
    let pred = Array3::from_shape_fn((3, 100, 99), |(n, t, d)| {
        0.2 * ((t as f64) * 0.1 + d as f64 + n as f64).sin()
    });
    let seed = Array3::from_shape_fn((3, 12, 99), |(n, t, d)| {
        0.2 * ((t as f64) * 0.1 + d as f64 + n as f64).cos()
    });
    write_npy(dir.path("pred.npy"), &pred).unwrap();
    write_npy(dir.path("seed.npy"), &seed).unwrap();
    let classifier = fixture_classifier();
    let (pred_path, seed_path) = (dir.path("pred.npy"), dir.path("seed.npy"));
    let base = [
        "--pred",
        p(&pred_path),
        "--seed",
        p(&seed_path),
        "--classifier",
        p(&classifier),
        "--action",
        "walking",
    ];
    let svg = dir.path("curve.svg");
    let mut args = base.to_vec();
    args.extend(["--metric", "classifier", "--json", "--plot", p(&svg)]);
    let report = json_of(&score(&args));
    let curve = &report["classifier"];
    assert_eq!(curve["action"], "walking");
    assert_eq!(curve["window_s"], 12.0 / 25.0);
    let times: Vec<f64> = curve["times_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(times.len(), 4, "window ends at 1, 2, 3, 4 s: {times:?}");
    assert!((times[0] - 1.0).abs() < 1e-12);
    for key in ["prob", "top1"] {
        for v in curve[key].as_array().unwrap() {
            assert!((0.0..=1.0).contains(&v.as_f64().unwrap()), "{key}: {v}");
        }
    }
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    // `all` includes it when --action is given (without --seed: no plausibility, no data needed).
    let report = json_of(&score(&[
        "--pred",
        p(&pred_path),
        "--classifier",
        p(&classifier),
        "--action",
        "walking",
        "--json",
    ]));
    assert!(report.get("classifier").is_some());
    // Bad input: an unknown action, a prediction shorter than one window, no --action.
    let mut args = base.to_vec();
    args[7] = "flying";
    assert_eq!(score(&args).status.code(), Some(2));
    write_npy(dir.path("short.npy"), &Array3::<f64>::zeros((3, 11, 99))).unwrap();
    let short = dir.path("short.npy");
    let out = score(&[
        "--pred",
        p(&short),
        "--classifier",
        p(&classifier),
        "--action",
        "walking",
        "--metric",
        "classifier",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    let out = score(&["--pred", p(&pred_path), "--metric", "classifier"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--action"));
}

/// A BVH continuation scored after its BVH seed starts from the seed's last pose (not from the
/// origin, which lifted the hips by their height), and `--seed-frames` scores one file holding
/// both: real S5 walking stays within the real hip drift either way, with equal reports.
#[test]
fn a_bvh_continuation_is_scored_from_its_seed() {
    use motion_core::formats::bvh::write_bvh;
    use motion_core::formats::expmap_bvh::expmap_to_bvh;
    use motion_core::motion::Motion;
    let root = data_root();
    let dataset = dataset_dir(&root);
    if !dataset.join("S5/walking_1.txt.gz").is_file() {
        eprintln!(
            "SKIPPED: a BVH continuation needs the H3.6M data at {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        return;
    }
    let dir = Scratch::new("continuation");
    let window = &load_action_windows(&dataset, "walking", LONG_TERM_HORIZON).unwrap()[0];
    let seed_len = window.seed.nrows();
    let whole =
        ndarray::concatenate(Axis(0), &[window.seed.view(), window.ground_truth.view()]).unwrap();
    let motion = Motion::expmap_of_width(whole, 25.0).unwrap().unwrap();
    let bvh = expmap_to_bvh(&motion).unwrap();
    let part = |name: &str, rows: std::ops::Range<usize>| {
        let mut b = bvh.clone();
        b.frames = bvh.frames.slice(ndarray::s![rows, ..]).to_owned();
        let path = dir.path(name);
        write_bvh(&path, &b).unwrap();
        path
    };
    let [seed, cont, all] = [
        part("seed.bvh", 0..seed_len),
        part("cont.bvh", seed_len..bvh.frames.nrows()),
        part("all.bvh", 0..bvh.frames.nrows()),
    ];
    let run = |args: &[&str]| {
        let mut all_args = args.to_vec();
        all_args.extend([
            "--action",
            "walking",
            "--data",
            p(&root),
            "--metric",
            "speed_ratio,drift,foot_contact",
            "--json",
        ]);
        json_of(&score(&all_args))
    };
    let paired = run(&["--pred", p(&cont), "--seed", p(&seed)]);
    let split = run(&["--pred", p(&all), "--seed-frames", &seed_len.to_string()]);
    for report in [&paired, &split] {
        let drift = &report["drift"]["windows"][0];
        assert!(
            drift["hip_height_mm"].as_f64().unwrap() < drift["hip_height_p95_mm"].as_f64().unwrap(),
            "{drift}"
        );
    }
    for key in ["speed_ratio", "drift", "foot_contact"] {
        let (a, b) = (&paired[key]["windows"], &split[key]["windows"]);
        for (wa, wb) in a.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
            for (field, va) in wa.as_object().unwrap() {
                if let (Some(x), Some(y)) = (va.as_f64(), wb[field].as_f64()) {
                    assert!(
                        (x - y).abs() <= 1e-6 * (1.0 + x.abs()),
                        "{key}.{field}: {x} vs {y}"
                    );
                }
            }
        }
    }
    // Nothing is left after the seed: a usage error.
    let output = score(&["--pred", p(&seed), "--seed-frames", &seed_len.to_string()]);
    assert_eq!(output.status.code(), Some(2));
}
