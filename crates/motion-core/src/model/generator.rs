//! Closed-loop generation for one character: feed seed frames (teacher forcing), then each
//! [`Generator::step`] yields the next full frame, derivative features recomputed from the
//! generated history. A thin wrapper over a [`BatchGenerator`] of one row, whose products are
//! matrix-vector (GEMV) and allocation-free.
//!
//! Deterministic: the same seed frames, action and noise give bit-identical frames on one
//! machine; a different [`Noise::Seed`] gives a different future for VGRU-d.
use super::batch::{BatchGenerator, FrameScalar, Noise};
use super::generate_error::GenerateError;
use super::predictor::MotionModel;
use ndarray::{Array2, ArrayView2, Axis};
use std::sync::Arc;

/// Per-character generator over shared model weights.
#[derive(Debug)]
pub struct Generator {
    inner: BatchGenerator,
}

impl Generator {
    /// A generator for one character.
    pub fn new(model: Arc<MotionModel>) -> Self {
        Self {
            inner: BatchGenerator::new(model, 1),
        }
    }

    /// The shared model.
    pub fn model(&self) -> &Arc<MotionModel> {
        self.inner.model()
    }

    /// Sets the VGRU plan horizon for the next start (see [`BatchGenerator::set_plan_horizon`]).
    pub fn set_plan_horizon(&mut self, horizon: usize) -> Result<(), GenerateError> {
        self.inner.set_plan_horizon(horizon)
    }

    /// Teacher-forces `seed [S, frame_dims]` (full frames, `S >= 1`), conditioned on `action`
    /// (required by action-conditioned models) with `noise` (VGRU-d's plan noise, the intention
    /// model's `z`; ignored by GRU-d and DAE-LSTM).
    pub fn start<T: FrameScalar>(
        &mut self,
        seed: ArrayView2<'_, T>,
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<(), GenerateError> {
        self.start_with(seed, action, noise, |_, _| {})
    }

    /// Like [`start`](Self::start); `teacher_forced(t, frame)` receives the prediction of frame
    /// `t + 1` made after reading seed frame `t` (never called for the intention model, which
    /// makes no teacher-forced predictions; see [`BatchGenerator::start_with`]).
    pub fn start_with<T: FrameScalar, F: FnMut(usize, &[f32])>(
        &mut self,
        seed: ArrayView2<'_, T>,
        action: Option<&str>,
        noise: Noise<'_>,
        mut teacher_forced: F,
    ) -> Result<(), GenerateError> {
        let actions: &[&str] = match &action {
            Some(a) => std::slice::from_ref(a),
            None => &[],
        };
        self.inner.start_with(
            seed.insert_axis(Axis(0)),
            actions,
            std::slice::from_ref(&noise),
            |t, frames| teacher_forced(t, frames.as_slice().expect("contiguous")),
        )
    }

    /// The width of the control vector the model reads (0: none); see
    /// [`BatchGenerator::control_dims`].
    pub fn control_dims(&self) -> usize {
        self.inner.control_dims()
    }

    /// Sets the control vector read from the next step on; see
    /// [`BatchGenerator::set_control`].
    pub fn set_control(&mut self, control: &[f32]) -> Result<(), GenerateError> {
        self.inner.set_control(0, control)
    }

    /// Conditions the character on `action` from its next frame on, without re-seeding; see
    /// [`BatchGenerator::set_action`] for when each architecture shows it and `crossfade`.
    pub fn set_action(&mut self, action: &str, crossfade: usize) -> Result<(), GenerateError> {
        self.inner.set_action(0, action, crossfade)
    }

    /// The next full frame (`frame_dims` values); see [`BatchGenerator::step`].
    pub fn step(&mut self) -> Result<&[f32], GenerateError> {
        let frames = self.inner.step()?;
        Ok(frames.to_slice().expect("contiguous"))
    }

    /// The next full frame, written into `out` (`frame_dims` values).
    pub fn step_into(&mut self, out: &mut [f32]) -> Result<(), GenerateError> {
        let frame = self.step()?;
        if out.len() != frame.len() {
            return Err(GenerateError::WrongWidth {
                expected: frame.len(),
                got: out.len(),
            });
        }
        out.copy_from_slice(frame);
        Ok(())
    }

    /// Convenience: the next `frames` frames as an array `[frames, frame_dims]` (allocates it).
    pub fn generate(&mut self, frames: usize) -> Result<Array2<f32>, GenerateError> {
        let width = self.model().config().frame_dims;
        let mut out = Array2::zeros((frames, width));
        for mut row in out.rows_mut() {
            let frame = self.step()?;
            row.iter_mut().zip(frame).for_each(|(o, v)| *o = *v);
        }
        Ok(out)
    }
}
