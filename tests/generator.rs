//! Closed-loop generation: determinism, noise, batch/single agreement, streaming past the plan,
//! typed errors for bad input, no heap allocation per step, parameter counts at paper size.
use motion::core::model::{
    generate_samples, intention::IntentionConfig, ArchConfig, Architecture, BatchGenerator,
    DaeLstmFields, GenerateError, Generator, ModelConfig, MotionModel, Noise, WeightStore,
};
use ndarray::{Array2, Array3, ArrayView2};
use std::path::PathBuf;
use std::sync::Arc;

mod common;
use common::allocations;

// ---- helpers -------------------------------------------------------------------------------------

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/parity")
        .join(name)
}

fn model(name: &str) -> Arc<MotionModel> {
    if name == "dae_lstm_actions" {
        // The parity fixture is unconditioned: a small random action-conditioned DAE-LSTM.
        let mut config = ModelConfig::paper(Architecture::DaeLstm);
        (config.hidden, config.layers) = (16, 2);
        config.arch = ArchConfig::DaeLstm(DaeLstmFields {
            dae_hidden: 24,
            dae_layers: 3,
        });
        config.seed_frames = 10;
        return Arc::new(MotionModel::random(&config, 11).unwrap());
    }
    Arc::new(MotionModel::load(fixture(&format!("{name}.safetensors"))).unwrap())
}

/// The fixture's seed frames `[10, 99]`.
fn seed() -> Array2<f32> {
    let store = WeightStore::open(fixture("vgru_d.expected.safetensors")).unwrap();
    let (shape, values) = store.tensor_any_shape("seed").unwrap();
    Array2::from_shape_vec((shape[0], shape[1]), values).unwrap()
}

fn run(
    model: &Arc<MotionModel>,
    seed: ArrayView2<f32>,
    action: Option<&str>,
    noise: Noise,
    n: usize,
) -> Array2<f32> {
    let mut g = Generator::new(Arc::clone(model));
    g.start(seed, action, noise).unwrap();
    g.generate(n).unwrap()
}

// ---- determinism and noise -------------------------------------------------------------------------

#[test]
fn same_rng_seed_gives_bit_identical_frames_and_another_seed_differs() {
    let m = model("vgru_d");
    let s = seed();
    // 80 frames > plan horizon 30: crosses two re-planned blocks.
    let a = run(&m, s.view(), Some("walking"), Noise::Seed(7), 80);
    let b = run(&m, s.view(), Some("walking"), Noise::Seed(7), 80);
    assert_eq!(a, b, "same seed must give bit-identical frames");
    let c = run(&m, s.view(), Some("walking"), Noise::Seed(8), 80);
    assert_ne!(a, c, "a different noise seed must give a different future");
    assert!(a.iter().all(|v| v.is_finite()));
    let d = run(&m, s.view(), Some("eating"), Noise::Seed(7), 80);
    assert_ne!(a, d, "the action conditions the plan");
}

#[test]
fn gru_d_ignores_noise_and_is_deterministic() {
    let m = model("gru_d");
    let s = seed();
    let a = run(&m, s.view(), None, Noise::Seed(1), 40);
    let b = run(&m, s.view(), None, Noise::Seed(2), 40);
    assert_eq!(a, b);
}

#[test]
fn restart_reproduces_and_f64_seeds_match_f32() {
    let m = model("vgru_d_residual");
    let s = seed();
    let mut g = Generator::new(Arc::clone(&m));
    g.start(s.view(), Some("smoking"), Noise::Seed(3)).unwrap();
    let first = g.generate(45).unwrap();
    let s64 = s.mapv(f64::from);
    g.start(s64.view(), Some("smoking"), Noise::Seed(3))
        .unwrap();
    let second = g.generate(45).unwrap();
    assert_eq!(
        first, second,
        "restarting resets all state; f64 seeds convert exactly"
    );
}

