//! Motion matching (Clavet 2016; Holden et al. 2020, "Learned Motion Matching", describe the
//! engine practice): a character controller that plays real motion-capture takes, on the takes'
//! own rig, jumping to the frame that best continues the pose toward where the player steers.
//! One door for the whole capability:
//!
//! - **Build** ([`MatchingDatabase::from_takes`]) from takes read by [`crate::takes`] (a folder of
//!   BVH files on any rig, resampled, with trajectories and contacts): every frame with its
//!   matching features ([`features`]: both ankles' positions and velocities and the hips'
//!   velocity now; the ground position and facing 1/3, 2/3 and 1 s ahead; each group normalised
//!   by its spread and weighted, [`DEFAULT_WEIGHTS`]) in a kiddo kd-tree.
//! - **Save and load** ([`MatchingDatabase::save`], [`MatchingDatabase::load`]): one
//!   self-describing safetensors file with the rig, the frames (rotations in f16), the features,
//!   the source takes, a `licence` and a `provenance` ([`file`]).
//! - **Play** ([`Matcher`]): from a seed ([`Matcher::start`]) or the first frame, toward a
//!   [`Goal`](crate::steering::Goal); every [`SEARCH_INTERVAL_S`] while steered (and where a take
//!   ends) it searches the frame whose features are nearest to the current pose's and to the
//!   trajectory the goal asks for (the goal velocity and facing approached with the time
//!   constants of [`crate::steering`]), and jumps there when it is clearly better than playing
//!   on ([`KEEP_PLAYING`]); jumps are inertialized (per joint, the rotation offset and its
//!   velocity decay as a critically damped spring of half-life [`BLEND_HALFLIFE_S`]). The root
//!   moves by the database's own root motion, its heading drawn toward the goal's facing. The
//!   poses then go through the grounding ([`crate::grounding`]), which locks planted feet.
//!
//! Poses are [`Pose`](crate::pose::Pose)s on the database's rig (metres, +y up). No allocation
//! per frame.
//!
//! ```no_run
//! use std::sync::Arc;
//! use motion_core::matching::{Matcher, MatchingDatabase, DEFAULT_WEIGHTS};
//! use motion_core::steering::{Goal, Vec2};
//! use motion_core::takes::{read_takes, TakeOptions};
//!
//! let takes = read_takes("../shared/data/cmu_locomotion".as_ref(), &TakeOptions::default())?;
//! let database = Arc::new(MatchingDatabase::from_takes(&takes, DEFAULT_WEIGHTS)?);
//! let mut matcher = Matcher::new(database);
//! matcher.set_goal(Some(Goal::towards(Vec2::new(1.2, 0.0), 0.0)));
//! for _ in 0..300 {
//!     let pose = matcher.step(); // the next 30 Hz frame
//!     let _ = pose.root_translation;
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
mod database;
pub mod features;
pub mod file;
mod matcher;

pub use database::{DatabaseClip, MatchingDatabase, TakeInfo, DEFAULT_WEIGHTS, SEARCH_INTERVAL_S};
pub use file::{is_database, DatabaseConfig};
pub use matcher::{Matcher, BLEND_HALFLIFE_S, KEEP_PLAYING};

use crate::grounding::LegsError;
use crate::weights::WeightsError;

/// Why a database could not be built, read or played from a seed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MatchingError {
    /// The skeleton's legs were not found (no feet to match).
    #[error("motion matching: {0}")]
    Legs(#[from] LegsError),
    /// No take is long enough to hold a frame to search.
    #[error("motion matching: no take has more than {0} frames")]
    TooShort(usize),
    /// A clip's frames are not of the skeleton's exp-map width.
    #[error("motion matching: clip {clip} has {got} values per frame, the skeleton {want}")]
    Width {
        /// Which clip (0-based).
        clip: usize,
        /// Its width.
        got: usize,
        /// The skeleton's exp-map width.
        want: usize,
    },
    /// A clip holds a value that is not finite.
    #[error("motion matching: clip {clip} frame {frame} holds a value that is not finite")]
    NotFinite {
        /// Which clip (0-based).
        clip: usize,
        /// Which frame (0-based).
        frame: usize,
    },
    /// The frames given cannot make a database.
    #[error("motion matching: {0}")]
    Build(String),
    /// A seed the database cannot continue.
    #[error("motion matching: {0}")]
    Seed(String),
    /// The file could not be read or is not a database.
    #[error(transparent)]
    Weights(#[from] WeightsError),
    /// The file could not be written.
    #[error("{0}")]
    Io(String),
}

#[cfg(test)]
mod tests;
