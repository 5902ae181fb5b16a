//! The intention-based stochastic model: the seed's frames are labelled with intentions, an
//! intention forecaster continues those labels as probabilities, and a stacked GRU pose
//! generator conditioned on a noise vector `z` reads the intentions forecast ahead of it.
//!
//! Citation: Tanke, Zaveri, Gall, "Intention-based Long-Term Human Motion Anticipation", 3DV
//! 2021 — Tanke et al. 2021, section 3 (3.1 the intention forecaster, eq. 3; 3.2 the pose generator,
//! eq. 6; 3.3 the intention labels). Tensors as in `training/models.py` (`IntentionModel`,
//! `IntentionLabels`; labelling in `training/intention_labels.py`):
//! `labels.centroids [K, O]`, `labels.merge [K]`, `label_encoder.*`, `label_decoder.*`,
//! `label_out.*`, `pose_encoder.*`, `intent_conv.*`, `rnn.{k}.*` (all GRUs in the PyTorch
//! convention); the decoder and the normalization are the predictor's own (`decoder.*`,
//! `norm.*`). Everything runs on normalized used dims.
//!
//! ## Inference (seed frames `0 .. S-1`, predictions `S ..`)
//! - Each seed frame's label: the nearest centroid (squared distance, lowest index on ties), then
//!   the merge table.
//! - `label_encoder` reads pose ⊕ one-hot(label) over the seed from 0; `pose_encoder` reads the
//!   seed poses from 0 and ends in `h_p`. Every decoder layer starts at `h_p ⊕ z`.
//! - `label_decoder` starts from the label encoder's last state; its first input is the one-hot
//!   of the last seed label, then its own previous `softmax(label_out(h))`: the intention
//!   probabilities of frames `S, S+1, ..`.
//! - The step producing frame `τ` reads `x̂_{τ-1} ⊕ z ⊕ intent_conv(window)`, the window being the
//!   probabilities of frames `τ-1 .. τ+γ-2` (frame `S-1`: its label's one-hot), `x̂_{S-1}` the
//!   last seed frame; the layers run bottom to top and `x̂_τ = x̂_{τ-1} + decoder(top)`.
//!
//! ## Streaming
//! The forecaster runs ahead of the poses: when the seed is over it has produced frames
//! `S .. S+γ-3` (none for `γ <= 2`), and each pose step first advances it to frame `τ+γ-2` (one
//! frame per step; none at the first step when `γ = 1`). A ring of the last `γ` probability
//! vectors per row holds the window. The forecaster does not read the poses, so this gives the
//! same numbers as forecasting the whole horizon first (what `training/models.py` does).
//! Every buffer is sized in [`Intention::new_state`]: a step allocates nothing.
//!
//! ## Action conditioning
//! This project's addition (the paper's model is unconditioned): a config with `actions` appends
//! the row's action one-hot `a` (`A` values) to the label encoder's input (pose ⊕ label one-hot ⊕
//! `a`), the label decoder's (probabilities ⊕ `a`) and the first decoder layer's (`x̂ ⊕ z ⊕ f ⊕
//! a`), as `training/models.py` does. [`Intention::set_action`] switches a row's one-hot: the
//! next pose step reads the new action, and so does every intention frame not yet forecast (the
//! forecaster runs `γ - 2` frames ahead of the poses).
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::arch::{gru_shapes, stacked_gru_shapes, ArchFields};
use super::config::{limits, ModelConfig};
use super::generate_error::GenerateError;
use super::net::NoiseSource;
use super::net::{own, Begin, Net, NetState};
use super::weights::{WeightStore, WeightsError};
use super::ArchConfig;
use crate::nn::{
    GruCell, GruConfig, GruConvention, GruScratch, Linear, LinearConfig, Stack, StackState,
};

/// The config fields only `intention` has.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IntentionFields {
    /// Width `N` of the noise `z` the pose decoder's initial state ends with and its every
    /// input reads (`0 < N < hidden`; the pose encoder has `hidden - N` units).
    pub noise_dims: usize,
    /// Standard deviation `s` of the noise drawn per sample, `z ~ N(0, s² I)` (absent = 1, the
    /// paper's `N(0, I)`): an inference-time choice stored with the weights, as a GAN's
    /// truncation. Training always draws `N(0, I)`; an explicit `z` is used as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_scale: Option<f32>,
    /// Units of the intention forecaster's encoder and decoder GRUs.
    pub label_hidden: usize,
    /// Number of intention labels `C` (Tanke et al. 2021: 8).
    pub intentions: usize,
    /// Pose clusters `K` whose centroids label the seed frames.
    pub clusters: usize,
    /// Look-ahead `γ`: intention probabilities of frames `τ-1 .. τ+γ-2` are read by the step
    /// producing frame `τ` (Tanke et al. 2021: 10).
    pub lookahead: usize,
    /// Output channels `Fe` of the temporal convolution over those probabilities.
    pub intention_features: usize,
}

