//! The multi-sample metrics of stochastic prediction as DLow (Yuan and Kitani 2020) and
//! BeLFusion (Barquero et al. 2023) compute them (`protocols_modern.md` §2.3): APD, ADE, FDE,
//! MMADE, MMFDE and CMD over `K` samples of each window.
//!
//! Conventions, stated once: a frame is one pose vector (`D` numbers, e.g. 16 root-relative joints
//! × 3 in metres) and every distance is the Euclidean norm of the **whole** pose vector, not a
//! per-joint mean. ADE is the smallest mean distance over the predicted frames among the samples,
//! FDE the smallest last-frame distance. The multimodal ground truth of window `n` is every
//! window `m` (of all windows scored together, `n` itself included) whose last observed pose lies
//! within the threshold of `n`'s ([`multimodal_sets`]); MMADE and MMFDE average ADE and FDE
//! against those windows' futures. APD is the mean distance over pairs of samples of the
//! flattened futures (0 for one sample); the mean over unordered pairs equals [`crate::apd`]'s
//! over ordered pairs.
//!
//! ```
//! use motion_metrics::multimodal::{score_sample_sets, SampleSets};
//! use ndarray::{Array2, Array3, Array4};
//!
//! // 2 windows, 3 samples, 4 frames, 2 numbers per pose.
//! let truth = Array3::from_shape_fn((2, 4, 2), |(n, t, _)| (n + t) as f64);
//! let samples = Array4::from_shape_fn((2, 3, 4, 2), |(n, k, t, _)| (n + t) as f64 + k as f64);
//! let last_observed = Array2::zeros((2, 2));
//! let scores = score_sample_sets(SampleSets {
//!     samples: samples.view(),
//!     truth: truth.view(),
//!     last_observed: last_observed.view(),
//!     threshold: 0.5,
//! })?;
//! assert_eq!(scores.mean.ade, 0.0); // sample 0 is the truth
//! # Ok::<(), motion_metrics::MetricError>(())
//! ```
use ndarray::{ArrayView1, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::{check_finite, check_not_empty, MetricError};

/// DLow's and BeLFusion's multimodal threshold on H3.6M (metres, on the 48-D last observed pose).
pub const H36M_MULTIMODAL_THRESHOLD: f64 = 0.5;

/// The inputs of [`score_sample_sets`].
#[derive(Debug, Clone, Copy)]
pub struct SampleSets<'a> {
    /// `N x K x T x D`: K samples of T predicted frames per window.
    pub samples: ArrayView4<'a, f64>,
    /// `N x T x D`: each window's real future.
    pub truth: ArrayView3<'a, f64>,
    /// `N x D`: each window's last observed pose (what the multimodal sets are built from).
    pub last_observed: ArrayView2<'a, f64>,
    /// The multimodal threshold on the last observed poses' distance (same units).
    pub threshold: f64,
}

/// The metrics of one window, or their means over windows.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SampleSetScores {
    /// Average pairwise distance of the samples (diversity; 0 for one sample).
    pub apd: f64,
    /// Smallest average displacement error over the samples.
    pub ade: f64,
    /// Smallest final displacement error over the samples.
    pub fde: f64,
    /// ADE averaged over the multimodal ground truth.
    pub mmade: f64,
    /// FDE averaged over the multimodal ground truth.
    pub mmfde: f64,
}

/// [`score_sample_sets`]'s result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SampleSetReport {
    /// Per window.
    pub windows: Vec<SampleSetScores>,
    /// The plain mean over windows.
    pub mean: SampleSetScores,
    /// The size of each window's multimodal set (itself included).
    pub multimodal_set_sizes: Vec<usize>,
}

/// Every window `m` whose last observed pose lies within `threshold` of window `n`'s (strictly
/// closer), for every `n` (`last_observed`: `N x D`); each set holds `n` itself.
pub fn multimodal_sets(last_observed: ArrayView2<'_, f64>, threshold: f64) -> Vec<Vec<usize>> {
    let n = last_observed.nrows();
    (0..n)
        .into_par_iter()
        .map(|i| {
            let a = last_observed.row(i);
            (0..n)
                .filter(|&m| m == i || distance(a, last_observed.row(m)) < threshold)
                .collect()
        })
        .collect()
}

