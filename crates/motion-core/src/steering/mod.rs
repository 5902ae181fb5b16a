//! Steering a character toward a goal velocity on the floor and a facing, by root-motion warping
//! as engines do it (no retraining): each model frame's ground displacement is turned onto the
//! goal's direction and scaled toward the goal's speed within [`SPEED_WARP`] of the model's own
//! stride, and the heading turns toward the goal's facing at a bounded rate. The warped pose
//! then goes through the grounding ([`crate::grounding`]), whose foot locking and two-bone leg IK
//! keep planted feet from sliding where the warp moves the body faster or slower than the legs.
//!
//! Conventions: the floor is the `x`-`z` plane (metres, +y up); a facing is a yaw in radians
//! about +y, `0` facing +z and `π/2` facing +x ([`facing_of`]); a character's heading is the
//! facing of its pelvis (the left-to-right hip axis turned a quarter about +y).
//!
//! Without a goal the poses pass through unchanged; a goal set later warps from the pose the
//! character is in. No allocation per frame.
//!
//! A model that is told where to go (`goal-gru`, [`crate::model::goal_gru`]) also reads a
//! [`control`] vector made from the goal and from where it is shown ([`Steering::control_vector`]):
//! its body walks where the goal asks, and the warping corrects what is left of its path.
pub mod control;
pub mod ground_frame;
pub mod path;

pub use control::GoalControl;
pub use glam::Vec2;
use glam::{Quat, Vec3};

use crate::grounding::find_body_parts;
use crate::pose::{root_motion_between, Pose};
use crate::skeleton::Skeleton;

/// How far a model frame's stride may be scaled toward the goal's speed: ±30 %.
pub const SPEED_WARP: (f32, f32) = (0.7, 1.3);
/// Goal speeds under this (m/s) stop the root.
pub const STOP_SPEED: f32 = 0.05;
/// Time constant (s) of the heading's approach to the goal's facing.
pub const TURN_TIME: f32 = 0.2;
/// The fastest turn (rad/s).
pub const MAX_TURN_RATE: f32 = 4.0;
/// Time constant (s) of the commanded velocity's approach to the goal's.
pub const VELOCITY_TIME: f32 = 0.25;

/// Where a character should go: a velocity on the floor and the facing to hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// Velocity on the floor, metres per second, `(x, z)` world axes.
    pub velocity: Vec2,
    /// Yaw to face, radians about +y ([`facing_of`]).
    pub facing: f32,
}

impl Goal {
    /// Walk at `velocity` facing where it goes (or keep `facing` when `velocity` is about zero).
    pub fn towards(velocity: Vec2, facing: f32) -> Goal {
        let facing = if velocity.length() > STOP_SPEED {
            facing_of(velocity)
        } else {
            facing
        };
        Goal { velocity, facing }
    }
}

/// The facing (yaw about +y, `0` = +z, `π/2` = +x) of a direction on the floor `(x, z)`.
pub fn facing_of(direction: Vec2) -> f32 {
    direction.x.atan2(direction.y)
}

/// The unit direction `(x, z)` of a facing.
pub fn direction_of(facing: f32) -> Vec2 {
    Vec2::new(facing.sin(), facing.cos())
}

/// `angle` brought into `(-π, π]` (radians).
pub fn wrap_angle(angle: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    let a = (angle + std::f32::consts::PI).rem_euclid(tau) - std::f32::consts::PI;
    if a <= -std::f32::consts::PI {
        a + tau
    } else {
        a
    }
}

