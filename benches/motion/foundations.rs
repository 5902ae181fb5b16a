//! Per-frame costs of the foundations: exp-map and channel FK, root integration, derivative
//! features, the protocol's Euler conversion (all allocation-free per frame).
use std::hint::black_box;

use criterion::Criterion;
use motion::core::derivatives::DerivativeBuffer;
use motion::core::kinematics::{ChannelFk, ExpMapFk};
use motion::core::root::RootIntegrator;
use motion::core::rotation::expmap_frame_to_euler_protocol;
use motion::core::skeleton::Skeleton;

fn frame(t: usize, width: usize) -> Vec<f64> {
    (0..width)
        .map(|k| (t as f64 * 0.13 + k as f64 * 0.71).sin() * if k < 3 { 10.0 } else { 0.5 })
        .collect()
}

/// Registers this module's benchmarks.
pub fn benches(c: &mut Criterion) {
    let skeleton = Skeleton::h36m();
    let frames: Vec<Vec<f64>> = (0..64).map(|t| frame(t, 99)).collect();
    let mut out = vec![[0.0; 3]; skeleton.len()];

    let mut fk = ExpMapFk::new(&skeleton);
    let mut root = RootIntegrator::new(2);
    let mut t = 0;
    c.bench_function("foundations/expmap_fk_frame_h36m", |b| {
        b.iter(|| {
            let f = &frames[t % 64];
            t += 1;
            let pose = root.push(f);
            fk.frame(&skeleton, black_box(f), &pose, &mut out);
            black_box(&out);
        })
    });

    let mut channel_fk = ChannelFk::new(&skeleton);
    let degrees: Vec<Vec<f64>> = frames
        .iter()
        .map(|f| f.iter().map(|v| v * 57.0).collect())
        .collect();
    c.bench_function("foundations/channel_fk_frame_h36m", |b| {
        b.iter(|| {
            let f = &degrees[t % 64];
            t += 1;
            channel_fk.frame(&skeleton, black_box(f), &mut out);
            black_box(&out);
        })
    });

    let mut euler = vec![0.0; 99];
    c.bench_function("foundations/euler_protocol_frame_99", |b| {
        b.iter(|| {
            let f = &frames[t % 64];
            t += 1;
            expmap_frame_to_euler_protocol(black_box(f), &mut euler);
            black_box(&euler);
        })
    });

    let used: Vec<Vec<f32>> = frames
        .iter()
        .map(|f| f[..54].iter().map(|&v| v as f32).collect())
        .collect();
    let mut buffer = DerivativeBuffer::<f32>::new(54, 3);
    let mut features = vec![0.0f32; 216];
    c.bench_function("foundations/derivative_push_54x3_f32", |b| {
        b.iter(|| {
            let f = &used[t % 64];
            t += 1;
            buffer.push(black_box(f), &mut features);
            black_box(&features);
        })
    });
}
