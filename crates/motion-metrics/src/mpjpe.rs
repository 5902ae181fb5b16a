//! MPJPE, the mean per-joint position error (mm) of the 3-D protocols of LTD (Mao et al. 2019),
//! History Repeats Itself (Mao et al. 2020) and siMLPe (Guo et al. 2023), as their code computes
//! it (`protocols_modern.md` §1):
//!
//! - positions of H3.6M exp-map frames come from forward kinematics with dims 0..5 (root
//!   translation and rotation) set to zero, so every pose is in the pelvis frame
//!   ([`h36m_pelvis_positions`]);
//! - the error of a frame is the mean over all 32 joints of the Euclidean distance
//!   ([`JointMean::All32`], the reference's); the four constant joints count as zero and the six
//!   joints that sit on another joint repeat it. A model that predicts only the 22 joints of the
//!   reference gets the ground truth elsewhere and the six copies ([`fill_h36m_prediction`]);
//!   [`JointMean::Predicted22`], the mean over those 22 only, is a separately named variant;
//! - a horizon is the error at one frame ([`MPJPE_HORIZON_FRAMES`]), not a mean up to it.
//!
//! ```
//! use motion_metrics::mpjpe::{mpjpe, JointMean};
//! use ndarray::Array3;
//!
//! let truth = Array3::<f64>::zeros((2, 32, 3));
//! let mut pred = truth.clone();
//! pred[[1, 5, 0]] = 32.0; // one joint of frame 1 is 32 mm off
//! let per_frame = mpjpe(pred.view(), truth.view(), JointMean::All32)?;
//! assert_eq!(per_frame.to_vec(), vec![0.0, 1.0]);
//! # Ok::<(), motion_metrics::MetricError>(())
//! ```
use ndarray::{s, Array1, Array2, Array3, Array4, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;

use motion_core::kinematics::ExpMapFk;
use motion_core::root::RootPose;
use motion_core::skeleton::{H36M_FRAME_DIMS, H36M_JOINT_COUNT};
use motion_core::Skeleton;

use crate::error::{check_finite, check_not_empty, MetricError};

/// The reported horizons (ms after the last observed frame at 25 Hz).
pub const MPJPE_HORIZONS_MS: [u32; 8] = [80, 160, 320, 400, 560, 720, 880, 1000];
/// The 0-based predicted frame of each horizon (`#2 #4 #8 #10 #14 #18 #22 #25`).
pub const MPJPE_HORIZON_FRAMES: [usize; 8] = [1, 3, 7, 9, 13, 17, 21, 24];
/// Predicted frames of the protocol (1 s at 25 Hz).
pub const MPJPE_OUTPUT_FRAMES: usize = 25;
/// The 22 joints the reference models predict (the others are constant after the root is
/// zeroed or sit on another joint).
pub const H36M_PREDICTED_JOINTS: [usize; 22] = [
    2, 3, 4, 5, 7, 8, 9, 10, 12, 13, 14, 15, 17, 18, 19, 21, 22, 25, 26, 27, 29, 30,
];
/// `(source, copy)`: the joints the reference copies from a predicted joint, because they sit on
/// it (zero offset).
pub const H36M_COPIED_JOINTS: [(usize, usize); 6] =
    [(13, 16), (19, 20), (22, 23), (13, 24), (27, 28), (30, 31)];

/// Which joints a frame's error averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JointMean {
    /// Every joint of the arrays (32 for H3.6M): the reference's convention.
    #[default]
    All32,
    /// The 22 predicted joints of H3.6M only (a variant; 13-15 % larger for zero-velocity).
    Predicted22,
}

impl JointMean {
    /// The name in reports: `all-32` or `predicted-22`.
    pub fn name(self) -> &'static str {
        match self {
            JointMean::All32 => "all-32",
            JointMean::Predicted22 => "predicted-22",
        }
    }

    /// The variant named `name` (as [`JointMean::name`] writes it, or `32` / `22`).
    pub fn from_name(name: &str) -> Option<JointMean> {
        match name {
            "all-32" | "32" => Some(JointMean::All32),
            "predicted-22" | "22" => Some(JointMean::Predicted22),
            _ => None,
        }
    }
}

