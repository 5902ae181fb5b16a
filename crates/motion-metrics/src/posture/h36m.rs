//! H3.6M helpers: world positions of exp-map frames and takes, and the posture reference of an
//! action from the data's takes.
use std::path::{Path, PathBuf};

use ndarray::{s, Array3, ArrayView2};
use rayon::prelude::*;

use motion_core::kinematics::ExpMapFk;
use motion_core::protocol::{read_take, sequence_file, Take, ACTIONS};
use motion_core::root::{RootIntegrator, RootPose};
use motion_core::skeleton::H36M_FRAME_DIMS;
use motion_core::Skeleton;

use super::{PostureJoints, PostureReference};
use crate::error::{check_finite, MetricError};
use crate::plausibility::{ReferenceError, ROOT_STEP_25HZ};

/// The subjects whose takes make an action's posture reference: H3.6M's training subjects (every
/// subject but the test subject S5, whose takes measured against the reference give the
/// real-vs-real values).
pub const REFERENCE_SUBJECTS: [&str; 6] = ["S1", "S6", "S7", "S8", "S9", "S11"];

/// The first frame of a take that a reference reads (2 s at 25 Hz, the protocol's seed length):
/// more than half of the H3.6M takes open with the subject holding the arms out near shoulder
/// height for up to ~1.5 s before the action starts (walking: 9 of 14 takes, 17-33 frames above
/// 45° of elevation), a pose of the capture, not of the action.
pub const REFERENCE_START_FRAME: usize = 50;

/// The posture joints of the H3.6M skeleton ([`PostureJoints::find`] on `Skeleton::h36m()`):
/// hips `RightUpLeg`/`LeftUpLeg`, knees `*Leg`, ankles `*Foot`, torso top `Neck`, head
/// `HeadSite`, shoulders `*Arm`, elbows `*ForeArm`, wrists `*Hand`; leg length 897.1 mm.
pub fn h36m_joints() -> PostureJoints {
    PostureJoints::find(&Skeleton::h36m()).expect("the H3.6M skeleton has legs, torso and arms")
}

/// World joint positions (`T x 32 x 3`, mm) of 25 Hz H3.6M exp-map frames, the root integrated
/// from `root_before` (the absolute root pose of the frame before the first, as in
/// `motion_metrics::plausibility::Measurer::measure_after`; `None`: from the identity, the first
/// frame applied once).
///
/// # Errors
/// A width other than 99, no frames, a non-finite value.
pub fn h36m_positions(
    frames: ArrayView2<'_, f64>,
    root_before: Option<RootPose>,
) -> Result<Array3<f64>, MetricError> {
    if frames.ncols() != H36M_FRAME_DIMS {
        return Err(MetricError::ShapeMismatch {
            what: "frames (H3.6M exp-map frames)".into(),
            found: frames.shape().to_vec(),
            expected: vec![frames.nrows(), H36M_FRAME_DIMS],
        });
    }
    if frames.nrows() == 0 {
        return Err(MetricError::Empty {
            what: "frames has no frames".into(),
        });
    }
    check_finite("frames", &frames)?;
    let mut root = RootIntegrator::after(root_before, ROOT_STEP_25HZ);
    Ok(positions_of(
        frames.rows().into_iter().map(|row| {
            let frame: Vec<f64> = row.to_vec();
            let pose = root.push(&frame);
            (frame, pose)
        }),
        frames.nrows(),
    ))
}

/// World joint positions (`T x 32 x 3`, mm) of a take's 25 Hz frames at their exact root poses
/// (`Take::root_poses`, integrated at the source's 50 Hz).
pub fn take_positions(take: &Take) -> Array3<f64> {
    positions_of(
        take.frames
            .rows()
            .into_iter()
            .zip(&take.root_poses)
            .map(|(row, pose)| (row.to_vec(), *pose)),
        take.frames.nrows(),
    )
}

fn positions_of(frames: impl Iterator<Item = (Vec<f64>, RootPose)>, count: usize) -> Array3<f64> {
    let skeleton = Skeleton::h36m();
    let joints = skeleton.len();
    let mut fk = ExpMapFk::new(&skeleton);
    let mut out = Array3::zeros((count, joints, 3));
    let mut positions = vec![[0.0; 3]; joints];
    for (t, (frame, pose)) in frames.enumerate() {
        fk.frame(&skeleton, &frame, &pose, &mut positions);
        for (j, p) in positions.iter().enumerate() {
            for k in 0..3 {
                out[[t, j, k]] = p[k];
            }
        }
    }
    out
}

/// World positions ([`take_positions`]) of every take of `action` by `subjects` in `dataset`
/// from frame [`REFERENCE_START_FRAME`] on (both subactions; files missing from the release and
/// takes without frames after the start are skipped), read in parallel, in order.
///
/// # Errors
/// An unknown action; no file at all; a file that cannot be read.
pub fn h36m_take_positions(
    dataset: &Path,
    action: &str,
    subjects: &[&str],
) -> Result<Vec<(PathBuf, Array3<f64>)>, ReferenceError> {
    if !ACTIONS.contains(&action) {
        return Err(ReferenceError::UnknownAction {
            action: action.to_string(),
        });
    }
    let files: Vec<PathBuf> = subjects
        .iter()
        .flat_map(|s| [1, 2].map(|sub| sequence_file(dataset, s, action, sub)))
        .filter(|p| p.is_file())
        .collect();
    if files.is_empty() {
        return Err(ReferenceError::NoData {
            dataset: dataset.to_path_buf(),
            problem: format!("no {action} file of {}", subjects.join(", ")),
        });
    }
    let takes: Vec<Option<(PathBuf, Array3<f64>)>> = files
        .into_par_iter()
        .map(|path| {
            let take = read_take(&path)?;
            let positions = take_positions(&take);
            Ok((positions.dim().0 > REFERENCE_START_FRAME).then(|| {
                let kept = positions
                    .slice(s![REFERENCE_START_FRAME.., .., ..])
                    .to_owned();
                (path, kept)
            }))
        })
        .collect::<Result<_, ReferenceError>>()?;
    Ok(takes.into_iter().flatten().collect())
}

/// The posture reference of `action` from the takes of `subjects` (usually
/// [`REFERENCE_SUBJECTS`]) on the H3.6M skeleton ([`h36m_joints`]).
///
/// # Errors
/// As [`h36m_take_positions`]; a take whose positions the measure rejects.
pub fn h36m_reference(
    dataset: &Path,
    action: &str,
    subjects: &[&str],
) -> Result<PostureReference, ReferenceError> {
    let takes = h36m_take_positions(dataset, action, subjects)?;
    let views: Vec<_> = takes.iter().map(|(_, p)| p.view()).collect();
    PostureReference::from_takes(&h36m_joints(), &views).map_err(|source| ReferenceError::Metric {
        path: dataset.to_path_buf(),
        source,
    })
}
