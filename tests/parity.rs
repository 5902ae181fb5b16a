//! Parity with the PyTorch reference modules (`training/layers.py`, `training/models.py`): the
//! committed fixtures in `tests/fixtures/parity/` (written by `python -m training.export_fixtures`)
//! must be reproduced within 1e-5, and loading errors must name the tensor and the file.
use motion::core::model::intention::Intention;
use motion::core::model::weights::serialize_f32;
use motion::core::model::{
    BatchGenerator, GenerateError, Generator, MotionModel, Noise, WeightStore, WeightsError,
};
use motion::core::nn::{
    BodyGruCell, BodyGruConfig, GruCell, GruConfig, GruConvention, GruScratch, Linear,
    LinearConfig, LstmCell, LstmConfig, LstmScratch, Mlp, MlpConfig, MlpScratch,
};
use ndarray::ArrayView2;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

const TOLERANCE: f32 = 1e-5;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/parity")
        .join(name)
}

fn layers() -> WeightStore {
    WeightStore::open(fixture("layers.safetensors")).expect("layers fixture")
}

fn get(store: &WeightStore, name: &str) -> (Vec<usize>, Vec<f32>) {
    store.tensor_any_shape(name).expect(name)
}

fn assert_close(what: &str, got: &[f32], expected: &[f32]) {
    assert_eq!(got.len(), expected.len(), "{what}: length");
    let (worst, at) = got
        .iter()
        .zip(expected)
        .enumerate()
        .map(|(i, (g, e))| ((g - e).abs(), i))
        .fold((0.0f32, 0), |a, b| if b.0 > a.0 { b } else { a });
    assert!(
        worst <= TOLERANCE,
        "{what}: max |diff| {worst:e} at {at} (got {}, expected {})",
        got[at],
        expected[at]
    );
}

fn convention(store: &WeightStore, name: &str) -> GruConvention {
    let text = store
        .metadata(&format!("{name}.convention"))
        .expect("convention metadata");
    GruConvention::from_name(text).expect("known convention")
}

fn check_gru(name: &str) {
    let store = layers();
    let (xs, x) = get(&store, &format!("{name}.x"));
    let (_, h0) = get(&store, &format!("{name}.h0"));
    let (_, expected) = get(&store, &format!("{name}.h"));
    let (steps, batch, inputs) = (xs[0], xs[1], xs[2]);
    let hidden = h0.len() / batch;
    let config = GruConfig {
        inputs,
        hidden,
        convention: convention(&store, name),
    };
    let cell = GruCell::load(&store, name, config).unwrap();
    // Batch 2 (sgemm path) and each row alone (GEMV path) must both match.
    let mut scratch = GruScratch::new(hidden, batch);
    let mut h = h0.clone();
    for t in 0..steps {
        cell.step(
            &x[t * batch * inputs..(t + 1) * batch * inputs],
            &mut h,
            batch,
            &mut scratch,
        );
        let e = &expected[t * batch * hidden..(t + 1) * batch * hidden];
        assert_close(&format!("{name} step {t}"), &h, e);
    }
    for b in 0..batch {
        let mut h = h0[b * hidden..(b + 1) * hidden].to_vec();
        for t in 0..steps {
            let xt = &x[(t * batch + b) * inputs..(t * batch + b + 1) * inputs];
            cell.step(xt, &mut h, 1, &mut scratch);
            let e = &expected[(t * batch + b) * hidden..(t * batch + b + 1) * hidden];
            assert_close(&format!("{name} row {b} step {t}"), &h, e);
        }
    }
}

#[test]
fn gru_pytorch_convention() {
    check_gru("gru_pytorch");
}

#[test]
fn gru_paper_convention() {
    check_gru("gru_paper");
}

