//! `motion-cli predict`, driven through the built binary with the small random-weight fixture
//! model (`tests/fixtures/parity/vgru_d.safetensors`: 15 actions, seed 10 frames, 25 Hz) and the
//! procedural seed `examples/walk_seed.bvh`. No `../shared` data is needed. The fixture's motion is
//! meaningless; these tests check shapes, conventions and plumbing.
mod common;

use common::{data_dir, fixture_model, listing, repo, scratch, walk_seed};
use std::path::{Path, PathBuf};
use std::process::Command;

use motion_core::formats::bvh::{read_bvh, write_bvh, Bvh};
use motion_core::formats::expmap_bvh::{bvh_to_expmap, ExpMapTarget};
use motion_core::formats::h36m_text::{read_expmap_text, write_expmap_text};
use motion_core::formats::npy::{read_npy_dyn, read_npy_frames};
use motion_core::kinematics::channel_positions;
use motion_core::skeleton::Skeleton;

/// Runs `motion-cli predict --model FIXTURE --no-grounding ARGS` (the file-writing rules on the
/// model's raw frames: seeds reproduced exactly, roots anchored); returns (exit code, stdout,
/// stderr). `grounded_predictions_stand_on_the_seed_floor` runs it grounded.
fn predict(args: &[&dyn AsRef<std::ffi::OsStr>]) -> (i32, String, String) {
    predict_with(&[&"--no-grounding"], args)
}

fn predict_with(
    extra: &[&dyn AsRef<std::ffi::OsStr>],
    args: &[&dyn AsRef<std::ffi::OsStr>],
) -> (i32, String, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_motion-cli"))
        .arg("predict")
        .arg("--model")
        .arg(fixture_model())
        .args(extra.iter().map(|a| a.as_ref()))
        .args(args.iter().map(|a| a.as_ref()))
        .output()
        .expect("runs motion-cli");
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn predict_ok(args: &[&dyn AsRef<std::ffi::OsStr>]) -> (String, String) {
    let (code, stdout, stderr) = predict(args);
    assert_eq!(code, 0, "motion-cli predict failed: {stderr}");
    (stdout, stderr)
}

#[test]
fn the_example_seed_is_a_walk_on_the_h36m_skeleton() {
    let bvh = read_bvh(walk_seed()).unwrap();
    assert_eq!(bvh.frames.nrows(), 75, "3 s at 25 Hz");
    assert!((bvh.fps() - 25.0).abs() < 1e-9);
    assert_eq!(ExpMapTarget::detect(&bvh).unwrap(), ExpMapTarget::H36m);
    let p = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
    // The root moves forward (+z) at about 0.7 m/s.
    let speed = (p[[74, 0, 2]] - p[[0, 0, 2]]) / (74.0 / 25.0);
    assert!((speed - 700.0).abs() < 20.0, "{speed} mm/s");
    // Feet reach the floor and the head stays about 1.6-1.8 m above it.
    let floor = p
        .iter()
        .skip(1)
        .step_by(3)
        .fold(f64::INFINITY, |m, &v| m.min(v));
    let head = Skeleton::h36m().joint_index("Head").unwrap();
    let height = p[[0, head, 1]] - floor;
    assert!(
        (1400.0..1900.0).contains(&height),
        "head {height} mm above the floor"
    );
}

#[test]
fn bvh_seed_gives_seed_plus_prediction_that_moves() {
    let dir = scratch("bvh");
    let out = dir.join("pred.bvh");
    let (stdout, _) = predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--action",
        &"walking",
        &"--out",
        &out,
        &"--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["seed_frames"], 10);
    assert_eq!(report["predicted_frames"], 100);
    assert_eq!(report["action"], "walking");
    assert_eq!(listing(&dir), ["pred.bvh"], "no temporary files left");

    let pred = read_bvh(&out).unwrap();
    let seed = read_bvh(walk_seed()).unwrap();
    assert_eq!(pred.frames.nrows(), 110);
    assert!((pred.frame_time - 0.04).abs() < 1e-12);
    assert_eq!(ExpMapTarget::detect(&pred).unwrap(), ExpMapTarget::H36m);
    // The seed part is the seed's last 10 frames, where they were in the input.
    let p_pred = channel_positions(&pred.skeleton, pred.frames.view()).unwrap();
    let p_seed = channel_positions(&seed.skeleton, seed.frames.view()).unwrap();
    for t in 0..10 {
        for j in 0..32 {
            for a in 0..3 {
                let d = (p_pred[[t, j, a]] - p_seed[[65 + t, j, a]]).abs();
                assert!(d < 1e-6, "frame {t} joint {j}: {d} mm");
            }
        }
    }
    // Predicted joints move.
    let wrist = 19;
    let moved = (10..110)
        .map(|t| (p_pred[[t, wrist, 1]] - p_pred[[10, wrist, 1]]).abs())
        .fold(0.0, f64::max);
    assert!(moved > 1.0, "the left hand moved {moved} mm");
}

#[test]
fn samples_prediction_only_and_formats() {
    let dir = scratch("samples");
    let bvh = dir.join("walk.bvh");
    predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--samples",
        &"3",
        &"--frames",
        &"20",
        &"--prediction-only",
        &"--out",
        &bvh,
        &"--quiet",
    ]);
    assert_eq!(listing(&dir), ["walk_0.bvh", "walk_1.bvh", "walk_2.bvh"]);
    let a = read_bvh(dir.join("walk_0.bvh")).unwrap();
    let b = read_bvh(dir.join("walk_1.bvh")).unwrap();
    assert_eq!(a.frames.nrows(), 20);
    assert_ne!(
        a.frames, b.frames,
        "VGRU-d samples differ by their plan noise"
    );

    let npy = dir.join("walk.npy");
    predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--samples",
        &"3",
        &"--frames",
        &"20",
        &"--out",
        &npy,
    ]);
    let stacked = read_npy_dyn(&npy).unwrap();
    assert_eq!(stacked.shape(), [3, 30, 99]);

    let txt = dir.join("one.txt");
    predict_ok(&[&"--seed", &walk_seed(), &"--frames", &"20", &"--out", &txt]);
    let frames = read_expmap_text(&txt).unwrap();
    assert_eq!(frames.dim(), (30, 99));
    // The same noise seed gives the same prediction: sample 0 of the stack is that one (up to
    // float32 rounding: a batch of 3 multiplies matrices, a batch of 1 vectors).
    let diff = (&frames - &stacked.index_axis(ndarray::Axis(0), 0)).mapv(f64::abs);
    let worst = diff.iter().fold(0.0f64, |m, &d| m.max(d));
    assert!(worst < 1e-3, "{worst}");
}

