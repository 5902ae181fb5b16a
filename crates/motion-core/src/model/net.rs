//! The one interface the generators drive every architecture through: a [`Net`] makes its
//! per-batch [`NetState`], begins a sequence (actions, noise, seed length), runs one body step
//! from derivative features to the decoder's input, optionally filters the decoded output, and
//! switches a row's action. [`BatchGenerator`](super::BatchGenerator) calls nothing else of a
//! network; each architecture's file implements the trait for its network, which its
//! [`ArchFields::load`](super::arch::ArchFields::load) makes.
use std::any::Any;

use super::config::ModelConfig;
use super::generate_error::GenerateError;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

/// Where a row's noise `N(0, I)` comes from: VGRU-d's plan noise `eps`, also the intention
/// model's `z` ([`super::intention`]).
#[derive(Debug)]
pub enum NoiseSource {
    /// A seeded generator: every plan block draws a fresh `eps`.
    Rng(Box<StdRng>),
    /// A fixed `eps` (parity tests, reproducible demos): every block reuses it.
    Fixed(Vec<f32>),
}

impl NoiseSource {
    /// A seeded source (`StdRng::seed_from_u64`).
    pub fn seeded(seed: u64) -> Self {
        NoiseSource::Rng(Box::new(StdRng::seed_from_u64(seed)))
    }

    /// The next `eps` (a seeded source draws `N(0, I)`; a fixed one copies its vector).
    pub(crate) fn fill(&mut self, eps: &mut [f32]) {
        match self {
            NoiseSource::Rng(rng) => {
                for e in eps {
                    *e = rng.sample(StandardNormal);
                }
            }
            NoiseSource::Fixed(v) => eps.copy_from_slice(v),
        }
    }
}

/// The recurrent state of a batch of rows of one [`Net`].
pub trait NetState: Any + std::fmt::Debug + Send + Sync {
    /// Itself, to be downcast by the net that made it.
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Any + std::fmt::Debug + Send + Sync> NetState for T {
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// What a sequence starts with.
#[derive(Debug)]
pub struct Begin<'a> {
    /// Rows of the state in use.
    pub rows: usize,
    /// Each row's action index (0 for unconditioned models).
    pub actions: &'a [usize],
    /// Each row's noise source (empty for deterministic nets, [`Net::noise_dims`] 0).
    pub noise: Vec<NoiseSource>,
    /// Seed frames that will be fed.
    pub seed_len: usize,
    /// Frames per plan block (VGRU-d).
    pub plan_horizon: usize,
}

/// A network the generators can drive (see the module docs).
pub trait Net: std::any::Any + std::fmt::Debug + Send + Sync {
    /// Trainable parameters of the network (the decoder and normalization excluded), as
    /// PyTorch counts them.
    fn parameter_count(&self) -> usize;
    /// Width of each row's noise vector (0: deterministic).
    fn noise_dims(&self) -> usize {
        0
    }
    /// Whether each seed frame's prediction is made and handed out (teacher forcing); the
    /// intention model's seed frames only feed its encoders.
    fn teacher_forced(&self) -> bool {
        true
    }
    /// Whether a start needs an action label.
    fn needs_action(&self) -> bool {
        false
    }
    /// A state for up to `rows` rows.
    fn new_state(&self, rows: usize, config: &ModelConfig) -> Box<dyn NetState>;
    /// Begins a sequence of every row.
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>);
    /// One body step of `rows` rows from their derivative `features`: the decoder's input, or
    /// `None` where no prediction is made (the intention model's early seed frames).
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        body_step: usize,
    ) -> Option<&'s [f32]>;
    /// Filters the decoded, normalized outputs in place before they are fed back (DAE-LSTM's
    /// autoencoder); nothing by default.
    fn filter(&self, _state: &mut dyn NetState, _out_norm: &mut [f32], _rows: usize) {}
    /// Width of each row's control vector (0: the net takes none; `goal-gru`: where the root
    /// goes over the next second, [`super::goal_gru`]).
    fn control_dims(&self) -> usize {
        0
    }
    /// Sets `row`'s control vector (`control_dims` values, checked by the caller), read by
    /// every step from the next on; a state starts with zeros.
    ///
    /// # Errors
    /// [`GenerateError::NotControlled`] for nets that take no control.
    fn set_control(
        &self,
        _state: &mut dyn NetState,
        _row: usize,
        _control: &[f32],
    ) -> Result<(), GenerateError> {
        Err(GenerateError::NotControlled)
    }
    /// Conditions `row` on `action` from body step `body_step` on.
    ///
    /// # Errors
    /// [`GenerateError::NotConditioned`] for nets that take no action.
    fn set_action(
        &self,
        _state: &mut dyn NetState,
        _rows: usize,
        _row: usize,
        _action: usize,
        _crossfade: usize,
        _body_step: usize,
    ) -> Result<(), GenerateError> {
        Err(GenerateError::NotConditioned)
    }
}

/// The state `net` made, as its concrete type.
pub(super) fn own<T: 'static>(state: &mut dyn NetState) -> &mut T {
    state
        .as_any_mut()
        .downcast_mut::<T>()
        .expect("a state made by this net")
}
