//! Motion-weights files with random weights, for benchmarks and tests of the engine (never for
//! motion): every tensor the schema names, uniform in `±1/sqrt(fan)` like PyTorch's default
//! init, serialized to real safetensors bytes so the normal loader (and its checks) is used.
use super::config::{ModelConfig, FORMAT_NAME, FORMAT_VERSION};
use super::predictor::MotionModel;
use super::weights::{serialize_f32, WeightStore, WeightsError};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::collections::BTreeMap;

/// Safetensors bytes of a schema-conformant file for `config` with random weights drawn from
/// `seed` (norm: mean 0, std 1; where uniform noise is not valid, the architecture's
/// [`ArchFields::random_values`](super::arch::ArchFields::random_values)).
pub fn random_weights_bytes(config: &ModelConfig, seed: u64) -> Vec<u8> {
    let mut rng = StdRng::seed_from_u64(seed);
    let tensors: Vec<(String, Vec<usize>, Vec<f32>)> = config
        .tensor_shapes()
        .into_iter()
        .map(|(name, shape)| {
            let n: usize = shape.iter().product();
            let own = config.arch.random_values(config, &name, n);
            let values: Vec<f32> = match name.as_str() {
                _ if own.is_some() => own.unwrap_or_default(),
                "norm.mean" => vec![0.0; n],
                "norm.std" => vec![1.0; n],
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
