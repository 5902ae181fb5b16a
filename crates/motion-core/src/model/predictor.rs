//! A loaded motion predictor: configuration, provenance, normalization, recurrent network and
//! decoder, read from one self-describing safetensors file (schema: weights/README.md).
//!
//! Citation: Gopalakrishnan, Mali, Kifer, Giles, Ororbia, "A Neural Temporal Model for Human
//! Motion Prediction", CVPR 2019 — Gopalakrishnan et al. 2019, sections 3.2-3.3 (VGRU-d, GRU-d); Ghosh, Song,
//! Aksan, Hilliges, "Learning Human Motion Models for Long-term Predictions", 3DV 2017 — paper
//! 002, section 3 (DAE-LSTM); Tanke, Zaveri, Gall, "Intention-based Long-Term Human Motion
//! Anticipation", 3DV 2021 — Tanke et al. 2021, section 3 (intention).
use super::config::{check_format, parse_provenance, Architecture, ModelConfig, Provenance};
use super::dae_lstm::DaeLstm;
use super::grud::GruD;
use super::intention::Intention;
use super::net::Net;
use super::norm::Normalization;
use super::vgru::VgruD;
use super::weights::{WeightStore, WeightsError};
use crate::nn::{Linear, LinearConfig};
use std::path::{Path, PathBuf};

/// The recurrent part of a predictor.
#[derive(Debug, Clone)]
pub enum Network {
    /// VGRU-d: plan GRU + body GRU.
    Vgru(Box<VgruD>),
    /// GRU-d: stacked GRU layers.
    Grud(GruD),
    /// DAE-LSTM: stacked LSTM layers and the dropout autoencoder that filters each output.
    DaeLstm(Box<DaeLstm>),
    /// Intention forecaster and noise-conditioned stacked GRU pose generator.
    Intention(Box<Intention>),
}

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
        let norm = Normalization::load(store, config.frame_dims, &config.dims_used)?;
        let network = match config.architecture() {
            Architecture::VgruD => Network::Vgru(Box::new(VgruD::load(store, &config)?)),
            Architecture::GruD => Network::Grud(GruD::load(store, &config)?),
            Architecture::DaeLstm => Network::DaeLstm(Box::new(DaeLstm::load(store, &config)?)),
            Architecture::Intention => {
                Network::Intention(Box::new(Intention::load(store, &config)?))
            }
        };
        let decoder = Linear::load(
            store,
            "decoder",
            LinearConfig {
                inputs: config.hidden,
                outputs: config.output_dims(),
            },
        )?;
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
    /// The network as the generators drive it: the one list of architectures.
    pub fn net(&self) -> &dyn Net {
        match self {
            Network::Vgru(n) => n.as_ref(),
            Network::Grud(n) => n,
            Network::DaeLstm(n) => n.as_ref(),
            Network::Intention(n) => n.as_ref(),
        }
    }
}