/// APD, ADE, FDE, MMADE and MMFDE of every window and their means.
///
/// Errors: shapes that disagree, an empty input, a non-finite value, a threshold that is negative
/// or not finite.
pub fn score_sample_sets(sets: SampleSets<'_>) -> Result<SampleSetReport, MetricError> {
    let SampleSets {
        samples,
        truth,
        last_observed,
        threshold,
    } = sets;
    check_not_empty("samples", &samples)?;
    let (n, _, t, d) = samples.dim();
    if truth.dim() != (n, t, d) {
        return Err(MetricError::ShapeMismatch {
            what: "ground truth".into(),
            found: truth.shape().to_vec(),
            expected: vec![n, t, d],
        });
    }
    if last_observed.dim() != (n, d) {
        return Err(MetricError::ShapeMismatch {
            what: "last observed poses".into(),
            found: last_observed.shape().to_vec(),
            expected: vec![n, d],
        });
    }
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(MetricError::InvalidConfig(format!(
            "the multimodal threshold must be a finite distance >= 0, got {threshold:e}"
        )));
    }
    check_finite("samples", &samples)?;
    check_finite("ground truth", &truth)?;
    check_finite("last observed poses", &last_observed)?;
    let sets = multimodal_sets(last_observed, threshold);
    let windows = score_windows(samples, 0, truth, &sets);
    Ok(SampleSetReport {
        mean: mean_scores(&windows),
        windows,
        multimodal_set_sizes: sets.iter().map(Vec::len).collect(),
    })
}

/// The scores of the windows `first .. first + n` whose samples are `samples` (`n x K x T x D`),
/// against `truth` of **all** windows (`N x T x D`) and their multimodal `sets`
/// ([`multimodal_sets`]): what [`score_sample_sets`] computes, a chunk of windows at a time, for
/// evaluations whose samples do not fit in memory at once. Inputs are not checked here.
///
/// # Panics
/// If the chunk reaches past `truth` or `sets`, or the shapes disagree.
pub fn score_windows(
    samples: ArrayView4<'_, f64>,
    first: usize,
    truth: ArrayView3<'_, f64>,
    sets: &[Vec<usize>],
) -> Vec<SampleSetScores> {
    (0..samples.dim().0)
        .into_par_iter()
        .map(|c| {
            let i = first + c;
            let own = samples.index_axis(Axis(0), c);
            let (ade, fde) = best_errors(own, truth.index_axis(Axis(0), i));
            let (mut mmade, mut mmfde) = (0.0, 0.0);
            for &m in &sets[i] {
                let (a, f) = best_errors(own, truth.index_axis(Axis(0), m));
                mmade += a;
                mmfde += f;
            }
            let size = sets[i].len() as f64;
            SampleSetScores {
                apd: pairwise_mean(own),
                ade,
                fde,
                mmade: mmade / size,
                mmfde: mmfde / size,
            }
        })
        .collect()
}

/// The plain mean of per-window scores (all zero for none).
pub fn mean_scores(windows: &[SampleSetScores]) -> SampleSetScores {
    let n = windows.len().max(1) as f64;
    let mean_of = |f: fn(&SampleSetScores) -> f64| windows.iter().map(f).sum::<f64>() / n;
    SampleSetScores {
        apd: mean_of(|s| s.apd),
        ade: mean_of(|s| s.ade),
        fde: mean_of(|s| s.fde),
        mmade: mean_of(|s| s.mmade),
        mmfde: mean_of(|s| s.mmfde),
    }
}

