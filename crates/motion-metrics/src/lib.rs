//! # motion-metrics
//!
//! NPSS (paper 000), the Euler-angle error of the standard H3.6M protocol, NDMS (paper 003) and
//! APD, in `f64`, exact to their definitions (`metrics.md`, `h36m.md`).
//!
//! Every metric takes ndarray views of the caller's data, checks shapes and finiteness (typed
//! [`MetricError`]s, never a panic), and parallelizes over sequences with rayon.
#![warn(missing_docs)]

pub mod apd;
pub mod error;
pub mod euler_error;
pub mod ndms;
pub mod npss;

pub use apd::{apd, apd_batch};
pub use error::MetricError;
pub use euler_error::{
    euler_error, euler_error_at_horizons, EULER_HORIZONS_MS, EULER_HORIZON_FRAMES_25HZ,
};
pub use ndms::{NdmsConfig, NdmsDatabase, NdmsReport, NnMethod};
pub use npss::{npss, npss_reference, npss_windows, Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
