//! # motion-core
//!
//! The data model and inference engine of the `motion` project: skeletons, rotations and forward
//! kinematics; H3.6M exp-map text, BVH and `.npy` in and out; motion-derivative features; GRU and
//! LSTM cells; the VTLN-RNN (VGRU-d) and GRU-d predictors of Gopalakrishnan et al. 2019; closed-loop generation
//! from self-describing safetensors weights.
//!
//! ## Conventions (stated once)
//! - Lengths are millimetres, angles radians, the vertical axis is **+y**.
//! - Rotations act on **row vectors** as in the H3.6M data: a child's world rotation is
//!   `W_j = R_j · W_parent` and a child's position `x_j = offset_j · W_parent + x_parent`.
//! - H3.6M exp-map text is 50 Hz with 99 columns; the evaluation protocol downsamples to 25 Hz by
//!   keeping the even frames. Dims 0..2 / 3..5 of an H3.6M frame are per-frame root translation /
//!   rotation **deltas**.
//! - Frames are stored row-major, `frames x channels`, in `f64` unless a model computes in `f32`.
//! - The engine boundary is [`pose`]: f32 glam data, **metres**, rotations as unit quaternions on
//!   **column vectors** (glam, Bevy, BVH); the H3.6M row-vector convention stays inside.
//! - Generated motion is **grounded** by default ([`grounding`]: the seed's floor levelled to
//!   `y = 0`, lean held to the action's real range, planted feet locked); switchable off.
//!
//! ## Example: a character in a game engine
//! Load weights, seed from a BVH, tick at 60 Hz reading engine [`pose::Pose`]s (f32 glam,
//! metres, column-vector quaternions) and the root motion for the character controller, and
//! switch the action without re-seeding.
//! ```
//! use std::sync::Arc;
//! use motion_core::formats::expmap_bvh::ExpMapTarget;
//! use motion_core::model::{Character, MotionModel, Noise};
//! use motion_core::seed::load_seed;
//!
//! let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
//! // A small random-weight fixture; `weights/` holds the shipped models.
//! let model = Arc::new(MotionModel::load(format!("{root}/tests/fixtures/parity/vgru_d.safetensors"))?);
//! let (fps, needed) = (model.config().fps, model.config().seed_frames);
//! // The one seed loader: format by extension, units checked, resampled to the model's rate.
//! let seed = load_seed(format!("{root}/examples/walk_seed.bvh").as_ref(), ExpMapTarget::H36m, fps, 50.0, None)?;
//! let window = seed.frames.slice(ndarray::s![seed.frames.nrows() - needed.., ..]);
//!
//! let mut character = Character::new(Arc::clone(&model))?; // one per character, weights shared
//! let mut pose = character.start(window, Some("walking"), Noise::Seed(7))?.clone();
//! let mut travelled = glam::Vec3::ZERO;
//! for tick in 0..180 {
//!     if tick == 90 {
//!         character.set_action("eating", 10)?; // no re-seeding, no stall
//!     }
//!     let next = character.advance(1.0 / 60.0)?; // generates model frames only when due
//!     // Drive the controller with the ground motion, pose the rig with the rest:
//!     travelled += next.root_motion.delta_translation; // metres, on the ground plane
//!     let _heading = next.root_motion.ground_yaw; // rotation about +y
//!     let _pelvis = (next.root_motion.pelvis_offset, next.root_motion.pelvis_rotation);
//!     let _hips_to_spine = next.local_rotations[11]; // joint order of character.skeleton()
//!     pose.clone_from(next);
//! }
//! assert_eq!(pose.local_rotations.len(), character.skeleton().len());
//! assert!(travelled.is_finite());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Example: load weights, seed, step (raw exp-map frames)
//! ```
//! use std::sync::Arc;
//! use motion_core::model::{Generator, MotionModel, Noise};
//! use ndarray::Array2;
//!
//! // A small random-weight fixture (15 actions, 99 dims, 10 seed frames at 25 Hz).
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/parity/vgru_d.safetensors");
//! let model = Arc::new(MotionModel::load(path)?);
//! let config = model.config();
//! // Seed: `seed_frames` H3.6M exp-map frames (here a still rest pose).
//! let seed = Array2::<f64>::zeros((config.seed_frames, config.frame_dims));
//! let mut generator = Generator::new(Arc::clone(&model)); // one per character, weights shared
//! generator.start(seed.view(), Some("walking"), Noise::Seed(7))?;
//! for _ in 0..25 {
//!     let frame: &[f32] = generator.step()?; // the next full frame, closed loop, no allocation
//!     assert_eq!(frame.len(), 99);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod any_format;
pub mod clip;
pub mod derivatives;
pub mod error;
pub mod file_sets;
pub mod formats;
pub mod grounding;
pub mod input_file;
pub mod kinematics;
pub mod limits;
pub mod matching;
pub mod model;
pub mod motion;
pub mod nn;
pub mod pose;
pub mod protocol;
pub mod resample;
pub mod retarget;
pub mod rig_target;
pub mod root;
pub mod rotation;
pub mod seed;
pub mod skeleton;
pub mod steering;
pub mod takes;
pub mod weights;

pub use error::{FormatError, MotionError, SkeletonError};
pub use motion::{Motion, MotionLayout, RootEncoding};
pub use skeleton::{Channel, Joint, Skeleton};
