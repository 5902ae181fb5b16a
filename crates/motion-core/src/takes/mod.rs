//! Takes: a folder of BVH motion-capture takes read onto one rig, at one rate, with each frame's
//! root trajectory (ground position and facing) and foot contacts — what a motion-matching
//! database ([`crate::matching`]) and a learned locomotion model are built from.
//!
//! ## The rule (one place)
//! - **Files**: every `*.bvh` of the folder (sorted by name; not recursive). A take that cannot be
//!   read (a parse error, a non-finite value, a bad frame time), whose rig cannot be mapped onto
//!   the common rig, or that is shorter than [`TakeOptions::min_seconds`] after resampling is
//!   skipped with its reason ([`Takes::skipped`]); the rest are used.
//! - **The common rig**: `--rig FILE` ([`TakeOptions::rig`]), by default the first readable
//!   take's. Its units are found from its legs ([`guess_mm_per_unit`]: millimetres,
//!   centimetres, metres, inches or CMU's ASF unit of 0.056444 m) and it is held in millimetres,
//!   +y up (what [`Pose`] and the grounding read). A take on another rig is retargeted onto it
//!   through the H3.6M skeleton ([`crate::retarget`]: the built-in name maps or
//!   [`TakeOptions::joint_map`]), rig joints without a counterpart keeping the common rig's
//!   first frame's rotations.
//! - **Rate**: each take is resampled to [`TakeOptions::fps`] (default [`DEFAULT_FPS`]) by slerp
//!   ([`crate::resample`]).
//! - **Floor**: each take's floor is the median over its frames of the lowest foot point
//!   ([`crate::grounding::legs`]), moved to `y = 0`.
//! - **Trajectory**: a frame's ground frame ([`GroundFrame`]) is the root's floor position and the
//!   pelvis heading ([`crate::steering::Steering::heading_of`]), both smoothed over a centred
//!   window of [`TRAJECTORY_SMOOTHING_S`] (the gait's sway and pelvis swing removed), clamped at
//!   the take's ends.
//! - **Contacts**: a foot touches the floor while its lowest point is below
//!   [`GroundingConfig::contact_height_m`] and its ankle moves slower than
//!   [`GroundingConfig::contact_speed_m_s`] horizontally (the grounding's rule, its defaults).
//!
//! ```no_run
//! use motion_core::takes::{read_takes, TakeOptions};
//! let takes = read_takes("../shared/data/cmu_locomotion".as_ref(), &TakeOptions::default())?;
//! for skipped in &takes.skipped {
//!     eprintln!("skipped {}: {}", skipped.path.display(), skipped.reason);
//! }
//! println!("{} takes, {} frames at {} Hz", takes.takes.len(), takes.frames(), takes.fps);
//! # Ok::<(), motion_core::takes::TakesError>(())
//! ```
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub mod training;
pub use training::{write_training_folder, TrainingManifest};

use glam::{DQuat, Quat, Vec2, Vec3};
use ndarray::Array2;

use crate::formats::bvh::{read_bvh, Bvh};
use crate::grounding::{find_body_parts, BodyParts, GroundingConfig};
use crate::kinematics::local_transform;
use crate::pose::{root_motion_between, Pose, METRES_PER_MM};
use crate::resample::resample_bvh;
use crate::retarget::{JointMap, Retargeter};
use crate::seed::rescale_bvh;
use crate::skeleton::Skeleton;
use crate::steering::ground_frame::GroundFrame;
use crate::steering::{wrap_angle, Steering};

/// The rate takes are brought to unless told otherwise (Hz).
pub const DEFAULT_FPS: f64 = 30.0;
/// Takes shorter than this (seconds) are skipped unless told otherwise.
pub const DEFAULT_MIN_SECONDS: f64 = 1.0;
/// The centred window (seconds) the trajectory's position and facing are averaged over.
pub const TRAJECTORY_SMOOTHING_S: f64 = 0.5;
/// The most takes one folder may hold.
pub const MAX_TAKES: usize = 100_000;

