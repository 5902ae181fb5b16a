//! What drives a character, loaded by one loader: a learned model ([`MotionModel`]) or a
//! motion-matching database ([`MatchingDatabase`]). [`MotionSource::load`] tells them apart by
//! the file's `format` metadata (`motion-weights` or `motion-matching`), so every front end that
//! opens a file plays either kind.
use std::path::Path;
use std::sync::Arc;

use super::predictor::MotionModel;
use crate::matching::{is_database, MatchingDatabase, MatchingError};
use crate::skeleton::Skeleton;
use crate::weights::{WeightStore, WeightsError};

/// A learned model or a motion-matching database (shared, immutable).
#[derive(Debug, Clone)]
pub enum MotionSource {
    /// A learned predictor (on H3.6M's skeleton or a rig).
    Model(Arc<MotionModel>),
    /// A motion-matching database on its takes' rig.
    Database(Arc<MatchingDatabase>),
}

/// Why a file could not be opened as either kind.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SourceError {
    /// A learned model's file is bad.
    #[error(transparent)]
    Weights(#[from] WeightsError),
    /// A database file is bad.
    #[error(transparent)]
    Matching(#[from] MatchingError),
}

impl MotionSource {
    /// Opens a weights or database file.
    ///
    /// # Errors
    /// The file cannot be read, or is neither kind, or fails its kind's checks.
    pub fn load(path: impl AsRef<Path>) -> Result<MotionSource, SourceError> {
        let store = WeightStore::open(path)?;
        MotionSource::from_store(&store)
    }

    /// The source of an opened file (see [`MotionSource::load`]).
    ///
    /// # Errors
    /// See [`MotionSource::load`].
    pub fn from_store(store: &WeightStore) -> Result<MotionSource, SourceError> {
        if is_database(store) {
            Ok(MotionSource::Database(Arc::new(
                MatchingDatabase::from_store(store)?,
            )))
        } else {
            Ok(MotionSource::Model(Arc::new(MotionModel::from_store(
                store,
            )?)))
        }
    }

    /// The skeleton the poses are on (a learned model's: H3.6M's or the rig its file holds; a
    /// database's rig).
    pub fn skeleton(&self) -> Arc<Skeleton> {
        match self {
            MotionSource::Model(m) => Arc::clone(m.skeleton()),
            MotionSource::Database(db) => db.skeleton().clone(),
        }
    }

    /// Whether it plays on a rig of its own (a database, or a learned model whose file holds its
    /// rig): seeded with poses on that rig ([`super::Character::start_poses_with`]), not with
    /// H3.6M exp-map frames.
    pub fn plays_on_rig(&self) -> bool {
        match self {
            MotionSource::Model(m) => m.config().skeleton == super::config::RIG_SKELETON,
            MotionSource::Database(_) => true,
        }
    }

    /// Millimetres per unit of the rig's files (a database's or a rig model's; 1 for H3.6M's
    /// skeleton): BVH written on the rig use them.
    pub fn rig_mm_per_unit(&self) -> f64 {
        match self {
            MotionSource::Model(m) => m.config().mm_per_unit.unwrap_or(1.0),
            MotionSource::Database(db) => db.mm_per_unit(),
        }
    }

    /// Frames per second of the source's own frames.
    pub fn fps(&self) -> f64 {
        match self {
            MotionSource::Model(m) => m.config().fps,
            MotionSource::Database(db) => db.fps(),
        }
    }

    /// The learned model, if it is one.
    pub fn model(&self) -> Option<&Arc<MotionModel>> {
        match self {
            MotionSource::Model(m) => Some(m),
            MotionSource::Database(_) => None,
        }
    }

    /// The database, if it is one.
    pub fn database(&self) -> Option<&Arc<MatchingDatabase>> {
        match self {
            MotionSource::Model(_) => None,
            MotionSource::Database(db) => Some(db),
        }
    }
}

impl From<Arc<MotionModel>> for MotionSource {
    fn from(model: Arc<MotionModel>) -> Self {
        MotionSource::Model(model)
    }
}

impl From<MotionModel> for MotionSource {
    fn from(model: MotionModel) -> Self {
        MotionSource::Model(Arc::new(model))
    }
}

impl From<Arc<MatchingDatabase>> for MotionSource {
    fn from(db: Arc<MatchingDatabase>) -> Self {
        MotionSource::Database(db)
    }
}

impl From<MatchingDatabase> for MotionSource {
    fn from(db: MatchingDatabase) -> Self {
        MotionSource::Database(Arc::new(db))
    }
}

impl From<&Arc<MotionModel>> for MotionSource {
    fn from(model: &Arc<MotionModel>) -> Self {
        MotionSource::Model(Arc::clone(model))
    }
}