#[test]
fn text_and_npy_seeds_at_other_rates_are_resampled() {
    let dir = scratch("rates");
    let seed = read_bvh(walk_seed()).unwrap();
    let expmap = bvh_to_expmap(&seed, ExpMapTarget::H36m)
        .unwrap()
        .into_frames();
    let text = dir.join("walk25.txt");
    write_expmap_text(&text, expmap.view()).unwrap();

    // Exp-map text read as 25 Hz: used as is; the .npy seed part equals the text's last frames.
    let out = dir.join("from_text.npy");
    let (_, stderr) = predict_ok(&[
        &"--seed",
        &text,
        &"--input-fps",
        &"25",
        &"--frames",
        &"5",
        &"--out",
        &out,
    ]);
    assert!(!stderr.contains("note:"), "{stderr}");
    let written = read_npy_frames(&out).unwrap();
    let original = read_expmap_text(&text).unwrap();
    assert_eq!(written.dim(), (15, 99));
    assert_eq!(
        written.slice(ndarray::s![..10, ..]),
        original.slice(ndarray::s![65.., ..])
    );

    // Read as 50 Hz (the default for exp-map files): every 2nd frame kept, with a notice.
    let (_, stderr) = predict_ok(&[&"--seed", &text, &"--frames", &"5", &"--out", &out]);
    assert!(stderr.contains("one frame in 2 kept"), "{stderr}");

    // A 100 Hz BVH is resampled by slerp, with a one-line notice; --quiet silences it.
    let fast = Bvh {
        frame_time: 0.01,
        ..seed
    };
    let fast_path = dir.join("walk100.bvh");
    write_bvh(&fast_path, &fast).unwrap();
    let (_, stderr) = predict_ok(&[&"--seed", &fast_path, &"--frames", &"5", &"--out", &out]);
    let notices: Vec<&str> = stderr.lines().filter(|l| l.starts_with("note:")).collect();
    assert_eq!(notices.len(), 1, "{stderr}");
    assert!(
        notices[0].contains("100 Hz resampled to the model's 25 Hz"),
        "{stderr}"
    );
    // 75 frames at 100 Hz span 0.74 s: 19 frames at 25 Hz, enough for the fixture's 10.
    let (_, stderr) = predict_ok(&[
        &"--seed",
        &fast_path,
        &"--frames",
        &"5",
        &"--out",
        &out,
        &"--quiet",
    ]);
    assert!(stderr.is_empty(), "{stderr}");
    assert_eq!(read_npy_frames(&out).unwrap().nrows(), 15);
}

