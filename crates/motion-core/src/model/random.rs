//! Motion-weights files with random weights, for benchmarks and tests of the engine (never for
//! motion): every tensor the schema names, uniform in `±1/sqrt(fan)` like PyTorch's default
//! init, serialized to real safetensors bytes so the normal loader (and its checks) is used.
use super::config::{
    ArchConfig, Architecture, DaeLstmFields, GruDFields, IntentionFields, ModelConfig, VgruDFields,
    DERIVATIVE_PADDING, FORMAT_NAME, FORMAT_VERSION,
};
use super::predictor::MotionModel;
use super::weights::{serialize_f32, WeightStore, WeightsError};
use crate::nn::GruConvention;
use crate::skeleton::{H36M_ACTIONS, H36M_DIMS_USED, H36M_FRAME_DIMS};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::collections::BTreeMap;

impl ModelConfig {
    /// The paper's configuration (Gopalakrishnan et al. 2019, section 4): H3.6M frames (99 dims, 54 used),
    /// derivative order 3, 512 units (GRU-d: 2 layers, PyTorch convention, unconditioned;
    /// VGRU-d: plan 512, paper convention, the 15 H3.6M actions), 50 seed + 100 predicted frames.
    /// DAE-LSTM (Ghosh et al. 2017, 4.1): 3 LSTM layers of 1000 units over plain min-max scaled poses and
    /// the action one-hot, a 3 x 3000 autoencoder. Intention (Tanke et al. 2021; `make_config` of
    /// `training/models.py`): 3 GRU layers of 256 units over plain poses, residual,
    /// unconditioned, noise 32, forecaster 128 units, 8 intentions from 32 clusters, look-ahead
    /// 10, 32 convolution channels.
    pub fn paper(architecture: Architecture) -> Self {
        let vgru = architecture == Architecture::VgruD;
        let dae = architecture == Architecture::DaeLstm;
        let intention = architecture == Architecture::Intention;
        let arch = match architecture {
            Architecture::VgruD => ArchConfig::VgruD(VgruDFields { plan_hidden: 512 }),
            Architecture::GruD => ArchConfig::GruD(GruDFields {}),
            Architecture::DaeLstm => ArchConfig::DaeLstm(DaeLstmFields {
                dae_hidden: 3000,
                dae_layers: 3,
            }),
            Architecture::Intention => ArchConfig::Intention(IntentionFields {
                noise_dims: 32,
                noise_scale: None,
                label_hidden: 128,
                intentions: 8,
                clusters: 32,
                lookahead: 10,
                intention_features: 32,
            }),
        };
        ModelConfig {
            arch,
            frame_dims: H36M_FRAME_DIMS,
            dims_used: H36M_DIMS_USED.to_vec(),
            hidden: match architecture {
                Architecture::DaeLstm => 1000,
                Architecture::Intention => 256,
                _ => 512,
            },
            layers: match architecture {
                Architecture::VgruD => 1,
                Architecture::GruD => 2,
                Architecture::DaeLstm | Architecture::Intention => 3,
            },
            normalization: if dae { "min-max" } else { "standard" }.into(),
            gru_convention: if vgru {
                GruConvention::Paper
            } else {
                GruConvention::PyTorch
            },
            residual: intention,
            derivative_order: if dae || intention { 0 } else { 3 },
            derivative_padding: DERIVATIVE_PADDING.into(),
            fps: 25.0,
            skeleton: "h36m-32".into(),
            actions: if vgru || dae {
                H36M_ACTIONS.iter().map(|a| a.to_string()).collect()
            } else {
                Vec::new()
            },
            seed_frames: 50,
            horizon: 100,
        }
    }

