//! The database: every frame of some takes on one rig, its matching features, normalisation and
//! a kd-tree over them.
use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{Quat, Vec2, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use ndarray::ArrayView2;

use super::features::{
    pose_features, trajectory_features, trajectory_frames, GroundFrame, FEATURES, GROUPS,
};
use super::MatchingError;
use crate::grounding::{find_body_parts, BodyParts};
use crate::pose::{Pose, PoseDecoder};
use crate::root::RootEncoding;
use crate::skeleton::Skeleton;
use crate::steering::Steering;
use crate::takes::{annotate_poses, Takes};

/// Seconds between searches while a goal is set.
pub const SEARCH_INTERVAL_S: f64 = 0.1;
/// A frame is searchable only with at least this much of its take after it (seconds, and at
/// least two search intervals): a jump lands where the take plays on, not on its last frames
/// (which would loop there).
pub const SEARCH_TAIL_S: f64 = 0.5;
/// The default weight of each feature group ([`GROUPS`] order: foot positions, foot velocities,
/// hip velocity, trajectory positions, trajectory directions).
pub const DEFAULT_WEIGHTS: [f32; 5] = [0.75, 1.0, 1.0, 1.0, 1.5];
/// Frames after the last one of a take that its trajectory is extrapolated from (its last
/// velocity, its last facing).
const EXTRAPOLATE_FROM: usize = 5;

/// One take of a database: its name, where its frames are, and where it came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TakeInfo {
    /// The take's name (its file name without extension).
    pub name: String,
    /// Its first frame in the database.
    pub first: usize,
    /// Its frames.
    pub frames: usize,
    /// The rate of its file (Hz).
    pub source_fps: f64,
    /// Whether it was retargeted from another rig.
    pub retargeted: bool,
}

/// One take's frames as a database reads them (poses on the database's rig, metres, floor at
/// `y = 0`).
#[derive(Debug, Clone)]
pub struct DatabaseClip<'a> {
    /// Where it came from.
    pub info: TakeInfo,
    /// Poses.
    pub poses: &'a [Pose],
    /// Smoothed ground frames ([`crate::takes::smoothed_trajectory`]).
    pub trajectory: &'a [GroundFrame],
    /// Foot contacts.
    pub contacts: &'a [[bool; 2]],
}

/// Every frame of some takes with its matching features, searchable by a kd-tree (see the
/// module docs of [`crate::matching`]).
#[derive(Debug)]
pub struct MatchingDatabase {
    pub(super) skeleton: Arc<Skeleton>,
    pub(super) mm_per_unit: f64,
    pub(super) fps: f64,
    pub(super) joints: usize,
    pub(super) parts: BodyParts,
    pub(super) steering: Steering,
    /// Per frame, every joint's local rotation (joint 0: the root's world rotation).
    pub(super) rotations: Vec<Quat>,
    /// Per frame, the root's world position (metres, the take's floor at `y = 0`).
    pub(super) roots: Vec<Vec3>,
    /// Per frame, its smoothed ground frame.
    pub(super) grounds: Vec<GroundFrame>,
    /// Per frame, foot contacts.
    pub(super) contacts: Vec<[bool; 2]>,
    /// Per frame, its features (normalised and weighted).
    pub(super) features: Vec<[f32; FEATURES]>,
    /// Per feature, the mean subtracted and the scale divided by (before the weight).
    pub(super) mean: [f32; FEATURES],
    pub(super) scale: [f32; FEATURES],
    /// Per group, its weight.
    pub(super) weights: [f32; 5],
    /// Per frame, the last frame of its take.
    pub(super) clip_end: Vec<u32>,
    pub(super) takes: Vec<TakeInfo>,
    /// Tree item -> frame.
    pub(super) searchable: Vec<u32>,
    pub(super) tree: ImmutableKdTree<f32, FEATURES>,
    pub(super) trajectory_frames: [usize; 3],
    pub(super) search_frames: usize,
    /// `licence` and `provenance` metadata.
    pub(super) licence: String,
    pub(super) provenance: BTreeMap<String, String>,
}

