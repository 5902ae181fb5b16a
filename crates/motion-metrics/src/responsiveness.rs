//! How a steerable character answers a game controller: scripted goal changes (turn 90 and 180
//! degrees, stop, speed up) after a warm-up walk, each from a fresh character, measured at the
//! 25 Hz model rate.
//!
//! - **Heading time**: seconds until the pelvis heading is within [`HEADING_TOLERANCE_DEG`] of the
//!   goal's facing (and stays within it for [`HOLD_S`]).
//! - **Speed time**: seconds until the root's ground speed, averaged over the last
//!   [`SPEED_WINDOW_S`], is within [`SPEED_TOLERANCE`] of the goal's (for the stop: under
//!   that share of the warm-up speed), held for [`HOLD_S`].
//! - **Skating** over the [`SKATING_S`] after the change: the fraction of frames with a foot point
//!   under 5 cm moving faster than 0.5 m/s on the floor ([`crate::plausibility`]'s definition).
//! - **Body speed**: the mean joint speed relative to the root in the heading frame (the body's
//!   own motion, not its travel), over every scenario frame, against real motion's
//!   ([`body_speed`] of real clips).
//! - **NDMS** (optional): the mean NDMS (Tanke et al. 2021, [`crate::ndms`]) of the body's motion
//!   words over every scenario (its last κ-1 warm-up frames before the change prepended) against
//!   a database of real motion words ([`RealMotion::ndms`], built from [`positions_of`] real
//!   clips): how much the steered body moves like real motion, 1 for a word real motion has.
//! - **Cost**: microseconds per frame (wall clock of [`Steerable::advance`]) and the bytes the
//!   caller says the controller holds.
//!
//! The goal speed of every scenario is the character's own warm-up speed (`v0`: 2 s without a
//! goal), so a warping controller is asked for what its stride can give.
use std::time::Instant;

use glam::{Quat, Vec2, Vec3};
use motion_core::grounding::find_body_parts;
use ndarray::Array3;

use crate::error::MetricError;
use crate::ndms::NdmsDatabase;
use motion_core::pose::Pose;
use motion_core::skeleton::Skeleton;
use motion_core::steering::{direction_of, wrap_angle, Goal, Steerable};
use serde::Serialize;

/// Seconds per frame (the 25 Hz model rate).
pub const FRAME_S: f64 = 0.04;
/// Warm-up without a goal (seconds).
pub const WARM_UP_S: f64 = 2.0;
/// Seconds each scenario runs after its goal change.
pub const SCENARIO_S: f64 = 4.0;
/// The heading counts as reached within this many degrees.
pub const HEADING_TOLERANCE_DEG: f32 = 10.0;
/// The speed counts as reached within this share of the goal's.
pub const SPEED_TOLERANCE: f32 = 0.1;
/// The window the ground speed is averaged over (seconds).
pub const SPEED_WINDOW_S: f64 = 1.0;
/// A target counts as reached when it holds this long (seconds).
pub const HOLD_S: f64 = 0.4;
/// Skating is measured over this long after the change (seconds).
pub const SKATING_S: f64 = 2.0;
/// The speed-up scenario's goal speed, as a share of the warm-up speed.
pub const SPEED_UP: f32 = 1.3;

/// One scripted goal change.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Scenario {
    /// Walk on at the warm-up speed, turned 90 degrees.
    Turn90,
    /// Walk on at the warm-up speed, turned 180 degrees.
    Turn180,
    /// Stop, facing the warm-up heading.
    Stop,
    /// Walk on the warm-up heading at [`SPEED_UP`] times the warm-up speed.
    SpeedUp,
}

impl Scenario {
    /// Every scenario, in report order.
    pub const ALL: [Scenario; 4] = [
        Scenario::Turn90,
        Scenario::Turn180,
        Scenario::Stop,
        Scenario::SpeedUp,
    ];

