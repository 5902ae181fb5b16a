//! The one seed loader every front end uses (CLI, engines, bindings): a BVH on the model's
//! skeleton, exp-map text or `.npy`, by extension; its units checked against the model's skeleton
//! (a BVH in centimetres, metres, inches or any other scale is rescaled with a notice, never used
//! as millimetres); every value finite; brought to the model's frame rate (a whole ratio keeps
//! every k-th frame, any other interpolates by slerp, [`crate::resample`]).
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ndarray::{s, Array2, ArrayView2};

use crate::error::FormatError;
use crate::formats::bvh::{read_bvh, Bvh};
use crate::formats::expmap_bvh::{bvh_to_expmap, expmap_to_bvh, ExpMapTarget};
use crate::formats::h36m_text::read_expmap_text;
use crate::formats::npy::read_npy_frames;
use crate::formats::FileFormat;
use crate::grounding::{ground_expmap_clip, ClipSpec, GroundingConfig, GroundingError};
use crate::motion::{Motion, MotionLayout};
use crate::resample::resample_bvh;
use crate::retarget::{JointMap, Retargeter};
use crate::root::{delta_between, integrate_root, RootPose};
use crate::skeleton::{Skeleton, H36M_SOURCE_FPS};

/// Why a seed could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SeedError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The file was read but cannot seed the model (skeleton, width, values, units); names the
    /// file.
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The seed file.
        path: PathBuf,
        /// What is wrong with it.
        problem: String,
    },
}

/// The slowest BVH seed rate accepted: [`crate::motion::MIN_FPS`], the rule of every command.
pub const MIN_SEED_FPS: f64 = crate::motion::MIN_FPS;
/// The fastest BVH seed rate accepted: [`crate::motion::MAX_FPS`].
pub const MAX_SEED_FPS: f64 = crate::motion::MAX_FPS;

/// The rate an exp-map file (which stores none) is read at unless the caller gives one: H3.6M's
/// 50 Hz. The one default of every front end: `motion-cli --input-fps`, Python's `input_fps`, the
/// C ABI's `motion_generator_start_bvh` (which reads any seed file) and [`load_model_seed`].
pub const DEFAULT_EXPMAP_FILE_FPS: f64 = crate::skeleton::H36M_SOURCE_FPS;

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
    /// One-line notices for the user (resampling, units, retargeting).
    pub notices: Vec<String>,
    /// When the seed was a BVH on another rig: how to write results back onto it.
    pub rig: Option<RigSeed>,
}

/// A seed read from a user's own rig ([`crate::retarget`]).
#[derive(Debug, Clone)]
pub struct RigSeed {
    /// Rig ↔ H3.6M.
    pub retargeter: Retargeter,
    /// The seed's rig frames (BVH channels) at the model's rate: the references of the rig
    /// joints the model does not have ([`Retargeter::to_rig`]).
    pub frames: Array2<f64>,
}

fn usage(path: &Path, problem: impl std::fmt::Display) -> SeedError {
    SeedError::Invalid {
        path: path.to_path_buf(),
        problem: problem.to_string(),
    }
}

/// [`load_seed`] with the front ends' defaults for a model whose frames have `frame_dims` values
/// at `fps`: the built-in skeleton of that width, exp-map files at `input_fps` or else
/// [`DEFAULT_EXPMAP_FILE_FPS`], a foreign BVH rig retargeted by its built-in map.
///
/// # Errors
/// A width no built-in skeleton has, and everything [`load_seed`] refuses.
pub fn load_model_seed(
    path: &Path,
    frame_dims: usize,
    fps: f64,
    input_fps: Option<f64>,
) -> Result<Seed, SeedError> {
    let target = ExpMapTarget::for_frame_dims(frame_dims).ok_or_else(|| {
        usage(
            path,
            format!("the model's frames of {frame_dims} values fit no built-in skeleton (99 = H3.6M, 117 = CMU)"),
        )
    })?;
    load_seed(
        path,
        target,
        fps,
        input_fps.unwrap_or(DEFAULT_EXPMAP_FILE_FPS),
        None,
    )
}

