//! A pose prior in the closed loop: per action, a Gaussian of real body poses in the model's
//! normalized used dims (`training/pose_prior.py` makes it from the H3.6M training subjects),
//! applied to every generated frame before it is fed back, so that a model whose postures drift
//! out of what people do (arms held up after a minute of walking) is pulled back to the edge of
//! the real ones. The root's dims are never changed.
//!
//! For a row doing action `a` and a frame `y` (normalized used dims): `z = C_a (y - μ_a)`,
//! `m = sqrt(mean_k (z_k · inv_std_ak)²)` over the axes with a positive `inv_std` (about 1 for
//! real poses); when `m > r`
//! (`config.prior_radius`), `y ← y - (1 - r / m) · C_aᵀ z`. Tensors: `prior.mean [A, O]`,
//! `prior.components [A, O, O]` (rows orthonormal, zero on the root's dims), `prior.inv_std
//! [A, O]`, with `A` the model's actions (1 for an unconditioned model). No allocation per frame.
use super::weights::{WeightStore, WeightsError};

/// A loaded pose prior (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PosePrior {
    radius: f32,
    dims: usize,
    groups: usize,
    mean: Vec<f32>,
    components: Vec<f32>,
    inv_std: Vec<f32>,
    /// Per group, the axes with a positive `inv_std` (what `m` averages over).
    axes: Vec<f32>,
}

impl PosePrior {
    /// Reads `prior.*` for `groups` actions (at least 1) of `dims` used dims.
    ///
    /// # Errors
    /// A tensor missing, of another shape or not finite; a radius that is not positive.
    pub fn load(
        store: &WeightStore,
        radius: f64,
        groups: usize,
        dims: usize,
    ) -> Result<PosePrior, WeightsError> {
        let groups = groups.max(1);
        if !(radius.is_finite() && radius > 0.0) {
            return Err(WeightsError::BadConfig {
                path: store.path().to_path_buf(),
                key: "config".into(),
                problem: format!("prior_radius {radius:e} is not a positive number"),
            });
        }
        let inv_std = store.tensor("prior.inv_std", &[groups, dims])?;
        let axes = inv_std
            .chunks(dims.max(1))
            .map(|g| g.iter().filter(|&&v| v > 0.0).count().max(1) as f32)
            .collect();
        Ok(PosePrior {
            radius: radius as f32,
            dims,
            groups,
            mean: store.tensor("prior.mean", &[groups, dims])?,
            components: store.tensor("prior.components", &[groups, dims, dims])?,
            inv_std,
            axes,
        })
    }

    /// The radius `r` in standard deviations (root mean square over the axes).
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Scratch values [`apply`](Self::apply) needs.
    pub fn scratch_len(&self) -> usize {
        self.dims
    }

    /// Pulls `frame` (normalized used dims) of a row doing action `group` (its index in the
    /// model's actions; 0 for an unconditioned model, clamped) to the prior's radius; returns
    /// whether it moved. `scratch` holds [`scratch_len`](Self::scratch_len) values.
    pub fn apply(&self, group: usize, frame: &mut [f32], scratch: &mut [f32]) -> bool {
        let o = self.dims;
        let g = group.min(self.groups - 1);
        let mean = &self.mean[g * o..(g + 1) * o];
        let comps = &self.components[g * o * o..(g + 1) * o * o];
        let inv = &self.inv_std[g * o..(g + 1) * o];
        let z = &mut scratch[..o];
        let mut sum = 0.0f32;
        for (k, zk) in z.iter_mut().enumerate() {
            let row = &comps[k * o..(k + 1) * o];
            let v: f32 = row
                .iter()
                .zip(frame.iter().zip(mean))
                .map(|(c, (y, m))| c * (y - m))
                .sum();
            *zk = v;
            let s = v * inv[k];
            sum += s * s;
        }
        let m = (sum / self.axes[g]).sqrt();
        // A NaN `m` (a NaN frame) is left alone, like one inside the radius.
        if m.is_nan() || m <= self.radius {
            return false;
        }
        let shrink = 1.0 - self.radius / m;
        for (k, zk) in z.iter().enumerate() {
            let row = &comps[k * o..(k + 1) * o];
            let w = shrink * zk;
            for (y, c) in frame.iter_mut().zip(row) {
                *y -= w * c;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prior(radius: f32) -> PosePrior {
        // Two dims: a root dim (untouched: zero components) and a body dim of std 2.
        PosePrior {
            radius,
            dims: 2,
            groups: 1,
            mean: vec![0.0, 1.0],
            components: vec![0.0, 1.0, 0.0, 0.0],
            inv_std: vec![0.5, 0.0],
            axes: vec![1.0],
        }
    }

    #[test]
    fn frames_beyond_the_radius_come_back_to_it_and_others_stay() {
        let p = prior(1.0);
        let mut scratch = [0.0; 2];
        // m = |3 - 1| * 0.5 = 1: inside (not beyond).
        let mut inside = [5.0, 3.0];
        assert!(!p.apply(0, &mut inside, &mut scratch));
        assert_eq!(inside, [5.0, 3.0]);
        // m = |9 - 1| * 0.5 = 4: shrunk to 1 (the body dim at 1 + 2).
        let mut outside = [5.0, 9.0];
        assert!(p.apply(0, &mut outside, &mut scratch));
        assert_eq!(outside[0], 5.0);
        assert!((outside[1] - 3.0).abs() < 1e-5, "{outside:?}");
        // A group beyond the prior's is its last.
        let mut again = [5.0, 9.0];
        assert!(p.apply(7, &mut again, &mut scratch));
        assert_eq!(again, outside);
    }
}
