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
pub fn gemv(x: &[f32], w: &[f32], inputs: usize, y: &mut [f32], accumulate: bool) {
    debug_assert_eq!(x.len(), inputs);
    if inputs == 0 {
        if !accumulate {
            y.fill(0.0);
        }
        return;
    }
    for (yo, row) in y.iter_mut().zip(w.chunks_exact(inputs)) {
        let d = dot(row, x);
        *yo = if accumulate { *yo + d } else { d };
    }
}

/// Dot product with 16 independent accumulators (vectorizes without `-C target-cpu`).
#[inline]
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    const LANES: usize = 16;
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f32; LANES];
    let ca = a.chunks_exact(LANES);
    let cb = b.chunks_exact(LANES);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (xa, xb) in ca.zip(cb) {
        for k in 0..LANES {
            acc[k] += xa[k] * xb[k];
        }
    }
    let mut tail = 0.0f32;
    for (p, q) in ra.iter().zip(rb) {
        tail += p * q;
    }
    // Pairwise reduction keeps the rounding error small and the order fixed (determinism).
    let mut width = LANES / 2;
    while width > 0 {
        for k in 0..width {
            acc[k] += acc[k + width];
        }
        width /= 2;
    }
    acc[0] + tail
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