/// Length units a BVH rig may be in, millimetres per unit, and their names.
pub const UNITS: [(f64, &str); 5] = [
    (1.0, "millimetres"),
    (10.0, "centimetres"),
    (1000.0, "metres"),
    (25.4, "inches"),
    (56.444, "CMU ASF units (0.056444 m)"),
];
/// The hip-to-ankle length of an adult, the yardstick of [`guess_mm_per_unit`] (mm).
const ADULT_LEG_MM: f64 = 850.0;

/// How takes are read (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct TakeOptions {
    /// The rate every take is resampled to (Hz).
    pub fps: f64,
    /// The rig file every take goes onto (`None`: the first readable take's).
    pub rig: Option<PathBuf>,
    /// A JSON joint map ([`JointMap::from_json`]) for rigs the built-in maps do not know.
    pub joint_map: Option<PathBuf>,
    /// Takes shorter than this after resampling are skipped (seconds).
    pub min_seconds: f64,
}

impl Default for TakeOptions {
    fn default() -> Self {
        TakeOptions {
            fps: DEFAULT_FPS,
            rig: None,
            joint_map: None,
            min_seconds: DEFAULT_MIN_SECONDS,
        }
    }
}

/// Why no takes could be read at all (single takes are skipped, [`Takes::skipped`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TakesError {
    /// The folder could not be listed.
    #[error("{path}: {problem}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// A bad option.
    #[error("{0}")]
    Options(String),
    /// The rig file could not be used.
    #[error("{path}: {problem}")]
    Rig {
        /// The rig file.
        path: PathBuf,
        /// What is wrong with it.
        problem: String,
    },
    /// No take was usable; every skipped one is listed.
    #[error("no usable take in {folder}: {}", list(.skipped))]
    NoTakes {
        /// The folder (or the first file).
        folder: PathBuf,
        /// Every take and why it was skipped.
        skipped: Vec<Skipped>,
    },
}

fn list(skipped: &[Skipped]) -> String {
    if skipped.is_empty() {
        return "it holds no .bvh file".into();
    }
    skipped
        .iter()
        .map(|s| format!("{} ({})", s.path.display(), s.reason))
        .collect::<Vec<_>>()
        .join("; ")
}

/// A take that was not used, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// Why it was skipped.
    pub reason: String,
}

/// The rig every take is on (see the module docs).
#[derive(Debug, Clone)]
pub struct Rig {
    /// The hierarchy in millimetres (what [`Pose`]s are posed on).
    pub skeleton: Arc<Skeleton>,
    /// The file it came from.
    pub source: PathBuf,
    /// Millimetres per unit of the file (BVH written back on the rig use the file's units).
    pub mm_per_unit: f64,
    /// The rig's legs and torso.
    pub parts: BodyParts,
}

/// One take on the common rig (see the module docs).
#[derive(Debug, Clone)]
pub struct Take {
    /// The file name without its extension.
    pub name: String,
    /// The file.
    pub path: PathBuf,
    /// The file's own rate (Hz).
    pub source_fps: f64,
    /// Whether it was retargeted from another rig.
    pub retargeted: bool,
    /// One pose per frame (metres, its floor at `y = 0`).
    pub poses: Vec<Pose>,
    /// Per frame, the smoothed ground frame.
    pub trajectory: Vec<GroundFrame>,
    /// Per frame, whether each leg's foot touches the floor (legs in [`BodyParts::legs`] order).
    pub contacts: Vec<[bool; 2]>,
}

impl Take {
    /// Frames held.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether the take holds no frame.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }
}

/// Takes on one rig at one rate.
#[derive(Debug, Clone)]
pub struct Takes {
    /// The common rig.
    pub rig: Rig,
    /// The rate (Hz).
    pub fps: f64,
    /// The takes used, in file-name order.
    pub takes: Vec<Take>,
    /// The takes not used, with their reasons.
    pub skipped: Vec<Skipped>,
}

