//! The control vector a `goal-gru` model reads ([`crate::model::goal_gru`]): where the root goes
//! over the next second, `[forward, side, turn]` in the floor frame of the current pelvis
//! heading (m/s, m/s, radians). From a [`Goal`], or without one from what the root did over the
//! last second (the model keeps doing it). The definition is `training/locomotion.py`'s
//! `control_of`, with the future displacement replaced by the goal's.
use glam::Vec2;

use super::{direction_of, facing_of, wrap_angle, Goal, STOP_SPEED};

/// The largest heading change a control asks for over its horizon (radians): H3.6M walking
/// turns at most 2.8 rad in a second (`training/locomotion.py`'s controls of the training
/// subjects); a larger goal turn is asked for a second at a time.
pub const MAX_CONTROL_TURN: f32 = 2.5;

/// How much of the gap between the goal's velocity and the one made good over the last second
/// is added to the velocity a control asks for (a proportional speed controller around the
/// model, which lags its control and seldom starts walking from a stand by itself).
pub const SPEED_FEEDBACK: f32 = 2.0;

/// The fastest a control asks for (m/s) beyond the goal's own speed: H3.6M walking's 95th
/// percentile forward speed is about 1 m/s.
pub const MAX_CONTROL_SPEED: f32 = 1.2;

/// Recent root positions and headings of one character, and its control (see the module
/// docs). No allocation per frame.
#[derive(Debug, Clone)]
pub struct GoalControl {
    /// Frames the control looks ahead (and the past one looks back).
    frames: usize,
    /// Seconds per frame.
    frame_time: f32,
    /// The last `frames + 1` root floor positions and headings, a ring.
    history: Vec<(Vec2, f32)>,
    /// Where the next entry goes.
    next: usize,
    /// Entries held (up to `frames + 1`).
    len: usize,
}

impl GoalControl {
    /// A control over `frames` frames of `frame_time` seconds.
    pub fn new(frames: usize, frame_time: f32) -> GoalControl {
        let frames = frames.max(1);
        GoalControl {
            frames,
            frame_time,
            history: vec![(Vec2::ZERO, 0.0); frames + 1],
            next: 0,
            len: 0,
        }
    }

    /// Forgets the motion so far.
    pub fn clear(&mut self) {
        self.len = 0;
        self.next = 0;
    }

    /// One more frame: the root's floor position `(x, z)` and the pelvis heading.
    pub fn record(&mut self, root: Vec2, heading: f32) {
        self.history[self.next] = (root, heading);
        self.next = (self.next + 1) % self.history.len();
        self.len = (self.len + 1).min(self.history.len());
    }

    /// The entry `back` frames before the newest (`0`: the newest).
    fn back(&self, back: usize) -> (Vec2, f32) {
        let n = self.history.len();
        self.history[(self.next + n - 1 - back) % n]
    }

    /// `control` held (a body-frame velocity and turn that do not change: what a seed did), with
    /// the speed feedback of a goal's control.
    pub fn holding(&self, control: [f32; 3]) -> [f32; 3] {
        self.with_feedback(control)
    }

    /// `control` with feedback on the speed made good over the last second along the velocity
    /// it asks for: a model that lags (or stands where it should walk) is asked for more, within
    /// [`MAX_CONTROL_SPEED`]. Only the speed along that direction is fed back (the gait's own
    /// sway across it would set the control swaying).
    fn with_feedback(&self, [forward, side, turn]: [f32; 3]) -> [f32; 3] {
        let wanted = Vec2::new(forward, side);
        let (Some(past), Some(direction)) = (self.past_velocity(), wanted.try_normalize()) else {
            return [forward, side, turn];
        };
        let [f, s] = in_heading_frame(past, self.back(0).1);
        let made_good = Vec2::new(f, s).dot(direction);
        let speed = wanted.length();
        let asked = (speed + (speed - made_good) * SPEED_FEEDBACK)
            .clamp(speed, MAX_CONTROL_SPEED.max(speed));
        let [forward, side] = (direction * asked).to_array();
        [forward, side, turn]
    }

    /// The root's mean floor velocity over the frames held (up to the last second), world axes.
    fn past_velocity(&self) -> Option<Vec2> {
        let span = self.len.checked_sub(1).filter(|&s| s > 0)?;
        let seconds = span as f32 * self.frame_time;
        Some((self.back(0).0 - self.back(span).0) / seconds)
    }

    /// `[forward, side, turn]` for `goal`, or without one the last second's motion; zeros
    /// before any frame.
    pub fn control(&self, goal: Option<Goal>) -> [f32; 3] {
        if self.len == 0 {
            return [0.0; 3];
        }
        let (root, heading) = self.back(0);
        match goal {
            Some(goal) => {
                let velocity = if goal.velocity.length() < STOP_SPEED {
                    Vec2::ZERO
                } else {
                    goal.velocity
                };
                let turn =
                    wrap_angle(goal.facing - heading).clamp(-MAX_CONTROL_TURN, MAX_CONTROL_TURN);
                // The travel direction relative to the goal's facing, from the mid-turn heading.
                let relative = wrap_angle(facing_of(velocity) - goal.facing);
                let travel = direction_of(heading + 0.5 * turn + relative) * velocity.length();
                let [forward, side] = in_heading_frame(travel, heading);
                self.with_feedback([forward, side, turn])
            }
            None => {
                let span = self.len - 1;
                if span == 0 {
                    return [0.0; 3];
                }
                let (old_root, old_heading) = self.back(span);
                let seconds = span as f32 * self.frame_time;
                let [forward, side] = in_heading_frame((root - old_root) / seconds, old_heading);
                let turn = wrap_angle(heading - old_heading) * self.frames as f32 / span as f32;
                [forward, side, turn]
            }
        }
    }
}