/// Loads `path` as a seed for a model on `target` running at `fps`. Exp-map files (which carry no
/// rate) are taken to be at `input_fps`. A BVH on another rig than the model's is retargeted
/// ([`crate::retarget`]) under `joint_map` (a JSON file) or the built-in map its names fit.
pub fn load_seed(
    path: &Path,
    target: ExpMapTarget,
    fps: f64,
    input_fps: f64,
    joint_map: Option<&Path>,
) -> Result<Seed, SeedError> {
    match FileFormat::from_path(path)? {
        FileFormat::Bvh => seed_from_bvh(read_bvh(path)?, path, target, fps, joint_map),
        FileFormat::Npy => seed_from_expmap(read_npy_frames(path)?, path, target, input_fps, fps),
        FileFormat::ExpMapText => {
            seed_from_expmap(read_expmap_text(path)?, path, target, input_fps, fps)
        }
    }
}

/// [`load_seed`] for exp-map frames already in memory (`frames x (3 + 3k)`, at `input_fps`):
/// width and values checked, brought to the model's `fps`; `label` names them in errors.
pub fn seed_from_expmap(
    frames: Array2<f64>,
    label: &Path,
    target: ExpMapTarget,
    input_fps: f64,
    fps: f64,
) -> Result<Seed, SeedError> {
    let path = label;
    let mut notices = Vec::new();
    let mut poses = None;
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
    let frames = resample_expmap(frames, target, input_fps, fps, path, &mut notices)?;
    Ok(Seed {
        frames,
        poses,
        notices,
        rig: None,
    })
}

/// [`load_seed`] for a BVH already in memory (parsed with
/// [`crate::formats::bvh::parse_bvh`], e.g. in a browser that has no files): `label` names it in
/// errors and notices.
pub fn seed_from_bvh(
    bvh: Bvh,
    label: &Path,
    target: ExpMapTarget,
    fps: f64,
    joint_map: Option<&Path>,
) -> Result<Seed, SeedError> {
    let mut notices = Vec::new();
    let mut rig = None;
    let frames = bvh_frames(bvh, label, target, fps, joint_map, &mut notices, &mut rig)?;
    Ok(Seed {
        frames,
        poses: None,
        notices,
        rig,
    })
}

/// The BVH case of [`load_seed`]: checked, rescaled, retargeted and resampled exp-map frames.
fn bvh_frames(
    mut bvh: Bvh,
    path: &Path,
    target: ExpMapTarget,
    fps: f64,
    joint_map: Option<&Path>,
    notices: &mut Vec<String>,
    rig: &mut Option<RigSeed>,
) -> Result<Array2<f64>, SeedError> {
    // Checked before anything is resampled: a Frame Time in milliseconds (20 for 50 Hz) would
    // otherwise be stretched to thousands of times its frames.
    crate::motion::check_frame_time(bvh.frame_time).map_err(|problem| usage(path, problem))?;
    if let Some(frame) = first_non_finite(&bvh.frames) {
        return Err(usage(
            path,
            format!("frame {frame} has a NaN or infinite value"),
        ));
    }
    let exact = check_skeleton(&bvh, target);
    if exact.is_ok() && joint_map.is_none() {
        let scale = unit_scale(&bvh.skeleton, &target.skeleton()).map_err(|e| usage(path, e))?;
        if !(UNITS_TOLERANCE.recip()..=UNITS_TOLERANCE).contains(&scale) {
            notices.push(format!(
                    "note: {}: the skeleton is {scale:.4} times the model's ({}): rescaled by {:.4}, root motion included",
                    path.display(),
                    units_guess(scale),
                    scale.recip()
                ));
            bvh = rescale_bvh(&bvh, scale.recip()).map_err(|e| usage(path, e))?;
        }
    } else {
        // Another rig: retarget it onto the model's skeleton (H3.6M models only).
        let exact_problem = exact.err().unwrap_or_default();
        if target != ExpMapTarget::H36m {
            return Err(usage(path, exact_problem));
        }
        let map = match joint_map {
            Some(file) => JointMap::read(&bvh.skeleton, file).map_err(|e| usage(path, e))?,
            None => JointMap::detect(&bvh.skeleton)
                .map_err(|e| usage(path, format!("{exact_problem}, and {e}")))?,
        };
        let retargeter = Retargeter::new(&bvh.skeleton, map).map_err(|e| usage(path, e))?;
        notices.push(format!(
                "note: {}: {} rig retargeted onto the model's H3.6M skeleton ({:.4} rig units per mm{})",
                path.display(),
                retargeter.map().name,
                retargeter.scale(),
                match units_guess(retargeter.scale()) {
                    "unknown units" => String::new(),
                    unit => format!(", {unit}"),
                }
            ));
        let frames = if same_rate(bvh.fps(), fps) {
            bvh.frames.clone()
        } else {
            resample_bvh(&bvh, fps).map_err(|e| usage(path, e))?.frames
        };
        let model_bvh = retargeter.to_model(bvh.frames.view(), bvh.frame_time);
        *rig = Some(RigSeed { retargeter, frames });
        bvh = model_bvh;
    }
    if !same_rate(bvh.fps(), fps) {
        notices.push(format!(
            "note: {}: {} Hz resampled to the model's {} Hz (rotations by slerp)",
            path.display(),
            round_rate(bvh.fps()),
            round_rate(fps)
        ));
        bvh = resample_bvh(&bvh, fps).map_err(|e| usage(path, e))?;
    }
    Ok(bvh_to_expmap(&bvh, target)
        .map_err(|e| usage(path, e))?
        .into_frames())
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
) -> Result<Array2<f64>, SeedError> {
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
    let bvh = resample_bvh(&bvh, to).map_err(|e| usage(path, e))?;
    Ok(bvh_to_expmap(&bvh, target)
        .map_err(|e| usage(path, e))?
        .into_frames())
}