impl Takes {
    /// Frames over all takes.
    pub fn frames(&self) -> usize {
        self.takes.iter().map(Take::len).sum()
    }
}

/// The `*.bvh` files of `dir`, sorted by name.
///
/// # Errors
/// The folder cannot be listed, or holds more than [`MAX_TAKES`] BVH files.
pub fn bvh_files(dir: &Path) -> Result<Vec<PathBuf>, TakesError> {
    let folder = |problem: String| TakesError::Folder {
        path: dir.to_path_buf(),
        problem,
    };
    let entries = std::fs::read_dir(dir).map_err(|e| folder(e.to_string()))?;
    let mut files = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| folder(e.to_string()))?.path();
        let is_bvh = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("bvh"));
        if is_bvh && path.is_file() {
            files.push(path);
            if files.len() > MAX_TAKES {
                return Err(folder(format!(
                    "more than {MAX_TAKES} .bvh files (MAX_TAKES)"
                )));
            }
        }
    }
    files.sort();
    Ok(files)
}

/// `files` (takes of `dir`) without those named in `exclude` (file names without `.bvh`, blank
/// entries ignored), and the names left out, each once.
///
/// # Errors
/// A name that no file of `files` has.
pub fn exclude_takes(
    dir: &Path,
    files: Vec<PathBuf>,
    exclude: &[String],
) -> Result<(Vec<PathBuf>, Vec<String>), TakesError> {
    let stem = |p: &PathBuf| {
        p.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let mut excluded: Vec<String> = Vec::new();
    for name in exclude.iter().map(|n| n.trim()).filter(|n| !n.is_empty()) {
        let name = name.strip_suffix(".bvh").unwrap_or(name);
        if !files.iter().any(|f| stem(f) == name) {
            return Err(TakesError::Options(format!(
                "--exclude {name}: {} holds no take {name}.bvh",
                dir.display()
            )));
        }
        if !excluded.iter().any(|e| e == name) {
            excluded.push(name.to_string());
        }
    }
    let files = files
        .into_iter()
        .filter(|f| !excluded.contains(&stem(f)))
        .collect();
    Ok((files, excluded))
}

/// Reads every BVH take of `dir` onto one rig (see the module docs).
///
/// # Errors
/// The folder cannot be listed, the options or rig file are bad, or no take is usable.
pub fn read_takes(dir: &Path, options: &TakeOptions) -> Result<Takes, TakesError> {
    let files = bvh_files(dir)?;
    read_take_files(&files, options, dir)
}

/// [`read_takes`] over a list of files (`label` names them in the error when none is usable).
///
/// # Errors
/// See [`read_takes`].
pub fn read_take_files(
    files: &[PathBuf],
    options: &TakeOptions,
    label: &Path,
) -> Result<Takes, TakesError> {
    if !(options.fps.is_finite() && (1.0..=1000.0).contains(&options.fps)) {
        return Err(TakesError::Options(format!(
            "--fps {} is not a rate between 1 and 1000 Hz",
            options.fps
        )));
    }
    if !(options.min_seconds.is_finite() && options.min_seconds >= 0.0) {
        return Err(TakesError::Options(format!(
            "the shortest take ({} s) must be a non-negative number of seconds",
            options.min_seconds
        )));
    }
    let mut skipped = Vec::new();
    let mut rig: Option<(Rig, Bvh)> = match &options.rig {
        Some(path) => {
            let bvh = read_checked(path).map_err(|problem| TakesError::Rig {
                path: path.clone(),
                problem,
            })?;
            let rig = rig_of(&bvh, path).map_err(|problem| TakesError::Rig {
                path: path.clone(),
                problem,
            })?;
            Some((rig, bvh))
        }
        None => None,
    };
    let mut takes = Vec::new();
    for path in files {
        let skip = |reason: String| Skipped {
            path: path.clone(),
            reason,
        };
        let bvh = match read_checked(path) {
            Ok(bvh) => bvh,
            Err(reason) => {
                skipped.push(skip(reason));
                continue;
            }
        };
        if rig.is_none() {
            match rig_of(&bvh, path) {
                Ok(r) => rig = Some((r, bvh.clone())),
                Err(reason) => {
                    skipped.push(skip(format!("not usable as the common rig: {reason}")));
                    continue;
                }
            }
        }
        let (common, common_bvh) = rig.as_ref().expect("a rig");
        match take_of(bvh, path, common, common_bvh, options) {
            Ok(take) => takes.push(take),
            Err(reason) => skipped.push(skip(reason)),
        }
    }
    let Some((rig, _)) = rig else {
        return Err(TakesError::NoTakes {
            folder: label.to_path_buf(),
            skipped,
        });
    };
    if takes.is_empty() {
        return Err(TakesError::NoTakes {
            folder: label.to_path_buf(),
            skipped,
        });
    }
    Ok(Takes {
        rig,
        fps: options.fps,
        takes,
        skipped,
    })
}

/// A BVH file read and checked for what every later step assumes.
fn read_checked(path: &Path) -> Result<Bvh, String> {
    let bvh = read_bvh(path).map_err(|e| e.to_string())?;
    check_frames(&bvh)?;
    Ok(bvh)
}

/// A BVH's frame time and frames checked for what every later step assumes: a usable rate, at
/// least one frame, every value finite and not huge.
fn check_frames(bvh: &Bvh) -> Result<(), String> {
    crate::motion::check_frame_time(bvh.frame_time)?;
    if let Some((t, _)) = bvh
        .frames
        .rows()
        .into_iter()
        .enumerate()
        .find(|(_, r)| r.iter().any(|v| !v.is_finite() || v.abs() > 1e9))
    {
        return Err(format!("frame {t} holds a non-finite or huge value"));
    }
    if bvh.frames.nrows() == 0 {
        return Err("no frames".into());
    }
    Ok(())
}

/// The millimetres per unit of a rig (see [`UNITS`]): the unit that makes its longer leg
/// (hip to ankle) nearest an adult's; `None` when none is within a factor 1.6 of it.
pub fn guess_mm_per_unit(parts: &BodyParts) -> Option<f64> {
    let leg = parts.leg_length;
    UNITS
        .iter()
        .map(|&(mm, _)| (mm, (leg * mm / ADULT_LEG_MM).ln().abs()))
        .filter(|&(_, d)| d < 1.6f64.ln())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(mm, _)| mm)
}

