//! The batched stepping: characters grouped by (model, playback rate), each group one
//! motion-core [`Crowd`] (one `BatchGenerator` stepped once per model frame for all its members,
//! every member with its own pose stream resampled to the game's frame rate, any and variable),
//! each member an entity. Members join and leave as characters spawn and despawn (the crowd
//! re-seeds the others from what they generated, so their motion goes on); between membership
//! changes a tick allocates nothing of its own (see `motion_core::model::Crowd`).
use std::path::Path;
use std::sync::Arc;

use bevy::prelude::*;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::GroundingConfig;
use motion_core::model::{
    CharacterError, Crowd, GenerateError, MemberId, MotionModel, MotionSource,
};
use motion_core::pose::{root_motion_between, Pose, METRES_PER_MM};
use motion_core::seed::seed_from_bvh;
use motion_core::skeleton::Skeleton;
use motion_core::steering::Goal;
use motion_core::takes::seed_poses_on_rig;

use crate::asset::MotionWeights;
use crate::character::{MotionCharacter, MotionFailed, MotionModelSource, MotionPose, MotionRig};
use crate::skin::{collect_rig, Hierarchy, MotionSkinned, SkinDriver};

/// Marks a joint entity the plugin spawned: `index` in the model skeleton's order.
#[derive(Component, Debug, Clone, Copy)]
pub struct MotionJoint {
    /// The joint's index in the skeleton.
    pub index: usize,
}

/// The built-in model, parsed once.
#[derive(Resource)]
pub(crate) struct BuiltinModel(pub(crate) Result<Arc<MotionModel>, String>);

impl BuiltinModel {
    pub(crate) fn load() -> BuiltinModel {
        BuiltinModel(match motion_core::model::builtin::game_model() {
            Some(Ok(model)) => Ok(Arc::new(model)),
            Some(Err(e)) => Err(e.to_string()),
            None => Err("this build has no built-in weights".into()),
        })
    }
}

/// Characters of one model (or database) at one playback rate: one [`Crowd`] (motion-core's
/// batch of characters), each member an entity.
struct Group {
    source: MotionSource,
    rate: f32,
    crowd: Crowd,
    /// Each member's entity, id and the action it was last given.
    members: Vec<(Entity, MemberId, String)>,
}

/// Every group of characters.
#[derive(Resource, Default)]
pub(crate) struct Crowds {
    groups: Vec<Group>,
}

impl Crowds {
    /// Drops `entity`'s row (and a group left empty).
    fn leave(&mut self, entity: Entity) {
        for group in &mut self.groups {
            group.members.retain(|&(e, id, _)| {
                let leaving = e == entity;
                if leaving {
                    group.crowd.remove(id);
                }
                !leaving
            });
        }
        self.groups.retain(|g| !g.members.is_empty());
    }

    /// The group of `source` at `rate`, made when there is none.
    fn group(&mut self, source: MotionSource, rate: f32) -> Result<&mut Group, String> {
        let found = self
            .groups
            .iter()
            .position(|g| same_source(&g.source, &source) && g.rate == rate);
        let i = match found {
            Some(i) => i,
            None => {
                let crowd = Crowd::new(source.clone()).map_err(|e| e.to_string())?;
                self.groups.push(Group {
                    source,
                    rate,
                    crowd,
                    members: Vec::new(),
                });
                self.groups.len() - 1
            }
        };
        Ok(&mut self.groups[i])
    }
}

/// Whether two sources are the same loaded file.
fn same_source(a: &MotionSource, b: &MotionSource) -> bool {
    match (a, b) {
        (MotionSource::Model(a), MotionSource::Model(b)) => Arc::ptr_eq(a, b),
        (MotionSource::Database(a), MotionSource::Database(b)) => Arc::ptr_eq(a, b),
        _ => false,
    }
}

