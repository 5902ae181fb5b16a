//! The batched stepping: characters grouped by (model, playback rate), each group one
//! [`BatchGenerator`] stepped once per model frame for all its rows, every row with its own
//! pose decoder and resampler (the game's frame rate, any and variable).
//!
//! A group is (re)started when characters join or leave it: every row is re-seeded from its
//! last `seed_frames` frames (its own seed at first, its generated frames later), so the motion
//! goes on from where it was; each row draws noise from its character's `rng_seed`. Between
//! membership changes a tick allocates nothing of its own (a group of 16 or more characters
//! steps in shards over the rayon pool, which allocates one small job record per extra shard; see
//! `motion_core::model::BatchGenerator`).
use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;

use bevy::prelude::*;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::GroundingConfig;
use motion_core::model::{BatchGenerator, MotionModel, Noise, PoseStream};
use motion_core::pose::{root_motion_between, METRES_PER_MM};
use motion_core::seed::seed_from_bvh;
use motion_core::skeleton::{Skeleton, H36M_SOURCE_FPS};
use motion_core::steering::Goal;
use ndarray::{s, Array2, Array3, ArrayView2};

use crate::asset::MotionWeights;
use crate::character::{MotionCharacter, MotionFailed, MotionModelSource, MotionPose, MotionRig};

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

/// One character's row of a group.
struct Member {
    entity: Entity,
    action: String,
    rng_seed: u64,
    /// Decoding, steering, grounding and resampling of the generated frames (motion-core's one
    /// chain, as `Character` uses it).
    stream: PoseStream,
    /// Generated frames not yet decoded (`frame_dims` floats each).
    pending: VecDeque<f32>,
    /// The last `seed_frames` frames, a ring (`next` is the oldest): what a restart re-seeds from.
    history: Array2<f32>,
    next: usize,
    scratch: Vec<f32>,
}

impl Member {
    fn remember(&mut self, frame: &[f32]) {
        self.history
            .row_mut(self.next)
            .as_slice_mut()
            .expect("contiguous")
            .copy_from_slice(frame);
        self.next = (self.next + 1) % self.history.nrows();
    }

    /// Decodes one pending frame into the resampler.
    fn consume(&mut self) -> Result<(), String> {
        let dims = self.scratch.len();
        for (dst, v) in self.scratch.iter_mut().zip(self.pending.drain(..dims)) {
            *dst = v;
        }
        self.stream.push(&self.scratch).map_err(|e| e.to_string())
    }

    /// Feeds the resampler from `pending` until it can advance by `dt` or `pending` runs out;
    /// whether it still needs a frame.
    fn feed(&mut self, dt: f64) -> Result<bool, String> {
        while self.stream.needs(dt) {
            if self.pending.is_empty() {
                return Ok(true);
            }
            self.consume()?;
        }
        Ok(false)
    }
}

/// Characters of one model at one playback rate, one batch.
struct Group {
    model: Arc<MotionModel>,
    rate: f32,
    members: Vec<Member>,
    batch: Option<BatchGenerator>,
    dirty: bool,
}

impl Group {
    fn restart(&mut self) -> Result<(), String> {
        let cfg = self.model.config();
        let (rows, len, dims) = (self.members.len(), cfg.seed_frames, cfg.frame_dims);
        let mut seeds = Array3::<f32>::zeros((rows, len, dims));
        for (i, m) in self.members.iter().enumerate() {
            let oldest = m.next;
            let mut out = seeds.slice_mut(s![i, .., ..]);
            out.slice_mut(s![..len - oldest, ..])
                .assign(&m.history.slice(s![oldest.., ..]));
            out.slice_mut(s![len - oldest.., ..])
                .assign(&m.history.slice(s![..oldest, ..]));
        }
        let actions: Vec<&str> = if cfg.actions.is_empty() {
            Vec::new()
        } else {
            self.members.iter().map(|m| m.action.as_str()).collect()
        };
        let noise: Vec<Noise<'_>> = self
            .members
            .iter()
            .map(|m| Noise::Seed(m.rng_seed))
            .collect();
        let mut batch = BatchGenerator::new(Arc::clone(&self.model), rows);
        batch
            .start(seeds.view(), &actions, &noise)
            .map_err(|e| e.to_string())?;
        self.batch = Some(batch);
        self.dirty = false;
        Ok(())
    }

