//! Many characters of one model stepped as one batch: a [`Crowd`] holds a [`BatchGenerator`]
//! stepped once per model frame for every member, and each member's [`PoseStream`] (decoding,
//! steering, grounding, resampling to any clock), as [`Character`](super::Character) does for
//! one. Engines with many characters (the Bevy plugin) drive this.
//!
//! A crowd of a motion-matching database ([`Crowd::new`] with a [`MotionSource::Database`]) holds
//! one [`Character`](super::Character) per member instead (a database has no batch to share):
//! members join with [`Crowd::add_poses`], and the rest of the API is the same.
//!
//! Members join and leave at any time: the batch restarts on the next
//! [`advance`](Crowd::advance), every member re-seeded from the last `seed_frames` frames it
//! generated (its seed at first), so the motion goes on from where it was; each draws noise
//! from its own `rng_seed`. Between membership changes an advance allocates nothing of its own
//! (a batch of 16 or more rows steps in shards over the rayon pool; see [`BatchGenerator`]).
//!
//! ```no_run
//! use motion_core::grounding::GroundingConfig;
//! use motion_core::model::{Crowd, MotionModel};
//! use std::sync::Arc;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = Arc::new(MotionModel::load("weights/intention_actions.safetensors")?);
//! let seed = ndarray::Array2::<f32>::zeros((50, model.config().frame_dims));
//! let mut crowd = Crowd::new(model)?;
//! let a = crowd.add(seed.view(), Some("walking"), 1, GroundingConfig::default())?;
//! let b = crowd.add(seed.view(), Some("eating"), 2, GroundingConfig::default())?;
//! for _ in 0..120 {
//!     crowd.advance(1.0 / 60.0)?; // both characters, one batch step per model frame
//!     let _walker = crowd.pose(a).expect("a member");
//! }
//! crowd.set_action(b, "smoking")?;
//! # Ok(())
//! # }
//! ```
use std::collections::VecDeque;
use std::sync::Arc;

use ndarray::{s, Array2, Array3, ArrayView2};

use super::batch::{BatchGenerator, Noise};
use super::character::CharacterError;
use super::generate_error::GenerateError;
use super::pose_stream::PoseStream;
use super::predictor::MotionModel;
use super::source::MotionSource;
use super::Character;
use crate::grounding::GroundingConfig;
use crate::motion::FrameScalar;
use crate::pose::Pose;
use crate::skeleton::Skeleton;
use crate::steering::Goal;

/// A member of a [`Crowd`] (unique within it, never reused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MemberId(u64);

/// One member's row.
#[derive(Debug)]
struct Member {
    id: MemberId,
    action: Option<String>,
    rng_seed: u64,
    stream: PoseStream,
    /// Generated frames not yet decoded (`frame_dims` floats each).
    pending: VecDeque<f32>,
    /// The last `seed_frames` frames, a ring (`next` is the oldest): what a restart re-seeds from.
    history: Array2<f32>,
    next: usize,
    scratch: Vec<f32>,
}

impl Member {
    fn remember(&mut self, frame: &[f32]) {
        self.history
            .row_mut(self.next)
            .as_slice_mut()
            .expect("contiguous")
            .copy_from_slice(frame);
        self.next = (self.next + 1) % self.history.nrows();
    }

    /// Feeds the resampler from `pending` until it can advance by `dt` or `pending` runs out;
    /// whether it still needs a frame.
    fn feed(&mut self, dt: f64) -> Result<bool, CharacterError> {
        let dims = self.scratch.len();
        while self.stream.needs(dt) {
            if self.pending.is_empty() {
                return Ok(true);
            }
            for (dst, v) in self.scratch.iter_mut().zip(self.pending.drain(..dims)) {
                *dst = v;
            }
            self.stream.push(&self.scratch)?;
        }
        Ok(false)
    }
}

/// A member of a database's crowd: its character and its current pose.
#[derive(Debug)]
struct Player {
    id: MemberId,
    character: Character,
    pose: Pose,
}

