//! Rig targets: a character's own skeleton (a glTF/GLB skin, a BVH, or joint arrays from an
//! engine) driven by the poses this crate makes. Given each frame's [`Pose`] (on the H3.6M
//! skeleton, or on any rig the built-in joint maps or a joint map fit), [`RigTarget::write`] fills
//! a [`RigPose`]: the local rotation of every joint of the target rig, as an engine writes it into
//! that joint, and the hips' translation in the parent space of the rig's hips, in metres. Nothing
//! is allocated per frame.
//!
//! ## The rule (one place)
//! - **Rest poses.** A target joint has a rest local rotation and translation (a glTF node's TRS;
//!   a Blender export gives every joint a non-identity rest rotation). The retargeter
//!   ([`crate::retarget`]) works on the rig's rest *positions* with identity rest rotations and
//!   gives each mapped joint a world rotation `W_j` from that rest; the joint's world rotation is
//!   then `W_j · R_j` (`R_j` its rest world rotation) and the value written is that expressed in
//!   its parent's current world frame. Unmapped joints (the skin's root, fingers, extra bones)
//!   keep their rest local rotation and follow their parent.
//! - **Mapping.** [`JointMap::detect`] on the rig's rest positions (the built-in maps: the Unreal
//!   one fits the Quaternius/Mesh2Motion mannequins), or a joint map given as JSON.
//! - **Hips.** The source hips' path, turned into the rig's world axes and scaled by the ratio
//!   of the rig's leg length to the source's (so that feet planted by the source's grounding stay
//!   on the floor for the rig's own legs), expressed in the parent space of the rig's hips.
//! - **Conventions.** Metres, +y up, right-handed, column-vector quaternions (glam), as
//!   [`Pose`]; a glTF character faces +z. Engines with other conventions convert once
//!   (`docs/embedding.md`).
//!
//! ```no_run
//! use motion_core::rig_target::{RigPose, RigTarget};
//! use motion_core::Skeleton;
//!
//! let mut target = RigTarget::from_gltf("assets/mannequin.glb".as_ref(), None, &Skeleton::h36m())?;
//! let mut out = RigPose::for_target(&target);
//! # let pose = motion_core::pose::Pose::rest(32);
//! target.write(&pose, &mut out); // each frame: out.local_rotations[j] into joint j
//! println!("{} joints, hips at {}", target.joints().len(), out.hips_translation);
//! # Ok::<(), motion_core::rig_target::RigTargetError>(())
//! ```
use std::path::Path;

use glam::{DQuat, DVec3, Quat, Vec3};

use crate::error::SkeletonError;
use crate::grounding::find_body_parts;
use crate::pose::{Pose, METRES_PER_MM};
use crate::retarget::{JointMap, RetargetError, Retargeter, MAPPED_JOINTS};
use crate::skeleton::{Channel, Joint, Skeleton};

mod gltf_skin;
#[cfg(test)]
mod tests;

pub use gltf_skin::read_gltf_joints;

/// The most joints a target rig may have (a game skeleton has a few hundred at most; Bevy
/// skins hold 256).
pub const MAX_JOINTS: usize = 4096;

/// One joint of a target rig (its rest pose as the engine holds it).
#[derive(Debug, Clone, PartialEq)]
pub struct RigJoint {
    /// The joint's name (a glTF node name, a BVH joint name).
    pub name: String,
    /// The parent joint (index into the rig's joints, parents first); `None` for a root.
    pub parent: Option<usize>,
    /// Rest local rotation (in the parent's frame; for a root, in the rig's world).
    pub rest_rotation: Quat,
    /// Rest local translation (metres, in the parent's frame; for a root, in the rig's world).
    pub rest_translation: Vec3,
}