fn check_body_gru(name: &str) {
    let store = layers();
    let (xs, x) = get(&store, &format!("{name}.x"));
    let (ps, p) = get(&store, &format!("{name}.p"));
    let (_, h0) = get(&store, &format!("{name}.h0"));
    let (_, expected) = get(&store, &format!("{name}.h"));
    let (steps, batch, inputs, guide) = (xs[0], xs[1], xs[2], ps[2]);
    let hidden = h0.len() / batch;
    let config = BodyGruConfig {
        gru: GruConfig {
            inputs,
            hidden,
            convention: convention(&store, name),
        },
        guide,
    };
    let cell = BodyGruCell::load(&store, name, config).unwrap();
    let mut scratch = GruScratch::new(hidden, batch);
    let mut h = h0.clone();
    for t in 0..steps {
        let xt = &x[t * batch * inputs..(t + 1) * batch * inputs];
        let pt = &p[t * batch * guide..(t + 1) * batch * guide];
        cell.step(xt, pt, guide, &mut h, batch, &mut scratch);
        let e = &expected[t * batch * hidden..(t + 1) * batch * hidden];
        assert_close(&format!("{name} step {t}"), &h, e);
    }
}

#[test]
fn body_gru_paper_convention() {
    check_body_gru("body_gru_paper");
}

#[test]
fn body_gru_pytorch_convention() {
    check_body_gru("body_gru_pytorch");
}

#[test]
fn lstm_cell() {
    let store = layers();
    let (xs, x) = get(&store, "lstm.x");
    let (_, h0) = get(&store, "lstm.h0");
    let (_, c0) = get(&store, "lstm.c0");
    let (_, eh) = get(&store, "lstm.h");
    let (_, ec) = get(&store, "lstm.c");
    let (steps, batch, inputs) = (xs[0], xs[1], xs[2]);
    let hidden = h0.len() / batch;
    let cell = LstmCell::load(&store, "lstm", LstmConfig { inputs, hidden }).unwrap();
    let mut scratch = LstmScratch::new(hidden, batch);
    let (mut h, mut c) = (h0, c0);
    for t in 0..steps {
        let xt = &x[t * batch * inputs..(t + 1) * batch * inputs];
        cell.step(xt, &mut h, &mut c, batch, &mut scratch);
        let span = t * batch * hidden..(t + 1) * batch * hidden;
        assert_close(&format!("lstm h step {t}"), &h, &eh[span.clone()]);
        assert_close(&format!("lstm c step {t}"), &c, &ec[span]);
    }
}

#[test]
fn linear_layer() {
    let store = layers();
    let (xs, x) = get(&store, "linear.x");
    let (ys, expected) = get(&store, "linear.y");
    let config = LinearConfig {
        inputs: xs[1],
        outputs: ys[1],
    };
    let layer = Linear::load(&store, "linear", config).unwrap();
    let mut y = vec![0.0; expected.len()];
    layer.forward(&x, xs[0], &mut y);
    assert_close("linear", &y, &expected);
    layer.forward(&x[..xs[1]], 1, &mut y[..ys[1]]);
    assert_close("linear row 0", &y[..ys[1]], &expected[..ys[1]]);
}