#[test]
fn explicit_noise_is_reused_by_every_plan_block() {
    let m = model("vgru_d");
    let s = seed();
    let eps = vec![0.3f32; 8];
    let a = run(&m, s.view(), Some("walking"), Noise::Explicit(&eps), 100);
    let b = run(&m, s.view(), Some("walking"), Noise::Explicit(&eps), 100);
    assert_eq!(a, b);
    assert!(a.iter().all(|v| v.is_finite()));
}

#[test]
fn dropped_dims_are_the_mean() {
    let m = model("gru_d");
    let used = &m.config().dims_used;
    let mean = m.normalization().mean().to_vec();
    let frames = run(&m, seed().view(), None, Noise::Seed(0), 5);
    for row in frames.rows() {
        for (d, v) in row.iter().enumerate() {
            if !used.contains(&d) {
                assert_eq!(*v, mean[d]);
            }
        }
    }
}

// ---- batch API -----------------------------------------------------------------------------------

#[test]
fn batch_rows_match_single_generators() {
    for name in ["vgru_d", "gru_d_residual", "dae_lstm", "intention"] {
        let m = model(name);
        let s = seed();
        let rows = 3;
        let mut seeds = Array3::<f32>::zeros((rows, s.nrows(), s.ncols()));
        for b in 0..rows {
            // Different seed motion per character.
            seeds
                .slice_mut(ndarray::s![b, .., ..])
                .assign(&s.mapv(|v| v * (1.0 + 0.05 * b as f32)));
        }
        let actions = ["walking", "eating", "walking"];
        let noise = [Noise::Seed(1), Noise::Seed(2), Noise::Seed(3)];
        let mut batch = BatchGenerator::new(Arc::clone(&m), rows);
        batch.start(seeds.view(), &actions, &noise).unwrap();
        let mut got = Array3::<f32>::zeros((rows, 70, s.ncols()));
        for k in 0..70 {
            let frames = batch.step().unwrap();
            got.slice_mut(ndarray::s![.., k, ..]).assign(&frames);
        }
        for b in 0..rows {
            let single = run(
                &m,
                seeds.slice(ndarray::s![b, .., ..]),
                Some(actions[b]),
                noise[b],
                70,
            );
            let diff = (&single - &got.slice(ndarray::s![b, .., ..]))
                .iter()
                .fold(0.0f32, |a, v| a.max(v.abs()));
            assert!(diff < 1e-4, "{name} row {b}: max diff {diff}");
        }
    }
}

#[test]
fn batch_errors() {
    let m = model("vgru_d");
    let s = seed();
    let seeds = Array3::<f32>::zeros((2, s.nrows(), s.ncols()));
    let mut g = BatchGenerator::new(Arc::clone(&m), 2);
    let err = g
        .start(seeds.view(), &["walking"], &[Noise::Seed(1)])
        .unwrap_err();
    assert!(matches!(
        err,
        GenerateError::WrongBatch {
            what: "noise sources",
            expected: 2,
            got: 1
        }
    ));
    let err = g
        .start(
            seeds.view(),
            &["walking", "eating", "posing"],
            &[Noise::Seed(1), Noise::Seed(2)],
        )
        .unwrap_err();
    assert!(matches!(
        err,
        GenerateError::WrongBatch {
            what: "actions",
            ..
        }
    ));
    // One action for all rows is fine.
    g.start(
        seeds.view(),
        &["walking"],
        &[Noise::Seed(1), Noise::Seed(2)],
    )
    .unwrap();
    assert_eq!(g.step().unwrap().dim(), (2, 99));
}

// ---- the intention model's noise z -------------------------------------------------------------------