/// The name of a unit of [`UNITS`].
pub fn unit_name(mm_per_unit: f64) -> &'static str {
    UNITS
        .iter()
        .find(|(mm, _)| (mm - mm_per_unit).abs() < 1e-9)
        .map_or("unknown units", |(_, n)| n)
}

/// The common rig of a BVH (see the module docs).
fn rig_of(bvh: &Bvh, path: &Path) -> Result<Rig, String> {
    let parts = find_body_parts(&bvh.skeleton).map_err(|e| e.to_string())?;
    let up = rest_up(&bvh.skeleton, &parts);
    if up.y < 0.9 {
        return Err(format!(
            "its rest pose stands along ({:.2}, {:.2}, {:.2}), not +y: a rig for takes must be y-up",
            up.x, up.y, up.z
        ));
    }
    let mm_per_unit = guess_mm_per_unit(&parts).ok_or_else(|| {
        format!(
            "its legs are {:.4} units long: no length unit (mm, cm, m, inch, CMU's) makes that an adult's",
            parts.leg_length
        )
    })?;
    for (j, joint) in bvh.skeleton.joints().iter().enumerate() {
        let rotations = joint.channels.iter().filter(|c| c.is_rotation()).count();
        let positions = joint.channels.len() - rotations;
        let ok = if joint.is_end_site {
            true
        } else if j == 0 {
            rotations == 3 && positions == 3
        } else {
            rotations == 3
        };
        if !ok {
            return Err(format!(
                "joint {:?} has channels {:?}: a rig for takes needs 3 rotations on every joint and 3 positions on the root",
                joint.name,
                joint.channels.iter().map(|c| c.bvh_name()).collect::<Vec<_>>()
            ));
        }
    }
    let mm = rescale_bvh(bvh, mm_per_unit)?;
    let parts = find_body_parts(&mm.skeleton).map_err(|e| e.to_string())?;
    Ok(Rig {
        skeleton: Arc::new(mm.skeleton),
        source: path.to_path_buf(),
        mm_per_unit,
        parts,
    })
}