#[test]
fn mlp() {
    let store = layers();
    let (xs, x) = get(&store, "mlp.x");
    let (_, expected) = get(&store, "mlp.y");
    let sizes: serde_json::Value = serde_json::from_str(store.metadata("sizes").unwrap()).unwrap();
    let widths: Vec<usize> = sizes["mlp"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    let mlp = Mlp::load(&store, "mlp", &MlpConfig { widths }).unwrap();
    let mut scratch = MlpScratch::new(&mlp, xs[0]);
    let mut y = vec![0.0; expected.len()];
    mlp.forward(&x, xs[0], &mut y, &mut scratch);
    assert_close("mlp", &y, &expected);
}

/// Runs a model fixture through the single-character Generator: teacher-forced outputs and 30
/// closed-loop frames.
fn check_model(name: &str) {
    let model = Arc::new(MotionModel::load(fixture(&format!("{name}.safetensors"))).unwrap());
    let expected = WeightStore::open(fixture(&format!("{name}.expected.safetensors"))).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (_, teacher) = get(&expected, "teacher_forced");
    let (cs, closed) = get(&expected, "closed_loop");
    let eps = expected.tensor_any_shape("eps").ok().map(|(_, v)| v);
    let horizon: usize = expected.metadata("horizon").unwrap().parse().unwrap();
    let action = expected.metadata("action");
    let width = ss[1];
    let seed = ArrayView2::from_shape((ss[0], width), &seed).unwrap();

    let mut generator = Generator::new(model);
    generator.set_plan_horizon(horizon).unwrap();
    let noise = match &eps {
        Some(e) => Noise::Explicit(e),
        None => Noise::Seed(0),
    };
    let mut tf = vec![0.0f32; teacher.len()];
    generator
        .start_with(seed, action, noise, |t, frame| {
            tf[t * width..(t + 1) * width].copy_from_slice(frame)
        })
        .unwrap();
    assert_close(&format!("{name} teacher_forced"), &tf, &teacher);
    for k in 0..cs[0] {
        let frame = generator.step().unwrap();
        assert_close(
            &format!("{name} closed_loop[{k}]"),
            frame,
            &closed[k * width..(k + 1) * width],
        );
    }
}

#[test]
fn vgru_d() {
    check_model("vgru_d");
}

/// `goal-gru` under a control that is constant over the seed and changes every step after it:
/// `set_control` before `start` and before each step reproduces `GoalGRU`'s closed loop.
#[test]
fn goal_gru_follows_its_control_step_by_step() {
    goal_gru_parity("goal_gru");
}

/// The same with a pose prior in the closed loop (`motion_core::model::prior`, PyTorch's
/// `PosePrior`): every generated and teacher-forced frame pulled to its radius as PyTorch does.
#[test]
fn goal_gru_with_a_pose_prior_matches_pytorch() {
    let model = MotionModel::load(fixture("goal_gru_prior.safetensors")).unwrap();
    assert!(model
        .prior()
        .is_some_and(|p| (p.radius() - 0.6).abs() < 1e-6));
    goal_gru_parity("goal_gru_prior");
}

fn goal_gru_parity(stem: &str) {
    let model = Arc::new(MotionModel::load(fixture(&format!("{stem}.safetensors"))).unwrap());
    let expected = WeightStore::open(fixture(&format!("{stem}.expected.safetensors"))).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (_, teacher) = get(&expected, "teacher_forced");
    let (cs, closed) = get(&expected, "closed_loop");
    let (ks, control) = get(&expected, "control");
    let (width, s, c) = (ss[1], ss[0], ks[1]);
    let seed = ArrayView2::from_shape((s, width), &seed).unwrap();
    let mut generator = Generator::new(model);
    assert_eq!(generator.control_dims(), c);
    generator.set_control(&control[(s - 1) * c..s * c]).unwrap();
    let mut tf = vec![0.0f32; teacher.len()];
    generator
        .start_with(seed, None, Noise::Seed(0), |t, frame| {
            tf[t * width..(t + 1) * width].copy_from_slice(frame)
        })
        .unwrap();
    assert_close(&format!("{stem} teacher_forced"), &tf, &teacher);
    for k in 0..cs[0] {
        if k > 0 {
            let t = s + k - 1;
            generator.set_control(&control[t * c..(t + 1) * c]).unwrap();
        }
        let frame = generator.step().unwrap();
        assert_close(
            &format!("{stem} closed_loop[{k}]"),
            frame,
            &closed[k * width..(k + 1) * width],
        );
    }
    // A control of the wrong length, or on a model without one, is a typed error.
    assert!(matches!(
        generator.set_control(&[0.0; 2]),
        Err(GenerateError::BadControl { expected: 3, .. })
    ));
    let grud = Arc::new(MotionModel::load(fixture("gru_d.safetensors")).unwrap());
    assert_eq!(
        Generator::new(grud).set_control(&[0.0; 3]),
        Err(GenerateError::NotControlled)
    );
}

/// Past its plan horizon the VGRU-d streams plan blocks (`model/vgru.rs`, "Streaming beyond the
/// planned horizon"); `training/models.py` (`VGRUD.plan_guides`) follows the same rule, so a closed
/// loop through three blocks matches PyTorch's.
fn check_streamed_plan(name: &str) {
    let model = Arc::new(MotionModel::load(fixture(&format!("{name}.safetensors"))).unwrap());
    let expected = WeightStore::open(fixture(&format!("{name}.expected.safetensors"))).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (ls, long) = get(&expected, "closed_loop_long");
    let (_, eps) = get(&expected, "eps");
    let horizon: usize = expected.metadata("horizon").unwrap().parse().unwrap();
    let long_horizon: usize = expected.metadata("long_horizon").unwrap().parse().unwrap();
    assert_eq!(ls[0], long_horizon);
    assert!(
        long_horizon > 3 * horizon,
        "the fixture must cross three block boundaries"
    );
    let width = ss[1];
    let seed = ArrayView2::from_shape((ss[0], width), &seed).unwrap();
    let mut generator = Generator::new(model);
    generator.set_plan_horizon(horizon).unwrap();
    generator
        .start(seed, expected.metadata("action"), Noise::Explicit(&eps))
        .unwrap();
    for k in 0..long_horizon {
        let frame = generator.step().unwrap();
        assert_close(
            &format!("{name} closed_loop_long[{k}]"),
            frame,
            &long[k * width..(k + 1) * width],
        );
    }
}

#[test]
fn vgru_d_streamed_plan_blocks() {
    check_streamed_plan("vgru_d");
    check_streamed_plan("vgru_d_residual");
    check_streamed_plan("vgru_d_f16");
}

#[test]
fn vgru_d_residual() {
    check_model("vgru_d_residual");
}

#[test]
fn vgru_d_f16_weights() {
    check_model("vgru_d_f16");
}

#[test]
fn gru_d() {
    check_model("gru_d");
}

#[test]
fn gru_d_residual() {
    check_model("gru_d_residual");
}

#[test]
fn dae_lstm() {
    check_model("dae_lstm");
}

/// Runs an intention fixture (Tanke et al. 2021) through the single-character Generator with the
/// fixture's explicit `z`: the seed's labels and the closed-loop frames (the model makes no
/// teacher-forced predictions). Returns the largest difference from PyTorch.
fn check_intention(name: &str) -> f32 {
    let model = Arc::new(MotionModel::load(fixture(&format!("{name}.safetensors"))).unwrap());
    let expected = WeightStore::open(fixture(&format!("{name}.expected.safetensors"))).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (_, z) = get(&expected, "eps");
    let (_, labels) = get(&expected, "seed_labels");
    let (cs, closed) = get(&expected, "closed_loop");
    let lookahead: usize = expected.metadata("lookahead").unwrap().parse().unwrap();
    assert_eq!(
        motion::core::model::intention::IntentionConfig::of(model.config()).lookahead,
        lookahead,
        "{name}"
    );
    let width = ss[1];
    let seed = ArrayView2::from_shape((ss[0], width), &seed).unwrap();

    let Some(net) = model.network().downcast_ref::<Intention>() else {
        panic!("{name}: not an intention model")
    };
    let o = model.config().output_dims();
    let mut x = vec![0.0f32; o];
    for (t, frame) in seed.outer_iter().enumerate() {
        model
            .normalization()
            .normalize(frame.as_slice().unwrap(), &mut x);
        assert_eq!(
            net.label(&x) as f32,
            labels[t],
            "{name}: label of seed frame {t}"
        );
    }

    let mut generator = Generator::new(Arc::clone(&model));
    generator
        .start_with(seed, None, Noise::Explicit(&z), |t, _| {
            panic!("{name}: a teacher-forced prediction after seed frame {t}")
        })
        .unwrap();
    let mut worst = 0.0f32;
    for k in 0..cs[0] {
        let frame = generator.step().unwrap();
        let e = &closed[k * width..(k + 1) * width];
        assert_close(&format!("{name} closed_loop[{k}]"), frame, e);
        worst = frame
            .iter()
            .zip(e)
            .fold(worst, |w, (g, e)| w.max((g - e).abs()));
    }
    // Unconditioned: an action is ignored.
    let mut with_action = Generator::new(Arc::clone(&model));
    with_action
        .start(seed, Some("walking"), Noise::Explicit(&z))
        .unwrap();
    let frames = with_action.generate(cs[0]).unwrap();
    assert_close(
        &format!("{name} with an action"),
        frames.as_slice().unwrap(),
        &closed,
    );
    eprintln!(
        "{name}: max |Rust - PyTorch float64| over {} frames: {worst:e}",
        cs[0]
    );
    worst
}

#[test]
fn intention() {
    check_intention("intention");
}

#[test]
fn intention_lookahead_1_and_2() {
    // gamma 1: the window is the previous frame alone, nothing forecast before the first step;
    // gamma 2: the ring holds two frames, nothing forecast before the first step either.
    check_intention("intention_lookahead1");
    check_intention("intention_lookahead2");
}

/// The action-conditioned intention fixture: the closed loop under the fixture's action, and a
/// switch to another action mid-stream (`Generator::set_action` before the pose step producing
/// frame `S + switch_at`).
#[test]
fn intention_with_actions_and_a_switch() {
    let name = "intention_actions";
    let model = Arc::new(MotionModel::load(fixture(&format!("{name}.safetensors"))).unwrap());
    let expected = WeightStore::open(fixture(&format!("{name}.expected.safetensors"))).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (_, z) = get(&expected, "eps");
    let (cs, closed) = get(&expected, "closed_loop");
    let (_, switched) = get(&expected, "switched");
    let action = expected.metadata("action").unwrap().to_string();
    let switch_to = expected.metadata("switch_to").unwrap().to_string();
    let switch_at: usize = expected.metadata("switch_at").unwrap().parse().unwrap();
    let width = ss[1];
    let seed = ArrayView2::from_shape((ss[0], width), &seed).unwrap();

    let mut generator = Generator::new(Arc::clone(&model));
    generator
        .start(seed, Some(&action), Noise::Explicit(&z))
        .unwrap();
    let frames = generator.generate(cs[0]).unwrap();
    assert_close(
        &format!("{name} closed_loop"),
        frames.as_slice().unwrap(),
        &closed,
    );
    assert!(
        matches!(
            Generator::new(Arc::clone(&model)).start(seed, None, Noise::Explicit(&z)),
            Err(GenerateError::MissingAction { .. })
        ),
        "a conditioned model needs an action"
    );

    let mut generator = Generator::new(Arc::clone(&model));
    generator
        .start(seed, Some(&action), Noise::Explicit(&z))
        .unwrap();
    for k in 0..cs[0] {
        if k == switch_at {
            generator.set_action(&switch_to, 0).unwrap();
        }
        let frame = generator.step().unwrap();
        assert_close(
            &format!("{name} switched[{k}]"),
            frame,
            &switched[k * width..(k + 1) * width],
        );
    }
    assert_ne!(
        &switched[(cs[0] - 1) * width..],
        &closed[(cs[0] - 1) * width..],
        "the switch changes the motion"
    );
}

#[test]
fn intention_batch_rows_with_their_own_z() {
    // Row 0 has the fixture's z, row 1 another z, row 2 the fixture's z again: rows 0 and 2
    // reproduce PyTorch, row 1 differs.
    let model = Arc::new(MotionModel::load(fixture("intention.safetensors")).unwrap());
    let expected = WeightStore::open(fixture("intention.expected.safetensors")).unwrap();
    let (ss, seed) = get(&expected, "seed");
    let (_, z) = get(&expected, "eps");
    let (cs, closed) = get(&expected, "closed_loop");
    let width = ss[1];
    let other: Vec<f32> = z.iter().map(|v| -v).collect();
    let seed = ArrayView2::from_shape((ss[0], width), &seed).unwrap();
    let seeds = seed.broadcast((3, ss[0], width)).unwrap();
    let mut batch = BatchGenerator::new(model, 3);
    batch
        .start(
            seeds,
            &[],
            &[
                Noise::Explicit(&z),
                Noise::Explicit(&other),
                Noise::Explicit(&z),
            ],
        )
        .unwrap();
    let mut differs = false;
    for k in 0..cs[0] {
        let frames = batch.step().unwrap();
        let e = &closed[k * width..(k + 1) * width];
        for row in [0, 2] {
            let got: Vec<f32> = frames.row(row).to_vec();
            assert_close(&format!("row {row} closed_loop[{k}]"), &got, e);
        }
        differs |= frames.row(1) != frames.row(0);
    }
    assert!(differs, "another z gives another future");
}

// ---- loading errors -----------------------------------------------------------------------------

/// A fixture's tensors (as f32) and metadata, for editing.
type Parts = (
    Vec<(String, Vec<usize>, Vec<f32>)>,
    BTreeMap<String, String>,
);

/// Rewrites a fixture with `edit` applied to its tensors and metadata, into a temp file.
fn edited(name: &str, edit: impl FnOnce(&mut Parts)) -> (tempfile::TempDir, PathBuf) {
    let store = WeightStore::open(fixture(name)).unwrap();
    let tensors = store
        .names()
        .map(|n| {
            let (s, v) = store.tensor_any_shape(n).unwrap();
            (n.to_string(), s, v)
        })
        .collect();
    let mut parts: Parts = (tensors, store.metadata_map().clone());
    edit(&mut parts);
    let data = serialize_f32(
        parts
            .0
            .iter()
            .map(|(n, s, v)| (n.as_str(), s.as_slice(), v.as_slice())),
        &parts.1,
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("edited.safetensors");
    std::fs::write(&path, data).unwrap();
    (dir, path)
}

fn load_error(path: &PathBuf) -> (WeightsError, String) {
    let err = MotionModel::load(path).unwrap_err();
    let msg = err.to_string();
    (err, msg)
}

#[test]
fn missing_tensor_is_named_with_file() {
    let (_dir, path) = edited("gru_d.safetensors", |(t, _)| {
        t.retain(|(n, _, _)| n != "rnn.1.weight_hh")
    });
    let (err, msg) = load_error(&path);
    assert!(matches!(err, WeightsError::MissingTensor { .. }), "{msg}");
    assert!(
        msg.contains("rnn.1.weight_hh") && msg.contains("edited.safetensors"),
        "{msg}"
    );
}

#[test]
fn wrong_shape_is_named_with_file() {
    let (_dir, path) = edited("vgru_d.safetensors", |(t, _)| {
        let entry = t
            .iter_mut()
            .find(|(n, _, _)| n == "body.weight_ph")
            .unwrap();
        entry.1 = vec![entry.1[1], entry.1[0]];
    });
    let (err, msg) = load_error(&path);
    assert!(matches!(err, WeightsError::WrongShape { .. }), "{msg}");
    assert!(
        msg.contains("body.weight_ph") && msg.contains("edited.safetensors"),
        "{msg}"
    );
    assert!(msg.contains("[48, 8]"), "{msg}");
}

#[test]
fn nan_weight_is_named_with_file() {
    let (_dir, path) = edited("gru_d.safetensors", |(t, _)| {
        let entry = t.iter_mut().find(|(n, _, _)| n == "decoder.bias").unwrap();
        entry.2[3] = f32::NAN;
    });
    let (err, msg) = load_error(&path);
    assert!(
        matches!(err, WeightsError::NonFinite { index: 3, .. }),
        "{msg}"
    );
    assert!(
        msg.contains("decoder.bias") && msg.contains("edited.safetensors"),
        "{msg}"
    );
}

#[test]
fn unknown_format_version_is_rejected() {
    let (_dir, path) = edited("gru_d.safetensors", |(_, m)| {
        m.insert("format_version".into(), "2".into());
    });
    let (err, msg) = load_error(&path);
    assert!(
        matches!(err, WeightsError::UnsupportedVersion { .. }),
        "{msg}"
    );
    assert!(
        msg.contains("format_version") && msg.contains("edited.safetensors"),
        "{msg}"
    );
}

#[test]
fn missing_file_and_garbage_are_errors() {
    let missing = fixture("does_not_exist.safetensors");
    assert!(matches!(
        MotionModel::load(&missing),
        Err(WeightsError::Io { .. })
    ));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("garbage.safetensors");
    std::fs::write(&path, b"not a safetensors file at all").unwrap();
    let msg = MotionModel::load(&path).unwrap_err().to_string();
    assert!(msg.contains("garbage.safetensors"), "{msg}");
    // A layers file is valid safetensors but not a motion-weights file.
    let msg = MotionModel::load(fixture("layers.safetensors"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("format") && msg.contains("layers.safetensors"),
        "{msg}"
    );
}

#[test]
fn zero_std_on_a_used_dim_is_rejected() {
    let (_dir, path) = edited("gru_d.safetensors", |(t, _)| {
        let entry = t.iter_mut().find(|(n, _, _)| n == "norm.std").unwrap();
        entry.2[6] = 0.0; // dim 6 is used
    });
    let (err, msg) = load_error(&path);
    assert!(matches!(err, WeightsError::InvalidTensor { .. }), "{msg}");
    assert!(
        msg.contains("norm.std") && msg.contains("edited.safetensors"),
        "{msg}"
    );
}

#[test]
fn a_std_or_mean_that_overflows_is_rejected() {
    for (tensor, value) in [
        ("norm.std", 1e-38f32),
        ("norm.mean", 3e38),
        ("norm.std", f32::NAN),
    ] {
        let (_dir, path) = edited("gru_d.safetensors", |(t, _)| {
            let entry = t.iter_mut().find(|(n, _, _)| n == tensor).unwrap();
            entry.2[6] = value; // dim 6 is used
        });
        let (err, msg) = load_error(&path);
        // NaN is caught when the tensor is read, the others by the normalization's range.
        assert!(
            value.is_nan() || matches!(err, WeightsError::InvalidTensor { .. }),
            "{msg}"
        );
        assert!(msg.contains(tensor) && msg.contains(" 6"), "{msg}");
    }
}

#[test]
fn action_classifier_matches_pytorch() {
    use motion::core::model::ActionClassifier;
    let classifier = ActionClassifier::load(fixture("action_classifier.safetensors")).unwrap();
    let expected = WeightStore::open(fixture("action_classifier.expected.safetensors")).unwrap();
    let (shape, windows) = get(&expected, "windows");
    let windows = ndarray::Array3::from_shape_vec((shape[0], shape[1], shape[2]), windows).unwrap();
    let logits = classifier.logits(windows.view()).unwrap();
    assert_close(
        "logits",
        logits.as_slice().unwrap(),
        &get(&expected, "logits").1,
    );
    // Same windows as f64 frames, one at a time (chunking must not change a window's result).
    let probabilities: Vec<f32> = (0..shape[0])
        .flat_map(|w| {
            let one = windows.slice(ndarray::s![w..w + 1, .., ..]).mapv(f64::from);
            classifier
                .probabilities(one.view())
                .unwrap()
                .iter()
                .map(|&p| p as f32)
                .collect::<Vec<_>>()
        })
        .collect();
    assert_close(
        "probabilities",
        &probabilities,
        &get(&expected, "probabilities").1,
    );
    assert_eq!(classifier.config().layers, 2);
    assert_eq!(classifier.config().derivative_order, 1);
    assert!(classifier.config().center);
}

#[test]
fn a_classifier_file_is_not_a_predictor_and_vice_versa() {
    use motion::core::model::ActionClassifier;
    let msg = MotionModel::load(fixture("action_classifier.safetensors"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("action-classifier") && msg.contains("action_classifier.safetensors"),
        "{msg}"
    );
    let msg = ActionClassifier::load(fixture("vgru_d.safetensors"))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("vgru_d.safetensors"), "{msg}");
    let (_dir, path) = edited("action_classifier.safetensors", |(t, _)| {
        t.retain(|(n, _, _)| n != "rnn.1.bias_hh")
    });
    let msg = ActionClassifier::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("rnn.1.bias_hh") && msg.contains("edited.safetensors"),
        "{msg}"
    );
}

#[test]
fn a_classifier_fits_predictors_with_its_frames_and_actions() {
    use motion::core::model::ActionClassifier;
    let classifier = ActionClassifier::load(fixture("action_classifier.safetensors")).unwrap();
    let vgru = MotionModel::load(fixture("vgru_d.safetensors")).unwrap();
    assert_eq!(classifier.fits(vgru.config()), Ok(()));
    // GRU-d fixtures are not action-conditioned.
    let grud = MotionModel::load(fixture("gru_d.safetensors")).unwrap();
    let problem = classifier.fits(grud.config()).unwrap_err();
    assert!(problem.contains("no action"), "{problem}");
    let mut faster = vgru.config().clone();
    faster.fps = 50.0;
    assert!(classifier.fits(&faster).unwrap_err().contains("50 Hz"));
}

// ---- intention model: bad tensors and configs ------------------------------------------------------

fn edit_tensor(parts: &mut Parts, name: &str, edit: impl FnOnce(&mut Vec<usize>, &mut Vec<f32>)) {
    let entry = parts.0.iter_mut().find(|(n, _, _)| n == name).unwrap();
    edit(&mut entry.1, &mut entry.2);
}

#[test]
fn intention_merge_table_outside_the_intentions_is_named() {
    for bad in [4.0f32, -1.0, 1.5] {
        let (_dir, path) = edited("intention.safetensors", |parts| {
            edit_tensor(parts, "labels.merge", |_, v| v[2] = bad)
        });
        let (err, msg) = load_error(&path);
        assert!(matches!(err, WeightsError::InvalidTensor { .. }), "{msg}");
        assert!(
            msg.contains("labels.merge")
                && msg.contains("cluster 2")
                && msg.contains("0..4")
                && msg.contains("edited.safetensors"),
            "{msg}"
        );
    }
}

#[test]
fn intention_wrong_shapes_and_missing_tensors_are_named() {
    for name in [
        "intent_conv.weight",
        "labels.centroids",
        "labels.merge",
        "label_encoder.weight_ih",
        "label_out.weight",
        "pose_encoder.weight_hh",
        "rnn.0.weight_ih",
    ] {
        let (_dir, path) = edited("intention.safetensors", |parts| {
            edit_tensor(parts, name, |shape, values| {
                // One row (or value) fewer.
                let row: usize = shape[1..].iter().product();
                shape[0] -= 1;
                values.truncate(values.len() - row);
            })
        });
        let (err, msg) = load_error(&path);
        assert!(
            matches!(err, WeightsError::WrongShape { .. }),
            "{name}: {msg}"
        );
        assert!(
            msg.contains(name) && msg.contains("edited.safetensors"),
            "{msg}"
        );
    }
    let (_dir, path) = edited("intention.safetensors", |(t, _)| {
        t.retain(|(n, _, _)| n != "label_decoder.bias_hh")
    });
    let (err, msg) = load_error(&path);
    assert!(matches!(err, WeightsError::MissingTensor { .. }), "{msg}");
    assert!(msg.contains("label_decoder.bias_hh"), "{msg}");
}

#[test]
fn intention_bad_configs_are_refused() {
    let cases: [(&str, &str, serde_json::Value); 6] = [
        (
            "noise_dims",
            "0 < noise_dims < hidden",
            serde_json::json!(24),
        ),
        (
            "noise_dims",
            "0 < noise_dims < hidden",
            serde_json::json!(0),
        ),
        ("lookahead", "lookahead >= 1", serde_json::json!(0)),
        (
            "intentions",
            "missing field `intentions`",
            serde_json::Value::Null,
        ),
        ("residual", "residual", serde_json::json!(false)),
        ("derivative_order", "derivative_order", serde_json::json!(3)),
    ];
    for (field, needle, value) in cases {
        let (_dir, path) = edited("intention.safetensors", |(_, m)| {
            let mut config: serde_json::Value = serde_json::from_str(&m["config"]).unwrap();
            if value.is_null() {
                config.as_object_mut().unwrap().remove(field);
            } else {
                config[field] = value.clone();
            }
            m.insert("config".into(), config.to_string());
        });
        let (err, msg) = load_error(&path);
        assert!(
            matches!(err, WeightsError::BadConfig { .. }),
            "{field}: {msg}"
        );
        assert!(msg.contains(needle), "{field}: {msg}");
    }
}

#[test]
fn intention_labels_ties_go_to_the_lowest_cluster() {
    let (_dir, path) = edited("intention.safetensors", |parts| {
        edit_tensor(parts, "labels.merge", |_, v| {
            v.copy_from_slice(&[0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0])
        });
        edit_tensor(parts, "labels.centroids", |shape, v| {
            let o = shape[1];
            let (first, rest) = v.split_at_mut(o);
            rest[..o].copy_from_slice(first); // cluster 1 = cluster 0
            let (head, tail) = v.split_at_mut(4 * o);
            tail[..o].copy_from_slice(&head[2 * o..3 * o]); // cluster 4 = cluster 2
        });
    });
    let model = MotionModel::load(&path).unwrap();
    let Some(net) = model.network().downcast_ref::<Intention>() else {
        panic!("not an intention model")
    };
    let store = WeightStore::open(&path).unwrap();
    let (shape, centroids) = store.tensor_any_shape("labels.centroids").unwrap();
    let o = shape[1];
    let at = |k: usize| &centroids[k * o..(k + 1) * o];
    assert_eq!(net.label(at(0)), 0, "cluster 0, not its twin 1");
    assert_eq!(net.label(at(1)), 0);
    assert_eq!(net.label(at(2)), 2, "cluster 2, not its twin 4");
    assert_eq!(net.label(at(3)), 3);
    assert_eq!(net.label(at(6)), 2);
}