#[test]
fn intention_z_per_row_seeded_or_explicit() {
    let m = model("intention");
    let s = seed();
    let n = IntentionConfig::of(m.config()).noise_dims;
    // Seeded z: reproducible, another seed another future.
    let a = run(&m, s.view(), None, Noise::Seed(7), 40);
    assert_eq!(a, run(&m, s.view(), None, Noise::Seed(7), 40));
    assert_ne!(a, run(&m, s.view(), None, Noise::Seed(8), 40));
    assert!(a.iter().all(|v| v.is_finite()));
    // Batch rows, each with its own z (seeded and explicit), equal single-row runs; rows with
    // different z differ.
    let z = vec![0.5f32; n];
    let noise = [
        Noise::Seed(1),
        Noise::Explicit(&z),
        Noise::Seed(2),
        Noise::Seed(1),
    ];
    let rows = noise.len();
    let seeds = Array3::from_shape_fn((rows, s.nrows(), s.ncols()), |(_, t, d)| s[[t, d]]);
    // Two shards of two rows: each shard's rows get their own noise.
    let mut batch = BatchGenerator::with_shards(Arc::clone(&m), rows, 2);
    assert_eq!(batch.shards(), 2);
    batch.start(seeds.view(), &[], &noise).unwrap();
    let mut got = Array3::<f32>::zeros((rows, 40, s.ncols()));
    for k in 0..40 {
        got.slice_mut(ndarray::s![.., k, ..])
            .assign(&batch.step().unwrap());
    }
    for (b, &nz) in noise.iter().enumerate() {
        let single = run(&m, s.view(), None, nz, 40);
        let diff = (&single - &got.slice(ndarray::s![b, .., ..]))
            .iter()
            .fold(0.0f32, |a, v| a.max(v.abs()));
        assert!(diff < 1e-4, "row {b}: max diff {diff}");
    }
    let row = |b: usize| got.slice(ndarray::s![b, .., ..]).to_owned();
    assert_ne!(row(0), row(1));
    assert_ne!(row(0), row(2));
    assert_eq!(
        row(0),
        row(3),
        "the same z in the same batch gives the same frames"
    );
    // generate_samples (CLI `predict --samples`): sample i draws z from rng_seed + i.
    let s64 = s.mapv(f64::from);
    let samples = generate_samples(&m, s64.view(), None, 20, 3, 41).unwrap();
    for i in 0..3 {
        let single = run(&m, s.view(), None, Noise::Seed(41 + i as u64), 20).mapv(f64::from);
        let diff = (&single - &samples.slice(ndarray::s![i, .., ..]))
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(diff < 1e-4, "sample {i}: max diff {diff}");
    }
    assert_ne!(
        samples.slice(ndarray::s![0, .., ..]),
        samples.slice(ndarray::s![1, .., ..])
    );
    // An explicit z of the wrong length, no action to change.
    let short = vec![0.0f32; n - 1];
    let mut g = Generator::new(Arc::clone(&m));
    assert_eq!(
        g.start(s.view(), None, Noise::Explicit(&short))
            .unwrap_err(),
        GenerateError::WrongNoiseLength {
            expected: n,
            got: n - 1
        }
    );
    g.start(s.view(), None, Noise::Seed(0)).unwrap();
    assert_eq!(
        g.set_action("walking", 0),
        Err(GenerateError::NotConditioned)
    );
}

/// The intention fixture with `noise_scale` set in its config, loaded (or the loading error).
fn intention_with_noise_scale(scale: f32) -> Result<Arc<MotionModel>, String> {
    let store = WeightStore::open(fixture("intention.safetensors")).unwrap();
    let tensors: Vec<(String, Vec<usize>, Vec<f32>)> = store
        .names()
        .map(|name| {
            let (shape, values) = store.tensor_any_shape(name).unwrap();
            (name.to_string(), shape, values)
        })
        .collect();
    let mut metadata = store.metadata_map().clone();
    let mut config: serde_json::Value = serde_json::from_str(&metadata["config"]).unwrap();
    config["noise_scale"] = serde_json::json!(scale);
    metadata.insert("config".into(), config.to_string());
    let bytes = motion::core::weights::serialize_f32(
        tensors
            .iter()
            .map(|(n, shape, v)| (n.as_str(), shape.as_slice(), v.as_slice())),
        &metadata,
    );
    WeightStore::from_bytes(&bytes, "scaled.safetensors")
        .and_then(|store| MotionModel::from_store(&store))
        .map(Arc::new)
        .map_err(|e| e.to_string())
}

