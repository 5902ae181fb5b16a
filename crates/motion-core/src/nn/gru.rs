//! GRU cell in two conventions, gate order r, z, n as in `torch.nn.GRU` state dicts.
//!
//! - [`GruConvention::PyTorch`]: `n = tanh(W_n x + b_in + r ⊙ (U_n h + b_hn))`
//! - [`GruConvention::Paper`] (Gopalakrishnan et al. 2019, eq. 3): `n = tanh(W_n x + b_in + U_n (r ⊙ h) + b_hn)`
//!
//! In both, `r = σ(W_r x + b_ir + U_r h + b_hr)`, `z = σ(W_z x + b_iz + U_z h + b_hz)` and
//! `h' = (1 - z) ⊙ n + z ⊙ h`. The input projection `W x + b_i` of all three gates is one matrix
//! product ([`GruCell::project_input`]); the body GRU adds its guide term to it before
//! [`GruCell::step_projected`].
use super::gates;
use super::gemm::MatMul;
use super::packed::PackedMatrix;
use crate::weights::{WeightStore, WeightsError};

/// Where the reset gate acts in the candidate (the only difference between the two conventions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum GruConvention {
    /// `torch.nn.GRU`: `r ⊙ (U_n h + b_hn)`.
    #[serde(rename = "pytorch")]
    PyTorch,
    /// Gopalakrishnan et al. 2019 eq. 3: `U_n (r ⊙ h) + b_hn`.
    #[serde(rename = "paper")]
    Paper,
}

impl GruConvention {
    /// The name used in weights metadata (`pytorch` or `paper`).
    pub fn name(self) -> &'static str {
        match self {
            GruConvention::PyTorch => "pytorch",
            GruConvention::Paper => "paper",
        }
    }

    /// Parses a metadata name (`pytorch` or `paper`).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "pytorch" => Some(GruConvention::PyTorch),
            "paper" => Some(GruConvention::Paper),
            _ => None,
        }
    }
}

/// Sizes and convention of a [`GruCell`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GruConfig {
    /// Input width `I`.
    pub inputs: usize,
    /// Hidden units `H`.
    pub hidden: usize,
    /// Candidate convention.
    pub convention: GruConvention,
}

/// A GRU cell's weights (immutable, shareable across characters).
#[derive(Debug, Clone)]
pub struct GruCell {
    config: GruConfig,
    weight_ih: PackedMatrix,
    /// Rows `0..2H` of `weight_hh` (the r and z gates).
    weight_hh_rz: PackedMatrix,
    /// Rows `2H..3H` of `weight_hh` (the candidate), apart because the paper convention
    /// multiplies it by `r ⊙ h`.
    weight_hh_n: PackedMatrix,
    bias_ih: Vec<f32>,
    bias_hh: Vec<f32>,
}

/// Per-step work buffers of a GRU cell for up to `capacity` rows (owned by the caller's state so a
/// step allocates nothing).
#[derive(Debug, Clone)]
pub struct GruScratch {
    capacity: usize,
    /// Input projection `W x + b_i`, `[batch, 3H]`.
    pub gi: Vec<f32>,
    gh: Vec<f32>,
    rh: Vec<f32>,
}

impl GruScratch {
    /// Buffers for a cell of `hidden` units and up to `capacity` batch rows.
    pub fn new(hidden: usize, capacity: usize) -> Self {
        Self {
            capacity,
            gi: vec![0.0; capacity * 3 * hidden],
            gh: vec![0.0; capacity * 3 * hidden],
            rh: vec![0.0; capacity * hidden],
        }
    }

    /// The largest batch these buffers fit.
    pub fn capacity(&self) -> usize {
        self.capacity
    }
}

impl GruCell {
    /// Reads `{prefix}.weight_ih [3H, I]`, `{prefix}.weight_hh [3H, H]`, `{prefix}.bias_ih [3H]`,
    /// `{prefix}.bias_hh [3H]`.
    pub fn load(
        store: &WeightStore,
        prefix: &str,
        config: GruConfig,
    ) -> Result<Self, WeightsError> {
        let (i, h) = (config.inputs, config.hidden);
        let weight_hh = PackedMatrix::load(store, &format!("{prefix}.weight_hh"), 3 * h, h)?;
        let (weight_hh_rz, weight_hh_n) = weight_hh.split_rows(2 * h);
        Ok(Self {
            config,
            weight_ih: PackedMatrix::load(store, &format!("{prefix}.weight_ih"), 3 * h, i)?,
            weight_hh_rz,
            weight_hh_n,
            bias_ih: store.tensor(&format!("{prefix}.bias_ih"), &[3 * h])?,
            bias_hh: store.tensor(&format!("{prefix}.bias_hh"), &[3 * h])?,
        })
    }

