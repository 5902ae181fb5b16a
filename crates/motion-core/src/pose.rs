//! Engine-facing poses: for each exp-map frame, the root transform, every joint's local rotation
//! and the root motion split as a character controller wants it, as plain f32 glam data.
//!
//! ## Conventions of [`Pose`] (the engine boundary; everything else in the crate is f64 / mm)
//! - Lengths in **metres**, +y up (the H3.6M and CMU data's up axis), right-handed.
//! - Rotations are unit [`Quat`]s acting on **column vectors** (glam, Bevy, Unity, Unreal, BVH):
//!   a joint's world rotation is `world[parent] * local[j]` and its position
//!   `world_pos[parent] + world[parent] * offset_j`. The exp-map frames' row-vector matrices are
//!   converted once, here: the local rotation of an H3.6M joint with exp map `r` is the rotation
//!   about `r` by `-|r|` ([`crate::rotation::h36m_joint_quat`]).
//! - The root: `local_rotations[0]` is the root's world rotation and [`Pose::root_translation`]
//!   its world position (the root joint's offset included), integrated from the H3.6M root deltas
//!   with the first-frame rule of [`crate::root`] (the first pushed frame is applied once, each
//!   later one `step` times), starting at the origin with no rotation. Push the seed first and
//!   the generated frames after it, so the character continues from where the seed left it.
//!
//! ```
//! use std::sync::Arc;
//! use motion_core::pose::PoseDecoder;
//! use motion_core::{RootEncoding, Skeleton};
//!
//! let mut decoder = PoseDecoder::new(Arc::new(Skeleton::h36m()), RootEncoding::Deltas, 2);
//! let mut frame = [0.0f32; 99];
//! frame[0] = 10.0; // 10 mm forward (root frame) per 50 Hz source frame
//! decoder.push(&frame);
//! let pose = decoder.push(&frame); // a 25 Hz frame spans 2 source frames: 20 mm more
//! assert!((pose.root_motion.ground_translation.x - 0.030).abs() < 1e-6);
//! assert_eq!(pose.local_rotations.len(), 32);
//! ```
use std::sync::Arc;

use glam::{DQuat, DVec3, Quat, Vec3};

use crate::kinematics::ExpMapFk;
use crate::motion::{FrameScalar, RootEncoding};
use crate::root::{root_deltas, RootIntegrator, RootPose};
use crate::rotation::{h36m_joint_expmap, h36m_joint_quat, quat_to_row_mat3, row_mat3_to_quat};
use crate::skeleton::Skeleton;

/// Metres per millimetre: [`Pose`] lengths are metres, the crate's data millimetres.
pub const METRES_PER_MM: f64 = 1e-3;

/// The root motion of one frame, split as engines use it: a ground transform for the character
/// controller (translation on the ground plane, heading about +y) and the rest for the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootMotion {
    /// The root's world position projected on the ground plane (`y = 0`), metres.
    pub ground_translation: Vec3,
    /// The heading: the twist of the root's world rotation about +y.
    pub ground_yaw: Quat,
    /// Ground displacement since the previous frame, metres, in world axes (zero on the first).
    pub delta_translation: Vec3,
    /// Heading change since the previous frame, radians about +y (zero on the first).
    pub delta_yaw: f32,
    /// The root's position in the ground frame: `ground_yaw⁻¹ * (root - ground)` — its height
    /// in `y`, zero in `x` and `z`.
    pub pelvis_offset: Vec3,
    /// The root's rotation left after the heading: `ground_yaw⁻¹ * root_rotation` (tilt and lean).
    pub pelvis_rotation: Quat,
}

impl RootMotion {
    const IDENTITY: RootMotion = RootMotion {
        ground_translation: Vec3::ZERO,
        ground_yaw: Quat::IDENTITY,
        delta_translation: Vec3::ZERO,
        delta_yaw: 0.0,
        pelvis_offset: Vec3::ZERO,
        pelvis_rotation: Quat::IDENTITY,
    };
}

/// One frame as an engine poses a rig (see the module conventions). `clone_from` reuses the
/// rotations' buffer (no allocation per frame).
#[derive(Debug, PartialEq)]
pub struct Pose {
    /// World position of the root joint, metres.
    pub root_translation: Vec3,
    /// Per joint (skeleton order), the rotation in its parent's frame; joint 0 (the root): its
    /// world rotation.
    pub local_rotations: Vec<Quat>,
    /// The root motion split into ground transform and pelvis remainder.
    pub root_motion: RootMotion,
}