#[test]
fn intention_noise_scale_scales_drawn_z_only() {
    let base = model("intention");
    let s = seed();
    let n = IntentionConfig::of(base.config()).noise_dims;
    // The file without the key and with 1 draw the same z.
    let one = intention_with_noise_scale(1.0).unwrap();
    assert_eq!(
        run(&base, s.view(), None, Noise::Seed(3), 20),
        run(&one, s.view(), None, Noise::Seed(3), 20)
    );
    // Scale 0: every seeded sample is the z = 0 future; an explicit z is used as given.
    let zero = intention_with_noise_scale(0.0).unwrap();
    let at_zero = run(&base, s.view(), None, Noise::Explicit(&vec![0.0; n]), 20);
    assert_eq!(run(&zero, s.view(), None, Noise::Seed(3), 20), at_zero);
    assert_eq!(run(&zero, s.view(), None, Noise::Seed(4), 20), at_zero);
    let z = vec![0.7f32; n];
    assert_eq!(
        run(&zero, s.view(), None, Noise::Explicit(&z), 20),
        run(&base, s.view(), None, Noise::Explicit(&z), 20)
    );
    // Scale 0.5: between the two, and different from both.
    let half = intention_with_noise_scale(0.5).unwrap();
    let (full, mid) = (
        run(&base, s.view(), None, Noise::Seed(3), 20),
        run(&half, s.view(), None, Noise::Seed(3), 20),
    );
    assert_ne!(mid, full);
    assert_ne!(mid, at_zero);
    // Out of range: refused when the file is read, naming the key.
    for bad in [-0.5f32, 1e6] {
        let err = intention_with_noise_scale(bad).unwrap_err();
        assert!(err.contains("noise_scale"), "{bad}: {err}");
    }
}

#[test]
fn intention_works_with_a_single_seed_frame_and_random_paper_size_weights() {
    // One seed frame: the last seed frame is also the first; paper sizes (gamma 10: 8 frames
    // forecast before the first step).
    let m = model("intention");
    let one = seed().slice(ndarray::s![9..10, ..]).to_owned();
    let frames = run(&m, one.view(), None, Noise::Seed(3), 5);
    assert!(frames.iter().all(|v| v.is_finite()));
    let paper =
        Arc::new(MotionModel::random(&ModelConfig::paper(Architecture::Intention), 2).unwrap());
    let seed = Array2::<f32>::zeros((50, 99));
    let frames = run(&paper, seed.view(), None, Noise::Seed(1), 30);
    assert!(frames.iter().all(|v| v.is_finite()));
    // PyTorch's count for make_config("intention", ...): GRUs (label encoder 54 + 8 -> 128,
    // label decoder 8 -> 128, pose encoder 54 -> 224, layers 54 + 32 + 32 -> 256, 256 -> 256
    // twice), label_out 128 -> 8, intent_conv 32 x 8 x 10, decoder 256 -> 54.
    let gru = |i: usize, h: usize| 3 * h * (i + h) + 6 * h;
    let expected = gru(62, 128)
        + gru(8, 128)
        + gru(54, 224)
        + gru(118, 256)
        + 2 * gru(256, 256)
        + (8 * 128 + 8)
        + (32 * 8 * 10 + 32)
        + (54 * 256 + 54);
    assert_eq!(paper.parameter_count(), expected);
    assert_eq!(paper.parameter_count(), 1_410_654); // sum(p.numel()) of IntentionModel
}

// ---- errors ----------------------------------------------------------------------------------------

