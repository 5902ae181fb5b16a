//! The body GRU of Gopalakrishnan et al. 2019 (eqs. 1-4): a GRU cell whose three gates (r, z and the candidate)
//! each also read the guide vector through `V p_t` (`weight_ph [3H, P]`, no extra bias).
//!
//! The guide term is added to the input projection, so the cell works in either convention
//! ([`GruConvention`](super::gru::GruConvention)); the paper's own is `U (r ⊙ h)`.
use super::gemm::MatMul;
use super::gru::{GruCell, GruConfig, GruScratch};
use super::packed::PackedMatrix;
use crate::weights::{WeightStore, WeightsError};

/// Sizes and convention of a [`BodyGruCell`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BodyGruConfig {
    /// Input width, hidden units and convention of the underlying GRU.
    pub gru: GruConfig,
    /// Guide-vector width `P`.
    pub guide: usize,
}

/// Body GRU weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct BodyGruCell {
    config: BodyGruConfig,
    gru: GruCell,
    weight_ph: PackedMatrix,
}

impl BodyGruCell {
    /// Reads the GRU tensors under `prefix` plus `{prefix}.weight_ph [3H, P]`.
    pub fn load(
        store: &WeightStore,
        prefix: &str,
        config: BodyGruConfig,
    ) -> Result<Self, WeightsError> {
        let gru = GruCell::load(store, prefix, config.gru)?;
        let weight_ph = PackedMatrix::load(
            store,
            &format!("{prefix}.weight_ph"),
            3 * config.gru.hidden,
            config.guide,
        )?;
        Ok(Self {
            config,
            gru,
            weight_ph,
        })
    }

    /// The cell's sizes and convention.
    pub fn config(&self) -> BodyGruConfig {
        self.config
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.gru.parameter_count() + self.weight_ph.len()
    }

    /// One step for `batch` rows: `x [batch, I]` contiguous, guides `p` with row stride `p_stride`,
    /// `h [batch, H]` updated in place.
    pub fn step(
        &self,
        x: &[f32],
        p: &[f32],
        p_stride: usize,
        h: &mut [f32],
        batch: usize,
        scratch: &mut GruScratch,
    ) {
        let g = 3 * self.config.gru.hidden;
        self.gru
            .project_input(x, self.config.gru.inputs, batch, scratch);
        MatMul::dense(batch, self.config.guide, g)
            .strided(p_stride, g)
            .run(p, &self.weight_ph, &mut scratch.gi, true);
        self.gru.step_projected(h, batch, scratch);
    }
}
