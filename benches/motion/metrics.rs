//! The metrics on protocol-sized inputs: NPSS (both variants) and the Euler error of 8 x 100 x 99
//! sequences, APD of 8 forecasts x 50 samples x 100 frames x 32 joints, and NDMS with the three
//! exact nearest-neighbour methods: a synthetic database of 20,000 motion words (the size of all S5
//! words of a few actions) queried by 100 words, and, when MOTION_DATA_DIR holds H3.6M, the S5
//! walking words queried by the 8 zero-velocity forecasts.
//!
//! Ghosh et al. 2017's action-classifier protocol on one action of a 12 s `eval` (40 x 300 frames).
//!
//! MPJPE of one action of the 256-window protocol (256 windows x 25 frames): from exp-map frames
//! (forward kinematics in the pelvis frame, then the error) and from positions; the multi-sample
//! metrics of 64 windows x 50 samples x 50 frames x 48 numbers. `benches/compare/compare_mpjpe.py`
//! times the same MPJPE against numpy.
//!
//! Run: `cargo bench --bench motion -- metrics`
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{BenchmarkId, Criterion, Throughput};
use motion::core::kinematics::expmap_positions;
use motion::core::protocol::{
    actions_with_windows, dataset_dir, expmap_batch_to_euler_protocol, load_action_windows,
    sequence_file, LONG_TERM_HORIZON, TEST_SUBJECT,
};
use motion::core::{formats::h36m_text, RootEncoding, Skeleton};
use motion::metrics::baselines::zero_velocity;
use motion::metrics::ndms::index::NearestIndex;
use motion::metrics::ndms::word::append_all_words;
use motion::metrics::{
    apd_batch, euler_error, NdmsConfig, NdmsDatabase, NnMethod, Npss, SpectrumPower,
};
use ndarray::{Array3, ArrayView3, Axis};