/// The rest pose's up direction (hips' midpoint to the torso top, or to the highest joint).
fn rest_up(skeleton: &Skeleton, parts: &BodyParts) -> glam::DVec3 {
    let rest = crate::grounding::legs::rest_positions(skeleton);
    let p = |j: usize| glam::DVec3::from_array(rest[j]);
    let hips = (p(parts.legs[0].hip) + p(parts.legs[1].hip)) * 0.5;
    let top = parts.torso_top.map(p).unwrap_or_else(|| {
        (0..skeleton.len())
            .map(p)
            .max_by(|a, b| a.y.total_cmp(&b.y))
            .unwrap_or(hips)
    });
    (top - hips).normalize_or_zero()
}

/// Whether two skeletons are the same rig (names, parents and channels; offsets in proportion).
fn same_rig(a: &Skeleton, b: &Skeleton) -> bool {
    a.len() == b.len()
        && a.joints()
            .iter()
            .zip(b.joints())
            .all(|(x, y)| x.name == y.name && x.parent == y.parent && x.channels == y.channels)
}

/// One take onto the common rig, resampled, with trajectory and contacts.
fn take_of(
    bvh: Bvh,
    path: &Path,
    rig: &Rig,
    rig_bvh: &Bvh,
    options: &TakeOptions,
) -> Result<Take, String> {
    let source_fps = bvh.fps();
    let retargeted = !same_rig(&bvh.skeleton, &rig_bvh.skeleton);
    let on_rig = if retargeted {
        onto_rig(&bvh, rig_bvh, options.joint_map.as_deref())?
    } else {
        bvh
    };
    let mm = rescale_bvh(&on_rig, rig.mm_per_unit)?;
    let resampled = if (mm.fps() - options.fps).abs() < 1e-6 * options.fps {
        mm
    } else {
        resample_bvh(&mm, options.fps).map_err(|e| e.to_string())?
    };
    let frames = resampled.frames.nrows();
    let seconds = frames as f64 / options.fps;
    if seconds < options.min_seconds || frames < 2 {
        return Err(format!(
            "{seconds:.2} s long at {} Hz, shorter than the {:.2} s a take needs",
            options.fps, options.min_seconds
        ));
    }
    let mut poses = poses_of(&rig.skeleton, &resampled.frames);
    let frame_time = (1.0 / options.fps) as f32;
    let (trajectory, contacts) = annotate_poses(&rig.skeleton, &rig.parts, &mut poses, frame_time)?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(Take {
        name,
        path: path.to_path_buf(),
        source_fps,
        retargeted,
        poses,
        trajectory,
        contacts,
    })
}

/// A take on another rig retargeted onto the common rig through the H3.6M skeleton.
fn onto_rig(bvh: &Bvh, rig_bvh: &Bvh, joint_map: Option<&Path>) -> Result<Bvh, String> {
    let map_of = |skeleton: &Skeleton, which: &str| match joint_map {
        Some(file) => JointMap::read(skeleton, file)
            .or_else(|_| JointMap::detect(skeleton).map_err(|e| e.to_string()))
            .map_err(|e| format!("{which}: {e}")),
        None => JointMap::detect(skeleton)
            .map_err(|e| format!("{which}: {e} (give a joint map with --joint-map)")),
    };
    let from = Retargeter::new(&bvh.skeleton, map_of(&bvh.skeleton, "the take's rig")?)
        .map_err(|e| format!("the take's rig: {e}"))?;
    let to = Retargeter::new(
        &rig_bvh.skeleton,
        map_of(&rig_bvh.skeleton, "the common rig")?,
    )
    .map_err(|e| format!("the common rig: {e}"))?;
    let model = from.to_model(bvh.frames.view(), bvh.frame_time);
    let references = rig_bvh.frames.slice(ndarray::s![..1, ..]);
    Ok(to.to_rig(&model, references))
}

