//! Skinned characters: a [`MotionCharacter`](crate::MotionCharacter) on a spawned glTF scene (or
//! any entity with a joint hierarchy below it) drives that hierarchy's own joints through a
//! motion-core [`RigTarget`] instead of spawning joints of its own.
//!
//! - **Finding the joints.** Once the entity has descendants (a glTF scene spawns its whole
//!   hierarchy at once), every descendant with a [`Transform`] becomes a rig joint, parents
//!   first, named by its [`Name`] (bevy_gltf names each node entity with the glTF node name;
//!   an unnamed entity is `entity{index}`); the character entity itself is the rig's root, its
//!   local space the rig's world. The built-in joint maps (or [`MotionSkinned::joint_map`])
//!   map them; meshes, fingers and extra bones are unmapped and keep their rest rotation.
//! - **Each tick**, the character's pose (its pelvis relative to the ground frame the
//!   character entity carries, raised onto the floor) goes through [`RigTarget::write`] into a
//!   [`RigPose`] made once, and every joint's `Transform.rotation` (and the hips'
//!   `translation`, divided by the uniform scale above it) is written before transforms
//!   propagate. Nothing is allocated per tick.
use bevy::prelude::*;
use motion_core::pose::Pose;
use motion_core::rig_target::{RigJoint, RigPose, RigTarget};
use motion_core::skeleton::Skeleton;

/// Put beside a [`MotionCharacter`](crate::MotionCharacter) on the root of a spawned glTF scene
/// (a `WorldAssetRoot`) or of any joint hierarchy: the character drives those joints (module
/// docs). The character starts once the hierarchy is there.
///
/// With the `gltf` feature (Bevy's glTF loader; the `skinned` example runs this):
/// ```ignore
/// # use bevy::prelude::*;
/// # use bevy::world_serialization::WorldAssetRoot;
/// # use motion_bevy::{MotionCharacter, MotionSkinned};
/// fn spawn(mut commands: Commands, assets: Res<AssetServer>) {
///     commands.spawn((
///         WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset("mannequin.glb"))),
///         MotionCharacter::new("walking", 1),
///         MotionSkinned::default(),
///     ));
/// }
/// ```
#[derive(Component, Debug, Clone, Default)]
pub struct MotionSkinned {
    /// A JSON joint map (`motion_core::retarget::JointMap::from_json`) for a rig the built-in
    /// maps (Unreal, Mixamo, CMU, ...) do not fit; `None`: the built-in maps.
    pub joint_map: Option<String>,
}

/// A started skinned character's mapping and buffers (sized once).
#[derive(Component)]
pub(crate) struct SkinDriver {
    target: RigTarget,
    out: RigPose,
    /// The source pose handed to the target: the character's pose with its pelvis in the
    /// ground frame, raised onto the floor.
    scratch: Pose,
    /// The joint entities in the rig's order (index 0: the character itself, never written).
    entities: Vec<Entity>,
    /// The uniform scale above the hips (the hips' translation is divided by it).
    hips_parent_scale: f32,
}

/// What [`collect_rig`] reads of the world: the hierarchy, and (feature `gltf`) the skins.
#[derive(bevy::ecs::system::SystemParam)]
pub(crate) struct Hierarchy<'w, 's> {
    children: Query<'w, 's, &'static Children>,
    parents: Query<'w, 's, &'static ChildOf>,
    nodes: Query<'w, 's, (&'static Transform, Option<&'static Name>)>,
    #[cfg(feature = "gltf")]
    skins: Query<'w, 's, &'static bevy::mesh::skinning::SkinnedMesh>,
}

impl Hierarchy<'_, '_> {
    /// The joints of the largest skin below `root` (feature `gltf`; `None` without one).
    fn skin_joints(&self, root: Entity) -> Option<Vec<Entity>> {
        #[cfg(feature = "gltf")]
        {
            self.children
                .iter_descendants(root)
                .filter_map(|e| self.skins.get(e).ok())
                .max_by_key(|s| s.joints.len())
                .map(|s| s.joints.clone())
        }
        #[cfg(not(feature = "gltf"))]
        {
            let _ = root;
            None
        }
    }
}