/// A floor vector `(x, z)` as `[along, across]` the heading (`across` is +x when facing +z).
fn in_heading_frame(v: Vec2, heading: f32) -> [f32; 2] {
    let (s, c) = heading.sin_cos();
    [v.x * s + v.y * c, v.x * c - v.y * s]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::steering::direction_of;

    #[test]
    fn a_goal_is_read_in_the_heading_frame() {
        let mut control = GoalControl::new(25, 0.04);
        control.record(Vec2::ZERO, std::f32::consts::FRAC_PI_2); // facing +x
        let goal = Goal {
            velocity: Vec2::new(1.0, 0.0),
            facing: std::f32::consts::FRAC_PI_2,
        };
        let [f, s, t] = control.control(Some(goal));
        assert!((f - 1.0).abs() < 1e-6 && s.abs() < 1e-6 && t.abs() < 1e-6);
        // Walking toward +z while facing +x: a quarter turn (negative: +x to +z), and the second's
        // travel along the mid-turn heading, 45 degrees, to the -side.
        let goal = Goal::towards(Vec2::new(0.0, 1.0), 0.0);
        let [f, s, t] = control.control(Some(goal));
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((f - h).abs() < 1e-6 && (s + h).abs() < 1e-6, "{f} {s}");
        assert!((t + std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{t}");
        // Side-stepping with the facing held: all side.
        let goal = Goal {
            velocity: Vec2::new(0.0, 1.0),
            facing: std::f32::consts::FRAC_PI_2,
        };
        let [f, s, t] = control.control(Some(goal));
        assert!(
            f.abs() < 1e-6 && (s + 1.0).abs() < 1e-6 && t.abs() < 1e-6,
            "{f} {s} {t}"
        );
        // A goal behind is asked for at most MAX_CONTROL_TURN at a time.
        let back = Goal {
            velocity: Vec2::ZERO,
            facing: -std::f32::consts::FRAC_PI_2 + 0.01,
        };
        assert_eq!(control.control(Some(back))[2], -MAX_CONTROL_TURN);
    }

    #[test]
    fn a_lagging_walker_is_asked_for_more_along_its_goal_only() {
        let mut control = GoalControl::new(25, 0.04);
        // 0.3 m/s along +z facing +z, swaying 0.1 m/s across, for a second.
        for k in 0..26 {
            let t = k as f32 * 0.04;
            control.record(Vec2::new(0.1 * t, 0.3 * t), 0.0);
        }
        let goal = Goal::towards(Vec2::new(0.0, 0.5), 0.0);
        let [f, s, t] = control.control(Some(goal));
        // 0.5 + SPEED_FEEDBACK * (0.5 - 0.3) = 0.9 along, nothing across (the sway is not fed back).
        assert!((f - (0.5 + SPEED_FEEDBACK * 0.2)).abs() < 1e-5, "{f}");
        assert!(s.abs() < 1e-6 && t.abs() < 1e-6, "{s} {t}");
        // Faster than asked: asked for the goal's speed, never less.
        let slow = Goal::towards(Vec2::new(0.0, 0.2), 0.0);
        assert!((control.control(Some(slow))[0] - 0.2).abs() < 1e-6);
        // Far behind: at most MAX_CONTROL_SPEED.
        let fast = Goal::towards(Vec2::new(0.0, 1.0), 0.0);
        assert!((control.control(Some(fast))[0] - MAX_CONTROL_SPEED).abs() < 1e-6);
        // Held controls get the same feedback.
        assert!((control.holding([0.5, 0.0, 0.1])[0] - (0.5 + SPEED_FEEDBACK * 0.2)).abs() < 1e-5);
    }

    #[test]
    fn without_a_goal_the_last_second_goes_on() {
        let mut control = GoalControl::new(25, 0.04);
        assert_eq!(control.control(None), [0.0; 3]);
        // Walking a circle: 0.8 m/s along the heading, turning 0.5 rad/s, for 3 s.
        let (mut p, mut h) = (Vec2::ZERO, 0.3f32);
        for _ in 0..75 {
            control.record(p, h);
            p += direction_of(h) * 0.8 * 0.04;
            h += 0.5 * 0.04;
        }
        let [f, s, t] = control.control(None);
        // Over one second of the circle: turn 0.5 rad, chord 0.8 * sin(0.25)/0.25 m in the
        // direction half the turn on from the old heading, less the half step (0.01 rad) by
        // which this walker's straight 25 Hz steps lag the arc.
        let (chord, angle) = (0.8 * (0.25f32).sin() / 0.25, 0.25f32 - 0.01);
        assert!((t - 0.5).abs() < 1e-4, "{t}");
        assert!((f - chord * angle.cos()).abs() < 1e-3, "{f}");
        assert!((s - chord * angle.sin()).abs() < 1e-3, "{s}");
    }
}
