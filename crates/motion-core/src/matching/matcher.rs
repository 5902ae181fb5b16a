//! The runtime: a character played from a [`MatchingDatabase`] toward a [`Goal`].
use std::sync::Arc;

use glam::{Quat, Vec2, Vec3};

use super::database::MatchingDatabase;
use super::features::{
    pose_features, trajectory_features, GroundFrame, FEATURES, TRAJECTORY_START,
};
use super::MatchingError;
use crate::grounding::floor::Floor;
use crate::grounding::{GroundingConfig, PoseGrounder};
use crate::pose::{root_motion_between, Pose, RootMotion};
use crate::skeleton::Skeleton;
use crate::steering::{wrap_angle, Goal, Steerable, TURN_TIME, VELOCITY_TIME};

/// Half-life of the inertialization offsets after a jump (seconds).
pub const BLEND_HALFLIFE_S: f32 = 0.1;
/// A search result is taken only when its distance is under this share of the playing frame's
/// (squared distances).
pub const KEEP_PLAYING: f32 = 0.5;
/// A search result within this many frames of the playing frame, in the same take, is no jump.
const SAME_PLACE_FRAMES: usize = 3;
/// The lean limit a database plays under unless the grounding configuration sets one (degrees:
/// none in effect; real takes lean as they lean).
pub const REAL_MOTION_LEAN_DEG: f32 = 90.0;
/// The facing correction toward the commanded facing per frame is at most this share of the
/// turn the database frame plays ...
pub const CORRECTION_TURN_SHARE: f32 = 0.5;
/// ... plus this rate (radians per second: 180 degrees/s).
pub const CORRECTION_TURN_RAD_S: f32 = std::f32::consts::PI;
/// Seconds of a seed the start reads its velocity and turn rate over.
const SEED_HISTORY_S: f32 = 0.5;

/// The scaled axis-angle of a rotation (the shorter way round).
fn log_q(q: Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let v = Vec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-8 {
        return v * 2.0;
    }
    v * (2.0 * s.atan2(q.w) / s)
}

/// A critically damped offset `x` with velocity `v` decayed over `dt` (half-life `halflife`).
fn decay(x: &mut Vec3, v: &mut Vec3, halflife: f32, dt: f32) {
    let y = 2.0 * std::f32::consts::LN_2 / halflife;
    let j1 = *v + *x * y;
    let e = (-y * dt).exp();
    *x = (*x + j1 * dt) * e;
    *v = (*v - j1 * (y * dt)) * e;
}

/// The root's rotation under its heading at database frame `f`.
fn tilt(db: &MatchingDatabase, f: usize) -> Quat {
    Quat::from_rotation_y(-db.grounds[f].facing) * db.rotations_of(f)[0]
}

/// The root's position in its ground frame at database frame `f` (height in y).
fn local_root(db: &MatchingDatabase, f: usize) -> Vec3 {
    let g = db.grounds[f];
    g.local3(db.roots[f] - Vec3::new(g.position.x, 0.0, g.position.y))
}

/// The two consecutive frames a frame's velocity is read from (within its take).
fn step_frames(db: &MatchingDatabase, frame: usize) -> (usize, usize) {
    let end = db.clip_end(frame);
    if frame < end {
        (frame, frame + 1)
    } else {
        (frame.saturating_sub(1), frame)
    }
}

/// A character played from a [`MatchingDatabase`] toward a [`Goal`] (see the module docs of
/// [`crate::matching`]). No allocation per frame.
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
    /// Per joint, the rotation offset left by jumps (scaled axis-angle, joint 0: the root's tilt
    /// under its heading) and its velocity, decaying to zero.
    offsets: Vec<Vec3>,
    offset_velocities: Vec<Vec3>,
    /// The root's offset in the ground frame left by jumps, and its velocity.
    root_offset: Vec3,
    root_offset_velocity: Vec3,
    query: [f32; FEATURES],
    started: bool,
    /// Seconds passed to [`Steerable::advance`] not yet stepped.
    clock: f64,
    raw: Pose,
    grounder: PoseGrounder,
    /// The height of the floor the seed stood on (the output stands on it).
    floor_height: f32,
    previous_motion: Option<RootMotion>,
    pose: Pose,
    positions: Vec<Vec3>,
    world: Vec<Quat>,
}

