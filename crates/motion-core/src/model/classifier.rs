//! The action classifier of Ghosh et al. 2017, section 4.5 (Ghosh, Song, Aksan, Hilliges, "Learning Human
//! Motion Models for Long-term Predictions", 3DV 2017): a separately trained recurrent classifier
//! that scores generated motion of any length — the longer a prediction keeps the seed's action
//! label, the better it is. Trained by `training/train_classifier.py`; schema `action-classifier`
//! in `weights/README.md`.
//!
//! A window of `T` full frames (`window` = 50 at 25 Hz for the shipped file) is normalized with the
//! file's statistics (used dims only), with `center` each non-root dim minus its window mean,
//! extended by backward differences up to `derivative_order`
//! (repeat-first padding inside the window, as `training/features.py`), run through `layers` stacked
//! LSTM layers (PyTorch convention), and the top layer's last hidden state goes through a linear
//! head to one logit per action; the class probabilities are their softmax.
//!
//! ```
//! use motion_core::model::ActionClassifier;
//! use ndarray::Array3;
//!
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/parity/action_classifier.safetensors");
//! let classifier = ActionClassifier::load(path)?;
//! let config = classifier.config();
//! // Two windows of a still rest pose.
//! let windows = Array3::<f64>::zeros((2, config.window, config.frame_dims));
//! let probabilities = classifier.probabilities(windows.view())?; // [2, actions]
//! assert_eq!(probabilities.dim(), (2, config.actions.len()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
use super::batch::FrameScalar;
use super::config::{
    check_format, parse_provenance, validate_derivatives, validate_dims_used, Provenance,
};
use super::norm::Normalization;
use super::weights::{WeightStore, WeightsError};
use crate::derivatives::DerivativeBuffer;
use crate::nn::parallel::pool::prelude::*;
use crate::nn::{Linear, LinearConfig, LstmCell, Stack};
use ndarray::{s, Array2, ArrayView3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `architecture` value of a classifier file.
pub const CLASSIFIER_ARCHITECTURE: &str = "action-classifier";

/// Upper bounds on config sizes (a file claiming more is refused, not allocated).
const MAX_HIDDEN: usize = 16_384;
const MAX_LAYERS: usize = 16;
const MAX_WINDOW: usize = 100_000;

/// Full-frame dims holding the root's per-frame deltas (never centered).
const ROOT_DELTA_DIMS: usize = 6;

/// Most windows classified per task when a batch is split over threads (larger batches make the
/// LSTM's products more efficient; a batch is split into one task per thread up to this size).
const MAX_CHUNK: usize = 512;

/// The `config` JSON object of an `action-classifier` file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClassifierConfig {
    /// Always `action-classifier`.
    pub architecture: String,
    /// Width of a full frame (99 for H3.6M).
    pub frame_dims: usize,
    /// Full-frame dims the classifier reads (normalized).
    pub dims_used: Vec<usize>,
    /// LSTM units per layer.
    pub hidden: usize,
    /// Stacked LSTM layers.
    pub layers: usize,
    /// 0 (frames only) up to 3 (frame + backward differences of order 1..=n).
    pub derivative_order: usize,
    /// `repeat-first` (inside each window).
    pub derivative_padding: String,
    /// Frame rate of the windows (25).
    pub fps: f64,
    /// Skeleton name (`h36m-32`).
    pub skeleton: String,
    /// Class labels, in logit order.
    pub actions: Vec<String>,
    /// Frames per window in training (50 = 2 s at 25 Hz).
    pub window: usize,
    /// Subtract each window's mean from every used dim except the root deltas (full-frame dims
    /// 0..5) before the differences (invariance to a subject's static pose offsets).
    #[serde(default)]
    pub center: bool,
}

impl ClassifierConfig {
    /// Checks the fields against each other and against sane bounds; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if self.architecture != CLASSIFIER_ARCHITECTURE {
            return Err(format!(
                "architecture `{}` is not `{CLASSIFIER_ARCHITECTURE}`",
                self.architecture
            ));
        }
        validate_dims_used(&self.dims_used, self.frame_dims)?;
        if !(1..=MAX_HIDDEN).contains(&self.hidden) {
            return Err(format!(
                "hidden {} (expected 1..={MAX_HIDDEN})",
                self.hidden
            ));
        }
        if !(1..=MAX_LAYERS).contains(&self.layers) {
            return Err(format!(
                "layers {} (expected 1..={MAX_LAYERS})",
                self.layers
            ));
        }
        validate_derivatives(self.derivative_order, &self.derivative_padding)?;
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return Err(format!("fps {} is not in (0, 1000]", self.fps));
        }
        if self.actions.len() < 2 {
            return Err("a classifier needs at least two action labels".into());
        }
        if !(1..=MAX_WINDOW).contains(&self.window) {
            return Err(format!(
                "window {} (expected 1..={MAX_WINDOW})",
                self.window
            ));
        }
        Ok(())
    }

    /// Input width of the first LSTM layer: `len(dims_used) * (1 + derivative_order)`.
    pub fn input_dims(&self) -> usize {
        self.dims_used.len() * (1 + self.derivative_order)
    }

    /// The window length in seconds (`window / fps`).
    pub fn window_seconds(&self) -> f64 {
        self.window as f64 / self.fps
    }

    /// The index of a label in logit order.
    pub fn action_index(&self, label: &str) -> Option<usize> {
        self.actions.iter().position(|a| a == label)
    }
}

