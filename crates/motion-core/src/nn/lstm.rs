//! LSTM cell in PyTorch's convention (`torch.nn.LSTMCell`), gate order i, f, g, o:
//! `c' = f ⊙ c + i ⊙ g`, `h' = o ⊙ tanh(c')` with `i, f, o = σ(·)`, `g = tanh(·)` of
//! `W x + b_i + U h + b_h`. Built for the DAE-LSTM of Ghosh et al. 2017.
use super::gates::{sigmoid_fast, tanh_fast};
use super::gemm::MatMul;
use super::packed::PackedMatrix;
use crate::weights::{WeightStore, WeightsError};

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
    /// `bias_ih + bias_hh`, the one bias of the step's gate pre-activations.
    bias: Vec<f32>,
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
        let bias_ih: Vec<f32> = store.tensor(&format!("{prefix}.bias_ih"), &[4 * h])?;
        let bias_hh: Vec<f32> = store.tensor(&format!("{prefix}.bias_hh"), &[4 * h])?;
        Ok(Self {
            config,
            weight_ih: PackedMatrix::load(store, &format!("{prefix}.weight_ih"), 4 * h, i)?,
            weight_hh: PackedMatrix::load(store, &format!("{prefix}.weight_hh"), 4 * h, h)?,
            bias: bias_ih.iter().zip(&bias_hh).map(|(a, b)| a + b).collect(),
        })
    }

    /// The cell's sizes.
    pub fn config(&self) -> LstmConfig {
        self.config
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        // Two stored biases (`bias_ih`, `bias_hh`) of 4H each.
        self.weight_ih.len() + self.weight_hh.len() + 2 * self.bias.len()
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
        MatMul::dense(batch, self.config.inputs, g).run_bias(x, &self.weight_ih, &self.bias, gates);
        MatMul::dense(batch, hid, g).run(h, &self.weight_hh, gates, true);
        // Element-wise half with the branch-free exponential of `gates` (vectorizes; within
        // 2.4e-7 of f64, see `gates::exp_fast`).
        for ((gate, h_row), c_row) in gates
            .chunks_exact(g)
            .zip(h[..batch * hid].chunks_exact_mut(hid))
            .zip(c[..batch * hid].chunks_exact_mut(hid))
        {
            let (i_f, g_o) = gate.split_at(2 * hid);
            let (gi, gf) = i_f.split_at(hid);
            let (gg, go) = g_o.split_at(hid);
            for j in 0..hid {
                let cell = sigmoid_fast(gf[j]) * c_row[j] + sigmoid_fast(gi[j]) * tanh_fast(gg[j]);
                c_row[j] = cell;
                h_row[j] = sigmoid_fast(go[j]) * tanh_fast(cell);
            }
        }
    }
}
