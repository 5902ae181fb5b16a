//! Normalization between full frames (what callers see) and the model's normalized used dims.
//!
//! `normalize`: `(x[d] - mean[d]) / std[d]` for each used dim `d`; `unnormalize`: `y * std + mean`
//! on the used dims, dropped dims restored to the mean — the same f32 arithmetic as
//! `training/features.py`.
use super::weights::{WeightStore, WeightsError};

/// Full-frame mean and std (`norm.mean`, `norm.std`) and the used dims.
#[derive(Debug, Clone)]
pub struct Normalization {
    mean: Vec<f32>,
    std: Vec<f32>,
    dims_used: Vec<usize>,
}

impl Normalization {
    /// Reads `norm.mean` and `norm.std` (`[frame_dims]`); rejects a zero std on a used dim.
    pub fn load(
        store: &WeightStore,
        frame_dims: usize,
        dims_used: &[usize],
    ) -> Result<Self, WeightsError> {
        let mean = store.tensor("norm.mean", &[frame_dims])?;
        let std = store.tensor("norm.std", &[frame_dims])?;
        if let Some(&d) = dims_used.iter().find(|&&d| std[d] == 0.0) {
            return Err(WeightsError::InvalidTensor {
                path: store.path().to_path_buf(),
                tensor: "norm.std".into(),
                problem: format!("std of used dim {d} is 0"),
            });
        }
        Ok(Self {
            mean,
            std,
            dims_used: dims_used.to_vec(),
        })
    }

    /// Full-frame mean.
    pub fn mean(&self) -> &[f32] {
        &self.mean
    }

    /// Full-frame std.
    pub fn std(&self) -> &[f32] {
        &self.std
    }

    /// Full frame width.
    pub fn frame_dims(&self) -> usize {
        self.mean.len()
    }

    /// Full frame `full [frame_dims]` -> normalized used dims `out [O]`.
    #[inline]
    pub fn normalize(&self, full: &[f32], out: &mut [f32]) {
        for (o, &d) in out.iter_mut().zip(&self.dims_used) {
            *o = (full[d] - self.mean[d]) / self.std[d];
        }
    }

    /// Normalized used dims `y [O]` -> full frame `full [frame_dims]` (dropped dims = mean).
    #[inline]
    pub fn unnormalize(&self, y: &[f32], full: &mut [f32]) {
        full.copy_from_slice(&self.mean);
        for (v, &d) in y.iter().zip(&self.dims_used) {
            full[d] = v * self.std[d] + self.mean[d];
        }
    }
}