impl Clone for Pose {
    fn clone(&self) -> Pose {
        Pose {
            root_translation: self.root_translation,
            local_rotations: self.local_rotations.clone(),
            root_motion: self.root_motion,
        }
    }

    fn clone_from(&mut self, source: &Pose) {
        self.root_translation = source.root_translation;
        self.local_rotations.clone_from(&source.local_rotations);
        self.root_motion = source.root_motion;
    }
}

impl Pose {
    /// The rest pose of `joints` joints at the origin.
    pub fn rest(joints: usize) -> Pose {
        Pose {
            root_translation: Vec3::ZERO,
            local_rotations: vec![Quat::IDENTITY; joints],
            root_motion: RootMotion::IDENTITY,
        }
    }

    /// The root's world rotation (`local_rotations[0]`).
    pub fn root_rotation(&self) -> Quat {
        self.local_rotations[0]
    }

    /// The height (metres) to raise this pose by so that its lowest joint touches the floor
    /// (`y = 0`). The root is integrated from the origin, so a character's hips start at floor
    /// level; engines add this once, at the start, to stand it on the ground.
    pub fn floor_offset(&self, skeleton: &Skeleton) -> f32 {
        let n = self.local_rotations.len();
        let (mut out, mut world) = (vec![Vec3::ZERO; n], vec![Quat::IDENTITY; n]);
        self.world_positions_into(skeleton, &mut out, &mut world);
        -out.iter().map(|p| p.y).fold(f32::INFINITY, f32::min)
    }

    /// World joint positions (metres) by forward kinematics of this pose's rotations on
    /// `skeleton` (offsets in millimetres, as the skeletons store them), into `out` (one per
    /// joint). What an engine computes from the pose; f32 throughout.
    ///
    /// # Panics
    /// If `skeleton` or `out` has another joint count than the pose.
    pub fn world_positions_into(&self, skeleton: &Skeleton, out: &mut [Vec3], world: &mut [Quat]) {
        let n = self.local_rotations.len();
        assert!(
            skeleton.len() == n && out.len() == n && world.len() == n,
            "joint counts differ"
        );
        let scale = METRES_PER_MM as f32;
        for (j, joint) in skeleton.joints().iter().enumerate() {
            let offset = Vec3::from_array(joint.offset.map(|v| v as f32)) * scale;
            match joint.parent {
                None => {
                    world[j] = self.local_rotations[j];
                    out[j] = self.root_translation;
                }
                Some(p) => {
                    world[j] = world[p] * self.local_rotations[j];
                    out[j] = out[p] + world[p] * offset;
                }
            }
        }
    }
}

/// Streaming exp-map frames → [`Pose`]s: root integration, local rotations and root motion, with
/// no allocation per frame.
#[derive(Debug, Clone)]
pub struct PoseDecoder {
    skeleton: Arc<Skeleton>,
    root: RootEncoding,
    integrator: RootIntegrator,
    started: bool,
    /// The last frame, as f64.
    frame: Vec<f64>,
    root_pose: RootPose,
    pose: Pose,
    fk: ExpMapFk,
    positions: Vec<[f64; 3]>,
}

impl PoseDecoder {
    /// A decoder of exp-map frames on `skeleton` whose root is stored as `root`; with
    /// [`RootEncoding::Deltas`] each frame spans `step` source frames (2 for H3.6M at 25 Hz).
    pub fn new(skeleton: Arc<Skeleton>, root: RootEncoding, step: usize) -> PoseDecoder {
        let joints = skeleton.len();
        PoseDecoder {
            frame: vec![0.0; skeleton.expmap_width()],
            fk: ExpMapFk::new(&skeleton),
            skeleton,
            root,
            integrator: RootIntegrator::new(step),
            started: false,
            root_pose: RootPose::IDENTITY,
            pose: Pose::rest(joints),
            positions: vec![[0.0; 3]; joints],
        }
    }

    /// The skeleton the frames are on.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// Forgets the history: the next frame is a first frame again (root at the origin).
    pub fn reset(&mut self) {
        self.integrator.reset();
        self.started = false;
    }

