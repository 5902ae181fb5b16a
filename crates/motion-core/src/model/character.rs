//! One animated character for a game engine: a [`Generator`] whose frames come out as engine
//! [`Pose`]s (f32 glam, metres, root motion split) at whatever rate the engine ticks, with the
//! action switchable mid-stream and the root steerable ([`Character::set_goal`]). It chains
//! closed-loop generation and a [`PoseStream`] (decoding, steering, grounding, resampling) and
//! allocates nothing per tick. Each model frame after the seed is grounded
//! ([`crate::grounding`]: on the seed's floor, upright, feet planted) unless the character was
//! made with [`GroundingConfig::off`].
//!
//! See the crate docs for a complete example.
use std::sync::Arc;

use ndarray::ArrayView2;

use super::batch::Noise;
use super::generate_error::GenerateError;
use super::generator::Generator;
use super::pose_stream::PoseStream;
use super::predictor::MotionModel;
use crate::grounding::{Grounder, GroundingConfig, GroundingError};
use crate::motion::FrameScalar;
use crate::pose::Pose;
use crate::resample::ResampleError;
use crate::skeleton::{Skeleton, H36M_SOURCE_FPS};
use crate::steering::{Goal, Steerable};

/// Why a [`Character`] could not start or advance.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CharacterError {
    /// The generator refused the seed, action or noise, or was not started.
    #[error(transparent)]
    Generate(#[from] GenerateError),
    /// A bad time step.
    #[error(transparent)]
    Resample(#[from] ResampleError),
    /// The model's frames are on a skeleton this crate has no pose layout for.
    #[error("the model's skeleton {0:?} has no built-in pose layout (h36m-32 has)")]
    Skeleton(String),
    /// The skeleton has no legs to ground.
    #[error(transparent)]
    Grounding(#[from] GroundingError),
}

/// A generator and a [`PoseStream`] for one character (see the module docs).
#[derive(Debug)]
pub struct Character {
    generator: Generator,
    stream: PoseStream,
}

impl Character {
    /// A character driven by `model` (weights shared between characters), grounded
    /// ([`GroundingConfig::default`]).
    ///
    /// # Errors
    /// A model whose skeleton is not the H3.6M one.
    pub fn new(model: Arc<MotionModel>) -> Result<Character, CharacterError> {
        Character::with_grounding(model, GroundingConfig::default())
    }

    /// A character driven by `model` whose frames are grounded as `grounding` says
    /// ([`GroundingConfig::off`]: the model's raw motion).
    ///
    /// # Errors
    /// A model whose skeleton is not the H3.6M one.
    pub fn with_grounding(
        model: Arc<MotionModel>,
        grounding: GroundingConfig,
    ) -> Result<Character, CharacterError> {
        let config = model.config();
        if config.skeleton != "h36m-32" {
            return Err(CharacterError::Skeleton(config.skeleton.clone()));
        }
        // H3.6M root deltas are per 50 Hz source frame: a 25 Hz model frame spans 2.
        let step = ((H36M_SOURCE_FPS / config.fps).round() as usize).max(1);
        let mut stream = PoseStream::new(Arc::new(Skeleton::h36m()), config.fps, step, grounding)?;
        stream.use_control_of(config);
        Ok(Character {
            stream,
            generator: Generator::new(model),
        })
    }

    /// Grounds the frames after the next [`start`](Self::start) as `grounding` says
    /// ([`GroundingConfig::off`]: the model's raw motion); the motion under way keeps its own.
    pub fn set_grounding(&mut self, grounding: GroundingConfig) {
        self.stream.set_grounding(grounding);
    }

    /// The grounding in force (floor, contacts, lean limit).
    pub fn grounder(&self) -> &Grounder {
        self.stream.grounder()
    }

    /// The skeleton the poses are on (joint order of [`Pose::local_rotations`]).
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        self.stream.skeleton()
    }

    /// The generator (plan horizon, model).
    pub fn generator_mut(&mut self) -> &mut Generator {
        &mut self.generator
    }

    /// Seeds the character with `seed` (exp-map frames at the model's rate, at least its
    /// `seed_frames`), conditioned on `action`; returns the pose of the last seed frame, where
    /// the motion continues from (the root integrated over the seed from the origin).
    pub fn start<T: FrameScalar>(
        &mut self,
        seed: ArrayView2<'_, T>,
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<&Pose, CharacterError> {
        self.generator.start(seed, action, noise)?;
        self.stream.start(seed, action)?;
        if let Some(control) = self.stream.control_vector() {
            // A model told where to go reads its first control over the seed too (as in
            // training): seeded again with the control the seed and the goal give.
            self.generator.set_control(&control)?;
            self.generator.start(seed, action, noise)?;
        }
        Ok(self.stream.current())
    }

    /// [`start`](Self::start) from the last `seed_frames` frames of a longer clip (a loaded seed
    /// file: [`crate::seed`]); a clip shorter than `seed_frames` is refused
    /// ([`GenerateError::TooFewSeedFrames`]).
    pub fn start_from_clip<T: FrameScalar>(
        &mut self,
        clip: ArrayView2<'_, T>,
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<&Pose, CharacterError> {
        let needed = self.generator.model().config().seed_frames;
        if clip.nrows() < needed {
            return Err(GenerateError::TooFewSeedFrames {
                needed,
                got: clip.nrows(),
            }
            .into());
        }
        let skip = clip.nrows() - needed;
        self.start(clip.slice_move(ndarray::s![skip.., ..]), action, noise)
    }

    /// Moves the character's clock by `dt` seconds (any rate, variable steps) and returns its
    /// pose there, generating model frames as needed.
    /// A long `dt` (a hitch) is walked through frame by frame; the pose's root-motion deltas
    /// span all of it.
    pub fn advance(&mut self, dt: f64) -> Result<&Pose, CharacterError> {
        self.stream.advance_generating(dt, &mut self.generator)
    }

    /// Changes the action without re-seeding ([`Generator::set_action`]); the lean limit
    /// follows it.
    pub fn set_action(&mut self, action: &str, crossfade: usize) -> Result<(), CharacterError> {
        self.generator.set_action(action, crossfade)?;
        self.stream.set_action(Some(action));
        Ok(())
    }

    /// Steers the character toward `goal` (a velocity on the floor and a facing; `None`: the
    /// model's own root motion) from the next model frame on, by root-motion warping
    /// ([`crate::steering`]), and a model told where to go (`goal-gru`) also by its control
    /// vector; kept across [`start`](Self::start)s.
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        self.stream.set_goal(goal);
    }

    /// The goal in force ([`Character::set_goal`]).
    pub fn goal(&self) -> Option<Goal> {
        self.stream.goal()
    }

    /// The heading (yaw about +y, `0` facing +z) of `pose`'s pelvis, the angle a goal's facing
    /// is compared with.
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        self.stream.heading_of(pose)
    }
}

impl Steerable for Character {
    type Error = CharacterError;

    fn skeleton(&self) -> &Skeleton {
        self.stream.skeleton()
    }

    fn set_goal(&mut self, goal: Option<Goal>) {
        Character::set_goal(self, goal);
    }

    fn advance(&mut self, dt: f64) -> Result<&Pose, CharacterError> {
        Character::advance(self, dt)
    }

    fn heading_of(&self, pose: &Pose) -> f32 {
        Character::heading_of(self, pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture() -> Arc<MotionModel> {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/parity/vgru_d.safetensors"
        );
        Arc::new(MotionModel::load(path).unwrap())
    }

    #[test]
    fn ticks_at_60_hz_follow_the_model_frames() {
        let model = fixture();
        let seed = ndarray::Array2::<f32>::from_shape_fn((10, 99), |(t, d)| match d {
            0 => 10.0,
            1..6 => 0.0,
            _ => 0.2 * ((t + d) as f32 * 0.3).sin(),
        });
        let raw = GroundingConfig::off;
        let mut a = Character::with_grounding(Arc::clone(&model), raw()).unwrap();
        let start = a
            .start(seed.view(), Some("walking"), Noise::Seed(4))
            .unwrap()
            .clone();
        // The last seed frame's pose: root integrated over the seed (10 mm x 2 per 25 Hz frame).
        let walked = start.root_motion.ground_translation.length();
        assert!((walked - 0.19).abs() < 1e-4, "{walked}");
        let mut b = Character::with_grounding(model, raw()).unwrap();
        b.start(seed.view(), Some("walking"), Noise::Seed(4))
            .unwrap();
        // 12 ticks of 1/60 s = 5 frames of 1/25 s: both clocks meet there.
        for _ in 0..12 {
            a.advance(1.0 / 60.0).unwrap();
        }
        for _ in 0..5 {
            b.advance(1.0 / 25.0).unwrap();
        }
        let (pa, pb) = (
            a.advance(0.0).unwrap().clone(),
            b.advance(0.0).unwrap().clone(),
        );
        assert!((pa.root_translation - pb.root_translation).length() < 1e-5);
        for (qa, qb) in pa.local_rotations.iter().zip(&pb.local_rotations) {
            assert!(
                qa.abs_diff_eq(*qb, 1e-5) || qa.abs_diff_eq(-*qb, 1e-5),
                "{qa} {qb}"
            );
        }
        // A 0.5 s hitch is walked through: the same pose as 25 steps of 0.02 s, and the root
        // motion's deltas span the whole step.
        let before = a.advance(0.0).unwrap().root_motion;
        let long = a.advance(0.5).unwrap().clone();
        for _ in 0..25 {
            b.advance(0.02).unwrap();
        }
        let short = b.advance(0.0).unwrap().clone();
        assert!((long.root_translation - short.root_translation).length() < 1e-4);
        let moved = long.root_motion.ground_translation - before.ground_translation;
        assert!((long.root_motion.delta_translation - moved).length() < 1e-5);
        assert!(moved.length() > 0.01, "{moved}");
        assert!(a.set_action("eating", 0).is_ok());
        assert!(matches!(
            a.advance(-1.0),
            Err(CharacterError::Resample(ResampleError::BadStep(_)))
        ));
    }

    #[test]
    fn a_grounded_character_stands_on_the_floor_and_ticks_like_the_raw_one() {
        let model = fixture();
        let seed = ndarray::Array2::<f32>::from_shape_fn((10, 99), |(t, d)| match d {
            0 => 10.0,
            1 => 30.0, // the raw root climbs 6 cm a frame
            2..6 => 0.0,
            _ => 0.2 * ((t + d) as f32 * 0.3).sin(),
        });
        let mut grounded = Character::new(Arc::clone(&model)).unwrap();
        let mut raw = Character::with_grounding(model, GroundingConfig::off()).unwrap();
        grounded
            .start(seed.view(), Some("walking"), Noise::Seed(4))
            .unwrap();
        raw.start(seed.view(), Some("walking"), Noise::Seed(4))
            .unwrap();
        let skeleton = Arc::clone(grounded.skeleton());
        let n = skeleton.len();
        let (mut p, mut w) = (vec![glam::Vec3::ZERO; n], vec![glam::Quat::IDENTITY; n]);
        let feet = grounded.grounder().body_parts().legs.clone();
        let mut travelled = 0.0;
        // Model-rate ticks: each pose is a grounded model frame (the fixture's random weights
        // jump too far between frames for an interpolated pose to be checked this tightly).
        for tick in 0..60 {
            let pose = grounded.advance(1.0 / 25.0).unwrap();
            pose.world_positions_into(&skeleton, &mut p, &mut w);
            let lowest = feet
                .iter()
                .flat_map(|l| l.foot_points.iter().map(|&j| p[j].y))
                .fold(f32::INFINITY, f32::min);
            assert!(
                lowest.abs() < 1e-3,
                "tick {tick}: lowest foot point {lowest} m"
            );
            travelled += pose.root_motion.delta_translation.length();
            raw.advance(1.0 / 25.0).unwrap();
        }
        assert!(travelled.is_finite());
    }
}
