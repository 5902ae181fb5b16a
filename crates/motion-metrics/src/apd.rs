//! APD, the average pairwise distance of a set of samples of one forecast (Tanke et al. 2021, Table 5):
//! the mean over ordered pairs `i != j` of the Euclidean distance between the flattened samples.
use ndarray::{ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

use crate::error::{check_finite, check_not_empty, MetricError};

/// APD of `S` samples, each flattened to one row (`S x L`). 0 for one sample.
pub fn apd(samples: ArrayView2<'_, f64>) -> Result<f64, MetricError> {
    check_not_empty("samples", &samples)?;
    check_finite("samples", &samples)?;
    Ok(apd_unchecked(samples))
}

/// APD of every forecast of `N x S x L` samples, and their mean over the `N` forecasts.
pub fn apd_batch(samples: ArrayView3<'_, f64>) -> Result<(Vec<f64>, f64), MetricError> {
    check_not_empty("samples", &samples)?;
    check_finite("samples", &samples)?;
    let per_forecast: Vec<f64> = (0..samples.dim().0)
        .into_par_iter()
        .map(|i| apd_unchecked(samples.index_axis(Axis(0), i)))
        .collect();
    let mean = per_forecast.iter().sum::<f64>() / per_forecast.len() as f64;
    Ok((per_forecast, mean))
}

fn apd_unchecked(samples: ArrayView2<'_, f64>) -> f64 {
    let count = samples.nrows();
    if count < 2 {
        return 0.0;
    }
    // The distance is symmetric: sum the unordered pairs once, the ordered mean is the same.
    let mut sum = 0.0;
    for i in 0..count {
        let a = samples.row(i);
        for j in i + 1..count {
            let b = samples.row(j);
            sum += a
                .iter()
                .zip(b.iter())
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt();
        }
    }
    sum / (count * (count - 1) / 2) as f64
}
