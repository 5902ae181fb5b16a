//! Posture realism in `eval` ([`crate::posture`]): per window of the horizon (the plausibility
//! windows, 0-2 s ... 50-60 s), the frames after the seeds of every test window and sample pooled
//! and measured against the action's reference (the takes of [`REFERENCE_SUBJECTS`] from
//! [`REFERENCE_START_FRAME`]); beside them the real-vs-real values: the test subject's own takes
//! of the action measured the same way, what a number of real motion reads.
use ndarray::{s, ArrayView2};
use serde::Serialize;

use motion_core::root::RootPose;

use crate::error::MetricError;
use crate::plausibility::WINDOW_BOUNDS_S;
use crate::posture::{
    h36m_joints, h36m_positions, h36m_take_positions, PostureReference, PostureReport,
    PostureStats, REFERENCE_SUBJECTS,
};

/// The readable numbers of a [`PostureReport`] (its histograms left out).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PostureSummary {
    /// Frames measured.
    pub frames: usize,
    /// Fréchet distance of the feature Gaussians (leg lengths squared).
    pub frechet: f64,
    /// Earth mover's distance of the upper-arm elevation histograms (degrees).
    pub arm_elevation_emd_deg: f64,
    /// Earth mover's distance of the thigh elevation histograms (degrees).
    pub thigh_elevation_emd_deg: f64,
    /// Fraction of frames whose higher upper arm is above the real p99.
    pub arms_above_real_p99: f64,
}

impl From<&PostureReport> for PostureSummary {
    fn from(r: &PostureReport) -> Self {
        PostureSummary {
            frames: r.frames,
            frechet: r.frechet,
            arm_elevation_emd_deg: r.arm_elevation_emd_deg,
            thigh_elevation_emd_deg: r.thigh_elevation_emd_deg,
            arms_above_real_p99: r.arms_above_real_p99,
        }
    }
}

/// One window of the horizon and its posture (`None`: no frame of it was generated or covered).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PostureWindow {
    /// `"a-b"` seconds after the seed.
    pub window: String,
    /// The measure of the frames in it.
    pub posture: Option<PostureSummary>,
}

/// The posture realism of one action (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ActionPosture {
    /// The subjects whose takes make the reference.
    pub reference_subjects: Vec<&'static str>,
    /// Real frames in the reference.
    pub reference_frames: usize,
    /// The real p99 of the higher upper arm's elevation (degrees).
    pub real_arm_elevation_p99_deg: f64,
    /// The test subject's takes of the action against the reference (`None`: none in the data).
    pub real_vs_real: Option<PostureSummary>,
    /// The model's predictions grounded, per window.
    pub model_grounded: Vec<PostureWindow>,
    /// The model's raw predictions, per window.
    pub model: Vec<PostureWindow>,
    /// The zero-velocity baseline, per window.
    pub zero_velocity: Vec<PostureWindow>,
    /// The real continuation, per window (as far as the files cover).
    pub ground_truth: Vec<PostureWindow>,
}

/// The reference of `action` and the real-vs-real value of `test_subject`'s takes.
///
/// # Errors
/// As [`crate::posture::h36m_reference`].
pub fn action_posture_reference(
    dataset: &std::path::Path,
    action: &str,
    test_subject: &str,
) -> Result<(PostureReference, Option<PostureSummary>), crate::plausibility::ReferenceError> {
    let reference = crate::posture::h36m_reference(dataset, action, &REFERENCE_SUBJECTS)?;
    let real = match h36m_take_positions(dataset, action, &[test_subject]) {
        Ok(takes) => {
            let views: Vec<_> = takes.iter().map(|(_, p)| p.view()).collect();
            Some(reference.measure(&views).map_err(|source| {
                crate::plausibility::ReferenceError::Metric {
                    path: dataset.to_path_buf(),
                    source,
                }
            })?)
        }
        Err(crate::plausibility::ReferenceError::NoData { .. }) => None,
        Err(e) => return Err(e),
    };
    Ok((reference, real.as_ref().map(PostureSummary::from)))
}

/// The frame range `[from, to)` of window `(a, b)` seconds at `fps`.
fn window_frames(bounds: (u32, u32), fps: f64) -> (usize, usize) {
    (
        (f64::from(bounds.0) * fps).round() as usize,
        (f64::from(bounds.1) * fps).round() as usize,
    )
}