/// The seed window `start..end` the model reads. A window that starts at the clip's first frame
/// has that frame's root "delta" relative to the world origin (the absolute start pose); the
/// model was trained on frame-to-frame deltas, so that frame gets its successor's delta instead.
pub fn model_window(
    frames: &Array2<f64>,
    start: usize,
    end: usize,
    target: ExpMapTarget,
) -> Array2<f64> {
    let mut window = frames.slice(s![start..end, ..]).to_owned();
    if start == 0 && target == ExpMapTarget::H36m && window.nrows() > 1 {
        let next = window.slice(s![1, 0..6]).to_owned();
        window.slice_mut(s![0, 0..6]).assign(&next);
    }
    window
}

/// Frames `start..end` of the clip. With `anchor` (BVH output), the first frame's root delta is
/// replaced by the absolute pose it has in the whole clip, so that the written frames stay where
/// they were in the input; `poses` (exact absolute poses of the first frames, if known) are
/// preferred to integrating the deltas.
pub fn clip_window(
    frames: &Array2<f64>,
    start: usize,
    end: usize,
    target: ExpMapTarget,
    fps: f64,
    anchor: Option<Option<&[RootPose]>>,
) -> Array2<f64> {
    let mut window = frames.slice(s![start..end, ..]).to_owned();
    let Some(poses) = anchor else {
        return window;
    };
    if target == ExpMapTarget::H36m && start > 0 && end > start {
        let step = ((H36M_SOURCE_FPS / fps).round() as usize).max(1);
        let delta = |t: usize| {
            let r = frames.row(t);
            ([r[0], r[1], r[2]], [r[3], r[4], r[5]])
        };
        let pose = match poses {
            Some(p) if start < p.len() => p[start],
            Some(p) if start == p.len() && start > 0 => {
                let (d, rd) = delta(start);
                p[start - 1].advanced(d, rd, step)
            }
            _ => integrate_root(frames.slice(s![..=start, ..]), step)[start],
        };
        let (d, rd) = delta_between(&RootPose::IDENTITY, &pose, 1);
        for axis in 0..3 {
            window[[0, axis]] = d[axis];
            window[[0, 3 + axis]] = rd[axis];
        }
    }
    window
}

/// How a front end turns a seed file's frames and a model's continuation into the frames it
/// writes or returns (`predict`'s files, Python's arrays): one rule for all of them.
#[derive(Debug, Clone)]
pub struct WrittenClip<'a> {
    /// The frames' layout.
    pub target: ExpMapTarget,
    /// Their rate.
    pub fps: f64,
    /// The seed window the model read, within the history.
    pub seed: std::ops::Range<usize>,
    /// The first row written (the seed window's start, or its end for the prediction only).
    pub first_written: usize,
    /// The action (the grounding's lean limit).
    pub action: Option<&'a str>,
    /// The grounding ([`GroundingConfig::off`]: the model's raw frames).
    pub grounding: GroundingConfig,
    /// Raw frames only: the history's known absolute root poses, to anchor a BVH's first
    /// written frame ([`clip_window`]); `None` for exp-map outputs.
    pub anchor: Option<Option<&'a [RootPose]>>,
}

