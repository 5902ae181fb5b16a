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
use super::config::{ArchConfig, ModelConfig};
use super::generate_error::GenerateError;
use super::net::{own, Begin, Net, NetState};
use super::weights::{WeightStore, WeightsError};
use crate::nn::{LstmCell, LstmScratch, Mlp, MlpConfig, MlpScratch, Stack, StackState};

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
    pub fn load(store: &WeightStore, config: &ModelConfig) -> Result<Self, WeightsError> {
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
                widths: match &config.arch {
                    ArchConfig::DaeLstm(f) => f.widths(config.output_dims()),
                    _ => vec![config.output_dims(); 2],
                },
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
