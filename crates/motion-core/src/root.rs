//! H3.6M root deltas <-> absolute root trajectory.
//!
//! H3.6M frames store, in dims 0..2, the root translation **delta** of the frame (mm, expressed in
//! the root's frame of the previous frame) and, in dims 3..5, the root rotation **delta** as an
//! exponential map. With row vectors (h36m.md), starting from `R = I`, `T = 0`:
//!
//! ```text
//! R_abs(t) = Rd(t) · R_abs(t-1)
//! T_abs(t) = T_abs(t-1) + d(t) · R_abs(t-1)
//! ```
//!
//! ## Steps spanning several source frames (25 Hz)
//! The deltas are per **50 Hz source frame**. After the protocol's downsampling (keep frames
//! 0, 2, 4, ...) one 25 Hz step spans two source frames but only one delta (that of the kept
//! frame) survives. With `step = 2` we apply each kept delta `step` times, i.e. as if the dropped
//! source frame had the same delta as the kept one:
//!
//! ```text
//! R_abs(t) = Rd^s · R_abs(t-1)
//! T_abs(t) = T_abs(t-1) + d · (I + Rd + ... + Rd^(s-1)) · R_abs(t-1)
//! ```
//!
//! The **first** frame is applied once (it is source frame 0, which has no dropped predecessor),
//! so 25 Hz frame `k` approximates 50 Hz frame `2k`. [`root_deltas`] inverts this exactly (to
//! ~1e-12), including the float32-epsilon quirk of [`expmap2rotmat`].
use ndarray::{Array2, ArrayView2};

use crate::rotation::{expmap2rotmat, mat3_mul, vec_mul_mat3, Mat3, MAT3_IDENTITY};
/// How the root's dims 0..5 of an exp-map frame are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RootEncoding {
    /// Per-source-frame deltas in the previous root frame (H3.6M); integrate them for positions.
    Deltas,
    /// Absolute root translation (dims 0..2) and exp-map rotation (dims 3..5) (CMU).
    Absolute,
}

/// Rotation helpers that lived here once; they belong to [`crate::rotation`].
pub use crate::rotation::{mat3_inverse, rotmat_to_expmap_pow};

/// Absolute root pose of one frame in the H3.6M row-vector convention: a root-local point `p`
/// is at `p · rotation + translation` in the world (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootPose {
    /// World rotation of the root (row-vector convention).
    pub rotation: Mat3,
    /// World position of the root (mm).
    pub translation: [f64; 3],
}

impl RootPose {
    /// The pose before the first frame: `R = I`, `T = 0`.
    pub const IDENTITY: RootPose = RootPose {
        rotation: MAT3_IDENTITY,
        translation: [0.0; 3],
    };

    /// The pose stored **absolutely** in a frame (CMU layout): translation = dims 0..2, rotation =
    /// `expmap2rotmat(dims 3..5)`.
    ///
    /// # Panics
    /// If `frame.len() < 6`.
    pub fn from_absolute_frame(frame: &[f64]) -> RootPose {
        RootPose {
            rotation: expmap2rotmat([frame[3], frame[4], frame[5]]),
            translation: [frame[0], frame[1], frame[2]],
        }
    }

    /// This pose advanced by one delta applied `times` times (see the module docs).
    pub fn advanced(&self, d: [f64; 3], rd: [f64; 3], times: usize) -> RootPose {
        let step_rot = expmap2rotmat(rd);
        let mut pose = *self;
        for _ in 0..times {
            let moved = vec_mul_mat3(d, &pose.rotation);
            pose.translation = [
                pose.translation[0] + moved[0],
                pose.translation[1] + moved[1],
                pose.translation[2] + moved[2],
            ];
            pose.rotation = mat3_mul(&step_rot, &pose.rotation);
        }
        pose
    }
}

/// Streaming root integration: one [`RootPose`] per pushed frame, no allocation.
#[derive(Debug, Clone)]
pub struct RootIntegrator {
    pose: RootPose,
    step: usize,
    started: bool,
}

impl RootIntegrator {
    /// An integrator for frames that each span `step` source frames (1 at 50 Hz, 2 at 25 Hz).
    /// A `step` of 0 is treated as 1.
    pub fn new(step: usize) -> RootIntegrator {
        RootIntegrator {
            pose: RootPose::IDENTITY,
            step: step.max(1),
            started: false,
        }
    }

    /// An integrator that continues a take after `before`, the absolute pose of the frame
    /// before the first one pushed (every pushed frame is applied `step` times, the first one
    /// too); `None`: the first pushed frame is the take's first ([`Self::new`]).
    pub fn after(before: Option<RootPose>, step: usize) -> RootIntegrator {
        match before {
            None => RootIntegrator::new(step),
            Some(pose) => RootIntegrator {
                pose,
                step: step.max(1),
                started: true,
            },
        }
    }

