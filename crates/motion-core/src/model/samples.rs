//! Several predictions from one seed: the batch every front end (CLI `predict --samples`, the
//! Python bindings) draws samples with.
use std::sync::Arc;

use ndarray::{s, Array3, ArrayView2};

use super::batch::{BatchGenerator, Noise};
use super::generate_error::GenerateError;
use super::predictor::MotionModel;

/// The most values `samples x frames x frame_dims` one [`generate_samples`] call returns
/// ([`crate::limits::MAX_CLIP_VALUES`], 256 MiB of f64): more is refused up front
/// ([`GenerateError::TooLarge`]); generate in several calls.
pub const MAX_SAMPLE_VALUES: usize = crate::limits::MAX_CLIP_VALUES;

/// Checks that `samples` predictions of `frames` frames of `frame_dims` values fit
/// [`MAX_SAMPLE_VALUES`] (with no overflow on the way).
pub fn check_sample_size(
    samples: usize,
    frames: usize,
    frame_dims: usize,
) -> Result<(), GenerateError> {
    let values = samples
        .checked_mul(frames)
        .and_then(|v| v.checked_mul(frame_dims));
    match values {
        Some(v) if v <= MAX_SAMPLE_VALUES => Ok(()),
        _ => Err(GenerateError::TooLarge {
            samples,
            frames,
            frame_dims,
            limit: MAX_SAMPLE_VALUES,
        }),
    }
}

/// `samples` closed-loop predictions of `frames` frames each after `seed` (`S x frame_dims`
/// at the model's rate, `S >= 1`; the model reads all of it), conditioned on `action`:
/// `[samples, frames, frame_dims]` in f64. Sample `i` draws its noise (VGRU-d's plan noise, the
/// intention model's `z`) from
/// `StdRng::seed_from_u64(rng_seed + i)` (wrapping), so sample `i` is the same whatever the
/// sample count.
pub fn generate_samples(
    model: &Arc<MotionModel>,
    seed: ArrayView2<'_, f64>,
    action: Option<&str>,
    frames: usize,
    samples: usize,
    rng_seed: u64,
) -> Result<Array3<f64>, GenerateError> {
    let n = samples.max(1);
    check_sample_size(n, frames, model.config().frame_dims)?;
    let mut generator = BatchGenerator::new(Arc::clone(model), n);
    let seeds = seed
        .broadcast((n, seed.nrows(), seed.ncols()))
        .expect("a 2-D seed broadcasts along a new first axis");
    let actions: Vec<&str> = action.into_iter().collect();
    let noise: Vec<Noise<'_>> = (0..n as u64)
        .map(|i| Noise::Seed(rng_seed.wrapping_add(i)))
        .collect();
    generator.start(seeds, &actions, &noise)?;
    let mut out = Array3::zeros((n, frames, model.config().frame_dims));
    for t in 0..frames {
        let step = generator.step()?;
        for (i, row) in step.outer_iter().enumerate() {
            out.slice_mut(s![i, t, ..])
                .zip_mut_with(&row, |o, &v| *o = f64::from(v));
            if let Some(dim) = row.iter().position(|v| !v.is_finite()) {
                return Err(GenerateError::NonFiniteOutput {
                    sample: i,
                    frame: t,
                    dim,
                });
            }
        }
    }
    Ok(out)
}