    /// Decodes the next frame (`skeleton.expmap_width()` values: seed frames first, then
    /// generated ones) and returns its pose.
    ///
    /// # Panics
    /// If `frame` has another width than the skeleton's exp-map frames.
    pub fn push<T: FrameScalar>(&mut self, frame: &[T]) -> &Pose {
        assert_eq!(frame.len(), self.frame.len(), "exp-map frame width");
        for (d, s) in self.frame.iter_mut().zip(frame) {
            *d = s.to_f64();
        }
        self.root_pose = match self.root {
            RootEncoding::Deltas => self.integrator.push(&self.frame),
            RootEncoding::Absolute => RootPose::from_absolute_frame(&self.frame),
        };
        let root_rotation = row_mat3_to_quat(&self.root_pose.rotation);
        let offset = DVec3::from_array(self.skeleton.joint(0).offset);
        let root_translation =
            (DVec3::from_array(self.root_pose.translation) + offset) * METRES_PER_MM;
        let pose = &mut self.pose;
        pose.local_rotations[0] = root_rotation.as_quat();
        for j in 1..pose.local_rotations.len() {
            let k = 3 + 3 * j;
            let r = [self.frame[k], self.frame[k + 1], self.frame[k + 2]];
            pose.local_rotations[j] = h36m_joint_quat(r).as_quat();
        }
        let previous = self.started.then_some(pose.root_motion);
        pose.root_translation = root_translation.as_vec3();
        pose.root_motion = root_motion_between(root_translation, root_rotation, previous);
        self.started = true;
        &self.pose
    }

    /// Every frame of `take` (rows of exp-map frames, oldest first) decoded from a fresh start
    /// (the decoder is reset first): one pose per row. Allocates the poses (whole clips, not a
    /// per-frame path).
    ///
    /// # Panics
    /// If `take`'s rows have another width than the skeleton's exp-map frames.
    pub fn decode_all<T: FrameScalar>(&mut self, take: ndarray::ArrayView2<'_, T>) -> Vec<Pose> {
        self.reset();
        let mut row = Vec::with_capacity(take.ncols());
        take.rows()
            .into_iter()
            .map(|r| {
                row.clear();
                row.extend(r.iter().copied());
                self.push(&row).clone()
            })
            .collect()
    }

    /// The pose of the last pushed frame (the rest pose before any).
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// World joint positions (metres) of the last pushed frame into `out` (one per joint), by the
    /// crate's f64 forward kinematics ([`crate::kinematics::expmap_positions`]'s, exact to the
    /// data's rotation convention) rounded to f32 once.
    ///
    /// # Panics
    /// If `out` does not have one entry per joint.
    pub fn world_positions(&mut self, out: &mut [Vec3]) {
        assert_eq!(out.len(), self.positions.len(), "one position per joint");
        self.fk.frame(
            &self.skeleton,
            &self.frame,
            &self.root_pose,
            &mut self.positions,
        );
        for (o, p) in out.iter_mut().zip(&self.positions) {
            *o = (DVec3::from_array(*p) * METRES_PER_MM).as_vec3();
        }
    }
}

/// Poses on `skeleton` as exp-map frames with the root stored as deltas, each frame spanning
/// `step` source frames: the inverse of [`PoseDecoder`] with [`RootEncoding::Deltas`] (decoding
/// the result gives the poses back, the root integrated from the origin at the first frame).
/// Joint rotations of angle π or more come back as the same rotation by a smaller angle. Whole
/// clips: allocates the frames.
///
/// # Panics
/// If a pose has another joint count than `skeleton`.
pub fn encode_poses(skeleton: &Skeleton, poses: &[Pose], step: usize) -> ndarray::Array2<f64> {
    let offset = DVec3::from_array(skeleton.joint(0).offset);
    let roots: Vec<RootPose> = poses
        .iter()
        .map(|pose| {
            assert_eq!(pose.local_rotations.len(), skeleton.len(), "joint count");
            let translation = pose.root_translation.as_dvec3() / METRES_PER_MM - offset;
            RootPose {
                rotation: quat_to_row_mat3(pose.root_rotation().as_dquat().normalize()),
                translation: translation.to_array(),
            }
        })
        .collect();
    let mut frames = ndarray::Array2::zeros((poses.len(), skeleton.expmap_width()));
    frames
        .slice_mut(ndarray::s![.., 0..6])
        .assign(&root_deltas(&roots, step));
    for (pose, mut row) in poses.iter().zip(frames.rows_mut()) {
        for (j, q) in pose.local_rotations.iter().enumerate().skip(1) {
            let r = h36m_joint_expmap(q.as_dquat().normalize());
            for k in 0..3 {
                row[3 + 3 * j + k] = r[k];
            }
        }
    }
    frames
}

