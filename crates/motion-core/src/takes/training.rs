//! Takes written out for training a learned model on their own rig
//! (`training/locomotion.py --takes`): one folder holding
//! - `takes.json`: the [`TrainingManifest`] (rate, frame layout, the rig's rest forward, the
//!   takes and those left out);
//! - `rig.bvh`: the common rig (hierarchy in the rig file's units, one frame of zeros);
//! - `NAME.npy` per take: its frames as exp-map frames on the rig (f64, `[frames, 3 + 3 *
//!   joints]`, [`crate::pose::encode_poses`]): dims 0..5 the root as per-frame deltas in the
//!   previous root frame (mm; each frame spans one frame, `root_step` 1), then one H3.6M-convention
//!   exp-map triple per joint (End Sites and the root's own triple stay zero). Decoding a file
//!   with [`crate::pose::PoseDecoder`] (step 1) on the rig gives the take's poses back, its first
//!   frame at the origin.
//!
//! The folder is written under a temporary name and renamed when complete; an existing folder is
//! never written into.
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{Takes, TakesError};
use crate::formats::bvh::{to_bvh_string, Bvh};
use crate::formats::npy::write_npy;
use crate::pose::encode_poses;
use crate::seed::rescale_bvh;

/// The `format` entry of `takes.json`.
pub const TRAINING_FORMAT: &str = "motion-takes";
/// The `format_version` entry of `takes.json`.
pub const TRAINING_FORMAT_VERSION: u32 = 1;

/// `takes.json` (see the module docs).
#[derive(Debug, Clone, Serialize)]
pub struct TrainingManifest {
    /// [`TRAINING_FORMAT`].
    pub format: String,
    /// [`TRAINING_FORMAT_VERSION`].
    pub format_version: u32,
    /// Frames per second of every take.
    pub fps: f64,
    /// Source frames each frame's root delta spans (1).
    pub root_step: usize,
    /// Values per frame (`3 + 3 * joints`).
    pub frame_dims: usize,
    /// Joints of the rig (End Sites included).
    pub joints: usize,
    /// The pelvis's forward direction in the root's rest frame
    /// ([`crate::steering::rest_forward`]): a frame's heading is `facing_of(R * rest_forward)`.
    pub rest_forward: [f32; 3],
    /// Millimetres per unit of `rig.bvh`.
    pub mm_per_unit: f64,
    /// The rig file inside the folder (`rig.bvh`).
    pub rig_file: String,
    /// Where the rig came from.
    pub rig_source: PathBuf,
    /// The takes written, in file-name order.
    pub takes: Vec<TrainingTake>,
    /// Takes left out by name.
    pub excluded: Vec<String>,
    /// Takes that could not be used, with their reasons.
    pub skipped: Vec<SkippedTake>,
}

/// One take of a [`TrainingManifest`].
#[derive(Debug, Clone, Serialize)]
pub struct TrainingTake {
    /// The take's name (its file name without `.bvh`).
    pub name: String,
    /// Its frames inside the folder (`NAME.npy`).
    pub file: String,
    /// Frames held.
    pub frames: usize,
    /// The BVH file it came from.
    pub source: PathBuf,
    /// The source file's rate (Hz).
    pub source_fps: f64,
    /// Whether it was retargeted onto the rig.
    pub retargeted: bool,
}

/// A take left out of a [`TrainingManifest`] and why.
#[derive(Debug, Clone, Serialize)]
pub struct SkippedTake {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub reason: String,
}

/// Writes `takes` as a training folder `out` (see the module docs; `excluded` is recorded as the
/// takes left out by name) and returns its manifest.
///
/// # Errors
/// `out` exists, the rig cannot be written as BVH, or a file cannot be written (the partial
/// folder is removed).
pub fn write_training_folder(
    takes: &Takes,
    excluded: &[String],
    out: &Path,
) -> Result<TrainingManifest, TakesError> {
    let fail = |problem: String| TakesError::Folder {
        path: out.to_path_buf(),
        problem,
    };
    if out.exists() {
        return Err(fail(
            "exists: the takes are written to a new folder, never into one".into(),
        ));
    }
    let skeleton = takes.rig.skeleton.as_ref();
    let rest_forward = crate::steering::rest_forward(skeleton)
        .map_err(|e| fail(format!("the rig cannot face: {e}")))?;
    let mut manifest = TrainingManifest {
        format: TRAINING_FORMAT.into(),
        format_version: TRAINING_FORMAT_VERSION,
        fps: takes.fps,
        root_step: 1,
        frame_dims: skeleton.expmap_width(),
        joints: skeleton.len(),
        rest_forward: rest_forward.to_array(),
        mm_per_unit: takes.rig.mm_per_unit,
        rig_file: "rig.bvh".into(),
        rig_source: takes.rig.source.clone(),
        takes: Vec::with_capacity(takes.takes.len()),
        excluded: excluded.to_vec(),
        skipped: takes
            .skipped
            .iter()
            .map(|s| SkippedTake {
                path: s.path.clone(),
                reason: s.reason.clone(),
            })
            .collect(),
    };
    let partial = crate::formats::atomic::temp_path(out);
    let written = (|| -> Result<(), String> {
        std::fs::create_dir(&partial).map_err(|e| e.to_string())?;
        let rig = Bvh {
            skeleton: skeleton.clone(),
            frames: ndarray::Array2::zeros((1, skeleton.channel_count())),
            frame_time: 1.0 / takes.fps,
        };
        let rig = rescale_bvh(&rig, 1.0 / takes.rig.mm_per_unit)?;
        let text = to_bvh_string(&rig).map_err(|e| e.to_string())?;
        std::fs::write(partial.join(&manifest.rig_file), text).map_err(|e| e.to_string())?;
        for take in &takes.takes {
            let file = format!("{}.npy", take.name);
            let frames = encode_poses(skeleton, &take.poses, 1);
            write_npy(partial.join(&file), &frames).map_err(|e| e.to_string())?;
            manifest.takes.push(TrainingTake {
                name: take.name.clone(),
                file,
                frames: take.len(),
                source: take.path.clone(),
                source_fps: take.source_fps,
                retargeted: take.retargeted,
            });
        }
        let json = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
        std::fs::write(partial.join("takes.json"), json).map_err(|e| e.to_string())?;
        std::fs::rename(&partial, out).map_err(|e| e.to_string())
    })();
    if let Err(problem) = written {
        let _ = std::fs::remove_dir_all(&partial);
        return Err(fail(problem));
    }
    Ok(manifest)
}