/// `(min_k mean_t ‖Ŷ_kt − Y_t‖, min_k ‖Ŷ_kT − Y_T‖)` of `K x T x D` samples against `T x D`.
fn best_errors(samples: ArrayView3<'_, f64>, truth: ArrayView2<'_, f64>) -> (f64, f64) {
    let last = truth.nrows() - 1;
    let mut ade = f64::INFINITY;
    let mut fde = f64::INFINITY;
    for sample in samples.outer_iter() {
        let mean = sample
            .outer_iter()
            .zip(truth.outer_iter())
            .map(|(a, b)| distance(a, b))
            .sum::<f64>()
            / truth.nrows() as f64;
        ade = ade.min(mean);
        fde = fde.min(distance(sample.row(last), truth.row(last)));
    }
    (ade, fde)
}

/// Mean over unordered pairs of the distance between flattened samples (`K x T x D`).
fn pairwise_mean(samples: ArrayView3<'_, f64>) -> f64 {
    let k = samples.dim().0;
    if k < 2 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        for j in i + 1..k {
            sum += samples
                .index_axis(Axis(0), i)
                .iter()
                .zip(samples.index_axis(Axis(0), j).iter())
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
        }
    }
    sum / (k * (k - 1) / 2) as f64
}

fn distance(a: ArrayView1<'_, f64>, b: ArrayView1<'_, f64>) -> f64 {
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// CMD, the area between the cumulative motion distribution of the predictions and a reference
/// (BeLFusion `metrics/evaluation.py::cmd`): per window `v(t)` = the mean over samples and joints of
/// the joint displacement between predicted frames `t-1` and `t` (`t = 1..T-1`; poses of
/// `joints x 3` numbers); per class `V_c(t)` = the mean of `v(t)` over its windows and
/// `CMD_c = Σ_t (T − t)·|V_c(t) − μ_c|`; CMD = `Σ_c (N_c/N)·CMD_c`.
///
/// `samples`: `N x K x T x (3·J)`; `classes`: each window's class (an index into `reference`);
/// `reference`: `μ_c`, the mean real displacement per joint and frame of each class. BeLFusion's
/// `μ_c` were computed on the original H3.6M positions; values from another source give a
/// CMD of the same form, not the same number.
pub fn cmd(
    samples: ArrayView4<'_, f64>,
    classes: &[usize],
    reference: &[f64],
) -> Result<f64, MetricError> {
    check_not_empty("samples", &samples)?;
    check_finite("samples", &samples)?;
    let (n, _, t, d) = samples.dim();
    if classes.len() != n {
        return Err(MetricError::ShapeMismatch {
            what: "window classes".into(),
            found: vec![classes.len()],
            expected: vec![n],
        });
    }
    if !d.is_multiple_of(3) || t < 2 {
        return Err(MetricError::InvalidConfig(format!(
            "CMD needs poses of joints x 3 numbers and at least 2 frames; got {t} frames of {d}"
        )));
    }
    if let Some(&c) = classes.iter().find(|&&c| c >= reference.len()) {
        return Err(MetricError::InvalidConfig(format!(
            "window class {c} has no reference displacement ({} given)",
            reference.len()
        )));
    }
    let joints = d / 3;
    let per_window: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let set = samples.index_axis(Axis(0), i);
            (1..t)
                .map(|f| {
                    let mut sum = 0.0;
                    for sample in set.outer_iter() {
                        for j in 0..joints {
                            sum += (0..3)
                                .map(|c| {
                                    let v = sample[[f, 3 * j + c]] - sample[[f - 1, 3 * j + c]];
                                    v * v
                                })
                                .sum::<f64>()
                                .sqrt();
                        }
                    }
                    sum / (set.dim().0 * joints) as f64
                })
                .collect()
        })
        .collect();
    let mut total = 0.0;
    for (c, &mu) in reference.iter().enumerate() {
        let members: Vec<usize> = (0..n).filter(|&i| classes[i] == c).collect();
        if members.is_empty() {
            continue;
        }
        let mut area = 0.0;
        for f in 1..t {
            let v =
                members.iter().map(|&i| per_window[i][f - 1]).sum::<f64>() / members.len() as f64;
            area += (t - f) as f64 * (v - mu).abs();
        }
        total += members.len() as f64 / n as f64 * area;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3, Array4};

    /// The definitions written out with plain loops.
    fn naive(
        samples: &Array4<f64>,
        truth: &Array3<f64>,
        last: &Array2<f64>,
        threshold: f64,
    ) -> Vec<[f64; 5]> {
        let (n, k, t, d) = samples.dim();
        let dist = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let row = |a: &Array4<f64>, i, s, f| (0..d).map(|c| a[[i, s, f, c]]).collect::<Vec<_>>();
        let trow = |i, f| (0..d).map(|c| truth[[i, f, c]]).collect::<Vec<_>>();
        let ade_fde = |i: usize, m: usize| {
            let mut best = (f64::MAX, f64::MAX);
            for s in 0..k {
                let a = (0..t)
                    .map(|f| dist(&row(samples, i, s, f), &trow(m, f)))
                    .sum::<f64>()
                    / t as f64;
                let f = dist(&row(samples, i, s, t - 1), &trow(m, t - 1));
                best = (best.0.min(a), best.1.min(f));
            }
            best
        };
        (0..n)
            .map(|i| {
                let mut apd = 0.0;
                let mut pairs = 0.0;
                for a in 0..k {
                    for b in 0..k {
                        if a != b {
                            let x: Vec<f64> = (0..t).flat_map(|f| row(samples, i, a, f)).collect();
                            let y: Vec<f64> = (0..t).flat_map(|f| row(samples, i, b, f)).collect();
                            apd += dist(&x, &y);
                            pairs += 1.0;
                        }
                    }
                }
                let (ade, fde) = ade_fde(i, i);
                let li: Vec<f64> = last.row(i).to_vec();
                let set: Vec<usize> = (0..n)
                    .filter(|&m| dist(&li, &last.row(m).to_vec()) < threshold)
                    .collect();
                let mm: Vec<(f64, f64)> = set.iter().map(|&m| ade_fde(i, m)).collect();
                [
                    if pairs > 0.0 { apd / pairs } else { 0.0 },
                    ade,
                    fde,
                    mm.iter().map(|p| p.0).sum::<f64>() / mm.len() as f64,
                    mm.iter().map(|p| p.1).sum::<f64>() / mm.len() as f64,
                ]
            })
            .collect()
    }

    #[test]
    fn the_metrics_agree_with_the_definitions_written_out() {
        let samples = Array4::from_shape_fn((6, 4, 5, 6), |(n, k, t, d)| {
            (0.3 * n as f64 + 1.1 * k as f64 + 0.2 * t as f64 * d as f64).sin()
        });
        let truth = Array3::from_shape_fn((6, 5, 6), |(n, t, d)| {
            (0.5 * n as f64 + 0.15 * t as f64 + d as f64).cos()
        });
        let last = Array2::from_shape_fn((6, 6), |(n, d)| 0.2 * ((n * 3 + d) % 4) as f64);
        let report = score_sample_sets(SampleSets {
            samples: samples.view(),
            truth: truth.view(),
            last_observed: last.view(),
            threshold: 0.5,
        })
        .unwrap();
        let expected = naive(&samples, &truth, &last, 0.5);
        assert!(report.multimodal_set_sizes.iter().any(|&s| s > 1));
        for (got, want) in report.windows.iter().zip(&expected) {
            let got = [got.apd, got.ade, got.fde, got.mmade, got.mmfde];
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-12, "{got:?} vs {want:?}");
            }
        }
        let mean_ade = expected.iter().map(|e| e[1]).sum::<f64>() / 6.0;
        assert!((report.mean.ade - mean_ade).abs() < 1e-12);
        let flat = samples
            .index_axis(Axis(0), 2)
            .into_shape_with_order((4, 30))
            .unwrap()
            .to_owned();
        assert!((report.windows[2].apd - crate::apd(flat.view()).unwrap()).abs() < 1e-12);
    }

    #[test]
    fn chunks_of_windows_give_the_whole_runs_scores() {
        let samples = Array4::from_shape_fn((7, 3, 4, 6), |(n, k, t, d)| {
            (0.4 * n as f64 + 0.9 * k as f64 + 0.3 * t as f64 + d as f64).sin()
        });
        let truth = Array3::from_shape_fn((7, 4, 6), |(n, t, d)| (0.2 * (n + t + d) as f64).cos());
        let last = Array2::from_shape_fn((7, 6), |(n, d)| 0.1 * ((n + d) % 3) as f64);
        let whole = score_sample_sets(SampleSets {
            samples: samples.view(),
            truth: truth.view(),
            last_observed: last.view(),
            threshold: 0.3,
        })
        .unwrap();
        let sets = multimodal_sets(last.view(), 0.3);
        let mut chunked = score_windows(
            samples.slice(ndarray::s![0..3, .., .., ..]),
            0,
            truth.view(),
            &sets,
        );
        chunked.extend(score_windows(
            samples.slice(ndarray::s![3..7, .., .., ..]),
            3,
            truth.view(),
            &sets,
        ));
        assert_eq!(chunked, whole.windows);
        assert_eq!(mean_scores(&chunked), whole.mean);
    }

    #[test]
    fn one_sample_has_no_diversity_and_a_threshold_of_zero_keeps_each_window_alone() {
        let truth = Array3::from_shape_fn((3, 4, 3), |(n, t, d)| (n * t + d) as f64);
        let samples = truth.clone().insert_axis(Axis(1));
        let last = Array2::zeros((3, 3));
        let report = score_sample_sets(SampleSets {
            samples: samples.view(),
            truth: truth.view(),
            last_observed: last.view(),
            threshold: 0.0,
        })
        .unwrap();
        assert_eq!(report.multimodal_set_sizes, vec![1, 1, 1]);
        assert_eq!(report.mean.apd, 0.0);
        assert_eq!(report.mean.mmade, 0.0);
    }

    #[test]
    fn cmd_follows_its_definition() {
        // One joint moving 1 per frame in x in class 0, 2 per frame in class 1.
        let samples = Array4::from_shape_fn((3, 2, 4, 3), |(n, _, t, c)| {
            if c == 0 {
                t as f64 * if n == 2 { 2.0 } else { 1.0 }
            } else {
                0.0
            }
        });
        let got = cmd(samples.view(), &[0, 0, 1], &[0.5, 2.0]).unwrap();
        // Class 0: |1 - 0.5| x (3 + 2 + 1) = 3, weight 2/3; class 1: 0.
        assert!((got - 2.0).abs() < 1e-12);
        assert!(cmd(samples.view(), &[0, 0], &[0.5, 2.0]).is_err());
        assert!(cmd(samples.view(), &[0, 0, 2], &[0.5, 2.0]).is_err());
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let truth = Array3::<f64>::zeros((2, 4, 3));
        let samples = Array4::<f64>::zeros((2, 3, 4, 3));
        let last = Array2::<f64>::zeros((2, 3));
        let sets = |threshold| SampleSets {
            samples: samples.view(),
            truth: truth.view(),
            last_observed: last.view(),
            threshold,
        };
        assert!(matches!(
            score_sample_sets(sets(f64::NAN)),
            Err(MetricError::InvalidConfig(_))
        ));
        let wrong = Array3::<f64>::zeros((2, 5, 3));
        assert!(matches!(
            score_sample_sets(SampleSets {
                truth: wrong.view(),
                ..sets(0.5)
            }),
            Err(MetricError::ShapeMismatch { .. })
        ));
        let mut bad = samples.clone();
        bad[[1, 2, 3, 0]] = f64::INFINITY;
        assert!(matches!(
            score_sample_sets(SampleSets {
                samples: bad.view(),
                ..sets(0.5)
            }),
            Err(MetricError::NonFinite { .. })
        ));
    }
}
