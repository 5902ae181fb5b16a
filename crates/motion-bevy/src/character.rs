//! The components a game puts on (and reads from) a character.
use std::path::Path;
use std::sync::Arc;

use bevy::prelude::*;
use motion_core::formats::bvh::{parse_bvh, read_bvh, Bvh};
use motion_core::pose::Pose;

use crate::asset::MotionWeights;

/// Which model drives a character.
#[derive(Debug, Clone, Default)]
pub enum MotionModelSource {
    /// The weights built into motion-core (the shipped default model).
    #[default]
    Builtin,
    /// A weights asset (`asset_server.load("model.safetensors")`: a learned model, or a
    /// motion-matching database such as `matching_cmu.safetensors`, whose characters play on its
    /// own rig, the seed retargeted onto it, and ignore the action); the character starts once
    /// it has loaded.
    Asset(Handle<MotionWeights>),
}

/// A seed motion: a BVH on the model's skeleton or a rig motion-core retargets (CMU, Mixamo,
/// Unreal), any units and rate; its last `seed_frames` frames at the model's rate start the
/// character.
#[derive(Debug, Clone)]
pub struct MotionSeed {
    pub(crate) bvh: Arc<Bvh>,
    pub(crate) label: Arc<str>,
}

/// The walk seed shipped with motion-core (`examples/walk_seed.bvh`), built in.
const WALK_SEED_BVH: &str = include_str!("../../../examples/walk_seed.bvh");

impl MotionSeed {
    /// The bundled walk seed.
    pub fn walk() -> MotionSeed {
        MotionSeed::from_bvh_text(WALK_SEED_BVH, "walk_seed.bvh").expect("the bundled seed parses")
    }

    /// A seed from BVH text; `label` names it in errors.
    pub fn from_bvh_text(text: &str, label: &str) -> Result<MotionSeed, String> {
        let bvh = parse_bvh(text, label).map_err(|e| e.to_string())?;
        Ok(MotionSeed {
            bvh: Arc::new(bvh),
            label: label.into(),
        })
    }

    /// A seed from a BVH file.
    pub fn from_bvh_file(path: impl AsRef<Path>) -> Result<MotionSeed, String> {
        let path = path.as_ref();
        let bvh = read_bvh(path).map_err(|e| e.to_string())?;
        Ok(MotionSeed {
            bvh: Arc::new(bvh),
            label: path.display().to_string().into(),
        })
    }
}

/// A character driven by a motion generator. Spawn it with a [`Transform`] (where its motion
/// starts); the plugin spawns its joint hierarchy as children ([`MotionRig`]) and moves the
/// character entity by the root motion. Change [`action`](Self::action) from game code at any
/// time: the plugin switches the generator on the next tick.
#[derive(Component, Debug, Clone)]
#[require(Transform)]
pub struct MotionCharacter {
    /// The model.
    pub model: MotionModelSource,
    /// Where the motion starts.
    pub seed: MotionSeed,
    /// The action the model is conditioned on (one of the model's; an unknown one is reported
    /// in [`MotionFailed`]).
    pub action: String,
    /// The generator's noise seed (characters sharing a batch draw from a mix of theirs).
    pub rng_seed: u64,
    /// Playback rate: 1 is real time; characters with the same model and rate share a batch.
    pub playback_rate: f32,
    /// Keep the character on its seed's floor, upright, planted feet locked
    /// (`motion_core::grounding`; default `true`); `false` poses the model's raw motion. Read
    /// when the character starts.
    pub grounding: bool,
    /// Where to go: a velocity on the floor and a facing in world axes (`motion_core::steering`:
    /// the model's stride warped within 30 % toward the speed, its heading turned toward the
    /// facing); `None` (the default) lets the model walk where it walks. Read every tick.
    pub goal: Option<MotionGoal>,
}

/// A steering goal in world axes (see [`MotionCharacter::goal`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionGoal {
    /// Velocity on the floor, metres per second: `x` and `z` world axes.
    pub velocity: Vec2,
    /// Yaw to face, radians about +y: 0 faces +z, pi/2 faces +x.
    pub facing: f32,
}

impl MotionGoal {
    /// Walk at `velocity` (`x`, `z`) facing where it goes.
    pub fn towards(velocity: Vec2) -> MotionGoal {
        MotionGoal {
            velocity,
            facing: velocity.x.atan2(velocity.y),
        }
    }
}

impl MotionCharacter {
    /// The built-in model from the bundled walk seed, doing `action` in real time.
    pub fn new(action: impl Into<String>, rng_seed: u64) -> MotionCharacter {
        MotionCharacter {
            model: MotionModelSource::Builtin,
            seed: MotionSeed::walk(),
            action: action.into(),
            rng_seed,
            playback_rate: 1.0,
            grounding: true,
            goal: None,
        }
    }
}

/// The character's current pose (motion-core's engine [`Pose`]: metres, local rotations, root
/// motion), written every tick before transforms propagate.
#[derive(Component, Debug, Clone)]
pub struct MotionPose(pub Pose);

/// The joint entities the plugin spawned under a character, in the model skeleton's order
/// (joint 0, the hips, is a child of the character; the rest follow the skeleton's parents).
/// Attach meshes to them.
#[derive(Component, Debug, Clone)]
pub struct MotionRig {
    pub(crate) joints: Vec<Entity>,
    pub(crate) names: Vec<String>,
    pub(crate) origin: Transform,
    pub(crate) floor: f32,
}

impl MotionRig {
    /// The joint entities, skeleton order.
    pub fn joints(&self) -> &[Entity] {
        &self.joints
    }

    /// The joint names, skeleton order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The character's transform when it started: root motion is relative to it.
    pub fn origin(&self) -> Transform {
        self.origin
    }

    /// How far the hips are raised (metres, along the character's +y) so that the first pose's
    /// lowest joint stands on the character's origin: spawn characters on the floor.
    pub fn floor_offset(&self) -> f32 {
        self.floor
    }
}

/// Why a character could not start or go on (bad seed, unknown action, a model without a pose
/// layout); the plugin leaves such a character alone until the component is removed.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct MotionFailed(pub String);
