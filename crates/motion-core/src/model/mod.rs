//! Motion predictors (VGRU-d, GRU-d, DAE-LSTM, intention), self-describing weights and
//! closed-loop generation.
//!
//! - [`weights`]: safetensors tensors by state-dict name, [`WeightsError`].
//! - [`config`]: the `config` / `provenance` metadata of the schema in `weights/README.md`.
//! - [`MotionModel`]: a loaded predictor (shared, immutable); [`vgru`], [`grud`], [`dae_lstm`]
//!   and [`intention`] its networks, each file an architecture (its network and its config
//!   fields, [`arch::ArchFields`]), registered once below.
//! - [`Generator`] (one character) and [`BatchGenerator`] (many in lockstep): closed-loop frames;
//!   [`Character`] and [`Crowd`] turn them into engine poses.
//! - [`ActionClassifier`]: the action classifier of Ghosh et al. 2017 (section 4.5), the long-horizon
//!   evaluation instrument.
//! - [`random`]: schema-conformant files with random weights (benchmarks, tests).
//!
//! ```no_run
//! use motion_core::model::{Generator, MotionModel, Noise};
//! use std::sync::Arc;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = Arc::new(MotionModel::load("weights/vgru_d_multi.safetensors")?);
//! let seed = ndarray::Array2::<f32>::zeros((50, model.config().frame_dims)); // 50 full frames
//! let mut character = Generator::new(Arc::clone(&model)); // one per character
//! character.start(seed.view(), Some("walking"), Noise::Seed(42))?;
//! for _ in 0..100 {
//!     let frame: &[f32] = character.step()?; // next full frame (99 values), no allocation
//!     # let _ = frame;
//! }
//! # Ok(())
//! # }
//! ```
pub mod arch;
mod auto_control;
pub mod batch;
pub mod builtin;
pub mod character;
pub mod classifier;
pub mod config;
pub mod crowd;
pub mod dae_lstm;
pub mod generate_error;
pub mod generator;
pub mod goal_gru;
pub mod grud;
pub mod intention;
pub mod net;
pub mod norm;
pub mod pose_stream;
pub mod predictor;
pub mod prior;
pub mod random;
pub mod samples;
pub mod source;
pub mod vgru;
/// The weights store lives below both `nn` and `model` ([`crate::weights`]); this path is kept.
pub use crate::weights;

pub use batch::{BatchGenerator, FrameScalar, Noise};
pub use character::{Character, CharacterError};
pub use classifier::{ActionClassifier, ClassifierConfig, ClassifyError, CLASSIFIER_ARCHITECTURE};
pub use config::{ModelConfig, Provenance};
pub use crowd::{Crowd, MemberId};
pub use dae_lstm::DaeLstmFields;
pub use generate_error::GenerateError;
pub use generator::Generator;
pub use goal_gru::GoalGruFields;
pub use grud::GruDFields;
pub use intention::IntentionFields;
pub use pose_stream::PoseStream;
pub use predictor::{MotionModel, Network};
pub use samples::generate_samples;
pub use source::{MotionSource, SourceError};
pub use vgru::VgruDFields;
pub use weights::{WeightStore, WeightsError};

// The architectures, one line each: the schema name and the file's config fields. Adding an
// architecture is its file (network + `ArchFields`) and a line here.
arch::register_architectures! {
    /// VTLN-RNN with derivative inputs: plan GRU + body GRU + decoder (Gopalakrishnan et al.
    /// 2019, 3.2).
    VgruD("vgru-d", vgru::VgruDFields),
    /// Stacked GRU layers with derivative inputs + decoder (Gopalakrishnan et al. 2019, GRU-d).
    GruD("gru-d", grud::GruDFields),
    /// Stacked LSTM layers + decoder whose every output is filtered by a dropout autoencoder
    /// before it is fed back (Ghosh et al. 2017, section 3).
    DaeLstm("dae-lstm", dae_lstm::DaeLstmFields),
    /// Intention forecaster + noise-conditioned stacked GRU pose generator reading the
    /// intentions forecast ahead (Tanke et al. 2021, section 3).
    Intention("intention", intention::IntentionFields),
    /// Stacked GRU layers over plain poses + decoder, the first layer also reading where the
    /// root goes over the next second (steerable locomotion; `training/locomotion.py`).
    GoalGru("goal-gru", goal_gru::GoalGruFields),
}
