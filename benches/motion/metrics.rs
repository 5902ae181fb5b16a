//! (being built)
use criterion::Criterion;

/// Registers this module's benchmarks.
pub fn benches(_c: &mut Criterion) {}
