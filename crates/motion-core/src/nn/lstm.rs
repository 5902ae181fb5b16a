//! LSTM cell in PyTorch's convention (`torch.nn.LSTMCell`), gate order i, f, g, o:
//! `c' = f ⊙ c + i ⊙ g`, `h' = o ⊙ tanh(c')` with `i, f, o = σ(·)`, `g = tanh(·)` of
//! `W x + b_i + U h + b_h`. Built for the DAE-LSTM of paper 002.
use super::activation::{sigmoid, tanh};
use super::gemm::MatMul;
use super::packed::PackedMatrix;
use crate::model::weights::{WeightStore, WeightsError};

/// Sizes of an [`LstmCell`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LstmConfig {
    /// Input width `I`.
    pub inputs: usize,
    /// Hidden units `H`.
    pub hidden: usize,
}

/// LSTM cell weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct LstmCell {
    config: LstmConfig,
    weight_ih: PackedMatrix,
    weight_hh: PackedMatrix,
    bias_ih: Vec<f32>,
    bias_hh: Vec<f32>,
}

/// Per-step work buffer of an LSTM cell for up to `capacity` rows.
#[derive(Debug, Clone)]
pub struct LstmScratch {
    gates: Vec<f32>,
}

impl LstmScratch {
    /// Buffers for a cell of `hidden` units and up to `capacity` batch rows.
    pub fn new(hidden: usize, capacity: usize) -> Self {
        Self {
            gates: vec![0.0; capacity * 4 * hidden],
        }
    }
}

impl LstmCell {
    /// Reads `{prefix}.weight_ih [4H, I]`, `{prefix}.weight_hh [4H, H]`, `{prefix}.bias_ih [4H]`,
    /// `{prefix}.bias_hh [4H]`.
    pub fn load(
        store: &WeightStore,
        prefix: &str,
        config: LstmConfig,
    ) -> Result<Self, WeightsError> {
        let (i, h) = (config.inputs, config.hidden);
        Ok(Self {
            config,
            weight_ih: PackedMatrix::load(store, &format!("{prefix}.weight_ih"), 4 * h, i)?,
            weight_hh: PackedMatrix::load(store, &format!("{prefix}.weight_hh"), 4 * h, h)?,
            bias_ih: store.tensor(&format!("{prefix}.bias_ih"), &[4 * h])?,
            bias_hh: store.tensor(&format!("{prefix}.bias_hh"), &[4 * h])?,
        })
    }

    /// The cell's sizes.
    pub fn config(&self) -> LstmConfig {
        self.config
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.weight_ih.len() + self.weight_hh.len() + self.bias_ih.len() + self.bias_hh.len()
    }

    /// One step for `batch` rows: `x [batch, I]`, hidden `h` and cell `c` (`[batch, H]`) updated in place.
    pub fn step(
        &self,
        x: &[f32],
        h: &mut [f32],
        c: &mut [f32],
        batch: usize,
        scratch: &mut LstmScratch,
    ) {
        let hid = self.config.hidden;
        let g = 4 * hid;
        let gates = &mut scratch.gates[..batch * g];
        for row in gates.chunks_exact_mut(g) {
            for ((o, bi), bh) in row.iter_mut().zip(&self.bias_ih).zip(&self.bias_hh) {
                *o = bi + bh;
            }
        }
        MatMul::dense(batch, self.config.inputs, g).run(x, &self.weight_ih, gates, true);
        MatMul::dense(batch, hid, g).run(h, &self.weight_hh, gates, true);
        for b in 0..batch {
            let gate = &gates[b * g..(b + 1) * g];
            for j in 0..hid {
                let i = sigmoid(gate[j]);
                let f = sigmoid(gate[hid + j]);
                let gg = tanh(gate[2 * hid + j]);
                let o = sigmoid(gate[3 * hid + j]);
                let cell = f * c[b * hid + j] + i * gg;
                c[b * hid + j] = cell;
                h[b * hid + j] = o * tanh(cell);
            }
        }
    }
}
