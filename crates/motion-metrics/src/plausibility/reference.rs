//! The real-data side of the plausibility measures, per action, computed from the H3.6M exp-map
//! files (the one place these statistics are made; definitions in the [parent module](super)):
//!
//! - the **reference speed**: mean joint speed in the root frame over every 25 Hz frame step of
//!   the action's S5 files (both subactions that exist, steps pooled);
//! - the **drift p95**: per window, the 95th percentile of the largest hip height change and
//!   torso lean change over real 12 s windows of the action in every subject's files (a window
//!   every 25 frames from frame 50 on, seeded by the 50 frames before it, exactly as a prediction
//!   is measured: the root integrated from the take's first frame).
//!
//! Files missing from the data release are skipped (and the files used are listed); files are
//! read in parallel and windows measured in parallel. [`action_reference`] keeps each result for
//! the rest of the process.
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use ndarray::{s, Array2};
use rayon::prelude::*;
use serde::Serialize;

use motion_core::protocol::{
    read_take, sequence_file, ACTIONS, SEED_FRAMES, SUBJECTS, TEST_SUBJECT,
};
use motion_core::root::RootPose;
use motion_core::FormatError;

use super::{HorizonWindow, Measurer, DRIFT_PERCENTILE, REAL_WINDOW_FRAMES as MAX_HORIZON_FRAMES};
use crate::error::MetricError;

/// Frames between the starts of consecutive real drift windows (1 s at 25 Hz).
pub const DRIFT_WINDOW_HOP: usize = 25;

/// Why the reference statistics of an action cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReferenceError {
    /// Not one of the 15 H3.6M actions.
    #[error("unknown action `{action}`; valid actions: {}", ACTIONS.join(", "))]
    UnknownAction {
        /// The name given.
        action: String,
    },
    /// The data has nothing to compute the statistic from.
    #[error("{}: {problem}", dataset.display())]
    NoData {
        /// The exp-map dataset directory.
        dataset: PathBuf,
        /// What is missing.
        problem: String,
    },
    /// A data file cannot be read or parsed (the error names it).
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A data file holds values the measures reject.
    #[error("{}: {source}", path.display())]
    Metric {
        /// The file.
        path: PathBuf,
        /// The problem.
        #[source]
        source: MetricError,
    },
}

/// The p95 of real drift in one window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriftP95 {
    /// Hip height change (mm).
    pub hip_height_mm: f64,
    /// Torso lean change (degrees).
    pub lean_deg: f64,
}

/// What real motion of an action does in the floor frame, over the first
/// [`REAL_RANGE_FRAMES`] frames (2 s) after the seed of each of its real windows (every
/// subject): the ranges a grounded prediction is held to. Later frames are left out because the
/// data's own root, integrated from 25 Hz deltas, drifts (a few degrees of tilt and tens of cm
/// of height over 12 s), which would widen the ranges with motion no person made.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RealRanges {
    /// 95th percentile of the torso lean (degrees).
    pub lean_p95_deg: f64,
    /// 5th percentile of the hip height above the floor (mm).
    pub hip_height_p5_mm: f64,
    /// 95th percentile of the hip height above the floor (mm).
    pub hip_height_p95_mm: f64,
    /// Fraction of frames whose lowest foot point is within `ON_FLOOR_MM` of the floor.
    pub on_floor_fraction: f64,
    /// Fraction of frames that penetrate the floor.
    pub penetration_fraction: f64,
    /// Fraction of frames that skate, every subject.
    pub skating_fraction: f64,
    /// Fraction of frames that skate, S5's windows only.
    pub s5_skating_fraction: f64,
}

/// Frames after each real window's seed that [`RealRanges`] pools (2 s at 25 Hz).
pub const REAL_RANGE_FRAMES: usize = 50;

/// The reference statistics of one action.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionReference {
    /// The action.
    pub action: String,
    /// The exp-map dataset directory read.
    pub dataset: PathBuf,
    /// Mean joint speed in the root frame over the S5 files (mm/s).
    pub s5_mean_speed_mm_s: f64,
    /// Frame steps behind it.
    pub s5_frame_steps: usize,
    /// The S5 files read.
    pub s5_files: Vec<PathBuf>,
    /// The files (every subject) that gave real 12 s windows.
    pub drift_files: Vec<PathBuf>,
    /// Per real window and motion frame: the hip height change (mm).
    hip: Array2<f64>,
    /// Per real window and motion frame: the torso lean change (degrees).
    lean: Array2<f64>,
    /// Floor-frame ranges of the real windows.
    pub real: RealRanges,
}

/// One subject's take, read and downsampled.
struct Take {
    subject: &'static str,
    path: PathBuf,
    frames: Array2<f64>,
    /// The exact absolute root pose of each frame (`motion_core::protocol::Take`).
    root_poses: Vec<RootPose>,
}

