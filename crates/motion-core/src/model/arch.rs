//! What one architecture supplies, and the one macro that registers the architectures.
//!
//! An architecture is one file of this module's parent: its network (a [`Net`]) and the config
//! fields only it has, a type implementing [`ArchFields`] (its checks, `motion-cli info`'s lines,
//! the tensors it reads, its paper configuration and its loader). The parent registers every
//! architecture in one `register_architectures!` list, which generates the [`Architecture`]
//! and [`ArchConfig`] enums (tagged by the config's `architecture` key) and every dispatch over
//! them; nothing else lists the architectures.
//!
//! [`Architecture`]: super::Architecture
//! [`ArchConfig`]: super::ArchConfig
use std::fmt::Debug;
use std::sync::Arc;

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::config::ModelConfig;
use super::net::Net;
use super::weights::{WeightStore, WeightsError};

/// The config fields of one architecture (beside the shared ones of [`ModelConfig`]) and what
/// the engine needs of it.
pub trait ArchFields: Debug + Clone + PartialEq + Serialize + DeserializeOwned {
    /// Whether the model draws noise, so that samples of one seed differ.
    const STOCHASTIC: bool;

    /// The configuration of the architecture's paper (H3.6M frames at 25 Hz).
    fn paper() -> ModelConfig;

    /// Checks the fields against the shared ones (which passed their own checks); returns what
    /// is wrong.
    fn validate(&self, config: &ModelConfig) -> Result<(), String>;

    /// `motion-cli info`'s lines, `(key, value)`: what the architecture is first, its sizes
    /// (`sizes`) last.
    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)>;

    /// Width of the first recurrent layer's input: the frame's features unless the
    /// architecture appends more (DAE-LSTM: the action one-hot).
    fn rnn_input_dims(&self, config: &ModelConfig) -> usize {
        config.input_dims()
    }

    /// Appends the name and shape of every tensor the network reads, in schema order (between
    /// `norm.*` and `decoder.*`).
    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>);

    /// The values of tensor `name` (`n` of them) in a file of random weights
    /// ([`random`](super::random)) where uniform noise would not be valid; `None` otherwise.
    fn random_values(&self, _config: &ModelConfig, _name: &str, _n: usize) -> Option<Vec<f32>> {
        None
    }

    /// Reads the network's tensors (everything but `norm.*` and `decoder.*`).
    ///
    /// # Errors
    /// A tensor missing or of the wrong dtype, shape or values, named.
    fn load(&self, store: &WeightStore, config: &ModelConfig)
        -> Result<Arc<dyn Net>, WeightsError>;
}

/// Appends the four tensors of a GRU cell named `prefix` (PyTorch's `weight_ih`, `weight_hh`,
/// `bias_ih`, `bias_hh`) to `shapes`.
pub fn gru_shapes(
    shapes: &mut Vec<(String, Vec<usize>)>,
    prefix: &str,
    inputs: usize,
    hidden: usize,
) {
    shapes.push((format!("{prefix}.weight_ih"), vec![3 * hidden, inputs]));
    shapes.push((format!("{prefix}.weight_hh"), vec![3 * hidden, hidden]));
    shapes.push((format!("{prefix}.bias_ih"), vec![3 * hidden]));
    shapes.push((format!("{prefix}.bias_hh"), vec![3 * hidden]));
}

/// Appends the GRU cells `{prefix}.{k}` of `layers` stacked layers of `hidden` units, the first
/// reading `inputs` values (GRU-d, `goal-gru`, the intention model's pose decoder).
pub fn stacked_gru_shapes(
    shapes: &mut Vec<(String, Vec<usize>)>,
    prefix: &str,
    layers: usize,
    inputs: usize,
    hidden: usize,
) {
    for k in 0..layers {
        let width = if k == 0 { inputs } else { hidden };
        gru_shapes(shapes, &format!("{prefix}.{k}"), width, hidden);
    }
}