#[test]
fn bad_input_gives_typed_errors() {
    let m = model("vgru_d");
    let mut g = Generator::new(Arc::clone(&m));
    assert_eq!(g.step().unwrap_err(), GenerateError::NotStarted);

    let empty = Array2::<f32>::zeros((0, 99));
    let err = g
        .start(empty.view(), Some("walking"), Noise::Seed(0))
        .unwrap_err();
    assert_eq!(err, GenerateError::TooFewSeedFrames { needed: 1, got: 0 });
    assert!(err.to_string().contains("at least 1"));

    let narrow = Array2::<f32>::zeros((5, 98));
    let err = g
        .start(narrow.view(), Some("walking"), Noise::Seed(0))
        .unwrap_err();
    assert_eq!(
        err,
        GenerateError::WrongWidth {
            expected: 99,
            got: 98
        }
    );

    let s = seed();
    let err = g
        .start(s.view(), Some("moonwalk"), Noise::Seed(0))
        .unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, GenerateError::UnknownAction { .. }));
    assert!(
        msg.contains("moonwalk") && msg.contains("walkingdog") && msg.contains("directions"),
        "{msg}"
    );

    let err = g.start(s.view(), None, Noise::Seed(0)).unwrap_err();
    assert!(matches!(err, GenerateError::MissingAction { .. }));

    let mut bad = s.clone();
    bad[[4, 17]] = f32::NAN;
    let err = g
        .start(bad.view(), Some("walking"), Noise::Seed(0))
        .unwrap_err();
    assert!(
        matches!(
            err,
            GenerateError::NonFiniteSeed {
                character: 0,
                frame: 4,
                dim: 17,
                ..
            }
        ),
        "{err}"
    );

    let eps = [0.0f32; 3];
    let err = g
        .start(s.view(), Some("walking"), Noise::Explicit(&eps))
        .unwrap_err();
    assert_eq!(
        err,
        GenerateError::WrongNoiseLength {
            expected: 8,
            got: 3
        }
    );

    assert_eq!(
        g.set_plan_horizon(0).unwrap_err(),
        GenerateError::ZeroHorizon
    );
    let mut out = vec![0.0f32; 10];
    g.start(s.view(), Some("walking"), Noise::Seed(0)).unwrap();
    assert!(matches!(
        g.step_into(&mut out),
        Err(GenerateError::WrongWidth { .. })
    ));
}

// ---- real-time properties --------------------------------------------------------------------------

#[test]
fn a_step_does_not_allocate() {
    for name in [
        "vgru_d",
        "gru_d",
        "dae_lstm",
        "dae_lstm_actions",
        "intention",
        "intention_lookahead1",
        "intention_lookahead2",
    ] {
        let m = model(name);
        let mut g = Generator::new(Arc::clone(&m));
        g.set_plan_horizon(20).unwrap();
        g.start(seed().view(), Some("walking"), Noise::Seed(5))
            .unwrap();
        let mut frame = vec![0.0f32; 99];
        let probe = allocations();
        std::hint::black_box(vec![0u8; 16]);
        assert!(allocations() > probe, "the counter sees allocations");
        let before = allocations();
        // 100 steps cross several re-planned blocks of 20, with action switches.
        for k in 0..100 {
            if (name == "vgru_d" || name == "dae_lstm_actions") && k % 17 == 5 {
                g.set_action(if k % 2 == 0 { "eating" } else { "walking" }, 4)
                    .unwrap();
            }
            g.step_into(&mut frame).unwrap();
        }
        assert_eq!(
            allocations() - before,
            0,
            "{name}: heap allocations during steps"
        );
    }
}

#[test]
fn weights_are_shareable_and_generators_movable() {
    fn send_sync<T: Send + Sync>() {}
    fn send<T: Send>() {}
    send_sync::<MotionModel>();
    send_sync::<Arc<MotionModel>>();
    send::<Generator>();
    send::<BatchGenerator>();
}