/// A character that can be steered toward a [`Goal`], one frame at a time: a model's
/// [`Character`](crate::model::Character) (root-motion warping, [`Steering`]) or a
/// [`Matcher`](crate::matching::Matcher) (motion matching). What a steering benchmark drives.
pub trait Steerable {
    /// Why a frame could not be made.
    type Error: std::error::Error + Send + Sync + 'static;
    /// The skeleton of the poses.
    fn skeleton(&self) -> &Skeleton;
    /// Steers toward `goal` from the next frame on (`None`: the character's own motion).
    fn set_goal(&mut self, goal: Option<Goal>);
    /// The pose `dt` seconds on.
    ///
    /// # Errors
    /// The character could not make a frame.
    fn advance(&mut self, dt: f64) -> Result<&Pose, Self::Error>;
    /// The heading (yaw about +y, `0` facing +z) of `pose`'s pelvis.
    fn heading_of(&self, pose: &Pose) -> f32;
}

/// The pelvis's forward direction in the root's rest frame (unit, on the floor): across the
/// rest hips, turned to face +z when the hip with the larger rest x is on the left (H3.6M and
/// most rigs face +z at rest with their left on +x). A pose's heading is
/// `facing_of(root_rotation * rest_forward)` ([`Steering::heading_of`]; `training/locomotion.py`
/// reads the same vector for a rig's controls).
///
/// # Errors
/// A skeleton without two legs (no hips to face by).
pub fn rest_forward(skeleton: &Skeleton) -> Result<Vec3, crate::grounding::LegsError> {
    let parts = find_body_parts(skeleton)?;
    let rest = crate::grounding::legs::rest_positions(skeleton);
    let hip = |leg: usize| {
        let p = rest[parts.legs[leg].hip];
        Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    };
    let (a, b) = (hip(0), hip(1));
    let across = if a.x > b.x { a - b } else { b - a };
    let forward = across.cross(Vec3::Y);
    Ok(Vec3::new(forward.x, 0.0, forward.z)
        .try_normalize()
        .unwrap_or(Vec3::Z))
}

/// Root-motion warping toward a [`Goal`] (see the module docs), one model frame at a time.
#[derive(Debug, Clone)]
pub struct Steering {
    /// The pelvis's forward direction in the root's rest frame (metres, unit).
    forward_rest: Vec3,
    frame_time: f32,
    goal: Option<Goal>,
    /// The velocity commanded this frame (approaches the goal's).
    command: Vec2,
    /// The previous raw (unwarped) root position and heading.
    raw_root: Vec3,
    raw_heading: f32,
    /// The warped root's floor position and heading.
    root: Vec2,
    heading: f32,
    /// Whether the poses have been warped since the last reset (otherwise they pass through).
    warping: bool,
    /// The control of a model that reads one (its poses are warped as well).
    control: Option<GoalControl>,
    out: Pose,
}

impl Steering {
    /// Steering for poses on `skeleton` arriving every `frame_time` seconds.
    ///
    /// # Errors
    /// A skeleton without two legs (no hips to face by).
    pub fn new(
        skeleton: &Skeleton,
        frame_time: f32,
    ) -> Result<Steering, crate::grounding::LegsError> {
        Ok(Steering {
            forward_rest: rest_forward(skeleton)?,
            frame_time,
            goal: None,
            command: Vec2::ZERO,
            raw_root: Vec3::ZERO,
            raw_heading: 0.0,
            root: Vec2::ZERO,
            heading: 0.0,
            warping: false,
            control: None,
            out: Pose::rest(skeleton.len()),
        })
    }

    /// Also makes a control vector over `frames` frames for a model that reads one
    /// ([`GoalControl`]), from the goal and the shown root and heading.
    pub fn use_control(&mut self, frames: usize) {
        self.control = Some(GoalControl::new(frames, self.frame_time));
    }

    /// The control vector for the model's next step (`None`: the model reads none).
    pub fn control_vector(&self) -> Option<[f32; 3]> {
        self.control.as_ref().map(|c| c.control(self.goal))
    }

    /// `control` held, with the speed feedback of a goal's control ([`GoalControl::holding`];
    /// `None`: the model reads none).
    pub fn holding(&self, control: [f32; 3]) -> Option<[f32; 3]> {
        self.control.as_ref().map(|c| c.holding(control))
    }

