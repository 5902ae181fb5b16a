//! GRU-d: stacked GRU layers over motion-derivative features, then a linear decoder.
//!
//! Citation: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 — Gopalakrishnan et al. 2019, sections 3.2-3.3 (the GRU-d baseline: two layers of
//! 512 units with derivative inputs). Tensors `rnn.{k}.*` as in `training/models.py`.
use super::config::ModelConfig;
use super::weights::{WeightStore, WeightsError};
use crate::nn::{GruCell, GruConfig, GruScratch};

/// GRU-d recurrent weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct GruD {
    layers: Vec<GruCell>,
}

/// Per-batch recurrent state of [`GruD`]: one hidden vector per layer and row.
#[derive(Debug, Clone)]
pub struct GruDState {
    hidden: Vec<Vec<f32>>,
    scratch: Vec<GruScratch>,
}

impl GruD {
    /// Reads `rnn.{k}.weight_ih/weight_hh/bias_ih/bias_hh` for `k in 0..layers`.
    pub fn load(store: &WeightStore, config: &ModelConfig) -> Result<Self, WeightsError> {
        let layers = (0..config.layers)
            .map(|k| {
                let cfg = GruConfig {
                    inputs: if k == 0 {
                        config.input_dims()
                    } else {
                        config.hidden
                    },
                    hidden: config.hidden,
                    convention: config.gru_convention,
                };
                GruCell::load(store, &format!("rnn.{k}"), cfg)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { layers })
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.layers.iter().map(GruCell::parameter_count).sum()
    }

    /// Hidden units of the top layer.
    pub fn hidden(&self) -> usize {
        self.layers[0].config().hidden
    }

    /// Zeroed state for up to `capacity` rows.
    pub fn new_state(&self, capacity: usize) -> GruDState {
        let h = self.hidden();
        GruDState {
            hidden: self
                .layers
                .iter()
                .map(|_| vec![0.0; capacity * h])
                .collect(),
            scratch: self
                .layers
                .iter()
                .map(|_| GruScratch::new(h, capacity))
                .collect(),
        }
    }

    /// Zeroes the hidden state of `batch` rows.
    pub fn reset(&self, state: &mut GruDState, batch: usize) {
        let h = self.hidden();
        for layer in &mut state.hidden {
            layer[..batch * h].fill(0.0);
        }
    }

    /// One step for `batch` rows of features `x [batch, I]`; returns the top hidden `[batch, H]`.
    pub fn step<'s>(&self, state: &'s mut GruDState, x: &[f32], batch: usize) -> &'s [f32] {
        let h = self.hidden();
        for (k, cell) in self.layers.iter().enumerate() {
            let (below, rest) = state.hidden.split_at_mut(k);
            let input: &[f32] = if k == 0 {
                x
            } else {
                &below[k - 1][..batch * h]
            };
            cell.step(input, &mut rest[0], batch, &mut state.scratch[k]);
        }
        let top = state.hidden.last().expect("at least one layer");
        &top[..batch * h]
    }
}
