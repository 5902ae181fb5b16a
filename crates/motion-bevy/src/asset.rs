//! motion-weights `.safetensors` files as Bevy assets.

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetLoader, LoadContext};
use bevy::reflect::TypePath;
use motion_core::model::weights::WeightStore;
use motion_core::model::{MotionSource, SourceError};

/// A learned model or a motion-matching database loaded from a self-describing safetensors file
/// (`asset_server.load("vgru.safetensors")`, `asset_server.load("matching_cmu.safetensors")`).
#[derive(Asset, TypePath, Debug, Clone)]
pub struct MotionWeights {
    /// The model or database, shared by every character that uses it.
    pub source: MotionSource,
}

/// Why a weights file did not load.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MotionAssetError {
    /// The bytes could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The asset path.
        path: String,
        /// What the reader said.
        source: std::io::Error,
    },
    /// The file is not a valid motion model (names the tensor or field at fault).
    #[error(transparent)]
    Weights(#[from] motion_core::model::weights::WeightsError),
    /// The file is not a valid model or database (names the tensor or field at fault).
    #[error(transparent)]
    Source(#[from] SourceError),
}

/// Loads [`MotionWeights`] from `.safetensors` files.
#[derive(Debug, Default, TypePath)]
pub struct MotionWeightsLoader;

impl AssetLoader for MotionWeightsLoader {
    type Asset = MotionWeights;
    type Settings = ();
    type Error = MotionAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<MotionWeights, MotionAssetError> {
        let path = load_context.path().to_string();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|source| MotionAssetError::Io {
                path: path.clone(),
                source,
            })?;
        let store = WeightStore::from_bytes(&bytes, path)?;
        Ok(MotionWeights {
            source: MotionSource::from_store(&store)?,
        })
    }

    fn extensions(&self) -> &[&str] {
        &["safetensors"]
    }
}