/// The error of every frame (`T`) of `pred` against `truth` (both `T x J x 3`, the same units):
/// the mean over the joints of `joints` of the Euclidean distance.
///
/// Errors: different shapes, an empty input, a non-finite value, [`JointMean::Predicted22`] on
/// arrays of other than 32 joints.
pub fn mpjpe(
    pred: ArrayView3<'_, f64>,
    truth: ArrayView3<'_, f64>,
    joints: JointMean,
) -> Result<Array1<f64>, MetricError> {
    check_pair("prediction", &pred, "ground truth", &truth)?;
    let selected = selected_joints(joints, truth.dim().1)?;
    Ok(per_frame(pred, truth, selected.as_deref()))
}

/// [`mpjpe`] of `N` sequences at once (`N x T x J x 3`): the error of every sequence and frame
/// (`N x T`). Parallel over sequences.
pub fn mpjpe_batch(
    pred: ArrayView4<'_, f64>,
    truth: ArrayView4<'_, f64>,
    joints: JointMean,
) -> Result<Array2<f64>, MetricError> {
    check_pair("prediction", &pred, "ground truth", &truth)?;
    let (n, t, j, _) = truth.dim();
    let selected = selected_joints(joints, j)?;
    let rows: Vec<Array1<f64>> = (0..n)
        .into_par_iter()
        .map(|i| {
            per_frame(
                pred.index_axis(Axis(0), i),
                truth.index_axis(Axis(0), i),
                selected.as_deref(),
            )
        })
        .collect();
    let mut out = Array2::zeros((n, t));
    for (mut row, errors) in out.outer_iter_mut().zip(rows) {
        row.assign(&errors);
    }
    Ok(out)
}

/// The values at [`MPJPE_HORIZON_FRAMES`] of a per-frame error curve of at least 25 frames
/// (`None` for a shorter one).
pub fn at_horizons(per_frame: &[f64]) -> Option<[f64; 8]> {
    if per_frame.len() < MPJPE_OUTPUT_FRAMES {
        return None;
    }
    Some(MPJPE_HORIZON_FRAMES.map(|f| per_frame[f]))
}

/// Joint positions (mm, `T x 32 x 3`) of H3.6M exp-map frames (`T x 99`) as the 3-D protocols
/// compute them: dims 0..5 set to zero, then forward kinematics with the built-in H3.6M skeleton
/// (the offsets of the reference's `_some_variables`). Every frame has the root at the origin and
/// no heading.
///
/// Errors: frames of other than 99 dims, or a non-finite value.
pub fn h36m_pelvis_positions(frames: ArrayView2<'_, f64>) -> Result<Array3<f64>, MetricError> {
    if frames.ncols() != H36M_FRAME_DIMS {
        return Err(MetricError::ShapeMismatch {
            what: "exp-map frames".into(),
            found: frames.shape().to_vec(),
            expected: vec![frames.nrows(), H36M_FRAME_DIMS],
        });
    }
    check_finite("exp-map frames", &frames)?;
    let skeleton = Skeleton::h36m();
    let mut fk = ExpMapFk::new(&skeleton);
    let mut frame = [0.0; H36M_FRAME_DIMS];
    let mut joints = [[0.0; 3]; H36M_JOINT_COUNT];
    let mut out = Array3::zeros((frames.nrows(), H36M_JOINT_COUNT, 3));
    for (row, mut dst) in frames.outer_iter().zip(out.outer_iter_mut()) {
        for (d, (f, v)) in frame.iter_mut().zip(row.iter()).enumerate() {
            *f = if d < 6 { 0.0 } else { *v };
        }
        fk.frame(&skeleton, &frame, &RootPose::IDENTITY, &mut joints);
        for (j, p) in joints.iter().enumerate() {
            dst.slice_mut(s![j, ..]).assign(&ndarray::aview1(p));
        }
    }
    Ok(out)
}

