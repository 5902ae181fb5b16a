//! A multilayer perceptron: [`Linear`] layers with ReLU between them (none after the last),
//! named `{prefix}.layers.{k}.weight/bias`. Built for the denoising autoencoder of Ghosh et al. 2017.
use super::activation::relu;
use super::linear::{Linear, LinearConfig};
use crate::weights::{WeightStore, WeightsError};

/// Layer widths of an [`Mlp`]: `widths[0]` inputs, then each layer's output width.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MlpConfig {
    /// Input width followed by the output width of every layer (at least two entries).
    pub widths: Vec<usize>,
}

/// MLP weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct Mlp {
    layers: Vec<Linear>,
}

/// Activation buffers of an [`Mlp`] for up to `capacity` rows (two ping-pong buffers).
#[derive(Debug, Clone)]
pub struct MlpScratch {
    a: Vec<f32>,
    b: Vec<f32>,
}

impl MlpScratch {
    /// Buffers for `mlp` and up to `capacity` batch rows.
    pub fn new(mlp: &Mlp, capacity: usize) -> Self {
        let widest = mlp
            .layers
            .iter()
            .map(|l| l.config().outputs)
            .max()
            .unwrap_or(0);
        Self {
            a: vec![0.0; capacity * widest],
            b: vec![0.0; capacity * widest],
        }
    }
}

impl Mlp {
    /// Reads `{prefix}.layers.{k}.weight/bias` for `k in 0..widths.len()-1`.
    pub fn load(
        store: &WeightStore,
        prefix: &str,
        config: &MlpConfig,
    ) -> Result<Self, WeightsError> {
        let layers = config
            .widths
            .windows(2)
            .enumerate()
            .map(|(k, w)| {
                let cfg = LinearConfig {
                    inputs: w[0],
                    outputs: w[1],
                };
                Linear::load(store, &format!("{prefix}.layers.{k}"), cfg)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { layers })
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.layers.iter().map(Linear::parameter_count).sum()
    }

    /// `y = MLP(x)` for `batch` contiguous rows.
    pub fn forward(&self, x: &[f32], batch: usize, y: &mut [f32], scratch: &mut MlpScratch) {
        let n = self.layers.len();
        let MlpScratch { a, b } = scratch;
        for (k, layer) in self.layers.iter().enumerate() {
            let out_w = layer.config().outputs;
            let input: &[f32] = if k == 0 { x } else { &a[..] };
            if k + 1 == n {
                layer.forward(input, batch, y);
            } else {
                layer.forward(input, batch, b);
                for v in &mut b[..batch * out_w] {
                    *v = relu(*v);
                }
                std::mem::swap(a, b);
            }
        }
    }
}
