//! Exp-map motions (H3.6M, CMU) <-> BVH on the same skeleton.
//!
//! ## What the BVH holds
//! The skeleton's own joints, names and offsets (for H3.6M: the 32 joints of
//! `h36m_skeleton.json`, mm, y up), every joint a `JOINT` (the "Site" leaves too, so all 99 dims
//! survive; no `End Site` is added), the channels of the skeleton (the built-in ones: root
//! `Xposition Yposition Zposition Zrotation Xrotation Yrotation`, others
//! `Zrotation Xrotation Yrotation`), and the same world frame as the exp-map FK of
//! [`crate::kinematics`]:
//! - the root's position channels are the absolute root translation (H3.6M deltas integrated
//!   with [`crate::root`], one step per `round(50 / fps)` source frames), its rotation channels the
//!   absolute root rotation, so the character actually moves;
//! - a joint's BVH (column-vector) local rotation is the transpose of its H3.6M row-vector
//!   `R = expmap2rotmat(r)`.
//!
//! ## Exactness
//! The evaluation's `expmap2rotmat` has a float32-ε quirk: `k = r / (θ + ε)` is not a unit
//! axis, so its matrices rotate by a slightly smaller angle and shrink vectors across the axis
//! by ~1e-7. The BVH stores the rotation *of that matrix* (`R`, orthonormalised), not of the
//! ideal exp-map, so the angle error vanishes; the shrink cannot be expressed by a rotation and
//! remains: BVH FK equals exp-map FK to ~1e-4 mm (1.5e-4 mm max on S5 walking_1, well inside the
//! 1e-3 mm to which h36m.md says the data's bone lengths hold). The way back solves the same
//! formula ([`crate::rotation::rotmat_to_expmap_pow`]), so exp-map -> BVH -> exp-map returns the same
//! numbers to ~1e-8 (exp-maps with angle > π come back as the equivalent one with angle < π) and
//! BVH -> exp-map -> BVH the same channels to ~1e-7. Root deltas are taken against the
//! re-integrated trajectory ("closed loop"), so integrating them again does not drift over long
//! clips.
//!
//! Rotation channels are continuous over time ([`continuous_euler_degrees`]): each frame takes,
//! of the equivalent Euler triples, the one nearest the previous frame, so curves neither jump at
//! ±180° nor flip when a middle angle passes ±90°. The first frame has the canonical angles.
use std::sync::Arc;

use glam::DQuat;
use ndarray::Array2;

use crate::motion::{Motion, MotionLayout, RootEncoding};
use crate::root::{delta_between, integrate_root, RootIntegrator, RootPose};
use crate::rotation::rotmat_to_expmap_pow;
use crate::rotation::{
    axis_quat, euler_to_quat, expmap2rotmat, quat_to_euler, quat_to_row_mat3, row_mat3_to_quat,
    EulerOrder,
};
use crate::skeleton::{Channel, Skeleton, H36M_SOURCE_FPS};

use super::bvh::Bvh;

/// Why a motion could not be converted between exp-map and BVH.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// The motion is not in the exp-map layout.
    #[error("expected an exp-map motion, got BVH channels")]
    NotExpMap,
    /// A joint of the skeleton has channels that an exp-map triple cannot be written to.
    #[error("joint {joint:?}: {problem}")]
    Channels {
        /// The joint.
        joint: String,
        /// What its channels should be.
        problem: String,
    },
    /// A joint of the target skeleton is missing from the BVH.
    #[error(
        "the BVH has no joint {name:?} (the {target} skeleton needs all of its {count} joints)"
    )]
    MissingJoint {
        /// The missing joint.
        name: String,
        /// The target skeleton's name.
        target: &'static str,
        /// Its joint count.
        count: usize,
    },
    /// A BVH joint that is not in the target skeleton (End Sites aside).
    #[error("the BVH joint {name:?} is not in the {target} skeleton")]
    ExtraJoint {
        /// The BVH joint.
        name: String,
        /// The target skeleton's name.
        target: &'static str,
    },
    /// A joint has another parent than in the target skeleton.
    #[error(
        "joint {name:?} has parent {found:?} in the BVH but {expected:?} in the {target} skeleton"
    )]
    ParentMismatch {
        /// The joint.
        name: String,
        /// Its parent in the BVH.
        found: String,
        /// Its parent in the target skeleton.
        expected: String,
        /// The target skeleton's name.
        target: &'static str,
    },
    /// No built-in exp-map skeleton has this BVH's joints.
    #[error("no built-in exp-map skeleton fits this BVH: its root is {root:?} with {joints} joints (H3.6M needs the 32 joint names of h36m_skeleton.json, CMU joint_00..joint_37)")]
    NoSkeletonFits {
        /// The BVH root's name.
        root: String,
        /// Its joint count (End Sites excluded).
        joints: usize,
    },
    /// The frame rate is too low for H3.6M root deltas (one step spanning more than
    /// [`MAX_ROOT_STEP`] source frames).
    #[error("{fps} fps is too low for H3.6M root deltas (at least 1 fps: deltas are per 50 Hz source frame)")]
    FrameRate {
        /// The rejected rate.
        fps: f64,
    },
    /// The values of a frame are not finite.
    #[error("frame {frame} has a non-finite value")]
    NonFinite {
        /// 0-based frame index.
        frame: usize,
    },
}

