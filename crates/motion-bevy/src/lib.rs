//! Bevy plugin for motion-core: characters driven by motion generators, batched per model, posed
//! into the `Transform`s of a joint hierarchy at the game's frame rate.
//!
//! ```
//! use bevy::prelude::*;
//! use motion_bevy::{MotionCharacter, MotionPlugin, MotionPose, MotionRig};
//!
//! let mut app = App::new();
//! // A game adds `DefaultPlugins`; headless, these are enough.
//! app.add_plugins((MinimalPlugins, AssetPlugin::default(), TransformPlugin, MotionPlugin));
//! // The built-in model from the bundled walk seed, starting 2 m along x.
//! let walker = app
//!     .world_mut()
//!     .spawn((MotionCharacter::new("walking", 1), Transform::from_xyz(2.0, 0.0, 0.0)))
//!     .id();
//! for _ in 0..10 {
//!     app.update(); // the plugin spawned 32 joint entities under it and poses them every tick
//! }
//! // Game code switches the action; the generator follows on the next tick.
//! app.world_mut().get_mut::<MotionCharacter>(walker).unwrap().action = "sitting".into();
//! app.update();
//! assert_eq!(app.world().get::<MotionRig>(walker).unwrap().joints().len(), 32);
//! assert_eq!(app.world().get::<MotionPose>(walker).unwrap().0.local_rotations.len(), 32);
//! ```
//!
//! What the plugin does each tick (in `PostUpdate`, before transforms propagate):
//! - a new [`MotionCharacter`] gets its joint entities ([`MotionRig`]: one child entity per
//!   skeleton joint, [`MotionJoint`] marked, bone offsets as translations) and a row in the batch
//!   of its model and playback rate;
//! - every batch is stepped as often as the game's frame time needs (**one batched step per
//!   model frame for all its characters**: a `BatchGenerator` underneath), each character
//!   resampled to the game's clock;
//! - a character with [`MotionSkinned`] on a spawned glTF scene (a skinned humanoid) drives that
//!   scene's own joints instead, found by `Name` and mapped onto the model's skeleton (rest poses,
//!   proportions and the hips' height handled by `motion_core::rig_target`);
//! - the pose is written: the character entity's `Transform` is its start transform times the
//!   root motion (ground translation and heading), the hips' local transform the pelvis offset
//!   (raised once so the first pose stands on the entity's origin: spawn on the floor) and tilt, every other joint its local rotation; [`MotionPose`] holds the engine pose.
//!
//! Conventions are motion-core's engine ones ([`motion_core::pose`]): metres, +y up,
//! right-handed, column-vector quaternions (Bevy's). Weights files load as [`MotionWeights`]
//! assets (`.safetensors`); failures land in [`MotionFailed`] on the character, never a panic.
mod asset;
mod character;
mod crowd;
mod skin;

use bevy::prelude::*;
use bevy::transform::TransformSystems;

pub use asset::{MotionAssetError, MotionWeights, MotionWeightsLoader};
pub use character::{
    MotionCharacter, MotionFailed, MotionGoal, MotionModelSource, MotionPose, MotionRig, MotionSeed,
};
pub use crowd::MotionJoint;
pub use skin::MotionSkinned;

/// Where the plugin's systems run, in `PostUpdate` before transform propagation: order game
/// systems that read [`MotionPose`] after it.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct MotionSystems;

/// The plugin: the weights asset and loader, and the systems that start, step and pose
/// characters (see the crate docs).
#[derive(Debug, Default)]
pub struct MotionPlugin;

impl Plugin for MotionPlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<MotionWeights>()
            .init_asset_loader::<MotionWeightsLoader>()
            .insert_resource(crowd::BuiltinModel::load())
            .init_resource::<crowd::Crowds>()
            .configure_sets(
                PostUpdate,
                MotionSystems.before(TransformSystems::Propagate),
            )
            .add_systems(
                PostUpdate,
                (
                    crowd::remove_characters,
                    crowd::start_characters,
                    crowd::step_characters,
                )
                    .chain()
                    .in_set(MotionSystems),
            );
    }
}
