//! One closed-loop generation step for GRU-d 2x512 and VGRU-d 512 (random weights of the paper's
//! sizes: 99-dim frames, 54 used, derivative order 3, 15 actions) with f32 weights at batch 1, 8
//! and 256 and with f16 weights (the layout of an f16 file: kept half-size, widened in the
//! kernels) at batch 1 and 8. Throughput is reported per character: `Elements(batch)` steps/s.
//!
//! `nn/product`: one `[1536, 512]` product (the GRU's `U h` at paper size) through the row
//! kernels and through the GEMM at batches 1 to 64, f32 and f16 rows: where the row kernels stop
//! paying is `row_kernel_max_batch` in `nn/gemm.rs`.
//!
//! `nn/gates`: the element-wise half of a GRU step at batch 256 x 512 units (paper convention,
//! one thread): `nn::gates` (branch-free `exp`, vectorized) against the same formulas with the
//! scalar libm `exp`/`tanh` the cells used before.
//!
//! Run: `cargo bench --bench motion -- closed_loop_step` (or `-- nn/product`, `-- nn/gates`)
use criterion::{BenchmarkId, Criterion, Throughput};
use motion::core::model::random::random_weights_bytes;
use motion::core::model::{
    Architecture, BatchGenerator, ModelConfig, MotionModel, Noise, WeightStore,
};
use motion::core::nn::gemm::MatMul;
use motion::core::nn::PackedMatrix;
use ndarray::Array3;
use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

const SEED_FRAMES: usize = 10;
/// Plan horizon of the benchmark generators.
const PLAN_HORIZON: usize = 80;
/// Steps timed per seeded generator (within its plan).
const STEPS_PER_SEED: u64 = 70;

/// A generator for `batch` characters, seeded and already past its first step, whose plan covers
/// far more steps than the benchmark takes (so VGRU re-planning is not what is measured).
fn seeded(model: &Arc<MotionModel>, batch: usize) -> BatchGenerator {
    let mut generator = BatchGenerator::new(Arc::clone(model), batch);
    generator
        .set_plan_horizon(PLAN_HORIZON)
        .expect("horizon > 0");
    let seeds = Array3::from_shape_fn((batch, SEED_FRAMES, 99), |(b, t, d)| {
        0.1 * ((b * 7 + t * 3 + d) as f32 * 0.37).sin()
    });
    let noise: Vec<Noise> = (0..batch as u64).map(Noise::Seed).collect();
    generator
        .start(seeds.view(), &["walking"], &noise)
        .expect("valid seed");
    generator.step().expect("started");
    generator
}

/// A paper-size random model, its weights f32 or rounded to f16 (`f16 = true`).
fn paper_model(architecture: Architecture, f16: bool) -> Arc<MotionModel> {
    let bytes = random_weights_bytes(&ModelConfig::paper(architecture), 42);
    let store = WeightStore::from_bytes(&bytes, "<random seed 42>").expect("random weights parse");
    let store = if f16 {
        store.with_f16_parameters()
    } else {
        store
    };
    Arc::new(MotionModel::from_store(&store).expect("random weights load"))
}

/// Registers this module's benchmarks.
pub fn benches(c: &mut Criterion) {
    closed_loop_step(c);
    product(c);
    gates(c);
}

