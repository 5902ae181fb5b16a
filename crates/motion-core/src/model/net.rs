//! The one interface the generators drive every architecture through: a [`Net`] makes its
//! per-batch [`NetState`], begins a sequence (actions, noise, seed length), runs one body step
//! from derivative features to the decoder's input, optionally filters the decoded output, and
//! switches a row's action. [`BatchGenerator`](super::BatchGenerator) calls nothing else of a
//! network; each architecture's file implements the trait for its network, and
//! [`Network::net`] is the one place the architectures are listed.
use std::any::Any;

use super::config::ModelConfig;
use super::dae_lstm::{DaeLstm, DaeLstmState};
use super::generate_error::GenerateError;
use super::grud::{GruD, GruDState};
use super::intention::{Intention, IntentionState};
use super::predictor::Network;
use super::vgru::{NoiseSource, VgruD, VgruState};

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
pub trait Net: std::fmt::Debug + Send + Sync {
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
fn own<T: 'static>(state: &mut dyn NetState) -> &mut T {
    state
        .as_any_mut()
        .downcast_mut::<T>()
        .expect("a state made by this net")
}

impl Network {
    /// The network as the generators drive it: the one list of architectures.
    pub fn net(&self) -> &dyn Net {
        match self {
            Network::Vgru(n) => n.as_ref(),
            Network::Grud(n) => n,
            Network::DaeLstm(n) => n.as_ref(),
            Network::Intention(n) => n.as_ref(),
        }
    }
}

impl Net for VgruD {
    fn noise_dims(&self) -> usize {
        self.plan_hidden()
    }
    fn needs_action(&self) -> bool {
        true
    }
    fn new_state(&self, rows: usize, config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows, config.seed_frames + config.horizon))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        VgruD::begin(
            self,
            own::<VgruState>(state),
            &begin.actions[..begin.rows],
            begin.noise,
            begin.seed_len,
            begin.plan_horizon,
        );
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(VgruD::step(
            self,
            own::<VgruState>(state),
            features,
            rows,
            body_step,
        ))
    }
    fn set_action(
        &self,
        state: &mut dyn NetState,
        rows: usize,
        row: usize,
        action: usize,
        _crossfade: usize,
        body_step: usize,
    ) -> Result<(), GenerateError> {
        VgruD::set_action(self, own::<VgruState>(state), rows, row, action, body_step);
        Ok(())
    }
}

impl Net for GruD {
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        self.reset(own::<GruDState>(state), begin.rows);
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        _body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(GruD::step(self, own::<GruDState>(state), features, rows))
    }
}

impl Net for DaeLstm {
    fn needs_action(&self) -> bool {
        true
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        DaeLstm::begin(
            self,
            own::<DaeLstmState>(state),
            &begin.actions[..begin.rows],
        );
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        _body_step: usize,
    ) -> Option<&'s [f32]> {
        Some(DaeLstm::step(
            self,
            own::<DaeLstmState>(state),
            features,
            rows,
        ))
    }
    fn filter(&self, state: &mut dyn NetState, out_norm: &mut [f32], rows: usize) {
        DaeLstm::filter(self, own::<DaeLstmState>(state), out_norm, rows);
    }
    fn set_action(
        &self,
        state: &mut dyn NetState,
        _rows: usize,
        row: usize,
        action: usize,
        crossfade: usize,
        _body_step: usize,
    ) -> Result<(), GenerateError> {
        DaeLstm::set_action(self, own::<DaeLstmState>(state), row, action, crossfade);
        Ok(())
    }
}

impl Net for Intention {
    fn noise_dims(&self) -> usize {
        Intention::noise_dims(self)
    }
    fn teacher_forced(&self) -> bool {
        false
    }
    fn needs_action(&self) -> bool {
        self.is_conditioned()
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(self.new_state(rows))
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        Intention::begin(
            self,
            own::<IntentionState>(state),
            begin.noise,
            begin.actions,
            begin.seed_len,
        );
    }
    /// Switches at once (`crossfade` is not used: the model was trained on hard switches).
    fn set_action(
        &self,
        state: &mut dyn NetState,
        _rows: usize,
        row: usize,
        action: usize,
        _crossfade: usize,
        _body_step: usize,
    ) -> Result<(), GenerateError> {
        if !self.is_conditioned() {
            return Err(GenerateError::NotConditioned);
        }
        Intention::set_action(self, own::<IntentionState>(state), row, action);
        Ok(())
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        body_step: usize,
    ) -> Option<&'s [f32]> {
        Intention::step(
            self,
            own::<IntentionState>(state),
            features,
            rows,
            body_step,
        )
    }
}