/// Windows handed to the classifier were not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ClassifyError {
    /// The frames are not `frame_dims` wide.
    #[error("windows have {found} values per frame, the classifier reads {expected}")]
    FrameWidth {
        /// `frame_dims` of the classifier.
        expected: usize,
        /// The width given.
        found: usize,
    },
    /// A window has no frames.
    #[error("windows have no frames")]
    Empty,
    /// A frame value is NaN or infinite.
    #[error("window {window}, frame {frame}, value {dim} is not finite ({value})")]
    NonFinite {
        /// Window index.
        window: usize,
        /// Frame index inside the window.
        frame: usize,
        /// Value index inside the frame.
        dim: usize,
        /// The value found.
        value: f64,
    },
}

/// A loaded action classifier (immutable; share with `Arc`).
#[derive(Debug, Clone)]
pub struct ActionClassifier {
    path: PathBuf,
    config: ClassifierConfig,
    provenance: Provenance,
    norm: Normalization,
    rnn: Stack<LstmCell>,
    head: Linear,
}

impl ActionClassifier {
    /// Loads an `action-classifier` weights file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, WeightsError> {
        Self::from_store(&WeightStore::open(path)?)
    }

    /// Builds the classifier from a parsed file, checking the schema metadata and every tensor the
    /// configuration implies (presence, dtype, shape, finiteness).
    pub fn from_store(store: &WeightStore) -> Result<Self, WeightsError> {
        let path = store.path().to_path_buf();
        check_format(store)?;
        let bad = |problem: String| WeightsError::BadConfig {
            path: path.clone(),
            key: "config".into(),
            problem,
        };
        let config: ClassifierConfig = serde_json::from_str(store.require_metadata("config")?)
            .map_err(|e| bad(e.to_string()))?;
        config.validate().map_err(bad)?;
        let provenance = match store.metadata("provenance") {
            Some(json) => parse_provenance(json, &path)?,
            None => Provenance::new(),
        };
        let norm = Normalization::load(store, config.frame_dims, &config.dims_used)?;
        let rnn = Stack::load_lstm(
            store,
            "rnn",
            config.layers,
            config.input_dims(),
            config.hidden,
        )?;
        let head = Linear::load(
            store,
            "head",
            LinearConfig {
                inputs: config.hidden,
                outputs: config.actions.len(),
            },
        )?;
        Ok(Self {
            path,
            config,
            provenance,
            norm,
            rnn,
            head,
        })
    }

    /// The file the weights came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The `config` metadata.
    pub fn config(&self) -> &ClassifierConfig {
        &self.config
    }

    /// The `provenance` metadata (empty if the file has none).
    pub fn provenance(&self) -> &Provenance {
        &self.provenance
    }

    /// Trainable parameters (normalization statistics excluded).
    pub fn parameter_count(&self) -> usize {
        self.rnn.parameter_count() + self.head.parameter_count()
    }

    /// Logits `[N, actions]` of `N` windows of `T` full frames each (`windows [N, T, frame_dims]`,
    /// at the classifier's `fps`; `T` is normally `config().window`). Windows are classified
    /// independently (split over the rayon pool for large `N`).
    pub fn logits<T: FrameScalar + Sync>(
        &self,
        windows: ArrayView3<'_, T>,
    ) -> Result<Array2<f32>, ClassifyError> {
        let (n, steps, width) = windows.dim();
        if width != self.config.frame_dims {
            return Err(ClassifyError::FrameWidth {
                expected: self.config.frame_dims,
                found: width,
            });
        }
        if steps == 0 {
            return Err(ClassifyError::Empty);
        }
        for ((w, t, d), v) in windows.indexed_iter() {
            if !v.to_f64().is_finite() {
                return Err(ClassifyError::NonFinite {
                    window: w,
                    frame: t,
                    dim: d,
                    value: v.to_f64(),
                });
            }
        }
        let classes = self.config.actions.len();
        let chunk = n
            .div_ceil(crate::nn::parallel::pool::current_num_threads())
            .clamp(1, MAX_CHUNK);
        let starts: Vec<usize> = (0..n).step_by(chunk).collect();
        let chunks: Vec<Vec<f32>> = starts
            .par_iter()
            .map(|&s| {
                let part = windows.slice(s![s..(s + chunk).min(n), .., ..]);
                crate::nn::parallel::serial(|| self.run_chunk(part))
            })
            .collect();
        let flat: Vec<f32> = chunks.concat();
        let out = Array2::from_shape_vec((n, classes), flat).expect("one row of logits per window");
        Ok(out)
    }

    /// Class probabilities `[N, actions]` (softmax of [`logits`](Self::logits), in f64).
    pub fn probabilities<T: FrameScalar + Sync>(
        &self,
        windows: ArrayView3<'_, T>,
    ) -> Result<Array2<f64>, ClassifyError> {
        let logits = self.logits(windows)?;
        let mut probs = logits.mapv(f64::from);
        for mut row in probs.rows_mut() {
            let max = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            row.mapv_inplace(|v| (v - max).exp());
            let sum: f64 = row.sum();
            row.mapv_inplace(|v| v / sum);
        }
        Ok(probs)
    }

    /// Whether this classifier can label a predictor's seeds: same frame width and rate, and
    /// every class one of the predictor's actions. Returns what does not fit.
    pub fn fits(&self, predictor: &super::ModelConfig) -> Result<(), String> {
        let c = &self.config;
        if c.frame_dims != predictor.frame_dims || (c.fps - predictor.fps).abs() > 1e-9 {
            return Err(format!(
                "the classifier reads {} dims at {} Hz, the model {} dims at {} Hz",
                c.frame_dims, c.fps, predictor.frame_dims, predictor.fps
            ));
        }
        match c
            .actions
            .iter()
            .find(|a| predictor.action_index(a).is_none())
        {
            Some(a) => Err(format!("the model has no action `{a}`")),
            None => Ok(()),
        }
    }

    /// The most probable action of a motion clip at the classifier's rate (e.g. a predictor's
    /// seed): its last `window` frames (all of them if it has fewer) are classified. Returns the
    /// label and its probability.
    pub fn infer_action<T: FrameScalar + Sync>(
        &self,
        frames: ndarray::ArrayView2<'_, T>,
    ) -> Result<(String, f64), ClassifyError> {
        let start = frames.nrows().saturating_sub(self.config.window);
        let tail = frames.slice(s![start.., ..]).insert_axis(ndarray::Axis(0));
        let probs = self.probabilities(tail)?;
        let row = probs.row(0);
        let best = (0..row.len())
            .max_by(|&a, &b| row[a].total_cmp(&row[b]))
            .unwrap_or(0);
        Ok((self.config.actions[best].clone(), row[best]))
    }

    /// The LSTM stack over one chunk of windows, in lockstep; returns `[rows, actions]` logits.
    fn run_chunk<T: FrameScalar>(&self, chunk: ArrayView3<'_, T>) -> Vec<f32> {
        let (rows, steps, width) = chunk.dim();
        let c = &self.config;
        let used = c.dims_used.len();
        let input = c.input_dims();
        let mut derivs: Vec<DerivativeBuffer<f32>> = (0..rows)
            .map(|_| DerivativeBuffer::new(used, c.derivative_order))
            .collect();
        // Normalized used dims of every frame of every row: [rows, steps, used].
        let mut full = vec![0.0f32; width];
        let mut normalized = vec![0.0f32; rows * steps * used];
        for r in 0..rows {
            for t in 0..steps {
                for (f, v) in full.iter_mut().zip(chunk.slice(s![r, t, ..])) {
                    *f = v.to_f32();
                }
                let at = (r * steps + t) * used;
                self.norm.normalize(&full, &mut normalized[at..at + used]);
            }
            if c.center {
                let frames = &mut normalized[r * steps * used..(r + 1) * steps * used];
                for (j, &dim) in c.dims_used.iter().enumerate() {
                    if dim < ROOT_DELTA_DIMS {
                        continue;
                    }
                    let mean = frames.iter().skip(j).step_by(used).sum::<f32>() / steps as f32;
                    frames
                        .iter_mut()
                        .skip(j)
                        .step_by(used)
                        .for_each(|v| *v -= mean);
                }
            }
        }
        let mut x = vec![0.0f32; rows * input];
        let mut state = self.rnn.new_state(rows);
        for t in 0..steps {
            for (r, buffer) in derivs.iter_mut().enumerate() {
                let at = (r * steps + t) * used;
                buffer.push(
                    &normalized[at..at + used],
                    &mut x[r * input..(r + 1) * input],
                );
            }
            self.rnn.step(&mut state, &x, rows);
        }
        let classes = c.actions.len();
        let mut logits = vec![0.0f32; rows * classes];
        self.head.forward(state.top(), rows, &mut logits);
        logits
    }
}
