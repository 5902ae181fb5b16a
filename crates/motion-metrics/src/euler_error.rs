//! The Euler-angle error of the standard H3.6M protocol ("MSE" in the papers' tables), as
//! `h36m.md` defines it: per sequence, keep the dims whose ground-truth standard deviation over the
//! predicted frames exceeds 1e-4; per frame, the square root of the sum of squared differences
//! over those dims; then the mean over sequences.
//!
//! Inputs are Euler sequences already (see `motion_core::protocol` for the conversion from
//! exp-maps, which also zeroes dims 0..5).
use ndarray::{ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

use crate::error::{check_finite, check_not_empty, MetricError};

/// A dim is used when the ground truth's (population) standard deviation over the predicted
/// frames exceeds this.
pub const STD_THRESHOLD: f64 = 1e-4;

/// The horizons the papers report, in milliseconds.
pub const EULER_HORIZONS_MS: [u32; 6] = [80, 160, 320, 400, 560, 1000];

/// The 0-based predicted frames of [`EULER_HORIZONS_MS`] at 25 Hz (40 ms per frame).
pub const EULER_HORIZON_FRAMES_25HZ: [usize; 6] = [1, 3, 7, 9, 13, 24];

/// The mean Euler error over sequences, per predicted frame. `gt` and `pred` are `N x T x D`.
pub fn euler_error(
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
) -> Result<Vec<f64>, MetricError> {
    check_not_empty("ground truth", &gt)?;
    if gt.shape() != pred.shape() {
        return Err(MetricError::ShapeMismatch {
            what: "prediction".into(),
            found: pred.shape().to_vec(),
            expected: gt.shape().to_vec(),
        });
    }
    check_finite("ground truth", &gt)?;
    check_finite("prediction", &pred)?;
    let (sequences, frames, _) = gt.dim();
    let per_sequence: Vec<Vec<f64>> = (0..sequences)
        .into_par_iter()
        .map(|i| sequence_error(gt.index_axis(Axis(0), i), pred.index_axis(Axis(0), i)))
        .collect();
    // Summed in sequence order: the result does not depend on the thread count.
    let mut mean = vec![0.0; frames];
    for errors in &per_sequence {
        for (m, e) in mean.iter_mut().zip(errors) {
            *m += e;
        }
    }
    for m in &mut mean {
        *m /= sequences as f64;
    }
    Ok(mean)
}

/// The per-frame error of one `T x D` sequence.
fn sequence_error(gt: ArrayView2<'_, f64>, pred: ArrayView2<'_, f64>) -> Vec<f64> {
    let frames = gt.nrows() as f64;
    let used: Vec<usize> = gt
        .axis_iter(Axis(1))
        .enumerate()
        .filter(|(_, column)| {
            let mean = column.sum() / frames;
            let variance = column.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / frames;
            variance.sqrt() > STD_THRESHOLD
        })
        .map(|(j, _)| j)
        .collect();
    gt.outer_iter()
        .zip(pred.outer_iter())
        .map(|(g, p)| {
            used.iter()
                .map(|&j| (g[j] - p[j]) * (g[j] - p[j]))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// The error at the papers' horizons (80, 160, 320, 400, 560, 1000 ms) from a 25 Hz per-frame
/// series; `None` where the series is too short.
pub fn euler_error_at_horizons(per_frame: &[f64]) -> [(u32, Option<f64>); 6] {
    let mut out = [(0, None); 6];
    for (slot, (&ms, &frame)) in out.iter_mut().zip(
        EULER_HORIZONS_MS
            .iter()
            .zip(EULER_HORIZON_FRAMES_25HZ.iter()),
    ) {
        *slot = (ms, per_frame.get(frame).copied());
    }
    out
}