#[test]
fn batch_mode_keeps_going_past_a_bad_file() {
    let dir = scratch("batch");
    let seeds = dir.join("seeds");
    let outs = dir.join("out");
    std::fs::create_dir_all(&seeds).unwrap();
    std::fs::create_dir_all(&outs).unwrap();
    std::fs::copy(walk_seed(), seeds.join("a.bvh")).unwrap();
    std::fs::copy(walk_seed(), seeds.join("b.bvh")).unwrap();
    std::fs::write(
        seeds.join("broken.bvh"),
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n",
    )
    .unwrap();
    std::fs::write(seeds.join("notes.md"), "not a seed").unwrap();
    let (code, stdout, stderr) = predict(&[
        &"--seed",
        &seeds,
        &"--out",
        &outs,
        &"--frames",
        &"10",
        &"--json",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert_eq!(listing(&outs), ["a.bvh", "b.bvh"]);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["succeeded"], 2);
    assert_eq!(report["failed"], 1);
    let failed = report["seeds"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s.get("error").is_some())
        .unwrap();
    assert!(
        failed["error"].as_str().unwrap().contains("broken.bvh:4"),
        "{failed}"
    );

    // Text summary without --json.
    let (code, _, stderr) = predict(&[&"--seed", &seeds, &"--out", &outs, &"--frames", &"10"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("predicted 2 of 3 seeds"), "{stderr}");
    assert!(
        stderr.contains("failed: ") && stderr.contains("broken.bvh"),
        "{stderr}"
    );
}

#[test]
fn output_is_deterministic_for_a_noise_seed() {
    let dir = scratch("determinism");
    let (a, b, c) = (dir.join("a.bvh"), dir.join("b.bvh"), dir.join("c.bvh"));
    for (out, seed) in [(&a, "7"), (&b, "7"), (&c, "8")] {
        predict_ok(&[
            &"--seed",
            &walk_seed(),
            &"--rng-seed",
            &seed,
            &"--frames",
            &"30",
            &"--out",
            out,
        ]);
    }
    let read = |p: &PathBuf| std::fs::read(p).unwrap();
    assert_eq!(read(&a), read(&b));
    assert_ne!(read(&a), read(&c));
}

#[test]
fn intention_model_samples_each_draw_their_own_z() {
    // The intention fixture (Tanke et al. 2021, unconditioned): --samples N gives N different
    // predictions, sample i from --rng-seed + i, reproducibly; an action is refused as for any
    // unconditioned model.
    let dir = scratch("intention");
    let model = repo().join("tests/fixtures/parity/intention.safetensors");
    let run = |out: &Path, samples: &str, rng_seed: &str, action: Option<&str>| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_motion-cli"));
        command
            .arg("predict")
            .arg("--model")
            .arg(&model)
            .arg("--no-grounding");
        command
            .arg("--seed")
            .arg(walk_seed())
            .arg("--prediction-only");
        command.args([
            "--frames",
            "20",
            "--samples",
            samples,
            "--rng-seed",
            rng_seed,
        ]);
        if let Some(action) = action {
            command.args(["--action", action]);
        }
        let output = command.arg("--out").arg(out).output().unwrap();
        (
            output.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&output.stderr).into_owned(),
        )
    };
    let (three, one) = (dir.join("three.npy"), dir.join("one.npy"));
    assert_eq!(run(&three, "3", "5", None).0, 0);
    assert_eq!(run(&one, "1", "6", None).0, 0);
    let three = read_npy_dyn(&three).unwrap();
    assert_eq!(three.shape(), &[3, 20, 99]);
    let sample = |k: usize| three.index_axis(ndarray::Axis(0), k).to_owned();
    assert_ne!(sample(0), sample(1));
    assert_ne!(sample(1), sample(2));
    let one = read_npy_dyn(&one).unwrap();
    assert_eq!(one.shape(), &[20, 99], "one sample: frames x dims");
    // Sample 1 of seed 5 is sample 0 of seed 6 (up to the summation order of batch 3 vs 1).
    let diff = (&one - &sample(1)).fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(diff < 1e-4, "max diff {diff}");
    let (code, stderr) = run(&dir.join("x.npy"), "1", "0", Some("walking"));
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("not action-conditioned"), "{stderr}");
}