/// Joins a new character to its model's (or database's) group; its first pose, or why it cannot
/// start.
fn join(
    crowds: &mut Crowds,
    entity: Entity,
    source: MotionSource,
    character: &MotionCharacter,
) -> Result<(Arc<Skeleton>, Pose), String> {
    if !(character.playback_rate.is_finite() && character.playback_rate >= 0.0) {
        return Err(format!(
            "playback rate {} (finite, >= 0)",
            character.playback_rate
        ));
    }
    let grounding = if character.grounding {
        GroundingConfig::default()
    } else {
        GroundingConfig::off()
    };
    let id = match source.clone() {
        MotionSource::Database(db) => {
            // A database plays on its own rig: the seed goes onto it (retargeted when needed).
            let seed = seed_poses_on_rig(
                (*character.seed.bvh).clone(),
                db.skeleton(),
                db.mm_per_unit(),
                db.fps(),
                None,
            )
            .map_err(|e| format!("{}: {e}", character.seed.label))?;
            let group = crowds.group(source.clone(), character.playback_rate)?;
            group
                .crowd
                .add_poses(&seed, grounding)
                .map_err(|e| format!("{}: {e}", character.seed.label))?
        }
        MotionSource::Model(model) => {
            let seed = seed_from_bvh(
                (*character.seed.bvh).clone(),
                Path::new(&*character.seed.label),
                ExpMapTarget::H36m,
                model.config().fps,
                None,
            )
            .map_err(|e| e.to_string())?;
            let group = crowds.group(source.clone(), character.playback_rate)?;
            group
                .crowd
                .add(
                    seed.frames.view(),
                    Some(&character.action),
                    character.rng_seed,
                    grounding,
                )
                .map_err(|e| match e {
                    // Errors of the seed name its file.
                    CharacterError::Generate(
                        GenerateError::TooFewSeedFrames { .. }
                        | GenerateError::WrongWidth { .. }
                        | GenerateError::NonFiniteSeed { .. },
                    ) => format!("{}: {e}", character.seed.label),
                    e => e.to_string(),
                })?
        }
    };
    let group = crowds.group(source, character.playback_rate)?;
    group.members.push((entity, id, character.action.clone()));
    let pose = group.crowd.pose(id).expect("just added").clone();
    Ok((group.crowd.skeleton().clone(), pose))
}

/// Bevy's glam type from motion-core's (they may be different glam versions).
fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

fn quat(q: [f32; 4]) -> Quat {
    Quat::from_array(q)
}

/// Starts characters that have no rig yet: spawns their joints, seeds their rows.
#[allow(clippy::type_complexity)]
pub(crate) fn start_characters(
    mut commands: Commands,
    mut crowds: ResMut<Crowds>,
    builtin: Res<BuiltinModel>,
    weights: Res<Assets<MotionWeights>>,
    asset_server: Res<AssetServer>,
    new: Query<
        (Entity, &MotionCharacter, &Transform, Option<&MotionSkinned>),
        (Without<MotionRig>, Without<MotionFailed>),
    >,
    hierarchy: Hierarchy,
) {
    for (entity, character, transform, skinned) in &new {
        // A skinned character waits for its hierarchy (a glTF scene spawns once loaded).
        let rig = match skinned {
            Some(_) => match collect_rig(entity, &hierarchy) {
                Some(rig) => Some(rig),
                None => continue,
            },
            None => None,
        };
        let model = match &character.model {
            MotionModelSource::Builtin => builtin.0.clone().map(MotionSource::Model),
            MotionModelSource::Asset(handle) => match weights.get(handle) {
                Some(w) => Ok(w.source.clone()),
                None => match asset_server.load_state(handle) {
                    bevy::asset::LoadState::Failed(e) => Err(e.to_string()),
                    _ => continue, // still loading
                },
            },
        };
        let (skeleton, pose) = match model.and_then(|m| join(&mut crowds, entity, m, character)) {
            Ok(ok) => ok,
            Err(e) => {
                commands.entity(entity).insert(MotionFailed(e));
                continue;
            }
        };
        let floor = pose.floor_offset(&skeleton);
        if let (Some((rig_joints, entities, scales)), Some(skinned)) = (rig, skinned) {
            let map = skinned.joint_map.as_deref();
            match SkinDriver::new(rig_joints, entities, &scales, map, &skeleton) {
                Ok(driver) => {
                    let names = driver
                        .target()
                        .joints()
                        .iter()
                        .map(|j| j.name.clone())
                        .collect();
                    commands.entity(entity).insert((
                        MotionRig {
                            joints: driver.entities().to_vec(),
                            names,
                            origin: *transform,
                            floor,
                        },
                        MotionPose(pose),
                        driver,
                    ));
                }
                Err(e) => {
                    crowds.leave(entity);
                    commands.entity(entity).insert(MotionFailed(e));
                }
            }
            continue;
        }
        let mut joints = Vec::with_capacity(skeleton.len());
        for (j, joint) in skeleton.joints().iter().enumerate() {
            let parent = joint.parent.map_or(entity, |p| joints[p]);
            let offset = joint.offset.map(|v| (v * METRES_PER_MM) as f32);
            let id = commands
                .spawn((
                    Name::new(joint.name.clone()),
                    MotionJoint { index: j },
                    Transform::from_translation(Vec3::from_array(offset)),
                    ChildOf(parent),
                ))
                .id();
            joints.push(id);
        }
        commands.entity(entity).insert((
            MotionRig {
                joints,
                names: skeleton.joints().iter().map(|j| j.name.clone()).collect(),
                origin: *transform,
                floor,
            },
            MotionPose(pose),
        ));
    }
}