/// Deterministic pseudo-random numbers in [-1, 1) (splitmix64).
fn noise(i: u64) -> f64 {
    let mut z = i
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(0x2545_F491_4F6C_DD1D);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Sequences of `dims` smooth signals (sums of two sinusoids with per-sequence phases).
fn smooth(sequences: usize, frames: usize, dims: usize, salt: u64) -> Array3<f64> {
    Array3::from_shape_fn((sequences, frames, dims), |(i, t, d)| {
        let key = salt * 1_000_003 + (i * dims + d) as u64;
        let t = t as f64;
        0.5 * (0.13 * t * (1.0 + noise(key)) + 3.0 * noise(key + 7)).sin()
            + 0.2 * (0.41 * t + 3.0 * noise(key + 11)).sin()
    })
}

/// 32-joint positions (mm) of a synthetic walk-like motion: every joint oscillates around its
/// rest place while the body moves forward.
fn positions(frames: usize, salt: u64) -> Array3<f64> {
    Array3::from_shape_fn((frames, 32, 3), |(t, j, c)| {
        let key = salt * 997 + (j * 3 + c) as u64;
        let t = t as f64;
        let rest = 400.0 * noise(key + 101);
        let swing = 120.0 * (0.25 * t * (1.0 + 0.3 * noise(key)) + 6.0 * noise(key + 5)).sin();
        let forward = if c == 2 { 25.0 * t } else { 0.0 };
        rest + swing + forward
    })
}

fn bench_npss_and_euler(c: &mut Criterion) {
    let gt = smooth(8, 100, 99, 1);
    let pred = smooth(8, 100, 99, 2);
    let mut group = c.benchmark_group("metrics/sequences_8x100x99");
    let mut npss = Npss::new();
    group.bench_function("npss", |b| {
        b.iter(|| {
            npss.score(
                black_box(gt.view()),
                black_box(pred.view()),
                SpectrumPower::Modulus,
            )
            .unwrap()
        })
    });
    group.bench_function("npss_reference", |b| {
        b.iter(|| {
            npss.score(
                black_box(gt.view()),
                black_box(pred.view()),
                SpectrumPower::RealPart,
            )
            .unwrap()
        })
    });
    group.bench_function("euler_error", |b| {
        b.iter(|| euler_error(black_box(gt.view()), black_box(pred.view())).unwrap())
    });
    group.bench_function("expmap_to_euler_protocol", |b| {
        b.iter(|| expmap_batch_to_euler_protocol(black_box(gt.view())))
    });
    group.finish();
}

fn bench_apd(c: &mut Criterion) {
    let samples = smooth(8, 50, 100 * 32 * 3, 3);
    let mut group = c.benchmark_group("metrics/apd");
    group.throughput(Throughput::Elements(8));
    group.bench_function("8x50_samples_100x32x3", |b| {
        b.iter(|| apd_batch(black_box(samples.view())).unwrap())
    });
    group.finish();
}

fn bench_mpjpe_and_sample_sets(c: &mut Criterion) {
    use motion::metrics::mpjpe::{score_mpjpe, MpjpeInput};
    use motion::metrics::multimodal::{score_sample_sets, SampleSets};
    use motion::metrics::JointMean;
    let gt = smooth(256, 25, 99, 5);
    let pred = smooth(256, 25, 99, 6);
    let mut group = c.benchmark_group("metrics/mpjpe_256x25");
    group.throughput(Throughput::Elements(256));
    group.bench_function("expmap", |b| {
        b.iter(|| {
            score_mpjpe(
                black_box(pred.view().into_dyn()),
                black_box(gt.view().into_dyn()),
                MpjpeInput::Expmap,
                JointMean::All32,
            )
            .unwrap()
        })
    });
    let positions = smooth(256, 25, 96, 7);
    let other = smooth(256, 25, 96, 8);
    group.bench_function("positions", |b| {
        b.iter(|| {
            score_mpjpe(
                black_box(other.view().into_dyn()),
                black_box(positions.view().into_dyn()),
                MpjpeInput::Positions,
                JointMean::All32,
            )
            .unwrap()
        })
    });
    group.finish();
    let samples = smooth(64 * 50, 50, 48, 9)
        .into_shape_with_order((64, 50, 50, 48))
        .unwrap();
    let truth = smooth(64, 50, 48, 10);
    let last = truth.index_axis(Axis(1), 0).to_owned();
    let mut group = c.benchmark_group("metrics/sample_sets");
    group.throughput(Throughput::Elements(64));
    group.bench_function("64x50_samples_50x48", |b| {
        b.iter(|| {
            score_sample_sets(SampleSets {
                samples: black_box(samples.view()),
                truth: truth.view(),
                last_observed: last.view(),
                threshold: 0.5,
            })
            .unwrap()
        })
    });
    group.finish();
}

/// Builds and queries both exact indexes over `database` (sequences of positions), with
/// `queries` (forecasts of positions, scored without seed).
fn bench_ndms_pair(
    c: &mut Criterion,
    name: &str,
    database: &[ArrayView3<'_, f64>],
    queries: &[ArrayView3<'_, f64>],
) {
    // The word frame `motion-cli score` uses for FK positions of H3.6M exp-maps.
    let config = NdmsConfig::h36m_body_frame();
    let mut words = Vec::new();
    for s in database {
        append_all_words(*s, &config, &mut words);
    }
    let word_count = words.len() / config.word_len();
    let mut query_words = Vec::new();
    for q in queries {
        append_all_words(*q, &config, &mut query_words);
    }
    let query_count = query_words.len() / config.word_len();
    let mut group = c.benchmark_group(format!("metrics/ndms_{name}_{word_count}_words"));
    group.sample_size(10);
    let build =
        |method| NearestIndex::build_frames(method, words.clone(), config.word_len(), config.kappa);
    for (label, method) in [
        ("brute_force", NnMethod::BruteForce),
        ("pca_kd_tree", NnMethod::PcaKdTree),
        ("pose_bound", NnMethod::PoseBound),
    ] {
        group.throughput(Throughput::Elements(1));
        group.bench_function(BenchmarkId::new("build", label), |b| {
            b.iter(|| build(black_box(method)))
        });
        let index = build(method);
        group.throughput(Throughput::Elements(query_count as u64));
        group.bench_function(
            BenchmarkId::new(format!("{query_count}_queries"), label),
            |b| b.iter(|| index.nearest_batch(black_box(&query_words))),
        );
        let db = NdmsDatabase::from_sequences(config.clone(), database, method).unwrap();
        group.bench_function(BenchmarkId::new("score_forecasts", label), |b| {
            b.iter(|| db.score_forecasts(black_box(queries), None).unwrap())
        });
    }
    group.finish();
}

fn bench_ndms_synthetic(c: &mut Criterion) {
    // 10 sequences x 2007 frames -> 20,000 words of κ = 8; one 107-frame forecast -> 100 words.
    let database: Vec<Array3<f64>> = (0..10).map(|s| positions(2007, s)).collect();
    let views: Vec<_> = database.iter().map(|d| d.view()).collect();
    let forecast = positions(107, 99);
    bench_ndms_pair(c, "synthetic", &views, &[forecast.view()]);
}

fn bench_ndms_h36m(c: &mut Criterion) {
    let root = std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let dataset = dataset_dir(&root);
    let skeleton = Skeleton::h36m();
    let fk = |frames: ndarray::ArrayView2<'_, f64>| {
        expmap_positions(&skeleton, frames, RootEncoding::Deltas, 2).unwrap()
    };
    // Every S5 sequence with test windows, at 25 Hz, as positions.
    let mut walking = Vec::new();
    let mut all = Vec::new();
    for action in actions_with_windows() {
        for sub in [1, 2] {
            let path = sequence_file(&dataset, TEST_SUBJECT, action, sub);
            let Ok(frames) = h36m_text::read_expmap_text(&path) else {
                eprintln!(
                    "SKIPPED: NDMS bench on S5: cannot read {} (set MOTION_DATA_DIR)",
                    path.display()
                );
                return;
            };
            let positions = fk(h36m_text::downsample_protocol(frames.view()).view());
            if action == "walking" {
                walking.push(positions.clone());
            }
            all.push(positions);
        }
    }
    // Queries: the 8 zero-velocity walking forecasts with the seam (107 frames -> 100 words each).
    let windows = load_action_windows(&dataset, "walking", LONG_TERM_HORIZON).unwrap();
    let forecasts: Vec<Array3<f64>> = windows
        .iter()
        .map(|w| {
            let forecast = zero_velocity(w.seed.view(), LONG_TERM_HORIZON);
            let joined = ndarray::concatenate(Axis(0), &[w.seed.view(), forecast.view()]).unwrap();
            fk(joined.view()).slice_move(ndarray::s![w.seed.nrows() - 7.., .., ..])
        })
        .collect();
    let queries: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
    let walking: Vec<_> = walking.iter().map(|d| d.view()).collect();
    bench_ndms_pair(c, "s5_walking", &walking, &queries);
    let all: Vec<_> = all.iter().map(|d| d.view()).collect();
    bench_ndms_pair(c, "s5_all_actions", &all, &queries);
}

/// Ghosh et al. 2017's classifier protocol on one action of `eval --horizon 300 --samples 5`: 40
/// predictions of 300 frames after 50-frame seeds (12 windows each), with the built-in-size
/// classifier when `weights/action_classifier.safetensors` exists (else the small fixture). Compare
/// with `motion-cli eval --actions all --horizon 300 --samples 5 [--no-classifier]` times.
fn bench_classifier_protocol(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let shipped = root.join("weights/action_classifier.safetensors");
    let path = if shipped.is_file() {
        shipped
    } else {
        root.join("tests/fixtures/parity/action_classifier.safetensors")
    };
    let classifier = motion::core::model::ActionClassifier::load(&path).expect("classifier");
    let seeds = smooth(40, 50, 99, 3).mapv(|v| 0.3 * v);
    let preds = smooth(40, 300, 99, 4).mapv(|v| 0.3 * v);
    let mut group = c.benchmark_group("metrics/classifier_protocol");
    group.sample_size(10);
    group.throughput(Throughput::Elements(40 * 12));
    group.bench_function("40x300_frames", |b| {
        b.iter(|| {
            motion::metrics::classifier_protocol(
                &classifier,
                Some(seeds.view()),
                black_box(preds.view()),
                "walking",
            )
            .unwrap()
        })
    });
    group.finish();
}

/// Registers this module's benchmarks.
pub fn benches(c: &mut Criterion) {
    bench_classifier_protocol(c);
    bench_npss_and_euler(c);
    bench_apd(c);
    bench_mpjpe_and_sample_sets(c);
    bench_ndms_synthetic(c);
    bench_ndms_h36m(c);
}