impl MatchingDatabase {
    /// A database of H3.6M exp-map clips at 25 Hz (root stored as deltas, the protocol's
    /// [`crate::protocol::load_subject_sequences`] frames): the steering baseline over H3.6M.
    ///
    /// # Errors
    /// A clip of the wrong width or with a non-finite value; no clip longer than a second.
    pub fn h36m(clips: &[ArrayView2<'_, f64>]) -> Result<MatchingDatabase, MatchingError> {
        MatchingDatabase::from_expmap(Arc::new(Skeleton::h36m()), RootEncoding::Deltas, 2, clips)
    }

    /// A database of exp-map clips on `skeleton` at 25 Hz whose root is stored as `root` (with
    /// deltas, each frame spanning `step` source frames).
    ///
    /// # Errors
    /// See [`MatchingDatabase::h36m`]; a skeleton without two legs.
    pub fn from_expmap(
        skeleton: Arc<Skeleton>,
        root: RootEncoding,
        step: usize,
        clips: &[ArrayView2<'_, f64>],
    ) -> Result<MatchingDatabase, MatchingError> {
        let parts = find_body_parts(&skeleton)?;
        let width = skeleton.expmap_width();
        let fps = 25.0;
        let mut decoder = PoseDecoder::new(skeleton.clone(), root, step);
        let mut owned = Vec::new();
        for (c, clip) in clips.iter().enumerate() {
            if clip.ncols() != width {
                return Err(MatchingError::Width {
                    clip: c,
                    got: clip.ncols(),
                    want: width,
                });
            }
            if let Some((f, _)) = clip
                .rows()
                .into_iter()
                .enumerate()
                .find(|(_, r)| r.iter().any(|v| !v.is_finite()))
            {
                return Err(MatchingError::NotFinite { clip: c, frame: f });
            }
            let mut poses = decoder.decode_all(clip.view());
            let (trajectory, contacts) =
                annotate_poses(&skeleton, &parts, &mut poses, (1.0 / fps) as f32)
                    .map_err(MatchingError::Build)?;
            owned.push((poses, trajectory, contacts));
        }
        let mut first = 0;
        let views: Vec<DatabaseClip<'_>> = owned
            .iter()
            .enumerate()
            .map(|(c, (poses, trajectory, contacts))| {
                let info = TakeInfo {
                    name: format!("clip {c}"),
                    first,
                    frames: poses.len(),
                    source_fps: fps,
                    retargeted: false,
                };
                first += poses.len();
                DatabaseClip {
                    info,
                    poses,
                    trajectory,
                    contacts,
                }
            })
            .collect();
        MatchingDatabase::build(skeleton, 1.0, fps, &views, DEFAULT_WEIGHTS)
    }

    /// A database of takes read by [`crate::takes::read_takes`] (on their own rig).
    ///
    /// # Errors
    /// No take has a frame to search.
    pub fn from_takes(takes: &Takes, weights: [f32; 5]) -> Result<MatchingDatabase, MatchingError> {
        let mut first = 0;
        let clips: Vec<DatabaseClip<'_>> = takes
            .takes
            .iter()
            .map(|t| {
                let info = TakeInfo {
                    name: t.name.clone(),
                    first,
                    frames: t.len(),
                    source_fps: t.source_fps,
                    retargeted: t.retargeted,
                };
                first += t.len();
                DatabaseClip {
                    info,
                    poses: &t.poses,
                    trajectory: &t.trajectory,
                    contacts: &t.contacts,
                }
            })
            .collect();
        MatchingDatabase::build(
            takes.rig.skeleton.clone(),
            takes.rig.mm_per_unit,
            takes.fps,
            &clips,
            weights,
        )
    }

    /// A database of clips on `skeleton` (offsets in millimetres; `mm_per_unit` of the rig's
    /// file) at `fps`, each group of features weighted by `weights`.
    ///
    /// # Errors
    /// A skeleton without two legs, clips of another joint count, non-finite values, bad
    /// weights, or no frame to search.
    pub fn build(
        skeleton: Arc<Skeleton>,
        mm_per_unit: f64,
        fps: f64,
        clips: &[DatabaseClip<'_>],
        weights: [f32; 5],
    ) -> Result<MatchingDatabase, MatchingError> {
        let parts = find_body_parts(&skeleton)?;
        let frame_time = (1.0 / fps) as f32;
        let steering = Steering::new(&skeleton, frame_time)?;
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(MatchingError::Build(format!(
                "feature weights {weights:?} must be finite and non-negative"
            )));
        }
        let joints = skeleton.len();
        let horizon = trajectory_frames(fps);
        let search_frames = ((SEARCH_INTERVAL_S * fps).round() as usize).max(1);
        let tail = ((SEARCH_TAIL_S * fps).round() as usize).max(2 * search_frames);
        let total: usize = clips.iter().map(|c| c.poses.len()).sum();
        let mut rotations = Vec::with_capacity(total * joints);
        let (mut roots, mut grounds, mut contacts) = (
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
        );
        let mut clip_end = Vec::with_capacity(total);
        let mut takes = Vec::with_capacity(clips.len());
        let mut features = vec![[0.0f32; FEATURES]; total];
        let mut searchable = Vec::new();
        let (mut positions, mut world) = (vec![Vec3::ZERO; joints], vec![Quat::IDENTITY; joints]);
        for (c, clip) in clips.iter().enumerate() {
            let n = clip.poses.len();
            if clip.trajectory.len() != n || clip.contacts.len() != n {
                return Err(MatchingError::Build(format!(
                    "clip {c}: {n} poses, {} ground frames, {} contacts",
                    clip.trajectory.len(),
                    clip.contacts.len()
                )));
            }
            if n == 0 {
                continue;
            }
            let first = roots.len();
            let mut info = clip.info.clone();
            info.first = first;
            info.frames = n;
            takes.push(info);
            let mut ankles = Vec::with_capacity(n);
            for (f, pose) in clip.poses.iter().enumerate() {
                if pose.local_rotations.len() != joints {
                    return Err(MatchingError::Build(format!(
                        "clip {c} frame {f}: {} joints, the skeleton {joints}",
                        pose.local_rotations.len()
                    )));
                }
                let finite = pose.root_translation.is_finite()
                    && pose.local_rotations.iter().all(|q| q.is_finite());
                if !finite {
                    return Err(MatchingError::NotFinite { clip: c, frame: f });
                }
                pose.world_positions_into(&skeleton, &mut positions, &mut world);
                ankles.push([
                    positions[parts.legs[0].ankle],
                    positions[parts.legs[1].ankle],
                ]);
                rotations.extend_from_slice(&pose.local_rotations);
                roots.push(pose.root_translation);
                grounds.push(clip.trajectory[f]);
                contacts.push(clip.contacts[f]);
                clip_end.push((first + n - 1) as u32);
            }
            let last = first + n - 1;
            for f in 0..n {
                let i = first + f;
                // Velocities by a backward difference (the first frame: forward).
                let (a, b) = if f == 0 {
                    (0, 1.min(n - 1))
                } else {
                    (f - 1, f)
                };
                let dt = if a == b { 1.0 } else { frame_time };
                pose_features(
                    &grounds[i],
                    roots[first + b],
                    ankles[b],
                    roots[first + a],
                    ankles[a],
                    dt,
                    &mut features[i],
                );
                // Frames beyond the take's end are extrapolated from its last velocity.
                let ahead = horizon.map(|k| ground_ahead(&grounds[first..=last], f, k));
                trajectory_features(&grounds[i], ahead, &mut features[i]);
                if i + tail <= last {
                    searchable.push(i as u32);
                }
            }
        }
        if searchable.is_empty() {
            return Err(MatchingError::TooShort(tail));
        }
        // Per feature: the mean over searchable frames; per group: the mean standard deviation
        // of its numbers.
        let mut mean = [0.0f32; FEATURES];
        let mut scale = [1.0f32; FEATURES];
        let count = searchable.len() as f64;
        for &(start, len) in &GROUPS {
            let mut spread = 0.0;
            for d in start..start + len {
                let value = |i: &u32| f64::from(features[*i as usize][d]);
                let m = searchable.iter().map(value).sum::<f64>() / count;
                let var = searchable
                    .iter()
                    .map(|i| (value(i) - m).powi(2))
                    .sum::<f64>()
                    / count;
                mean[d] = m as f32;
                spread += var.sqrt() / len as f64;
            }
            let spread = if spread > 1e-9 { spread as f32 } else { 1.0 };
            scale[start..start + len].fill(spread);
        }
        let mut db = MatchingDatabase {
            skeleton,
            mm_per_unit,
            fps,
            joints,
            parts,
            steering,
            rotations,
            roots,
            grounds,
            contacts,
            features,
            mean,
            scale,
            weights,
            clip_end,
            takes,
            searchable,
            tree: ImmutableKdTree::new_from_slice(&[[0.0; FEATURES]])
                .map_err(|e| MatchingError::Build(format!("the kd-tree: {e:?}")))?,
            trajectory_frames: horizon,
            search_frames,
            licence: String::new(),
            provenance: BTreeMap::new(),
        };
        let mut raw = std::mem::take(&mut db.features);
        for f in &mut raw {
            db.normalise(f);
        }
        db.features = raw;
        db.rebuild_tree()?;
        Ok(db)
    }

    /// Builds the kd-tree over the searchable frames' features.
    pub(super) fn rebuild_tree(&mut self) -> Result<(), MatchingError> {
        let points: Vec<[f32; FEATURES]> = self
            .searchable
            .iter()
            .map(|&i| self.features[i as usize])
            .collect();
        if points.iter().flatten().any(|v| !v.is_finite()) {
            return Err(MatchingError::Build("a feature is not finite".into()));
        }
        self.tree = ImmutableKdTree::new_from_slice(&points)
            .map_err(|e| MatchingError::Build(format!("the kd-tree: {e:?}")))?;
        Ok(())
    }

    /// Raw features normalised and weighted as the database's are.
    pub fn normalise(&self, raw: &mut [f32; FEATURES]) {
        for (g, &(start, len)) in GROUPS.iter().enumerate() {
            let span = start..start + len;
            for ((x, mean), scale) in raw[span.clone()]
                .iter_mut()
                .zip(&self.mean[span.clone()])
                .zip(&self.scale[span])
            {
                *x = (*x - mean) / scale * self.weights[g];
            }
        }
    }

    /// Sets the `licence` entry (what a product may do with the frames).
    pub fn set_licence(&mut self, licence: impl Into<String>) {
        self.licence = licence.into();
    }

    /// The `licence` entry.
    pub fn licence(&self) -> &str {
        &self.licence
    }

    /// Adds a `provenance` entry (where the frames came from, how it was built).
    pub fn set_provenance(&mut self, key: impl Into<String>, value: impl Into<String>) {
        self.provenance.insert(key.into(), value.into());
    }

    /// The `provenance` entries.
    pub fn provenance(&self) -> &BTreeMap<String, String> {
        &self.provenance
    }

    /// The skeleton of the poses (offsets in millimetres).
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// Millimetres per unit of the rig's own files (BVH written on the rig use its units).
    pub fn mm_per_unit(&self) -> f64 {
        self.mm_per_unit
    }

    /// The frame rate (Hz).
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// The legs and torso of the rig.
    pub fn body_parts(&self) -> &BodyParts {
        &self.parts
    }

    /// Frames held.
    pub fn frames(&self) -> usize {
        self.roots.len()
    }

    /// The takes, in order.
    pub fn takes(&self) -> &[TakeInfo] {
        &self.takes
    }

    /// Frames a search can land on.
    pub fn searchable_frames(&self) -> usize {
        self.searchable.len()
    }

    /// The feature groups' weights.
    pub fn weights(&self) -> [f32; 5] {
        self.weights
    }

    /// Frames between searches while a goal is set.
    pub fn search_frames(&self) -> usize {
        self.search_frames
    }

    /// Frames ahead of the three trajectory samples.
    pub fn trajectory_frames(&self) -> [usize; 3] {
        self.trajectory_frames
    }

    /// Bytes held in memory (poses, roots, ground frames, contacts, features and the tree's
    /// points).
    pub fn bytes(&self) -> usize {
        self.rotations.len() * std::mem::size_of::<Quat>()
            + self.roots.len() * std::mem::size_of::<Vec3>()
            + self.grounds.len() * std::mem::size_of::<GroundFrame>()
            + self.contacts.len() * 2
            + self.features.len() * std::mem::size_of::<[f32; FEATURES]>()
            + self.clip_end.len() * 4
            + self.searchable.len() * (4 + std::mem::size_of::<[f32; FEATURES]>())
    }

    /// The database frame `frame` as a pose (the take's own world placement).
    pub fn pose(&self, frame: usize) -> Pose {
        let mut pose = Pose::rest(self.joints);
        pose.local_rotations
            .copy_from_slice(self.rotations_of(frame));
        pose.root_translation = self.roots[frame];
        pose
    }

    /// The ground frame of database frame `frame`.
    pub fn ground(&self, frame: usize) -> GroundFrame {
        self.grounds[frame]
    }

    /// The foot contacts of database frame `frame`.
    pub fn contacts(&self, frame: usize) -> [bool; 2] {
        self.contacts[frame]
    }

    /// The (normalised) features of database frame `frame`.
    pub fn features(&self, frame: usize) -> &[f32; FEATURES] {
        &self.features[frame]
    }

    /// The frame whose features are nearest to `query` (normalised like the database's), and
    /// its squared distance.
    pub fn nearest(&self, query: &[f32; FEATURES]) -> (usize, f32) {
        let found = self
            .tree
            .query(query)
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute();
        (
            self.searchable[found.item as usize] as usize,
            found.distance,
        )
    }

    /// The same search by brute force (the reference the kd-tree is tested against).
    pub fn nearest_brute_force(&self, query: &[f32; FEATURES]) -> (usize, f32) {
        self.searchable
            .iter()
            .map(|&i| {
                let d = self.features[i as usize]
                    .iter()
                    .zip(query)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f32>();
                (i as usize, d)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a searchable frame")
    }

    pub(super) fn rotations_of(&self, frame: usize) -> &[Quat] {
        &self.rotations[frame * self.joints..(frame + 1) * self.joints]
    }

    pub(super) fn clip_end(&self, frame: usize) -> usize {
        self.clip_end[frame] as usize
    }
}

/// The ground frame `k` frames after frame `f` of a take's `grounds`, extrapolated past its end
/// from its last velocity (its facing held).
fn ground_ahead(grounds: &[GroundFrame], f: usize, k: usize) -> GroundFrame {
    let last = grounds.len() - 1;
    let target = f + k;
    if target <= last {
        return grounds[target];
    }
    let back = EXTRAPOLATE_FROM.min(last);
    let end = grounds[last];
    if back == 0 {
        return end;
    }
    let velocity: Vec2 = (end.position - grounds[last - back].position) / back as f32;
    GroundFrame {
        position: end.position + velocity * (target - last) as f32,
        facing: end.facing,
    }
}