fn gates(c: &mut Criterion) {
    use motion::core::nn::activation::{sigmoid, tanh};
    use motion::core::nn::{gates, parallel};
    let (batch, hidden) = (256, 512);
    let g = 3 * hidden;
    let gi: Vec<f32> = (0..batch * g)
        .map(|i| ((i * 37 % 1000) as f32 - 500.0) / 120.0)
        .collect();
    let gh: Vec<f32> = (0..batch * g)
        .map(|i| ((i * 91 % 1000) as f32 - 500.0) / 150.0)
        .collect();
    let h0: Vec<f32> = (0..batch * hidden)
        .map(|i| ((i % 200) as f32 - 100.0) / 100.0)
        .collect();
    let mut group = c.benchmark_group("nn/gates");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .throughput(Throughput::Elements((batch * hidden) as u64));
    group.bench_function("vectorized", |b| {
        let (mut h, mut rh) = (h0.clone(), vec![0.0; batch * hidden]);
        b.iter(|| {
            parallel::serial(|| {
                gates::reset_times_hidden(&gi, &gh, &h, &mut rh, batch, hidden);
                gates::paper_state_update(&gi, &gh, &mut h, batch, hidden);
            });
            black_box(h[0])
        })
    });
    group.bench_function("scalar_libm", |b| {
        let (mut h, mut rh) = (h0.clone(), vec![0.0; batch * hidden]);
        b.iter(|| {
            for r in 0..batch {
                let (gi, gh) = (&gi[r * g..(r + 1) * g], &gh[r * g..(r + 1) * g]);
                let (h, rh) = (
                    &mut h[r * hidden..(r + 1) * hidden],
                    &mut rh[r * hidden..(r + 1) * hidden],
                );
                for j in 0..hidden {
                    rh[j] = sigmoid(gi[j] + gh[j]) * h[j];
                }
                for j in 0..hidden {
                    let z = sigmoid(gi[hidden + j] + gh[hidden + j]);
                    let n = tanh(gi[2 * hidden + j] + gh[2 * hidden + j]);
                    h[j] = (1.0 - z) * n + z * h[j];
                }
            }
            black_box(h[0])
        })
    });
    group.finish();
}

fn closed_loop_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("nn/closed_loop_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for (name, architecture) in [
        ("gru-d-2x512", Architecture::GruD),
        ("vgru-d-512", Architecture::VgruD),
    ] {
        for (dtype, batches) in [("", &[1usize, 8, 256][..]), ("-f16", &[1, 8][..])] {
            let model = paper_model(architecture, !dtype.is_empty());
            for &batch in batches {
                group.throughput(Throughput::Elements(batch as u64));
                group.bench_function(BenchmarkId::new(format!("{name}{dtype}"), batch), |b| {
                    // Only the steps are timed: seeding (and the VGRU plan it computes) happens
                    // outside, and each generator takes fewer steps than its plan covers, so
                    // re-planning is not measured either (amortized it adds one plan-GRU step
                    // per frame).
                    b.iter_custom(|iters| {
                        let mut total = Duration::ZERO;
                        let mut left = iters;
                        while left > 0 {
                            let mut generator = seeded(&model, batch);
                            let n = left.min(STEPS_PER_SEED);
                            let start = Instant::now();
                            for _ in 0..n {
                                black_box(generator.step().expect("started")[[0, 0]]);
                            }
                            total += start.elapsed();
                            left -= n;
                        }
                        total
                    });
                });
            }
        }
    }
    group.finish();
}

fn product(c: &mut Criterion) {
    let (outputs, inputs) = (1536, 512);
    let values: Vec<f32> = (0..outputs * inputs)
        .map(|k| ((k as f32) * 0.618).sin() * 0.04)
        .collect();
    let matrices = [
        (
            "f32",
            PackedMatrix::from_f32(values.clone(), outputs, inputs),
        ),
        ("f16", PackedMatrix::f16_from_f32(&values, outputs, inputs)),
    ];
    let mut group = c.benchmark_group("nn/product");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for batch in [1usize, 2, 4, 8, 16, 24, 32, 64] {
        let x: Vec<f32> = (0..batch * inputs)
            .map(|k| (k as f32 * 0.1).cos())
            .collect();
        let mut y = vec![0.0f32; batch * outputs];
        let mm = MatMul::dense(batch, inputs, outputs);
        group.throughput(Throughput::Elements((2 * batch * inputs * outputs) as u64));
        for (dtype, w) in &matrices {
            group.bench_function(BenchmarkId::new(format!("rows-{dtype}"), batch), |b| {
                b.iter(|| mm.run_rows(black_box(&x), w, &mut y, false))
            });
            group.bench_function(BenchmarkId::new(format!("gemm-{dtype}"), batch), |b| {
                b.iter(|| mm.run_gemm(black_box(&x), w, &mut y, false))
            });
        }
    }
    group.finish();
}
