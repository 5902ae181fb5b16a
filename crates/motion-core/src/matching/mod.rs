//! Motion matching: the baseline a learned, steerable locomotion model is measured against
//! (Clavet 2016; Holden et al. 2020's "Learned Motion Matching" describe the engine practice).
//! A [`MatchingDatabase`] holds every frame of some training clips with its matching features
//! ([`features`]: both ankles' positions and velocities and the hips' velocity now, the root's
//! position and facing 0.32, 0.68 and 1.0 s ahead, each group scaled by its spread) in a kiddo
//! kd-tree; a [`Matcher`] plays the database forward and, every [`SEARCH_FRAMES`] frames, jumps to
//! the frame whose features are nearest to the current pose's and to the trajectory a
//! [`Goal`] asks for (the goal velocity and facing approached with the time constants of
//! [`crate::steering`]), blending the jump away by inertialization (joint rotation offsets
//! decaying with a [`BLEND_HALFLIFE_S`] half-life). The root moves by the database's own root
//! motion, its heading drawn toward the goal's facing ([`crate::steering::TURN_TIME`]).
//!
//! Poses are [`Pose`]s on the database's skeleton, floor at `y = 0` (the database's median lowest
//! foot point), one per 25 Hz frame. No allocation per frame.
//!
//! ```no_run
//! use motion_core::matching::{MatchingDatabase, Matcher};
//! use motion_core::steering::{Goal, Vec2};
//! # fn clips() -> Vec<ndarray::Array2<f64>> { vec![] }
//! let clips = clips(); // H3.6M exp-map frames at 25 Hz, e.g. protocol::load_subject_sequences
//! let views: Vec<_> = clips.iter().map(|c| c.view()).collect();
//! let database = std::sync::Arc::new(MatchingDatabase::h36m(&views).unwrap());
//! let mut matcher = Matcher::new(database);
//! matcher.set_goal(Some(Goal::towards(Vec2::new(1.2, 0.0), 0.0)));
//! for _ in 0..100 {
//!     let pose = matcher.step(); // the next 25 Hz frame
//!     let _ = pose.root_translation;
//! }
//! ```
pub mod features;

use std::sync::Arc;