/// The channel layout of one joint as the conversion reads and writes it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct JointChannels {
    /// Index of the first channel of the joint in a BVH frame.
    pub(crate) start: usize,
    /// Column (relative to `start`) of x, y, z position channels (root only).
    pub(crate) position: Option<[usize; 3]>,
    /// Rotation order and the column (relative to `start`) of each of its three angles.
    pub(crate) rotation: (EulerOrder, [usize; 3]),
}

/// Reads the layout of a joint that must have 3 rotation channels (and, for the root, 3
/// position channels).
pub(crate) fn joint_channels(skeleton: &Skeleton, j: usize) -> Result<JointChannels, ConvertError> {
    let joint = skeleton.joint(j);
    let is_root = joint.parent.is_none();
    let problem = || ConvertError::Channels {
        joint: joint.name.clone(),
        problem: if is_root {
            "the root needs 3 position and 3 rotation channels".to_string()
        } else {
            "needs exactly 3 rotation channels about distinct axes".to_string()
        },
    };
    let mut axes = Vec::with_capacity(3);
    let mut columns = Vec::with_capacity(3);
    let mut position = [usize::MAX; 3];
    for (k, channel) in joint.channels.iter().enumerate() {
        if channel.is_rotation() {
            axes.push(channel.axis());
            columns.push(k);
        } else if is_root {
            position[channel.axis()] = k;
        } else {
            return Err(problem());
        }
    }
    let order = <[usize; 3]>::try_from(axes.as_slice())
        .ok()
        .and_then(EulerOrder::from_axes)
        .ok_or_else(problem)?;
    let columns = <[usize; 3]>::try_from(columns.as_slice()).map_err(|_| problem())?;
    let position = if is_root {
        if position.contains(&usize::MAX) {
            return Err(problem());
        }
        Some(position)
    } else {
        None
    };
    Ok(JointChannels {
        start: skeleton.channel_start(j),
        position,
        rotation: (order, columns),
    })
}

/// The longest root step (source frames per frame) the conversions accept: 1 fps for H3.6M.
pub const MAX_ROOT_STEP: usize = 50;

/// Source frames per frame for H3.6M root deltas at this frame time: `round(50 Hz · frame_time)`,
/// at least 1 (1 at 50 Hz, 2 at 25 Hz); an error above [`MAX_ROOT_STEP`].
pub fn root_step_for_frame_time(frame_time: f64) -> Result<usize, ConvertError> {
    let step = (H36M_SOURCE_FPS * frame_time).round();
    if !(step.is_finite() && step <= MAX_ROOT_STEP as f64) {
        return Err(ConvertError::FrameRate {
            fps: 1.0 / frame_time,
        });
    }
    Ok((step as usize).max(1))
}

