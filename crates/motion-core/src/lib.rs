//! # motion-core
//!
//! The data model and inference engine of the `motion` project: skeletons, rotations and forward
//! kinematics; H3.6M exp-map text, BVH and `.npy` in and out; motion-derivative features; GRU and
//! LSTM cells; the VTLN-RNN (VGRU-d) and GRU-d predictors of paper 000; closed-loop generation
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
//!
//! ## Example: load weights, seed, step
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

pub mod derivatives;
pub mod error;
pub mod formats;
pub mod kinematics;
pub mod model;
pub mod motion;
pub mod nn;
pub mod pose;
pub mod protocol;
pub mod resample;
pub mod root;
pub mod rotation;
pub mod seed;
pub mod skeleton;

pub use error::{FormatError, MotionError, SkeletonError};
pub use motion::{Motion, MotionLayout, RootEncoding};
pub use skeleton::{Channel, Joint, Skeleton};
