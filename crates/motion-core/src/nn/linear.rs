//! A fully connected layer `y = W x + b` with PyTorch's `nn.Linear` layout (`weight [out, in]`).
use super::gemm::MatMul;
use super::packed::PackedMatrix;
use crate::weights::{WeightStore, WeightsError};

/// Sizes of a [`Linear`] layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinearConfig {
    /// Input width.
    pub inputs: usize,
    /// Output width.
    pub outputs: usize,
}

/// A fully connected layer; immutable once loaded.
#[derive(Debug, Clone)]
pub struct Linear {
    config: LinearConfig,
    weight: PackedMatrix,
    bias: Vec<f32>,
}

impl Linear {
    /// Reads `{prefix}.weight [out, in]` and `{prefix}.bias [out]`.
    pub fn load(
        store: &WeightStore,
        prefix: &str,
        config: LinearConfig,
    ) -> Result<Self, WeightsError> {
        let weight = PackedMatrix::load(
            store,
            &format!("{prefix}.weight"),
            config.outputs,
            config.inputs,
        )?;
        let bias = store.tensor(&format!("{prefix}.bias"), &[config.outputs])?;
        Ok(Self {
            config,
            weight,
            bias,
        })
    }

    /// The layer's sizes.
    pub fn config(&self) -> LinearConfig {
        self.config
    }

    /// The weight matrix `[outputs, inputs]`.
    pub fn weight(&self) -> &PackedMatrix {
        &self.weight
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.weight.len() + self.bias.len()
    }

    /// `y[b] = W x[b] + bias` for `batch` contiguous rows of `x [batch, in]` into `y [batch, out]`.
    pub fn forward(&self, x: &[f32], batch: usize, y: &mut [f32]) {
        let out = self.config.outputs;
        MatMul::dense(batch, self.config.inputs, out).run_bias(x, &self.weight, &self.bias, y);
    }
}
