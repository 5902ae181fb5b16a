//! [`MatMul`]: the operand layout of one matrix product, the plain data every kernel reads
//! ([`super::gemm`] runs products over it and hands it to the row kernels of every SIMD path).

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
}