    /// The scenario's name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Turn90 => "turn 90",
            Scenario::Turn180 => "turn 180",
            Scenario::Stop => "stop",
            Scenario::SpeedUp => "speed up",
        }
    }

    /// The goal after a warm-up at `speed` (m/s) heading `heading` (yaw).
    pub fn goal(self, heading: f32, speed: f32) -> Goal {
        let turn = |angle: f32| Goal::towards(direction_of(heading + angle) * speed, 0.0);
        match self {
            Scenario::Turn90 => turn(std::f32::consts::FRAC_PI_2),
            Scenario::Turn180 => turn(std::f32::consts::PI),
            Scenario::Stop => Goal {
                velocity: Vec2::ZERO,
                facing: heading,
            },
            Scenario::SpeedUp => Goal::towards(direction_of(heading) * speed * SPEED_UP, 0.0),
        }
    }
}

/// What one scenario measured.
#[derive(Debug, Clone, Serialize)]
pub struct ScenarioReport {
    /// Which change.
    pub scenario: Scenario,
    /// The goal speed (m/s).
    pub goal_speed_m_s: f32,
    /// Seconds until the heading is within tolerance (`None`: not within [`SCENARIO_S`]).
    pub heading_s: Option<f64>,
    /// Seconds until the speed is within tolerance (`None`: not within [`SCENARIO_S`]).
    pub speed_s: Option<f64>,
    /// Skating fraction over the [`SKATING_S`] after the change.
    pub skating: f64,
    /// Ground speed over the scenario's last 2 s (m/s, the distance made good).
    pub late_speed_m_s: f32,
}

/// A controller's answers to every scenario.
#[derive(Debug, Clone, Serialize)]
pub struct ResponsivenessReport {
    /// The controller's name.
    pub controller: String,
    /// Its warm-up ground speed without a goal (m/s): the scenarios' base speed.
    pub warm_up_speed_m_s: f32,
    /// Per scenario.
    pub scenarios: Vec<ScenarioReport>,
    /// Mean body speed over every scenario frame against the real motion's.
    pub body_speed_ratio: f64,
    /// Mean NDMS of the body's motion words over every scenario against the real motion's
    /// database (`None`: no database given).
    pub ndms: Option<f64>,
    /// Wall-clock microseconds per frame.
    pub us_per_frame: f64,
    /// Bytes the controller holds (as the caller counts them).
    pub memory_bytes: usize,
}

/// The real motion a controller's body is compared with.
#[derive(Debug, Clone, Copy)]
pub struct RealMotion<'a> {
    /// [`body_speed`] of real motion of the kind asked for (m/s).
    pub body_speed: f64,
    /// A database of its motion words for NDMS (positions from [`positions_of`], metres), in
    /// words of a rigid body frame ([`crate::ndms::NdmsConfig::h36m_body_frame`] for H3.6M rigs:
    /// real takes decoded from root deltas stand in the pelvis frame where integration started,
    /// not on a level floor); `None`: no NDMS.
    pub ndms: Option<&'a NdmsDatabase>,
}