/// The reference's full 32-joint prediction from the 22 predicted joints (`T x 22 x 3`, in
/// [`H36M_PREDICTED_JOINTS`] order): the ground truth (`T x 32 x 3`), the 22 written over it,
/// then the [`H36M_COPIED_JOINTS`] copied.
pub fn fill_h36m_prediction(
    predicted: ArrayView3<'_, f64>,
    truth: ArrayView3<'_, f64>,
) -> Result<Array3<f64>, MetricError> {
    let (t, j, c) = truth.dim();
    if (j, c) != (H36M_JOINT_COUNT, 3) {
        return Err(MetricError::ShapeMismatch {
            what: "ground truth".into(),
            found: truth.shape().to_vec(),
            expected: vec![t, H36M_JOINT_COUNT, 3],
        });
    }
    if predicted.dim() != (t, H36M_PREDICTED_JOINTS.len(), 3) {
        return Err(MetricError::ShapeMismatch {
            what: "prediction of the 22 joints".into(),
            found: predicted.shape().to_vec(),
            expected: vec![t, H36M_PREDICTED_JOINTS.len(), 3],
        });
    }
    let mut out = truth.to_owned();
    for (k, &joint) in H36M_PREDICTED_JOINTS.iter().enumerate() {
        out.slice_mut(s![.., joint, ..])
            .assign(&predicted.slice(s![.., k, ..]));
    }
    for (source, copy) in H36M_COPIED_JOINTS {
        let values = out.slice(s![.., source, ..]).to_owned();
        out.slice_mut(s![.., copy, ..]).assign(&values);
    }
    Ok(out)
}

/// How the arrays given to [`score_mpjpe`] are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MpjpeInput {
    /// H3.6M exp-map frames (`N x T x 99`): positions by [`h36m_pelvis_positions`].
    Expmap,
    /// Positions, `N x T x J x 3` or `N x T x 3J` (flattened joints, LTD's layout).
    Positions,
}

/// [`score_mpjpe`]'s result.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MpjpeScores {
    /// Sequences scored.
    pub sequences: usize,
    /// The error of every predicted frame, the mean over sequences.
    pub per_frame: Vec<f64>,
    /// The values at 80 ... 1000 ms ([`MPJPE_HORIZON_FRAMES`], 25 Hz frames) when the prediction
    /// has 25 frames or more.
    pub horizons: Option<[f64; 8]>,
    /// `true` when the prediction held the 22 predicted H3.6M joints and was completed from the
    /// ground truth ([`fill_h36m_prediction`]).
    pub filled_from_truth: bool,
}

/// MPJPE of predictions against ground truth given as arrays (`score --metric mpjpe`, Python's
/// `motion.mpjpe`): both read as `input`, the error of every frame averaged over sequences. A
/// prediction of the 22 predicted joints against 32-joint truth is completed the reference's way.
pub fn score_mpjpe(
    pred: ndarray::ArrayViewD<'_, f64>,
    truth: ndarray::ArrayViewD<'_, f64>,
    input: MpjpeInput,
    joints: JointMean,
) -> Result<MpjpeScores, MetricError> {
    let truth = positions_of(truth, input, "ground truth")?;
    let mut pred = positions_of(pred, input, "prediction")?;
    let (n, t, j, _) = truth.dim();
    let filled = pred.dim() == (n, t, H36M_PREDICTED_JOINTS.len(), 3) && j == H36M_JOINT_COUNT;
    if filled {
        let mut full = Array4::zeros(truth.raw_dim());
        for i in 0..n {
            full.index_axis_mut(Axis(0), i)
                .assign(&fill_h36m_prediction(
                    pred.index_axis(Axis(0), i),
                    truth.index_axis(Axis(0), i),
                )?);
        }
        pred = full.into();
    }
    let errors = mpjpe_batch(pred.view(), truth.view(), joints)?;
    let per_frame = errors.mean_axis(Axis(0)).expect("not empty").to_vec();
    Ok(MpjpeScores {
        sequences: n,
        horizons: at_horizons(&per_frame),
        per_frame,
        filled_from_truth: filled,
    })
}