/// Per window, the posture of `clips`: each a 25 Hz H3.6M clip (seed, then motion) whose root
/// is integrated from `root_before` (`None`: from the identity), measured on the frames after
/// its `seed_frames`.
///
/// # Errors
/// A clip the measure rejects (a non-finite value).
pub fn windows_posture(
    reference: &PostureReference,
    clips: &[(Option<RootPose>, ArrayView2<'_, f64>, usize)],
    fps: f64,
) -> Result<Vec<PostureWindow>, MetricError> {
    let joints = h36m_joints();
    let mut stats: Vec<PostureStats> = WINDOW_BOUNDS_S
        .iter()
        .map(|_| PostureStats::new(&joints))
        .collect();
    for (root_before, clip, seed_frames) in clips {
        if clip.nrows() <= *seed_frames {
            continue;
        }
        let positions = h36m_positions(clip.view(), *root_before)?;
        let motion = positions.slice(s![*seed_frames.., .., ..]);
        for (bounds, stats) in WINDOW_BOUNDS_S.iter().zip(stats.iter_mut()) {
            let (from, to) = window_frames(*bounds, fps);
            let to = to.min(motion.dim().0);
            if from < to {
                stats.push_frames(motion.slice(s![from..to, .., ..]))?;
            }
        }
    }
    WINDOW_BOUNDS_S
        .iter()
        .zip(&stats)
        .map(|(bounds, stats)| {
            Ok(PostureWindow {
                window: format!("{}-{}", bounds.0, bounds.1),
                posture: if stats.frames() == 0 {
                    None
                } else {
                    Some(PostureSummary::from(&reference.measure_stats(stats)?))
                },
            })
        })
        .collect()
}

/// Bookkeeping for [`ActionPosture`]: the reference's numbers.
pub fn action_posture(
    reference: &PostureReference,
    real_vs_real: Option<PostureSummary>,
    windows: [Vec<PostureWindow>; 4],
) -> ActionPosture {
    let [model_grounded, model, zero_velocity, ground_truth] = windows;
    ActionPosture {
        reference_subjects: REFERENCE_SUBJECTS.to_vec(),
        reference_frames: reference.stats().frames(),
        real_arm_elevation_p99_deg: reference.arm_p99_deg(),
        real_vs_real,
        model_grounded,
        model,
        zero_velocity,
        ground_truth,
    }
}

/// Posture realism of any H3.6M predictions of `action` ([`score_posture`]): per window after
/// the seed, beside the real-vs-real value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PostureScore {
    /// The action whose takes are the reference.
    pub action: String,
    /// The subjects whose takes make the reference.
    pub reference_subjects: Vec<&'static str>,
    /// Real frames in the reference.
    pub reference_frames: usize,
    /// The real p99 of the higher upper arm's elevation (degrees).
    pub real_arm_elevation_p99_deg: f64,
    /// The test subject's (S5) takes against the reference (`None`: none in the data).
    pub real_vs_real: Option<PostureSummary>,
    /// The predictions, per window after the seed (cut at their length).
    pub windows: Vec<PostureWindow>,
}

/// Posture realism of `clips` (25 Hz H3.6M exp-map clips, each with the absolute root pose of
/// the frame before it, `None`: integrated from the identity, and the number of its frames that
/// are seed) against `action`'s reference in `dataset`: what `motion-cli score --metric posture`
/// and Python's `motion.posture` report.
///
/// # Errors
/// No data for the action; a clip the measure rejects.
pub fn score_posture(
    dataset: &std::path::Path,
    action: &str,
    clips: &[(Option<RootPose>, ArrayView2<'_, f64>, usize)],
) -> Result<PostureScore, crate::plausibility::ReferenceError> {
    let (reference, real_vs_real) = action_posture_reference(dataset, action, "S5")?;
    let windows = windows_posture(&reference, clips, motion_core::skeleton::H36M_PROTOCOL_FPS)
        .map_err(|source| crate::plausibility::ReferenceError::Metric {
            path: dataset.to_path_buf(),
            source,
        })?;
    Ok(PostureScore {
        action: action.to_string(),
        reference_subjects: REFERENCE_SUBJECTS.to_vec(),
        reference_frames: reference.stats().frames(),
        real_arm_elevation_p99_deg: reference.arm_p99_deg(),
        real_vs_real,
        windows,
    })
}
