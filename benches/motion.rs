//! The project's one criterion benchmark entry: neural inference steps and metrics.
//! Sub-modules live in `benches/motion/`.
use criterion::{criterion_group, criterion_main};

#[path = "motion/metrics.rs"]
mod metrics;
#[path = "motion/nn.rs"]
mod nn;

criterion_group!(benches, nn::benches, metrics::benches);
criterion_main!(benches);