impl ArchFields for IntentionFields {
    const STOCHASTIC: bool = true;

    /// Tanke et al. 2021 (`make_config` of `training/models.py`): 3 GRU layers of 256 units over
    /// plain poses, residual, unconditioned, noise 32, forecaster 128 units, 8 intentions from 32
    /// clusters, look-ahead 10, 32 convolution channels.
    fn paper() -> ModelConfig {
        let fields = IntentionFields {
            noise_dims: 32,
            noise_scale: None,
            label_hidden: 128,
            intentions: 8,
            clusters: 32,
            lookahead: 10,
            intention_features: 32,
        };
        ModelConfig {
            residual: true,
            ..ModelConfig::h36m(fields.into(), 256, 3)
        }
    }

    /// In range, and the fixed choices of the model (plain poses, residual, PyTorch GRUs).
    fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        let at_most = |what: &str, value: usize, limit: usize| {
            if value > limit {
                Err(format!("{what} {value} is over the limit of {limit}"))
            } else {
                Ok(())
            }
        };
        at_most("noise_dims", self.noise_dims, limits::UNITS)?;
        at_most("label_hidden", self.label_hidden, limits::UNITS)?;
        at_most("intention_features", self.intention_features, limits::UNITS)?;
        at_most("intentions", self.intentions, limits::INTENTIONS)?;
        at_most("clusters", self.clusters, limits::INTENTIONS)?;
        at_most("lookahead", self.lookahead, limits::LOOKAHEAD)?;
        at_most(
            "lookahead * intentions",
            self.lookahead * self.intentions,
            limits::WINDOW_VALUES,
        )?;
        let noise = self.noise_dims;
        if noise == 0 || noise >= config.hidden {
            return Err(format!(
                "intention needs 0 < noise_dims < hidden, got noise_dims {noise}, hidden {}",
                config.hidden
            ));
        }
        if let Some(scale) = self.noise_scale {
            if !(0.0..=limits::NOISE_SCALE).contains(&scale) {
                return Err(format!(
                    "noise_scale {scale} is not in [0, {}]",
                    limits::NOISE_SCALE
                ));
            }
        }
        for (field, value) in [
            ("label_hidden", self.label_hidden),
            ("intentions", self.intentions),
            ("clusters", self.clusters),
            ("lookahead", self.lookahead),
            ("intention_features", self.intention_features),
        ] {
            if value == 0 {
                return Err(format!("intention needs {field} >= 1"));
            }
        }
        if config.layers == 0 {
            return Err("intention with 0 GRU layers".into());
        }
        if !config.residual {
            return Err("intention is residual (output = previous pose + decoder)".into());
        }
        if config.derivative_order != 0 {
            return Err(format!(
                "intention reads plain poses: derivative_order {} (expected 0)",
                config.derivative_order
            ));
        }
        if config.gru_convention != GruConvention::PyTorch {
            return Err(format!(
                "intention's GRUs use the pytorch convention, the config says `{}`",
                config.gru_convention.name()
            ));
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, its intentions and noise, then its
    /// sizes (last).
    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        let (n, fe) = (self.noise_dims, self.intention_features);
        let outputs = config.output_dims();
        let conditioned = if config.actions.is_empty() {
            String::new()
        } else {
            format!(" + action one-hot {}", config.actions.len())
        };
        vec![
            (
                "architecture",
                "intention (seed labelled with intentions, intention forecaster GRU, stacked GRU \
                 pose generator on noise z and the intentions forecast ahead + linear decoder, \
                 Tanke et al. 2021)"
                    .into(),
            ),
            (
                "intentions",
                format!(
                    "{} intentions from {} pose clusters (labels.centroids, labels.merge); \
                     forecaster GRUs (label_hidden) {} units; look-ahead {} frames, \
                     intent_conv {fe} channels",
                    self.intentions, self.clusters, self.label_hidden, self.lookahead
                ),
            ),
            (
                "noise",
                format!(
                    "z ~ N(0, s² I) of noise_dims {n} per sample, s = noise_scale {}; pose \
                     encoder {} units, decoder layers start at its state + z",
                    self.noise_scale.unwrap_or(1.0),
                    config.hidden.saturating_sub(n)
                ),
            ),
            (
                "sizes",
                format!(
                    "{} GRU layers x {} units (first layer input {} = pose {} + noise {n} + \
                     intention features {fe}{conditioned})",
                    config.layers,
                    config.hidden,
                    outputs + n + fe + config.actions.len(),
                    outputs
                ),
            ),
        ]
    }

    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>) {
        let c = IntentionConfig::of(config);
        let (l, n, o) = (c.label_hidden, c.intentions, c.outputs);
        shapes.push(("labels.centroids".into(), vec![c.clusters, o]));
        shapes.push(("labels.merge".into(), vec![c.clusters]));
        gru_shapes(shapes, "label_encoder", c.label_input_dims(), l);
        gru_shapes(shapes, "label_decoder", c.label_decoder_dims(), l);
        shapes.push(("label_out.weight".into(), vec![n, l]));
        shapes.push(("label_out.bias".into(), vec![n]));
        gru_shapes(shapes, "pose_encoder", o, c.pose_hidden());
        shapes.push((
            "intent_conv.weight".into(),
            vec![c.features, n, c.lookahead],
        ));
        shapes.push(("intent_conv.bias".into(), vec![c.features]));
        stacked_gru_shapes(shapes, "rnn", config.layers, c.rnn_input_dims(), c.hidden);
    }

    /// The merge table maps cluster `k` to intention `k mod intentions`.
    fn random_values(&self, _config: &ModelConfig, name: &str, n: usize) -> Option<Vec<f32>> {
        let c = self.intentions.max(1);
        (name == "labels.merge").then(|| (0..n).map(|k| (k % c) as f32).collect())
    }

    fn load(
        &self,
        store: &WeightStore,
        config: &ModelConfig,
    ) -> Result<Arc<dyn Net>, WeightsError> {
        Ok(Arc::new(Intention::load(store, config)?))
    }
}

