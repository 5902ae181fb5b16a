//! A loaded motion predictor: configuration, provenance, normalization, recurrent network and
//! decoder, read from one self-describing safetensors file (schema: weights/README.md).
//!
//! Citation: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 — Gopalakrishnan et al. 2019, sections 3.2-3.3 (VGRU-d, GRU-d); Ghosh, Song,
//! Aksan, Hilliges, "Learning Human Motion Models for Long-term Predictions", 3DV 2017 — paper
//! 002, section 3 (DAE-LSTM); Tanke, Zaveri, Gall, "Intention-based Long-Term Human Motion
//! Anticipation", 3DV 2021 — Tanke et al. 2021, section 3 (intention).
use super::config::{check_format, parse_provenance, ModelConfig, Provenance};
use super::net::Net;
use super::norm::Normalization;
use super::prior::PosePrior;
use super::weights::{WeightStore, WeightsError};
use crate::nn::{Linear, LinearConfig};
use crate::skeleton::Skeleton;
use std::any::Any;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The recurrent part of a predictor: the architecture's [`Net`] (shared by clones).
#[derive(Debug, Clone)]
pub struct Network(Arc<dyn Net>);

/// Immutable predictor weights; share one across characters and threads with `Arc`.
#[derive(Debug, Clone)]
pub struct MotionModel {
    path: PathBuf,
    config: ModelConfig,
    provenance: Provenance,
    norm: Normalization,
    network: Network,
    decoder: Linear,
    stored_dtype: String,
    skeleton: Arc<Skeleton>,
    prior: Option<PosePrior>,
}

impl MotionModel {
    /// Loads a motion-weights file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, WeightsError> {
        Self::from_store(&WeightStore::open(path)?)
    }

    /// Builds the predictor from an already parsed file, checking the schema's metadata and every
    /// tensor the configuration implies (presence, dtype, shape, finiteness).
    pub fn from_store(store: &WeightStore) -> Result<Self, WeightsError> {
        let path = store.path().to_path_buf();
        check_format(store)?;
        let config = ModelConfig::from_json(store.require_metadata("config")?, &path)?;
        let provenance = match store.metadata("provenance") {
            Some(json) => parse_provenance(json, &path)?,
            None => Provenance::new(),
        };
        let skeleton = Arc::new(
            config
                .skeleton()
                .map_err(|problem| WeightsError::BadConfig {
                    path: path.clone(),
                    key: "config".into(),
                    problem,
                })?,
        );
        let norm = Normalization::load(store, config.frame_dims, &config.dims_used)?;
        let network = Network(config.arch.load(store, &config)?);
        let decoder = Linear::load(
            store,
            "decoder",
            LinearConfig {
                inputs: config.hidden,
                outputs: config.output_dims(),
            },
        )?;
        let prior = match config.prior_radius {
            Some(radius) => Some(PosePrior::load(
                store,
                radius,
                config.actions.len(),
                config.output_dims(),
            )?),
            None => None,
        };
        let stored_dtype = store
            .dtype_name("decoder.weight")
            .unwrap_or_else(|| "F32".into());
        Ok(Self {
            path,
            config,
            provenance,
            norm,
            network,
            decoder,
            stored_dtype,
            skeleton,
            prior,
        })
    }

    /// The file the weights came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The `config` metadata.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// The pose prior of its closed loop, if the file has one ([`crate::model::prior`]).
    pub fn prior(&self) -> Option<&PosePrior> {
        self.prior.as_ref()
    }

    /// The skeleton its frames are on (H3.6M's, or the rig the file holds).
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// The `provenance` metadata (empty if the file has none).
    pub fn provenance(&self) -> &Provenance {
        &self.provenance
    }

    /// Normalization statistics.
    pub fn normalization(&self) -> &Normalization {
        &self.norm
    }

    /// The recurrent network.
    pub fn network(&self) -> &Network {
        &self.network
    }

    /// The output decoder.
    pub fn decoder(&self) -> &Linear {
        &self.decoder
    }

    /// Dtype the weights were stored in (`F32`, `F16` or `BF16`; computed in f32 regardless).
    pub fn stored_dtype(&self) -> &str {
        &self.stored_dtype
    }

    /// Trainable parameters (normalization statistics excluded), as PyTorch counts them.
    pub fn parameter_count(&self) -> usize {
        self.network.net().parameter_count() + self.decoder.parameter_count()
    }

    /// Width of the hidden state the decoder reads.
    pub fn top_hidden(&self) -> usize {
        self.config.hidden
    }
}

impl Network {
    /// The network as the generators drive it.
    pub fn net(&self) -> &dyn Net {
        self.0.as_ref()
    }

    /// The network as its concrete type (`VgruD`, `GruD`, `DaeLstm`, `Intention`), if it is one.
    pub fn downcast_ref<T: Net>(&self) -> Option<&T> {
        let any: &dyn Any = self.0.as_ref();
        any.downcast_ref()
    }
}