/// `N x T x J x 3` positions of an input read as `input` (a view of 4-D positions, else a copy).
fn positions_of<'a>(
    values: ndarray::ArrayViewD<'a, f64>,
    input: MpjpeInput,
    what: &str,
) -> Result<ndarray::CowArray<'a, f64, ndarray::Ix4>, MetricError> {
    let shape = values.shape().to_vec();
    let wrong = |expected: &str| {
        MetricError::InvalidConfig(format!(
            "MPJPE reads the {what} as {expected}; its shape is {shape:?}"
        ))
    };
    check_not_empty(what, &values)?;
    match input {
        MpjpeInput::Expmap => {
            if shape.len() != 3 || shape[2] != H36M_FRAME_DIMS {
                return Err(wrong("H3.6M exp-map frames N x T x 99"));
            }
            let mut out = Array4::zeros((shape[0], shape[1], H36M_JOINT_COUNT, 3));
            for (i, seq) in values.outer_iter().enumerate() {
                let seq = seq
                    .into_dimensionality::<ndarray::Ix2>()
                    .expect("3-D input");
                let positions = h36m_pelvis_positions(seq).map_err(|e| match e {
                    MetricError::NonFinite { index, .. } => MetricError::NonFinite {
                        what: what.to_string(),
                        index: [vec![i], index].concat(),
                    },
                    other => other,
                })?;
                out.index_axis_mut(Axis(0), i).assign(&positions);
            }
            Ok(out.into())
        }
        MpjpeInput::Positions => match shape.len() {
            4 => Ok(values
                .into_dimensionality::<ndarray::Ix4>()
                .expect("4-D input")
                .into()),
            3 if shape[2].is_multiple_of(3) => {
                let dims = (shape[0], shape[1], shape[2] / 3, 3);
                Ok(match values.clone().into_shape_with_order(dims) {
                    Ok(view) => view.into(),
                    Err(_) => values
                        .to_owned()
                        .into_shape_with_order(dims)
                        .expect("same element count")
                        .into_dimensionality::<ndarray::Ix4>()
                        .expect("4-D")
                        .into(),
                })
            }
            _ => Err(wrong("positions N x T x J x 3 or N x T x 3J")),
        },
    }
}

fn check_pair<D: ndarray::Dimension>(
    a_name: &str,
    a: &ndarray::ArrayView<'_, f64, D>,
    b_name: &str,
    b: &ndarray::ArrayView<'_, f64, D>,
) -> Result<(), MetricError> {
    check_not_empty(b_name, b)?;
    if a.shape() != b.shape() {
        return Err(MetricError::ShapeMismatch {
            what: a_name.to_string(),
            found: a.shape().to_vec(),
            expected: b.shape().to_vec(),
        });
    }
    if b.shape()[b.ndim() - 1] != 3 {
        return Err(MetricError::InvalidConfig(format!(
            "MPJPE needs positions with 3 coordinates per joint; the last axis of {b_name} has {}",
            b.shape()[b.ndim() - 1]
        )));
    }
    check_finite(a_name, a)?;
    check_finite(b_name, b)
}

fn selected_joints(joints: JointMean, count: usize) -> Result<Option<Vec<usize>>, MetricError> {
    match joints {
        JointMean::All32 => Ok(None),
        JointMean::Predicted22 if count == H36M_JOINT_COUNT => {
            Ok(Some(H36M_PREDICTED_JOINTS.to_vec()))
        }
        JointMean::Predicted22 => Err(MetricError::InvalidConfig(format!(
            "the 22-joint mean is defined on the 32 H3.6M joints; the positions have {count}"
        ))),
    }
}

fn per_frame(
    pred: ArrayView3<'_, f64>,
    truth: ArrayView3<'_, f64>,
    joints: Option<&[usize]>,
) -> Array1<f64> {
    let count = truth.dim().1;
    // One pass over row-major slices (a copy only for inputs that are not), joints summed in order.
    let (pred, truth) = (pred.as_standard_layout(), truth.as_standard_layout());
    let (p, g) = (
        pred.as_slice().expect("standard layout"),
        truth.as_slice().expect("standard layout"),
    );
    let row = 3 * count;
    p.chunks_exact(row)
        .zip(g.chunks_exact(row))
        .map(|(a, b)| match joints {
            Some(list) => {
                list.iter()
                    .map(|&j| distance3(&a[3 * j..3 * j + 3], &b[3 * j..3 * j + 3]))
                    .sum::<f64>()
                    / list.len() as f64
            }
            None => {
                a.chunks_exact(3)
                    .zip(b.chunks_exact(3))
                    .map(|(x, y)| distance3(x, y))
                    .sum::<f64>()
                    / count as f64
            }
        })
        .collect()
}

