//! The config fields each architecture adds to the shared ones, with their checks and the lines
//! `motion-cli info` prints for them. [`ArchConfig`](super::ArchConfig) tags them by the
//! `architecture` key.
use serde::{Deserialize, Serialize};

use super::{limits, ModelConfig};
use crate::nn::GruConvention;

/// The config fields only `vgru-d` has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct VgruDFields {
    /// Plan GRU units `P`.
    pub plan_hidden: usize,
}

impl VgruDFields {
    /// A plan, actions to feed it and a horizon to plan over.
    pub(crate) fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if self.plan_hidden == 0 {
            return Err("vgru-d needs plan_hidden > 0".into());
        }
        if self.plan_hidden > limits::UNITS {
            return Err(format!(
                "plan_hidden {} is over the limit of {}",
                self.plan_hidden,
                limits::UNITS
            ));
        }
        if config.actions.is_empty() {
            return Err("vgru-d needs at least one action label".into());
        }
        if config.horizon == 0 {
            return Err("vgru-d needs horizon > 0".into());
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    pub(crate) fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "vgru-d (VTLN-RNN: plan GRU + body GRU + linear decoder, Gopalakrishnan et al. 2019)"
                    .into(),
            ),
            (
                "sizes",
                format!(
                    "body GRU {} units, plan GRU {} units",
                    config.hidden, self.plan_hidden
                ),
            ),
        ]
    }
}

/// The config fields only `gru-d` has: none; its sizes are the shared `hidden` and `layers`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GruDFields {}

impl GruDFields {
    /// At least one layer.
    pub(crate) fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if config.layers == 0 {
            return Err("gru-d with 0 layers".into());
        }
        Ok(())
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    pub(crate) fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "gru-d (stacked GRU + linear decoder, Gopalakrishnan et al. 2019)".into(),
            ),
            (
                "sizes",
                format!("{} GRU layers x {} units", config.layers, config.hidden),
            ),
        ]
    }
}

/// The config fields only `dae-lstm` has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct DaeLstmFields {
    /// Units of each hidden layer of the dropout autoencoder.
    pub dae_hidden: usize,
    /// Hidden layers of the dropout autoencoder (Ghosh et al. 2017: 3).
    pub dae_layers: usize,
}

impl DaeLstmFields {
    /// LSTM layers and an autoencoder with units, within the limits.
    pub(crate) fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if self.dae_hidden > limits::UNITS {
            return Err(format!(
                "dae_hidden {} is over the limit of {}",
                self.dae_hidden,
                limits::UNITS
            ));
        }
        if self.dae_layers > limits::LAYERS {
            return Err(format!(
                "dae_layers {} is over the limit of {}",
                self.dae_layers,
                limits::LAYERS
            ));
        }
        if config.layers == 0 {
            return Err("dae-lstm with 0 LSTM layers".into());
        }
        if self.dae_hidden == 0 {
            return Err("dae-lstm needs dae_hidden > 0".into());
        }
        Ok(())
    }

    /// The autoencoder's layer widths `[O, dae_hidden x dae_layers, O]`.
    pub fn widths(&self, outputs: usize) -> Vec<usize> {
        let mut widths = vec![outputs];
        widths.extend(std::iter::repeat_n(self.dae_hidden, self.dae_layers));
        widths.push(outputs);
        widths
    }

    /// `motion-cli info`'s lines: what the architecture is, then its sizes (last).
    pub(crate) fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "dae-lstm (stacked LSTM + linear decoder, each output filtered by a dropout \
                 autoencoder before it is fed back, Ghosh et al. 2017)"
                    .into(),
            ),
            (
                "sizes",
                format!(
                    "{} LSTM layers x {} units (first layer input {} = features + {} action \
                     one-hot); autoencoder {} ReLU layers x {} units",
                    config.layers,
                    config.hidden,
                    config.rnn_input_dims(),
                    config.actions.len(),
                    self.dae_layers,
                    self.dae_hidden
                ),
            ),
        ]
    }
}

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

impl IntentionFields {
    /// In range, and the fixed choices of the model (plain poses, residual, PyTorch GRUs).
    pub(crate) fn validate(&self, config: &ModelConfig) -> Result<(), String> {
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
    pub(crate) fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
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
}
