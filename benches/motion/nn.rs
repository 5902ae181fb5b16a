//! One closed-loop generation step at batch 1 and batch 256 for GRU-d 2x512 and VGRU-d 512
//! (random weights of the paper's sizes: 99-dim frames, 54 used, derivative order 3, 15 actions).
//! Throughput is reported per character: `Elements(batch)` steps/s.
//!
//! Run: `cargo bench --bench motion -- nn`
use criterion::{BenchmarkId, Criterion, Throughput};
use motion::core::model::{Architecture, BatchGenerator, ModelConfig, MotionModel, Noise};
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

/// Registers this module's benchmarks.
pub fn benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("nn/closed_loop_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for (name, architecture) in [
        ("gru-d-2x512", Architecture::GruD),
        ("vgru-d-512", Architecture::VgruD),
    ] {
        let model = Arc::new(
            MotionModel::random(&ModelConfig::paper(architecture), 42)
                .expect("random weights load"),
        );
        for batch in [1usize, 256] {
            group.throughput(Throughput::Elements(batch as u64));
            group.bench_function(BenchmarkId::new(name, batch), |b| {
                // Only the steps are timed: seeding (and the VGRU plan it computes) happens
                // outside, and each generator takes fewer steps than its plan covers, so
                // re-planning is not measured either (amortized it adds one plan-GRU step per
                // frame).
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
    group.finish();
}
