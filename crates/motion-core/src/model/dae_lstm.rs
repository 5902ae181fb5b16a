//! DAE-LSTM: stacked LSTM layers (LSTM-3LR) predicting the next pose, and a dropout autoencoder
//! that filters every prediction before it is fed back.
//!
//! Citation: Ghosh, Song, Aksan, Hilliges, "Learning Human Motion Models for Long-term
//! Predictions", 3DV 2017 — Ghosh et al. 2017, section 3 (3.1 the dropout autoencoder, 3.2 the LSTM-3LR,
//! 3.3 stacking them at inference). Tensors as in `training/models.py` (`DAELSTM`):
//! `rnn.{k}.weight_ih/weight_hh/bias_ih/bias_hh` (PyTorch LSTM cells, gate order i, f, g, o),
//! `dae.layers.{k}.weight/bias` (ReLU between layers, none after the last); the decoder and the
//! normalization are the predictor's own (`decoder.*`, `norm.*`).
//!
//! The first LSTM layer reads the frame's features followed by the action one-hot when the
//! config names actions. The autoencoder maps the decoded (normalized) pose to its filtered
//! version in the same space; that filtered pose is both the output and the next input.
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::arch::ArchFields;
use super::config::{limits, ModelConfig};
use super::generate_error::GenerateError;
use super::net::{own, Begin, Net, NetState};
use super::weights::{WeightStore, WeightsError};
use crate::nn::{LstmCell, LstmScratch, Mlp, MlpConfig, MlpScratch, Stack, StackState};

/// The config fields only `dae-lstm` has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct DaeLstmFields {
    /// Units of each hidden layer of the dropout autoencoder.
    pub dae_hidden: usize,
    /// Hidden layers of the dropout autoencoder (Ghosh et al. 2017: 3).
    pub dae_layers: usize,
}

impl ArchFields for DaeLstmFields {
    const STOCHASTIC: bool = false;

    /// Ghosh et al. 2017, section 4.1: 3 LSTM layers of 1000 units over plain, min-max scaled
    /// poses and the action one-hot, an autoencoder of 3 x 3000 units.
    fn paper() -> ModelConfig {
        ModelConfig {
            normalization: "min-max".into(),
            actions: ModelConfig::h36m_actions(),
            ..ModelConfig::h36m(
                DaeLstmFields {
                    dae_hidden: 3000,
                    dae_layers: 3,
                }
                .into(),
                1000,
                3,
            )
        }
    }

    /// LSTM layers and an autoencoder with units, within the limits.
    fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if self.dae_hidden > limits::UNITS {
            return Err(format!(
                "dae_hidden {} is over the limit of {}",
                self.dae_hidden,
                limits::UNITS
            ));
        }
        if self.dae_layers > limits::LAYERS {
            return Err(format!(
                "dae_layers {} is over the limit of {}",
                self.dae_layers,
                limits::LAYERS
            ));
        }
        if config.layers == 0 {
            return Err("dae-lstm with 0 LSTM layers".into());
        }
        if self.dae_hidden == 0 {
            return Err("dae-lstm needs dae_hidden > 0".into());
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "dae-lstm (stacked LSTM + linear decoder, each output filtered by a dropout \
                 autoencoder before it is fed back, Ghosh et al. 2017)"
                    .into(),
            ),
            (
                "sizes",
                format!(
                    "{} LSTM layers x {} units (first layer input {} = features + {} action \
                     one-hot); autoencoder {} ReLU layers x {} units",
                    config.layers,
                    config.hidden,
                    config.rnn_input_dims(),
                    config.actions.len(),
                    self.dae_layers,
                    self.dae_hidden
                ),
            ),
        ]
    }

    fn rnn_input_dims(&self, config: &ModelConfig) -> usize {
        config.input_dims() + config.actions.len()
    }

    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>) {
        let h = config.hidden;
        for k in 0..config.layers {
            let inputs = if k == 0 { config.rnn_input_dims() } else { h };
            shapes.push((format!("rnn.{k}.weight_ih"), vec![4 * h, inputs]));
            shapes.push((format!("rnn.{k}.weight_hh"), vec![4 * h, h]));
            shapes.push((format!("rnn.{k}.bias_ih"), vec![4 * h]));
            shapes.push((format!("rnn.{k}.bias_hh"), vec![4 * h]));
        }
        for (k, w) in self.widths(config.output_dims()).windows(2).enumerate() {
            shapes.push((format!("dae.layers.{k}.weight"), vec![w[1], w[0]]));
            shapes.push((format!("dae.layers.{k}.bias"), vec![w[1]]));
        }
    }

    fn load(
        &self,
        store: &WeightStore,
        config: &ModelConfig,
    ) -> Result<Arc<dyn Net>, WeightsError> {
        Ok(Arc::new(DaeLstm::load(store, config, self)?))
    }
}

impl DaeLstmFields {
    /// The autoencoder's layer widths `[O, dae_hidden x dae_layers, O]`.
    pub fn widths(&self, outputs: usize) -> Vec<usize> {
        let mut widths = vec![outputs];
        widths.extend(std::iter::repeat_n(self.dae_hidden, self.dae_layers));
        widths.push(outputs);
        widths
    }
}

/// DAE-LSTM weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct DaeLstm {
    rnn: Stack<LstmCell>,
    dae: Mlp,
    features: usize,
    actions: usize,
    outputs: usize,
}

