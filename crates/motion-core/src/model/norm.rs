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

/// The smallest std of a used dim a weights file may carry (motion dims vary by far more).
pub const MIN_STD: f32 = 1e-6;
/// The largest mean of a used dim, in size (millimetres and radians stay far below).
pub const MAX_MEAN: f32 = 1e7;

impl Normalization {
    /// Reads `norm.mean` and `norm.std` (`[frame_dims]`); rejects, on a used dim, a std that is
    /// not finite or below [`MIN_STD`] (dividing by it overflows f32) and a mean that is not
    /// finite or larger than [`MAX_MEAN`] in size.
    pub fn load(
        store: &WeightStore,
        frame_dims: usize,
        dims_used: &[usize],
    ) -> Result<Self, WeightsError> {
        let mean = store.tensor("norm.mean", &[frame_dims])?;
        let std = store.tensor("norm.std", &[frame_dims])?;
        let bad = |tensor: &str, problem: String| WeightsError::InvalidTensor {
            path: store.path().to_path_buf(),
            tensor: tensor.into(),
            problem,
        };
        if let Some(&d) = dims_used
            .iter()
            .find(|&&d| !(std[d].is_finite() && std[d].abs() >= MIN_STD))
        {
            return Err(bad(
                "norm.std",
                format!(
                    "std of used dim {d} is {:e}, outside {MIN_STD:e} ..= finite",
                    std[d]
                ),
            ));
        }
        if let Some(&d) = dims_used
            .iter()
            .find(|&&d| !(mean[d].is_finite() && mean[d].abs() <= MAX_MEAN))
        {
            return Err(bad(
                "norm.mean",
                format!(
                    "mean of used dim {d} is {:e}, larger than {MAX_MEAN:e} in size",
                    mean[d]
                ),
            ));
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