/// BVH channel frames (millimetres) as poses (metres).
pub fn poses_of(skeleton: &Skeleton, frames: &Array2<f64>) -> Vec<Pose> {
    let mut poses = Vec::with_capacity(frames.nrows());
    let mut previous = None;
    for row in frames.rows() {
        let row = row.to_vec();
        let mut pose = Pose::rest(skeleton.len());
        for (j, q) in pose.local_rotations.iter_mut().enumerate() {
            let (m, t) = local_transform(skeleton, j, &row);
            *q = DQuat::from_mat3(&m).normalize().as_quat();
            if j == 0 {
                pose.root_translation = (t * METRES_PER_MM).as_vec3();
            }
        }
        let root = pose.root_translation.as_dvec3();
        pose.root_motion = root_motion_between(root, pose.local_rotations[0].as_dquat(), previous);
        previous = Some(pose.root_motion);
        poses.push(pose);
    }
    poses
}

/// Moves a take's floor to `y = 0` and finds its trajectory and contacts (module docs).
pub(crate) fn annotate_poses(
    skeleton: &Skeleton,
    parts: &BodyParts,
    poses: &mut [Pose],
    frame_time: f32,
) -> Result<(Vec<GroundFrame>, Vec<[bool; 2]>), String> {
    let n = skeleton.len();
    let (mut positions, mut world) = (vec![Vec3::ZERO; n], vec![Quat::IDENTITY; n]);
    let mut lowest = Vec::with_capacity(poses.len());
    let mut feet = Vec::with_capacity(poses.len());
    for pose in poses.iter() {
        pose.world_positions_into(skeleton, &mut positions, &mut world);
        let low = |leg: usize| {
            parts.legs[leg]
                .foot_points
                .iter()
                .map(|&j| positions[j].y)
                .fold(f32::INFINITY, f32::min)
        };
        let (a, b) = (low(0), low(1));
        lowest.push(a.min(b));
        feet.push((
            [
                positions[parts.legs[0].ankle],
                positions[parts.legs[1].ankle],
            ],
            [a, b],
        ));
    }
    let mut sorted = lowest.clone();
    sorted.sort_by(f32::total_cmp);
    let floor = sorted[sorted.len() / 2];
    let mut previous = None;
    for pose in poses.iter_mut() {
        pose.root_translation.y -= floor;
        let root = pose.root_translation.as_dvec3();
        pose.root_motion = root_motion_between(root, pose.local_rotations[0].as_dquat(), previous);
        previous = Some(pose.root_motion);
    }
    let config = GroundingConfig::default();
    let contacts = (0..poses.len())
        .map(|t| {
            let before = t.saturating_sub(1);
            let after = (t + 1).min(poses.len() - 1);
            let span = ((after - before) as f32 * frame_time).max(frame_time);
            std::array::from_fn(|leg| {
                let moved = feet[after].0[leg] - feet[before].0[leg];
                let speed = Vec2::new(moved.x, moved.z).length() / span;
                feet[t].1[leg] - floor < config.contact_height_m && speed < config.contact_speed_m_s
            })
        })
        .collect();
    let steering = Steering::new(skeleton, frame_time).map_err(|e| e.to_string())?;
    let trajectory = smoothed_trajectory(poses, &steering, frame_time);
    Ok((trajectory, contacts))
}