/// Per-batch state of a [`DaeLstm`]: hidden and cell vectors per layer, the action of each row,
/// and work buffers, all sized once.
#[derive(Debug, Clone)]
pub struct DaeLstmState {
    rnn: StackState<LstmScratch>,
    input: Vec<f32>,
    action: Vec<usize>,
    /// Per row, a crossfade in progress: (previous action, steps done, steps in all).
    fade: Vec<(usize, usize, usize)>,
    dae_scratch: MlpScratch,
    filtered: Vec<f32>,
}

impl DaeLstm {
    /// Reads `rnn.{k}.*` for `k in 0..layers` and `dae.layers.{k}.*` for the config's widths.
    pub fn load(
        store: &WeightStore,
        config: &ModelConfig,
        fields: &DaeLstmFields,
    ) -> Result<Self, WeightsError> {
        let rnn = Stack::load_lstm(
            store,
            "rnn",
            config.layers,
            config.rnn_input_dims(),
            config.hidden,
        )?;
        let dae = Mlp::load(
            store,
            "dae",
            &MlpConfig {
                widths: fields.widths(config.output_dims()),
            },
        )?;
        Ok(Self {
            rnn,
            dae,
            features: config.input_dims(),
            actions: config.actions.len(),
            outputs: config.output_dims(),
        })
    }

    /// Number of trainable parameters (LSTM layers and autoencoder).
    pub fn parameter_count(&self) -> usize {
        self.rnn.parameter_count() + self.dae.parameter_count()
    }

    /// Units per LSTM layer.
    pub fn hidden(&self) -> usize {
        self.rnn.hidden()
    }

    /// The dropout autoencoder.
    pub fn autoencoder(&self) -> &Mlp {
        &self.dae
    }

    /// Zeroed state for up to `capacity` rows.
    pub fn new_state(&self, capacity: usize) -> DaeLstmState {
        DaeLstmState {
            rnn: self.rnn.new_state(capacity),
            input: vec![0.0; capacity * (self.features + self.actions)],
            action: vec![0; capacity],
            fade: vec![(0, 0, 0); capacity],
            dae_scratch: MlpScratch::new(&self.dae, capacity),
            filtered: vec![0.0; capacity * self.outputs],
        }
    }

    /// Zeroes the state of `actions.len()` rows and sets each row's action index (ignored by a
    /// model without actions).
    pub fn begin(&self, state: &mut DaeLstmState, actions: &[usize]) {
        self.rnn.reset(&mut state.rnn, actions.len());
        state.action[..actions.len()].copy_from_slice(actions);
        state.fade[..actions.len()].fill((0, 0, 0));
    }

    /// Conditions row `row` on `action` (one-hot index) from the next step on, without
    /// re-seeding; with `crossfade = n > 0` the one-hot input moves from the previous action to
    /// the new one over `n` steps (weights `k / (n + 1)`, `k = 1..n`), then holds the new one.
    pub fn set_action(
        &self,
        state: &mut DaeLstmState,
        row: usize,
        action: usize,
        crossfade: usize,
    ) {
        debug_assert!(action < self.actions);
        let previous = state.action[row];
        state.action[row] = action;
        state.fade[row] = if crossfade > 0 && previous != action {
            (previous, 0, crossfade)
        } else {
            (0, 0, 0)
        };
    }

    /// One step for `batch` rows of features `x [batch, I]`; returns the top hidden `[batch, H]`.
    pub fn step<'s>(&self, state: &'s mut DaeLstmState, x: &[f32], batch: usize) -> &'s [f32] {
        let width = self.features + self.actions;
        for (b, row) in state.input[..batch * width]
            .chunks_exact_mut(width)
            .enumerate()
        {
            let (features, onehot) = row.split_at_mut(self.features);
            features.copy_from_slice(&x[b * self.features..(b + 1) * self.features]);
            onehot.fill(0.0);
            if self.actions > 0 {
                let (from, done, steps) = &mut state.fade[b];
                if *done < *steps {
                    *done += 1;
                    let w = *done as f32 / (*steps + 1) as f32;
                    onehot[*from] = 1.0 - w;
                    onehot[state.action[b]] = w;
                } else {
                    onehot[state.action[b]] = 1.0;
                }
            }
        }
        self.rnn
            .step(&mut state.rnn, &state.input[..batch * width], batch)
    }

    /// Replaces `batch` decoded poses `pose [batch, O]` by the autoencoder's filtering of them.
    pub fn filter(&self, state: &mut DaeLstmState, pose: &mut [f32], batch: usize) {
        let n = batch * self.outputs;
        self.dae.forward(
            &pose[..n],
            batch,
            &mut state.filtered[..n],
            &mut state.dae_scratch,
        );
        pose[..n].copy_from_slice(&state.filtered[..n]);
    }
}

impl Net for DaeLstm {
    fn parameter_count(&self) -> usize {
        DaeLstm::parameter_count(self)
    }
    fn needs_action(&self) -> bool {
        true
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        DaeLstm::begin(
            self,
            own::<DaeLstmState>(state),
            &begin.actions[..begin.rows],
        );
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        _body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(DaeLstm::step(
            self,
            own::<DaeLstmState>(state),
            features,
            rows,
        ))
    }
    fn filter(&self, state: &mut dyn NetState, out_norm: &mut [f32], rows: usize) {
        DaeLstm::filter(self, own::<DaeLstmState>(state), out_norm, rows);
    }
    fn set_action(
        &self,
        state: &mut dyn NetState,
        _rows: usize,
        row: usize,
        action: usize,
        crossfade: usize,
        _body_step: usize,
    ) -> Result<(), GenerateError> {
        DaeLstm::set_action(self, own::<DaeLstmState>(state), row, action, crossfade);
        Ok(())
    }
}
