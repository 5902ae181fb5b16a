//! GRU-d: stacked GRU layers over motion-derivative features, then a linear decoder.
//!
//! Citation: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 — Gopalakrishnan et al. 2019, sections 3.2-3.3 (the GRU-d baseline: two layers of
//! 512 units with derivative inputs). Tensors `rnn.{k}.*` as in `training/models.py`.
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::arch::{stacked_gru_shapes, ArchFields};
use super::config::ModelConfig;
use super::net::{own, Begin, Net, NetState};
use super::weights::{WeightStore, WeightsError};
use crate::nn::{GruCell, GruScratch, Stack, StackState};

/// The config fields only `gru-d` has: none; its sizes are the shared `hidden` and `layers`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GruDFields {}

impl ArchFields for GruDFields {
    const STOCHASTIC: bool = false;

    /// Gopalakrishnan et al. 2019, section 4 (the GRU-d baseline): derivative order 3, 2 layers
    /// of 512 units, unconditioned.
    fn paper() -> ModelConfig {
        ModelConfig {
            derivative_order: 3,
            ..ModelConfig::h36m(GruDFields {}.into(), 512, 2)
        }
    }

    /// At least one layer.
    fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if config.layers == 0 {
            return Err("gru-d with 0 layers".into());
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "gru-d (stacked GRU + linear decoder, Gopalakrishnan et al. 2019)".into(),
            ),
            (
                "sizes",
                format!("{} GRU layers x {} units", config.layers, config.hidden),
            ),
        ]
    }

    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>) {
        stacked_gru_shapes(
            shapes,
            "rnn",
            config.layers,
            config.input_dims(),
            config.hidden,
        );
    }

    fn load(
        &self,
        store: &WeightStore,
        config: &ModelConfig,
    ) -> Result<Arc<dyn Net>, WeightsError> {
        Ok(Arc::new(GruD::load(store, config)?))
    }
}

/// GRU-d recurrent weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct GruD {
    rnn: Stack<GruCell>,
}

/// Per-batch recurrent state of [`GruD`]: one hidden vector per layer and row.
pub type GruDState = StackState<GruScratch>;

impl GruD {
    /// Reads `rnn.{k}.weight_ih/weight_hh/bias_ih/bias_hh` for `k in 0..layers`.
    pub fn load(store: &WeightStore, config: &ModelConfig) -> Result<Self, WeightsError> {
        let rnn = Stack::load_gru(
            store,
            "rnn",
            config.layers,
            config.input_dims(),
            config.hidden,
            config.gru_convention,
        )?;
        Ok(Self { rnn })
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.rnn.parameter_count()
    }

    /// Hidden units of every layer.
    pub fn hidden(&self) -> usize {
        self.rnn.hidden()
    }

    /// Zeroed state for up to `capacity` rows.
    pub fn new_state(&self, capacity: usize) -> GruDState {
        self.rnn.new_state(capacity)
    }

    /// Zeroes the hidden state of `batch` rows.
    pub fn reset(&self, state: &mut GruDState, batch: usize) {
        self.rnn.reset(state, batch);
    }

    /// One step for `batch` rows of features `x [batch, I]`; returns the top hidden `[batch, H]`.
    pub fn step<'s>(&self, state: &'s mut GruDState, x: &[f32], batch: usize) -> &'s [f32] {
        self.rnn.step(state, x, batch)
    }
}

impl Net for GruD {
    fn parameter_count(&self) -> usize {
        GruD::parameter_count(self)
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        self.reset(own::<GruDState>(state), begin.rows);
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        _body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(GruD::step(self, own::<GruDState>(state), features, rows))
    }
}
