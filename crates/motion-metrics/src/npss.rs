//! NPSS, the normalized power spectrum similarity of paper 000 (section 3.5), exactly as
//! `metrics.md` defines it: per sequence and dim, the earth mover's distance between the
//! normalized power spectra (the L1 distance of their **cumulative** sums), averaged with the
//! ground truth's total power as weight.
//!
//! Two spectra are offered: the paper's `|DFT|²` ([`SpectrumPower::Modulus`], the default) and
//! the published implementation's `Re(DFT)²` ([`SpectrumPower::RealPart`]), which is what every
//! published NPSS number was computed with.
use std::sync::Arc;

use ndarray::{s, ArrayView3};
use rayon::prelude::*;
use rustfft::{num_complex::Complex, Fft, FftPlanner};

use crate::error::{check_finite, check_not_empty, MetricError};

/// Which power spectrum NPSS compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumPower {
    /// `|DFT|²`, the paper's definition.
    Modulus,
    /// `Re(DFT)²`: the published code stored the complex coefficients in a real array, dropping
    /// the imaginary part. Reproduces the papers' tables.
    RealPart,
}

impl SpectrumPower {
    fn of(self, c: Complex<f64>) -> f64 {
        match self {
            SpectrumPower::Modulus => c.re * c.re + c.im * c.im,
            SpectrumPower::RealPart => c.re * c.re,
        }
    }
}

/// A time window of the prediction on which NPSS is computed with its own DFT (paper 000 Table 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NpssWindow {
    /// Human-readable name, e.g. `"0-1 s"`.
    pub label: &'static str,
    /// First frame (inclusive).
    pub start: usize,
    /// One past the last frame.
    pub end: usize,
}

/// The windows 0-1 s, 1-2 s and 2-4 s at 25 Hz: frames 0-24, 25-49, 50-99.
pub const NPSS_WINDOWS_25HZ: [NpssWindow; 3] = [
    NpssWindow {
        label: "0-1 s",
        start: 0,
        end: 25,
    },
    NpssWindow {
        label: "1-2 s",
        start: 25,
        end: 50,
    },
    NpssWindow {
        label: "2-4 s",
        start: 50,
        end: 100,
    },
];

/// The NPSS of one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowScore {
    /// The window.
    pub window: NpssWindow,
    /// Its NPSS.
    pub value: f64,
}

/// A reusable NPSS evaluator: keeps one FFT planner so that repeated calls with the same
/// sequence length reuse the plan.
pub struct Npss {
    planner: FftPlanner<f64>,
}

impl Default for Npss {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for Npss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Npss")
    }
}

/// Per-thread work buffers: the DFTs of one sequence's ground truth and prediction, dim-major.
struct SequenceBuffers {
    gt: Vec<Complex<f64>>,
    pred: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    cumulative_gt: Vec<f64>,
}

impl Npss {
    /// A new evaluator with an empty plan cache.
    pub fn new() -> Self {
        Self {
            planner: FftPlanner::new(),
        }
    }

    /// NPSS of `pred` against `gt`, both `N x T x D` (sequences x frames x dims).
    ///
    /// Errors: shapes differ, an axis is empty, a value is not finite, or every ground-truth
    /// (sequence, dim) has zero total power (NPSS is then undefined).
    pub fn score(
        &mut self,
        gt: ArrayView3<'_, f64>,
        pred: ArrayView3<'_, f64>,
        power: SpectrumPower,
    ) -> Result<f64, MetricError> {
        check_inputs(&gt, &pred)?;
        let (_, frames, dims) = gt.dim();
        let fft = self.planner.plan_fft_forward(frames);
        let per_sequence = weighted_emd_per_sequence(&fft, gt, pred, power, frames, dims);
        // Summed in sequence order so that the result does not depend on the thread count.
        let (weighted, total) = per_sequence
            .iter()
            .fold((0.0, 0.0), |(a, b), (w, t)| (a + w, b + t));
        if total == 0.0 {
            return Err(MetricError::Undefined {
                metric: "NPSS",
                reason:
                    "the ground truth has zero power in every sequence and dim (all weights are 0)"
                        .into(),
            });
        }
        Ok(weighted / total)
    }

    /// NPSS on each window of `windows` that lies inside the `T` frames (a window reaching past
    /// the end is left out), each with its own DFT.
    pub fn score_windows(
        &mut self,
        gt: ArrayView3<'_, f64>,
        pred: ArrayView3<'_, f64>,
        power: SpectrumPower,
        windows: &[NpssWindow],
    ) -> Result<Vec<WindowScore>, MetricError> {
        check_inputs(&gt, &pred)?;
        let frames = gt.dim().1;
        windows
            .iter()
            .filter(|w| w.start < w.end && w.end <= frames)
            .map(|&window| {
                let range = s![.., window.start..window.end, ..];
                let value = self.score(gt.slice(range), pred.slice(range), power)?;
                Ok(WindowScore { window, value })
            })
            .collect()
    }
}

fn check_inputs(gt: &ArrayView3<'_, f64>, pred: &ArrayView3<'_, f64>) -> Result<(), MetricError> {
    check_not_empty("ground truth", gt)?;
    if gt.shape() != pred.shape() {
        return Err(MetricError::ShapeMismatch {
            what: "prediction".into(),
            found: pred.shape().to_vec(),
            expected: gt.shape().to_vec(),
        });
    }
    check_finite("ground truth", gt)?;
    check_finite("prediction", pred)
}