fn distance3(a: &[f64], b: &[f64]) -> f64 {
    let (x, y, z) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    (x * x + y * y + z * z).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twenty_two_joints_are_completed_from_the_truth_and_layouts_agree() {
        let frames = ndarray::Array3::from_shape_fn((2, 25, 99), |(n, t, d)| {
            0.05 * ((d * 3 + t + n) % 13) as f64 - 0.3
        });
        let truth = {
            let mut out = Array4::zeros((2, 25, 32, 3));
            for n in 0..2 {
                out.index_axis_mut(Axis(0), n)
                    .assign(&h36m_pelvis_positions(frames.index_axis(Axis(0), n)).unwrap());
            }
            out
        };
        let moved = truth.mapv(|v| v + 2.0);
        let pred22 = Array4::from_shape_fn((2, 25, 22, 3), |(n, t, k, c)| {
            moved[[n, t, H36M_PREDICTED_JOINTS[k], c]]
        });
        let flat = pred22.clone().into_shape_with_order((2, 25, 66)).unwrap();
        let a = score_mpjpe(
            flat.view().into_dyn(),
            truth.view().into_dyn(),
            MpjpeInput::Positions,
            JointMean::All32,
        )
        .unwrap();
        let b = score_mpjpe(
            pred22.view().into_dyn(),
            truth.view().into_dyn(),
            MpjpeInput::Positions,
            JointMean::All32,
        )
        .unwrap();
        assert!(a.filled_from_truth);
        assert_eq!(a, b);
        // Moved by (2, 2, 2): 22 + 6 copies of sqrt(12) over 32 joints.
        let expected = 28.0 * 12f64.sqrt() / 32.0;
        assert!((a.per_frame[0] - expected).abs() < 1e-9);
        let from_expmap = score_mpjpe(
            frames.view().into_dyn(),
            frames.view().into_dyn(),
            MpjpeInput::Expmap,
            JointMean::All32,
        )
        .unwrap();
        assert_eq!(from_expmap.horizons, Some([0.0; 8]));
        assert!(score_mpjpe(
            flat.view().into_dyn(),
            flat.view().into_dyn(),
            MpjpeInput::Expmap,
            JointMean::All32
        )
        .is_err());
    }

    fn wave(t: usize, j: usize, phase: f64) -> Array3<f64> {
        Array3::from_shape_fn((t, j, 3), |(a, b, c)| {
            (0.3 * a as f64 + 0.7 * b as f64 + c as f64 + phase).sin() * 100.0
        })
    }

    #[test]
    fn the_error_is_the_mean_joint_distance_of_each_frame() {
        let truth = wave(4, 5, 0.0);
        let pred = wave(4, 5, 0.4);
        let got = mpjpe(pred.view(), truth.view(), JointMean::All32).unwrap();
        for t in 0..4 {
            let mut sum = 0.0;
            for j in 0..5 {
                let d: Vec<f64> = (0..3).map(|c| pred[[t, j, c]] - truth[[t, j, c]]).collect();
                sum += (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            }
            assert!((got[t] - sum / 5.0).abs() < 1e-12);
        }
    }

    #[test]
    fn the_batch_agrees_with_one_sequence_at_a_time() {
        let truth = Array4::from_shape_fn((3, 6, 32, 3), |(n, t, j, c)| {
            (n as f64 + 0.2 * t as f64 + 0.1 * j as f64 + c as f64).cos()
        });
        let pred = truth.mapv(|v| v * 1.1 + 0.01);
        for mean in [JointMean::All32, JointMean::Predicted22] {
            let batch = mpjpe_batch(pred.view(), truth.view(), mean).unwrap();
            for n in 0..3 {
                let one = mpjpe(
                    pred.index_axis(Axis(0), n),
                    truth.index_axis(Axis(0), n),
                    mean,
                )
                .unwrap();
                assert_eq!(batch.row(n).to_vec(), one.to_vec());
            }
        }
    }

    #[test]
    fn the_32_joint_mean_counts_the_copies_and_the_constant_joints() {
        // Positions of a real pose; each predicted joint moved by its own distance.
        let frames = Array2::from_shape_fn((1, 99), |(_, d)| 0.1 * ((d * 7) % 11) as f64 - 0.5);
        let truth = h36m_pelvis_positions(frames.view()).unwrap();
        let predicted = Array3::from_shape_fn((1, 22, 3), |(_, k, c)| {
            truth[[0, H36M_PREDICTED_JOINTS[k], c]] + if c == 0 { 1.0 + k as f64 } else { 0.0 }
        });
        let full = fill_h36m_prediction(predicted.view(), truth.view()).unwrap();
        let e = |j: usize| {
            H36M_PREDICTED_JOINTS
                .iter()
                .position(|&p| p == j)
                .map_or(0.0, |k| 1.0 + k as f64)
        };
        let expected = (H36M_PREDICTED_JOINTS.iter().map(|&j| e(j)).sum::<f64>()
            + 2.0 * e(13)
            + e(19)
            + e(22)
            + e(27)
            + e(30))
            / 32.0;
        let all = mpjpe(full.view(), truth.view(), JointMean::All32).unwrap();
        assert!((all[0] - expected).abs() < 1e-9, "{} vs {expected}", all[0]);
        let only22 = mpjpe(full.view(), truth.view(), JointMean::Predicted22).unwrap();
        assert!((only22[0] - 11.5).abs() < 1e-9); // the mean of 1..=22
    }

    #[test]
    fn pelvis_positions_ignore_the_root_and_put_copies_on_their_sources() {
        let mut frames =
            Array2::from_shape_fn((2, 99), |(t, d)| 0.05 * ((d * 3 + t) % 13) as f64 - 0.3);
        let a = h36m_pelvis_positions(frames.view()).unwrap();
        for d in 0..6 {
            frames[[1, d]] += 100.0 + d as f64;
        }
        let b = h36m_pelvis_positions(frames.view()).unwrap();
        assert_eq!(a, b);
        for (source, copy) in H36M_COPIED_JOINTS {
            for c in 0..3 {
                assert!((a[[0, source, c]] - a[[0, copy, c]]).abs() < 1e-9);
            }
        }
        for c in 0..3 {
            assert_eq!(a[[0, 0, c]], 0.0);
        }
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let truth = wave(3, 32, 0.0);
        let short = wave(2, 32, 0.0);
        assert!(matches!(
            mpjpe(short.view(), truth.view(), JointMean::All32),
            Err(MetricError::ShapeMismatch { .. })
        ));
        let mut bad = truth.clone();
        bad[[1, 2, 0]] = f64::NAN;
        assert!(matches!(
            mpjpe(bad.view(), truth.view(), JointMean::All32),
            Err(MetricError::NonFinite { index, .. }) if index == vec![1, 2, 0]
        ));
        let few = wave(3, 17, 0.0);
        assert!(matches!(
            mpjpe(few.view(), few.view(), JointMean::Predicted22),
            Err(MetricError::InvalidConfig(_))
        ));
        let flat = Array3::<f64>::zeros((3, 32, 2));
        assert!(mpjpe(flat.view(), flat.view(), JointMean::All32).is_err());
        assert!(h36m_pelvis_positions(Array2::zeros((2, 98)).view()).is_err());
        assert_eq!(at_horizons(&[0.0; 24]), None);
        let curve: Vec<f64> = (0..25).map(f64::from).collect();
        assert_eq!(
            at_horizons(&curve),
            Some([1.0, 3.0, 7.0, 9.0, 13.0, 17.0, 21.0, 24.0])
        );
    }
}