#[test]
fn parameter_counts_at_paper_size() {
    // Gopalakrishnan et al. 2019 Table 1 reports GRU-d 2,735,670 and VGRU-d 3,413,047 (TensorFlow 1 cells, whose
    // bias layout differs from PyTorch's two bias vectors); these are the PyTorch-layout counts.
    let grud = MotionModel::random(&ModelConfig::paper(Architecture::GruD), 1).unwrap();
    let (i, h, o) = (216, 512, 54);
    let gru = |inp: usize| 3 * h * inp + 3 * h * h + 6 * h;
    assert_eq!(grud.parameter_count(), gru(i) + gru(h) + o * h + o);
    assert_eq!(grud.parameter_count(), 2_724_918);
    let vgru = MotionModel::random(&ModelConfig::paper(Architecture::VgruD), 1).unwrap();
    let p = 512;
    let plan = 3 * p * 15 + 3 * p * p + 6 * p + 2 * p;
    let body = gru(i) + 3 * h * p;
    assert_eq!(vgru.parameter_count(), plan + body + o * h + o);
    assert_eq!(vgru.parameter_count(), 2_748_982);
    eprintln!(
        "parameters at paper size: GRU-d {} (paper 2,735,670), VGRU-d {} (paper 3,413,047)",
        grud.parameter_count(),
        vgru.parameter_count()
    );
}

// ---- shipped weights on real data -----------------------------------------------------------------

/// The shipped multi-action VGRU-d continues a real walking clip for 250 frames (10 s, past two
/// re-planned blocks) with finite angles of a plausible size. Skips visibly without the data.
#[test]
fn shipped_weights_continue_real_motion() {
    let weights =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("weights/vgru_d_multi.safetensors");
    if !weights.exists() {
        eprintln!(
            "SKIPPED: shipped_weights_continue_real_motion: {} not found",
            weights.display()
        );
        return;
    }
    let clip = common::data_root().join("h3.6m/dataset/S5/walking_1.txt.gz");
    if !clip.exists() {
        eprintln!(
            "SKIPPED: shipped_weights_continue_real_motion: {} not found (set MOTION_DATA_DIR)",
            clip.display()
        );
        return;
    }
    let frames = motion::core::formats::h36m_text::read_expmap_text(&clip).unwrap();
    let frames = motion::core::formats::h36m_text::downsample_protocol(frames.view());
    let model = Arc::new(MotionModel::load(&weights).unwrap());
    let seed_len = model.config().seed_frames;
    let mut g = Generator::new(Arc::clone(&model));
    let action = model
        .config()
        .actions
        .iter()
        .find(|a| *a == "walking")
        .cloned();
    g.start(
        frames.slice(ndarray::s![100..100 + seed_len, ..]),
        action.as_deref(),
        Noise::Seed(11),
    )
    .unwrap();
    let generated = g.generate(250).unwrap();
    let used = &model.config().dims_used;
    let worst = generated
        .rows()
        .into_iter()
        .flat_map(|r| used.iter().map(move |&d| r[d].abs()))
        .fold(0.0f32, f32::max);
    assert!(
        worst.is_finite() && worst < 50.0,
        "largest generated value {worst}"
    );
}

// ---- switching the action mid-stream ----------------------------------------------------------------

/// `n` frames of a generator that switches to `switch` (with `crossfade`) after `after` frames.
fn switched(name: &str, switch: Option<(&str, usize)>, after: usize, n: usize) -> Array2<f32> {
    let m = model(name);
    let mut g = Generator::new(Arc::clone(&m));
    g.set_plan_horizon(20).unwrap();
    g.start(seed().view(), Some("walking"), Noise::Seed(3))
        .unwrap();
    let mut out = g.generate(after).unwrap();
    if let Some((action, crossfade)) = switch {
        g.set_action(action, crossfade).unwrap();
    }
    let rest = g.generate(n - after).unwrap();
    out.append(ndarray::Axis(0), rest.view()).unwrap();
    out
}

fn first_difference(a: &Array2<f32>, b: &Array2<f32>) -> Option<usize> {
    (0..a.nrows()).find(|&t| a.row(t) != b.row(t))
}