    /// The cell's sizes and convention.
    pub fn config(&self) -> GruConfig {
        self.config
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.weight_ih.len()
            + self.weight_hh_rz.len()
            + self.weight_hh_n.len()
            + self.bias_ih.len()
            + self.bias_hh.len()
    }

    /// Column `col` of `weight_ih` plus `bias_ih` (the input projection of a one-hot input), into `gi [3H]`.
    pub fn project_one_hot(&self, col: Option<usize>, gi: &mut [f32]) {
        gi.copy_from_slice(&self.bias_ih);
        if let Some(c) = col {
            for (r, g) in gi.iter_mut().enumerate() {
                *g += self.weight_ih.get(r, c);
            }
        }
    }

    /// `gi[b] = W_ih x[b] + b_ih` for `batch` rows of `x` (row stride `x_stride`) into `scratch.gi`.
    pub fn project_input(
        &self,
        x: &[f32],
        x_stride: usize,
        batch: usize,
        scratch: &mut GruScratch,
    ) {
        let g = 3 * self.config.hidden;
        MatMul::dense(batch, self.config.inputs, g)
            .strided(x_stride, g)
            .run_bias(x, &self.weight_ih, &self.bias_ih, &mut scratch.gi);
    }

    /// One full step: `h ← GRU(x, h)` for `batch` rows (`x` contiguous `[batch, I]`, `h [batch, H]`).
    pub fn step(&self, x: &[f32], h: &mut [f32], batch: usize, scratch: &mut GruScratch) {
        self.project_input(x, self.config.inputs, batch, scratch);
        let GruScratch { gi, gh, rh, .. } = scratch;
        self.recur(gi, h, batch, gh, rh);
    }

    /// The recurrent half of a step, the input projection being already in `scratch.gi`.
    pub fn step_projected(&self, h: &mut [f32], batch: usize, scratch: &mut GruScratch) {
        let GruScratch { gi, gh, rh, .. } = scratch;
        self.recur(gi, h, batch, gh, rh);
    }

    /// The recurrent half of a step with an input projection held elsewhere (`gi [batch, 3H]`,
    /// e.g. a constant one-hot projection repeated over rows).
    pub fn step_with_projection(
        &self,
        gi: &[f32],
        h: &mut [f32],
        batch: usize,
        scratch: &mut GruScratch,
    ) {
        let GruScratch { gh, rh, .. } = scratch;
        self.recur(gi, h, batch, gh, rh);
    }

    fn recur(&self, gi: &[f32], h: &mut [f32], batch: usize, gh: &mut [f32], rh: &mut [f32]) {
        let hid = self.config.hidden;
        let g = 3 * hid;
        let (gi, h, gh) = (
            &gi[..batch * g],
            &mut h[..batch * hid],
            &mut gh[..batch * g],
        );
        let (bias_rz, bias_n) = self.bias_hh.split_at(2 * hid);
        // r and z first (rows 0..2H of U).
        MatMul::dense(batch, hid, 2 * hid).strided(hid, g).run_bias(
            h,
            &self.weight_hh_rz,
            bias_rz,
            gh,
        );
        match self.config.convention {
            GruConvention::PyTorch => {
                MatMul::dense(batch, hid, hid).strided(hid, g).run_bias(
                    h,
                    &self.weight_hh_n,
                    bias_n,
                    &mut gh[2 * hid..],
                );
                gates::pytorch_state_update(gi, gh, h, batch, hid);
            }
            GruConvention::Paper => {
                // The candidate from U_n (r ⊙ h).
                let rh = &mut rh[..batch * hid];
                gates::reset_times_hidden(gi, gh, h, rh, batch, hid);
                MatMul::dense(batch, hid, hid).strided(hid, g).run_bias(
                    rh,
                    &self.weight_hh_n,
                    bias_n,
                    &mut gh[2 * hid..],
                );
                gates::paper_state_update(gi, gh, h, batch, hid);
            }
        }
    }
}
