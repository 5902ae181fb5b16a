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
use super::source::MotionSource;
use crate::grounding::{Grounder, GroundingConfig, GroundingError};
use crate::matching::Matcher;
use crate::motion::FrameScalar;
use crate::pose::{encode_poses, Pose};
use crate::resample::PoseResampler;
use crate::resample::ResampleError;
use crate::skeleton::Skeleton;
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
    /// A motion-matching database was given exp-map frames to start from.
    #[error(
        "a motion-matching database starts from poses on its rig (a BVH seed), not exp-map frames"
    )]
    NeedsPoses,
    /// A learned model was given poses to start from.
    #[error("a learned model starts from exp-map frames (a seed file), not poses")]
    NeedsFrames,
    /// A seed the database cannot continue.
    #[error("{0}")]
    Seed(String),
}

/// What steps a [`Character`]: a generator and its [`PoseStream`], or a motion matcher and a
/// resampler to the engine's rate.
#[derive(Debug)]
enum Driver {
    Model {
        generator: Box<Generator>,
        stream: Box<PoseStream>,
    },
    Matching {
        matcher: Box<Matcher>,
        resampler: Box<PoseResampler>,
        grounding: GroundingConfig,
    },
}

/// One character driven by a learned model or a motion-matching database (see the module docs).
#[derive(Debug)]
pub struct Character {
    driver: Driver,
}

impl Character {
    /// A character driven by `source` (a learned model or a motion-matching database, weights
    /// shared between characters), grounded ([`GroundingConfig::default`]).
    ///
    /// # Errors
    /// A learned model whose skeleton is not the H3.6M one.
    pub fn new(source: impl Into<MotionSource>) -> Result<Character, CharacterError> {
        Character::with_grounding(source, GroundingConfig::default())
    }

    /// A character driven by `source` whose frames are grounded as `grounding` says
    /// ([`GroundingConfig::off`]: the raw motion).
    ///
    /// # Errors
    /// A learned model whose skeleton is not the H3.6M one.
    pub fn with_grounding(
        source: impl Into<MotionSource>,
        grounding: GroundingConfig,
    ) -> Result<Character, CharacterError> {
        let model = match source.into() {
            MotionSource::Model(model) => model,
            MotionSource::Database(db) => {
                let resampler = Box::new(PoseResampler::new(db.skeleton().len(), db.fps()));
                return Ok(Character {
                    driver: Driver::Matching {
                        matcher: Box::new(Matcher::with_grounding(db, grounding)),
                        resampler,
                        grounding,
                    },
                });
            }
        };
        let config = model.config();
        let mut stream = PoseStream::new(
            Arc::clone(model.skeleton()),
            config.fps,
            config.root_step(),
            grounding,
        )?;
        stream.use_control_of(config);
        Ok(Character {
            driver: Driver::Model {
                stream: Box::new(stream),
                generator: Box::new(Generator::new(model)),
            },
        })
    }

    /// Whether a motion-matching database drives this character.
    pub fn is_database(&self) -> bool {
        matches!(self.driver, Driver::Matching { .. })
    }

    /// The frame rate of what drives the character (the model's or the database's, Hz).
    pub fn source_fps(&self) -> f64 {
        match &self.driver {
            Driver::Model { generator, .. } => generator.model().config().fps,
            Driver::Matching { matcher, .. } => matcher.database().fps(),
        }
    }

    /// Grounds the frames after the next [`start`](Self::start) as `grounding` says
    /// ([`GroundingConfig::off`]: the raw motion); the motion under way keeps its own.
    pub fn set_grounding(&mut self, grounding: GroundingConfig) {
        match &mut self.driver {
            Driver::Model { stream, .. } => stream.set_grounding(grounding),
            Driver::Matching {
                grounding: kept, ..
            } => *kept = grounding,
        }
    }

    /// The grounding in force (floor, contacts, lean limit).
    pub fn grounder(&self) -> &Grounder {
        match &self.driver {
            Driver::Model { stream, .. } => stream.grounder(),
            Driver::Matching { matcher, .. } => matcher.grounder(),
        }
    }

