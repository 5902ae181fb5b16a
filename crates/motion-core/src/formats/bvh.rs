//! BVH (Biovision Hierarchy) files: a reader and a writer of our own.
//!
//! The reader accepts any hierarchy (one `ROOT`, nested `JOINT`s, `End Site`s), `OFFSET`,
//! `CHANNELS` with 0 to 6 channels in any order on any joint, `MOTION`, `Frames:` and
//! `Frame Time:`. It tolerates tabs, CRLF line ends, odd spacing, trailing whitespace, blank
//! lines, a byte order mark, keywords in any case and a `{` on the keyword's line. Every malformed
//! input is a [`FormatError::Parse`] naming the file, the 1-based line and what was expected; it
//! never panics and never allocates more than the size of the file allows, whatever `Frames:` says.
//! A `Frames:` count that disagrees with the number of frame lines is an error giving both.
//!
//! In memory ([`Bvh`]) the channel values are exactly those of the file: rotations in **degrees**,
//! positions in the file's units (the channel FK of [`crate::kinematics`] reads them so). An `End Site` becomes a joint without channels
//! ([`Joint::is_end_site`](crate::skeleton::Joint::is_end_site)) named `<parent>_End`. A `JOINT`
//! without children is accepted (and written) as is: the H3.6M skeleton's "Site" leaves are such
//! joints, because the data has an exp-map triple for each of them.
//!
//! The writer uses the standard layout (tabs, one frame per line) and Rust's shortest
//! round-trip representation of each number, so a written file reads back to the same values.
use std::path::Path;
use std::sync::Arc;

use ndarray::Array2;

use crate::error::{FormatError, MotionError};
use crate::motion::{Motion, MotionLayout};
use crate::skeleton::Skeleton;

mod parse;
mod write;

pub use parse::MAX_CHANNEL_MAGNITUDE;
pub use write::write_to;

/// A BVH file in memory: the hierarchy, the frames and the frame time.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// The hierarchy, with each joint's channels in file order.
    pub skeleton: Skeleton,
    /// Frames x channels, in the skeleton's channel order; rotations in degrees.
    pub frames: Array2<f64>,
    /// Seconds per frame (`Frame Time:`).
    pub frame_time: f64,
}

impl Bvh {
    /// Frames per second (`1 / frame_time`).
    pub fn fps(&self) -> f64 {
        1.0 / self.frame_time
    }

    /// The motion in the [`MotionLayout::Channels`] layout (values as in the file).
    pub fn to_motion(&self) -> Result<Motion, MotionError> {
        Motion::new(
            Arc::new(self.skeleton.clone()),
            MotionLayout::Channels,
            self.frames.clone(),
            self.fps(),
        )
    }

    /// A BVH of a motion in the [`MotionLayout::Channels`] layout (`None` for exp-map motions:
    /// convert those with [`crate::formats::expmap_bvh::expmap_to_bvh`]).
    pub fn from_motion(motion: &Motion) -> Option<Bvh> {
        (motion.layout() == MotionLayout::Channels).then(|| Bvh {
            skeleton: (**motion.skeleton()).clone(),
            frames: motion.frames().to_owned(),
            frame_time: motion.frame_time(),
        })
    }
}

/// Reads a `.bvh` file.
pub fn read_bvh(path: impl AsRef<Path>) -> Result<Bvh, FormatError> {
    let path = path.as_ref();
    let bytes = crate::input_file::read_regular(path).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        FormatError::Parse {
            path: path.to_path_buf(),
            line,
            problem: "expected UTF-8 text".to_string(),
        }
    })?;
    parse_bvh(text, path)
}

/// Parses BVH text; `path` only names the source in errors.
pub fn parse_bvh(text: &str, path: impl AsRef<Path>) -> Result<Bvh, FormatError> {
    parse::parse(text, path.as_ref())
}

/// The BVH text of `bvh`.
///
/// # Errors
/// As [`write_to`]: frames that do not fit the skeleton, non-finite values, a bad frame time.
pub fn to_bvh_string(bvh: &Bvh) -> std::io::Result<String> {
    let mut out = Vec::new();
    write_to(&mut out, bvh)?;
    // The writer only emits UTF-8 (joint names are Rust strings).
    String::from_utf8(out).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// Writes `bvh` to `path`, through a temporary file in the same directory renamed into place, so
/// a failure never leaves a half-written file.
pub fn write_bvh(path: impl AsRef<Path>, bvh: &Bvh) -> Result<(), FormatError> {
    super::atomic::write_atomically(path.as_ref(), |w| write_to(&mut *w, bvh))
}
