//! `motion`: facade over [`motion_core`] (skeletons, formats, kinematics, neural predictors)
//! and [`motion_metrics`] (NPSS, Euler error, NDMS, APD).
//!
//! The command-line tool lives in the `motion-cli` crate.
#![warn(missing_docs)]

pub use motion_core as core;
pub use motion_metrics as metrics;

/// The README's Rust snippets, compiled and run as doc tests (`cargo test --doc -p motion`).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
