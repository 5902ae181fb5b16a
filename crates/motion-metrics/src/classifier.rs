//! The action-classifier protocol of Ghosh et al. 2017 (section 4.5, Figures 4-5): a separately trained
//! classifier ([`ActionClassifier`]) slides over generated motion of any length; the probability it
//! gives the seed's action, second by second, is the quality curve. Real motion keeps it high;
//! motion that freezes or degrades loses it.
//!
//! Definition (stated once here). Predictions are `N x H` frames at the classifier's rate (25 Hz
//! for the shipped file), optionally preceded by each sequence's seed (`N x S` frames). Windows of
//! `W = config.window` frames (2 s) end every `hop` frames (1 s) after the seed: window `k`
//! (`k = 1, 2, ...`) ends at `e_k = k * hop` predicted frames and holds frames `e_k - W .. e_k`,
//! where negative indices are the seed's last frames. A window is scored only if it is complete
//! (without a seed, the first window ends at `W`). For each window end `t_k = e_k / fps` seconds:
//! - `prob[k]`: mean over the `N` sequences of the probability of the named action;
//! - `top1[k]`: fraction of sequences whose most probable class is the named action;
//! - `mean_probabilities[k][a]`: mean probability of every class `a` (Figure 5's curves).
//!
//! ```
//! use motion_core::model::ActionClassifier;
//! use motion_metrics::classifier_curve;
//! use ndarray::Array3;
//!
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/parity/action_classifier.safetensors");
//! let classifier = ActionClassifier::load(path)?;
//! let window = classifier.config().window; // 12 frames in this small fixture
//! let seeds = Array3::<f64>::zeros((2, window, 99));
//! let predictions = Array3::<f64>::zeros((2, 3 * window, 99));
//! let curve = classifier_curve(&classifier, Some(seeds.view()), predictions.view(), "walking", window / 2)?;
//! assert_eq!(curve.times_s.len(), 6); // one window per hop of the prediction
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
use crate::error::{check_finite, check_not_empty, MetricError};
use motion_core::model::ActionClassifier;
use ndarray::{Array2, ArrayView2, Axis};
use ndarray::{Array3, ArrayView3};
use serde::Serialize;

/// The classifier's probability of one action over the horizon (Ghosh et al. 2017, Figure 4).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClassifierCurve {
    /// The action whose probability is reported.
    pub action: String,
    /// Window length in seconds.
    pub window_s: f64,
    /// End of each window, seconds after the seed.
    pub times_s: Vec<f64>,
    /// Mean probability of `action` per window.
    pub prob: Vec<f64>,
    /// Fraction of sequences classified as `action` (top-1) per window.
    pub top1: Vec<f64>,
    /// Number of sequences.
    pub sequences: usize,
    /// Sequences with a complete window at each window end (all of them unless lengths differ).
    pub sequences_per_window: Vec<usize>,
    /// The classifier's labels (the columns of `mean_probabilities`).
    pub classes: Vec<String>,
    /// Mean probability of every class per window (`times x classes`).
    pub mean_probabilities: Vec<Vec<f64>>,
}

impl ClassifierCurve {
    /// The mean of `prob` over the windows ending in `(from_s, to_s]` (`None` if there are none).
    pub fn mean_prob_between(&self, from_s: f64, to_s: f64) -> Option<f64> {
        let values: Vec<f64> = self
            .times_s
            .iter()
            .zip(&self.prob)
            .filter(|(t, _)| **t > from_s + 1e-9 && **t <= to_s + 1e-9)
            .map(|(_, p)| *p)
            .collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    }
}

/// The protocol's hop between window ends, in seconds (Ghosh et al. 2017's curves are sampled per second).
pub const HOP_SECONDS: f64 = 1.0;

/// [`classifier_curve`] with the protocol's hop of [`HOP_SECONDS`] (25 frames at 25 Hz).
pub fn classifier_protocol(
    classifier: &ActionClassifier,
    seeds: Option<ArrayView3<'_, f64>>,
    predictions: ArrayView3<'_, f64>,
    action: &str,
) -> Result<ClassifierCurve, MetricError> {
    classifier_curve(
        classifier,
        seeds,
        predictions,
        action,
        protocol_hop(classifier),
    )
}