/// Ground frames of `poses`: the root's floor position and the pelvis heading, each averaged
/// over a centred window of [`TRAJECTORY_SMOOTHING_S`] (clamped at the ends).
pub fn smoothed_trajectory(
    poses: &[Pose],
    steering: &Steering,
    frame_time: f32,
) -> Vec<GroundFrame> {
    let n = poses.len();
    // Unwrapped headings, so that averaging never crosses ±π.
    let mut headings = Vec::with_capacity(n);
    let mut last = 0.0f32;
    for (t, pose) in poses.iter().enumerate() {
        let h = steering.heading_of(pose);
        let h = if t == 0 {
            h
        } else {
            last + wrap_angle(h - last)
        };
        headings.push(h);
        last = h;
    }
    let half = ((TRAJECTORY_SMOOTHING_S / f64::from(frame_time)) / 2.0).round() as usize;
    (0..n)
        .map(|t| {
            let (a, b) = (t.saturating_sub(half), (t + half).min(n - 1));
            // A symmetric window (as wide on both sides as the take allows).
            let reach = (t - a).min(b - t);
            let (a, b) = (t - reach, t + reach);
            let count = (b - a + 1) as f32;
            let mut position = Vec2::ZERO;
            let mut heading = 0.0;
            for k in a..=b {
                let r = poses[k].root_translation;
                position += Vec2::new(r.x, r.z);
                heading += headings[k];
            }
            GroundFrame {
                position: position / count,
                facing: wrap_angle(heading / count),
            }
        })
        .collect()
}

/// A seed BVH (any rig the built-in maps or `joint_map` fit, any units and rate) as poses on
/// `rig` (offsets in millimetres; `mm_per_unit` of its files) at `fps`: the seed of a
/// database's character ([`crate::matching::Matcher::start`]). The same rig (joint names,
/// parents and channels) is only rescaled by the ratio of leg lengths; another is retargeted
/// through the H3.6M skeleton as takes are.
///
/// # Errors
/// A bad frame time or value, a rig that cannot be mapped, or a seed over the clip limits.
pub fn seed_poses_on_rig(
    bvh: Bvh,
    rig: &Skeleton,
    mm_per_unit: f64,
    fps: f64,
    joint_map: Option<&Path>,
) -> Result<Vec<Pose>, String> {
    check_frames(&bvh).map_err(|e| format!("the seed: {e}"))?;
    let rig_parts = find_body_parts(rig).map_err(|e| e.to_string())?;
    let mm = if same_rig(&bvh.skeleton, rig) && joint_map.is_none() {
        let parts = find_body_parts(&bvh.skeleton).map_err(|e| e.to_string())?;
        if parts.leg_length.is_nan() || parts.leg_length <= 0.0 {
            return Err("the seed's legs have no length".into());
        }
        rescale_bvh(&bvh, rig_parts.leg_length / parts.leg_length)?
    } else {
        let rig_file = Bvh {
            skeleton: rig.clone(),
            frames: Array2::zeros((1, rig.channel_count())),
            frame_time: bvh.frame_time,
        };
        let rig_file = rescale_bvh(&rig_file, 1.0 / mm_per_unit)?;
        let on_rig = onto_rig(&bvh, &rig_file, joint_map)?;
        rescale_bvh(&on_rig, mm_per_unit)?
    };
    let resampled = if (mm.fps() - fps).abs() < 1e-6 * fps {
        mm
    } else {
        resample_bvh(&mm, fps).map_err(|e| e.to_string())?
    };
    Ok(poses_of(rig, &resampled.frames))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_guessed_from_the_legs() {
        let rig = crate::retarget::demo_rig("", false, 0.1);
        let parts = find_body_parts(&rig).unwrap();
        assert_eq!(
            guess_mm_per_unit(&parts),
            Some(10.0),
            "{}",
            parts.leg_length
        );
        let rig = crate::retarget::demo_rig("", false, 0.001);
        let parts = find_body_parts(&rig).unwrap();
        assert_eq!(guess_mm_per_unit(&parts), Some(1000.0));
        let rig = crate::retarget::demo_rig("", false, 1.0);
        let parts = find_body_parts(&rig).unwrap();
        assert_eq!(guess_mm_per_unit(&parts), Some(1.0));
    }
}
