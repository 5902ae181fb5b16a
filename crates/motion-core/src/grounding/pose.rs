//! [`Grounder`] over engine [`Pose`]s: what [`crate::model::Character`] and the Bevy plugin run
//! between their pose decoder and resampler.
use super::{Grounder, GroundingConfig, GroundingError};
use crate::pose::{root_motion_between, Pose, RootMotion, METRES_PER_MM};
use crate::skeleton::Skeleton;

/// Grounds a stream of poses on the H3.6M-unit (millimetre) skeleton they are posed on: observe
/// the seed's poses, then ground each later one into a pose of its own, root motion included.
/// No allocation per pose.
#[derive(Debug, Clone)]
pub struct PoseGrounder {
    grounder: Grounder,
    out: Pose,
    previous: Option<RootMotion>,
    frame_time: f32,
}

impl PoseGrounder {
    /// A grounder of poses on `skeleton` (offsets in millimetres) arriving every `frame_time`
    /// seconds.
    ///
    /// # Errors
    /// A skeleton without two legs.
    pub fn new(
        skeleton: &Skeleton,
        frame_time: f32,
        config: GroundingConfig,
    ) -> Result<PoseGrounder, GroundingError> {
        Ok(PoseGrounder {
            grounder: Grounder::new(skeleton, METRES_PER_MM as f32, config)?,
            out: Pose::rest(skeleton.len()),
            previous: None,
            frame_time,
        })
    }

    /// The grounder (floor, contacts, lean limit).
    pub fn grounder(&self) -> &Grounder {
        &self.grounder
    }

    /// Forgets everything; `action` sets the lean limit.
    pub fn reset(&mut self, action: Option<&str>) {
        self.grounder.reset();
        self.grounder.set_action(action);
        self.previous = None;
    }

    /// Whether the root leads the feet ([`Grounder::set_root_leads`]: a steered character).
    pub fn set_root_leads(&mut self, leads: bool) {
        self.grounder.set_root_leads(leads);
    }

    /// The source's own foot contacts for the frames that follow
    /// ([`Grounder::set_source_contacts`]).
    pub fn set_source_contacts(&mut self, contacts: Option<[bool; 2]>) {
        self.grounder.set_source_contacts(contacts);
    }

    /// Sets the lean limit for `action`.
    pub fn set_action(&mut self, action: Option<&str>) {
        self.grounder.set_action(action);
    }

    /// Feeds one seed pose to the floor fit.
    pub fn observe_seed(&mut self, pose: &Pose) {
        self.grounder
            .observe_seed(pose.root_translation, &pose.local_rotations);
    }

    /// Grounds on `floor` instead of the one fitted on the seed ([`Grounder::set_floor`]).
    pub fn set_floor(&mut self, floor: super::floor::Floor) {
        self.grounder.set_floor(floor);
    }

    /// `pose` grounded (its root motion against the last grounded pose), or `pose` itself when
    /// grounding is off.
    ///
    /// # Panics
    /// If `pose` has another joint count than the skeleton.
    pub fn ground<'a>(&'a mut self, pose: &'a Pose) -> &'a Pose {
        if !self.grounder.config().enabled {
            return pose;
        }
        let out = &mut self.out;
        out.root_translation = pose.root_translation;
        out.local_rotations.copy_from_slice(&pose.local_rotations);
        self.grounder.ground(
            &mut out.root_translation,
            &mut out.local_rotations,
            self.frame_time,
        );
        out.root_motion = root_motion_between(
            out.root_translation.as_dvec3(),
            out.local_rotations[0].as_dquat(),
            self.previous,
        );
        self.previous = Some(out.root_motion);
        out
    }
}
