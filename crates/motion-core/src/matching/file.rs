//! The database file: one self-describing safetensors file (schema in `weights/README.md`,
//! "Motion-matching databases").
//!
//! Metadata: `format` = `motion-matching`, `format_version` = `1`, `config` (JSON: rate, units,
//! feature groups and weights, trajectory times, search interval, the rig as BVH text), `takes`
//! (JSON: each take's name, first frame, frames, source rate, whether retargeted), `licence`
//! (text) and `provenance` (JSON object of strings). Tensors: `frames.rotations` `[F, J, 4]`
//! (f16, each joint's local rotation as x, y, z, w; joint 0 the root's world rotation),
//! `frames.roots` `[F, 3]` (f32, metres, the take's floor at `y = 0`), `frames.ground` `[F, 3]`
//! (f32: the smoothed ground position x, z and facing), `frames.contacts` `[F, 2]` (f16, 0 or 1),
//! `features.values` `[F, 27]` (f16, normalised and weighted), `features.mean` and
//! `features.scale` `[27]` (f32).
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Quat, Vec2, Vec3};
use safetensors::tensor::{Dtype, TensorView};
use serde::{Deserialize, Serialize};

use super::database::{MatchingDatabase, TakeInfo};
use super::features::{trajectory_frames, GroundFrame, FEATURES, GROUP_NAMES, TRAJECTORY_TIMES_S};
use super::MatchingError;
use crate::formats::bvh::{parse_bvh, to_bvh_string, Bvh};
use crate::grounding::find_body_parts;
use crate::seed::rescale_bvh;
use crate::steering::Steering;
use crate::weights::{WeightStore, WeightsError};

/// The `format` metadata of a database file.
pub const FORMAT_NAME: &str = "motion-matching";
/// The `format_version` this crate reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The `config` metadata of a database file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatabaseConfig {
    /// Frames per second.
    pub fps: f64,
    /// Millimetres per unit of the rig's files.
    pub mm_per_unit: f64,
    /// Joints of the rig (End Sites included).
    pub joints: usize,
    /// Frames held.
    pub frames: usize,
    /// The feature groups, in order.
    pub groups: Vec<String>,
    /// Each group's weight.
    pub weights: Vec<f32>,
    /// Seconds ahead of the trajectory samples.
    pub trajectory_s: Vec<f64>,
    /// Seconds between searches while steered.
    pub search_interval_s: f64,
    /// The rig as BVH text (hierarchy in the rig's units, one frame of zeros).
    pub rig_bvh: String,
}

/// Whether an opened safetensors file is a motion-matching database.
pub fn is_database(store: &WeightStore) -> bool {
    store.metadata("format") == Some(FORMAT_NAME)
}

fn half_bytes(values: impl Iterator<Item = f32>) -> Vec<u8> {
    values
        .flat_map(|v| half::f16::from_f32(v).to_le_bytes())
        .collect()
}

fn f32_bytes(values: impl Iterator<Item = f32>) -> Vec<u8> {
    values.flat_map(|v| v.to_le_bytes()).collect()
}