    /// A seed frame's pose, where the control's past second starts (call before
    /// [`reset`](Self::reset) with the seed's poses, oldest first; nothing without a control).
    pub fn observe_seed(&mut self, pose: &Pose) {
        let heading = self.heading_of(pose);
        if let Some(control) = &mut self.control {
            control.record(
                Vec2::new(pose.root_translation.x, pose.root_translation.z),
                heading,
            );
        }
    }

    /// Forgets the seed frames observed so far (a new seed follows).
    pub fn clear_seed(&mut self) {
        if let Some(control) = &mut self.control {
            control.clear();
        }
    }

    /// The goal in force.
    pub fn goal(&self) -> Option<Goal> {
        self.goal
    }

    /// Steers toward `goal` from the next frame on (`None`: the model's own root motion, from
    /// where the character is).
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        if goal.is_some() && self.goal.is_none() {
            // Start commanding from the velocity the character has.
            self.command = Vec2::ZERO;
        }
        self.goal = goal;
    }

    /// The heading (facing, [`facing_of`]) of a pose's pelvis.
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        let f = pose.root_rotation() * self.forward_rest;
        facing_of(Vec2::new(f.x, f.z))
    }

    /// Forgets the motion so far: `pose` (the last seed frame) is where steering starts; the goal
    /// is kept.
    pub fn reset(&mut self, pose: &Pose) {
        self.raw_root = pose.root_translation;
        self.raw_heading = self.heading_of(pose);
        self.root = Vec2::new(pose.root_translation.x, pose.root_translation.z);
        self.heading = self.raw_heading;
        self.command = Vec2::ZERO;
        self.warping = false;
    }

    /// The next model frame `pose` (raw, from the decoder) warped toward the goal.
    pub fn steer<'a>(&'a mut self, pose: &'a Pose) -> &'a Pose {
        let warped = self.warp(pose);
        if let Some(control) = &mut self.control {
            // A model told where to go is told it from where it is shown.
            control.record(self.root, self.heading);
        }
        if warped {
            &self.out
        } else {
            pose
        }
    }

    /// Warps `pose` into `self.out` (`true`) or leaves it as it is (`false`); the shown root and
    /// heading are updated either way.
    fn warp(&mut self, pose: &Pose) -> bool {
        let raw_heading = self.heading_of(pose);
        let raw_step = pose.root_translation - self.raw_root;
        let raw_turn = wrap_angle(raw_heading - self.raw_heading);
        // The raw step in the previous raw heading's frame (forward = +z).
        let local = rotate(Vec2::new(raw_step.x, raw_step.z), -self.raw_heading);
        self.raw_root = pose.root_translation;
        self.raw_heading = raw_heading;
        let Some(goal) = self.goal else {
            if !self.warping {
                self.root = Vec2::new(pose.root_translation.x, pose.root_translation.z);
                self.heading = raw_heading;
                return false;
            }
            // After a goal: the model's own motion, carried on from the warped frame.
            self.heading = wrap_angle(self.heading + raw_turn);
            self.root += rotate(local, self.heading - raw_turn);
            self.write(pose, raw_heading);
            return true;
        };
        self.warping = true;
        let dt = self.frame_time;
        let blend = (dt / VELOCITY_TIME).min(1.0);
        self.command += (goal.velocity - self.command) * blend;
        // Heading: toward the goal's facing at a bounded rate.
        let error = wrap_angle(goal.facing - self.heading);
        let turn =
            (error * (dt / TURN_TIME).min(1.0)).clamp(-MAX_TURN_RATE * dt, MAX_TURN_RATE * dt);
        self.heading = wrap_angle(self.heading + turn);
        // Translation: the model's stride length, scaled toward the commanded speed, along the
        // commanded direction.
        let stride = local.length();
        let wanted = self.command.length() * dt;
        let step = if goal.velocity.length() < STOP_SPEED && wanted < STOP_SPEED * dt {
            Vec2::ZERO
        } else if stride > 1e-6 {
            let scale = (wanted / stride).clamp(SPEED_WARP.0, SPEED_WARP.1);
            self.command.normalize_or_zero() * stride * scale
        } else {
            Vec2::ZERO
        };
        self.root += step;
        self.write(pose, raw_heading);
        true
    }

    /// `pose` moved to the warped root and turned by the warped minus the raw heading, into
    /// `self.out`.
    fn write(&mut self, pose: &Pose, raw_heading: f32) {
        let turn = Quat::from_rotation_y(wrap_angle(self.heading - raw_heading));
        let out = &mut self.out;
        out.local_rotations.copy_from_slice(&pose.local_rotations);
        out.local_rotations[0] = (turn * pose.local_rotations[0]).normalize();
        out.root_translation = Vec3::new(self.root.x, pose.root_translation.y, self.root.y);
        out.root_motion = root_motion_between(
            out.root_translation.as_dvec3(),
            out.local_rotations[0].as_dquat(),
            Some(pose.root_motion),
        );
    }
}