/// Characters of one model stepped as one batch, or of one motion-matching database (see the
/// module docs).
#[derive(Debug)]
pub struct Crowd {
    source: MotionSource,
    /// The learned model (`None`: a database's crowd, whose members are `players`).
    model: Option<Arc<MotionModel>>,
    players: Vec<Player>,
    skeleton: Arc<Skeleton>,
    root_step: usize,
    members: Vec<Member>,
    batch: Option<BatchGenerator>,
    /// Whether membership changed since the batch started.
    dirty: bool,
    next_id: u64,
}

impl Crowd {
    /// An empty crowd of `source`'s characters (a learned model, or a motion-matching database).
    ///
    /// # Errors
    /// None today (the `Result` is kept for sources that cannot make a crowd).
    pub fn new(source: impl Into<MotionSource>) -> Result<Crowd, CharacterError> {
        let source = source.into();
        let Some(model) = source.model().cloned() else {
            return Ok(Crowd {
                skeleton: source.skeleton(),
                source,
                model: None,
                players: Vec::new(),
                root_step: 1,
                members: Vec::new(),
                batch: None,
                dirty: false,
                next_id: 0,
            });
        };
        let root_step = model.config().root_step();
        let skeleton = Arc::clone(model.skeleton());
        Ok(Crowd {
            source,
            model: Some(model),
            players: Vec::new(),
            skeleton,
            root_step,
            members: Vec::new(),
            batch: None,
            dirty: false,
            next_id: 0,
        })
    }

    /// The learned model (`None`: a database's crowd).
    pub fn model(&self) -> Option<&Arc<MotionModel>> {
        self.model.as_ref()
    }

    /// What drives the members.
    pub fn source(&self) -> &MotionSource {
        &self.source
    }

    /// The skeleton of the poses.
    pub fn skeleton(&self) -> &Arc<Skeleton> {
        &self.skeleton
    }

    /// Members.
    pub fn len(&self) -> usize {
        self.members.len() + self.players.len()
    }