/// Converts an exp-map motion (H3.6M with root deltas, CMU with an absolute root) to BVH on the
/// motion's skeleton, whose joints must each have 3 rotation channels (the root also 3 position
/// channels), as the built-in skeletons have. See the module docs for the conventions.
pub fn expmap_to_bvh(motion: &Motion) -> Result<Bvh, ConvertError> {
    let MotionLayout::ExpMap { root } = motion.layout() else {
        return Err(ConvertError::NotExpMap);
    };
    let skeleton = motion.skeleton();
    let layouts = (0..skeleton.len())
        .map(|j| joint_channels(skeleton, j))
        .collect::<Result<Vec<_>, _>>()?;
    let source = motion.frames();
    if let Some(frame) = source
        .rows()
        .into_iter()
        .position(|row| row.iter().any(|v| !v.is_finite()))
    {
        return Err(ConvertError::NonFinite { frame });
    }
    let poses: Vec<RootPose> = match root {
        RootEncoding::Deltas => {
            integrate_root(source, root_step_for_frame_time(motion.frame_time())?)
        }
        RootEncoding::Absolute => source
            .rows()
            .into_iter()
            .map(|row| {
                let dims = [row[0], row[1], row[2], row[3], row[4], row[5]];
                RootPose::from_absolute_frame(&dims)
            })
            .collect(),
    };
    let channels = skeleton.channel_count();
    let mut frames = Array2::zeros((motion.len(), channels));
    let mut out = vec![0.0; channels];
    let mut previous = vec![0.0; channels];
    for (t, (row, pose)) in source.rows().into_iter().zip(&poses).enumerate() {
        for (j, layout) in layouts.iter().enumerate() {
            let q = if j == 0 {
                if let Some(position) = layout.position {
                    for axis in 0..3 {
                        out[layout.start + position[axis]] = pose.translation[axis];
                    }
                }
                row_mat3_to_quat(&pose.rotation)
            } else {
                let k = 3 + 3 * j;
                row_mat3_to_quat(&expmap2rotmat([row[k], row[k + 1], row[k + 2]]))
            };
            let (order, columns) = layout.rotation;
            let previous_angles = (t > 0).then(|| columns.map(|c| previous[layout.start + c]));
            let angles = continuous_euler_degrees(order, q, previous_angles);
            for axis in 0..3 {
                out[layout.start + columns[axis]] = angles[axis];
            }
        }
        for (dst, &src) in frames.row_mut(t).iter_mut().zip(&out) {
            *dst = src;
        }
        std::mem::swap(&mut out, &mut previous);
    }
    Ok(Bvh {
        skeleton: (**skeleton).clone(),
        frames,
        frame_time: motion.frame_time(),
    })
}

/// Euler angles in degrees of the rotation `q`: without `previous`, the canonical ones of
/// [`quat_to_euler`]; with it, whichever of the equivalent triples (the canonical one, the other
/// solution `(a + 180, 180 - b, c + 180)` of Tait-Bryan orders or `(a + 180, -b, c + 180)` of
/// proper ones, each angle moved by whole turns) is nearest `previous`, so that curves stay
/// continuous through ±180° and through the middle angle's ±90°.
pub fn continuous_euler_degrees(
    order: EulerOrder,
    q: DQuat,
    previous: Option<[f64; 3]>,
) -> [f64; 3] {
    let canonical = quat_to_euler(order, q).map(f64::to_degrees);
    let Some(previous) = previous else {
        return canonical;
    };
    let [a, b, c] = canonical;
    let mut best = canonical;
    let mut best_distance = f64::INFINITY;
    // At gimbal lock only a combination of the first and third angles is defined: keep the
    // third where it was and solve for the first.
    let [first, second, third] = order.axes();
    let rest = q * axis_quat(third, -previous[2].to_radians()) * axis_quat(second, -b.to_radians());
    let axis_part = [rest.x, rest.y, rest.z][first];
    let locked_first = (2.0 * axis_part.atan2(rest.w)).to_degrees();
    for candidate in [
        [a, b, c],
        [a + 180.0, 180.0 - b, c + 180.0],
        [a + 180.0, -b, c + 180.0],
        [locked_first, b, previous[2]],
    ] {
        // Only triples that are the same rotation (the other solution depends on the order).
        // Only triples that are the same rotation to 1e-9 rad (the other solution depends on
        // the order; the gimbal-lock one holds only at the lock). The vector part of the
        // difference measures small angles precisely, where `dot` would not.
        let difference = euler_to_quat(order, candidate.map(f64::to_radians)).inverse() * q;
        if 2.0 * difference.xyz().length() > 1e-9 {
            continue;
        }
        let unwrapped = [0, 1, 2].map(|k| unwrap_degrees(candidate[k], previous[k]));
        let distance: f64 = (0..3).map(|k| (unwrapped[k] - previous[k]).powi(2)).sum();
        if distance < best_distance {
            best_distance = distance;
            best = unwrapped;
        }
    }
    best
}

/// `angle` plus the multiple of 360° that brings it nearest to `previous`.
fn unwrap_degrees(angle: f64, previous: f64) -> f64 {
    let turns = ((previous - angle) / 360.0).round();
    if turns == 0.0 || !turns.is_finite() {
        angle
    } else {
        angle + 360.0 * turns
    }
}

/// A built-in exp-map skeleton a BVH can be converted to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExpMapTarget {
    /// The H3.6M 32-joint skeleton, root stored as per-50 Hz-frame deltas (99 dims).
    H36m,
    /// The CMU 38-joint skeleton (`joint_00`..`joint_37`), absolute root (117 dims).
    Cmu,
}