/// A path on the floor for a character to follow: a [`Goal`] toward the next point at a
/// speed, moving on to the point after once within a radius of it (a loop starts again at the
/// first point). What the engine demos and the square-course checks steer with.
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoints {
    points: Vec<Vec2>,
    next: usize,
    speed: f32,
    radius: f32,
    looping: bool,
}

impl Waypoints {
    /// Follow `points` (`(x, z)` metres) at `speed` (m/s), each reached within `radius` (m).
    pub fn new(points: Vec<Vec2>, speed: f32, radius: f32, looping: bool) -> Waypoints {
        Waypoints {
            points,
            next: 0,
            speed,
            radius,
            looping,
        }
    }

    /// The points, in order.
    pub fn points(&self) -> &[Vec2] {
        &self.points
    }

    /// The point being walked to (`None`: the path is done).
    pub fn target(&self) -> Option<Vec2> {
        self.points.get(self.next).copied()
    }

    /// Index of the point being walked to (`points.len()` when done).
    pub fn next_index(&self) -> usize {
        self.next
    }

    /// The goal for a character at `here` (`(x, z)`) facing `facing`: toward the next point,
    /// moving on past those within the radius; standing still facing `facing` when done.
    pub fn goal(&mut self, here: Vec2, facing: f32) -> Goal {
        for _ in 0..self.points.len() {
            let Some(point) = self.target() else { break };
            if (point - here).length() > self.radius {
                return Goal::towards((point - here).normalize() * self.speed, facing);
            }
            self.next += 1;
            if self.looping {
                self.next %= self.points.len();
            }
        }
        Goal {
            velocity: Vec2::ZERO,
            facing,
        }
    }
}