/// Measures a controller made fresh by `make` for every scenario (see the module docs) against
/// `real` motion.
///
/// # Errors
/// `make` or a frame failed, or the NDMS database does not fit the controller's skeleton.
pub fn measure<S, E>(
    controller: &str,
    mut make: impl FnMut() -> Result<S, E>,
    real: RealMotion<'_>,
    memory_bytes: usize,
) -> Result<ResponsivenessReport, E>
where
    S: Steerable,
    E: From<S::Error> + From<MetricError>,
{
    let (mut time, mut frames) = (0.0f64, 0usize);
    let mut body = BodySpeed::default();
    let mut scenarios = Vec::new();
    let mut warm_up_speed = 0.0;
    let (mut seeds, mut tracks) = (Vec::new(), Vec::new());
    for scenario in Scenario::ALL {
        let mut character = make()?;
        let mut probe = Probe::new(character.skeleton());
        let (mut seed, mut track) = (Vec::new(), Vec::new());
        let mut pose = Pose::rest(character.skeleton().len());
        let warm_up = (WARM_UP_S / FRAME_S).round() as usize;
        let mut start = None;
        for f in 0..warm_up {
            let t = Instant::now();
            pose.clone_from(character.advance(FRAME_S)?);
            time += t.elapsed().as_secs_f64();
            frames += 1;
            if f == 0 {
                start = Some(floor(pose.root_translation));
            }
            probe.heading = character.heading_of(&pose);
            probe.observe(character.skeleton(), &pose);
            probe.record(&mut seed);
        }
        let heading = character.heading_of(&pose);
        let speed = (floor(pose.root_translation) - start.expect("frames")).length()
            / ((warm_up - 1) as f32 * FRAME_S as f32);
        warm_up_speed = speed;
        let goal = scenario.goal(heading, speed);
        character.set_goal(Some(goal));
        let goal_speed = goal.velocity.length();
        let (mut heading_at, mut speed_at) = (Hold::default(), Hold::default());
        let (mut skating, mut skating_frames) = (0usize, 0usize);
        let mut roots = Vec::new();
        let steps = (SCENARIO_S / FRAME_S).round() as usize;
        let window = (SPEED_WINDOW_S / FRAME_S).round() as usize;
        for f in 1..=steps {
            let t = Instant::now();
            pose.clone_from(character.advance(FRAME_S)?);
            time += t.elapsed().as_secs_f64();
            frames += 1;
            let now = f as f64 * FRAME_S;
            probe.heading = character.heading_of(&pose);
            let slides = probe.observe(character.skeleton(), &pose);
            probe.record(&mut track);
            body.add(probe.body_speed);
            if now <= SKATING_S + 1e-9 {
                skating += usize::from(slides);
                skating_frames += 1;
            }
            let h = character.heading_of(&pose);
            let off = wrap_angle(h - goal.facing).abs().to_degrees();
            heading_at.offer(now, off <= HEADING_TOLERANCE_DEG);
            roots.push(floor(pose.root_translation));
            if roots.len() > window {
                let v = (roots[roots.len() - 1] - roots[roots.len() - 1 - window]).length()
                    / (window as f64 * FRAME_S) as f32;
                let ok = if goal_speed > 0.0 {
                    (v - goal_speed).abs() <= SPEED_TOLERANCE * goal_speed
                } else {
                    v <= SPEED_TOLERANCE * speed
                };
                speed_at.offer(now, ok);
            }
        }
        scenarios.push(ScenarioReport {
            scenario,
            goal_speed_m_s: goal_speed,
            heading_s: heading_at.reached(),
            speed_s: speed_at.reached(),
            skating: skating as f64 / skating_frames.max(1) as f64,
            late_speed_m_s: late_speed(&roots),
        });
        let joints = character.skeleton().len();
        seeds.push(frames_of(seed, joints));
        tracks.push(frames_of(track, joints));
    }
    let ndms = match real.ndms {
        Some(database) => {
            let forecasts: Vec<_> = tracks.iter().map(|t| t.view()).collect();
            let seeds: Vec<_> = seeds.iter().map(|t| t.view()).collect();
            Some(database.score_forecasts(&forecasts, Some(&seeds))?.mean)
        }
        None => None,
    };
    Ok(ResponsivenessReport {
        controller: controller.to_string(),
        warm_up_speed_m_s: warm_up_speed,
        scenarios,
        body_speed_ratio: body.mean() / real.body_speed,
        ndms,
        us_per_frame: time / frames.max(1) as f64 * 1e6,
        memory_bytes,
    })
}

/// World positions (metres, `T x J x 3`) of `poses` on `skeleton`: the input of an NDMS database
/// of real motion ([`RealMotion::ndms`]) or of its own score.
pub fn positions_of<'a>(
    skeleton: &Skeleton,
    poses: impl IntoIterator<Item = &'a Pose>,
) -> Array3<f64> {
    let n = skeleton.len();
    let (mut positions, mut world, mut out) =
        (vec![Vec3::ZERO; n], vec![Quat::IDENTITY; n], Vec::new());
    for pose in poses {
        pose.world_positions_into(skeleton, &mut positions, &mut world);
        extend_flat(&mut out, &positions);
    }
    frames_of(out, n)
}

