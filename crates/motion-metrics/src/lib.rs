//! # motion-metrics
//!
//! NPSS (paper 000), the Euler-angle error of the standard H3.6M protocol, NDMS (paper 003) and
//! APD, in `f64`, exact to their definitions.
#![warn(missing_docs)]
