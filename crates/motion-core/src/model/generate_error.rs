//! Errors of closed-loop generation: bad seeds, actions or noise given to a generator.

/// Bad input to [`Generator`](super::Generator) or [`BatchGenerator`](super::BatchGenerator).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GenerateError {
    /// The predictions asked for would not fit in memory (see
    /// [`crate::model::samples::MAX_SAMPLE_VALUES`]).
    #[error("{samples} samples x {frames} frames x {frame_dims} values is over the limit of {limit} values (MAX_SAMPLE_VALUES, 256 MiB of f64): ask for fewer, in several runs")]
    TooLarge {
        /// Samples asked for.
        samples: usize,
        /// Frames per sample.
        frames: usize,
        /// Values per frame.
        frame_dims: usize,
        /// The limit.
        limit: usize,
    },
    /// Fewer seed frames than the model needs.
    #[error("{got} seed frames given, the model needs at least {needed}")]
    TooFewSeedFrames {
        /// Frames the model needs.
        needed: usize,
        /// Frames given.
        got: usize,
    },
    /// Seed frames of the wrong width.
    #[error("seed frames have {got} values, the model's frames have {expected}")]
    WrongWidth {
        /// The model's `frame_dims`.
        expected: usize,
        /// The width given.
        got: usize,
    },
    /// A seed value is NaN or infinite.
    #[error("seed of character {character}: frame {frame}, dim {dim} is {value}")]
    NonFiniteSeed {
        /// Batch row (0 for a single generator).
        character: usize,
        /// 0-based frame.
        frame: usize,
        /// 0-based dim.
        dim: usize,
        /// The value found.
        value: f64,
    },
    /// An action label the model was not trained with.
    #[error("unknown action `{label}`; valid actions: {}", valid.join(", "))]
    UnknownAction {
        /// The label given.
        label: String,
        /// The model's labels.
        valid: Vec<String>,
    },
    /// The model is action-conditioned and no action was given.
    #[error("this model needs an action; valid actions: {}", valid.join(", "))]
    MissingAction {
        /// The model's labels.
        valid: Vec<String>,
    },
    /// An explicit noise vector of the wrong length.
    #[error("explicit noise has {got} values, the model needs {expected} (vgru-d: plan_hidden, intention: noise_dims)")]
    WrongNoiseLength {
        /// The noise width: VGRU-d's plan width `P`, the intention model's `noise_dims`.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// Per-character arguments (seeds, actions, noise) disagree with the batch size.
    #[error("{what}: {got} given for a batch of {expected}")]
    WrongBatch {
        /// Which argument.
        what: &'static str,
        /// The generator's batch size.
        expected: usize,
        /// The count given.
        got: usize,
    },
    /// A plan horizon of 0 steps.
    #[error("plan horizon must be at least 1 step")]
    ZeroHorizon,
    /// The model produced a value that is not finite (weights that overflow on this seed):
    /// nothing is written.
    #[error("the model produced a non-finite value at frame {frame}, dim {dim} of sample {sample}: its weights overflow on this seed")]
    NonFiniteOutput {
        /// The sample.
        sample: usize,
        /// The predicted frame (0-based).
        frame: usize,
        /// The dim.
        dim: usize,
    },
    /// A batch row that does not exist.
    #[error("character {row} does not exist: the batch has {batch}")]
    NoSuchRow {
        /// The row given.
        row: usize,
        /// The batch size.
        batch: usize,
    },
    /// An action was set on a model that is not action-conditioned.
    #[error("this model is not action-conditioned: it has no action to change")]
    NotConditioned,
    /// A control was set on a model that takes none (only `goal-gru` does).
    #[error("this model takes no control vector (a goal-gru model does): steer it with Character::set_goal's root warping instead")]
    NotControlled,
    /// A control vector of the wrong length or with a value that is not finite.
    #[error("control vector {got:?}: the model needs {expected} finite values")]
    BadControl {
        /// The model's control width.
        expected: usize,
        /// The values given.
        got: Vec<f32>,
    },
    /// `step` was called before `start`.
    #[error("step() or set_action() called before start(): seed the generator first")]
    NotStarted,
}