    /// The skeleton the poses are on (joint order of [`Pose::local_rotations`]).
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        match &self.driver {
            Driver::Model { stream, .. } => stream.skeleton(),
            Driver::Matching { matcher, .. } => matcher.skeleton(),
        }
    }

    /// The generator (plan horizon, model); `None` for a database.
    pub fn generator_mut(&mut self) -> Option<&mut Generator> {
        match &mut self.driver {
            Driver::Model { generator, .. } => Some(generator),
            Driver::Matching { .. } => None,
        }
    }

    /// The matcher; `None` for a learned model.
    pub fn matcher(&self) -> Option<&Matcher> {
        match &self.driver {
            Driver::Model { .. } => None,
            Driver::Matching { matcher, .. } => Some(matcher),
        }
    }

    /// Seeds the character with `seed` (exp-map frames at the model's rate, at least its
    /// `seed_frames`), conditioned on `action`; returns the pose of the last seed frame, where
    /// the motion continues from (the root integrated over the seed from the origin). A database
    /// starts from poses instead ([`start_poses`](Self::start_poses)).
    pub fn start<T: FrameScalar>(
        &mut self,
        seed: ArrayView2<'_, T>,
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<&Pose, CharacterError> {
        self.start_model_frames(seed, seed, action, noise)
    }

    /// Starts the model on `seed` and the pose stream on `shown` (the same motion, whose first
    /// row may hold the absolute root the model never reads).
    fn start_model_frames<T: FrameScalar, U: FrameScalar>(
        &mut self,
        seed: ArrayView2<'_, T>,
        shown: ArrayView2<'_, U>,
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<&Pose, CharacterError> {
        let Driver::Model { generator, stream } = &mut self.driver else {
            return Err(CharacterError::NeedsPoses);
        };
        generator.start(seed, action, noise)?;
        stream.start(shown, action)?;
        if let Some(control) = stream.control_vector() {
            // A model told where to go reads its first control over the seed too (as in
            // training): seeded again with the control the seed and the goal give.
            generator.set_control(&control)?;
            generator.start(seed, action, noise)?;
        }
        Ok(stream.current())
    }

    /// Seeds the character with `seed`: poses on its skeleton ([`skeleton`](Self::skeleton): a
    /// database's or a rig model's rig, e.g. from [`crate::takes::seed_poses_on_rig`]) at its
    /// rate, oldest first. The motion continues from the last one, in the seed's coordinates. A
    /// learned model reads the last `seed_frames` of them as exp-map frames
    /// ([`crate::pose::encode_poses`]; too few are refused) with `action`.
    pub fn start_poses(&mut self, seed: &[Pose]) -> Result<&Pose, CharacterError> {
        self.start_poses_with(seed, None, Noise::Seed(0))
    }

    /// [`start_poses`](Self::start_poses) with a learned model's action and noise (a database
    /// has neither).
    pub fn start_poses_with(
        &mut self,
        seed: &[Pose],
        action: Option<&str>,
        noise: Noise<'_>,
    ) -> Result<&Pose, CharacterError> {
        if let Driver::Model { generator, stream } = &self.driver {
            let config = generator.model().config();
            let needed = config.seed_frames.max(2);
            if seed.len() < needed {
                return Err(GenerateError::TooFewSeedFrames {
                    needed,
                    got: seed.len(),
                }
                .into());
            }
            let skeleton = stream.skeleton();
            if seed
                .iter()
                .any(|p| p.local_rotations.len() != skeleton.len())
            {
                return Err(CharacterError::Seed(format!(
                    "the seed's poses are not on the model's {}-joint skeleton",
                    skeleton.len()
                )));
            }
            let shown = encode_poses(skeleton, &seed[seed.len() - needed..], config.root_step());
            // The decoder reads the first row as the absolute root (the seed's coordinates); the
            // model reads deltas only: its first row repeats the second's root delta.
            let mut frames = shown.clone();
            let first_delta = shown.slice(ndarray::s![1, 0..6]);
            frames.slice_mut(ndarray::s![0, 0..6]).assign(&first_delta);
            let skip = needed - config.seed_frames;
            return self.start_model_frames(
                frames.slice(ndarray::s![skip.., ..]),
                shown.view(),
                action,
                noise,
            );
        }
        let Driver::Matching {
            matcher,
            resampler,
            grounding,
        } = &mut self.driver
        else {
            unreachable!("a learned model returned above")
        };
        if *matcher.grounder().config() != *grounding {
            let goal = matcher.goal();
            **matcher = Matcher::with_grounding(matcher.database().clone(), *grounding);
            matcher.set_goal(goal);
        }
        let pose = matcher
            .start(seed)
            .map_err(|e| CharacterError::Seed(e.to_string()))?;
        resampler.reset();
        resampler.push(pose)?;
        Ok(resampler.advance(0.0)?)
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
        let Driver::Model { generator, .. } = &self.driver else {
            return Err(CharacterError::NeedsPoses);
        };
        let needed = generator.model().config().seed_frames;
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
    /// pose there, making frames as needed (a database's character that was never started
    /// plays from the database's first frame).
    /// A long `dt` (a hitch) is walked through frame by frame; the pose's root-motion deltas
    /// span all of it.
    pub fn advance(&mut self, dt: f64) -> Result<&Pose, CharacterError> {
        match &mut self.driver {
            Driver::Model { generator, stream } => stream.advance_generating(dt, generator),
            Driver::Matching {
                matcher, resampler, ..
            } => resampler.advance_pulling(dt, |r| {
                r.push(matcher.step())?;
                Ok::<(), CharacterError>(())
            }),
        }
    }

    /// The pose [`advance`](Self::advance) (or a start) last returned.
    pub fn current(&self) -> &Pose {
        match &self.driver {
            Driver::Model { stream, .. } => stream.current(),
            Driver::Matching { resampler, .. } => resampler.current(),
        }
    }

    /// Changes the action without re-seeding ([`Generator::set_action`]); the lean limit
    /// follows it. A database has no actions: it plays its takes whatever the action.
    pub fn set_action(&mut self, action: &str, crossfade: usize) -> Result<(), CharacterError> {
        if let Driver::Model { generator, stream } = &mut self.driver {
            generator.set_action(action, crossfade)?;
            stream.set_action(Some(action));
        }
        Ok(())
    }

    /// Steers the character toward `goal` (a velocity on the floor and a facing; `None`: the
    /// source's own root motion) from the next frame on: a learned model by root-motion warping
    /// ([`crate::steering`]), a model told where to go (`goal-gru`) also by its control vector,
    /// a database by searching for frames that go there; kept across [`start`](Self::start)s.
    pub fn set_goal(&mut self, goal: Option<Goal>) {
        match &mut self.driver {
            Driver::Model { stream, .. } => stream.set_goal(goal),
            Driver::Matching { matcher, .. } => matcher.set_goal(goal),
        }
    }

    /// The goal in force ([`Character::set_goal`]).
    pub fn goal(&self) -> Option<Goal> {
        match &self.driver {
            Driver::Model { stream, .. } => stream.goal(),
            Driver::Matching { matcher, .. } => matcher.goal(),
        }
    }

    /// The heading (yaw about +y, `0` facing +z) of `pose`'s pelvis, the angle a goal's facing
    /// is compared with.
    pub fn heading_of(&self, pose: &Pose) -> f32 {
        match &self.driver {
            Driver::Model { stream, .. } => stream.heading_of(pose),
            Driver::Matching { matcher, .. } => matcher.heading_of(pose),
        }
    }
}

impl Steerable for Character {
    type Error = CharacterError;

    fn skeleton(&self) -> &Skeleton {
        Character::skeleton(self)
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
    use crate::model::MotionModel;

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