    /// Whether the crowd has no member.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every member, in the order they joined.
    pub fn members(&self) -> impl Iterator<Item = MemberId> + '_ {
        self.members
            .iter()
            .map(|m| m.id)
            .chain(self.players.iter().map(|p| p.id))
    }

    /// A new member of a database's crowd continuing `seed` (poses on the database's rig at its
    /// rate, oldest first: [`crate::takes::seed_poses_on_rig`]; empty: the database's first
    /// frame), grounded as `grounding` says; its first pose is there at once.
    ///
    /// # Errors
    /// A learned model's crowd ([`CharacterError::NeedsFrames`]: use [`add`](Self::add)), or a
    /// seed of another joint count or with a non-finite value.
    pub fn add_poses(
        &mut self,
        seed: &[Pose],
        grounding: GroundingConfig,
    ) -> Result<MemberId, CharacterError> {
        if self.model.is_some() {
            return Err(CharacterError::NeedsFrames);
        }
        let mut character = Character::with_grounding(self.source.clone(), grounding)?;
        let pose = if seed.is_empty() {
            character.advance(0.0)?.clone()
        } else {
            character.start_poses(seed)?.clone()
        };
        let id = MemberId(self.next_id);
        self.next_id += 1;
        self.players.push(Player {
            id,
            character,
            pose,
        });
        Ok(id)
    }

    /// A new member seeded from the last `seed_frames` frames of `clip` (exp-map frames at the
    /// model's rate: a loaded seed file, [`crate::seed`]) doing `action`, drawing noise from
    /// `rng_seed`, grounded as `grounding` says; it moves from the next
    /// [`advance`](Self::advance) on, its first pose (the last seed frame's) is there at once.
    ///
    /// # Errors
    /// A database's crowd ([`CharacterError::NeedsPoses`]: use [`add_poses`](Self::add_poses));
    /// a clip shorter than `seed_frames`, of the wrong width or with a non-finite value; an
    /// action the model does not know (or none for an action-conditioned model).
    pub fn add<T: FrameScalar>(
        &mut self,
        clip: ArrayView2<'_, T>,
        action: Option<&str>,
        rng_seed: u64,
        grounding: GroundingConfig,
    ) -> Result<MemberId, CharacterError> {
        let Some(model) = self.model.clone() else {
            return Err(CharacterError::NeedsPoses);
        };
        let config = model.config();
        let (needed, dims) = (config.seed_frames, config.frame_dims);
        if clip.nrows() < needed {
            return Err(GenerateError::TooFewSeedFrames {
                needed,
                got: clip.nrows(),
            }
            .into());
        }
        if clip.ncols() != dims {
            return Err(GenerateError::WrongWidth {
                expected: dims,
                got: clip.ncols(),
            }
            .into());
        }
        let window = clip.slice_move(s![clip.nrows() - needed.., ..]);
        let history = window.mapv(|v| v.to_f64() as f32);
        if let Some(((frame, dim), &value)) = history.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(GenerateError::NonFiniteSeed {
                character: self.members.len(),
                frame,
                dim,
                value: f64::from(value),
            }
            .into());
        }
        let action = check_action(&model, action)?;
        let mut stream =
            PoseStream::new(self.skeleton.clone(), config.fps, self.root_step, grounding)?;
        stream.use_control_of(config);
        stream.start(history.view(), action.as_deref())?;
        let id = MemberId(self.next_id);
        self.next_id += 1;
        self.members.push(Member {
            id,
            action,
            rng_seed,
            stream,
            pending: VecDeque::with_capacity(8 * dims),
            history,
            next: 0,
            scratch: vec![0.0; dims],
        });
        self.dirty = true;
        Ok(id)
    }

    /// Removes a member (the others go on from where they are); whether it was one.
    pub fn remove(&mut self, id: MemberId) -> bool {
        let before = self.members.len();
        self.members.retain(|m| m.id != id);
        let removed = self.members.len() != before;
        self.dirty |= removed;
        let players = self.players.len();
        self.players.retain(|p| p.id != id);
        removed || self.players.len() != players
    }

    /// The current pose of a member.
    pub fn pose(&self, id: MemberId) -> Option<&Pose> {
        match self.player(id) {
            Some(p) => Some(&p.pose),
            None => self.member(id).map(|m| m.stream.current()),
        }
    }

    /// The heading (yaw about +y, `0` facing +z) of a member's pose's pelvis.
    pub fn heading_of(&self, id: MemberId, pose: &Pose) -> Option<f32> {
        match self.player(id) {
            Some(p) => Some(p.character.heading_of(pose)),
            None => self.member(id).map(|m| m.stream.heading_of(pose)),
        }
    }

    /// A member's action.
    pub fn action(&self, id: MemberId) -> Option<&str> {
        self.member(id).and_then(|m| m.action.as_deref())
    }

    /// Steers a member toward `goal` (`None`: the model's own root motion) from its next model
    /// frame on; whether it is a member.
    pub fn set_goal(&mut self, id: MemberId, goal: Option<Goal>) -> bool {
        if let Some(p) = self.players.iter_mut().find(|p| p.id == id) {
            p.character.set_goal(goal);
            return true;
        }
        match self.members.iter_mut().find(|m| m.id == id) {
            Some(m) => {
                m.stream.set_goal(goal);
                true
            }
            None => false,
        }
    }

    /// Switches a member to `action` from its next model frame on, without re-seeding (a
    /// database's member has no actions: ignored).
    ///
    /// # Errors
    /// Not a member ([`GenerateError::NoSuchRow`]), an action the model does not know, or a
    /// model without actions.
    pub fn set_action(&mut self, id: MemberId, action: &str) -> Result<(), CharacterError> {
        let Some(model) = self.model.clone() else {
            if self.player(id).is_none() {
                return Err(GenerateError::NoSuchRow {
                    row: id.0 as usize,
                    batch: self.players.len(),
                }
                .into());
            }
            return Ok(());
        };
        let row = self
            .members
            .iter()
            .position(|m| m.id == id)
            .ok_or(GenerateError::NoSuchRow {
                row: id.0 as usize,
                batch: self.members.len(),
            })?;
        let known = check_action(&model, Some(action))?;
        if let (Some(batch), false) = (self.batch.as_mut(), self.dirty) {
            batch.set_action(row, action, 0)?;
        }
        let m = &mut self.members[row];
        m.action = known;
        m.stream.set_action(Some(action));
        Ok(())
    }

    /// Moves every member's clock by `dt` seconds (any rate, variable steps; a long `dt` is
    /// walked through a model frame at a time), stepping the batch as often as the member that
    /// needs most frames asks.
    ///
    /// # Errors
    /// A bad time step, or the generator failed (a non-finite output).
    pub fn advance(&mut self, dt: f64) -> Result<(), CharacterError> {
        for p in &mut self.players {
            p.pose.clone_from(p.character.advance(dt)?);
        }
        let Some(model) = self.model.clone() else {
            return Ok(());
        };
        if self.members.is_empty() {
            return Ok(());
        }
        if self.dirty || self.batch.is_none() {
            self.restart(&model)?;
        }
        let frame = 1.0 / model.config().fps;
        let mut left = dt;
        loop {
            let step = left.min(frame);
            left -= step;
            self.tick(step)?;
            if left <= 0.0 {
                return Ok(());
            }
        }
    }

    fn member(&self, id: MemberId) -> Option<&Member> {
        self.members.iter().find(|m| m.id == id)
    }

    fn player(&self, id: MemberId) -> Option<&Player> {
        self.players.iter().find(|p| p.id == id)
    }

    /// A new batch of every member, each re-seeded from its history.
    fn restart(&mut self, model: &Arc<MotionModel>) -> Result<(), CharacterError> {
        let config = model.config();
        let (rows, len, dims) = (self.members.len(), config.seed_frames, config.frame_dims);
        let mut seeds = Array3::<f32>::zeros((rows, len, dims));
        for (i, m) in self.members.iter().enumerate() {
            let oldest = m.next;
            let mut out = seeds.slice_mut(s![i, .., ..]);
            out.slice_mut(s![..len - oldest, ..])
                .assign(&m.history.slice(s![oldest.., ..]));
            out.slice_mut(s![len - oldest.., ..])
                .assign(&m.history.slice(s![..oldest, ..]));
        }
        let actions: Vec<&str> = if config.actions.is_empty() {
            Vec::new()
        } else {
            self.members
                .iter()
                .map(|m| m.action.as_deref().unwrap_or_default())
                .collect()
        };
        let noise: Vec<Noise<'_>> = self
            .members
            .iter()
            .map(|m| Noise::Seed(m.rng_seed))
            .collect();
        let mut batch = BatchGenerator::new(Arc::clone(model), rows);
        set_controls(&self.members, &mut batch)?;
        batch.start(seeds.view(), &actions, &noise)?;
        self.batch = Some(batch);
        self.dirty = false;
        Ok(())
    }

    /// Moves every member's clock by `dt` (at most one model frame).
    fn tick(&mut self, dt: f64) -> Result<(), CharacterError> {
        let batch = self.batch.as_mut().ok_or(GenerateError::NotStarted)?;
        loop {
            let mut starving = false;
            for m in &mut self.members {
                starving |= m.feed(dt)?;
            }
            if !starving {
                break;
            }
            set_controls(&self.members, batch)?;
            let frames = batch.step()?;
            for (m, frame) in self.members.iter_mut().zip(frames.rows()) {
                let frame = frame.to_slice().expect("contiguous rows");
                m.pending.extend(frame);
                m.remember(frame);
            }
        }
        for m in &mut self.members {
            m.stream.advance(dt)?;
        }
        Ok(())
    }
}

/// Each member's control (a model that reads one) from its goal and the frames its stream has
/// taken, into its batch row.
fn set_controls(members: &[Member], batch: &mut BatchGenerator) -> Result<(), GenerateError> {
    for (i, m) in members.iter().enumerate() {
        if let Some(control) = m.stream.control_vector() {
            batch.set_control(i, &control)?;
        }
    }
    Ok(())
}

/// `action` checked against the model's labels (`None` for a model without actions).
fn check_action(
    model: &MotionModel,
    action: Option<&str>,
) -> Result<Option<String>, GenerateError> {
    let config = model.config();
    if config.actions.is_empty() {
        return Ok(None);
    }
    let action = action.ok_or_else(|| GenerateError::MissingAction {
        valid: config.actions.clone(),
    })?;
    if config.action_index(action).is_none() {
        return Err(GenerateError::UnknownAction {
            label: action.to_string(),
            valid: config.actions.clone(),
        });
    }
    Ok(Some(action.to_string()))
}

#[cfg(test)]
mod tests;
