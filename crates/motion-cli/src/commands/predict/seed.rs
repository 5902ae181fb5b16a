//! Reading a seed sequence for a model: BVH on the model's skeleton, exp-map text or `.npy`,
//! brought to the model's frame rate and checked for shape and finiteness.
use std::path::Path;

use motion_core::formats::bvh::{read_bvh, Bvh};
use motion_core::formats::expmap_bvh::{bvh_to_expmap, expmap_to_bvh, ExpMapTarget};
use motion_core::formats::h36m_text::read_expmap_text;
use motion_core::formats::npy::read_npy_frames;
use motion_core::formats::FileFormat;
use motion_core::motion::{Motion, MotionLayout};
use motion_core::root::{integrate_root, RootPose};
use motion_core::skeleton::H36M_SOURCE_FPS;
use ndarray::{s, Array2};
use std::sync::Arc;

use crate::commands::UsageError;
use motion_core::resample::resample_bvh;

/// Two frame rates closer than this (relative) are the same: BVH frame times are rounded in files.
const SAME_RATE: f64 = 1e-3;

/// A seed at the model's frame rate.
#[derive(Debug)]
pub struct Seed {
    /// Exp-map frames (`frames x frame_dims`, root as the target's encoding) at the model's rate.
    pub frames: Array2<f64>,
    /// The exact absolute root pose of each frame when the frames alone cannot give it: H3.6M
    /// deltas downsampled from the source rate (integrating the kept deltas twice drifts over a
    /// long take; these come from integrating every source frame).
    pub poses: Option<Vec<RootPose>>,
    /// One-line notices for the user (resampling).
    pub notices: Vec<String>,
}

fn usage(path: &Path, problem: impl std::fmt::Display) -> anyhow::Error {
    UsageError(format!("{}: {problem}", path.display())).into()
}

/// Loads `path` as a seed for a model on `target` running at `fps`. Exp-map files (which carry no
/// rate) are taken to be at `input_fps`.
pub fn load_seed(
    path: &Path,
    target: ExpMapTarget,
    fps: f64,
    input_fps: f64,
) -> anyhow::Result<Seed> {
    let mut notices = Vec::new();
    let mut poses = None;
    let frames = match FileFormat::from_path(path)? {
        FileFormat::Bvh => {
            let mut bvh = read_bvh(path)?;
            check_skeleton(&bvh, target).map_err(|e| usage(path, e))?;
            if let Some(frame) = first_non_finite(&bvh.frames) {
                return Err(usage(
                    path,
                    format!("frame {frame} has a NaN or infinite value"),
                ));
            }
            if !same_rate(bvh.fps(), fps) {
                notices.push(format!(
                    "note: {}: {} Hz resampled to the model's {} Hz (rotations by slerp)",
                    path.display(),
                    round_rate(bvh.fps()),
                    round_rate(fps)
                ));
                bvh = resample_bvh(&bvh, fps);
            }
            bvh_to_expmap(&bvh, target)
                .map_err(|e| usage(path, e))?
                .into_frames()
        }
        format => {
            let frames = if format == FileFormat::Npy {
                read_npy_frames(path)?
            } else {
                read_expmap_text(path)?
            };
            let width = target.skeleton().expmap_width();
            if frames.ncols() != width {
                return Err(usage(
                    path,
                    format!(
                        "{} values per frame, but the model's {} skeleton has {width}",
                        frames.ncols(),
                        target.name()
                    ),
                ));
            }
            if let Some(frame) = first_non_finite(&frames) {
                return Err(usage(
                    path,
                    format!("frame {frame} has a NaN or infinite value"),
                ));
            }
            if target == ExpMapTarget::H36m {
                poses = downsampled_poses(&frames, input_fps, fps);
            }
            resample_expmap(frames, target, input_fps, fps, path, &mut notices)?
        }
    };
    Ok(Seed {
        frames,
        poses,
        notices,
    })
}