#[test]
fn seed_end_and_truth_line_up_with_the_seed_file() {
    let dir = scratch("truth");
    let walk = read_bvh(walk_seed()).unwrap();
    let p_walk = channel_positions(&walk.skeleton, walk.frames.view()).unwrap();
    let seed = walk_seed();
    for prediction_only in [false, true] {
        let (pred, truth) = (dir.join("pred.bvh"), dir.join("truth.bvh"));
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
            &"--seed",
            &seed,
            &"--seed-end",
            &"30",
            &"--frames",
            &"20",
            &"--truth",
            &truth,
            &"--out",
            &pred,
            &"--quiet",
        ];
        if prediction_only {
            args.push(&"--prediction-only");
        }
        predict_ok(&args);
        let first = if prediction_only { 30 } else { 20 };
        let t = read_bvh(&truth).unwrap();
        let p = read_bvh(&pred).unwrap();
        assert_eq!(t.frames.nrows(), 50 - first);
        assert_eq!(p.frames.nrows(), 50 - first);
        let p_truth = channel_positions(&t.skeleton, t.frames.view()).unwrap();
        let p_pred = channel_positions(&p.skeleton, p.frames.view()).unwrap();
        // The truth is the seed file's own frames, where they were.
        for k in 0..t.frames.nrows() {
            for j in 0..32 {
                for a in 0..3 {
                    let d = (p_truth[[k, j, a]] - p_walk[[first + k, j, a]]).abs();
                    assert!(d < 1e-6, "frame {k} joint {j}: {d} mm");
                }
            }
        }
        // The prediction continues from there: its first frame's root is near the seed's.
        let r = 0;
        let gap = (0..3)
            .map(|a| (p_pred[[0, r, a]] - p_walk[[first, r, a]]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(gap < 100.0, "prediction starts {gap} mm from the seed");
    }
    // Not enough frames after --seed-end for --truth.
    let (code, _, stderr) = predict(&[
        &"--seed",
        &walk_seed(),
        &"--seed-end",
        &"60",
        &"--frames",
        &"20",
        &"--truth",
        &dir.join("t.bvh"),
        &"--out",
        &dir.join("p.bvh"),
    ]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("--truth needs 20 frames after the seed window, the file has 15"),
        "{stderr}"
    );
}

#[test]
fn h36m_take_is_anchored_by_exact_integration() {
    let take = data_dir().join("h3.6m/dataset/S5/walking_1.txt.gz");
    if !take.exists() {
        eprintln!(
            "SKIPPED: {} not found (set MOTION_DATA_DIR)",
            take.display()
        );
        return;
    }
    let dir = scratch("h36m");
    let (pred, truth) = (dir.join("pred.bvh"), dir.join("truth.bvh"));
    predict_ok(&[
        &"--seed",
        &take,
        &"--seed-end",
        &"1000",
        &"--truth",
        &truth,
        &"--out",
        &pred,
        &"--quiet",
    ]);
    // The seed window starts at 25 Hz frame 990 = 50 Hz frame 1980 of the take, whose pose the
    // 50 Hz integration of every source frame gives (the kept 25 Hz deltas alone drift by
    // tens of centimetres over 40 s).
    let frames = read_expmap_text(&take).unwrap();
    let poses = motion_core::root::integrate_root(frames.view(), 1);
    let t = read_bvh(&truth).unwrap();
    let p = channel_positions(&t.skeleton, t.frames.view()).unwrap();
    for a in 0..3 {
        let d = (p[[0, 0, a]] - poses[1980].translation[a]).abs();
        assert!(d < 1e-6, "axis {a}: {d} mm");
    }
}

fn fixture_classifier() -> PathBuf {
    repo().join("tests/fixtures/parity/action_classifier.safetensors")
}

/// Without --action the seed's action is inferred by the classifier and said so; --action wins.
#[test]
fn the_action_is_inferred_from_the_seed_when_not_given() {
    let dir = scratch("infer");
    let out = dir.join("pred.npy");
    let (stdout, _) = predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--classifier",
        &fixture_classifier(),
        &"--frames",
        &"5",
        &"--out",
        &out,
        &"--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["action_inferred"], true);
    // The label is what the classifier gives the seed's last window (the model's 10 seed frames).
    let classifier = motion_core::model::ActionClassifier::load(fixture_classifier()).unwrap();
    let bvh = read_bvh(walk_seed()).unwrap();
    let motion = bvh_to_expmap(&bvh, ExpMapTarget::H36m).unwrap();
    let frames = motion.frames();
    let n = frames.nrows();
    let (label, _) = classifier
        .infer_action(frames.slice(ndarray::s![n - 10.., ..]))
        .unwrap();
    assert_eq!(report["action"], label.as_str());
    assert!(report["notices"]
        .as_array()
        .unwrap()
        .iter()
        .any(|n| n.as_str().unwrap().contains("inferred from the seed")));
    let (stdout, _) = predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--classifier",
        &fixture_classifier(),
        &"--action",
        &"eating",
        &"--frames",
        &"5",
        &"--out",
        &out,
        &"--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["action"], "eating");
    assert_eq!(report["action_inferred"], false);
    // A classifier file that is not one: exit 2, one line naming it.
    let (code, _, stderr) = predict(&[
        &"--seed",
        &walk_seed(),
        &"--classifier",
        &fixture_model(),
        &"--out",
        &out,
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("vgru_d.safetensors"), "{stderr}");
}

#[test]
fn fps_writes_bvh_at_any_rate_through_the_model_frames() {
    let dir = scratch("fps60");
    let (at25, at60) = (dir.join("p25.bvh"), dir.join("p60.bvh"));
    let seed = walk_seed();
    for (out, fps) in [(&at25, None), (&at60, Some("60"))] {
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
            &"--seed",
            &seed,
            &"--action",
            &"walking",
            &"--frames",
            &"20",
            &"--out",
            out,
        ];
        if let Some(f) = &fps {
            args.extend([&"--fps" as &dyn AsRef<std::ffi::OsStr>, f]);
        }
        predict_ok(&args);
    }
    let (a, b) = (read_bvh(&at25).unwrap(), read_bvh(&at60).unwrap());
    assert!((b.fps() - 60.0).abs() < 1e-9);
    let span = (a.frames.nrows() - 1) as f64 / 25.0;
    assert_eq!(b.frames.nrows(), (span * 60.0 + 1e-6).floor() as usize + 1);
    // Every 0.2 s both have a frame: the 60 Hz file passes through the model's frames.
    let pa = motion_core::kinematics::channel_positions(&a.skeleton, a.frames.view()).unwrap();
    let pb = motion_core::kinematics::channel_positions(&b.skeleton, b.frames.view()).unwrap();
    for k in 0..(a.frames.nrows() - 1) / 5 {
        let d = (&pa.index_axis(ndarray::Axis(0), 5 * k)
            - &pb.index_axis(ndarray::Axis(0), 12 * k))
            .mapv(f64::abs)
            .fold(0.0f64, |m, &v| m.max(v));
        assert!(d < 1e-6, "0.2 s x {k}: {d} mm");
    }
    // Exp-map output keeps the model's rate: --fps is refused, naming the file.
    let (code, _, err) = predict(&[
        &"--seed",
        &walk_seed(),
        &"--action",
        &"walking",
        &"--out",
        &dir.join("p.npy"),
        &"--fps",
        &"60",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("p.npy") && err.contains("--fps"), "{err}");
}

/// The example walk on the library's CMU-style demo rig at 120 fps, written to `path`.
fn write_rig_walk(path: &Path, rename: Option<(&str, &str)>) {
    use motion_core::resample::resample_bvh;
    use motion_core::retarget::{demo_rig, JointMap, Retargeter};
    let rig = demo_rig("", false, 1.0 / 70.0);
    let retargeter = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
    let rest = ndarray::Array2::zeros((1, rig.channel_count()));
    let mut bvh = resample_bvh(
        &retargeter.to_rig(&read_bvh(walk_seed()).unwrap(), rest.view()),
        120.0,
    )
    .unwrap();
    if let Some((from, to)) = rename {
        rename_joint(&mut bvh, from, to);
    }
    write_bvh(path, &bvh).unwrap();
}

/// `bvh` with its joint `from` called `to`: a rig no built-in map fits.
fn rename_joint(bvh: &mut Bvh, from: &str, to: &str) {
    let joints = bvh
        .skeleton
        .joints()
        .iter()
        .map(|j| {
            let mut j = j.clone();
            if j.name == from {
                j.name = to.into();
            }
            j
        })
        .collect();
    bvh.skeleton = motion_core::skeleton::Skeleton::new(joints).unwrap();
}

#[test]
fn a_seed_on_another_rig_is_predicted_and_written_back_onto_it() {
    use motion_core::kinematics::local_transform;
    let dir = scratch("rig");
    let (seed, out) = (dir.join("cmu_walk.bvh"), dir.join("pred.bvh"));
    write_rig_walk(&seed, None);
    let (_, stderr) = predict_ok(&[
        &"--seed",
        &seed,
        &"--action",
        &"walking",
        &"--frames",
        &"20",
        &"--out",
        &out,
    ]);
    assert!(stderr.contains("CMU mocap BVH rig retargeted"), "{stderr}");
    let (input, pred) = (read_bvh(&seed).unwrap(), read_bvh(&out).unwrap());
    assert_eq!(
        pred.skeleton, input.skeleton,
        "written on the user's own rig"
    );
    assert!((pred.fps() - 25.0).abs() < 1e-9);
    // The seed part (the fixture model reads 10 frames) is the input at 25 Hz, unchanged.
    let at25 = motion_core::resample::resample_bvh(&input, 25.0).unwrap();
    let (n, k) = (at25.frames.nrows(), 10);
    assert_eq!(pred.frames.nrows(), k + 20);
    let mut worst: f64 = 0.0;
    for t in 0..k {
        let (a, b) = (at25.frames.row(n - k + t), pred.frames.row(t));
        for j in 0..input.skeleton.len() {
            let qa = glam::DQuat::from_mat3(
                &local_transform(&input.skeleton, j, a.as_slice().unwrap()).0,
            );
            let qb = glam::DQuat::from_mat3(
                &local_transform(&input.skeleton, j, b.as_slice().unwrap()).0,
            );
            worst = worst.max(2.0 * (qa.inverse() * qb).xyz().length());
        }
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() < 1e-6,
                "frame {t}: root {c}: {} vs {}",
                a[c],
                b[c]
            );
        }
    }
    assert!(
        worst.to_degrees() < 1e-4,
        "seed round trip {} deg",
        worst.to_degrees()
    );

    // A rig no built-in map fits: one line naming the file and the joint without a match.
    let odd = dir.join("odd.bvh");
    write_rig_walk(&odd, Some(("LeftForeArm", "LeftElbow")));
    let (code, _, err) = predict(&[&"--seed", &odd, &"--action", &"walking", &"--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("odd.bvh") && err.contains("\"LeftForeArm\""),
        "{err}"
    );
    // A joint map fixes it; one naming a joint the rig lacks is refused, naming both.
    let names =
        motion_core::retarget::CMU_NAMES.map(|n| if n == "LeftForeArm" { "LeftElbow" } else { n });
    let pairs: Vec<String> = motion_core::retarget::MAPPED_JOINTS
        .iter()
        .zip(names)
        .map(|(m, u)| format!("\"{m}\": \"{u}\""))
        .collect();
    let map = dir.join("map.json");
    std::fs::write(&map, format!("{{{}}}", pairs.join(", "))).unwrap();
    predict_ok(&[
        &"--seed",
        &odd,
        &"--action",
        &"walking",
        &"--joint-map",
        &map,
        &"--out",
        &out,
    ]);
    std::fs::write(
        &map,
        format!("{{{}}}", pairs.join(", ")).replace("LeftElbow", "LeftKnuckle"),
    )
    .unwrap();
    let (code, _, err) = predict(&[
        &"--seed",
        &odd,
        &"--action",
        &"walking",
        &"--joint-map",
        &map,
        &"--out",
        &out,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("map.json") && err.contains("LeftKnuckle"),
        "{err}"
    );
}

#[test]
fn grounded_predictions_stand_on_the_seed_floor() {
    // The fixture's random weights float and tumble the body; grounded (the default), every
    // predicted frame keeps its lowest foot point on the seed's floor, levelled to y = 0.
    let dir = scratch("grounded");
    let (pred, raw) = (dir.join("pred.bvh"), dir.join("raw.bvh"));
    let (code, stdout, stderr) = predict_with(
        &[],
        &[
            &"--seed",
            &walk_seed(),
            &"--action",
            &"walking",
            &"--frames",
            &"100",
            &"--out",
            &pred,
            &"--json",
        ],
    );
    assert_eq!(code, 0, "{stderr}");
    predict_ok(&[
        &"--seed",
        &walk_seed(),
        &"--action",
        &"walking",
        &"--frames",
        &"100",
        &"--out",
        &raw,
    ]);
    // The output is in the seed's coordinates: the floor is the plane fitted to the seed's feet.
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let floor = &report["seed_floor"];
    let plane = |x: f64, z: f64| {
        1000.0
            * (floor["slope_x"].as_f64().unwrap() * x / 1000.0
                + floor["slope_z"].as_f64().unwrap() * z / 1000.0
                + floor["height_m"].as_f64().unwrap())
    };
    // Per frame: the lowest foot point's height over the floor under it (mm).
    let lowest = |path: &Path, over_floor: bool| -> Vec<f64> {
        let track = motion_core::any_format::read_positions(path, 25.0, 0).unwrap();
        let p = track.positions;
        (0..p.shape()[0])
            .map(|t| {
                [3, 4, 5, 8, 9, 10]
                    .map(|j| {
                        let under = if over_floor {
                            plane(p[[t, j, 0]], p[[t, j, 2]])
                        } else {
                            0.0
                        };
                        p[[t, j, 1]] - under
                    })
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    };
    let (grounded, raw) = (lowest(&pred, true), lowest(&raw, false));
    for (t, y) in grounded.iter().enumerate().skip(50) {
        assert!(
            y.abs() < 10.0,
            "frame {t}: lowest foot point {y} mm over the seed's floor"
        );
    }
    let raw_off = raw[50..]
        .iter()
        .map(|y| (y - raw[49]).abs())
        .fold(0.0, f64::max);
    assert!(
        raw_off > 50.0,
        "the raw fixture stays on the floor ({raw_off} mm): the test shows nothing"
    );
}

/// `bvh` with its whole motion tilted `degrees` about the world x and z axes and lifted `lift`
/// units along world +y and +z: a take whose floor is sloped and off the origin.
fn tilted(bvh: &Bvh, degrees: f64, lift: f64) -> Bvh {
    use motion_core::formats::expmap_bvh::continuous_euler_degrees;
    use motion_core::kinematics::local_transform;
    use motion_core::rotation::EulerOrder;
    use motion_core::skeleton::Channel;
    let tilt = glam::DQuat::from_rotation_x(degrees.to_radians())
        * glam::DQuat::from_rotation_z(0.7 * degrees.to_radians());
    let root = bvh.skeleton.joint(0);
    let axis = |c: &Channel| match c {
        Channel::Xrotation | Channel::Xposition => 0,
        Channel::Yrotation | Channel::Yposition => 1,
        _ => 2,
    };
    let rot: Vec<usize> = (0..root.channels.len())
        .filter(|&k| root.channels[k].is_rotation())
        .collect();
    let pos: Vec<usize> = (0..root.channels.len())
        .filter(|&k| !root.channels[k].is_rotation())
        .collect();
    let order = EulerOrder::from_axes([0, 1, 2].map(|i| axis(&root.channels[rot[i]]))).unwrap();
    let offset = glam::DVec3::from_array(root.offset);
    let mut out = bvh.clone();
    let mut before = None;
    for t in 0..bvh.frames.nrows() {
        let row = bvh.frames.row(t).to_vec();
        let (r, p) = local_transform(&bvh.skeleton, 0, &row);
        let q = tilt * glam::DQuat::from_mat3(&r);
        let world = tilt * p + glam::DVec3::new(0.0, lift, lift);
        let angles = continuous_euler_degrees(order, q, before);
        before = Some(angles);
        for i in 0..3 {
            out.frames[[t, rot[i]]] = angles[i];
            out.frames[[t, pos[i]]] = (world - offset)[axis(&root.channels[pos[i]])];
        }
    }
    out
}

/// The seed part of a grounded prediction is the input's last frames, and the prediction goes on
/// from where the input ends, in the input's coordinates, on a tilted and lifted floor: for a
/// CMU-style rig, the same rig z-up, and a rig mapped by a joint map.
#[test]
fn a_grounded_prediction_keeps_the_seed_in_the_users_coordinates() {
    use motion_core::kinematics::local_transform;
    use motion_core::resample::resample_bvh;
    use motion_core::retarget::{demo_rig, JointMap, Retargeter, CMU_NAMES, MAPPED_JOINTS};
    let dir = scratch("user_frame");
    let walk = read_bvh(walk_seed()).unwrap();
    let map = dir.join("map.json");
    let pairs: Vec<String> = MAPPED_JOINTS
        .iter()
        .zip(CMU_NAMES.map(|n| if n == "LeftForeArm" { "LeftElbow" } else { n }))
        .map(|(m, u)| format!("\"{m}\": \"{u}\""))
        .collect();
    std::fs::write(&map, format!("{{{}}}", pairs.join(", "))).unwrap();
    for (name, z_up, renamed) in [
        ("cmu", false, false),
        ("zup", true, false),
        ("mapped", false, true),
    ] {
        let rig = demo_rig("", z_up, 1.0 / 10.0);
        let retargeter = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
        let rest = ndarray::Array2::zeros((1, rig.channel_count()));
        let mut bvh = tilted(&retargeter.to_rig(&walk, rest.view()), 3.0, 40.0);
        if renamed {
            rename_joint(&mut bvh, "LeftForeArm", "LeftElbow");
        }
        let bvh = resample_bvh(&bvh, 25.0).unwrap();
        let (seed, out) = (
            dir.join(format!("{name}.bvh")),
            dir.join(format!("{name}_pred.bvh")),
        );
        write_bvh(&seed, &bvh).unwrap();
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
            &"--seed",
            &seed,
            &"--action",
            &"walking",
            &"--frames",
            &"20",
            &"--out",
            &out,
            &"--json",
        ];
        if renamed {
            args.extend([&"--joint-map" as &dyn AsRef<std::ffi::OsStr>, &map]);
        }
        let (code, stdout, stderr) = predict_with(&[], &args);
        assert_eq!(code, 0, "{name}: {stderr}");
        let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert!(
            report["notices"].to_string().contains("tilted"),
            "{name}: the tilt is reported: {}",
            report["notices"]
        );
        let tilt = report["seed_floor"]["tilt_deg"].as_f64().unwrap();
        assert!(tilt > 0.5 && tilt < 20.0, "{name}: floor tilt {tilt}");
        let (input, pred) = (read_bvh(&seed).unwrap(), read_bvh(&out).unwrap());
        let (n, k) = (input.frames.nrows(), 10);
        assert_eq!(pred.frames.nrows(), k + 20);
        let (mut worst_deg, mut worst_rel): (f64, f64) = (0.0, 0.0);
        for t in 0..k {
            let (a, b) = (input.frames.row(n - k + t), pred.frames.row(t));
            for j in 0..input.skeleton.len() {
                let q = |row: ndarray::ArrayView1<'_, f64>| {
                    glam::DQuat::from_mat3(
                        &local_transform(&input.skeleton, j, row.as_slice().unwrap()).0,
                    )
                };
                let d = q(a).inverse() * q(b);
                worst_deg = worst_deg.max(2.0 * d.xyz().length().to_degrees());
            }
            for c in 0..3 {
                worst_rel = worst_rel.max((a[c] - b[c]).abs() / a[c].abs().max(1.0));
            }
        }
        assert!(
            worst_deg < 1e-4,
            "{name}: seed rotations differ by {worst_deg} deg"
        );
        assert!(
            worst_rel < 1e-6,
            "{name}: seed root differs by {worst_rel} (relative)"
        );
        // The prediction continues from the seed's last frame: one step, not a jump.
        let step = |row: ndarray::ArrayView1<'_, f64>| glam::DVec3::new(row[0], row[1], row[2]);
        let last_step = (step(input.frames.row(n - 1)) - step(input.frames.row(n - 2))).length();
        let first = (step(pred.frames.row(k)) - step(pred.frames.row(k - 1))).length();
        assert!(
            first < 3.0 * last_step + 2.0,
            "{name}: jump of {first} units (a step is {last_step})"
        );
    }
}
