//! Typed errors for reading and writing motion files.
//!
//! Every variant names the file; parse errors also name the 1-based line and what was expected.
use std::path::PathBuf;

/// Why an output could not be written: the source of [`FormatError::Write`], a type of its own so
/// that callers find a failed write in an error's `source()` chain even behind wrappers that
/// forward their source (and tell it from a failed read: exit 1, not 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct WriteFailure(#[source] pub std::io::Error);

/// An error reading or writing a motion file (H3.6M text, BVH, `.npy`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    /// An output could not be written (disk full, permission denied, missing directory): a
    /// failure of the environment rather than of the input, unless the directory is missing.
    /// Nothing is left behind ([`crate::formats::atomic`]).
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: WriteFailure,
    },
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A line of a text format did not parse: names the 1-based line and what was expected.
    #[error("{}:{line}: {problem}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was found and what was expected.
        problem: String,
    },
    /// The content parsed but is inconsistent (frame counts, column counts, shapes, NaN, ...).
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The file's extension names no format this crate reads or writes.
    #[error("{}: unknown motion format (expected .txt, .txt.gz, .bvh or .npy)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
}

/// An invalid skeleton description (from code or from a BVH hierarchy).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SkeletonError {
    /// The skeleton has no joints.
    #[error("skeleton has no joints")]
    Empty,
    /// Joint 0 must be the only root (a joint without parent).
    #[error("joint {index} ({name:?}) has no parent but only joint 0 may be the root")]
    MultipleRoots {
        /// Index of the offending joint.
        index: usize,
        /// Its name.
        name: String,
    },
    /// Joint 0 has a parent.
    #[error("joint 0 ({name:?}) must be the root but has a parent")]
    RootHasParent {
        /// Its name.
        name: String,
    },
    /// A joint's parent does not come before it.
    #[error("joint {index} ({name:?}) has parent {parent}, which does not come before it")]
    ParentNotBefore {
        /// Index of the offending joint.
        index: usize,
        /// Its name.
        name: String,
        /// The parent index given.
        parent: usize,
    },
    /// Two joints share a name.
    #[error("joint name {name:?} is used by joints {first} and {second}")]
    DuplicateName {
        /// The shared name.
        name: String,
        /// First joint with it.
        first: usize,
        /// Second joint with it.
        second: usize,
    },
    /// An End Site has channels or children.
    #[error("end site {index} ({name:?}) {problem}")]
    BadEndSite {
        /// Index of the end site.
        index: usize,
        /// Its name.
        name: String,
        /// What is wrong (has channels / has children).
        problem: &'static str,
    },
    /// A joint lists the same channel twice.
    #[error("joint {index} ({name:?}) lists channel {channel} twice")]
    DuplicateChannel {
        /// Index of the joint.
        index: usize,
        /// Its name.
        name: String,
        /// The repeated channel's BVH name.
        channel: &'static str,
    },
    /// An offset is not finite.
    #[error("joint {index} ({name:?}) has a non-finite offset")]
    NonFiniteOffset {
        /// Index of the joint.
        index: usize,
        /// Its name.
        name: String,
    },
}

/// A motion whose data does not fit its layout, or a window out of range.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MotionError {
    /// The number of channels does not match the layout.
    #[error("motion has {found} channels but its layout needs {expected}")]
    ChannelCount {
        /// Channels the layout needs.
        expected: usize,
        /// Channels the data has.
        found: usize,
    },
    /// The frame rate is not finite or below 1 frame per second.
    #[error("frame rate must be finite and at least 1 frame per second, got {fps}")]
    BadFps {
        /// The rejected frame rate, formatted.
        fps: String,
    },
    /// A window reaches past the last frame.
    #[error("window of {len} frames starting at {start} is out of range for {frames} frames")]
    WindowOutOfRange {
        /// First frame of the window.
        start: usize,
        /// Window length.
        len: usize,
        /// Frames in the motion.
        frames: usize,
    },
}