impl Matcher {
    /// A character at the origin facing the database's first searchable frame's facing, on that
    /// frame, grounded ([`GroundingConfig::default`]).
    pub fn new(database: Arc<MatchingDatabase>) -> Matcher {
        Matcher::with_grounding(database, GroundingConfig::default())
    }

    /// [`Matcher::new`] grounded as `grounding` says ([`GroundingConfig::off`]: the database's
    /// frames as they are, blended). The database plays real takes: a lean limit or hip-height
    /// hold left to the action (`None`) is off ([`REAL_MOTION_LEAN_DEG`], no hold); floor, foot
    /// locking and the takes' own contacts ([`crate::grounding::Grounder::set_source_contacts`])
    /// remain.
    pub fn with_grounding(
        database: Arc<MatchingDatabase>,
        mut grounding: GroundingConfig,
    ) -> Matcher {
        grounding.max_lean_deg = grounding.max_lean_deg.or(Some(REAL_MOTION_LEAN_DEG));
        grounding.min_hip_fraction = grounding.min_hip_fraction.or(Some(0.0));
        let joints = database.joints;
        let frame_time = (1.0 / database.fps) as f32;
        let grounder = PoseGrounder::new(&database.skeleton, frame_time, grounding)
            .expect("the database's rig has legs (checked when it was built)");
        let mut matcher = Matcher {
            frame: database.searchable[0] as usize,
            since_search: 0,
            goal: None,
            velocity: Vec2::ZERO,
            facing: 0.0,
            ground: GroundFrame {
                position: Vec2::ZERO,
                facing: 0.0,
            },
            offsets: vec![Vec3::ZERO; joints],
            offset_velocities: vec![Vec3::ZERO; joints],
            root_offset: Vec3::ZERO,
            root_offset_velocity: Vec3::ZERO,
            query: [0.0; FEATURES],
            started: false,
            clock: 0.0,
            raw: Pose::rest(joints),
            grounder,
            floor_height: 0.0,
            previous_motion: None,
            pose: Pose::rest(joints),
            positions: vec![Vec3::ZERO; joints],
            world: vec![Quat::IDENTITY; joints],
            database,
        };
        matcher.reset_grounding_on_database();
        matcher
    }

    /// The database played.
    pub fn database(&self) -> &Arc<MatchingDatabase> {
        &self.database
    }