impl WrittenClip<'_> {
    /// The rows from `first_written` of `history` (the seed file's frames up to the seed's end)
    /// followed by `continuation`: grounded on the seed window's floor ([`crate::grounding`];
    /// with `predicted` false a real continuation is only moved onto that floor), or raw. Either
    /// way in the seed file's own coordinates: the written seed rows are the file's, and the
    /// continuation follows on from them ([`crate::grounding::ClipSpec::in_input_frame`]).
    ///
    /// # Errors
    /// A skeleton without two legs (grounding on).
    pub fn frames(
        &self,
        history: ArrayView2<'_, f64>,
        continuation: ArrayView2<'_, f64>,
        predicted: bool,
    ) -> Result<Array2<f64>, GroundingError> {
        Ok(self.frames_and_floor(history, continuation, predicted)?.0)
    }

    /// [`frames`](Self::frames), and the seed's floor the grounding worked on (world metres, its
    /// slope and levelling; `None` with grounding off): what a front end reports.
    ///
    /// # Errors
    /// A skeleton without two legs (grounding on).
    pub fn frames_and_floor(
        &self,
        history: ArrayView2<'_, f64>,
        continuation: ArrayView2<'_, f64>,
        predicted: bool,
    ) -> Result<(Array2<f64>, Option<crate::grounding::Floor>), GroundingError> {
        let whole = ndarray::concatenate(ndarray::Axis(0), &[history, continuation])
            .expect("frames of one layout");
        let stop = whole.nrows();
        if self.grounding.enabled {
            let mut spec = ClipSpec::new(
                self.target,
                self.fps,
                self.seed.clone(),
                self.action,
                self.grounding,
            );
            spec.ground_after_seed = predicted;
            spec.in_input_frame = true;
            let clip = ground_expmap_clip(whole.view(), &spec)?;
            return Ok((clip.window(self.first_written..stop), clip.floor));
        }
        Ok((
            clip_window(
                &whole,
                self.first_written,
                stop,
                self.target,
                self.fps,
                self.anchor,
            ),
            None,
        ))
    }
}

/// Sizes within this factor of the model's skeleton are taken as millimetres (people differ);
/// outside it a BVH is rescaled.
pub const UNITS_TOLERANCE: f64 = 1.3;

/// How large `skeleton` is against `reference`: the ratio of their summed bone lengths over the
/// joints both have by name (End Sites aside). 1 for the same units and build; 0.1 for a
/// skeleton in centimetres against one in millimetres.
pub fn unit_scale(skeleton: &Skeleton, reference: &Skeleton) -> Result<f64, String> {
    let (mut ours, mut theirs) = (0.0, 0.0);
    for joint in reference.joints().iter().filter(|j| !j.is_end_site) {
        if let Some(other) = skeleton
            .joints()
            .iter()
            .find(|o| !o.is_end_site && o.name == joint.name)
        {
            let length = |o: [f64; 3]| (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
            ours += length(other.offset);
            theirs += length(joint.offset);
        }
    }
    let scale = ours / theirs;
    if !(scale.is_finite() && (1e-5..=1e3).contains(&scale)) {
        return Err(format!(
            "the skeleton's bones sum to {ours} units against the model's {theirs} mm: no unit makes them comparable"
        ));
    }
    Ok(scale)
}

/// The unit a size ratio (against millimetres) most likely means, for notices.
pub fn units_guess(scale: f64) -> &'static str {
    const UNITS: [(f64, &str); 5] = [
        (0.1, "centimetres?"),
        (0.001, "metres?"),
        (1.0 / 25.4, "inches?"),
        (1.0 / 304.8, "feet?"),
        (1.0, "millimetres, another build"),
    ];
    UNITS
        .iter()
        .find(|(u, _)| (scale / u).ln().abs() < 0.15)
        .map_or("unknown units", |(_, name)| name)
}

/// `bvh` with every joint offset and position channel multiplied by `factor` (rotations as they
/// are): the same motion in other length units.
pub fn rescale_bvh(bvh: &Bvh, factor: f64) -> Result<Bvh, String> {
    let mut joints = bvh.skeleton.joints().to_vec();
    for joint in &mut joints {
        joint.offset = joint.offset.map(|v| v * factor);
    }
    let skeleton = Skeleton::new(joints).map_err(|e| e.to_string())?;
    let mut frames = bvh.frames.clone();
    for (j, joint) in bvh.skeleton.joints().iter().enumerate() {
        let start = bvh.skeleton.channel_start(j);
        for (k, channel) in joint.channels.iter().enumerate() {
            if !channel.is_rotation() {
                frames.column_mut(start + k).mapv_inplace(|v| v * factor);
            }
        }
    }
    Ok(Bvh {
        skeleton,
        frames,
        frame_time: bvh.frame_time,
    })
}