use glam::{Quat, Vec2, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use ndarray::ArrayView2;

use crate::grounding::{find_body_parts, LegsError};
use crate::pose::{root_motion_between, Pose, PoseDecoder};
use crate::root::RootEncoding;
use crate::skeleton::Skeleton;
use crate::steering::{wrap_angle, Goal, Steerable, Steering, TURN_TIME, VELOCITY_TIME};
use features::{
    pose_features, rotate, trajectory_features, GroundFrame, FEATURES, GROUPS, TRAJECTORY_FRAMES,
    TRAJECTORY_START,
};

/// Frames between searches (0.2 s at 25 Hz).
pub const SEARCH_FRAMES: usize = 5;
/// Half-life of the inertialization offsets after a jump (seconds).
pub const BLEND_HALFLIFE_S: f32 = 0.1;
/// The database's frame time (25 Hz).
pub const FRAME_TIME: f32 = 0.04;
/// A search result is taken only when its distance is under this share of the playing frame's
/// (squared distances).
pub const KEEP_PLAYING: f32 = 0.5;
/// A search result within this many frames of the playing frame, in the same clip, is no jump.
const SAME_PLACE_FRAMES: usize = 3;

/// Why a database could not be built.
#[derive(Debug, thiserror::Error)]
pub enum MatchingError {
    /// The skeleton's legs were not found (no feet to match).
    #[error("motion matching: {0}")]
    Legs(#[from] LegsError),
    /// No clip is long enough to hold a frame with a second of trajectory after it.
    #[error("motion matching: no clip has more than {0} frames")]
    TooShort(usize),
    /// A clip's frames are not of the skeleton's exp-map width.
    #[error("motion matching: clip {clip} has {got} values per frame, the skeleton {want}")]
    Width {
        /// Which clip (0-based).
        clip: usize,
        /// Its width.
        got: usize,
        /// The skeleton's exp-map width.
        want: usize,
    },
    /// A clip holds a value that is not finite.
    #[error("motion matching: clip {clip} frame {frame} holds a value that is not finite")]
    NotFinite {
        /// Which clip (0-based).
        clip: usize,
        /// Which frame (0-based).
        frame: usize,
    },
}

/// Every frame of some clips with its matching features, searchable by a kd-tree.
#[derive(Debug)]
pub struct MatchingDatabase {
    skeleton: Arc<Skeleton>,
    joints: usize,
    /// Reads headings the way the steering does.
    steering: Steering,
    /// Per frame, every joint's local rotation (joint 0: the root's world rotation).
    rotations: Vec<Quat>,
    /// Per frame, the root's world position (metres, the floor at `y = 0`).
    roots: Vec<Vec3>,
    /// Per frame, its ground frame.
    grounds: Vec<GroundFrame>,
    /// Per frame, its features (scaled); frames without a second after them or a frame before
    /// are not in the tree.
    features: Vec<[f32; FEATURES]>,
    /// Per frame, the last frame of its clip.
    clip_end: Vec<usize>,
    /// Per feature, the scale it was divided by.
    scale: [f32; FEATURES],
    /// Tree item -> frame.
    searchable: Vec<usize>,
    tree: ImmutableKdTree<f32, FEATURES>,
}

impl MatchingDatabase {
    /// A database of H3.6M exp-map clips at 25 Hz (root stored as deltas, the protocol's
    /// [`crate::protocol::load_subject_sequences`] frames).
    ///
    /// # Errors
    /// A clip of the wrong width or with a non-finite value; no clip longer than a second.
    pub fn h36m(clips: &[ArrayView2<'_, f64>]) -> Result<MatchingDatabase, MatchingError> {
        MatchingDatabase::new(Arc::new(Skeleton::h36m()), RootEncoding::Deltas, 2, clips)
    }

    /// A database of exp-map clips on `skeleton` at 25 Hz whose root is stored as `root` (with
    /// deltas, each frame spanning `step` source frames).
    ///
    /// # Errors
    /// See [`MatchingDatabase::h36m`]; a skeleton without two legs.
    pub fn new(
        skeleton: Arc<Skeleton>,
        root: RootEncoding,
        step: usize,
        clips: &[ArrayView2<'_, f64>],
    ) -> Result<MatchingDatabase, MatchingError> {
        let parts = find_body_parts(&skeleton)?;
        let ankles = [parts.legs[0].ankle, parts.legs[1].ankle];
        let feet: Vec<usize> = parts
            .legs
            .iter()
            .flat_map(|l| l.foot_points.iter().copied())
            .collect();
        let steering = Steering::new(&skeleton, FRAME_TIME)?;
        let joints = skeleton.len();
        let width = skeleton.expmap_width();
        let mut decoder = PoseDecoder::new(skeleton.clone(), root, step);
        let mut positions = vec![Vec3::ZERO; joints];
        let mut frame: Vec<f64> = Vec::with_capacity(width);
        let (mut rotations, mut roots, mut grounds) = (Vec::new(), Vec::new(), Vec::new());
        let (mut ankle_positions, mut lowest, mut clip_end) = (Vec::new(), Vec::new(), Vec::new());
        for (c, clip) in clips.iter().enumerate() {
            if clip.ncols() != width {
                return Err(MatchingError::Width {
                    clip: c,
                    got: clip.ncols(),
                    want: width,
                });
            }
            decoder.reset();
            let first = rotations.len() / joints.max(1);
            for (f, row) in clip.rows().into_iter().enumerate() {
                if row.iter().any(|v| !v.is_finite()) {
                    return Err(MatchingError::NotFinite { clip: c, frame: f });
                }
                frame.clear();
                frame.extend(row.iter());
                decoder.push(&frame);
                decoder.world_positions(&mut positions);
                let pose = decoder.pose();
                rotations.extend_from_slice(&pose.local_rotations);
                roots.push(pose.root_translation);
                grounds.push(GroundFrame {
                    position: Vec2::new(pose.root_translation.x, pose.root_translation.z),
                    facing: steering.heading_of(pose),
                });
                ankle_positions.push([positions[ankles[0]], positions[ankles[1]]]);
                lowest.push(
                    feet.iter()
                        .map(|&j| positions[j].y)
                        .fold(f32::INFINITY, f32::min),
                );
            }
            let last = roots.len().saturating_sub(1);
            clip_end.extend(std::iter::repeat_n(last, roots.len() - first));
        }
        // The floor: the median lowest foot point.
        let mut sorted = lowest.clone();
        sorted.sort_by(f32::total_cmp);
        let floor = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        for (r, a) in roots.iter_mut().zip(&mut ankle_positions) {
            r.y -= floor;
            for p in a.iter_mut() {
                p.y -= floor;
            }
        }
        let horizon = TRAJECTORY_FRAMES[2];
        let frames = roots.len();
        let mut features = vec![[0.0f32; FEATURES]; frames];
        let mut searchable = Vec::new();
        for i in 0..frames {
            let first_of_clip = i == 0 || clip_end[i - 1] != clip_end[i];
            let previous = if first_of_clip { i } else { i - 1 };
            let dt = if first_of_clip { 1.0 } else { FRAME_TIME };
            pose_features(
                &grounds[i],
                roots[i],
                ankle_positions[i],
                roots[previous],
                ankle_positions[previous],
                dt,
                &mut features[i],
            );
            let ahead = TRAJECTORY_FRAMES.map(|k| grounds[(i + k).min(clip_end[i])]);
            trajectory_features(&grounds[i], ahead, &mut features[i]);
            if !first_of_clip && i + horizon <= clip_end[i] {
                searchable.push(i);
            }
        }
        if searchable.is_empty() {
            return Err(MatchingError::TooShort(horizon + 1));
        }
        // Each group divided by its spread (the mean standard deviation of its numbers).
        let mut scale = [1.0f32; FEATURES];
        for &(start, len) in &GROUPS {
            let n = searchable.len() as f64;
            let spread: f64 = (start..start + len)
                .map(|d| {
                    let value = |i: usize| f64::from(features[i][d]);
                    let mean = searchable.iter().map(|&i| value(i)).sum::<f64>() / n;
                    let var = searchable
                        .iter()
                        .map(|&i| (value(i) - mean).powi(2))
                        .sum::<f64>()
                        / n;
                    var.sqrt() / len as f64
                })
                .sum();
            let spread = if spread > 1e-9 { spread as f32 } else { 1.0 };
            scale[start..start + len].fill(spread);
        }
        for f in &mut features {
            for (x, s) in f.iter_mut().zip(&scale) {
                *x /= s;
            }
        }
        let points: Vec<[f32; FEATURES]> = searchable.iter().map(|&i| features[i]).collect();
        let tree = ImmutableKdTree::new_from_slice(&points).expect("finite, non-empty features");
        Ok(MatchingDatabase {
            skeleton,
            joints,
            steering,
            rotations,
            roots,
            grounds,
            features,
            clip_end,
            scale,
            searchable,
            tree,
        })
    }

    /// The skeleton of the poses.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// Frames held.
    pub fn frames(&self) -> usize {
        self.roots.len()
    }

    /// Frames a search can land on (a frame before and a second after them in their clip).
    pub fn searchable_frames(&self) -> usize {
        self.searchable.len()
    }

    /// Bytes held (poses, roots, features and the tree's points), the baseline's memory.
    pub fn bytes(&self) -> usize {
        self.rotations.len() * std::mem::size_of::<Quat>()
            + self.roots.len() * std::mem::size_of::<Vec3>()
            + self.grounds.len() * std::mem::size_of::<GroundFrame>()
            + self.features.len() * std::mem::size_of::<[f32; FEATURES]>()
            + self.clip_end.len() * std::mem::size_of::<usize>()
            + self.searchable.len()
                * (std::mem::size_of::<usize>() + std::mem::size_of::<[f32; FEATURES]>())
    }

    /// The frame whose features are nearest to `query` (scaled like the database's), and its
    /// squared distance.
    fn nearest(&self, query: &[f32; FEATURES]) -> (usize, f32) {
        let found = self
            .tree
            .query(query)
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute();
        (self.searchable[found.item as usize], found.distance)
    }

    fn rotations_of(&self, frame: usize) -> &[Quat] {
        &self.rotations[frame * self.joints..(frame + 1) * self.joints]
    }
}

/// A character played from a [`MatchingDatabase`] toward a [`Goal`] (see the module docs).
#[derive(Debug, Clone)]
pub struct Matcher {
    database: Arc<MatchingDatabase>,
    /// The database frame playing.
    frame: usize,
    /// Frames since the last search.
    since_search: usize,
    goal: Option<Goal>,
    /// The commanded velocity and facing (approaching the goal's).
    velocity: Vec2,
    facing: f32,
    /// The character's ground frame in the world.
    ground: GroundFrame,
    /// Per joint, the rotation offset left by the last jump (decaying to identity).
    offsets: Vec<Quat>,
    /// The root height offset left by the last jump (metres).
    height_offset: f32,
    query: [f32; FEATURES],
    started: bool,
    /// Seconds passed to [`Steerable::advance`] not yet stepped.
    clock: f64,
    pose: Pose,
}

impl Matcher {
    /// A character at the origin facing +z, on the database's first searchable frame.
    pub fn new(database: Arc<MatchingDatabase>) -> Matcher {
        let joints = database.joints;
        let frame = database.searchable[0];
        Matcher {
            frame,
            since_search: 0,
            goal: None,
            velocity: Vec2::ZERO,
            facing: 0.0,
            ground: GroundFrame {
                position: Vec2::ZERO,
                facing: 0.0,
            },
            offsets: vec![Quat::IDENTITY; joints],
            height_offset: 0.0,
            query: [0.0; FEATURES],
            started: false,
            clock: 0.0,
            pose: Pose::rest(joints),
            database,
        }
    }

    /// The database played.
    pub fn database(&self) -> &Arc<MatchingDatabase> {
        &self.database
    }

    /// The skeleton of the poses.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.database.skeleton
    }

    /// Steers toward `goal` from the next frame on (`None`: play the database on, searching for
    /// the trajectory the playing clip has).
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        self.goal = goal;
    }

    /// The goal in force.
    pub fn goal(&self) -> Option<Goal> {
        self.goal
    }

    /// The heading (yaw about +y) of a pose: its pelvis's facing, as
    /// [`Steering::heading_of`] reads it.
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        self.database.steering.heading_of(pose)
    }

    /// The database frame playing.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// The next 25 Hz frame.
    pub fn step(&mut self) -> &Pose {
        let db = self.database.clone();
        let dt = FRAME_TIME;
        let previous = self.frame;
        // The commanded velocity and facing approach the goal's (set at once on the first frame).
        if let Some(goal) = self.goal {
            let (k, turn) = if self.started {
                (
                    1.0 - (-dt / VELOCITY_TIME).exp(),
                    1.0 - (-dt / TURN_TIME).exp(),
                )
            } else {
                (1.0, 1.0)
            };
            self.velocity += (goal.velocity - self.velocity) * k;
            self.facing += wrap_angle(goal.facing - self.facing) * turn;
        }
        // Play on; search every few frames with a goal, on the first frame, and where the clip
        // has less than a second left.
        let mut next = if self.started { previous + 1 } else { previous };
        let continuing = next < db.frames() && db.clip_end[next] == db.clip_end[previous];
        if !continuing {
            next = previous;
        }
        let at_end = !continuing || next + TRAJECTORY_FRAMES[2] > db.clip_end[next];
        self.since_search += 1;
        let due = self.goal.is_some() && (self.since_search >= SEARCH_FRAMES || !self.started);
        if at_end || due {
            self.since_search = 0;
            self.query = db.features[next];
            if self.goal.is_some() {
                self.desired_trajectory(&db);
            }
            let (best, cost) = db.nearest(&self.query);
            // Playing on wins unless the best is clearly better (fewer jumps, less jitter).
            let playing_on = db.features[next]
                .iter()
                .zip(&self.query)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>();
            let same = !at_end
                && (cost >= playing_on * KEEP_PLAYING
                    || db.clip_end[best] == db.clip_end[next]
                        && best.abs_diff(next) <= SAME_PLACE_FRAMES);
            if !same {
                self.jump(&db, next, best);
                next = best;
            }
        }
        // Root motion from the database, the heading drawn toward the commanded facing.
        if self.started {
            let (from, to) = (db.grounds[next - 1], db.grounds[next]);
            let step = from.local(to.position - from.position);
            self.ground.position += rotate(step, self.ground.facing);
            self.ground.facing += wrap_angle(to.facing - from.facing);
            if self.goal.is_some() {
                let turn = 1.0 - (-dt / TURN_TIME).exp();
                self.ground.facing += wrap_angle(self.facing - self.ground.facing) * turn;
            }
        } else if self.goal.is_some() {
            self.ground.facing = self.facing;
        }
        self.ground.facing = wrap_angle(self.ground.facing);
        self.frame = next;
        self.pose_from(&db, next);
        // The jump's offsets decay.
        let decay = 1.0 - (-dt * std::f32::consts::LN_2 / BLEND_HALFLIFE_S).exp();
        for o in &mut self.offsets {
            *o = o.slerp(Quat::IDENTITY, decay).normalize();
        }
        self.height_offset *= 1.0 - decay;
        self.started = true;
        &self.pose
    }

    /// The trajectory part of the query: where the commanded velocity, approaching the goal's,
    /// takes the character over the next second, and the facing it turns to, in the
    /// character's ground frame.
    fn desired_trajectory(&mut self, db: &MatchingDatabase) {
        let goal = self.goal.expect("a goal");
        let mut ahead = [self.ground; 3];
        let (mut position, mut velocity, mut facing) =
            (self.ground.position, self.velocity, self.ground.facing);
        let k = 1.0 - (-FRAME_TIME / VELOCITY_TIME).exp();
        let turn = 1.0 - (-FRAME_TIME / TURN_TIME).exp();
        let mut n = 0;
        for f in 1..=TRAJECTORY_FRAMES[2] {
            velocity += (goal.velocity - velocity) * k;
            position += velocity * FRAME_TIME;
            facing += wrap_angle(goal.facing - facing) * turn;
            if f == TRAJECTORY_FRAMES[n] {
                ahead[n] = GroundFrame { position, facing };
                n += 1;
            }
        }
        let mut trajectory = [0.0; FEATURES];
        trajectory_features(&self.ground, ahead, &mut trajectory);
        let parts = self.query.iter_mut().zip(&trajectory).zip(&db.scale);
        for ((q, t), s) in parts.skip(TRAJECTORY_START) {
            *q = t / s;
        }
    }

    /// Starts the inertialization of a jump from database frame `from` to `to`.
    fn jump(&mut self, db: &MatchingDatabase, from: usize, to: usize) {
        let (a, b) = (db.rotations_of(from), db.rotations_of(to));
        for j in 1..self.offsets.len() {
            self.offsets[j] = (self.offsets[j] * a[j] * b[j].inverse()).normalize();
        }
        // The root: its tilt and lean relative to the heading.
        let tilt = |frame: usize, q: Quat| Quat::from_rotation_y(-db.grounds[frame].facing) * q;
        self.offsets[0] =
            (self.offsets[0] * tilt(from, a[0]) * tilt(to, b[0]).inverse()).normalize();
        self.height_offset += db.roots[from].y - db.roots[to].y;
    }

    /// The output pose of database frame `frame` at the character's ground frame.
    fn pose_from(&mut self, db: &MatchingDatabase, frame: usize) {
        let source = db.rotations_of(frame);
        for (j, (out, &q)) in self
            .pose
            .local_rotations
            .iter_mut()
            .zip(source)
            .enumerate()
            .skip(1)
        {
            *out = (self.offsets[j] * q).normalize();
        }
        let tilt = Quat::from_rotation_y(-db.grounds[frame].facing) * source[0];
        let root_rotation =
            (Quat::from_rotation_y(self.ground.facing) * self.offsets[0] * tilt).normalize();
        self.pose.local_rotations[0] = root_rotation;
        let root = Vec3::new(
            self.ground.position.x,
            db.roots[frame].y + self.height_offset,
            self.ground.position.y,
        );
        let previous = self.started.then_some(self.pose.root_motion);
        self.pose.root_translation = root;
        self.pose.root_motion =
            root_motion_between(root.as_dvec3(), root_rotation.as_dquat(), previous);
    }
}

impl Steerable for Matcher {
    type Error = std::convert::Infallible;

    fn skeleton(&self) -> &Skeleton {
        &self.database.skeleton
    }

    fn set_goal(&mut self, goal: Option<Goal>) {
        Matcher::set_goal(self, goal);
    }

    /// Whole 25 Hz frames: as many as `dt` and the time left over from earlier calls cover
    /// (at least one on the first call), the pose of the last.
    fn advance(&mut self, dt: f64) -> Result<&Pose, Self::Error> {
        self.clock += dt;
        let frame = f64::from(FRAME_TIME);
        if !self.started {
            self.clock = self.clock.max(frame);
        }
        while self.clock >= frame * (1.0 - 1e-9) {
            self.clock -= frame;
            self.step();
        }
        Ok(&self.pose)
    }

    fn heading_of(&self, pose: &Pose) -> f32 {
        Matcher::heading_of(self, pose)
    }
}

#[cfg(test)]
mod tests;