    /// The skeleton of the poses.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.database.skeleton
    }

    /// Seconds per frame.
    pub fn frame_time(&self) -> f64 {
        1.0 / self.database.fps
    }

    /// Steers toward `goal` from the next frame on (`None`: play the database on).
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        if goal.is_some() && self.goal.is_none() {
            self.velocity = self.current_velocity();
            self.facing = self.ground.facing;
        }
        self.goal = goal;
        self.grounder.set_root_leads(goal.is_some());
    }

    /// The goal in force.
    pub fn goal(&self) -> Option<Goal> {
        self.goal
    }

    /// The heading (yaw about +y) of a pose: its pelvis's facing.
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        self.database.steering.heading_of(pose)
    }

    /// The database frame playing.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// The last pose made (the last seed pose right after [`Matcher::start`]).
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// The ground velocity of the database frame playing (world axes, m/s).
    fn current_velocity(&self) -> Vec2 {
        let db = &self.database;
        let (a, b) = step_frames(db, self.frame);
        let step = db.grounds[a].local(db.grounds[b].position - db.grounds[a].position);
        self.ground.world(step) * db.fps as f32
    }

    /// Grounding fitted on the database's own floor (`y = 0`).
    fn reset_grounding_on_database(&mut self) {
        self.grounder.reset(None);
        self.grounder.set_root_leads(self.goal.is_some());
        let db = self.database.clone();
        let end = db.clip_end(self.frame);
        for f in self.frame..=end.min(self.frame + db.search_frames * 3) {
            self.raw.local_rotations.copy_from_slice(db.rotations_of(f));
            self.raw.root_translation = db.roots[f];
            self.grounder.observe_seed(&self.raw);
        }
        self.grounder.set_floor(Floor::level_at(0.0));
        self.floor_height = 0.0;
        self.previous_motion = None;
    }

    /// Continues `seed` (poses on the database's rig, oldest first, anywhere in the world, on a
    /// level floor): the database frame nearest its last pose (and the goal, or where the seed
    /// was going) plays on from there, blended from the seed's last pose; the output stays in the
    /// seed's coordinates. Returns the seed's last pose.
    ///
    /// # Errors
    /// An empty seed, a seed of another joint count, or a non-finite value.
    pub fn start(&mut self, seed: &[Pose]) -> Result<&Pose, MatchingError> {
        let db = self.database.clone();
        let joints = db.joints;
        let Some(last) = seed.last() else {
            return Err(MatchingError::Seed("the seed has no frames".into()));
        };
        if let Some((f, p)) = seed
            .iter()
            .enumerate()
            .find(|(_, p)| p.local_rotations.len() != joints)
        {
            return Err(MatchingError::Seed(format!(
                "seed frame {f} has {} joints, the database's rig {joints}",
                p.local_rotations.len()
            )));
        }
        if let Some(f) = seed.iter().position(|p| {
            !(p.root_translation.is_finite() && p.local_rotations.iter().all(|q| q.is_finite()))
        }) {
            return Err(MatchingError::Seed(format!(
                "seed frame {f} holds a non-finite value"
            )));
        }
        let dt = (1.0 / db.fps) as f32;
        // The seed's floor: the median of its frames' lowest foot points.
        let mut lows: Vec<f32> = Vec::with_capacity(seed.len());
        let mut ankles = Vec::with_capacity(2);
        for (t, pose) in seed.iter().enumerate() {
            pose.world_positions_into(&db.skeleton, &mut self.positions, &mut self.world);
            let low = db
                .parts
                .legs
                .iter()
                .flat_map(|l| l.foot_points.iter())
                .map(|&j| self.positions[j].y)
                .fold(f32::INFINITY, f32::min);
            lows.push(low);
            if t + 2 >= seed.len() {
                ankles.push([
                    self.positions[db.parts.legs[0].ankle],
                    self.positions[db.parts.legs[1].ankle],
                ]);
            }
        }
        lows.sort_by(f32::total_cmp);
        let floor = lows[lows.len() / 2];
        let down = Vec3::new(0.0, floor, 0.0);
        let previous = if seed.len() >= 2 {
            &seed[seed.len() - 2]
        } else {
            last
        };
        let (ankles_before, ankles_now) = (ankles[0], ankles[ankles.len() - 1]);
        // Where the seed was going over its last half second.
        let back = ((SEED_HISTORY_S / dt).round() as usize).clamp(1, seed.len().max(2) - 1);
        let back = back.min(seed.len() - 1);
        let mut heading = db.steering.heading_of(last);
        let (mut turn_rate, mut velocity) = (0.0, Vec2::ZERO);
        if back > 0 {
            let old = &seed[seed.len() - 1 - back];
            let span = back as f32 * dt;
            // Average heading over the window (the pelvis swing removed), unwrapped.
            let mut sum = 0.0;
            let mut h = db.steering.heading_of(old);
            let first = h;
            for pose in &seed[seed.len() - 1 - back..] {
                h += wrap_angle(db.steering.heading_of(pose) - h);
                sum += h;
            }
            heading = wrap_angle(sum / (back + 1) as f32);
            turn_rate = (h - first) / span;
            let (a, b) = (old.root_translation, last.root_translation);
            velocity = Vec2::new(b.x - a.x, b.z - a.z) / span;
        }
        self.ground = GroundFrame {
            position: Vec2::new(last.root_translation.x, last.root_translation.z),
            facing: heading,
        };
        self.velocity = velocity;
        self.facing = heading;
        // The query: the seed's last pose and where it was going (or the goal).
        let mut raw = [0.0f32; FEATURES];
        pose_features(
            &self.ground,
            last.root_translation - down,
            ankles_now.map(|a| a - down),
            previous.root_translation - down,
            ankles_before.map(|a| a - down),
            dt,
            &mut raw,
        );
        let mut ahead = [self.ground; 3];
        for (k, &frames) in db.trajectory_frames.iter().enumerate() {
            let t = frames as f32 * dt;
            ahead[k] = GroundFrame {
                position: self.ground.position + velocity * t,
                facing: self.ground.facing + (turn_rate * t).clamp(-2.0, 2.0),
            };
        }
        trajectory_features(&self.ground, ahead, &mut raw);
        db.normalise(&mut raw);
        self.query = raw;
        if self.goal.is_some() {
            self.desired_trajectory(&db);
        }
        let (best, _) = db.nearest(&self.query);
        // Offsets that take the database frame to the seed's last pose, decaying from there.
        let (a, b) = step_frames(&db, best);
        for j in 1..joints {
            let (qa, qb) = (db.rotations_of(a)[j], db.rotations_of(b)[j]);
            let w_db = log_q(qb * qa.inverse()) / dt;
            let w_seed =
                log_q(last.local_rotations[j] * previous.local_rotations[j].inverse()) / dt;
            self.offsets[j] = log_q(last.local_rotations[j] * db.rotations_of(best)[j].inverse());
            self.offset_velocities[j] = w_seed - w_db;
        }
        let seed_tilt =
            |p: &Pose, g: &GroundFrame| Quat::from_rotation_y(-g.facing) * p.local_rotations[0];
        let tilt_best = tilt(&db, best);
        self.offsets[0] = log_q(seed_tilt(last, &self.ground) * tilt_best.inverse());
        self.offset_velocities[0] =
            log_q(seed_tilt(last, &self.ground) * seed_tilt(previous, &self.ground).inverse()) / dt
                - log_q(tilt(&db, b) * tilt(&db, a).inverse()) / dt;
        let local_seed = |p: &Pose| {
            self.ground.local3(
                p.root_translation
                    - down
                    - Vec3::new(self.ground.position.x, 0.0, self.ground.position.y),
            )
        };
        self.root_offset = local_seed(last) - local_root(&db, best);
        self.root_offset_velocity = (local_seed(last) - local_seed(previous)) / dt
            - (local_root(&db, b) - local_root(&db, a)) / dt;
        self.frame = best;
        self.since_search = 0;
        self.started = true;
        self.clock = 0.0;
        // Grounding on the seed's floor, the output in the seed's coordinates.
        self.grounder.reset(None);
        self.grounder.set_root_leads(self.goal.is_some());
        for pose in seed {
            self.raw.clone_from(pose);
            self.raw.root_translation -= down;
            self.grounder.observe_seed(&self.raw);
        }
        // The seed was put on a level floor at its median lowest foot point, as the takes were.
        self.grounder.set_floor(Floor::level_at(0.0));
        self.floor_height = floor;
        self.pose.clone_from(last);
        self.previous_motion = Some(last.root_motion);
        Ok(&self.pose)
    }

    /// The next frame.
    pub fn step(&mut self) -> &Pose {
        let db = self.database.clone();
        let dt = (1.0 / db.fps) as f32;
        if let Some(goal) = self.goal {
            let k = 1.0 - (-dt / VELOCITY_TIME).exp();
            let turn = 1.0 - (-dt / TURN_TIME).exp();
            self.velocity += (goal.velocity - self.velocity) * k;
            self.facing += wrap_angle(goal.facing - self.facing) * turn;
        }
        let previous = self.frame;
        let end = db.clip_end(previous);
        let mut next = if self.started { previous + 1 } else { previous };
        let mut at_end = false;
        if next > end {
            next = previous;
            at_end = true;
        }
        at_end |= next + db.search_frames > db.clip_end(next);
        self.since_search += 1;
        let due = self.goal.is_some() && (self.since_search >= db.search_frames || !self.started);
        if at_end || due {
            self.since_search = 0;
            self.query = db.features[next];
            if self.goal.is_some() {
                self.desired_trajectory(&db);
            }
            let (best, cost) = db.nearest(&self.query);
            let playing_on = db.features[next]
                .iter()
                .zip(&self.query)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>();
            let same = !at_end
                && (cost >= playing_on * KEEP_PLAYING
                    || db.clip_end(best) == db.clip_end(next)
                        && best.abs_diff(next) <= SAME_PLACE_FRAMES);
            if !same && best != next {
                self.jump(&db, next, best);
                next = best;
            }
        }
        // Root motion from the database, the heading drawn toward the commanded facing.
        if self.started {
            let (a, b) = step_frames(&db, next);
            let (from, to) = (db.grounds[a], db.grounds[b]);
            let step = from.local(to.position - from.position);
            self.ground.position += self.ground.world(step);
            let played = wrap_angle(to.facing - from.facing);
            self.ground.facing += played;
            if self.goal.is_some() {
                // The correction toward the commanded facing, at most a share of the turn the
                // database plays plus a slow pivot: the body does not swivel on a planted foot.
                let turn = 1.0 - (-dt / TURN_TIME).exp();
                let limit = CORRECTION_TURN_SHARE * played.abs() + CORRECTION_TURN_RAD_S * dt;
                let wanted = wrap_angle(self.facing - self.ground.facing) * turn;
                self.ground.facing += wanted.clamp(-limit, limit);
            }
        } else if self.goal.is_some() {
            self.ground.facing = self.facing;
        }
        self.ground.facing = wrap_angle(self.ground.facing);
        self.frame = next;
        self.pose_from(&db, next);
        for (o, v) in self.offsets.iter_mut().zip(&mut self.offset_velocities) {
            decay(o, v, BLEND_HALFLIFE_S, dt);
        }
        decay(
            &mut self.root_offset,
            &mut self.root_offset_velocity,
            BLEND_HALFLIFE_S,
            dt,
        );
        self.started = true;
        &self.pose
    }

    /// The trajectory part of the query: where the commanded velocity, approaching the goal's,
    /// takes the character over the next second, and the facing it turns to, in the
    /// character's ground frame.
    fn desired_trajectory(&mut self, db: &MatchingDatabase) {
        let goal = self.goal.expect("a goal");
        let dt = (1.0 / db.fps) as f32;
        let mut ahead = [self.ground; 3];
        let (mut position, mut velocity, mut facing) =
            (self.ground.position, self.velocity, self.ground.facing);
        let k = 1.0 - (-dt / VELOCITY_TIME).exp();
        let turn = 1.0 - (-dt / TURN_TIME).exp();
        let mut n = 0;
        for f in 1..=db.trajectory_frames[2] {
            velocity += (goal.velocity - velocity) * k;
            position += velocity * dt;
            facing += wrap_angle(goal.facing - facing) * turn;
            if f == db.trajectory_frames[n] {
                ahead[n] = GroundFrame { position, facing };
                n += 1;
            }
        }
        let mut trajectory = [0.0; FEATURES];
        trajectory_features(&self.ground, ahead, &mut trajectory);
        db.normalise(&mut trajectory);
        self.query[TRAJECTORY_START..].copy_from_slice(&trajectory[TRAJECTORY_START..]);
    }

    /// Starts the inertialization of a jump from database frame `from` (what would have played)
    /// to `to`.
    fn jump(&mut self, db: &MatchingDatabase, from: usize, to: usize) {
        let dt = (1.0 / db.fps) as f32;
        let (fa, fb) = step_frames(db, from);
        let (ta, tb) = step_frames(db, to);
        let velocity = |a: Quat, b: Quat| log_q(b * a.inverse()) / dt;
        for j in 1..self.offsets.len() {
            let shown = Quat::from_scaled_axis(self.offsets[j]) * db.rotations_of(from)[j];
            self.offsets[j] = log_q(shown * db.rotations_of(to)[j].inverse());
            self.offset_velocities[j] += velocity(db.rotations_of(fa)[j], db.rotations_of(fb)[j])
                - velocity(db.rotations_of(ta)[j], db.rotations_of(tb)[j]);
        }
        let shown = Quat::from_scaled_axis(self.offsets[0]) * tilt(db, from);
        self.offsets[0] = log_q(shown * tilt(db, to).inverse());
        self.offset_velocities[0] +=
            velocity(tilt(db, fa), tilt(db, fb)) - velocity(tilt(db, ta), tilt(db, tb));
        self.root_offset += local_root(db, from) - local_root(db, to);
        self.root_offset_velocity += (local_root(db, fb) - local_root(db, fa)) / dt
            - (local_root(db, tb) - local_root(db, ta)) / dt;
    }

    /// The output pose of database frame `frame` at the character's ground frame.
    fn pose_from(&mut self, db: &MatchingDatabase, frame: usize) {
        let source = db.rotations_of(frame);
        for ((out, offset), q) in self.raw.local_rotations[1..]
            .iter_mut()
            .zip(&self.offsets[1..])
            .zip(&source[1..])
        {
            *out = (Quat::from_scaled_axis(*offset) * *q).normalize();
        }
        let tilt = Quat::from_scaled_axis(self.offsets[0]) * tilt(db, frame);
        self.raw.local_rotations[0] =
            (Quat::from_rotation_y(self.ground.facing) * tilt).normalize();
        let local = local_root(db, frame) + self.root_offset;
        let across = self.ground.world(Vec2::new(local.x, local.z));
        self.raw.root_translation = Vec3::new(
            self.ground.position.x + across.x,
            local.y,
            self.ground.position.y + across.y,
        );
        self.grounder.set_source_contacts(Some(db.contacts[frame]));
        let grounded = self.grounder.ground(&self.raw);
        self.pose
            .local_rotations
            .copy_from_slice(&grounded.local_rotations);
        self.pose.root_translation = grounded.root_translation + Vec3::Y * self.floor_height;
        self.pose.root_motion = root_motion_between(
            self.pose.root_translation.as_dvec3(),
            self.pose.local_rotations[0].as_dquat(),
            self.previous_motion,
        );
        self.previous_motion = Some(self.pose.root_motion);
    }

    /// The feet touching the floor on the last frame (legs in the rig's body-parts order).
    pub fn contacts(&self) -> [bool; 2] {
        self.grounder.grounder().contacts()
    }

    /// The grounding in force (floor, contacts).
    pub fn grounder(&self) -> &crate::grounding::Grounder {
        self.grounder.grounder()
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

    /// Whole database frames: as many as `dt` and the time left over from earlier calls cover
    /// (at least one on the first call), the pose of the last.
    fn advance(&mut self, dt: f64) -> Result<&Pose, Self::Error> {
        self.clock += dt;
        let frame = self.frame_time();
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
mod tests {
    use super::*;

    #[test]
    fn log_and_exp_agree_and_decay_halves() {
        let q = Quat::from_rotation_y(2.5) * Quat::from_rotation_x(0.3);
        let back = Quat::from_scaled_axis(log_q(q));
        assert!(back.dot(q).abs() > 1.0 - 1e-6);
        assert!(log_q(-q).distance(log_q(q)) < 1e-5);
        let (mut x, mut v) = (Vec3::X, Vec3::ZERO);
        for _ in 0..100 {
            decay(&mut x, &mut v, 0.1, 0.001);
        }
        // A critically damped spring from rest: below the exponential's half at one half-life.
        assert!(x.x < 0.9 && x.x > 0.3, "{x}");
    }
}