/// For every sequence: (Σ_j w_ij · emd_ij, Σ_j w_ij).
fn weighted_emd_per_sequence(
    fft: &Arc<dyn Fft<f64>>,
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
    power: SpectrumPower,
    frames: usize,
    dims: usize,
) -> Vec<(f64, f64)> {
    let scratch_len = fft.get_inplace_scratch_len();
    (0..gt.dim().0)
        .into_par_iter()
        .map_init(
            || SequenceBuffers {
                gt: vec![Complex::default(); frames * dims],
                pred: vec![Complex::default(); frames * dims],
                scratch: vec![Complex::default(); scratch_len],
                cumulative_gt: vec![0.0; frames],
            },
            |buffers, i| {
                load_dim_major(gt.slice(s![i, .., ..]), &mut buffers.gt);
                load_dim_major(pred.slice(s![i, .., ..]), &mut buffers.pred);
                // One call transforms all D contiguous series of length T.
                fft.process_with_scratch(&mut buffers.gt, &mut buffers.scratch);
                fft.process_with_scratch(&mut buffers.pred, &mut buffers.scratch);
                let mut weighted = 0.0;
                let mut total = 0.0;
                for j in 0..dims {
                    let series = j * frames..(j + 1) * frames;
                    let (emd, weight) = spectral_emd(
                        &buffers.gt[series.clone()],
                        &buffers.pred[series],
                        power,
                        &mut buffers.cumulative_gt,
                    );
                    weighted += weight * emd;
                    total += weight;
                }
                (weighted, total)
            },
        )
        .collect()
}

/// Copies a `T x D` sequence into `D` contiguous complex series of length `T`.
fn load_dim_major(sequence: ndarray::ArrayView2<'_, f64>, out: &mut [Complex<f64>]) {
    let frames = sequence.nrows();
    for ((t, j), &v) in sequence.indexed_iter() {
        out[j * frames + t] = Complex::new(v, 0.0);
    }
}

/// The EMD between the normalized power spectra of one dim (the L1 distance of their cumulative
/// sums) and the ground truth's total power (the weight). A spectrum of total power 0 stays 0.
fn spectral_emd(
    gt: &[Complex<f64>],
    pred: &[Complex<f64>],
    power: SpectrumPower,
    cumulative_gt: &mut [f64],
) -> (f64, f64) {
    let gt_total: f64 = gt.iter().map(|&c| power.of(c)).sum();
    let pred_total: f64 = pred.iter().map(|&c| power.of(c)).sum();
    let gt_scale = if gt_total > 0.0 { 1.0 / gt_total } else { 0.0 };
    let pred_scale = if pred_total > 0.0 {
        1.0 / pred_total
    } else {
        0.0
    };
    let mut running = 0.0;
    for (c, out) in gt.iter().zip(cumulative_gt.iter_mut()) {
        running += power.of(*c) * gt_scale;
        *out = running;
    }
    let mut running = 0.0;
    let mut emd = 0.0;
    for (c, cg) in pred.iter().zip(cumulative_gt.iter()) {
        running += power.of(*c) * pred_scale;
        emd += (running - cg).abs();
    }
    (emd, gt_total)
}

/// NPSS with the paper's `|DFT|²` power spectrum over the whole sequences (`N x T x D`).
pub fn npss(gt: ArrayView3<'_, f64>, pred: ArrayView3<'_, f64>) -> Result<f64, MetricError> {
    Npss::new().score(gt, pred, SpectrumPower::Modulus)
}

/// NPSS as the published implementation computes it (`Re(DFT)²`), reproducing the papers' numbers.
pub fn npss_reference(
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
) -> Result<f64, MetricError> {
    Npss::new().score(gt, pred, SpectrumPower::RealPart)
}

/// NPSS on the 0-1 s, 1-2 s and 2-4 s windows of 25 Hz sequences (those that fit in `T`).
pub fn npss_windows(
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
    power: SpectrumPower,
) -> Result<Vec<WindowScore>, MetricError> {
    Npss::new().score_windows(gt, pred, power, &NPSS_WINDOWS_25HZ)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// 0 <= NPSS <= T - 1 (each EMD of cumulative spectra is at most T - 1), NPSS(x, x) = 0.
        #[test]
        fn npss_is_bounded(
            frames in 2usize..40,
            values in proptest::collection::vec(-10.0f64..10.0, 2 * 40 * 3 * 2),
        ) {
            let len = 2 * frames * 3;
            let gt = Array3::from_shape_vec((2, frames, 3), values[..len].to_vec()).unwrap();
            let pred = Array3::from_shape_vec((2, frames, 3), values[len..2 * len].to_vec()).unwrap();
            for power in [SpectrumPower::Modulus, SpectrumPower::RealPart] {
                let mut npss = Npss::new();
                if let Ok(v) = npss.score(gt.view(), pred.view(), power) {
                    prop_assert!(v >= 0.0 && v <= (frames - 1) as f64 + 1e-9, "{v}");
                    prop_assert_eq!(npss.score(gt.view(), gt.view(), power).unwrap(), 0.0);
                }
            }
        }
    }
}