/// Appends `positions` to `out` as flat f64 `x, y, z` per joint.
fn extend_flat(out: &mut Vec<f64>, positions: &[Vec3]) {
    out.extend(positions.iter().flat_map(|p| p.to_array().map(f64::from)));
}

/// `T x J x 3` frames from flat positions.
fn frames_of(flat: Vec<f64>, joints: usize) -> Array3<f64> {
    let frames = flat.len() / (joints * 3).max(1);
    Array3::from_shape_vec((frames, joints, 3), flat).expect("whole frames")
}

/// The mean body speed (m/s: joint speed relative to the root in the heading frame, over every
/// joint and frame) of 25 Hz poses on `skeleton`, headings read by `heading_of`.
pub fn body_speed<'a>(
    skeleton: &Skeleton,
    poses: impl IntoIterator<Item = &'a Pose>,
    heading_of: impl Fn(&Pose) -> f32,
) -> f64 {
    let mut probe = Probe::new(skeleton);
    let mut body = BodySpeed::default();
    for (i, pose) in poses.into_iter().enumerate() {
        probe.heading = heading_of(pose);
        probe.observe(skeleton, pose);
        if i > 0 {
            body.add(probe.body_speed);
        }
    }
    body.mean()
}

#[derive(Default)]
struct BodySpeed {
    sum: f64,
    n: usize,
}

impl BodySpeed {
    fn add(&mut self, v: f64) {
        self.sum += v;
        self.n += 1;
    }

    fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }
}

/// The first time from which a condition held for [`HOLD_S`] (how every scenario's heading and
/// speed times are counted; other harnesses count theirs with it too).
#[derive(Debug, Default, Clone, Copy)]
pub struct Hold {
    since: Option<f64>,
    reached: Option<f64>,
}

impl Hold {
    /// Whether the condition holds at `now` (seconds, increasing).
    pub fn offer(&mut self, now: f64, ok: bool) {
        if self.reached.is_some() {
            return;
        }
        match (ok, self.since) {
            (true, None) => self.since = Some(now),
            (true, Some(since)) if now - since >= HOLD_S - 1e-9 => self.reached = Some(since),
            (false, _) => self.since = None,
            _ => {}
        }
    }

    /// When the condition began to hold for [`HOLD_S`] (`None`: not yet).
    pub fn reached(&self) -> Option<f64> {
        self.reached
    }
}

/// Per-frame positions of a character: foot skating and body speed.
struct Probe {
    feet: Vec<usize>,
    positions: Vec<Vec3>,
    world: Vec<Quat>,
    feet_before: Vec<Vec3>,
    body_before: Vec<Vec3>,
    started: bool,
    heading: f32,
    body_speed: f64,
}

impl Probe {
    fn new(skeleton: &Skeleton) -> Probe {
        let feet = find_body_parts(skeleton)
            .map(|p| {
                p.legs
                    .iter()
                    .flat_map(|l| l.foot_points.iter().copied())
                    .collect()
            })
            .unwrap_or_default();
        let n = skeleton.len();
        Probe {
            feet,
            positions: vec![Vec3::ZERO; n],
            world: vec![Quat::IDENTITY; n],
            feet_before: Vec::new(),
            body_before: vec![Vec3::ZERO; n],
            started: false,
            heading: 0.0,
            body_speed: 0.0,
        }
    }

    /// Takes the next frame; whether a foot point skated into it.
    fn observe(&mut self, skeleton: &Skeleton, pose: &Pose) -> bool {
        pose.world_positions_into(skeleton, &mut self.positions, &mut self.world);
        let root = self.positions[0];
        let turn = Quat::from_rotation_y(-self.heading);
        let mut slides = false;
        let mut speed = 0.0;
        for (j, p) in self.positions.iter().enumerate() {
            let body = turn * (*p - root);
            if self.started {
                speed += f64::from((body - self.body_before[j]).length()) / FRAME_S;
            }
            self.body_before[j] = body;
        }
        self.body_speed = speed / self.positions.len().max(1) as f64;
        for (k, &j) in self.feet.iter().enumerate() {
            let p = self.positions[j];
            if let Some(b) = self.feet_before.get(k) {
                slides |= p.y < 0.05 && (floor(p) - floor(*b)).length() / FRAME_S as f32 > 0.5;
            }
        }
        self.feet_before.clear();
        self.feet_before
            .extend(self.feet.iter().map(|&j| self.positions[j]));
        self.started = true;
        slides
    }

