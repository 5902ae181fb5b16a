//! Typed errors of the metrics: what is wrong with the caller's arrays.

/// An input the metrics cannot score, or a score that is undefined for the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MetricError {
    /// Ground truth and prediction (or two inputs that must agree) have different shapes.
    #[error("shape mismatch: {what} has shape {found:?} but {expected:?} was expected")]
    ShapeMismatch {
        /// Which input disagrees.
        what: String,
        /// The shape found.
        found: Vec<usize>,
        /// The shape expected.
        expected: Vec<usize>,
    },
    /// An input has no sequences, no frames or no dimensions.
    #[error("empty input: {what}")]
    Empty {
        /// Which input is empty.
        what: String,
    },
    /// An input holds NaN or an infinity.
    #[error("{what} holds a non-finite value (NaN or infinity) at index {index:?}")]
    NonFinite {
        /// Which input.
        what: String,
        /// The multi-dimensional index of the first non-finite value.
        index: Vec<usize>,
    },
    /// Every weight of a weighted mean is zero (e.g. NPSS of an all-constant ground truth).
    #[error("{metric} is undefined: {reason}")]
    Undefined {
        /// The metric.
        metric: &'static str,
        /// Why.
        reason: String,
    },
    /// A sequence is shorter than one motion word (NDMS).
    #[error("{what} has {frames} frames, fewer than the motion-word length κ = {kappa}")]
    TooShort {
        /// Which input.
        what: String,
        /// Its number of frames.
        frames: usize,
        /// The motion-word length.
        kappa: usize,
    },
    /// A configuration value is out of range (e.g. a joint index beyond the skeleton).
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
}

/// Returns an error naming the first non-finite value of `values`.
pub(crate) fn check_finite<D: ndarray::Dimension>(
    what: &str,
    values: &ndarray::ArrayView<'_, f64, D>,
) -> Result<(), MetricError> {
    // `iter` walks in logical (row-major) order, so the flat position gives the index.
    let Some(mut flat) = values.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let mut index = vec![0; values.ndim()];
    for (slot, &len) in index.iter_mut().zip(values.shape()).rev() {
        *slot = flat % len;
        flat /= len;
    }
    Err(MetricError::NonFinite {
        what: what.to_string(),
        index,
    })
}

/// Returns an error if any axis of `values` has length zero.
pub(crate) fn check_not_empty<D: ndarray::Dimension>(
    what: &str,
    values: &ndarray::ArrayView<'_, f64, D>,
) -> Result<(), MetricError> {
    if values.is_empty() {
        return Err(MetricError::Empty {
            what: format!("{what} has shape {:?}", values.shape()),
        });
    }
    Ok(())
}