    /// Every tensor name and shape this configuration implies (schema order: norm, network, decoder).
    pub fn tensor_shapes(&self) -> Vec<(String, Vec<usize>)> {
        let (h, i, o, f) = (
            self.hidden,
            self.input_dims(),
            self.output_dims(),
            self.frame_dims,
        );
        let mut shapes = vec![
            ("norm.mean".to_string(), vec![f]),
            ("norm.std".to_string(), vec![f]),
        ];
        fn gru(shapes: &mut Vec<(String, Vec<usize>)>, prefix: &str, inputs: usize, hidden: usize) {
            shapes.push((format!("{prefix}.weight_ih"), vec![3 * hidden, inputs]));
            shapes.push((format!("{prefix}.weight_hh"), vec![3 * hidden, hidden]));
            shapes.push((format!("{prefix}.bias_ih"), vec![3 * hidden]));
            shapes.push((format!("{prefix}.bias_hh"), vec![3 * hidden]));
        }
        match &self.arch {
            ArchConfig::GruD(_) => {
                for k in 0..self.layers {
                    gru(
                        &mut shapes,
                        &format!("rnn.{k}"),
                        if k == 0 { i } else { h },
                        h,
                    );
                }
            }
            ArchConfig::VgruD(fields) => {
                let p = fields.plan_hidden;
                gru(&mut shapes, "plan.cell", self.actions.len(), p);
                gru(&mut shapes, "body", i, h);
                shapes.push(("plan.mu".into(), vec![p]));
                shapes.push(("plan.sigma".into(), vec![p]));
                shapes.push(("body.weight_ph".into(), vec![3 * h, p]));
            }
            ArchConfig::Intention(_) => {
                let c = super::intention::IntentionConfig::of(self);
                let (l, n) = (c.label_hidden, c.intentions);
                shapes.push(("labels.centroids".into(), vec![c.clusters, o]));
                shapes.push(("labels.merge".into(), vec![c.clusters]));
                gru(&mut shapes, "label_encoder", c.label_input_dims(), l);
                gru(&mut shapes, "label_decoder", c.label_decoder_dims(), l);
                shapes.push(("label_out.weight".into(), vec![n, l]));
                shapes.push(("label_out.bias".into(), vec![n]));
                gru(&mut shapes, "pose_encoder", o, c.pose_hidden());
                shapes.push((
                    "intent_conv.weight".into(),
                    vec![c.features, n, c.lookahead],
                ));
                shapes.push(("intent_conv.bias".into(), vec![c.features]));
                for k in 0..self.layers {
                    gru(
                        &mut shapes,
                        &format!("rnn.{k}"),
                        if k == 0 { c.rnn_input_dims() } else { h },
                        h,
                    );
                }
            }
            ArchConfig::DaeLstm(fields) => {
                for k in 0..self.layers {
                    let inputs = if k == 0 { self.rnn_input_dims() } else { h };
                    shapes.push((format!("rnn.{k}.weight_ih"), vec![4 * h, inputs]));
                    shapes.push((format!("rnn.{k}.weight_hh"), vec![4 * h, h]));
                    shapes.push((format!("rnn.{k}.bias_ih"), vec![4 * h]));
                    shapes.push((format!("rnn.{k}.bias_hh"), vec![4 * h]));
                }
                for (k, w) in fields.widths(o).windows(2).enumerate() {
                    shapes.push((format!("dae.layers.{k}.weight"), vec![w[1], w[0]]));
                    shapes.push((format!("dae.layers.{k}.bias"), vec![w[1]]));
                }
            }
        }
        shapes.push(("decoder.weight".into(), vec![o, h]));
        shapes.push(("decoder.bias".into(), vec![o]));
        shapes
    }
}

/// Safetensors bytes of a schema-conformant file for `config` with random weights drawn from
/// `seed` (norm: mean 0, std 1; an intention model's merge table maps cluster `k` to intention
/// `k mod intentions`).
pub fn random_weights_bytes(config: &ModelConfig, seed: u64) -> Vec<u8> {
    let mut rng = StdRng::seed_from_u64(seed);
    let tensors: Vec<(String, Vec<usize>, Vec<f32>)> = config
        .tensor_shapes()
        .into_iter()
        .map(|(name, shape)| {
            let n: usize = shape.iter().product();
            let values: Vec<f32> = match name.as_str() {
                "norm.mean" | "plan.mu" | "plan.sigma" => vec![0.0; n],
                "norm.std" => vec![1.0; n],
                "labels.merge" => {
                    let c = super::intention::IntentionConfig::of(config)
                        .intentions
                        .max(1);
                    (0..n).map(|k| (k % c) as f32).collect()
                }
                _ => {
                    let fan = if name.contains("bias") || shape.len() < 2 {
                        config.hidden
                    } else {
                        shape[1].max(1)
                    };
                    let bound = 1.0 / (fan as f32).sqrt();
                    (0..n).map(|_| rng.random_range(-bound..bound)).collect()
                }
            };
            (name, shape, values)
        })
        .collect();
    let metadata = BTreeMap::from([
        ("format".to_string(), FORMAT_NAME.to_string()),
        ("format_version".to_string(), FORMAT_VERSION.to_string()),
        (
            "config".to_string(),
            serde_json::to_string(config).expect("config serializes"),
        ),
        (
            "provenance".to_string(),
            format!(r#"{{"data":"random","iterations":0,"seed":{seed}}}"#),
        ),
    ]);
    serialize_f32(
        tensors
            .iter()
            .map(|(name, shape, values)| (name.as_str(), shape.as_slice(), values.as_slice())),
        &metadata,
    )
}

impl MotionModel {
    /// A predictor with random weights for `config` (see [`random_weights_bytes`]).
    pub fn random(config: &ModelConfig, seed: u64) -> Result<Self, WeightsError> {
        let bytes = random_weights_bytes(config, seed);
        Self::from_store(&WeightStore::from_bytes(
            &bytes,
            format!("<random seed {seed}>"),
        )?)
    }
}