/// The sizes of an intention model, read from its config.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntentionConfig {
    /// Pose width `O` (used dims).
    pub outputs: usize,
    /// Units per pose-decoder layer `H`.
    pub hidden: usize,
    /// Pose-decoder layers.
    pub layers: usize,
    /// Noise width `N` (`0 < N < H`).
    pub noise_dims: usize,
    /// Standard deviation of a drawn `z` (`noise_scale`, 1 when absent).
    pub noise_scale: f32,
    /// Units of the forecaster's GRUs `L`.
    pub label_hidden: usize,
    /// Intention labels `C`.
    pub intentions: usize,
    /// Pose clusters `K`.
    pub clusters: usize,
    /// Look-ahead `γ >= 1`.
    pub lookahead: usize,
    /// Convolution channels `Fe`.
    pub features: usize,
    /// Action labels `A` (0: unconditioned, the paper's model).
    pub actions: usize,
}

impl IntentionConfig {
    /// The sizes of `config` (an `intention` config that passed validation; another
    /// architecture's reads 0 for the intention sizes).
    pub fn of(config: &ModelConfig) -> Self {
        let f = match &config.arch {
            ArchConfig::Intention(f) => *f,
            _ => IntentionFields {
                noise_dims: 0,
                noise_scale: None,
                label_hidden: 0,
                intentions: 0,
                clusters: 0,
                lookahead: 0,
                intention_features: 0,
            },
        };
        Self {
            outputs: config.output_dims(),
            hidden: config.hidden,
            layers: config.layers,
            noise_dims: f.noise_dims,
            noise_scale: f.noise_scale.unwrap_or(1.0),
            label_hidden: f.label_hidden,
            intentions: f.intentions,
            clusters: f.clusters,
            lookahead: f.lookahead,
            features: f.intention_features,
            actions: config.actions.len(),
        }
    }

    /// Width of the first decoder layer's input, `O + N + Fe + A`.
    pub fn rnn_input_dims(&self) -> usize {
        self.outputs + self.noise_dims + self.features + self.actions
    }