/// The protocol's hop in frames at the classifier's rate (25 at 25 Hz).
pub fn protocol_hop(classifier: &ActionClassifier) -> usize {
    (classifier.config().fps * HOP_SECONDS).round().max(1.0) as usize
}

/// Window ends (in predicted frames) of the protocol for a horizon of `horizon` frames, with
/// `seed` frames available before it.
pub fn window_ends(horizon: usize, seed: usize, window: usize, hop: usize) -> Vec<usize> {
    if hop == 0 {
        return Vec::new();
    }
    (1..)
        .map(|k| k * hop)
        .take_while(|&e| e <= horizon)
        .filter(|&e| e + seed >= window)
        .collect()
}

/// Scores `predictions [N, H, D]` (after `seeds [N, S, D]`, if given) with the protocol above for
/// `action`, windows every `hop` frames.
///
/// Errors: unknown action, shapes that disagree, non-finite values, or a horizon too short for
/// one complete window.
pub fn classifier_curve(
    classifier: &ActionClassifier,
    seeds: Option<ArrayView3<'_, f64>>,
    predictions: ArrayView3<'_, f64>,
    action: &str,
    hop: usize,
) -> Result<ClassifierCurve, MetricError> {
    check_not_empty("predictions", &predictions)?;
    check_finite("predictions", &predictions)?;
    let (n, horizon, dims) = predictions.dim();
    if let Some(seeds) = seeds {
        check_finite("seeds", &seeds)?;
        let (sn, s, sd) = seeds.dim();
        if sn != n || sd != dims {
            return Err(MetricError::ShapeMismatch {
                what: "seeds".into(),
                found: seeds.shape().to_vec(),
                expected: vec![n, s, dims],
            });
        }
    }
    let empty = Array2::<f64>::zeros((0, dims));
    let pairs: Vec<_> = (0..n)
        .map(|i| {
            let seed = seeds.map_or(empty.view(), |s| s.index_axis_move(Axis(0), i));
            (seed, predictions.index_axis(Axis(0), i))
        })
        .collect();
    let curve = classifier_curve_pairs(classifier, &pairs, action, hop)?;
    debug_assert!(curve.times_s.len() <= horizon / hop);
    Ok(curve)
}