/// `v` turned by `angle` about +y (the facing convention: `rotate(+z, a) = direction_of(a)`).
fn rotate(v: Vec2, angle: f32) -> Vec2 {
    let (s, c) = angle.sin_cos();
    // +z (0, 1) -> (sin a, cos a); +x (1, 0) -> (cos a, -sin a).
    Vec2::new(v.x * c + v.y * s, -v.x * s + v.y * c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waypoints_lead_on_and_stop_at_the_end() {
        let mut path = Waypoints::new(
            vec![Vec2::new(0.0, 2.0), Vec2::new(2.0, 2.0)],
            0.5,
            0.3,
            false,
        );
        let g = path.goal(Vec2::ZERO, 1.0);
        assert!((g.velocity - Vec2::new(0.0, 0.5)).length() < 1e-6 && g.facing.abs() < 1e-6);
        let g = path.goal(Vec2::new(0.0, 1.8), 1.0);
        assert_eq!(path.next_index(), 1);
        assert!((g.velocity - Vec2::new(2.0, 0.2).normalize() * 0.5).length() < 1e-6);
        let g = path.goal(Vec2::new(2.0, 2.1), 1.0);
        assert_eq!(
            (path.target(), g.velocity, g.facing),
            (None, Vec2::ZERO, 1.0)
        );
        // A loop starts again; standing on every point of it, the goal is to stand.
        let mut ring = Waypoints::new(vec![Vec2::ZERO, Vec2::new(0.1, 0.0)], 0.5, 0.3, true);
        assert_eq!(ring.goal(Vec2::ZERO, 0.0).velocity, Vec2::ZERO);
        assert!(ring.target().is_some());
    }

    #[test]
    fn facings_and_rotations_agree() {
        for a in [-3.0f32, -1.0, 0.0, 0.5, 2.0, 3.1] {
            let d = direction_of(a);
            assert!((facing_of(d) - a).abs() < 1e-5);
            assert!((rotate(Vec2::Y, a) - d).length() < 1e-6);
        }
        assert!((wrap_angle(3.5 * std::f32::consts::PI) + 0.5 * std::f32::consts::PI).abs() < 1e-5);
    }

    #[test]
    fn the_rest_pose_faces_plus_z_and_poses_pass_through_without_a_goal() {
        let skeleton = Skeleton::h36m();
        let mut steering = Steering::new(&skeleton, 0.04).unwrap();
        let rest = Pose::rest(skeleton.len());
        assert!(steering.heading_of(&rest).abs() < 1e-5);
        steering.reset(&rest);
        let mut moved = rest.clone();
        moved.root_translation = Vec3::new(0.1, 0.9, 0.2);
        let out = steering.steer(&moved).clone();
        assert_eq!(out, moved);
    }

    /// A synthetic walker (stride 1 m/s along a heading that wobbles ±0.15 rad) steered around a
    /// 4 m square by [`Waypoints`] at 1 m/s reaches each corner within 1 m by the ideal
    /// time plus 2 s, and faces where it goes.
    #[test]
    fn a_steady_walker_is_steered_around_a_square() {
        let skeleton = Skeleton::h36m();
        let dt = 0.04f32;
        let mut steering = Steering::new(&skeleton, dt).unwrap();
        let mut raw = Pose::rest(skeleton.len());
        raw.root_translation = Vec3::new(0.0, 0.9, 0.0);
        steering.reset(&raw);
        let corners = [
            Vec2::new(0.0, 4.0),
            Vec2::new(4.0, 4.0),
            Vec2::new(4.0, 0.0),
            Vec2::new(0.0, 0.0),
        ];
        let mut path = Waypoints::new(corners.to_vec(), 1.0, 0.3, false);
        let (mut reached, mut time) = ([None; 4], 0.0f32);
        let mut here = Vec2::ZERO;
        while path.target().is_some() && time < 30.0 {
            for (k, corner) in corners.iter().enumerate() {
                if (*corner - here).length() < 1.0 && k <= path.next_index() {
                    reached[k].get_or_insert(time);
                }
            }
            steering.set_goal(Some(path.goal(here, 0.0)));
            time += dt;
            let heading = 0.15 * (time * 2.0).sin();
            let step = direction_of(heading) * dt;
            raw.root_translation += Vec3::new(step.x, 0.0, step.y);
            raw.local_rotations[0] = Quat::from_rotation_y(heading);
            let out = steering.steer(&raw);
            here = Vec2::new(out.root_translation.x, out.root_translation.z);
            assert!((out.root_translation.y - 0.9).abs() < 1e-6);
        }
        for (k, at) in reached.iter().enumerate() {
            let ideal = 4.0 * (k + 1) as f32;
            let at = at.unwrap_or_else(|| panic!("corner {k} not reached"));
            assert!(at <= ideal + 2.0, "corner {k}: {at} s, ideal {ideal} s");
        }
        // Facing the last leg's direction (-x).
        let facing = steering.heading;
        assert!(
            wrap_angle(facing + std::f32::consts::FRAC_PI_2).abs() < 0.2,
            "{facing}"
        );
    }
}