    /// Width of the label encoder's input, `O + C + A`.
    pub fn label_input_dims(&self) -> usize {
        self.outputs + self.intentions + self.actions
    }

    /// Width of the label decoder's input, `C + A`.
    pub fn label_decoder_dims(&self) -> usize {
        self.intentions + self.actions
    }

    /// Units of the pose encoder, `H - N`.
    pub fn pose_hidden(&self) -> usize {
        self.hidden.saturating_sub(self.noise_dims)
    }
}

/// Intention-model weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct Intention {
    config: IntentionConfig,
    /// `[K, O]`.
    centroids: Vec<f32>,
    /// The intention of each cluster, `[K]`, each `< C`.
    merge: Vec<usize>,
    label_encoder: GruCell,
    label_decoder: GruCell,
    label_out: Linear,
    pose_encoder: GruCell,
    /// `intent_conv.weight [Fe, C, γ]` stored as `[Fe, γ, C]` (a window frame's `C` values
    /// contiguous).
    conv_weight: Vec<f32>,
    conv_bias: Vec<f32>,
    rnn: Stack<GruCell>,
}

/// Per-batch state of an [`Intention`] model, all sized once in [`Intention::new_state`].
#[derive(Debug)]
pub struct IntentionState {
    capacity: usize,
    /// Seed frames of the current sequence.
    seed_len: usize,
    /// The last frame whose intention probabilities are in `ring`.
    forecast_last: usize,
    /// `z` per row `[capacity, N]`.
    z: Vec<f32>,
    /// Label of each row's latest seed frame.
    labels: Vec<usize>,
    /// Each row's action (conditioned models).
    actions: Vec<usize>,
    /// Label-encoder input per row, pose ⊕ one-hot ⊕ action one-hot `[capacity, O + C + A]`.
    label_input: Vec<f32>,
    /// Label encoder, then decoder state `[capacity, L]`.
    label_h: Vec<f32>,
    label_scratch: GruScratch,
    /// The label decoder's next input, probabilities ⊕ action one-hot `[capacity, C + A]`.
    label_x: Vec<f32>,
    logits: Vec<f32>,
    /// Per row the probabilities of the last `γ` frames, frame `j` in slot `j % γ`:
    /// `[capacity, γ, C]`.
    ring: Vec<f32>,
    pose_h: Vec<f32>,
    pose_scratch: GruScratch,
    /// First decoder layer's input per row, `x ⊕ z ⊕ features ⊕ action one-hot`
    /// `[capacity, O + N + Fe + A]`.
    input: Vec<f32>,
    rnn: StackState<GruScratch>,
}

/// `out` (empty for unconditioned models) set to the one-hot of `index`.
fn write_onehot(out: &mut [f32], index: usize) {
    if !out.is_empty() {
        out.fill(0.0);
        out[index] = 1.0;
    }
}

fn gru(
    store: &WeightStore,
    prefix: &str,
    inputs: usize,
    hidden: usize,
) -> Result<GruCell, WeightsError> {
    GruCell::load(
        store,
        prefix,
        GruConfig {
            inputs,
            hidden,
            convention: GruConvention::PyTorch,
        },
    )
}