/// Drops the rows of despawned characters (or ones whose [`MotionCharacter`] was removed).
pub(crate) fn remove_characters(
    mut removed: RemovedComponents<MotionCharacter>,
    mut crowds: ResMut<Crowds>,
) {
    for entity in removed.read() {
        crowds.leave(entity);
    }
}

/// One tick: action changes, the batched steps, the poses written into the rigs' transforms.
#[allow(clippy::type_complexity)]
pub(crate) fn step_characters(
    time: Res<Time>,
    mut commands: Commands,
    mut crowds: ResMut<Crowds>,
    mut characters: Query<
        (
            &MotionCharacter,
            &MotionRig,
            &mut Transform,
            &mut MotionPose,
            Option<&mut SkinDriver>,
        ),
        Without<MotionJoint>,
    >,
    mut joints: Query<&mut Transform, Without<MotionCharacter>>,
) {
    let mut failed: Vec<(Entity, String)> = Vec::new();
    crowds.groups.retain_mut(|group| {
        // Goals and action changes from game code.
        for (entity, id, action) in &mut group.members {
            let Ok((character, rig, ..)) = characters.get(*entity) else {
                continue;
            };
            group
                .crowd
                .set_goal(*id, character.goal.map(|g| motion_goal(g, rig.origin)));
            if character.action != *action {
                if let Err(e) = group.crowd.set_action(*id, &character.action) {
                    failed.push((*entity, format!("{e}; carrying on with {action:?}")));
                }
                action.clone_from(&character.action);
            }
        }
        let dt = time.delta_secs_f64() * f64::from(group.rate);
        if let Err(e) = group.crowd.advance(dt) {
            failed.extend(group.members.iter().map(|m| (m.0, e.to_string())));
            return false;
        }
        for &(entity, id, _) in &group.members {
            let Ok((_, rig, mut root, mut pose, skin)) = characters.get_mut(entity) else {
                continue;
            };
            let Some(now) = group.crowd.pose(id) else {
                continue;
            };
            // The root motion over the whole tick (a long one spans several model frames).
            let motion = root_motion_between(
                now.root_translation.as_dvec3(),
                now.local_rotations[0].as_dquat(),
                Some(pose.0.root_motion),
            );
            *root = rig.origin.mul_transform(
                Transform::from_translation(vec3(motion.ground_translation.to_array()))
                    .with_rotation(quat(motion.ground_yaw.to_array())),
            );
            if let Some(mut skin) = skin {
                skin.pose(
                    now,
                    motion.pelvis_offset,
                    motion.pelvis_rotation,
                    rig.floor,
                    &mut joints,
                );
            } else {
                for (j, &joint) in rig.joints.iter().enumerate() {
                    let Ok(mut t) = joints.get_mut(joint) else {
                        continue;
                    };
                    if j == 0 {
                        t.translation = vec3(motion.pelvis_offset.to_array()) + Vec3::Y * rig.floor;
                        t.rotation = quat(motion.pelvis_rotation.to_array());
                    } else {
                        t.rotation = quat(now.local_rotations[j].to_array());
                    }
                }
            }
            pose.0.clone_from(now);
            pose.0.root_motion = motion;
        }
        !group.members.is_empty()
    });
    for (entity, e) in failed {
        commands.entity(entity).insert(MotionFailed(e));
    }
}

/// A world-axes goal in the character's motion frame (its spawn transform's axes, where the
/// plugin integrates its root motion).
fn motion_goal(goal: crate::MotionGoal, origin: Transform) -> Goal {
    let inverse = origin.rotation.inverse();
    let v = inverse * Vec3::new(goal.velocity.x, 0.0, goal.velocity.y);
    let f = inverse * Vec3::new(goal.facing.sin(), 0.0, goal.facing.cos());
    Goal {
        velocity: motion_core::steering::Vec2::new(v.x, v.z),
        facing: f.x.atan2(f.z),
    }
}