/// Registers the architectures: one line each, `Variant("schema-name", path::to::Fields)` with
/// its doc comment. Generates `Architecture` (a plain tag), `ArchConfig` (the tag with its
/// fields, `#[serde(tag = "architecture")]`) and their dispatch to [`ArchFields`].
macro_rules! register_architectures {
    ($( $(#[$doc:meta])* $variant:ident($name:literal, $fields:ty) ),+ $(,)?) => {
        /// Which predictor a weights file holds (the config's `architecture` key).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
        pub enum Architecture {
            $( $(#[$doc])* #[serde(rename = $name)] $variant, )+
        }

        impl Architecture {
            /// Every registered architecture.
            pub const ALL: &'static [Architecture] = &[$( Architecture::$variant ),+];

            /// The schema name (the `architecture` key's value).
            pub fn name(self) -> &'static str {
                match self { $( Architecture::$variant => $name, )+ }
            }

            /// The architecture of a schema name.
            pub fn from_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|a| a.name() == name)
            }

            /// Whether the model draws noise, so that samples of one seed differ.
            pub fn is_stochastic(self) -> bool {
                match self {
                    $( Architecture::$variant =>
                        <$fields as $crate::model::arch::ArchFields>::STOCHASTIC, )+
                }
            }

            /// The configuration of the architecture's paper.
            pub fn paper_config(self) -> ModelConfig {
                match self {
                    $( Architecture::$variant =>
                        <$fields as $crate::model::arch::ArchFields>::paper(), )+
                }
            }
        }

        /// The config fields that belong to one architecture, tagged by the `architecture` key.
        #[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(tag = "architecture")]
        pub enum ArchConfig {
            $( $(#[$doc])* #[serde(rename = $name)] $variant($fields), )+
        }

        $(
            impl From<$fields> for ArchConfig {
                fn from(fields: $fields) -> Self {
                    ArchConfig::$variant(fields)
                }
            }
        )+

        impl ArchConfig {
            /// Which architecture.
            pub fn architecture(&self) -> Architecture {
                match self { $( ArchConfig::$variant(_) => Architecture::$variant, )+ }
            }

            /// The architecture's checks of its fields against the shared ones.
            pub fn validate(&self, config: &ModelConfig) -> Result<(), String> {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.validate(config), )+ }
            }

            /// What the architecture is and its own sizes in words, as `(key, value)` lines
            /// (`motion-cli info`; the last is `sizes`).
            pub fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.describe(config), )+ }
            }

            /// Width of the first recurrent layer's input.
            pub fn rnn_input_dims(&self, config: &ModelConfig) -> usize {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.rnn_input_dims(config), )+ }
            }

            /// Appends the network's tensors (see [`ArchFields::tensor_shapes`]).
            ///
            /// [`ArchFields::tensor_shapes`]: $crate::model::arch::ArchFields::tensor_shapes
            pub fn tensor_shapes(
                &self,
                config: &ModelConfig,
                shapes: &mut Vec<(String, Vec<usize>)>,
            ) {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.tensor_shapes(config, shapes), )+ }
            }

            /// Values of a random file's tensor where uniform noise is not valid.
            pub fn random_values(
                &self,
                config: &ModelConfig,
                name: &str,
                n: usize,
            ) -> Option<Vec<f32>> {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.random_values(config, name, n), )+ }
            }

            /// Reads the network's tensors.
            ///
            /// # Errors
            /// A tensor missing or of the wrong dtype, shape or values, named.
            pub fn load(
                &self,
                store: &$crate::weights::WeightStore,
                config: &ModelConfig,
            ) -> Result<std::sync::Arc<dyn $crate::model::net::Net>, $crate::weights::WeightsError>
            {
                use $crate::model::arch::ArchFields;
                match self { $( ArchConfig::$variant(f) => f.load(store, config), )+ }
            }
        }
    };
}
pub(crate) use register_architectures;