impl MatchingDatabase {
    /// The database as safetensors bytes (see the module docs).
    ///
    /// # Errors
    /// The rig cannot be written as BVH.
    pub fn to_bytes(&self) -> Result<Vec<u8>, MatchingError> {
        let frames = self.frames();
        let rig = Bvh {
            skeleton: self.skeleton.as_ref().clone(),
            frames: ndarray::Array2::zeros((1, self.skeleton.channel_count())),
            frame_time: 1.0 / self.fps,
        };
        let rig = rescale_bvh(&rig, 1.0 / self.mm_per_unit).map_err(MatchingError::Build)?;
        let rig_bvh = to_bvh_string(&rig).map_err(|e| MatchingError::Build(e.to_string()))?;
        let config = DatabaseConfig {
            fps: self.fps,
            mm_per_unit: self.mm_per_unit,
            joints: self.joints,
            frames,
            groups: GROUP_NAMES.iter().map(|s| s.to_string()).collect(),
            weights: self.weights.to_vec(),
            trajectory_s: TRAJECTORY_TIMES_S.to_vec(),
            search_interval_s: self.search_frames as f64 / self.fps,
            rig_bvh,
        };
        let json = |v: &dyn erased::Json| v.json();
        let mut metadata = BTreeMap::new();
        metadata.insert("format".to_string(), FORMAT_NAME.to_string());
        metadata.insert("format_version".to_string(), FORMAT_VERSION.to_string());
        metadata.insert("config".to_string(), json(&config));
        metadata.insert("takes".to_string(), json(&self.takes));
        metadata.insert("licence".to_string(), self.licence.clone());
        metadata.insert("provenance".to_string(), json(&self.provenance));
        let rotations = half_bytes(self.rotations.iter().flat_map(|q| q.to_array()));
        let roots = f32_bytes(self.roots.iter().flat_map(|r| r.to_array()));
        let ground = f32_bytes(
            self.grounds
                .iter()
                .flat_map(|g| [g.position.x, g.position.y, g.facing]),
        );
        let contacts = half_bytes(
            self.contacts
                .iter()
                .flat_map(|c| c.map(|b| if b { 1.0 } else { 0.0 })),
        );
        let features = half_bytes(self.features.iter().flatten().copied());
        let mean = f32_bytes(self.mean.iter().copied());
        let scale = f32_bytes(self.scale.iter().copied());
        let tensors: Vec<(&str, Dtype, Vec<usize>, &[u8])> = vec![
            (
                "frames.rotations",
                Dtype::F16,
                vec![frames, self.joints, 4],
                &rotations,
            ),
            ("frames.roots", Dtype::F32, vec![frames, 3], &roots),
            ("frames.ground", Dtype::F32, vec![frames, 3], &ground),
            ("frames.contacts", Dtype::F16, vec![frames, 2], &contacts),
            (
                "features.values",
                Dtype::F16,
                vec![frames, FEATURES],
                &features,
            ),
            ("features.mean", Dtype::F32, vec![FEATURES], &mean),
            ("features.scale", Dtype::F32, vec![FEATURES], &scale),
        ];
        let views = tensors
            .iter()
            .map(|(name, dtype, shape, bytes)| {
                let view = TensorView::new(*dtype, shape.clone(), bytes)
                    .map_err(|e| MatchingError::Build(format!("tensor {name}: {e:?}")))?;
                Ok((name.to_string(), view))
            })
            .collect::<Result<Vec<_>, MatchingError>>()?;
        let metadata = metadata.into_iter().collect();
        safetensors::serialize(views, Some(metadata))
            .map_err(|e| MatchingError::Build(format!("safetensors: {e:?}")))
    }

