//! Model frames in, engine poses out at any rate: the one chain every character front end uses
//! ([`crate::model::Character`], the Bevy plugin's batched characters). Each model frame is
//! decoded into a [`Pose`] (root integrated from the seed, [`PoseDecoder`]), steered toward the
//! character's goal ([`crate::steering`]), grounded ([`crate::grounding`]: the seed's floor,
//! upright, planted feet locked) and held for resampling to the engine's clock
//! ([`PoseResampler`], one model frame of look-ahead). Nothing is allocated per frame.
use std::sync::Arc;

use ndarray::ArrayView2;

use crate::grounding::{Grounder, GroundingConfig, GroundingError, PoseGrounder};
use crate::motion::{FrameScalar, RootEncoding};
use crate::pose::{Pose, PoseDecoder};
use crate::resample::{PoseResampler, ResampleError};
use crate::skeleton::Skeleton;
use crate::steering::{Goal, Steering};

use super::config::ModelConfig;
use super::generate_error::GenerateError;
use super::generator::Generator;
use super::goal_gru::steerable_control_frames;

/// Decoder, steering, grounding and resampler of one character (see the module docs).
#[derive(Debug)]
pub struct PoseStream {
    decoder: PoseDecoder,
    steering: Steering,
    grounder: PoseGrounder,
    resampler: PoseResampler,
    /// The grounding the next start uses.
    grounding: GroundingConfig,
    frame_time: f32,
}

impl PoseStream {
    /// A stream of poses on `skeleton` from model frames at `fps` whose root deltas each span
    /// `root_step` source frames (H3.6M at 25 Hz: 2), grounded as `grounding` says.
    ///
    /// # Errors
    /// A skeleton without two legs (nothing to ground or face by).
    pub fn new(
        skeleton: Arc<Skeleton>,
        fps: f64,
        root_step: usize,
        grounding: GroundingConfig,
    ) -> Result<PoseStream, GroundingError> {
        let frame_time = (1.0 / fps) as f32;
        Ok(PoseStream {
            grounder: PoseGrounder::new(&skeleton, frame_time, grounding)?,
            steering: Steering::new(&skeleton, frame_time)?,
            resampler: PoseResampler::new(skeleton.len(), fps),
            decoder: PoseDecoder::new(skeleton, RootEncoding::Deltas, root_step),
            grounding,
            frame_time,
        })
    }

    /// Grounds the frames after the next [`start`](Self::start) as `grounding` says; the motion
    /// under way keeps its own.
    pub fn set_grounding(&mut self, grounding: GroundingConfig) {
        self.grounding = grounding;
    }

    /// Starts over from `seed` (model frames, oldest first) doing `action` (the grounding's lean
    /// limit): the seed is decoded and measured for the floor, and its last pose is the first
    /// output. The goal is kept.
    ///
    /// # Errors
    /// A grounding that cannot be made for the skeleton.
    pub fn start<T: FrameScalar>(
        &mut self,
        seed: ArrayView2<'_, T>,
        action: Option<&str>,
    ) -> Result<&Pose, GroundingError> {
        if *self.grounder.grounder().config() != self.grounding {
            self.grounder =
                PoseGrounder::new(self.decoder.skeleton(), self.frame_time, self.grounding)?;
        }
        self.decoder.reset();
        self.resampler.reset();
        self.grounder.reset(action);
        self.grounder.set_root_leads(self.steering.goal().is_some());
        self.steering.clear_seed();
        for row in seed.rows() {
            let pose = match row.as_slice() {
                Some(frame) => self.decoder.push(frame),
                None => {
                    let owned: Vec<T> = row.iter().copied().collect();
                    self.decoder.push(&owned)
                }
            };
            self.grounder.observe_seed(pose);
            self.steering.observe_seed(pose);
        }
        self.steering.reset(self.decoder.pose());
        self.resampler
            .push(self.grounder.ground(self.decoder.pose()))
            .expect("an empty resampler takes a pose of its skeleton");
        Ok(self
            .resampler
            .advance(0.0)
            .expect("the pose just pushed is there"))
    }

    /// Takes the next model frame (decoded, steered, grounded, held for resampling).
    ///
    /// # Errors
    /// The resampler already holds all it can ([`PoseStream::needs`] says when to push).
    pub fn push<T: FrameScalar>(&mut self, frame: &[T]) -> Result<(), ResampleError> {
        let pose = self.decoder.push(frame);
        self.resampler
            .push(self.grounder.ground(self.steering.steer(pose)))
    }

    /// Whether [`advance`](Self::advance)`(dt)` needs another model frame first.
    pub fn needs(&self, dt: f64) -> bool {
        self.resampler.needs(dt)
    }

    /// Moves the clock by `dt` seconds with the frames pushed so far.
    ///
    /// # Errors
    /// A bad step, or one past the newest frame.
    pub fn advance(&mut self, dt: f64) -> Result<&Pose, ResampleError> {
        self.resampler.advance(dt)
    }

    /// Moves the clock by `dt` seconds (any length), stepping `generator` for each model frame
    /// it needs (a hitch is walked through a frame at a time; the root-motion deltas span `dt`).
    ///
    /// # Errors
    /// The generator's, or a bad step.
    pub fn advance_generating<E: From<ResampleError> + From<GenerateError>>(
        &mut self,
        dt: f64,
        generator: &mut Generator,
    ) -> Result<&Pose, E> {
        let (decoder, steering, grounder) =
            (&mut self.decoder, &mut self.steering, &mut self.grounder);
        self.resampler.advance_pulling(dt, |resampler| {
            if let Some(control) = steering.control_vector() {
                generator.set_control(&control)?;
            }
            let frame = generator.step()?;
            resampler.push(grounder.ground(steering.steer(decoder.push(frame))))?;
            Ok(())
        })
    }

    /// The pose [`advance`](Self::advance) last returned.
    pub fn current(&self) -> &Pose {
        self.resampler.current()
    }

    /// The skeleton of the poses.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        self.decoder.skeleton()
    }

    /// The grounding in force.
    pub fn grounder(&self) -> &Grounder {
        self.grounder.grounder()
    }

    /// The action whose lean limit the grounding holds.
    pub fn set_action(&mut self, action: Option<&str>) {
        self.grounder.set_action(action);
    }

    /// Steers toward `goal` from the next frame ([`Steering::set_goal`]); while a goal is set the
    /// root leads the grounding's held feet ([`Grounder::set_root_leads`]).
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        self.steering.set_goal(goal);
        self.grounder.set_root_leads(goal.is_some());
    }

    /// Steers a model that reads a control vector (`goal-gru` with 3 control values) by that
    /// control too ([`Steering::use_control`]).
    pub fn use_control_of(&mut self, config: &ModelConfig) {
        if let Some(frames) = steerable_control_frames(config) {
            self.steering.use_control(frames);
        }
    }

    /// The control vector for the model's next step (`None`: the model reads none).
    pub fn control_vector(&self) -> Option<[f32; 3]> {
        self.steering.control_vector()
    }

    /// The goal in force.
    pub fn goal(&self) -> Option<Goal> {
        self.steering.goal()
    }

    /// The heading of `pose`'s pelvis ([`Steering::heading_of`]).
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        self.steering.heading_of(pose)
    }
}