    /// Moves every row's clock by `dt` (at most one model frame), stepping the batch as often as
    /// the row that needs most frames asks.
    fn tick(&mut self, dt: f64) -> Result<(), String> {
        let batch = self.batch.as_mut().ok_or("the group was not started")?;
        loop {
            let mut starving = false;
            for m in &mut self.members {
                starving |= m.feed(dt)?;
            }
            if !starving {
                break;
            }
            let frames = batch.step().map_err(|e| e.to_string())?;
            for (m, frame) in self.members.iter_mut().zip(frames.rows()) {
                let frame = frame.to_slice().expect("contiguous rows");
                m.pending.extend(frame);
                m.remember(frame);
            }
        }
        for m in &mut self.members {
            m.stream.advance(dt).map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

/// Every group of characters.
#[derive(Resource, Default)]
pub(crate) struct Crowds {
    groups: Vec<Group>,
}

impl Crowds {
    fn join(&mut self, model: Arc<MotionModel>, rate: f32, member: Member) {
        let group = match self
            .groups
            .iter_mut()
            .position(|g| Arc::ptr_eq(&g.model, &model) && g.rate == rate)
        {
            Some(i) => &mut self.groups[i],
            None => {
                self.groups.push(Group {
                    model,
                    rate,
                    members: Vec::new(),
                    batch: None,
                    dirty: true,
                });
                self.groups.last_mut().expect("just pushed")
            }
        };
        group.members.push(member);
        group.dirty = true;
    }
}

/// The row of a new character and its first pose, or why it cannot start.
fn new_member(
    entity: Entity,
    model: &MotionModel,
    character: &MotionCharacter,
) -> Result<Member, String> {
    let cfg = model.config();
    if cfg.skeleton != "h36m-32" {
        return Err(format!(
            "the model's skeleton {:?} has no built-in pose layout (h36m-32 has)",
            cfg.skeleton
        ));
    }
    if !cfg.actions.is_empty() && !cfg.actions.contains(&character.action) {
        return Err(format!(
            "unknown action {:?}; the model knows {}",
            character.action,
            cfg.actions.join(", ")
        ));
    }
    if !(character.playback_rate.is_finite() && character.playback_rate >= 0.0) {
        return Err(format!(
            "playback rate {} (finite, >= 0)",
            character.playback_rate
        ));
    }
    let seed = seed_from_bvh(
        (*character.seed.bvh).clone(),
        Path::new(&*character.seed.label),
        ExpMapTarget::H36m,
        cfg.fps,
        None,
    )
    .map_err(|e| e.to_string())?;
    let needed = cfg.seed_frames;
    let have = seed.frames.nrows();
    if have < needed {
        return Err(format!(
            "{}: {have} frames at the model's {} Hz, it needs {needed}",
            character.seed.label, cfg.fps
        ));
    }
    let window: ArrayView2<'_, f64> = seed.frames.slice(s![have - needed.., ..]);
    let skeleton = Arc::new(Skeleton::h36m());
    let step = ((H36M_SOURCE_FPS / cfg.fps).round() as usize).max(1);
    let grounding = if character.grounding {
        GroundingConfig::default()
    } else {
        GroundingConfig::off()
    };
    let mut stream =
        PoseStream::new(skeleton, cfg.fps, step, grounding).map_err(|e| e.to_string())?;
    stream
        .start(window, Some(&character.action))
        .map_err(|e| e.to_string())?;
    let dims = cfg.frame_dims;
    Ok(Member {
        entity,
        action: character.action.clone(),
        rng_seed: character.rng_seed,
        stream,
        pending: VecDeque::with_capacity(8 * dims),
        history: window.mapv(|v| v as f32),
        next: 0,
        scratch: vec![0.0; dims],
    })
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
    new: Query<(Entity, &MotionCharacter, &Transform), (Without<MotionRig>, Without<MotionFailed>)>,
) {
    for (entity, character, transform) in &new {
        let model = match &character.model {
            MotionModelSource::Builtin => builtin.0.clone(),
            MotionModelSource::Asset(handle) => match weights.get(handle) {
                Some(w) => Ok(Arc::clone(&w.model)),
                None => match asset_server.load_state(handle) {
                    bevy::asset::LoadState::Failed(e) => Err(e.to_string()),
                    _ => continue, // still loading
                },
            },
        };
        let started = model
            .and_then(|model| new_member(entity, &model, character).map(|member| (model, member)));
        let (model, member) = match started {
            Ok(ok) => ok,
            Err(e) => {
                commands.entity(entity).insert(MotionFailed(e));
                continue;
            }
        };
        let skeleton = member.stream.skeleton().clone();
        let pose = member.stream.current().clone();
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
                floor: pose.floor_offset(&skeleton),
            },
            MotionPose(pose),
        ));
        crowds.join(model, character.playback_rate, member);
    }
}

