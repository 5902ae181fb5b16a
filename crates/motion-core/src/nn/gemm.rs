//! The one matrix product every layer uses: `Y = X Wᵀ` for a row-major weight `W [out, in]`
//! (the PyTorch layout) and a batch of input rows `X [batch, in]`.
//!
//! Batch 1 goes through a tight GEMV (dot products with independent accumulators, written so the
//! compiler vectorizes them) that touches no heap memory. Larger batches go to
//! `matrixmultiply::sgemm` (whose packing buffers are its own business), split over rayon
//! threads by rows of `X` when the product is big enough to pay for the fork.

/// Operand layout of one product `Y[b, o] = beta * Y[b, o] + Σ_i X[b, i] * W[o, i]`.
#[derive(Debug, Clone, Copy)]
pub struct MatMul {
    /// Rows of `X` and `Y`.
    pub batch: usize,
    /// Columns of `X` (= columns of `W`).
    pub inputs: usize,
    /// Columns of `Y` (= rows of `W`).
    pub outputs: usize,
    /// Distance between consecutive rows of `X`.
    pub x_stride: usize,
    /// Distance between consecutive rows of `Y`.
    pub y_stride: usize,
}

/// Below this many multiply-adds a product is not split across threads.
const PARALLEL_MIN_WORK: usize = 1 << 21;
/// Minimum rows per thread when splitting.
const PARALLEL_MIN_ROWS: usize = 16;

impl MatMul {
    /// A product over contiguous rows (`x_stride = inputs`, `y_stride = outputs`).
    pub fn dense(batch: usize, inputs: usize, outputs: usize) -> Self {
        Self {
            batch,
            inputs,
            outputs,
            x_stride: inputs,
            y_stride: outputs,
        }
    }

    /// Same product with explicit row strides.
    pub fn strided(self, x_stride: usize, y_stride: usize) -> Self {
        Self {
            x_stride,
            y_stride,
            ..self
        }
    }

    /// `Y = X Wᵀ` (`accumulate = false`) or `Y += X Wᵀ` (`accumulate = true`).
    ///
    /// Panics if a slice is too short for the layout (a programming error, not bad input).
    pub fn run(&self, x: &[f32], w: &[f32], y: &mut [f32], accumulate: bool) {
        if self.batch == 0 || self.outputs == 0 {
            return;
        }
        assert!(w.len() >= self.outputs * self.inputs, "weight too short");
        assert!(
            x.len() >= (self.batch - 1) * self.x_stride + self.inputs,
            "input too short"
        );
        assert!(
            y.len() >= (self.batch - 1) * self.y_stride + self.outputs,
            "output too short"
        );
        if self.batch == 1 {
            gemv(
                &x[..self.inputs],
                w,
                self.inputs,
                &mut y[..self.outputs],
                accumulate,
            );
            return;
        }
        let work = self.batch * self.inputs * self.outputs;
        let threads = rayon::current_num_threads();
        if threads > 1 && work >= PARALLEL_MIN_WORK && self.batch >= 2 * PARALLEL_MIN_ROWS {
            let rows = self.batch.div_ceil(threads).max(PARALLEL_MIN_ROWS);
            let this = *self;
            rayon::scope(|s| {
                let mut y_rest = &mut y[..];
                let mut start = 0;
                while start < this.batch {
                    let n = rows.min(this.batch - start);
                    let y_len = if start + n == this.batch {
                        y_rest.len()
                    } else {
                        n * this.y_stride
                    };
                    let (y_chunk, rest) = y_rest.split_at_mut(y_len);
                    y_rest = rest;
                    let x_chunk = &x[start * this.x_stride..];
                    let part = MatMul { batch: n, ..this };
                    s.spawn(move |_| part.sgemm(x_chunk, w, y_chunk, accumulate));
                    start += n;
                }
            });
        } else {
            self.sgemm(x, w, y, accumulate);
        }
    }

