//! The matching features of one frame (Clavet 2016; Holden et al. 2020): where the feet are and
//! how they and the hips move, and where the root goes and faces over the next second, all in the
//! frame's own ground frame (the smoothed root on the floor, its facing along +z).

use glam::Vec3;

use crate::steering::direction_of;
pub use crate::steering::ground_frame::{rotate, GroundFrame};

/// Numbers per feature vector.
pub const FEATURES: usize = 27;
/// Seconds ahead of the three trajectory samples.
pub const TRAJECTORY_TIMES_S: [f64; 3] = [1.0 / 3.0, 2.0 / 3.0, 1.0];
/// The feature groups (start, length): foot positions, foot velocities, hip velocity,
/// trajectory positions, trajectory directions. Each group is scaled by its own spread.
pub const GROUPS: [(usize, usize); 5] = [(0, 6), (6, 6), (12, 3), (15, 6), (21, 6)];
/// The groups' names, in [`GROUPS`] order (the database file's `features.groups`).
pub const GROUP_NAMES: [&str; 5] = [
    "foot_positions",
    "foot_velocities",
    "hip_velocity",
    "trajectory_positions",
    "trajectory_directions",
];
/// Where the trajectory part starts (positions, then directions).
pub const TRAJECTORY_START: usize = 15;

/// The frames ahead of the trajectory samples at `fps` (at least 1, increasing).
pub fn trajectory_frames(fps: f64) -> [usize; 3] {
    let mut out = TRAJECTORY_TIMES_S.map(|t| ((t * fps).round() as usize).max(1));
    for k in 1..3 {
        out[k] = out[k].max(out[k - 1] + 1);
    }
    out
}

/// The pose part of the features (`out[..15]`): both ankles relative to the ground frame's
/// floor point, their velocities and the root's velocity, in `frame` (world metres, `dt` seconds
/// between `previous` and `current` positions).
pub fn pose_features(
    frame: &GroundFrame,
    root: Vec3,
    ankles: [Vec3; 2],
    previous_root: Vec3,
    previous_ankles: [Vec3; 2],
    dt: f32,
    out: &mut [f32; FEATURES],
) {
    let floor = Vec3::new(frame.position.x, 0.0, frame.position.y);
    for (side, (&now, &before)) in ankles.iter().zip(&previous_ankles).enumerate() {
        let p = frame.local3(now - floor);
        let v = frame.local3((now - before) / dt);
        out[3 * side..3 * side + 3].copy_from_slice(&p.to_array());
        out[6 + 3 * side..9 + 3 * side].copy_from_slice(&v.to_array());
    }
    let v = frame.local3((root - previous_root) / dt);
    out[12..15].copy_from_slice(&v.to_array());
}

/// The trajectory part of the features (`out[15..]`): the ground frames `ahead` (at
/// [`TRAJECTORY_TIMES_S`]) as positions and facing directions in `frame`.
pub fn trajectory_features(
    frame: &GroundFrame,
    ahead: [GroundFrame; 3],
    out: &mut [f32; FEATURES],
) {
    for (k, a) in ahead.iter().enumerate() {
        let p = frame.local(a.position - frame.position);
        let d = direction_of(a.facing - frame.facing);
        out[TRAJECTORY_START + 2 * k..TRAJECTORY_START + 2 * k + 2].copy_from_slice(&p.to_array());
        out[TRAJECTORY_START + 6 + 2 * k..TRAJECTORY_START + 8 + 2 * k]
            .copy_from_slice(&d.to_array());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn a_frame_facing_x_sees_x_ahead() {
        let frame = GroundFrame {
            position: Vec2::new(1.0, 2.0),
            facing: std::f32::consts::FRAC_PI_2,
        };
        // Facing +x: one metre further along +x is one metre ahead (+z local).
        let ahead = frame.local(Vec2::new(1.0, 0.0));
        assert!((ahead - Vec2::new(0.0, 1.0)).length() < 1e-6, "{ahead}");
        assert!((frame.world(ahead) - Vec2::new(1.0, 0.0)).length() < 1e-6);
        let mut out = [0.0; FEATURES];
        let later = GroundFrame {
            position: Vec2::new(2.0, 2.0),
            facing: std::f32::consts::FRAC_PI_2,
        };
        trajectory_features(&frame, [later; 3], &mut out);
        assert!((out[15] - 0.0).abs() < 1e-6 && (out[16] - 1.0).abs() < 1e-6);
        // The same facing: straight ahead.
        assert!((out[21]).abs() < 1e-6 && (out[22] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn trajectory_frames_follow_the_rate() {
        assert_eq!(trajectory_frames(30.0), [10, 20, 30]);
        assert_eq!(trajectory_frames(25.0), [8, 17, 25]);
        assert_eq!(trajectory_frames(1.0), [1, 2, 3]);
    }
}