    /// Integrates one frame (dims 0..5 are read) and returns its absolute pose.
    ///
    /// # Panics
    /// If `frame.len() < 6`.
    pub fn push(&mut self, frame: &[f64]) -> RootPose {
        let times = if self.started { self.step } else { 1 };
        self.started = true;
        self.pose = self.pose.advanced(
            [frame[0], frame[1], frame[2]],
            [frame[3], frame[4], frame[5]],
            times,
        );
        self.pose
    }

    /// The pose of the last pushed frame ([`RootPose::IDENTITY`] before the first).
    pub fn pose(&self) -> RootPose {
        self.pose
    }

    /// Forgets the history: the next push is a first frame again.
    pub fn reset(&mut self) {
        self.pose = RootPose::IDENTITY;
        self.started = false;
    }
}

/// Integrates the root deltas (dims 0..5 of every frame) into absolute poses.
/// `step` = source frames per frame (1 for 50 Hz H3.6M, 2 for the protocol's 25 Hz).
///
/// # Panics
/// If the frames have fewer than 6 columns.
pub fn integrate_root(frames: ArrayView2<f64>, step: usize) -> Vec<RootPose> {
    integrate_root_after(None, frames, step)
}

/// [`integrate_root`] of frames that continue a take after `before` ([`RootIntegrator::after`]).
///
/// # Panics
/// If the frames have fewer than 6 columns.
pub fn integrate_root_after(
    before: Option<RootPose>,
    frames: ArrayView2<f64>,
    step: usize,
) -> Vec<RootPose> {
    assert!(frames.ncols() >= 6, "root deltas need 6 columns");
    let mut integrator = RootIntegrator::after(before, step);
    let mut row = [0.0; 6];
    frames
        .rows()
        .into_iter()
        .map(|f| {
            for (k, r) in row.iter_mut().enumerate() {
                *r = f[k];
            }
            integrator.push(&row)
        })
        .collect()
}

/// The exact absolute root poses of the frames a downsampling by `step` keeps (source frames
/// `0, step, 2·step, ..`): every source frame of the take (`frames`, at the source rate) is
/// integrated once, from the identity before the first. A window of the downsampled take that
/// starts at kept frame `k > 0` continues after pose `k - 1` ([`RootIntegrator::after`]), so
/// its seed has the orientation the body really had (integrating the window from the identity
/// instead tilts a seated body by its pelvis' tilt; integrating the downsampled take from its
/// start piles up the dropped frames' error over minutes).
///
/// # Panics
/// If the frames have fewer than 6 columns.
pub fn integrate_root_kept(frames: ArrayView2<f64>, step: usize) -> Vec<RootPose> {
    let step = step.max(1);
    integrate_root(frames, 1)
        .into_iter()
        .step_by(step)
        .collect()
}

/// Writes the absolute root poses into dims 0..5 of every frame: translation in 0..2 and the
/// exp-map of the rotation in 3..5, in the form [`RootPose::from_absolute_frame`] reads back
/// (exactly for a rotation made by one `expmap2rotmat`; to ~1e-7 for integrated rotations, which
/// are products of its slightly non-orthonormal matrices).
pub fn write_absolute_root(poses: &[RootPose], frames: &mut Array2<f64>) {
    for (pose, mut row) in poses.iter().zip(frames.rows_mut()) {
        let r = rotmat_to_expmap_pow(&pose.rotation, 1);
        for k in 0..3 {
            row[k] = pose.translation[k];
            row[3 + k] = r[k];
        }
    }
}

/// The per-frame deltas (T x 6: translation delta, rotation delta exp-map) whose integration with
/// the same `step` gives `poses` back: the exact inverse of [`integrate_root`].
///
/// Poses that no delta can produce (e.g. a rotation step of π or more per frame at 25 Hz) are
/// approximated.
pub fn root_deltas(poses: &[RootPose], step: usize) -> Array2<f64> {
    let step = step.max(1);
    let mut out = Array2::zeros((poses.len(), 6));
    let mut prev = RootPose::IDENTITY;
    for (t, pose) in poses.iter().enumerate() {
        let times = if t == 0 { 1 } else { step };
        let (d, rd) = delta_between(&prev, pose, times);
        for k in 0..3 {
            out[[t, k]] = d[k];
            out[[t, 3 + k]] = rd[k];
        }
        prev = *pose;
    }
    out
}