#[test]
fn set_action_switches_without_reseeding() {
    for name in ["vgru_d", "dae_lstm_actions"] {
        let plain = switched(name, None, 5, 60);
        // The same action again changes nothing, bit for bit (VGRU-d re-plans the next block
        // from the same noise).
        assert_eq!(switched(name, Some(("walking", 0)), 5, 60), plain, "{name}");
        let eating = switched(name, Some(("eating", 0)), 5, 60);
        let first = first_difference(&plain, &eating).expect("the switch shows");
        match name {
            // Reads the one-hot every step: the very next frame.
            "dae_lstm_actions" => assert_eq!(first, 5),
            // Seed 10 frames, blocks of 20: frame k (0-based) comes from body step 9 + k; the
            // next block starts at body step 30 (frame 21), re-planned in time.
            _ => assert_eq!(first, 21, "{name}"),
        }
        // Late in a block (less than half left): the block after next.
        if name == "vgru_d" {
            let late = switched(name, Some(("eating", 0)), 15, 60);
            assert_eq!(first_difference(&plain, &late), Some(41));
        }
    }
    // A crossfade starts closer to the old action and ends on the new one's path.
    let fade = switched("dae_lstm_actions", Some(("eating", 8)), 5, 60);
    let eating = switched("dae_lstm_actions", Some(("eating", 0)), 5, 60);
    let plain = switched("dae_lstm_actions", None, 5, 60);
    let dist = |a: &Array2<f32>, b: &Array2<f32>, t: usize| -> f32 {
        a.row(t)
            .iter()
            .zip(b.row(t))
            .map(|(x, y)| (x - y).abs())
            .sum()
    };
    assert_eq!(first_difference(&plain, &fade), Some(5));
    assert!(dist(&fade, &plain, 5) < dist(&eating, &plain, 5));
}

#[test]
fn set_action_on_one_row_leaves_the_others_alone() {
    let m = model("vgru_d");
    let seeds = Array3::from_shape_fn((2, 10, 99), |(_, t, d)| seed()[[t, d]]);
    let run = |switch: bool| {
        let mut g = BatchGenerator::new(Arc::clone(&m), 2);
        g.set_plan_horizon(20).unwrap();
        g.start(
            seeds.view(),
            &["walking"],
            &[Noise::Seed(1), Noise::Seed(2)],
        )
        .unwrap();
        let mut rows = vec![Vec::new(), Vec::new()];
        for k in 0..50 {
            if switch && k == 3 {
                g.set_action(1, "eating", 0).unwrap();
            }
            let f = g.step().unwrap();
            for (r, row) in rows.iter_mut().enumerate() {
                row.extend(f.row(r).iter().copied());
            }
        }
        rows
    };
    let (a, b) = (run(false), run(true));
    assert_eq!(a[0], b[0], "row 0 untouched");
    assert_ne!(a[1], b[1], "row 1 switched");
}

#[test]
fn set_action_errors_are_typed() {
    let m = model("vgru_d");
    let mut g = Generator::new(Arc::clone(&m));
    assert_eq!(g.set_action("walking", 0), Err(GenerateError::NotStarted));
    g.start(seed().view(), Some("walking"), Noise::Seed(0))
        .unwrap();
    assert!(matches!(
        g.set_action("moonwalk", 0),
        Err(GenerateError::UnknownAction { .. })
    ));
    let mut b = BatchGenerator::new(Arc::clone(&m), 2);
    let seeds = Array3::from_shape_fn((2, 10, 99), |(_, t, d)| seed()[[t, d]]);
    b.start(
        seeds.view(),
        &["walking"],
        &[Noise::Seed(1), Noise::Seed(2)],
    )
    .unwrap();
    assert_eq!(
        b.set_action(2, "eating", 0),
        Err(GenerateError::NoSuchRow { row: 2, batch: 2 })
    );
    let mut grud = Generator::new(model("gru_d"));
    grud.start(seed().view(), None, Noise::Seed(0)).unwrap();
    assert_eq!(
        grud.set_action("walking", 0),
        Err(GenerateError::NotConditioned)
    );
}