    /// Writes the database to `path` (a temporary file renamed into place).
    ///
    /// # Errors
    /// See [`MatchingDatabase::to_bytes`]; the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<(), MatchingError> {
        let bytes = self.to_bytes()?;
        crate::formats::atomic::write_bytes_atomically(path, &bytes)
            .map_err(|e| MatchingError::Io(e.to_string()))
    }

    /// Loads a database file.
    ///
    /// # Errors
    /// A file that is not a database of this format, or whose tensors disagree with its
    /// `config` and `takes` (each error names the file and the entry).
    pub fn load(path: impl AsRef<Path>) -> Result<MatchingDatabase, MatchingError> {
        let store = WeightStore::open(path.as_ref())?;
        MatchingDatabase::from_store(&store)
    }

    /// The database of an opened file (see [`MatchingDatabase::load`]).
    ///
    /// # Errors
    /// See [`MatchingDatabase::load`].
    pub fn from_store(store: &WeightStore) -> Result<MatchingDatabase, MatchingError> {
        let path = store.path().to_path_buf();
        let bad = |key: &str, problem: String| {
            MatchingError::Weights(WeightsError::BadConfig {
                path: path.clone(),
                key: key.to_string(),
                problem,
            })
        };
        let format = store.require_metadata("format")?;
        if format != FORMAT_NAME {
            return Err(bad(
                "format",
                format!("`{format}`, expected `{FORMAT_NAME}`"),
            ));
        }
        let version = store.require_metadata("format_version")?;
        if version.trim() != FORMAT_VERSION.to_string() {
            return Err(bad(
                "format_version",
                format!("`{version}`: this reader reads version {FORMAT_VERSION}"),
            ));
        }
        let config: DatabaseConfig = serde_json::from_str(store.require_metadata("config")?)
            .map_err(|e| bad("config", e.to_string()))?;
        let takes: Vec<TakeInfo> = serde_json::from_str(store.require_metadata("takes")?)
            .map_err(|e| bad("takes", e.to_string()))?;
        let licence = store.metadata("licence").unwrap_or_default().to_string();
        let provenance: BTreeMap<String, String> = match store.metadata("provenance") {
            Some(text) => {
                serde_json::from_str(text).map_err(|e| bad("provenance", e.to_string()))?
            }
            None => BTreeMap::new(),
        };
        if !(config.fps.is_finite() && (1.0..=1000.0).contains(&config.fps)) {
            return Err(bad(
                "config",
                format!("fps {} is not 1 to 1000", config.fps),
            ));
        }
        if !(config.mm_per_unit.is_finite() && config.mm_per_unit > 0.0) {
            return Err(bad("config", format!("mm_per_unit {}", config.mm_per_unit)));
        }
        let weights: [f32; 5] = config
            .weights
            .clone()
            .try_into()
            .map_err(|_| bad("config", "weights: five numbers expected".into()))?;
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(bad("config", format!("weights {weights:?}")));
        }
        if config.groups != GROUP_NAMES {
            return Err(bad(
                "config",
                format!(
                    "feature groups {:?}, this reader knows {GROUP_NAMES:?}",
                    config.groups
                ),
            ));
        }
        let rig =
            parse_bvh(&config.rig_bvh, &path).map_err(|e| bad("config.rig_bvh", e.to_string()))?;
        let rig = rescale_bvh(&rig, config.mm_per_unit).map_err(|e| bad("config.rig_bvh", e))?;
        let skeleton = Arc::new(rig.skeleton);
        let joints = skeleton.len();
        if joints != config.joints {
            return Err(bad(
                "config",
                format!("{} joints, the rig has {joints}", config.joints),
            ));
        }
        let frames = config.frames;
        let mut next = 0;
        for t in &takes {
            if t.first != next || t.frames == 0 {
                return Err(bad(
                    "takes",
                    format!(
                        "take {:?} starts at frame {} with {} frames, expected to start at {next}",
                        t.name, t.first, t.frames
                    ),
                ));
            }
            next += t.frames;
        }
        if next != frames {
            return Err(bad(
                "takes",
                format!("the takes hold {next} frames, config {frames}"),
            ));
        }
        let parts = find_body_parts(&skeleton)?;
        let steering = Steering::new(&skeleton, (1.0 / config.fps) as f32)?;
        let rotations = store.tensor("frames.rotations", &[frames, joints, 4])?;
        let roots = store.tensor("frames.roots", &[frames, 3])?;
        let ground = store.tensor("frames.ground", &[frames, 3])?;
        let contacts = store.tensor("frames.contacts", &[frames, 2])?;
        let features = store.tensor("features.values", &[frames, FEATURES])?;
        let mean = store.tensor("features.mean", &[FEATURES])?;
        let scale = store.tensor("features.scale", &[FEATURES])?;
        if scale.iter().any(|s| *s <= 0.0) {
            return Err(bad("features.scale", "a scale that is not positive".into()));
        }
        let rotations: Vec<Quat> = rotations
            .chunks_exact(4)
            .map(|q| {
                let q = Quat::from_xyzw(q[0], q[1], q[2], q[3]);
                if q.length_squared() > 1e-6 {
                    q.normalize()
                } else {
                    Quat::IDENTITY
                }
            })
            .collect();
        let mut clip_end = Vec::with_capacity(frames);
        for t in &takes {
            clip_end.extend(std::iter::repeat_n(
                (t.first + t.frames - 1) as u32,
                t.frames,
            ));
        }
        let search_frames = ((config.search_interval_s * config.fps).round() as usize).max(1);
        let searchable: Vec<u32> = (0..frames)
            .filter(|&i| i + search_frames <= clip_end[i] as usize)
            .map(|i| i as u32)
            .collect();
        if searchable.is_empty() {
            return Err(bad("takes", "no frame to search".into()));
        }
        let mut db = MatchingDatabase {
            skeleton,
            mm_per_unit: config.mm_per_unit,
            fps: config.fps,
            joints,
            parts,
            steering,
            rotations,
            roots: roots
                .chunks_exact(3)
                .map(|r| Vec3::new(r[0], r[1], r[2]))
                .collect(),
            grounds: ground
                .chunks_exact(3)
                .map(|g| GroundFrame {
                    position: Vec2::new(g[0], g[1]),
                    facing: g[2],
                })
                .collect(),
            contacts: contacts
                .chunks_exact(2)
                .map(|c| [c[0] > 0.5, c[1] > 0.5])
                .collect(),
            features: features
                .chunks_exact(FEATURES)
                .map(|f| f.try_into().expect("27 values"))
                .collect(),
            mean: mean.try_into().expect("27 values"),
            scale: scale.try_into().expect("27 values"),
            weights,
            clip_end,
            takes,
            searchable,
            tree: kiddo::ImmutableKdTree::new_from_slice(&[[0.0; FEATURES]])
                .map_err(|e| MatchingError::Build(format!("the kd-tree: {e:?}")))?,
            trajectory_frames: trajectory_frames(config.fps),
            search_frames,
            licence,
            provenance,
        };
        db.rebuild_tree()?;
        Ok(db)
    }
}

mod erased {
    /// Serialises any `Serialize` value as JSON (one call site for the metadata entries).
    pub trait Json {
        fn json(&self) -> String;
    }

    impl<T: serde::Serialize> Json for T {
        fn json(&self) -> String {
            serde_json::to_string(self).expect("plain data serialises")
        }
    }
}