/// The delta `(d, rd)` that, applied `times` times to `prev`, gives `cur`.
pub fn delta_between(prev: &RootPose, cur: &RootPose, times: usize) -> ([f64; 3], [f64; 3]) {
    let times = times.max(1);
    let prev_inv = mat3_inverse(&prev.rotation).unwrap_or(MAT3_IDENTITY);
    // Rd^times = R(t) · R(t-1)^-1
    let m = mat3_mul(&cur.rotation, &prev_inv);
    let rd = rotmat_to_expmap_pow(&m, times);
    // T(t) - T(t-1) = d · S · R(t-1) with S = I + Rd + ... + Rd^(times-1)
    let step_rot = expmap2rotmat(rd);
    let mut s = MAT3_IDENTITY;
    let mut power = MAT3_IDENTITY;
    for _ in 1..times {
        power = mat3_mul(&power, &step_rot);
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += power[i][j];
            }
        }
    }
    let sr = mat3_mul(&s, &prev.rotation);
    let dt = [
        cur.translation[0] - prev.translation[0],
        cur.translation[1] - prev.translation[1],
        cur.translation[2] - prev.translation[2],
    ];
    let d = match mat3_inverse(&sr) {
        Some(inv) => vec_mul_mat3(dt, &inv),
        None => [0.0; 3],
    };
    (d, rd)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use ndarray::Array2;

    /// Deterministic pseudo-random root deltas resembling walking (mm per 50 Hz frame, small turns).
    fn deltas(frames: usize) -> Array2<f64> {
        Array2::from_shape_fn((frames, 6), |(t, k)| {
            let x = (t as f64 * 0.37 + k as f64 * 1.3).sin();
            match k {
                0..=2 => 14.0 * x + if k == 2 { 10.0 } else { 0.0 },
                _ => 0.02 * x,
            }
        })
    }

    fn max_abs_diff(a: &Array2<f64>, b: &Array2<f64>) -> f64 {
        a.iter()
            .zip(b.iter())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn integration_follows_the_h36m_formulas() {
        let d = deltas(3);
        let poses = integrate_root(d.view(), 1);
        let r0 = expmap2rotmat([d[[0, 3]], d[[0, 4]], d[[0, 5]]]);
        assert_eq!(poses[0].rotation, r0);
        assert_eq!(poses[0].translation, [d[[0, 0]], d[[0, 1]], d[[0, 2]]]);
        let r1 = expmap2rotmat([d[[1, 3]], d[[1, 4]], d[[1, 5]]]);
        assert_eq!(poses[1].rotation, mat3_mul(&r1, &r0));
        let moved = vec_mul_mat3([d[[1, 0]], d[[1, 1]], d[[1, 2]]], &r0);
        for k in 0..3 {
            assert_eq!(poses[1].translation[k], poses[0].translation[k] + moved[k]);
        }
    }

    #[test]
    fn deltas_round_trip_at_50_hz() {
        let d = deltas(500);
        let back = root_deltas(&integrate_root(d.view(), 1), 1);
        let err = max_abs_diff(&d, &back);
        assert!(err < 1e-9, "round trip error {err}");
    }

    #[test]
    fn deltas_round_trip_at_25_hz() {
        let d = deltas(300);
        let back = root_deltas(&integrate_root(d.view(), 2), 2);
        let err = max_abs_diff(&d, &back);
        assert!(err < 1e-9, "round trip error {err}");
    }

    #[test]
    fn tiny_and_zero_rotations_round_trip() {
        let mut d = deltas(50);
        for t in 0..50 {
            for k in 3..6 {
                d[[t, k]] = if t % 3 == 0 { 0.0 } else { 1e-8 * d[[t, k]] };
            }
        }
        for step in [1, 2, 3] {
            let back = root_deltas(&integrate_root(d.view(), step), step);
            let err = max_abs_diff(&d, &back);
            assert!(err < 1e-9, "step {step}: round trip error {err}");
        }
    }

    #[test]
    fn step_two_equals_repeating_each_delta_at_50_hz() {
        let d = deltas(40);
        let poses25 = integrate_root(d.view(), 2);
        // Same motion at 50 Hz: frame 0 once, then every later delta twice.
        let mut rows = vec![d.row(0).to_vec()];
        for t in 1..40 {
            rows.push(d.row(t).to_vec());
            rows.push(d.row(t).to_vec());
        }
        let flat: Vec<f64> = rows.concat();
        let d50 = Array2::from_shape_vec((rows.len(), 6), flat).unwrap();
        let poses50 = integrate_root(d50.view(), 1);
        for t in 0..40 {
            let p = &poses50[if t == 0 { 0 } else { 2 * t }];
            assert_eq!(p.translation, poses25[t].translation);
            assert_eq!(p.rotation, poses25[t].rotation);
        }
    }

    #[test]
    fn kept_poses_are_the_exact_50_hz_poses_and_windows_continue_them() {
        let d = deltas(400);
        let exact = integrate_root(d.view(), 1);
        let kept = integrate_root_kept(d.view(), 2);
        assert_eq!(kept.len(), 200);
        for (k, pose) in kept.iter().enumerate() {
            assert_eq!(*pose, exact[2 * k]);
        }
        // A 25 Hz window from kept frame 60 continues pose 59: its first frame applied twice,
        // as every later one, exactly what integrating the downsampled take from frame 59 does.
        let d25 = d.slice(ndarray::s![..;2, ..]).to_owned();
        let window = d25.slice(ndarray::s![60..80, ..]);
        let continued = integrate_root_after(Some(kept[59]), window, 2);
        let mut it = RootIntegrator::after(Some(kept[59]), 2);
        let mut reference = RootIntegrator::new(2);
        reference.push(d25.row(0).as_slice().unwrap());
        reference.pose = kept[59];
        for (t, row) in window.rows().into_iter().enumerate() {
            let row = row.to_vec();
            assert_eq!(it.push(&row), continued[t]);
            assert_eq!(reference.push(&row), continued[t]);
        }
        // From the identity instead, the window loses the take's orientation.
        let lost = integrate_root(window, 2);
        assert_ne!(lost[0].rotation, continued[0].rotation);
        // `None` is a take's first frame.
        assert_eq!(
            integrate_root_after(None, d.view(), 2),
            integrate_root(d.view(), 2)
        );
    }

    #[test]
    fn streaming_integrator_matches_batch_and_resets() {
        let d = deltas(20);
        let batch = integrate_root(d.view(), 2);
        let mut it = RootIntegrator::new(2);
        for (t, row) in d.rows().into_iter().enumerate() {
            assert_eq!(it.push(row.as_slice().unwrap()), batch[t]);
        }
        it.reset();
        assert_eq!(it.pose(), RootPose::IDENTITY);
        assert_eq!(it.push(d.row(0).as_slice().unwrap()), batch[0]);
    }

    #[test]
    fn absolute_root_round_trips_through_frames() {
        let d = deltas(30);
        let poses = integrate_root(d.view(), 1);
        let mut frames = Array2::zeros((30, 6));
        write_absolute_root(&poses, &mut frames);
        for (t, row) in frames.rows().into_iter().enumerate() {
            let p = RootPose::from_absolute_frame(row.as_slice().unwrap());
            for i in 0..3 {
                assert!((p.translation[i] - poses[t].translation[i]).abs() < 1e-12);
                for j in 0..3 {
                    // Integrated rotations are products of expmap2rotmat's slightly
                    // non-orthonormal matrices: one exp-map reproduces them to ~1e-7 only.
                    assert!((p.rotation[i][j] - poses[t].rotation[i][j]).abs() < 1e-6);
                }
            }
        }
    }

    #[test]
    fn expmap_inverse_is_exact_at_every_angle_scale() {
        for exponent in -14..=0 {
            for (i, times) in [1usize, 2, 3].into_iter().enumerate() {
                let angle = 10f64.powi(exponent) * (1.0 + 0.37 * i as f64);
                if angle * times as f64 >= 3.0 {
                    continue; // beyond π per frame: not a delta any integration produces
                }
                let r = [0.6 * angle, -0.48 * angle, 0.64 * angle];
                let mut m = expmap2rotmat(r);
                let e = m;
                for _ in 1..times {
                    m = mat3_mul(&m, &e);
                }
                let back = rotmat_to_expmap_pow(&m, times);
                for k in 0..3 {
                    let err = (back[k] - r[k]).abs();
                    assert!(
                        err <= 1e-9 * angle.max(1e-6) && err <= 1e-12,
                        "angle {angle:e} x{times}: {back:?} vs {r:?}"
                    );
                }
            }
        }
        assert_eq!(rotmat_to_expmap_pow(&MAT3_IDENTITY, 2), [0.0; 3]);
    }

    proptest::proptest! {
        #[test]
        fn expmap_inverse_round_trips_random_rotations(
            x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0, scale in 0.0f64..3.0
        ) {
            let r = [x * scale, y * scale, z * scale];
            proptest::prop_assume!((x * x + y * y + z * z).sqrt() * scale < 3.1);
            let back = rotmat_to_expmap_pow(&expmap2rotmat(r), 1);
            for k in 0..3 {
                proptest::prop_assert!((back[k] - r[k]).abs() < 1e-9, "{:?} vs {:?}", back, r);
            }
        }
    }

    #[test]
    fn mat3_inverse_inverts() {
        let m = mat3_mul(
            &expmap2rotmat([0.3, -1.0, 0.2]),
            &[[2.0, 0.1, 0.0], [0.0, 1.0, 0.3], [0.2, 0.0, 0.5]],
        );
        let inv = mat3_inverse(&m).unwrap();
        let id = mat3_mul(&m, &inv);
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((id[i][j] - want).abs() < 1e-14);
            }
        }
        assert!(mat3_inverse(&[[0.0; 3]; 3]).is_none());
    }
}
