//! Writing generated clips, the counterpart of [`crate::seed`]: `.bvh` (root integrated, on the
//! model's skeleton or back on the user's rig, at the model's rate or any other), `.npy` or
//! exp-map `.txt`; several samples as `OUT_0`, `OUT_1`, ... or one `.npy` with a samples axis.
//! Every file goes through a temporary file and a rename (the writers of [`crate::formats`] do
//! that).
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ndarray::{Array2, Array3, ArrayView2, Axis};

use crate::error::{FormatError, MotionError};
use crate::formats::bvh::write_bvh;
use crate::formats::expmap_bvh::{expmap_to_bvh, ExpMapTarget};
use crate::formats::h36m_text::write_expmap_text;
use crate::formats::npy::write_npy;
use crate::formats::FileFormat;
use crate::motion::{Motion, MotionLayout};
use crate::resample::resample_bvh;
use crate::retarget::Retargeter;

/// Why a clip could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ClipError {
    /// Writing failed (or the extension names no format).
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The frames do not form a motion on the skeleton.
    #[error(transparent)]
    Motion(#[from] MotionError),
    /// The output cannot be written where it was asked (names the path).
    #[error("{}: {problem}", path.display())]
    Output {
        /// The output path.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// The clips to write: one `frames x frame_dims` exp-map array per sample, all of one length.
pub struct Clips<'a> {
    /// Exp-map frames per sample (root as deltas for H3.6M).
    pub samples: &'a [Array2<f64>],
    /// Their frame rate.
    pub fps: f64,
    /// The rate BVH output is written at (`None`: `fps`).
    pub out_fps: Option<f64>,
    /// The user's rig and its reference frames, when the seed was retargeted: BVH output goes
    /// back onto the rig.
    pub rig: Option<(&'a Retargeter, ArrayView2<'a, f64>)>,
    /// A character's own rig (`--rig FILE.glb`): BVH output is written on it instead
    /// ([`crate::rig_target::RigTarget::to_bvh`]: its joint names, its rest translations as
    /// OFFSETs, metres).
    pub rig_target: Option<&'a crate::rig_target::RigTarget>,
    /// Their skeleton.
    pub target: ExpMapTarget,
}

/// Checks that `out` can be written (known extension, existing directory) before any work.
pub fn check_output(out: &Path) -> Result<FileFormat, ClipError> {
    let format = FileFormat::from_path(out)?;
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(ClipError::Output {
            path: out.to_path_buf(),
            problem: format!("the output directory {} does not exist", dir.display()),
        });
    }
    Ok(format)
}

/// Refuses an output that is one of the command's `inputs` (the same file, whatever the path
/// spelling): writing it would destroy what is being read.
pub fn check_not_an_input(out: &Path, inputs: &[&Path]) -> Result<(), ClipError> {
    let resolve = |p: &Path| -> Option<PathBuf> {
        if let Ok(full) = p.canonicalize() {
            return Some(full);
        }
        // An output that does not exist yet: its directory resolved, its name appended.
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    let Some(target) = resolve(out) else {
        return Ok(());
    };
    for input in inputs {
        if resolve(input).as_deref() == Some(target.as_path()) {
            return Err(ClipError::Output {
                path: out.to_path_buf(),
                problem: format!(
                    "is also an input ({}): writing it would destroy it; choose another output",
                    input.display()
                ),
            });
        }
    }
    Ok(())
}

/// `out` with `_{index}` before its extension (`pred.bvh` -> `pred_0.bvh`, `a.txt.gz` ->
/// `a_0.txt.gz`).
pub fn numbered(out: &Path, index: usize) -> PathBuf {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let lower = name.to_ascii_lowercase();
    let ext_len = [".txt.gz", ".bvh", ".npy", ".txt"]
        .iter()
        .find(|e| lower.ends_with(*e))
        .map_or(0, |e| e.len());
    let (stem, ext) = name.split_at(name.len() - ext_len);
    out.with_file_name(format!("{stem}_{index}{ext}"))
}

/// Writes the clips to `out` in `format`; returns the files written.
pub fn write_clips(
    out: &Path,
    format: FileFormat,
    clips: &Clips<'_>,
) -> Result<Vec<PathBuf>, ClipError> {
    let n = clips.samples.len();
    // Nothing non-finite is written (a seed whose values are out of any range, e.g. a root
    // position of 1e308, can overflow the integration): refused before any file is made.
    for (i, frames) in clips.samples.iter().enumerate() {
        if let Some((index, value)) = frames.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(ClipError::Output {
                path: out.to_path_buf(),
                problem: format!(
                    "sample {i}, frame {}, value {}: {} is not a finite number (the seed's values are out of range); nothing was written",
                    index.0,
                    index.1,
                    crate::motion::compact_number(*value)
                ),
            });
        }
    }
    if format == FileFormat::Npy && n > 1 {
        let (frames, dims) = clips.samples[0].dim();
        let mut stacked = Array3::zeros((n, frames, dims));
        for (mut dst, src) in stacked.axis_iter_mut(Axis(0)).zip(clips.samples) {
            dst.assign(src);
        }
        write_npy(out, &stacked)?;
        return Ok(vec![out.to_path_buf()]);
    }
    let mut written = Vec::with_capacity(n);
    for (i, frames) in clips.samples.iter().enumerate() {
        let path = if n == 1 {
            out.to_path_buf()
        } else {
            numbered(out, i)
        };
        match format {
            FileFormat::Npy => write_npy(&path, frames)?,
            FileFormat::ExpMapText => write_expmap_text(&path, frames.view())?,
            FileFormat::Bvh => {
                let motion = Motion::new(
                    Arc::new(clips.target.skeleton()),
                    MotionLayout::ExpMap {
                        root: clips.target.root(),
                    },
                    frames.clone(),
                    clips.fps,
                )?;
                let bvh = expmap_to_bvh(&motion).map_err(|e| ClipError::Output {
                    path: path.clone(),
                    problem: format!("the prediction cannot be written as BVH: {e}"),
                })?;
                let bvh = match (&clips.rig_target, &clips.rig) {
                    (Some(target), _) => {
                        let poses = crate::takes::poses_of(&bvh.skeleton, &bvh.frames);
                        let mut target = (*target).clone();
                        target
                            .to_bvh(&poses, bvh.fps())
                            .map_err(|e| ClipError::Output {
                                path: path.clone(),
                                problem: format!("the motion cannot be written on the rig: {e}"),
                            })?
                    }
                    (None, Some((retargeter, references))) => {
                        retargeter.to_rig(&bvh, references.view())
                    }
                    (None, None) => bvh,
                };
                let bvh = match clips.out_fps {
                    Some(fps) => resample_bvh(&bvh, fps).map_err(|e| ClipError::Output {
                        path: path.clone(),
                        problem: e.to_string(),
                    })?,
                    None => bvh,
                };
                write_bvh(&path, &bvh)?;
            }
        }
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_names_keep_the_extension() {
        assert_eq!(
            numbered(Path::new("out/pred.bvh"), 0),
            Path::new("out/pred_0.bvh")
        );
        assert_eq!(
            numbered(Path::new("a.txt.gz"), 12),
            Path::new("a_12.txt.gz")
        );
        assert_eq!(numbered(Path::new("P.NPY"), 1), Path::new("P_1.NPY"));
    }
}
