//! The large-batch products of a closed-loop step (batch 256, the paper-size models' shapes):
//! the AVX-512 kernel over pre-packed panels against `matrixmultiply::sgemm` reading the PyTorch
//! layout `W [out, in]` (re-packed, with a transposing gather, on every call) and reading a
//! pre-transposed `Wᵀ [in, out]` (its cheapest per-call packing), on 1 and 2 rayon threads.
//! Throughput is in FLOP (`2 * batch * in * out` per call), so criterion's "elem/s" is FLOP/s.
//! `gemm/peak/fma_registers` times 24 independent chains of AVX-512 FMAs on registers only: the
//! core's f32 peak at its current clock, measured in the same run (the VM reports only the base
//! clock, 2.6 GHz, while the cores boost; Zen 5 retires two 16-lane FMAs per cycle).
//!
//! Run: `cargo bench --bench motion -- gemm/`
use criterion::{BenchmarkId, Criterion, Throughput};
use motion::core::nn::sgemm_panels::{self, PanelMatrix};
use std::hint::black_box;
use std::time::Duration;

const BATCH: usize = 256;
/// `(inputs, outputs)` of the step's products: GRU input and recurrent projections (3H = 1536
/// gates), the paper convention's `U_{r,z}` (2H) and `U_n` (H), the decoder (54 used dims) and
/// a fused `[x, h]` product.
const SHAPES: [(usize, usize); 6] = [
    (216, 1536),
    (512, 1536),
    (512, 1024),
    (512, 512),
    (512, 54),
    (1024, 1536),
];

fn values(n: usize, seed: usize) -> Vec<f32> {
    (0..n)
        .map(|k| ((k * 7919 + seed * 104_729) % 2003) as f32 / 1001.0 - 1.0)
        .collect()
}

/// `Y = X Wᵀ` with `matrixmultiply`, `W` given by its strides `(rs, cs)` as an `[in, out]`
/// matrix; split by rows over two rayon tasks when the pool has two threads (as `nn::gemm` does).
#[allow(clippy::too_many_arguments)]
fn matrixmultiply_rows(
    batch: usize,
    inputs: usize,
    outputs: usize,
    x: &[f32],
    w: &[f32],
    (rs, cs): (isize, isize),
    y: &mut [f32],
) {
    if rayon::current_num_threads() > 1 {
        let half = batch / 2;
        let (y0, y1) = y.split_at_mut(half * outputs);
        let (x0, x1) = x.split_at(half * inputs);
        rayon::join(
            || matrixmultiply_rows_serial(half, inputs, outputs, x0, w, (rs, cs), y0),
            || matrixmultiply_rows_serial(batch - half, inputs, outputs, x1, w, (rs, cs), y1),
        );
    } else {
        matrixmultiply_rows_serial(batch, inputs, outputs, x, w, (rs, cs), y);
    }
}

#[allow(clippy::too_many_arguments)]
fn matrixmultiply_rows_serial(
    batch: usize,
    inputs: usize,
    outputs: usize,
    x: &[f32],
    w: &[f32],
    (rs, cs): (isize, isize),
    y: &mut [f32],
) {
    assert!(x.len() >= batch * inputs && y.len() >= batch * outputs);
    assert!(w.len() >= inputs * outputs);
    // SAFETY: the asserts above cover every element the dense strides address.
    unsafe {
        matrixmultiply::sgemm(
            batch,
            inputs,
            outputs,
            1.0,
            x.as_ptr(),
            inputs as isize,
            1,
            w.as_ptr(),
            rs,
            cs,
            0.0,
            y.as_mut_ptr(),
            outputs as isize,
            1,
        );
    }
}

/// Register-only FMA throughput: `n` rounds of 24 independent 16-lane FMAs.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn fma_registers(n: usize) -> f32 {
    use std::arch::x86_64::*;
    let mut acc = [_mm512_set1_ps(0.0); 24];
    let (a, b) = (_mm512_set1_ps(0.999), _mm512_set1_ps(0.001));
    for _ in 0..n {
        for r in acc.iter_mut() {
            *r = _mm512_fmadd_ps(*r, a, b);
        }
    }
    let mut sum = _mm512_set1_ps(0.0);
    for r in acc {
        sum = _mm512_add_ps(sum, r);
    }
    _mm512_reduce_add_ps(sum)
}

/// Registers this module's benchmarks.
pub fn benches(c: &mut Criterion) {
    #[cfg(target_arch = "x86_64")]
    if motion::core::nn::SimdPath::Avx512.supported() {
        const ROUNDS: usize = 100_000;
        let mut group = c.benchmark_group("gemm/peak");
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(1))
            .throughput(Throughput::Elements((ROUNDS * 24 * 32) as u64));
        // SAFETY: AVX-512F is available (checked above).
        group.bench_function("fma_registers", |b| {
            b.iter(|| unsafe { fma_registers(black_box(ROUNDS)) })
        });
        group.finish();
    }
    let mut group = c.benchmark_group("gemm/batch256");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    let pools: Vec<(usize, rayon::ThreadPool)> = [1, 2]
        .into_iter()
        .map(|n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .expect("thread pool");
            (n, pool)
        })
        .collect();
    for (inputs, outputs) in SHAPES {
        let x = values(BATCH * inputs, 1);
        let w = values(outputs * inputs, 2);
        let mut w_t = vec![0.0; inputs * outputs];
        for o in 0..outputs {
            for i in 0..inputs {
                w_t[i * outputs + o] = w[o * inputs + i];
            }
        }
        let panels = PanelMatrix::pack(&w, outputs, inputs);
        let mut y = vec![0.0; BATCH * outputs];
        group.throughput(Throughput::Elements((2 * BATCH * inputs * outputs) as u64));
        let shape = format!("{inputs}x{outputs}");
        for (threads, pool) in &pools {
            if sgemm_panels::panels_in_use() {
                group.bench_function(
                    BenchmarkId::new(format!("panels_avx512/t{threads}"), &shape),
                    |b| {
                        b.iter(|| {
                            pool.install(|| {
                                sgemm_panels::gemm_panels(
                                    BATCH,
                                    &x,
                                    inputs,
                                    &panels,
                                    &mut y,
                                    outputs,
                                    sgemm_panels::Init::Zero,
                                )
                            });
                            black_box(y[0])
                        })
                    },
                );
            }
            group.bench_function(
                BenchmarkId::new(format!("matrixmultiply_pytorch_layout/t{threads}"), &shape),
                |b| {
                    b.iter(|| {
                        pool.install(|| {
                            matrixmultiply_rows(
                                BATCH,
                                inputs,
                                outputs,
                                &x,
                                &w,
                                (1, inputs as isize),
                                &mut y,
                            )
                        });
                        black_box(y[0])
                    })
                },
            );
            group.bench_function(
                BenchmarkId::new(format!("matrixmultiply_transposed/t{threads}"), &shape),
                |b| {
                    b.iter(|| {
                        pool.install(|| {
                            matrixmultiply_rows(
                                BATCH,
                                inputs,
                                outputs,
                                &x,
                                &w_t,
                                (outputs as isize, 1),
                                &mut y,
                            )
                        });
                        black_box(y[0])
                    })
                },
            );
        }
    }
    group.finish();
}