/// The hierarchy below `root` as rig joints (module docs), with its entities and each one's
/// uniform scale; `None` while it has no descendants yet. With a skin below it (a glTF
/// character), only the skin's joints and the nodes above them are joints: meshes are not.
pub(crate) fn collect_rig(
    root: Entity,
    world: &Hierarchy<'_, '_>,
) -> Option<(Vec<RigJoint>, Vec<Entity>, Vec<f32>)> {
    let first = world.children.get(root).ok()?;
    if first.is_empty() {
        return None;
    }
    // With a skin: its joints and every node above one.
    let keep: Option<std::collections::HashSet<Entity>> = world.skin_joints(root).map(|joints| {
        let mut keep = std::collections::HashSet::new();
        for joint in joints {
            let mut at = Some(joint);
            while let Some(e) = at {
                if e == root || !keep.insert(e) {
                    break;
                }
                at = world.parents.get(e).ok().map(|c| c.parent());
            }
        }
        keep
    });
    // Breadth-first: parents before children. Each entry: entity, parent joint, world
    // transform relative to the character (scale kept, for the uniform scale).
    let mut entities = vec![root];
    let mut parents: Vec<Option<usize>> = vec![None];
    let mut transforms = vec![Transform::IDENTITY];
    let mut i = 0;
    while i < entities.len() {
        if let Ok(kids) = world.children.get(entities[i]) {
            for &kid in kids {
                let Ok((t, _)) = world.nodes.get(kid) else {
                    continue;
                };
                if keep.as_ref().is_some_and(|k| !k.contains(&kid)) {
                    continue;
                }
                entities.push(kid);
                parents.push(Some(i));
                transforms.push(transforms[i].mul_transform(*t));
            }
        }
        i += 1;
    }
    let joints = (0..entities.len())
        .map(|j| {
            let name = match (j, world.nodes.get(entities[j])) {
                (0, _) => "__character".to_string(),
                (_, Ok((_, Some(n)))) => n.as_str().to_string(),
                _ => format!("entity{}", entities[j].index()),
            };
            let (rest_rotation, rest_translation) = match parents[j] {
                None => (Quat::IDENTITY, Vec3::ZERO),
                Some(p) => {
                    let inv = transforms[p].rotation.inverse();
                    (
                        (inv * transforms[j].rotation).normalize(),
                        inv * (transforms[j].translation - transforms[p].translation),
                    )
                }
            };
            RigJoint {
                name,
                parent: parents[j],
                rest_rotation: motion_quat(rest_rotation),
                rest_translation: motion_vec(rest_translation),
            }
        })
        .collect();
    let scales = transforms
        .iter()
        .map(|w| w.scale.dot(Vec3::ONE) / 3.0)
        .collect();
    Some((joints, entities, scales))
}

/// motion-core's glam types from Bevy's (they may be different glam versions).
fn motion_quat(q: Quat) -> glam::Quat {
    glam::Quat::from_array(q.to_array())
}

fn motion_vec(v: Vec3) -> glam::Vec3 {
    glam::Vec3::from_array(v.to_array())
}

impl SkinDriver {
    /// The driver of the hierarchy `joints` / `entities` (from [`collect_rig`]) for poses on
    /// `source`.
    pub(crate) fn new(
        joints: Vec<RigJoint>,
        entities: Vec<Entity>,
        scales: &[f32],
        map: Option<&str>,
        source: &Skeleton,
    ) -> Result<SkinDriver, String> {
        let target = RigTarget::from_joints(joints, map, source).map_err(|e| e.to_string())?;
        let out = RigPose::for_target(&target);
        let hips_parent = target.joints()[target.hips()].parent.unwrap_or(0);
        Ok(SkinDriver {
            hips_parent_scale: scales[hips_parent].max(1e-6),
            scratch: Pose::rest(source.len()),
            out,
            target,
            entities,
        })
    }

    /// The rig target (its joints and map).
    pub(crate) fn target(&self) -> &RigTarget {
        &self.target
    }

    /// The joint entities, rig order.
    pub(crate) fn entities(&self) -> &[Entity] {
        &self.entities
    }

    /// Writes `pose` (whose pelvis is `pelvis_offset` / `pelvis_rotation` in the ground frame
    /// the character entity carries, `floor` metres under the floor) into the joints.
    pub(crate) fn pose(
        &mut self,
        pose: &Pose,
        pelvis_offset: glam::Vec3,
        pelvis_rotation: glam::Quat,
        floor: f32,
        joints: &mut Query<&mut Transform, Without<crate::MotionCharacter>>,
    ) {
        self.scratch
            .local_rotations
            .clone_from(&pose.local_rotations);
        self.scratch.local_rotations[0] = pelvis_rotation;
        self.scratch.root_translation = pelvis_offset + glam::Vec3::Y * floor;
        self.target.write(&self.scratch, &mut self.out);
        let hips = self.target.hips();
        for (j, &entity) in self.entities.iter().enumerate().skip(1) {
            let Ok(mut t) = joints.get_mut(entity) else {
                continue;
            };
            t.rotation = Quat::from_array(self.out.local_rotations[j].to_array());
            if j == hips {
                t.translation =
                    Vec3::from_array(self.out.hips_translation.to_array()) / self.hips_parent_scale;
            }
        }
    }
}