/// [`classifier_curve`] over `(seed, prediction)` pairs of any lengths (e.g. real continuations
/// that end at different frames): each window end averages the sequences that have a complete
/// window there (`sequences_per_window`).
pub fn classifier_curve_pairs(
    classifier: &ActionClassifier,
    pairs: &[(ArrayView2<'_, f64>, ArrayView2<'_, f64>)],
    action: &str,
    hop: usize,
) -> Result<ClassifierCurve, MetricError> {
    let config = classifier.config();
    let class = config.action_index(action).ok_or_else(|| {
        MetricError::InvalidConfig(format!(
            "the classifier does not know the action `{action}` (it knows {})",
            config.actions.join(", ")
        ))
    })?;
    if hop == 0 {
        return Err(MetricError::InvalidConfig("window hop is 0 frames".into()));
    }
    if pairs.is_empty() {
        return Err(MetricError::Empty {
            what: "no sequences to classify".into(),
        });
    }
    let dims = config.frame_dims;
    for (i, (seed, motion)) in pairs.iter().enumerate() {
        for (what, frames) in [("seed", seed), ("prediction", motion)] {
            if frames.ncols() != dims {
                return Err(MetricError::ShapeMismatch {
                    what: format!("{what} {i}"),
                    found: frames.shape().to_vec(),
                    expected: vec![frames.nrows(), dims],
                });
            }
            check_finite(&format!("{what} {i}"), frames)?;
        }
    }
    let window = config.window;
    let longest = pairs.iter().map(|(_, m)| m.nrows()).max().unwrap_or(0);
    let all_ends = window_ends(longest, window, window, hop);
    // (pair, window-end index) of every complete window.
    let jobs: Vec<(usize, usize)> = pairs
        .iter()
        .enumerate()
        .flat_map(|(i, (seed, motion))| {
            let ends = window_ends(motion.nrows(), seed.nrows(), window, hop);
            all_ends
                .iter()
                .enumerate()
                .filter(move |(_, e)| ends.contains(e))
                .map(move |(k, _)| (i, k))
        })
        .collect();
    if jobs.is_empty() {
        let (seed, motion) = pairs[0];
        return Err(MetricError::TooShort {
            what: format!(
                "the classifier protocol's input ({} seed + {} predicted frames)",
                seed.nrows(),
                motion.nrows()
            ),
            frames: seed.nrows() + motion.nrows(),
            kappa: window,
        });
    }
    let mut batch = Array3::<f64>::zeros((jobs.len(), window, dims));
    for (b, &(i, k)) in jobs.iter().enumerate() {
        let (seed, motion) = pairs[i];
        let end = all_ends[k] as isize;
        let mut out = batch.index_axis_mut(Axis(0), b);
        for (row, frame) in (end - window as isize..end).enumerate() {
            let source = if frame < 0 {
                seed.row((seed.nrows() as isize + frame) as usize)
            } else {
                motion.row(frame as usize)
            };
            out.row_mut(row).assign(&source);
        }
    }
    let probs = classifier.probabilities(batch.view()).map_err(|e| {
        MetricError::InvalidConfig(format!("the classifier cannot read the windows: {e}"))
    })?;
    let classes = config.actions.len();
    let mut prob = vec![0.0; all_ends.len()];
    let mut top1 = vec![0.0; all_ends.len()];
    let mut counts = vec![0usize; all_ends.len()];
    let mut mean_probabilities = vec![vec![0.0; classes]; all_ends.len()];
    for (b, &(_, k)) in jobs.iter().enumerate() {
        let row = probs.row(b);
        prob[k] += row[class];
        let best = row
            .iter()
            .enumerate()
            .fold(
                (0, f64::NEG_INFINITY),
                |a, (i, &p)| if p > a.1 { (i, p) } else { a },
            )
            .0;
        if best == class {
            top1[k] += 1.0;
        }
        counts[k] += 1;
        for (m, p) in mean_probabilities[k].iter_mut().zip(row) {
            *m += p;
        }
    }
    // Window ends no sequence reaches (only possible at the start without seeds) are dropped.
    let keep: Vec<usize> = (0..all_ends.len()).filter(|&k| counts[k] > 0).collect();
    Ok(ClassifierCurve {
        action: action.to_string(),
        window_s: config.window_seconds(),
        times_s: keep
            .iter()
            .map(|&k| all_ends[k] as f64 / config.fps)
            .collect(),
        prob: keep.iter().map(|&k| prob[k] / counts[k] as f64).collect(),
        top1: keep.iter().map(|&k| top1[k] / counts[k] as f64).collect(),
        sequences: pairs.len(),
        sequences_per_window: keep.iter().map(|&k| counts[k]).collect(),
        classes: config.actions.clone(),
        mean_probabilities: keep
            .iter()
            .map(|&k| {
                mean_probabilities[k]
                    .iter()
                    .map(|p| p / counts[k] as f64)
                    .collect()
            })
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{s, Array3};

    fn fixture() -> ActionClassifier {
        ActionClassifier::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/parity/action_classifier.safetensors"
        ))
        .unwrap()
    }

    fn motion(n: usize, frames: usize, phase: f64) -> Array3<f64> {
        Array3::from_shape_fn((n, frames, 99), |(s, t, d)| {
            0.3 * ((t as f64) * 0.2 + d as f64 + s as f64 + phase).sin()
        })
    }

    #[test]
    fn window_ends_follow_the_definition() {
        assert_eq!(
            window_ends(300, 50, 50, 25),
            (1..=12).map(|k| k * 25).collect::<Vec<_>>()
        );
        assert_eq!(
            window_ends(300, 0, 50, 25),
            (2..=12).map(|k| k * 25).collect::<Vec<_>>()
        );
        assert_eq!(window_ends(300, 10, 50, 25)[0], 50);
        assert!(window_ends(40, 0, 50, 25).is_empty());
    }

    /// The curve equals a naive loop classifying each window on its own.
    #[test]
    fn matches_classifying_each_window_alone() {
        let c = fixture();
        let w = c.config().window;
        let (seeds, preds) = (motion(3, w, 0.0), motion(3, 4 * w, 1.0));
        let hop = w / 2;
        let curve = classifier_curve(&c, Some(seeds.view()), preds.view(), "eating", hop).unwrap();
        let class = c.config().action_index("eating").unwrap();
        let full = ndarray::concatenate(ndarray::Axis(1), &[seeds.view(), preds.view()]).unwrap();
        for (k, &t) in curve.times_s.iter().enumerate() {
            let end = (t * c.config().fps).round() as usize + w;
            let mut p = 0.0;
            let mut top = 0.0;
            for seq in 0..3 {
                let one = full.slice(s![seq..seq + 1, end - w..end, ..]);
                let probs = c.probabilities(one).unwrap();
                p += probs[[0, class]];
                let best = (0..probs.ncols())
                    .max_by(|&a, &b| probs[[0, a]].total_cmp(&probs[[0, b]]))
                    .unwrap();
                top += f64::from(u8::from(best == class));
            }
            // f32 inference: the batch size may change a product's summation order.
            let diff = (curve.prob[k] - p / 3.0).abs();
            assert!(diff < 1e-5, "window {k}: {diff}");
            assert!((curve.top1[k] - top / 3.0).abs() < 1e-12, "window {k}");
            let total: f64 = curve.mean_probabilities[k].iter().sum();
            assert!((total - 1.0).abs() < 1e-6);
        }
        assert_eq!(curve.times_s.len(), 8);
        assert!((curve.times_s[0] - hop as f64 / c.config().fps).abs() < 1e-12);
    }

    /// Sequences of different lengths: each window end averages the sequences reaching it.
    #[test]
    fn pairs_of_different_lengths_count_what_covers_each_window() {
        let c = fixture();
        let w = c.config().window;
        let (seeds, preds) = (motion(2, w, 0.0), motion(2, 4 * w, 1.0));
        let short = preds.slice(s![1, ..2 * w, ..]);
        let pairs = [
            (seeds.slice(s![0, .., ..]), preds.slice(s![0, .., ..])),
            (seeds.slice(s![1, .., ..]), short),
        ];
        let curve = classifier_curve_pairs(&c, &pairs, "walking", w).unwrap();
        assert_eq!(curve.sequences_per_window, vec![2, 2, 1, 1]);
        let alone = classifier_curve(
            &c,
            Some(seeds.slice(s![0..1, .., ..])),
            preds.slice(s![0..1, .., ..]),
            "walking",
            w,
        )
        .unwrap();
        assert!((curve.prob[3] - alone.prob[3]).abs() < 1e-5);
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let c = fixture();
        let w = c.config().window;
        let preds = motion(2, 4 * w, 0.0);
        assert!(matches!(
            classifier_curve(&c, None, preds.view(), "flying", w),
            Err(MetricError::InvalidConfig(_))
        ));
        let short = motion(2, w - 1, 0.0);
        assert!(matches!(
            classifier_curve(&c, None, short.view(), "walking", w),
            Err(MetricError::TooShort { .. })
        ));
        let mut nan = preds.clone();
        nan[[1, 3, 7]] = f64::NAN;
        assert!(matches!(
            classifier_curve(&c, None, nan.view(), "walking", w),
            Err(MetricError::NonFinite { .. })
        ));
        let seeds = motion(3, w, 0.0);
        assert!(matches!(
            classifier_curve(&c, Some(seeds.view()), preds.view(), "walking", w),
            Err(MetricError::ShapeMismatch { .. })
        ));
    }
}