/// Exact absolute root poses of H3.6M frames at `from` Hz kept every k-th frame for `to` Hz,
/// when `from` is a whole multiple k > 1 of `to`.
fn downsampled_poses(frames: &Array2<f64>, from: f64, to: f64) -> Option<Vec<RootPose>> {
    let ratio = from / to;
    let k = ratio.round();
    if k < 2.0 || (ratio - k).abs() >= SAME_RATE * k {
        return None;
    }
    let step = ((H36M_SOURCE_FPS / from).round() as usize).max(1);
    let poses = integrate_root(frames.view(), step);
    Some(poses.into_iter().step_by(k as usize).collect())
}

/// Exp-map frames at `from` Hz brought to `to` Hz: a whole ratio keeps every k-th frame (as the
/// H3.6M protocol downsamples, keeping the per-source-frame root deltas), any other ratio goes
/// through BVH and slerp.
fn resample_expmap(
    frames: Array2<f64>,
    target: ExpMapTarget,
    from: f64,
    to: f64,
    path: &Path,
    notices: &mut Vec<String>,
) -> anyhow::Result<Array2<f64>> {
    if same_rate(from, to) {
        return Ok(frames);
    }
    let ratio = from / to;
    let k = ratio.round();
    if k >= 1.0 && (ratio - k).abs() < SAME_RATE * k {
        notices.push(format!(
            "note: {}: read as {} Hz (--input-fps); one frame in {} kept for the model's {} Hz",
            path.display(),
            round_rate(from),
            k as usize,
            round_rate(to)
        ));
        return Ok(frames.slice(s![..;k as usize, ..]).to_owned());
    }
    notices.push(format!(
        "note: {}: read as {} Hz (--input-fps); resampled to the model's {} Hz (rotations by slerp)",
        path.display(),
        round_rate(from),
        round_rate(to)
    ));
    let motion = Motion::new(
        Arc::new(target.skeleton()),
        MotionLayout::ExpMap {
            root: target.root(),
        },
        frames,
        from,
    )
    .map_err(|e| usage(path, e))?;
    let bvh = expmap_to_bvh(&motion).map_err(|e| usage(path, e))?;
    let bvh = resample_bvh(&bvh, to);
    Ok(bvh_to_expmap(&bvh, target)
        .map_err(|e| usage(path, e))?
        .into_frames())
}

/// Checks that the BVH's joints (End Sites aside) are the target skeleton's, in order; the error
/// says what differs.
pub fn check_skeleton(bvh: &Bvh, target: ExpMapTarget) -> Result<(), String> {
    let expected = target.skeleton();
    let found: Vec<&str> = bvh
        .skeleton
        .joints()
        .iter()
        .filter(|j| !j.is_end_site)
        .map(|j| j.name.as_str())
        .collect();
    let first_difference = expected
        .joints()
        .iter()
        .zip(&found)
        .position(|(e, f)| e.name != *f);
    let what = match first_difference {
        None if found.len() == expected.len() => return Ok(()),
        None => format!(
            "the BVH has {} joints, the model's {} skeleton {}",
            found.len(),
            target.name(),
            expected.len()
        ),
        Some(i) => format!(
            "{}first differing joint is #{i}: {:?} in the BVH, {:?} in the model's",
            if found.len() == expected.len() {
                String::new()
            } else {
                format!(
                    "the BVH has {} joints, the model's {}; ",
                    found.len(),
                    expected.len()
                )
            },
            found[i],
            expected.joint(i).name
        ),
    };
    Err(format!(
        "skeleton does not match the model's {} skeleton: {what}",
        target.name()
    ))
}

fn same_rate(a: f64, b: f64) -> bool {
    (a - b).abs() <= SAME_RATE * b
}

/// A rate for messages: 120 rather than 120.00000048.
fn round_rate(fps: f64) -> f64 {
    (fps * 1000.0).round() / 1000.0
}

fn first_non_finite(frames: &Array2<f64>) -> Option<usize> {
    frames
        .rows()
        .into_iter()
        .position(|row| row.iter().any(|v| !v.is_finite()))
}
