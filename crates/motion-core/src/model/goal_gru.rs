//! `goal-gru`: stacked GRU layers over plain poses whose first layer also reads a control vector,
//! where the root goes over the next second; a linear decoder adds the next frame's change
//! (residual). Stage two of steering: the model moves as it is told instead of being warped.
//!
//! This project's architecture (`training/locomotion.py`, `GoalGRU` of `training/models.py`,
//! tensors `rnn.{k}.*`): a GRU-d (Gopalakrishnan et al. 2019) over plain poses conditioned on the
//! control, as learned locomotion controllers are conditioned on the trajectory ahead.
//!
//! ## The control (`control_dims` 3, over `control_frames` frames: 25 at 25 Hz, one second)
//! In the floor frame of the pelvis heading of the frame being read ([`crate::steering`]'s
//! heading: the rest pose's forward turned by the root rotation, laid on the floor):
//! `[forward, side]`, the root's mean floor velocity over the next `control_frames` (m/s; `side`
//! is +x when facing +z), and `turn`, the heading change over them (radians, within ±π). Every
//! step reads the row's current control ([`Net::set_control`]); a row starts with zeros (stand).
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::arch::{stacked_gru_shapes, ArchFields};
use super::config::{limits, ModelConfig};
use super::generate_error::GenerateError;
use super::net::{own, Begin, Net, NetState};
use super::weights::{WeightStore, WeightsError};
use super::ArchConfig;
use crate::nn::{GruCell, GruScratch, Stack, StackState};

/// The config fields only `goal-gru` has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalGruFields {
    /// Values of the control vector (3: forward and side velocity, turn).
    pub control_dims: usize,
    /// Frames the control looks ahead (25 at 25 Hz: one second).
    pub control_frames: usize,
}

impl ArchFields for GoalGruFields {
    const STOCHASTIC: bool = false;

    /// `make_config("goal-gru")` of `training/models.py`: 2 GRU layers of 256 units over plain
    /// poses, residual, a control of 3 values over 25 frames.
    fn paper() -> ModelConfig {
        let fields = GoalGruFields {
            control_dims: 3,
            control_frames: 25,
        };
        ModelConfig {
            residual: true,
            ..ModelConfig::h36m(fields.into(), 256, 2)
        }
    }

    fn validate(&self, config: &ModelConfig) -> Result<(), String> {
        if self.control_dims == 0 || self.control_dims > limits::UNITS {
            return Err(format!(
                "goal-gru needs 1 ..= {} control_dims, got {}",
                limits::UNITS,
                self.control_dims
            ));
        }
        if self.control_frames == 0 || self.control_frames > limits::FRAMES {
            return Err(format!(
                "goal-gru needs 1 ..= {} control_frames, got {}",
                limits::FRAMES,
                self.control_frames
            ));
        }
        if config.layers == 0 {
            return Err("goal-gru with 0 GRU layers".into());
        }
        Ok(())
    }

    fn describe(&self, config: &ModelConfig) -> Vec<(&'static str, String)> {
        vec![
            (
                "architecture",
                "goal-gru (stacked GRU + linear decoder over plain poses, the first layer also \
                 reading where the root goes over the next second: steerable locomotion)"
                    .into(),
            ),
            (
                "control",
                format!(
                    "{} values over the next {} frames ({:.2} s): forward and side velocity \
                     (m/s) and heading change (rad) in the pelvis heading's floor frame",
                    self.control_dims,
                    self.control_frames,
                    self.control_frames as f64 / config.fps
                ),
            ),
            (
                "sizes",
                format!(
                    "{} GRU layers x {} units (first layer input {} = pose {} + control {})",
                    config.layers,
                    config.hidden,
                    config.rnn_input_dims(),
                    config.input_dims(),
                    self.control_dims
                ),
            ),
        ]
    }

    fn rnn_input_dims(&self, config: &ModelConfig) -> usize {
        config.input_dims() + self.control_dims
    }

    fn tensor_shapes(&self, config: &ModelConfig, shapes: &mut Vec<(String, Vec<usize>)>) {
        stacked_gru_shapes(
            shapes,
            "rnn",
            config.layers,
            config.rnn_input_dims(),
            config.hidden,
        );
    }

    fn load(
        &self,
        store: &WeightStore,
        config: &ModelConfig,
    ) -> Result<Arc<dyn Net>, WeightsError> {
        Ok(Arc::new(GoalGru::load(store, config, self)?))
    }
}

/// The control horizon (frames) of a model whose control this crate makes: a `goal-gru` of 3
/// control values (the steering's `[forward, side, turn]`, on H3.6M's skeleton or a rig, the
/// heading by the skeleton's rest forward); `None` for any other model.
pub fn steerable_control_frames(config: &ModelConfig) -> Option<usize> {
    match &config.arch {
        ArchConfig::GoalGru(f) if f.control_dims == 3 => Some(f.control_frames),
        _ => None,
    }
}

/// `goal-gru` recurrent weights (immutable, shareable).
#[derive(Debug, Clone)]
pub struct GoalGru {
    rnn: Stack<GruCell>,
    features: usize,
    controls: usize,
}

/// Per-batch state of a [`GoalGru`]: hidden vectors, each row's control and the first layer's
/// input, all sized once.
#[derive(Debug)]
pub struct GoalGruState {
    rnn: StackState<GruScratch>,
    control: Vec<f32>,
    input: Vec<f32>,
}

impl GoalGru {
    /// Reads `rnn.{k}.*` for `k in 0..layers` (the first layer over pose + control).
    pub fn load(
        store: &WeightStore,
        config: &ModelConfig,
        fields: &GoalGruFields,
    ) -> Result<Self, WeightsError> {
        let rnn = Stack::load_gru(
            store,
            "rnn",
            config.layers,
            config.input_dims() + fields.control_dims,
            config.hidden,
            config.gru_convention,
        )?;
        Ok(Self {
            rnn,
            features: config.input_dims(),
            controls: fields.control_dims,
        })
    }
}

impl Net for GoalGru {
    fn parameter_count(&self) -> usize {
        self.rnn.parameter_count()
    }
    fn control_dims(&self) -> usize {
        self.controls
    }
    fn new_state(&self, rows: usize, _config: &ModelConfig) -> Box<dyn NetState> {
        Box::new(GoalGruState {
            rnn: self.rnn.new_state(rows),
            control: vec![0.0; rows * self.controls],
            input: vec![0.0; rows * (self.features + self.controls)],
        })
    }
    fn begin(&self, state: &mut dyn NetState, begin: Begin<'_>) {
        self.rnn
            .reset(&mut own::<GoalGruState>(state).rnn, begin.rows);
    }
    fn step<'s>(
        &self,
        state: &'s mut dyn NetState,
        features: &[f32],
        rows: usize,
        _body_step: usize,
    ) -> Option<&'s [f32]> {
        let state = own::<GoalGruState>(state);
        let (f, c) = (self.features, self.controls);
        for (b, row) in state.input[..rows * (f + c)]
            .chunks_exact_mut(f + c)
            .enumerate()
        {
            row[..f].copy_from_slice(&features[b * f..(b + 1) * f]);
            row[f..].copy_from_slice(&state.control[b * c..(b + 1) * c]);
        }
        Some(
            self.rnn
                .step(&mut state.rnn, &state.input[..rows * (f + c)], rows),
        )
    }
    fn set_control(
        &self,
        state: &mut dyn NetState,
        row: usize,
        control: &[f32],
    ) -> Result<(), GenerateError> {
        let c = self.controls;
        own::<GoalGruState>(state).control[row * c..(row + 1) * c].copy_from_slice(control);
        Ok(())
    }
}