impl Intention {
    /// Reads every tensor of the model but `decoder.*` and `norm.*` (the predictor's); checks
    /// that `labels.merge` holds integers in `0..intentions`.
    pub fn load(store: &WeightStore, config: &ModelConfig) -> Result<Self, WeightsError> {
        let c = IntentionConfig::of(config);
        let (o, k, n) = (c.outputs, c.clusters, c.intentions);
        let centroids = store.tensor("labels.centroids", &[k, o])?;
        let merge = store
            .tensor("labels.merge", &[k])?
            .into_iter()
            .enumerate()
            .map(|(cluster, v)| {
                if v.fract() == 0.0 && v >= 0.0 && v < n as f32 {
                    Ok(v as usize)
                } else {
                    Err(WeightsError::InvalidTensor {
                        path: store.path().to_path_buf(),
                        tensor: "labels.merge".into(),
                        problem: format!(
                            "cluster {cluster} maps to {v}, not an intention index in 0..{n}"
                        ),
                    })
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let label_encoder = gru(store, "label_encoder", c.label_input_dims(), c.label_hidden)?;
        let label_decoder = gru(
            store,
            "label_decoder",
            c.label_decoder_dims(),
            c.label_hidden,
        )?;
        let label_out = Linear::load(
            store,
            "label_out",
            LinearConfig {
                inputs: c.label_hidden,
                outputs: n,
            },
        )?;
        let pose_encoder = gru(store, "pose_encoder", o, c.pose_hidden())?;
        let (fe, g) = (c.features, c.lookahead);
        let weight = store.tensor("intent_conv.weight", &[fe, n, g])?;
        let mut conv_weight = vec![0.0; fe * g * n];
        for f in 0..fe {
            for ch in 0..n {
                for j in 0..g {
                    conv_weight[(f * g + j) * n + ch] = weight[(f * n + ch) * g + j];
                }
            }
        }
        let conv_bias = store.tensor("intent_conv.bias", &[fe])?;
        let rnn = Stack::load_gru(
            store,
            "rnn",
            c.layers,
            c.rnn_input_dims(),
            c.hidden,
            GruConvention::PyTorch,
        )?;
        Ok(Self {
            config: c,
            centroids,
            merge,
            label_encoder,
            label_decoder,
            label_out,
            pose_encoder,
            conv_weight,
            conv_bias,
            rnn,
        })
    }

    /// The model's sizes.
    pub fn config(&self) -> IntentionConfig {
        self.config
    }

    /// Number of trainable parameters (the forecaster, the pose encoder, the convolution and the
    /// decoder layers; the label tables are not trained by gradient and not counted, as PyTorch
    /// counts buffers).
    pub fn parameter_count(&self) -> usize {
        self.label_encoder.parameter_count()
            + self.label_decoder.parameter_count()
            + self.label_out.parameter_count()
            + self.pose_encoder.parameter_count()
            + self.conv_weight.len()
            + self.conv_bias.len()
            + self.rnn.parameter_count()
    }

    /// Noise width `N` (the length of an explicit `z`).
    pub fn noise_dims(&self) -> usize {
        self.config.noise_dims
    }

    /// Units per decoder layer.
    pub fn hidden(&self) -> usize {
        self.config.hidden
    }

    /// The intention of normalized pose `x [O]`: the merge-table entry of the nearest centroid
    /// (squared Euclidean distance accumulated in f64, the lowest index on ties).
    pub fn label(&self, x: &[f32]) -> usize {
        let o = self.config.outputs;
        let mut best = (f64::INFINITY, 0);
        for (k, centroid) in self.centroids.chunks_exact(o).enumerate() {
            let d: f64 = x
                .iter()
                .zip(centroid)
                .map(|(&a, &c)| {
                    let e = f64::from(a) - f64::from(c);
                    e * e
                })
                .sum();
            if d < best.0 {
                best = (d, k);
            }
        }
        self.merge[best.1]
    }

    /// State for up to `capacity` rows.
    pub fn new_state(&self, capacity: usize) -> IntentionState {
        let c = &self.config;
        let (n, l) = (c.intentions, c.label_hidden);
        IntentionState {
            capacity,
            seed_len: 0,
            forecast_last: 0,
            z: vec![0.0; capacity * c.noise_dims],
            labels: vec![0; capacity],
            actions: vec![0; capacity],
            label_input: vec![0.0; capacity * c.label_input_dims()],
            label_h: vec![0.0; capacity * l],
            label_scratch: GruScratch::new(l, capacity),
            label_x: vec![0.0; capacity * c.label_decoder_dims()],
            logits: vec![0.0; capacity * n],
            ring: vec![0.0; capacity * c.lookahead * n],
            pose_h: vec![0.0; capacity * c.pose_hidden()],
            pose_scratch: GruScratch::new(c.pose_hidden(), capacity),
            input: vec![0.0; capacity * c.rnn_input_dims()],
            rnn: self.rnn.new_state(capacity),
        }
    }

    /// Starts `noise.len()` rows on a seed of `seed_len` frames: encoder states zeroed, each
    /// row's `z` drawn once from its source (a seeded `N(0, s² I)` generator, `s` the file's
    /// `noise_scale`, or a fixed vector used as given), each row's action from `actions` (read
    /// by conditioned models only; indices below `A`).
    pub fn begin(
        &self,
        state: &mut IntentionState,
        mut noise: Vec<NoiseSource>,
        actions: &[usize],
        seed_len: usize,
    ) {
        let batch = noise.len();
        assert!(batch <= state.capacity, "more rows than the state holds");
        if self.config.actions > 0 {
            assert!(actions.len() >= batch, "an action per row");
            state.actions[..batch].copy_from_slice(&actions[..batch]);
            assert!(
                state.actions[..batch]
                    .iter()
                    .all(|&a| a < self.config.actions),
                "action index out of range"
            );
        }
        let (nd, scale) = (self.config.noise_dims, self.config.noise_scale);
        for (source, z) in noise.iter_mut().zip(state.z.chunks_exact_mut(nd)) {
            source.fill(z);
            if matches!(source, NoiseSource::Rng(_)) {
                z.iter_mut().for_each(|v| *v *= scale);
            }
        }
        state.seed_len = seed_len;
        state.forecast_last = 0;
        state.label_h[..batch * self.config.label_hidden].fill(0.0);
        state.pose_h[..batch * self.config.pose_hidden()].fill(0.0);
    }

    /// Body step `t` for `batch` rows of normalized poses `x [batch, O]`: seed frame `t` while
    /// `t < S` (encoders only), otherwise the fed-back prediction `x̂_t`. From the last seed frame
    /// on it returns the top decoder layer's hidden `[batch, H]`, from which the predictor's
    /// decoder makes frame `t + 1` (residually, on `x`); before that `None`.
    pub fn step<'s>(
        &self,
        state: &'s mut IntentionState,
        x: &[f32],
        batch: usize,
        t: usize,
    ) -> Option<&'s [f32]> {
        if t < state.seed_len {
            self.encode(state, x, batch);
            if t + 1 < state.seed_len {
                return None;
            }
            self.finish_seed(state, batch);
        }
        Some(self.pose_step(state, x, batch, t + 1))
    }

    /// Whether the model reads an action (its config has `actions`).
    pub fn is_conditioned(&self) -> bool {
        self.config.actions > 0
    }

    /// Switches `row`'s action to `action` (`< A`) from the next step on (module docs).
    pub fn set_action(&self, state: &mut IntentionState, row: usize, action: usize) {
        assert!(action < self.config.actions, "action index out of range");
        state.actions[row] = action;
    }

    /// One seed frame through the labelling and both encoders.
    fn encode(&self, state: &mut IntentionState, x: &[f32], batch: usize) {
        let (o, n) = (self.config.outputs, self.config.intentions);
        let width = self.config.label_input_dims();
        for (b, row) in state.label_input[..batch * width]
            .chunks_exact_mut(width)
            .enumerate()
        {
            let pose = &x[b * o..(b + 1) * o];
            let label = self.label(pose);
            state.labels[b] = label;
            let (p, rest) = row.split_at_mut(o);
            let (onehot, action) = rest.split_at_mut(n);
            p.copy_from_slice(pose);
            onehot.fill(0.0);
            onehot[label] = 1.0;
            write_onehot(action, state.actions[b]);
        }
        self.label_encoder.step(
            &state.label_input[..batch * width],
            &mut state.label_h,
            batch,
            &mut state.label_scratch,
        );
        self.pose_encoder.step(
            &x[..batch * o],
            &mut state.pose_h,
            batch,
            &mut state.pose_scratch,
        );
    }

    /// After the last seed frame: decoder layers at `h_p ⊕ z`, the forecaster's first input and
    /// window frame `S-1` the last label's one-hot, frames `S .. S+γ-3` forecast.
    fn finish_seed(&self, state: &mut IntentionState, batch: usize) {
        let c = &self.config;
        let (n, g, nd, ph) = (c.intentions, c.lookahead, c.noise_dims, c.pose_hidden());
        for layer in state.rnn.hidden_mut() {
            for (b, h) in layer[..batch * c.hidden]
                .chunks_exact_mut(c.hidden)
                .enumerate()
            {
                h[..ph].copy_from_slice(&state.pose_h[b * ph..(b + 1) * ph]);
                h[ph..].copy_from_slice(&state.z[b * nd..(b + 1) * nd]);
            }
        }
        let last = state.seed_len - 1;
        state.ring[..batch * g * n].fill(0.0);
        let width = c.label_decoder_dims();
        for b in 0..batch {
            let label = state.labels[b];
            let x = &mut state.label_x[b * width..b * width + n];
            x.fill(0.0);
            x[label] = 1.0;
            state.ring[(b * g + last % g) * n + label] = 1.0;
        }
        state.forecast_last = last;
        for _ in 0..g.saturating_sub(2) {
            self.forecast(state, batch);
        }
    }

    /// One forecaster step: the probabilities of frame `forecast_last + 1` into the ring and the
    /// next input.
    fn forecast(&self, state: &mut IntentionState, batch: usize) {
        let (n, g) = (self.config.intentions, self.config.lookahead);
        let width = self.config.label_decoder_dims();
        for b in 0..batch {
            write_onehot(
                &mut state.label_x[b * width + n..(b + 1) * width],
                state.actions[b],
            );
        }
        self.label_decoder.step(
            &state.label_x[..batch * width],
            &mut state.label_h,
            batch,
            &mut state.label_scratch,
        );
        let l = self.config.label_hidden;
        self.label_out.forward(
            &state.label_h[..batch * l],
            batch,
            &mut state.logits[..batch * n],
        );
        let frame = state.forecast_last + 1;
        for b in 0..batch {
            let logits = &state.logits[b * n..(b + 1) * n];
            let max = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let x = &mut state.label_x[b * width..b * width + n];
            let mut sum = 0.0f32;
            for (p, &l) in x.iter_mut().zip(logits) {
                *p = (l - max).exp();
                sum += *p;
            }
            x.iter_mut().for_each(|p| *p /= sum);
            let slot = (b * g + frame % g) * n;
            state.ring[slot..slot + n].copy_from_slice(x);
        }
        state.forecast_last = frame;
    }

    /// The pose step producing frame `tau` from `x̂_{τ-1} = x`; returns the top hidden.
    fn pose_step<'s>(
        &self,
        state: &'s mut IntentionState,
        x: &[f32],
        batch: usize,
        tau: usize,
    ) -> &'s [f32] {
        let c = &self.config;
        let (o, n, g, nd, fe) = (
            c.outputs,
            c.intentions,
            c.lookahead,
            c.noise_dims,
            c.features,
        );
        // Window frames tau-1 ..= tau+g-2 (g >= 1, tau >= 1).
        let newest = tau + g - 2;
        while state.forecast_last < newest {
            self.forecast(state, batch);
        }
        let width = c.rnn_input_dims();
        for (b, row) in state.input[..batch * width]
            .chunks_exact_mut(width)
            .enumerate()
        {
            let (pose, rest) = row.split_at_mut(o);
            let (z, rest) = rest.split_at_mut(nd);
            let (features, action) = rest.split_at_mut(fe);
            write_onehot(action, state.actions[b]);
            pose.copy_from_slice(&x[b * o..(b + 1) * o]);
            z.copy_from_slice(&state.z[b * nd..(b + 1) * nd]);
            let ring = &state.ring[b * g * n..(b + 1) * g * n];
            for (f, out) in features.iter_mut().enumerate() {
                let mut acc = self.conv_bias[f];
                let weights = &self.conv_weight[f * g * n..(f + 1) * g * n];
                for (j, w) in weights.chunks_exact(n).enumerate() {
                    let slot = (tau - 1 + j) % g;
                    let p = &ring[slot * n..(slot + 1) * n];
                    acc += w.iter().zip(p).map(|(a, b)| a * b).sum::<f32>();
                }
                *out = acc;
            }
        }
        self.rnn
            .step(&mut state.rnn, &state.input[..batch * width], batch)
    }
}

impl Net for Intention {
    fn parameter_count(&self) -> usize {
        Intention::parameter_count(self)
    }
    fn noise_dims(&self) -> usize {
        Intention::noise_dims(self)
    }
    fn teacher_forced(&self) -> bool {
        false
    }
    fn needs_action(&self) -> bool {
        self.is_conditioned()
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        Intention::begin(
            self,
            own::<IntentionState>(state),
            begin.noise,
            begin.actions,
            begin.seed_len,
        );
    }
    /// Switches at once (`crossfade` is not used: the model was trained on hard switches).
    fn set_action(
        &self,
        state: &mut dyn NetState,
        _rows: usize,
        row: usize,
        action: usize,
        _crossfade: usize,
        _body_step: usize,
    ) -> Result<(), GenerateError> {
        if !self.is_conditioned() {
            return Err(GenerateError::NotConditioned);
        }
        Intention::set_action(self, own::<IntentionState>(state), row, action);
        Ok(())
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        body_step: usize,
    ) -> Option<&'s [f32]> {
        Intention::step(
            self,
            own::<IntentionState>(state),
            features,
            rows,
            body_step,
        )
    }
}