/// Drops the rows of despawned characters (or ones whose [`MotionCharacter`] was removed).
pub(crate) fn remove_characters(
    mut removed: RemovedComponents<MotionCharacter>,
    mut crowds: ResMut<Crowds>,
) {
    for entity in removed.read() {
        for group in &mut crowds.groups {
            let before = group.members.len();
            group.members.retain(|m| m.entity != entity);
            group.dirty |= group.members.len() != before;
        }
    }
    crowds.groups.retain(|g| !g.members.is_empty());
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
        ),
        Without<MotionJoint>,
    >,
    mut joints: Query<&mut Transform, With<MotionJoint>>,
) {
    let mut failed: Vec<(Entity, String)> = Vec::new();
    crowds.groups.retain_mut(|group| {
        if group.dirty {
            if let Err(e) = group.restart() {
                failed.extend(group.members.iter().map(|m| (m.entity, e.clone())));
                return false;
            }
        }
        // Action changes from game code.
        let batch = group.batch.as_mut().expect("started above");
        for (row, m) in group.members.iter_mut().enumerate() {
            let Ok((character, rig, ..)) = characters.get(m.entity) else {
                continue;
            };
            m.stream
                .set_goal(character.goal.map(|g| motion_goal(g, rig.origin)));
            if character.action != m.action {
                if let Err(e) = batch.set_action(row, &character.action, 0) {
                    failed.push((m.entity, format!("{e}; carrying on with {:?}", m.action)));
                }
                m.action.clone_from(&character.action);
                m.stream.set_action(Some(&character.action));
            }
        }
        // The clock, walked through a model frame at a time (a long frame of the game's).
        let frame = 1.0 / group.model.config().fps;
        let mut left = time.delta_secs_f64() * f64::from(group.rate);
        let mut substeps = 0;
        loop {
            substeps += 1;
            let dt = left.min(frame);
            left -= dt;
            if let Err(e) = group.tick(dt) {
                failed.extend(group.members.iter().map(|m| (m.entity, e.clone())));
                return false;
            }
            if left <= 0.0 {
                break;
            }
        }
        for m in &mut group.members {
            let Ok((_, rig, mut root, mut pose)) = characters.get_mut(m.entity) else {
                continue;
            };
            let now = m.stream.current();
            let mut motion = now.root_motion;
            if substeps > 1 {
                // The deltas over the whole tick, not its last model frame.
                motion = root_motion_between(
                    now.root_translation.as_dvec3(),
                    now.local_rotations[0].as_dquat(),
                    Some(pose.0.root_motion),
                );
            }
            *root = rig.origin.mul_transform(
                Transform::from_translation(vec3(motion.ground_translation.to_array()))
                    .with_rotation(quat(motion.ground_yaw.to_array())),
            );
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
            pose.0.clone_from(now);
            pose.0.root_motion = motion;
        }
        true
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
