//! The project's one criterion benchmark entry: neural inference steps and metrics.
//! Sub-modules live in `benches/motion/`.
use criterion::{criterion_group, criterion_main};

#[path = "motion/engine.rs"]
mod engine;
#[path = "motion/foundations.rs"]
mod foundations;
#[path = "motion/gemm.rs"]
mod gemm;
#[path = "motion/metrics.rs"]
mod metrics;
#[path = "motion/nn.rs"]
mod nn;

criterion_group!(
    benches,
    foundations::benches,
    nn::benches,
    metrics::benches,
    gemm::benches,
    engine::benches
);
criterion_main!(benches);
