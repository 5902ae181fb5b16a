//! # motion-metrics
//!
//! NPSS (Gopalakrishnan et al. 2019), the Euler-angle error of the standard H3.6M protocol, NDMS (Tanke et al. 2021),
//! APD, the 3-D joint-position error of LTD, HRI and siMLPe ([`mpjpe`]), the multi-sample metrics of
//! DLow and BeLFusion ([`multimodal`]), the action-classifier protocol of Ghosh et al. 2017, plausibility measures without ground
//! truth and the whole H3.6M test protocol of one action ([`protocol::ActionTruth`]), in `f64`, exact to their definitions (`metrics.md`, `h36m.md`).
//!
//! Every metric takes ndarray views of the caller's data, checks shapes and finiteness (typed
//! [`MetricError`]s, never a panic), and parallelizes over sequences with rayon.
//!
//! ## Example: NPSS of a prediction
//! ```
//! use motion_metrics::npss;
//! use ndarray::Array3;
//!
//! // 2 sequences x 32 frames x 3 features (Euler angles in practice).
//! let gt = Array3::from_shape_fn((2, 32, 3), |(n, t, d)| (0.4 * t as f64 + d as f64 + n as f64).sin());
//! let faster = Array3::from_shape_fn((2, 32, 3), |(n, t, d)| (0.8 * t as f64 + d as f64 + n as f64).sin());
//! assert!(npss(gt.view(), gt.view())?.abs() < 1e-12); // identical spectra: 0
//! assert!(npss(gt.view(), faster.view())? > 0.1); // power moved to other frequencies
//! # Ok::<(), motion_metrics::MetricError>(())
//! ```
#![warn(missing_docs)]

pub mod apd;
pub mod baselines;
pub mod classifier;
pub mod error;
pub mod euler_error;
pub mod evaluation;
pub mod mpjpe;
pub mod multimodal;
pub mod ndms;
pub mod npss;
pub mod plausibility;
pub mod posture;
pub mod protocol;
pub mod reference;
pub mod responsiveness;

pub use apd::{apd, apd_batch};
pub use classifier::{
    classifier_curve, classifier_curve_pairs, classifier_protocol, protocol_hop, ClassifierCurve,
};
pub use error::MetricError;
pub use euler_error::{
    euler_error, euler_error_at_horizons, EULER_HORIZONS_MS, EULER_HORIZON_FRAMES_25HZ,
};
pub use mpjpe::{mpjpe, mpjpe_batch, JointMean};
pub use multimodal::{score_sample_sets, SampleSetReport, SampleSetScores, SampleSets};
pub use ndms::{NdmsConfig, NdmsDatabase, NdmsReport, NnMethod};
pub use npss::{npss, npss_reference, npss_windows, Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
pub use plausibility::{ActionReference, PlausibilityReport};
pub use posture::{PostureJoints, PostureReference, PostureReport};