    /// Appends the positions of the last observed frame (metres, flat `x, y, z` per joint).
    fn record(&self, out: &mut Vec<f64>) {
        extend_flat(out, &self.positions);
    }
}

/// Ground speed over the last 2 s of root floor positions (25 Hz): the distance made good.
fn late_speed(roots: &[Vec2]) -> f32 {
    let n = ((2.0 / FRAME_S).round() as usize).min(roots.len().saturating_sub(1));
    if n == 0 {
        return 0.0;
    }
    (roots[roots.len() - 1] - roots[roots.len() - 1 - n]).length() / (n as f64 * FRAME_S) as f32
}

fn floor(p: Vec3) -> Vec2 {
    Vec2::new(p.x, p.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A controller that does exactly what it is told at once: the rest pose 1 m up (feet
    /// clear of the floor), facing the goal, moving at the goal's velocity; without a goal it
    /// walks +z at 1 m/s.
    struct Ideal {
        skeleton: Skeleton,
        goal: Goal,
        pose: Pose,
    }

    impl Steerable for Ideal {
        type Error = std::convert::Infallible;

        fn skeleton(&self) -> &Skeleton {
            &self.skeleton
        }

        fn set_goal(&mut self, goal: Option<Goal>) {
            if let Some(goal) = goal {
                self.goal = goal;
            }
        }

        fn advance(&mut self, dt: f64) -> Result<&Pose, Self::Error> {
            let v = self.goal.velocity * dt as f32;
            self.pose.root_translation += Vec3::new(v.x, 0.0, v.y);
            self.pose.local_rotations[0] = Quat::from_rotation_y(self.goal.facing);
            Ok(&self.pose)
        }

        fn heading_of(&self, pose: &Pose) -> f32 {
            let f = pose.local_rotations[0] * Vec3::Z;
            f.x.atan2(f.z)
        }
    }

    #[test]
    fn an_ideal_controller_answers_at_once() {
        let make = || -> Result<Ideal, Box<dyn std::error::Error + Send + Sync>> {
            let skeleton = Skeleton::h36m();
            let mut pose = Pose::rest(skeleton.len());
            pose.root_translation = Vec3::new(0.0, 1.0, 0.0);
            Ok(Ideal {
                goal: Goal {
                    velocity: Vec2::new(0.0, 1.0),
                    facing: 0.0,
                },
                pose,
                skeleton,
            })
        };
        let real = RealMotion {
            body_speed: 1.0,
            ndms: None,
        };
        let report = measure("ideal", make, real, 0).unwrap();
        assert!((report.warm_up_speed_m_s - 1.0).abs() < 1e-3);
        let window = SPEED_WINDOW_S + FRAME_S;
        for s in &report.scenarios {
            if s.scenario != Scenario::Stop && s.scenario != Scenario::SpeedUp {
                assert!(s.heading_s.is_some_and(|t| t <= FRAME_S + 1e-9), "{s:?}");
            }
            let speed = s.speed_s.expect("speed reached");
            assert!(speed <= window + 1e-9, "{s:?}");
            assert_eq!(s.skating, 0.0);
            assert!((s.late_speed_m_s - s.goal_speed_m_s).abs() < 1e-3, "{s:?}");
        }
        // The body does not move relative to its root.
        assert!(report.body_speed_ratio.abs() < 1e-6);
    }

    #[test]
    fn a_target_counts_from_when_it_starts_holding() {
        let mut hold = Hold::default();
        for (i, ok) in [
            false, true, false, true, true, true, true, true, true, true, true, true, true, true,
        ]
        .into_iter()
        .enumerate()
        {
            hold.offer(i as f64 * FRAME_S, ok);
        }
        assert!((hold.reached.unwrap() - 3.0 * FRAME_S).abs() < 1e-9);
    }
}