/// The twist of `q` about +y (the heading), as a unit quaternion.
pub fn yaw_of(q: DQuat) -> DQuat {
    let twist = DQuat::from_xyzw(0.0, q.y, 0.0, q.w);
    let norm = twist.length();
    if norm < 1e-12 {
        // Rotated 180° about a horizontal axis: no defined heading.
        DQuat::IDENTITY
    } else {
        twist / norm
    }
}

/// The root motion of a root at `translation` (metres) with world `rotation`, deltas against the
/// `previous` frame's (zero without one).
pub fn root_motion_between(
    translation: DVec3,
    rotation: DQuat,
    previous: Option<RootMotion>,
) -> RootMotion {
    let ground = DVec3::new(translation.x, 0.0, translation.z);
    let yaw = yaw_of(rotation);
    let (delta_translation, delta_yaw) = match previous {
        Some(p) => {
            let turn = yaw * p.ground_yaw.as_dquat().inverse();
            let angle = 2.0 * turn.y.atan2(turn.w);
            // The shorter way round.
            let angle = (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            (ground - p.ground_translation.as_dvec3(), angle)
        }
        None => (DVec3::ZERO, 0.0),
    };
    let inverse = yaw.inverse();
    RootMotion {
        ground_translation: ground.as_vec3(),
        ground_yaw: yaw.as_quat(),
        delta_translation: delta_translation.as_vec3(),
        delta_yaw: delta_yaw as f32,
        pelvis_offset: (inverse * (translation - ground)).as_vec3(),
        pelvis_rotation: (inverse * rotation).normalize().as_quat(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::expmap_positions;
    use ndarray::Array2;

    /// H3.6M-like frames: a root walking forward and turning, every joint moving.
    fn frames(n: usize) -> Array2<f64> {
        Array2::from_shape_fn((n, 99), |(t, d)| match d {
            0 => 8.0,
            1 => 0.5 * (t as f64 * 0.3).sin(),
            2 => 3.0,
            3 => 0.004 * (t as f64 * 0.2).cos(),
            4 => 0.01,
            5 => 0.003,
            _ => 0.6 * ((t as f64) * 0.17 + d as f64 * 0.7).sin(),
        })
    }

    #[test]
    fn encoding_poses_is_the_inverse_of_decoding() {
        let skeleton = Arc::new(Skeleton::h36m());
        let frames = frames(40);
        for step in [1, 2] {
            let poses = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, step)
                .decode_all(frames.view());
            let encoded = encode_poses(&skeleton, &poses, step);
            let again = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, step)
                .decode_all(encoded.view());
            for (a, b) in poses.iter().zip(&again) {
                assert!((a.root_translation - b.root_translation).length() < 1e-5);
                for (qa, qb) in a.local_rotations.iter().zip(&b.local_rotations) {
                    assert!(qa.dot(*qb).abs() > 1.0 - 1e-6, "{qa} vs {qb}");
                }
            }
        }
    }

    #[test]
    fn world_positions_equal_the_fk_and_the_pose_fk_agrees() {
        let skeleton = Arc::new(Skeleton::h36m());
        let frames = frames(60);
        let fk = expmap_positions(&skeleton, frames.view(), RootEncoding::Deltas, 2).unwrap();
        let mut decoder = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, 2);
        let n = skeleton.len();
        let (mut exact, mut engine, mut world) = (
            vec![Vec3::ZERO; n],
            vec![Vec3::ZERO; n],
            vec![Quat::IDENTITY; n],
        );
        let (mut worst_exact, mut worst_engine) = (0.0f64, 0.0f64);
        for (t, row) in frames.rows().into_iter().enumerate() {
            let pose = decoder.push(row.as_slice().unwrap()).clone();
            decoder.world_positions(&mut exact);
            pose.world_positions_into(&skeleton, &mut engine, &mut world);
            for j in 0..n {
                let want = DVec3::new(fk[[t, j, 0]], fk[[t, j, 1]], fk[[t, j, 2]]);
                // f32 holds a coordinate to 6e-8 of its size: allow that rounding beside 1e-4 mm.
                let allowance = 1e-4 + 1.2e-7 * want.length();
                let e = (exact[j].as_dvec3() * 1e3 - want).length();
                assert!(e <= allowance, "frame {t} joint {j}: {e} mm");
                worst_exact = worst_exact.max(e);
                // The rig FK from the f32 quaternions: exact rotations, unlike the data's
                // float32-epsilon exp map (bones off by up to ~1e-3 mm, h36m.md).
                worst_engine = worst_engine.max((engine[j].as_dvec3() * 1e3 - want).length());
            }
        }
        eprintln!("worst: decoder {worst_exact} mm, rig FK from the f32 pose {worst_engine} mm");
        assert!(worst_exact < 1e-3, "{worst_exact}");
        assert!(worst_engine < 0.05, "{worst_engine} mm");
    }

    #[test]
    fn a_whole_take_decodes_as_its_frames_pushed_one_by_one_from_a_fresh_start() {
        let skeleton = Arc::new(Skeleton::h36m());
        let f = frames(30);
        let mut one_by_one = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, 2);
        let want: Vec<Pose> = f
            .rows()
            .into_iter()
            .map(|row| one_by_one.push(row.as_slice().unwrap()).clone())
            .collect();
        let mut decoder = PoseDecoder::new(skeleton, RootEncoding::Deltas, 2);
        decoder.push(f.row(5).as_slice().unwrap()); // history that must not carry over
        assert_eq!(decoder.decode_all(f.view()), want);
        assert_eq!(decoder.decode_all(f.view()), want);
    }

    #[test]
    fn local_rotations_are_the_conjugate_of_the_exp_map_rotation() {
        let mut decoder = PoseDecoder::new(Arc::new(Skeleton::h36m()), RootEncoding::Deltas, 1);
        let f = frames(1);
        let pose = decoder.push(f.row(0).as_slice().unwrap());
        for j in 1..32 {
            let r = DVec3::new(f[[0, 3 + 3 * j]], f[[0, 4 + 3 * j]], f[[0, 5 + 3 * j]]);
            let want = DQuat::from_scaled_axis(-r);
            assert!(pose.local_rotations[j].as_dquat().abs_diff_eq(want, 1e-6));
        }
    }

    #[test]
    fn root_motion_splits_into_ground_and_pelvis() {
        let skeleton = Arc::new(Skeleton::h36m());
        let mut decoder = PoseDecoder::new(skeleton, RootEncoding::Deltas, 2);
        let f = frames(40);
        let mut ground = Vec3::ZERO;
        let mut heading = 0.0f64;
        for (t, row) in f.rows().into_iter().enumerate() {
            let pose = decoder.push(row.as_slice().unwrap());
            let m = pose.root_motion;
            // Accumulated deltas reproduce the absolute ground transform.
            if t == 0 {
                assert_eq!((m.delta_translation, m.delta_yaw), (Vec3::ZERO, 0.0));
                ground = m.ground_translation;
                heading = 2.0 * (m.ground_yaw.y as f64).atan2(m.ground_yaw.w as f64);
            }
            ground += m.delta_translation;
            heading += m.delta_yaw as f64;
            assert!((ground - m.ground_translation).length() < 1e-4, "frame {t}");
            let yaw = Quat::from_rotation_y(heading as f32);
            assert!(yaw.abs_diff_eq(m.ground_yaw, 1e-4) || yaw.abs_diff_eq(-m.ground_yaw, 1e-4));
            assert_eq!(m.ground_translation.y, 0.0);
            // Ground * pelvis = the root's world transform.
            let rebuilt = m.ground_yaw * m.pelvis_rotation;
            assert!(rebuilt.abs_diff_eq(pose.root_rotation(), 1e-5));
            let position = m.ground_translation + m.ground_yaw * m.pelvis_offset;
            assert!((position - pose.root_translation).length() < 1e-5);
            assert!(m.pelvis_offset.x.abs() < 1e-5 && m.pelvis_offset.z.abs() < 1e-5);
            // The pelvis rotation has no heading left.
            let left = yaw_of(m.pelvis_rotation.as_dquat());
            assert!(left.abs_diff_eq(DQuat::IDENTITY, 1e-5));
        }
        assert!(heading.abs() > 0.5, "the test root turns: {heading}");
    }
}