/// Why a rig target could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigTargetError {
    /// The file could not be read or parsed.
    #[error("{path}: {problem}")]
    File {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The joints given are not a rig (no joints, a parent after its child, a bad value).
    #[error("{0}")]
    Joints(String),
    /// The rig's joints could not be mapped onto the source's.
    #[error("the rig cannot be mapped: {0}")]
    Map(#[from] RetargetError),
    /// The rig has no legs to ground by.
    #[error("the rig has no two legs: {0}")]
    Legs(String),
}

impl RigJoint {
    /// Joints from the flat arrays an engine hands over (the C ABI, Python, JavaScript): per
    /// joint its name, its parent (`-1` for the root), its rest rotation `x, y, z, w` (4 values
    /// per joint) and rest translation in metres (3 per joint). The rig itself is checked by
    /// [`RigTarget::from_joints`].
    ///
    /// # Errors
    /// Lengths that disagree, or a parent below `-1`.
    pub fn from_arrays<S: Into<String>>(
        names: impl IntoIterator<Item = S>,
        parents: &[i64],
        rest_rotations: &[f32],
        rest_translations: &[f32],
    ) -> Result<Vec<RigJoint>, RigTargetError> {
        let names: Vec<String> = names.into_iter().map(Into::into).collect();
        let n = names.len();
        if parents.len() != n || rest_rotations.len() != 4 * n || rest_translations.len() != 3 * n {
            return Err(RigTargetError::Joints(format!(
                "{n} names need {n} parents, {} rest rotation values (4 per joint) and {} rest \
                 translation values (3 per joint); got {}, {} and {}",
                4 * n,
                3 * n,
                parents.len(),
                rest_rotations.len(),
                rest_translations.len()
            )));
        }
        names
            .into_iter()
            .enumerate()
            .map(|(j, name)| {
                let parent = match parents[j] {
                    -1 => None,
                    p if p >= 0 => Some(usize::try_from(p).unwrap_or(usize::MAX)),
                    p => {
                        return Err(RigTargetError::Joints(format!(
                            "joint {j} ({name:?}): parent {p} (-1 for the root)"
                        )))
                    }
                };
                let (r, t) = (
                    &rest_rotations[4 * j..4 * j + 4],
                    &rest_translations[3 * j..3 * j + 3],
                );
                Ok(RigJoint {
                    name,
                    parent,
                    rest_rotation: Quat::from_xyzw(r[0], r[1], r[2], r[3]),
                    rest_translation: Vec3::new(t[0], t[1], t[2]),
                })
            })
            .collect()
    }
}

impl From<SkeletonError> for RigTargetError {
    fn from(e: SkeletonError) -> Self {
        RigTargetError::Joints(e.to_string())
    }
}

/// What [`RigTarget::write`] fills: per target joint its local rotation, and the hips'
/// translation in the parent space of the rig's hips (metres).
#[derive(Debug, Clone, PartialEq)]
pub struct RigPose {
    /// Per target joint (the rig's order), the rotation to write into it.
    pub local_rotations: Vec<Quat>,
    /// The hips' local translation (metres, in the parent space of the hips).
    pub hips_translation: Vec3,
    /// The root joint's world position that puts the hips there with every other joint at its
    /// rest translation (metres): for engines and files that move the root instead of the hips.
    pub root_translation: Vec3,
}

impl RigPose {
    /// A pose buffer for `target` (its rest pose).
    pub fn for_target(target: &RigTarget) -> RigPose {
        RigPose {
            local_rotations: target.joints.iter().map(|j| j.rest_rotation).collect(),
            hips_translation: target.joints[target.hips].rest_translation,
            root_translation: target.joints[0].rest_translation,
        }
    }
}

/// A source skeleton's side of the mapping.
#[derive(Debug, Clone)]
enum Source {
    /// The H3.6M skeleton (the learned models' poses): its joints by [`MAPPED_JOINTS`] index.
    H36m { index: [usize; 21] },
    /// Any other rig, through its own retargeter.
    Rig(Box<Retargeter>),
}

/// A target rig and its mapping from a source skeleton (see the module docs).
#[derive(Debug, Clone)]
pub struct RigTarget {
    joints: Vec<RigJoint>,
    /// The rig as the retargeter sees it: rest world positions, identity rest rotations, mm.
    skeleton: Skeleton,
    retarget: Retargeter,
    source: Source,
    source_skeleton: Skeleton,
    /// The source's hips (the retargeter's `Hips`) joint.
    source_hips: usize,
    /// Rest world rotation per target joint.
    rest_world: Vec<DQuat>,
    /// The target's hips joint.
    hips: usize,
    /// Target leg length over the source's (the hips path's scale, metres per metre).
    leg_ratio: f64,
    /// The source's hips rest height over its floor, and the target's (metres).
    heights: (f64, f64),
    // Scratch, sized once.
    source_world: Vec<DQuat>,
    source_position: Vec<DVec3>,
    slot_world: [Option<DQuat>; 21],
    identity_world: Vec<DQuat>,
    world: Vec<DQuat>,
    position: Vec<DVec3>,
}

/// Rest world rotations and positions (metres) of joints in parents-first order.
fn rest_world(joints: &[RigJoint]) -> (Vec<DQuat>, Vec<DVec3>) {
    let mut rot: Vec<DQuat> = Vec::with_capacity(joints.len());
    let mut pos: Vec<DVec3> = Vec::with_capacity(joints.len());
    for j in joints {
        let (r, t) = (
            j.rest_rotation.as_dquat().normalize(),
            j.rest_translation.as_dvec3(),
        );
        match j.parent {
            None => {
                rot.push(r);
                pos.push(t);
            }
            Some(p) => {
                rot.push((rot[p] * r).normalize());
                pos.push(pos[p] + rot[p] * t);
            }
        }
    }
    (rot, pos)
}

/// Checks joints: at least two, parents before children, finite unit rotations and finite
/// translations, one root (several are joined under a synthetic root by the readers).
fn check_joints(joints: &[RigJoint]) -> Result<(), RigTargetError> {
    if joints.len() < 2 {
        return Err(RigTargetError::Joints(format!(
            "{} joint(s): a rig needs at least two",
            joints.len()
        )));
    }
    if joints.len() > MAX_JOINTS {
        return Err(RigTargetError::Joints(format!(
            "{} joints, more than {MAX_JOINTS} (rig_target::MAX_JOINTS)",
            joints.len()
        )));
    }
    for (i, j) in joints.iter().enumerate() {
        match j.parent {
            None if i != 0 => {
                return Err(RigTargetError::Joints(format!(
                    "joint {i} ({:?}) has no parent: only joint 0 is the root",
                    j.name
                )))
            }
            Some(p) if p >= i => {
                return Err(RigTargetError::Joints(format!(
                    "joint {i} ({:?}) has parent {p}: parents come before their children",
                    j.name
                )))
            }
            _ => {}
        }
        let q = j.rest_rotation;
        if !(q.is_finite() && (q.length() - 1.0).abs() < 1e-3) {
            return Err(RigTargetError::Joints(format!(
                "joint {i} ({:?}): rest rotation {q} is not a unit quaternion",
                j.name
            )));
        }
        if !j.rest_translation.is_finite() || j.rest_translation.abs().max_element() > 1e4 {
            return Err(RigTargetError::Joints(format!(
                "joint {i} ({:?}): rest translation {} is not a finite length under 10 km",
                j.name, j.rest_translation
            )));
        }
    }
    Ok(())
}

impl RigTarget {
    /// A target from its joints (parents first, joint 0 the root; what an engine hands over),
    /// mapped by `map` (a JSON joint map, [`JointMap::from_json`]; `None`: the built-in maps),
    /// driven by poses on `source`.
    ///
    /// # Errors
    /// Joints that are not a rig, a rig the maps do not fit, a source the maps do not fit, a
    /// rig or source without two legs.
    pub fn from_joints(
        joints: Vec<RigJoint>,
        map: Option<&str>,
        source: &Skeleton,
    ) -> Result<RigTarget, RigTargetError> {
        check_joints(&joints)?;
        let (rest_rot, rest_pos) = rest_world(&joints);
        // The retargeter's rig: rest positions (mm), identity rest rotations.
        let skeleton = Skeleton::new(
            joints
                .iter()
                .enumerate()
                .map(|(i, j)| {
                    let offset = match j.parent {
                        None => rest_pos[i],
                        Some(p) => rest_pos[i] - rest_pos[p],
                    } / METRES_PER_MM;
                    let channels = if j.parent.is_none() {
                        vec![
                            Channel::Xposition,
                            Channel::Yposition,
                            Channel::Zposition,
                            Channel::Zrotation,
                            Channel::Xrotation,
                            Channel::Yrotation,
                        ]
                    } else {
                        vec![Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]
                    };
                    Joint::new(j.name.clone(), j.parent, offset.to_array(), channels)
                })
                .collect(),
        )?;
        let joint_map = match map {
            Some(text) => JointMap::from_json(&skeleton, text)?,
            None => JointMap::detect(&skeleton)?,
        };
        let retarget = Retargeter::new(&skeleton, joint_map)?;
        let hips = retarget.map.user[0].expect("the hips are required");
        let source_side = if *source == Skeleton::h36m() {
            let index = MAPPED_JOINTS.map(|n| source.joint_index(n).expect("an H3.6M joint"));
            Source::H36m { index }
        } else {
            Source::Rig(Box::new(Retargeter::new(
                source,
                JointMap::detect(source)?,
            )?))
        };
        let source_hips = match &source_side {
            Source::H36m { index } => index[0],
            Source::Rig(r) => r.map.user[0].expect("the hips are required"),
        };
        let legs = |s: &Skeleton| {
            find_body_parts(s)
                .map(|p| p.leg_length * METRES_PER_MM)
                .map_err(|e| RigTargetError::Legs(format!("{}: {e}", s.joint(0).name)))
        };
        // The hips' rest height above the lowest rest joint (metres), up in the model's axes.
        let height = |s: &Skeleton, hips: usize, g: DQuat| {
            let mut world: Vec<DVec3> = Vec::with_capacity(s.len());
            for joint in s.joints() {
                let p = DVec3::from_array(joint.offset) * METRES_PER_MM;
                world.push(joint.parent.map_or(p, |q| world[q] + p));
            }
            let up = |p: DVec3| (g * p).y;
            up(world[hips]) - world.iter().map(|&p| up(p)).fold(f64::INFINITY, f64::min)
        };
        let source_g = match &source_side {
            Source::H36m { .. } => DQuat::IDENTITY,
            Source::Rig(r) => r.g,
        };
        let (source_leg, source_height) = (legs(source)?, height(source, source_hips, source_g));
        let (target_leg, target_height) = (legs(&skeleton)?, height(&skeleton, hips, retarget.g));
        let n = joints.len();
        Ok(RigTarget {
            leg_ratio: target_leg / source_leg,
            heights: (source_height, target_height),
            rest_world: rest_rot,
            hips,
            skeleton,
            retarget,
            source: source_side,
            source_skeleton: source.clone(),
            source_hips,
            source_world: vec![DQuat::IDENTITY; source.len()],
            source_position: vec![DVec3::ZERO; source.len()],
            slot_world: [None; 21],
            identity_world: vec![DQuat::IDENTITY; n],
            world: vec![DQuat::IDENTITY; n],
            position: vec![DVec3::ZERO; n],
            joints,
        })
    }

    /// A target from a glTF or GLB file's skin ([`read_gltf_joints`]), driven by poses on
    /// `source`.
    ///
    /// # Errors
    /// The file cannot be read or holds no usable skin; see [`from_joints`](Self::from_joints).
    pub fn from_gltf(
        path: &Path,
        map: Option<&str>,
        source: &Skeleton,
    ) -> Result<RigTarget, RigTargetError> {
        let joints = read_gltf_joints(path)?;
        RigTarget::from_joints(joints, map, source).map_err(|e| match e {
            RigTargetError::File { .. } => e,
            other => RigTargetError::File {
                path: path.to_path_buf(),
                problem: other.to_string(),
            },
        })
    }

    /// A target from a BVH skeleton (millimetres, identity rest rotations: the BVH semantics).
    ///
    /// # Errors
    /// See [`from_joints`](Self::from_joints).
    pub fn from_skeleton(
        rig: &Skeleton,
        map: Option<&str>,
        source: &Skeleton,
    ) -> Result<RigTarget, RigTargetError> {
        let joints = rig
            .joints()
            .iter()
            .map(|j| RigJoint {
                name: j.name.clone(),
                parent: j.parent,
                rest_rotation: Quat::IDENTITY,
                rest_translation: (DVec3::from_array(j.offset) * METRES_PER_MM).as_vec3(),
            })
            .collect();
        RigTarget::from_joints(joints, map, source)
    }

    /// The rig's joints.
    pub fn joints(&self) -> &[RigJoint] {
        &self.joints
    }

    /// The hips joint (what [`RigPose::hips_translation`] moves).
    pub fn hips(&self) -> usize {
        self.hips
    }

    /// The map in use (its name says which built-in map fitted).
    pub fn map(&self) -> &JointMap {
        self.retarget.map()
    }

    /// Whether joint `j` is driven (mapped) or keeps its rest rotation.
    pub fn is_mapped(&self, j: usize) -> bool {
        self.retarget.rig_slot.get(j).is_some_and(|s| s.is_some())
    }

    /// The skeleton the source poses are on.
    pub fn source_skeleton(&self) -> &Skeleton {
        &self.source_skeleton
    }

    /// The rig as the retargeter sees it (rest world positions in millimetres, identity rest
    /// rotations): BVH output on the rig uses the joints' own rest translations instead.
    pub fn retarget_skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    /// Fills `out` with the target rig's pose for the source `pose` (see the module docs). No
    /// allocation.
    ///
    /// # Panics
    /// If `pose` is not on the source skeleton or `out` not made for this target.
    pub fn write(&mut self, pose: &Pose, out: &mut RigPose) {
        let source = &self.source_skeleton;
        assert_eq!(pose.local_rotations.len(), source.len(), "source joints");
        assert_eq!(
            out.local_rotations.len(),
            self.joints.len(),
            "target joints"
        );
        // Source world rotations and positions (metres).
        for (j, joint) in source.joints().iter().enumerate() {
            let r = pose.local_rotations[j].as_dquat().normalize();
            let offset = DVec3::from_array(joint.offset) * METRES_PER_MM;
            match joint.parent {
                None => {
                    self.source_world[j] = r;
                    self.source_position[j] = pose.root_translation.as_dvec3();
                }
                Some(p) => {
                    self.source_world[j] = self.source_world[p] * r;
                    self.source_position[j] =
                        self.source_position[p] + self.source_world[p] * offset;
                }
            }
        }
        // Model (H3.6M) world rotation per mapped slot, and the hips in the model's axes.
        let hips_model = match &self.source {
            Source::H36m { index } => {
                for (slot, &j) in self.slot_world.iter_mut().zip(index) {
                    *slot = Some(self.source_world[j]);
                }
                self.source_position[index[0]]
            }
            Source::Rig(r) => {
                let g_inv = r.g.inverse();
                for (s, slot) in self.slot_world.iter_mut().enumerate() {
                    *slot = r.map.user[s]
                        .map(|u| (r.g * self.source_world[u] * g_inv * r.q[s]).normalize());
                }
                r.g * self.source_position[self.source_hips]
            }
        };
        // Target world rotations from an identity rest, then the rig's own rest composed in.
        let t = &self.retarget;
        let g_inv = t.g.inverse();
        for (j, joint) in self.joints.iter().enumerate() {
            let parent_identity = joint
                .parent
                .map_or(DQuat::IDENTITY, |p| self.identity_world[p]);
            let parent_world = joint.parent.map_or(DQuat::IDENTITY, |p| self.world[p]);
            let mapped = t.rig_slot[j].and_then(|s| self.slot_world[s].map(|w| (s, w)));
            match mapped {
                Some((s, w)) => {
                    self.identity_world[j] = (g_inv * w * t.q[s].inverse() * t.g).normalize();
                    self.world[j] = (self.identity_world[j] * self.rest_world[j]).normalize();
                    out.local_rotations[j] = (parent_world.inverse() * self.world[j])
                        .normalize()
                        .as_quat();
                }
                None => {
                    self.identity_world[j] = parent_identity;
                    let local = joint.rest_rotation.as_dquat().normalize();
                    self.world[j] = (parent_world * local).normalize();
                    out.local_rotations[j] = joint.rest_rotation;
                }
            }
            let offset = joint.rest_translation.as_dvec3();
            self.position[j] = match joint.parent {
                None => offset,
                Some(p) => self.position[p] + self.world[p] * offset,
            };
        }
        // The hips: the source's path (model axes, +y up, the floor at y = 0) scaled by the leg
        // ratio, its height above the source's standing height onto the rig's, in the rig's axes.
        let (source_height, target_height) = self.heights;
        let r = self.leg_ratio;
        let target = g_inv
            * DVec3::new(
                hips_model.x * r,
                target_height + (hips_model.y - source_height) * r,
                hips_model.z * r,
            );
        let hips_joint = &self.joints[self.hips];
        match hips_joint.parent {
            None => {
                out.hips_translation = target.as_vec3();
                out.root_translation = out.hips_translation;
            }
            Some(p) => {
                out.hips_translation =
                    (self.world[p].inverse() * (target - self.position[p])).as_vec3();
                out.root_translation = (self.joints[0].rest_translation.as_dvec3() + target
                    - self.position[self.hips])
                    .as_vec3();
            }
        }
    }

    /// The rig as a BVH skeleton (millimetres): each joint's rest translation as its OFFSET, three
    /// rotation channels per joint (`Z X Y`), the root also three positions. A pose written on it
    /// ([`bvh_pose`](Self::bvh_pose)) with the local rotations of a [`RigPose`] is that pose.
    pub fn bvh_skeleton(&self) -> Skeleton {
        Skeleton::new(
            self.joints
                .iter()
                .map(|j| {
                    let mut channels = Vec::with_capacity(6);
                    if j.parent.is_none() {
                        channels.extend([
                            Channel::Xposition,
                            Channel::Yposition,
                            Channel::Zposition,
                        ]);
                    }
                    channels.extend([Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]);
                    Joint::new(
                        j.name.clone(),
                        j.parent,
                        (j.rest_translation.as_dvec3() / METRES_PER_MM).to_array(),
                        channels,
                    )
                })
                .collect(),
        )
        .expect("checked joints make a skeleton")
    }

    /// `out` as a [`Pose`] on [`bvh_skeleton`](Self::bvh_skeleton) (the root moved so the hips are
    /// where `out` puts them), into `pose` (no allocation when it already has the rig's joints).
    pub fn bvh_pose(&self, out: &RigPose, pose: &mut Pose) {
        pose.local_rotations.clone_from(&out.local_rotations);
        pose.root_translation = out.root_translation;
    }

    /// The BVH of `poses` (on the source skeleton, at `fps`) on this rig, in metres
    /// ([`bvh_skeleton`](Self::bvh_skeleton) scaled to metres): what Blender imports as the
    /// character's own skeleton.
    ///
    /// # Errors
    /// A pose the BVH writer refuses (a non-finite value).
    pub fn to_bvh(
        &mut self,
        poses: &[Pose],
        fps: f64,
    ) -> Result<crate::formats::bvh::Bvh, crate::formats::expmap_bvh::ConvertError> {
        let skeleton = self.bvh_skeleton();
        let mut out = RigPose::for_target(self);
        let mut rig_poses = Vec::with_capacity(poses.len());
        for pose in poses {
            self.write(pose, &mut out);
            let mut p = Pose::rest(self.joints.len());
            self.bvh_pose(&out, &mut p);
            rig_poses.push(p);
        }
        let bvh = crate::formats::pose_bvh::poses_to_bvh(&skeleton, &rig_poses, fps)?;
        crate::seed::rescale_bvh(&bvh, METRES_PER_MM).map_err(|problem| {
            crate::formats::expmap_bvh::ConvertError::Channels {
                joint: skeleton.joint(0).name.clone(),
                problem,
            }
        })
    }
}