impl ExpMapTarget {
    /// The target's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            ExpMapTarget::H36m => "H3.6M",
            ExpMapTarget::Cmu => "CMU",
        }
    }

    /// The built-in skeleton whose exp-map frames have `frame_dims` values (99: H3.6M, 117: CMU).
    pub fn for_frame_dims(frame_dims: usize) -> Option<ExpMapTarget> {
        [ExpMapTarget::H36m, ExpMapTarget::Cmu]
            .into_iter()
            .find(|t| t.skeleton().expmap_width() == frame_dims)
    }

    /// The built-in skeleton.
    pub fn skeleton(self) -> Skeleton {
        match self {
            ExpMapTarget::H36m => Skeleton::h36m(),
            ExpMapTarget::Cmu => Skeleton::cmu(),
        }
    }

    /// How the root is stored.
    pub fn root(self) -> RootEncoding {
        match self {
            ExpMapTarget::H36m => RootEncoding::Deltas,
            ExpMapTarget::Cmu => RootEncoding::Absolute,
        }
    }

    /// The built-in skeleton whose joints (End Sites aside) this BVH has, by name.
    pub fn detect(bvh: &Bvh) -> Result<ExpMapTarget, ConvertError> {
        let joints: Vec<&str> = bvh.skeleton.body_joint_names();
        for target in [ExpMapTarget::H36m, ExpMapTarget::Cmu] {
            let skeleton = target.skeleton();
            if joints.len() == skeleton.len()
                && skeleton
                    .joints()
                    .iter()
                    .all(|j| joints.contains(&j.name.as_str()))
            {
                return Ok(target);
            }
        }
        Err(ConvertError::NoSkeletonFits {
            root: bvh.skeleton.joint(0).name.clone(),
            joints: joints.len(),
        })
    }
}

/// The largest difference between the BVH's joint offsets and those of `target`'s built-in
/// skeleton (joints matched by name; 0 when they agree). Exp-map frames do not store offsets, so a
/// BVH with other proportions or units converts to motion on the built-in skeleton's bones.
pub fn offset_difference(bvh: &Bvh, target: ExpMapTarget) -> f64 {
    let skeleton = target.skeleton();
    let mut worst = 0.0f64;
    for joint in skeleton.joints() {
        if let Some(index) = bvh.skeleton.joint_index(&joint.name) {
            let offset = bvh.skeleton.joint(index).offset;
            for (a, b) in offset.iter().zip(&joint.offset) {
                worst = worst.max((a - b).abs());
            }
        }
    }
    worst
}

