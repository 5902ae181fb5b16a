//! Motion file formats: H3.6M exp-map text, BVH and `.npy`.
use std::path::Path;

use crate::error::FormatError;

pub mod atomic;
pub mod bvh;
pub mod expmap_bvh;
pub mod h36m_text;
pub mod npy;
pub mod npy_stream;
pub mod pose_bvh;

/// A motion file format, as named by a file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// Exp-map text, `.txt` or gzip `.txt.gz` (see [`h36m_text`]).
    ExpMapText,
    /// BVH, `.bvh` (see [`bvh`]).
    Bvh,
    /// NumPy `.npy` (see [`npy`]).
    Npy,
}

impl FileFormat {
    /// The format named by the extension of `path` (case-insensitive): `.txt`, `.txt.gz`, `.bvh`
    /// or `.npy`; anything else is [`FormatError::UnknownFormat`].
    pub fn from_path(path: &Path) -> Result<FileFormat, FormatError> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if name.ends_with(".txt") || name.ends_with(".txt.gz") {
            Ok(FileFormat::ExpMapText)
        } else if name.ends_with(".bvh") {
            Ok(FileFormat::Bvh)
        } else if name.ends_with(".npy") {
            Ok(FileFormat::Npy)
        } else {
            Err(FormatError::UnknownFormat {
                path: path.to_path_buf(),
            })
        }
    }
}