/// Checks that the BVH's joints (End Sites aside) are the target skeleton's, in order; the error
/// says what differs.
pub fn check_skeleton(bvh: &Bvh, target: ExpMapTarget) -> Result<(), String> {
    let expected = target.skeleton();
    let found: Vec<&str> = bvh.skeleton.body_joint_names();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::bvh::write_bvh;

    fn walking_bvh() -> Bvh {
        let frames = Array2::from_shape_fn((30, 99), |(t, d)| match d {
            0 => 12.0,
            1..6 => 0.0,
            _ => 0.3 * ((t as f64) * 0.2 + d as f64).sin(),
        });
        expmap_to_bvh(&Motion::h36m(frames, 25.0).unwrap()).unwrap()
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("motion-seed-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_bvh_in_other_units_is_rescaled_with_a_notice() {
        let dir = scratch("units");
        let mm = dir.join("mm.bvh");
        write_bvh(&mm, &walking_bvh()).unwrap();
        let want = load_seed(&mm, ExpMapTarget::H36m, 25.0, 50.0, None).unwrap();
        assert!(want.notices.is_empty(), "{:?}", want.notices);
        for (factor, unit) in [
            (0.1, "centimetres"),
            (0.001, "metres"),
            (1.0 / 25.4, "inches"),
        ] {
            let path = dir.join(format!("{unit}.bvh"));
            write_bvh(&path, &rescale_bvh(&walking_bvh(), factor).unwrap()).unwrap();
            let got = load_seed(&path, ExpMapTarget::H36m, 25.0, 50.0, None).unwrap();
            assert_eq!(got.notices.len(), 1);
            assert!(got.notices[0].contains(unit), "{}", got.notices[0]);
            let worst = (&got.frames - &want.frames)
                .mapv(f64::abs)
                .fold(0.0f64, |m, &v| m.max(v));
            assert!(worst < 1e-6, "{unit}: {worst}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_seeds_are_errors_naming_the_file() {
        let dir = scratch("bad");
        let flat = dir.join("flat.bvh");
        write_bvh(&flat, &rescale_bvh(&walking_bvh(), 0.0).unwrap()).unwrap();
        let err = load_seed(&flat, ExpMapTarget::H36m, 25.0, 50.0, None).unwrap_err();
        assert!(matches!(err, SeedError::Invalid { .. }));
        assert!(
            err.to_string().contains("flat.bvh") && err.to_string().contains("unit"),
            "{err}"
        );
        // Frame times in milliseconds (or any rate outside 1 ..= 10,000 fps) are refused before
        // anything is resampled.
        for frame_time in [20.0, 100_000.0, 1e-9] {
            let mut bvh = walking_bvh();
            bvh.frame_time = frame_time;
            let err = seed_from_bvh(bvh, Path::new("slow.bvh"), ExpMapTarget::H36m, 25.0, None)
                .unwrap_err()
                .to_string();
            assert!(err.contains("slow.bvh") && err.contains("fps"), "{err}");
            assert_eq!(err.contains("milliseconds"), frame_time >= 1.0, "{err}");
        }
        let short = dir.join("short.npy");
        crate::formats::npy::write_npy(&short, &Array2::<f64>::zeros((4, 98))).unwrap();
        let err = load_seed(&short, ExpMapTarget::H36m, 25.0, 50.0, None).unwrap_err();
        assert!(
            err.to_string().contains("short.npy") && err.to_string().contains("98"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn anchoring_puts_the_window_where_it_was() {
        let mut frames = Array2::zeros((6, 99));
        for t in 0..6 {
            frames[[t, 2]] = 10.0; // 10 mm forward per source frame
        }
        let window = clip_window(&frames, 3, 6, ExpMapTarget::H36m, 25.0, Some(None));
        // Frame 3 at 25 Hz: 10 (frame 0, once) + 3 steps * 2 source frames * 10 = 70 mm.
        assert!((window[[0, 2]] - 70.0).abs() < 1e-9);
        assert_eq!(window[[1, 2]], 10.0);
        let input = model_window(&frames, 0, 6, ExpMapTarget::H36m);
        assert_eq!(input[[0, 2]], 10.0);
    }
}