/// Converts a BVH whose joints are those of `target` (matched by name, any order, any rotation
/// channel order; End Sites ignored) to an exp-map motion on the built-in skeleton, at the BVH's
/// frame rate. For H3.6M the absolute root is differentiated back to per-source-frame deltas
/// (`round(50 Hz · frame_time)` source frames per frame). Offsets are not stored in exp-map
/// frames: the target's own offsets apply. Non-root position channels must be zero.
pub fn bvh_to_expmap(bvh: &Bvh, target: ExpMapTarget) -> Result<Motion, ConvertError> {
    let skeleton = target.skeleton();
    let source = &bvh.skeleton;
    let name = target.name();
    // For each target joint, its index in the BVH.
    let mut map = Vec::with_capacity(skeleton.len());
    for joint in skeleton.joints() {
        let index = source
            .joint_index(&joint.name)
            .filter(|&i| !source.joint(i).is_end_site)
            .ok_or_else(|| ConvertError::MissingJoint {
                name: joint.name.clone(),
                target: name,
                count: skeleton.len(),
            })?;
        let found = source.parent(index).map(|p| source.joint(p).name.as_str());
        let expected = joint.parent.map(|p| skeleton.joint(p).name.as_str());
        if found != expected {
            return Err(ConvertError::ParentMismatch {
                name: joint.name.clone(),
                found: found.unwrap_or("(none: root)").to_string(),
                expected: expected.unwrap_or("(none: root)").to_string(),
                target: name,
            });
        }
        map.push(index);
    }
    if let Some(extra) = source
        .joints()
        .iter()
        .find(|j| !j.is_end_site && skeleton.joint_index(&j.name).is_none())
    {
        return Err(ConvertError::ExtraJoint {
            name: extra.name.clone(),
            target: name,
        });
    }
    for &index in &map[1..] {
        let joint = source.joint(index);
        let start = source.channel_start(index);
        for (k, channel) in joint.channels.iter().enumerate() {
            if !channel.is_rotation() && bvh.frames.column(start + k).iter().any(|&v| v != 0.0) {
                return Err(ConvertError::Channels {
                    joint: joint.name.clone(),
                    problem: "has non-zero position channels, which exp-map frames cannot store"
                        .to_string(),
                });
            }
        }
    }
    if let Some(frame) = bvh
        .frames
        .rows()
        .into_iter()
        .position(|row| row.iter().any(|v| !v.is_finite()))
    {
        return Err(ConvertError::NonFinite { frame });
    }

    let mut frames = Array2::zeros((bvh.frames.nrows(), skeleton.expmap_width()));
    let mut poses = Vec::with_capacity(bvh.frames.nrows());
    let mut row = vec![0.0; source.channel_count()];
    for (t, source_row) in bvh.frames.rows().into_iter().enumerate() {
        for (dst, &src) in row.iter_mut().zip(source_row.iter()) {
            *dst = src;
        }
        let mut out = frames.row_mut(t);
        for (j, &index) in map.iter().enumerate() {
            let (rotation, translation) = local_channels(source, index, &row);
            let m = quat_to_row_mat3(rotation);
            if j == 0 {
                poses.push(RootPose {
                    rotation: m,
                    translation,
                });
            } else {
                let r = rotmat_to_expmap_pow(&m, 1);
                for axis in 0..3 {
                    out[3 + 3 * j + axis] = r[axis];
                }
            }
        }
    }
    match target.root() {
        RootEncoding::Deltas => {
            let deltas = closed_loop_deltas(&poses, root_step_for_frame_time(bvh.frame_time)?);
            frames.slice_mut(ndarray::s![.., 0..6]).assign(&deltas);
        }
        RootEncoding::Absolute => {
            for (pose, mut row) in poses.iter().zip(frames.rows_mut()) {
                let r = rotmat_to_expmap_pow(&pose.rotation, 1);
                for axis in 0..3 {
                    row[axis] = pose.translation[axis];
                    row[3 + axis] = r[axis];
                }
            }
        }
    }
    Motion::new(
        Arc::new(skeleton),
        MotionLayout::ExpMap {
            root: target.root(),
        },
        frames,
        bvh.fps(),
    )
    .map_err(|e| ConvertError::Channels {
        joint: String::new(),
        problem: e.to_string(),
    })
}

/// Root deltas whose integration ([`crate::root::integrate_root`]) gives `poses`, each delta taken
/// from the pose that integration reaches (not the exact previous pose), so rounding errors do
/// not accumulate over thousands of frames: integrating the result lands within ~1e-12 of every
/// pose.
fn closed_loop_deltas(poses: &[RootPose], step: usize) -> Array2<f64> {
    let mut out = Array2::zeros((poses.len(), 6));
    let mut integrator = RootIntegrator::new(step);
    for (t, pose) in poses.iter().enumerate() {
        let times = if t == 0 { 1 } else { step.max(1) };
        let (d, rd) = delta_between(&integrator.pose(), pose, times);
        let delta = [d[0], d[1], d[2], rd[0], rd[1], rd[2]];
        integrator.push(&delta);
        for (k, value) in delta.into_iter().enumerate() {
            out[[t, k]] = value;
        }
    }
    out
}

/// A joint's local rotation (its rotation channels composed in listed order, column vectors) and
/// its position channels (zero where absent), from a BVH frame with rotations in degrees.
fn local_channels(skeleton: &Skeleton, j: usize, frame: &[f64]) -> (DQuat, [f64; 3]) {
    let joint = skeleton.joint(j);
    let start = skeleton.channel_start(j);
    let mut rotation = DQuat::IDENTITY;
    let mut translation = [0.0; 3];
    for (k, channel) in joint.channels.iter().enumerate() {
        let value = frame[start + k];
        match channel {
            Channel::Xposition | Channel::Yposition | Channel::Zposition => {
                translation[channel.axis()] = value;
            }
            Channel::Xrotation | Channel::Yrotation | Channel::Zrotation => {
                rotation *= axis_quat(channel.axis(), value.to_radians());
            }
        }
    }
    (rotation, translation)
}

/// Euler angles (degrees) of a BVH joint with three rotation channels, as a column-vector
/// quaternion (used by tests and tools that build BVH frames by hand).
pub fn bvh_euler_to_quat(order: EulerOrder, degrees: [f64; 3]) -> DQuat {
    euler_to_quat(order, degrees.map(f64::to_radians))
}