impl ActionReference {
    /// Computes the statistics of `action` from `dataset` (the directory holding `S1/`, `S5/`, ...).
    ///
    /// Errors: an unknown action, no S5 file of the action, no file long enough for one 12 s
    /// window (50 + 300 frames at 25 Hz), a file that cannot be read or parsed.
    pub fn compute(dataset: &Path, action: &str) -> Result<Self, ReferenceError> {
        if !ACTIONS.contains(&action) {
            return Err(ReferenceError::UnknownAction {
                action: action.to_string(),
            });
        }
        let paths: Vec<(&'static str, PathBuf)> = SUBJECTS
            .iter()
            .flat_map(|&subject| {
                [1u8, 2].map(|sub| (subject, sequence_file(dataset, subject, action, sub)))
            })
            .filter(|(_, path)| path.is_file())
            .collect();
        let takes: Vec<Take> = paths
            .into_par_iter()
            .map(|(subject, path)| {
                let take = read_take(&path)?;
                Ok(Take {
                    subject,
                    path,
                    frames: take.frames,
                    root_poses: take.root_poses,
                })
            })
            .collect::<Result<_, ReferenceError>>()?;

        // Reference speed: every frame step of the S5 takes.
        let s5: Vec<&Take> = takes.iter().filter(|t| t.subject == TEST_SUBJECT).collect();
        let speeds = s5
            .par_iter()
            .map_init(Measurer::new, |m, take| {
                let f = take.frames.view();
                if f.nrows() < 2 {
                    return Ok((0.0, 0));
                }
                let measured = m
                    .measure(f.slice(s![..1, ..]), f.slice(s![1.., ..]))
                    .map_err(|source| ReferenceError::Metric {
                        path: take.path.clone(),
                        source,
                    })?;
                Ok((measured.speed_mm_s.iter().sum::<f64>(), measured.frames()))
            })
            .collect::<Result<Vec<(f64, usize)>, ReferenceError>>()?;
        let (speed_sum, steps) = speeds
            .iter()
            .fold((0.0, 0), |(a, n), (s, k)| (a + s, n + k));
        if steps == 0 {
            return Err(ReferenceError::NoData {
                dataset: dataset.to_path_buf(),
                problem: format!(
                    "no {TEST_SUBJECT} file of {action} (its mean speed is the speed_ratio reference)"
                ),
            });
        }

        // Drift: real 12 s windows of every take.
        let starts: Vec<(usize, usize)> = takes
            .iter()
            .enumerate()
            .flat_map(|(i, take)| {
                let frames = take.frames.nrows();
                (SEED_FRAMES..)
                    .step_by(DRIFT_WINDOW_HOP)
                    .take_while(move |start| start + MAX_HORIZON_FRAMES <= frames)
                    .map(move |start| (i, start))
            })
            .collect();
        if starts.is_empty() {
            return Err(ReferenceError::NoData {
                dataset: dataset.to_path_buf(),
                problem: format!(
                    "no file of {action} has the {} frames at 25 Hz of one real 12 s window with its seed",
                    SEED_FRAMES + MAX_HORIZON_FRAMES
                ),
            });
        }
        let traces = starts
            .par_iter()
            .map_init(Measurer::new, |m, &(i, start)| {
                let f = takes[i].frames.view();
                let seed_start = start - SEED_FRAMES;
                let before = seed_start.checked_sub(1).map(|k| takes[i].root_poses[k]);
                m.measure_after(
                    before,
                    f.slice(s![seed_start..start, ..]),
                    f.slice(s![start..start + MAX_HORIZON_FRAMES, ..]),
                )
                .map_err(|source| ReferenceError::Metric {
                    path: takes[i].path.clone(),
                    source,
                })
            })
            .collect::<Result<Vec<_>, ReferenceError>>()?;
        let mut hip = Array2::zeros((traces.len(), MAX_HORIZON_FRAMES));
        let mut lean = Array2::zeros((traces.len(), MAX_HORIZON_FRAMES));
        for (r, t) in traces.iter().enumerate() {
            hip.row_mut(r)
                .iter_mut()
                .zip(&t.hip_height_change_mm)
                .for_each(|(d, v)| *d = *v);
            lean.row_mut(r)
                .iter_mut()
                .zip(&t.lean_change_deg)
                .for_each(|(d, v)| *d = *v);
        }
        let pooled = |f: &dyn Fn(&super::SequenceMeasures) -> &[f64]| -> Vec<f64> {
            traces
                .iter()
                .flat_map(|t| f(t)[..REAL_RANGE_FRAMES.min(t.frames())].iter().copied())
                .collect()
        };
        let share = |keep: &dyn Fn(&super::SequenceMeasures, usize) -> bool, s5: bool| {
            let (mut hit, mut all) = (0usize, 0usize);
            for (t, &(i, _)) in traces.iter().zip(&starts) {
                if s5 && takes[i].subject != TEST_SUBJECT {
                    continue;
                }
                for k in 0..REAL_RANGE_FRAMES.min(t.frames()) {
                    all += 1;
                    hit += usize::from(keep(t, k));
                }
            }
            hit as f64 / all.max(1) as f64
        };
        let mut leans = pooled(&|t| &t.lean_deg);
        let mut hips = pooled(&|t| &t.hip_height_mm);
        let real = RealRanges {
            lean_p95_deg: percentile(&mut leans, 95.0),
            hip_height_p5_mm: percentile(&mut hips, 5.0),
            hip_height_p95_mm: percentile(&mut hips, 95.0),
            on_floor_fraction: share(
                &|t, k| t.lowest_foot_mm[k].abs() <= super::ON_FLOOR_MM,
                false,
            ),
            penetration_fraction: share(
                &|t, k| t.lowest_foot_mm[k] < -super::PENETRATION_MM,
                false,
            ),
            skating_fraction: share(&|t, k| t.skating[k], false),
            s5_skating_fraction: share(&|t, k| t.skating[k], true),
        };
        let mut drift_files: Vec<PathBuf> =
            starts.iter().map(|&(i, _)| takes[i].path.clone()).collect();
        drift_files.dedup();
        Ok(Self {
            action: action.to_string(),
            dataset: dataset.to_path_buf(),
            s5_mean_speed_mm_s: speed_sum / steps as f64,
            s5_frame_steps: steps,
            s5_files: s5.iter().map(|t| t.path.clone()).collect(),
            drift_files,
            hip,
            lean,
            real,
        })
    }

    /// Real 12 s windows behind the drift p95.
    pub fn drift_windows(&self) -> usize {
        self.hip.nrows()
    }

    /// The p95 over the real windows of the largest change within motion frames
    /// `[window.start_frame, window.end_frame)`; a window past 12 s (no real window is longer)
    /// is held to the 8-12 s window's p95.
    pub fn drift_p95(&self, window: &HorizonWindow) -> DriftP95 {
        let end = window.end_frame.min(MAX_HORIZON_FRAMES);
        let start = if window.start_frame >= end {
            2 * MAX_HORIZON_FRAMES / 3
        } else {
            window.start_frame
        };
        let p95 = |a: &Array2<f64>| {
            let mut maxima: Vec<f64> = a
                .rows()
                .into_iter()
                .map(|r| r.slice(s![start..end]).iter().copied().fold(0.0, f64::max))
                .collect();
            percentile(&mut maxima, DRIFT_PERCENTILE)
        };
        DriftP95 {
            hip_height_mm: p95(&self.hip),
            lean_deg: p95(&self.lean),
        }
    }
}

/// The `q`-th percentile (0..=100) of `values` with linear interpolation between the order
/// statistics (numpy's default): position `q/100 · (n − 1)`. Sorts `values`; NaN for none.
pub fn percentile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let pos = (q / 100.0).clamp(0.0, 1.0) * (values.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    values[lo] + (values[hi] - values[lo]) * (pos - lo as f64)
}

type Cache = Mutex<HashMap<(PathBuf, String), Arc<ActionReference>>>;

/// [`ActionReference::compute`], once per (dataset, action) per process.
pub fn action_reference(
    dataset: &Path,
    action: &str,
) -> Result<Arc<ActionReference>, ReferenceError> {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let key = (dataset.to_path_buf(), action.to_string());
    if let Some(hit) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(Arc::clone(hit));
    }
    let computed = Arc::new(ActionReference::compute(dataset, action)?);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, Arc::clone(&computed));
    Ok(computed)
}

impl ActionReference {
    /// A reference made from given numbers (tests and callers with their own statistics):
    /// `hip` and `lean` are real windows x motion frames of per-frame changes.
    pub fn from_parts(
        action: &str,
        s5_mean_speed_mm_s: f64,
        hip: Array2<f64>,
        lean: Array2<f64>,
    ) -> Self {
        Self {
            action: action.to_string(),
            dataset: PathBuf::new(),
            s5_mean_speed_mm_s,
            s5_frame_steps: 0,
            s5_files: Vec::new(),
            drift_files: Vec::new(),
            hip,
            lean,
            real: RealRanges {
                lean_p95_deg: f64::NAN,
                hip_height_p5_mm: f64::NAN,
                hip_height_p95_mm: f64::NAN,
                on_floor_fraction: f64::NAN,
                penetration_fraction: f64::NAN,
                skating_fraction: f64::NAN,
                s5_skating_fraction: f64::NAN,
            },
        }
    }
}
