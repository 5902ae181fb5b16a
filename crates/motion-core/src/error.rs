//! Typed errors for reading and writing motion files.
//!
//! Every variant names the file; parse errors also name the 1-based line and what was expected.
use std::path::PathBuf;

/// An error reading or writing a motion file (H3.6M text, BVH, `.npy`).
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be opened, read or written.
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