    fn sgemm(&self, x: &[f32], w: &[f32], y: &mut [f32], accumulate: bool) {
        let beta = if accumulate { 1.0 } else { 0.0 };
        // SAFETY: the asserts in `run` (and the chunking there) guarantee that every element the
        // strides address lies inside `x`, `w` and `y`; `y` is exclusively borrowed.
        unsafe {
            matrixmultiply::sgemm(
                self.batch,
                self.inputs,
                self.outputs,
                1.0,
                x.as_ptr(),
                self.x_stride as isize,
                1,
                // Wᵀ as a [in, out] matrix: element (i, o) is w[o * in + i].
                w.as_ptr(),
                1,
                self.inputs as isize,
                beta,
                y.as_mut_ptr(),
                self.y_stride as isize,
                1,
            );
        }
    }
}

/// `y = W x` or `y += W x` for a row-major `W [y.len(), inputs]`.
///
/// On x86-64 with AVX2 and FMA (detected at run time) the same kernel is compiled for those
/// features and uses fused multiply-adds; elsewhere it is portable code the compiler vectorizes
/// for the baseline target. Either way the result for a given machine is deterministic.
pub fn gemv(x: &[f32], w: &[f32], inputs: usize, y: &mut [f32], accumulate: bool) {
    debug_assert_eq!(x.len(), inputs);
    if inputs == 0 {
        if !accumulate {
            y.fill(0.0);
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports the features `gemv_avx2_fma` is compiled for.
            unsafe { gemv_avx2_fma(x, w, inputs, y, accumulate) };
            return;
        }
    }
    gemv_kernel::<false>(x, w, inputs, y, accumulate);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn gemv_avx2_fma(x: &[f32], w: &[f32], inputs: usize, y: &mut [f32], accumulate: bool) {
    gemv_kernel::<true>(x, w, inputs, y, accumulate);
}

/// Lanes per accumulator row: 16 f32 = two AVX registers, enough independent sums to hide the
/// add latency.
const LANES: usize = 16;

#[inline(always)]
fn madd<const FMA: bool>(a: f32, b: f32, acc: f32) -> f32 {
    if FMA {
        a.mul_add(b, acc)
    } else {
        acc + a * b
    }
}

/// Pairwise sum of the lanes (fixed order, so results are deterministic).
#[inline(always)]
fn reduce(mut acc: [f32; LANES]) -> f32 {
    let mut width = LANES / 2;
    while width > 0 {
        for k in 0..width {
            acc[k] += acc[k + width];
        }
        width /= 2;
    }
    acc[0]
}

/// Four rows at a time, so each load of `x` serves four dot products.
#[inline(always)]
fn gemv_kernel<const FMA: bool>(
    x: &[f32],
    w: &[f32],
    inputs: usize,
    y: &mut [f32],
    accumulate: bool,
) {
    let rows = y.len();
    let w = &w[..rows * inputs];
    let full = inputs / LANES * LANES;
    let (x_body, x_tail) = x.split_at(full);
    let mut o = 0;
    while o + 4 <= rows {
        let r = |k: usize| &w[(o + k) * inputs..(o + k + 1) * inputs];
        let (r0, r1, r2, r3) = (r(0), r(1), r(2), r(3));
        let mut acc = [[0.0f32; LANES]; 4];
        for ((((xc, c0), c1), c2), c3) in x_body
            .chunks_exact(LANES)
            .zip(r0.chunks_exact(LANES))
            .zip(r1.chunks_exact(LANES))
            .zip(r2.chunks_exact(LANES))
            .zip(r3.chunks_exact(LANES))
        {
            for k in 0..LANES {
                acc[0][k] = madd::<FMA>(c0[k], xc[k], acc[0][k]);
                acc[1][k] = madd::<FMA>(c1[k], xc[k], acc[1][k]);
                acc[2][k] = madd::<FMA>(c2[k], xc[k], acc[2][k]);
                acc[3][k] = madd::<FMA>(c3[k], xc[k], acc[3][k]);
            }
        }
        for (j, row) in [r0, r1, r2, r3].iter().enumerate() {
            let mut d = reduce(acc[j]);
            for (a, b) in row[full..].iter().zip(x_tail) {
                d = madd::<FMA>(*a, *b, d);
            }
            y[o + j] = if accumulate { y[o + j] + d } else { d };
        }
        o += 4;
    }
    while o < rows {
        let row = &w[o * inputs..(o + 1) * inputs];
        let mut acc = [0.0f32; LANES];
        for (xc, c) in x_body.chunks_exact(LANES).zip(row.chunks_exact(LANES)) {
            for k in 0..LANES {
                acc[k] = madd::<FMA>(c[k], xc[k], acc[k]);
            }
        }
        let mut d = reduce(acc);
        for (a, b) in row[full..].iter().zip(x_tail) {
            d = madd::<FMA>(*a, *b, d);
        }
        y[o] = if accumulate { y[o] + d } else { d };
        o += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(x: &[f32], w: &[f32], b: usize, i: usize, o: usize) -> Vec<f32> {
        let mut y = vec![0.0; b * o];
        for r in 0..b {
            for c in 0..o {
                y[r * o + c] = (0..i).map(|k| x[r * i + k] * w[c * i + k]).sum();
            }
        }
        y
    }

    fn data(n: usize, seed: u32) -> Vec<f32> {
        (0..n)
            .map(|k| {
                (((k as u32).wrapping_mul(2654435761).wrapping_add(seed) >> 8) % 1000) as f32
                    / 500.0
                    - 1.0
            })
            .collect()
    }

    #[test]
    fn gemv_and_gemm_match_naive() {
        for &(b, i, o) in &[(1, 37, 11), (3, 5, 7), (64, 100, 300), (1, 0, 4)] {
            let x = data(b * i, 1);
            let w = data(o * i, 2);
            let expect = naive(&x, &w, b, i, o);
            let mut y = vec![1.0; b * o];
            MatMul::dense(b, i, o).run(&x, &w, &mut y, false);
            for (p, q) in y.iter().zip(&expect) {
                assert!((p - q).abs() < 1e-4, "{p} vs {q}");
            }
            MatMul::dense(b, i, o).run(&x, &w, &mut y, true);
            for (p, q) in y.iter().zip(&expect) {
                assert!((p - 2.0 * q).abs() < 2e-4);
            }
        }
    }

    #[test]
    fn portable_and_fused_kernels_match_naive() {
        for &(i, o) in &[(37, 11), (216, 9), (16, 4), (5, 3)] {
            let x = data(i, 5);
            let w = data(o * i, 6);
            let expect = naive(&x, &w, 1, i, o);
            for fused in [false, true] {
                let mut y = vec![0.0; o];
                if fused {
                    gemv_kernel::<true>(&x, &w, i, &mut y, false);
                } else {
                    gemv_kernel::<false>(&x, &w, i, &mut y, false);
                }
                for (p, q) in y.iter().zip(&expect) {
                    assert!((p - q).abs() < 1e-4, "fused {fused}: {p} vs {q}");
                }
            }
        }
    }

    #[test]
    fn strided_rows() {
        let (b, i, o) = (4, 6, 3);
        let x = data(b * 10, 3);
        let w = data(o * i, 4);
        let mut y = vec![0.0; b * 5];
        MatMul::dense(b, i, o)
            .strided(10, 5)
            .run(&x, &w, &mut y, false);
        for r in 0..b {
            for c in 0..o {
                let e: f32 = (0..i).map(|k| x[r * 10 + k] * w[c * i + k]).sum();
                assert!((y[r * 5 + c] - e).abs() < 1e-5);
            }
            assert_eq!(&y[r * 5 + 3..r * 5 + 5], &[0.0, 0.0]);
        }
    }
}
