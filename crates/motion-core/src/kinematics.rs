//! Forward kinematics: world joint positions (mm) from exp-map frames (H3.6M row-vector
//! convention) or from BVH channel frames (column-vector convention).
//!
//! ## Exp-map FK (h36m.md)
//! `R_j = expmap2rotmat(angles of joint j)`; root `W_0 = R_root`, `x_0 = offset_0 + T_root`;
//! child `j` of `p`: `W_j = R_j · W_p`, `x_j = offset_j · W_p + x_p` (offset as a row vector).
//! The root rotation/translation come from the integrated deltas (H3.6M) or straight from dims
//! 0..5 (CMU). Unlike the widely copied Python `fkl`, the exp-map values are **not** added to the
//! offsets and the root translation is **not** ignored.
//!
//! ## Channel FK (BVH)
//! Column vectors. A joint's local rotation is the product of its rotation channels **in listed
//! order** (`CHANNELS 3 Zrotation Xrotation Yrotation` -> `Rz · Rx · Ry`); its local translation
//! is its offset **plus** its position channels (BVH roots usually have a zero offset, so this is
//! the position channels). World: `M_j = M_p · L_j`, `x_j = x_p + M_p · t_j`. Channel values are
//! as in the BVH file: rotations in **degrees**.
use glam::{DMat3, DVec3};
use ndarray::{Array3, ArrayView2};

use crate::error::MotionError;
use crate::root::RootEncoding;
use crate::root::{RootIntegrator, RootPose};
use crate::rotation::{expmap2rotmat, mat3_mul, vec_mul_mat3, Mat3, MAT3_IDENTITY};
use crate::skeleton::{Channel, Skeleton};

/// Scratch space of the exp-map FK (one world rotation per joint), allocated once.
#[derive(Debug, Clone)]
pub struct ExpMapFk {
    world: Vec<Mat3>,
}

impl ExpMapFk {
    /// Scratch for `skeleton`.
    pub fn new(skeleton: &Skeleton) -> ExpMapFk {
        ExpMapFk {
            world: vec![MAT3_IDENTITY; skeleton.len()],
        }
    }

    /// Positions of one exp-map frame with the given absolute root pose (dims 0..5 of the frame
    /// are ignored): writes `skeleton.len()` positions into `out`. No allocation.
    ///
    /// # Panics
    /// If `frame.len() != skeleton.expmap_width()`, `out.len() != skeleton.len()` or the scratch
    /// was made for a smaller skeleton.
    pub fn frame(
        &mut self,
        skeleton: &Skeleton,
        frame: &[f64],
        root: &RootPose,
        out: &mut [[f64; 3]],
    ) {
        assert_eq!(frame.len(), skeleton.expmap_width(), "exp-map frame width");
        assert_eq!(out.len(), skeleton.len(), "output joints");
        assert!(self.world.len() >= skeleton.len(), "scratch too small");
        for (j, joint) in skeleton.joints().iter().enumerate() {
            match joint.parent {
                None => {
                    self.world[j] = root.rotation;
                    out[j] = add(joint.offset, root.translation);
                }
                Some(p) => {
                    let k = 3 + 3 * j;
                    let local = expmap2rotmat([frame[k], frame[k + 1], frame[k + 2]]);
                    let wp = self.world[p];
                    self.world[j] = mat3_mul(&local, &wp);
                    out[j] = add(vec_mul_mat3(joint.offset, &wp), out[p]);
                }
            }
        }
    }

    /// World rotations (row-vector convention) of the last frame computed.
    pub fn world_rotations(&self) -> &[Mat3] {
        &self.world
    }
}

/// World joint positions `T x J x 3` (mm) of exp-map frames. With [`RootEncoding::Deltas`] the
/// root is integrated with `step` source frames per frame (1 at 50 Hz, 2 at the protocol's
/// 25 Hz; see [`crate::root`]); with [`RootEncoding::Absolute`] `step` is ignored.
pub fn expmap_positions(
    skeleton: &Skeleton,
    frames: ArrayView2<f64>,
    root: RootEncoding,
    step: usize,
) -> Result<Array3<f64>, MotionError> {
    let width = skeleton.expmap_width();
    if frames.ncols() != width {
        return Err(MotionError::ChannelCount {
            expected: width,
            found: frames.ncols(),
        });
    }
    let joints = skeleton.len();
    let mut out = Array3::zeros((frames.nrows(), joints, 3));
    let mut fk = ExpMapFk::new(skeleton);
    let mut integrator = RootIntegrator::new(step);
    let mut frame = vec![0.0; width];
    let mut positions = vec![[0.0; 3]; joints];
    for (t, row) in frames.rows().into_iter().enumerate() {
        for (dst, src) in frame.iter_mut().zip(row.iter()) {
            *dst = *src;
        }
        let pose = match root {
            RootEncoding::Deltas => integrator.push(&frame),
            RootEncoding::Absolute => RootPose::from_absolute_frame(&frame),
        };
        fk.frame(skeleton, &frame, &pose, &mut positions);
        for (j, p) in positions.iter().enumerate() {
            for k in 0..3 {
                out[[t, j, k]] = p[k];
            }
        }
    }
    Ok(out)
}

/// Scratch space of the channel (BVH) FK, allocated once.
#[derive(Debug, Clone)]
pub struct ChannelFk {
    world: Vec<DMat3>,
}

impl ChannelFk {
    /// Scratch for `skeleton`.
    pub fn new(skeleton: &Skeleton) -> ChannelFk {
        ChannelFk {
            world: vec![DMat3::IDENTITY; skeleton.len()],
        }
    }

    /// Positions of one BVH frame (rotation channels in **degrees**, as in the file): writes `skeleton.len()`
    /// positions into `out`. No allocation.
    ///
    /// # Panics
    /// If `frame.len() != skeleton.channel_count()`, `out.len() != skeleton.len()` or the scratch
    /// was made for a smaller skeleton.
    pub fn frame(&mut self, skeleton: &Skeleton, frame: &[f64], out: &mut [[f64; 3]]) {
        assert_eq!(frame.len(), skeleton.channel_count(), "channel frame width");
        assert_eq!(out.len(), skeleton.len(), "output joints");
        assert!(self.world.len() >= skeleton.len(), "scratch too small");
        for (j, joint) in skeleton.joints().iter().enumerate() {
            let (local_rot, local_t) = local_transform(skeleton, j, frame);
            match joint.parent {
                None => {
                    self.world[j] = local_rot;
                    out[j] = local_t.to_array();
                }
                Some(p) => {
                    let wp = self.world[p];
                    self.world[j] = wp * local_rot;
                    out[j] = (DVec3::from_array(out[p]) + wp * local_t).to_array();
                }
            }
        }
    }

    /// World rotations (column-vector convention) of the last frame computed.
    pub fn world_rotations(&self) -> &[DMat3] {
        &self.world
    }
}

/// Local rotation (rotation channels composed in listed order) and translation (offset plus
/// position channels) of joint `j` in a BVH frame (rotation channels in degrees).
pub fn local_transform(skeleton: &Skeleton, j: usize, frame: &[f64]) -> (DMat3, DVec3) {
    let joint = skeleton.joint(j);
    let start = skeleton.channel_start(j);
    let mut rot = DMat3::IDENTITY;
    let mut t = DVec3::from_array(joint.offset);
    for (k, channel) in joint.channels.iter().enumerate() {
        let v = frame[start + k];
        let a = v.to_radians();
        match channel {
            Channel::Xposition => t.x += v,
            Channel::Yposition => t.y += v,
            Channel::Zposition => t.z += v,
            Channel::Xrotation => rot *= DMat3::from_rotation_x(a),
            Channel::Yrotation => rot *= DMat3::from_rotation_y(a),
            Channel::Zrotation => rot *= DMat3::from_rotation_z(a),
        }
    }
    (rot, t)
}

/// World joint positions `T x J x 3` of BVH channel frames (rotations in degrees).
pub fn channel_positions(
    skeleton: &Skeleton,
    frames: ArrayView2<f64>,
) -> Result<Array3<f64>, MotionError> {
    let width = skeleton.channel_count();
    if frames.ncols() != width {
        return Err(MotionError::ChannelCount {
            expected: width,
            found: frames.ncols(),
        });
    }
    let joints = skeleton.len();
    let mut out = Array3::zeros((frames.nrows(), joints, 3));
    let mut fk = ChannelFk::new(skeleton);
    let mut frame = vec![0.0; width];
    let mut positions = vec![[0.0; 3]; joints];
    for (t, row) in frames.rows().into_iter().enumerate() {
        for (dst, src) in frame.iter_mut().zip(row.iter()) {
            *dst = *src;
        }
        fk.frame(skeleton, &frame, &mut positions);
        for (j, p) in positions.iter().enumerate() {
            for k in 0..3 {
                out[[t, j, k]] = p[k];
            }
        }
    }
    Ok(out)
}

#[inline]
fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::root::integrate_root;
    use crate::rotation::{dmat3_to_euler, mat3_to_dmat3, EulerOrder};
    use ndarray::Array2;

    fn wavy_frames(frames: usize, width: usize, amplitude: f64) -> Array2<f64> {
        Array2::from_shape_fn((frames, width), |(t, k)| {
            let x = (t as f64 * 0.21 + k as f64 * 0.77).sin();
            match k {
                0..=2 => 12.0 * x,
                3..=5 => 0.03 * x,
                _ => amplitude * x,
            }
        })
    }

    fn dist(a: &[f64], b: &[f64]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    #[test]
    fn rest_pose_is_the_sum_of_offsets() {
        let s = Skeleton::h36m();
        let frames = Array2::zeros((1, 99));
        let p = expmap_positions(&s, frames.view(), RootEncoding::Deltas, 1).unwrap();
        // HeadSite = Spine + Spine1 + Neck + Head + HeadSite offsets (all along y).
        let want = 0.1 + 233.383263 + 257.077681 + 121.134938 + 115.002227;
        assert!((p[[0, 15, 1]] - want).abs() < 1e-9);
        assert!((p[[0, 3, 1]] - (-442.894612 - 454.206447)).abs() < 1e-9);
        assert!((p[[0, 1, 0]] + 132.948591).abs() < 1e-12);
    }

    #[test]
    fn bone_lengths_are_preserved_and_root_translation_is_used() {
        let s = Skeleton::h36m();
        let frames = wavy_frames(60, 99, 0.8);
        let p = expmap_positions(&s, frames.view(), RootEncoding::Deltas, 1).unwrap();
        let mut worst: f64 = 0.0;
        for t in 0..60 {
            for j in 1..s.len() {
                let parent = s.parent(j).unwrap();
                let a = [p[[t, j, 0]], p[[t, j, 1]], p[[t, j, 2]]];
                let b = [p[[t, parent, 0]], p[[t, parent, 1]], p[[t, parent, 2]]];
                worst = worst.max((dist(&a, &b) - s.bone_length(j)).abs());
            }
        }
        assert!(worst < 1e-3, "bone length error {worst} mm");
        // The root follows the integrated deltas (unlike the Python `fkl` quirk).
        let poses = integrate_root(frames.view(), 1);
        for k in 0..3 {
            assert_eq!(p[[59, 0, k]], poses[59].translation[k]);
        }
        assert!(poses[59].translation.iter().any(|v| v.abs() > 1.0));
    }

    #[test]
    fn absolute_root_reads_dims_0_to_5_directly() {
        let s = Skeleton::cmu();
        let frames = wavy_frames(5, 117, 0.5);
        let p = expmap_positions(&s, frames.view(), RootEncoding::Absolute, 7).unwrap();
        for t in 0..5 {
            for k in 0..3 {
                assert_eq!(p[[t, 0, k]], frames[[t, k]]);
            }
        }
    }

    #[test]
    fn wrong_widths_are_errors() {
        let s = Skeleton::h36m();
        let frames = Array2::zeros((2, 98));
        assert_eq!(
            expmap_positions(&s, frames.view(), RootEncoding::Deltas, 1).unwrap_err(),
            MotionError::ChannelCount {
                expected: 99,
                found: 98
            }
        );
        assert!(channel_positions(&s, frames.view()).is_err());
    }

    /// Converts exp-map frames to BVH channels of `Skeleton::h36m()` (root position + ZXY degrees)
    /// the way the H3.6M -> BVH conversion must: column-vector local rotation = `R_jᵀ`.
    fn to_channels(frames: &Array2<f64>) -> Array2<f64> {
        let s = Skeleton::h36m();
        let poses = integrate_root(frames.view(), 1);
        let mut out = Array2::zeros((frames.nrows(), s.channel_count()));
        for t in 0..frames.nrows() {
            for k in 0..3 {
                out[[t, k]] = poses[t].translation[k];
            }
            for j in 0..s.len() {
                let row = if j == 0 {
                    poses[t].rotation
                } else {
                    let k = 3 + 3 * j;
                    expmap2rotmat([frames[[t, k]], frames[[t, k + 1]], frames[[t, k + 2]]])
                };
                let col = mat3_to_dmat3(&row).transpose();
                let e = dmat3_to_euler(EulerOrder::ZXY, &col);
                let start = s.channel_start(j) + if j == 0 { 3 } else { 0 };
                for k in 0..3 {
                    out[[t, start + k]] = e[k].to_degrees();
                }
            }
        }
        out
    }

    #[test]
    fn channel_fk_agrees_with_expmap_fk_on_the_h36m_skeleton() {
        let s = Skeleton::h36m();
        let frames = wavy_frames(40, 99, 1.0);
        let want = expmap_positions(&s, frames.view(), RootEncoding::Deltas, 1).unwrap();
        let got = channel_positions(&s, to_channels(&frames).view()).unwrap();
        let worst = want
            .iter()
            .zip(got.iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "FK disagreement {worst} mm");
    }

    #[test]
    fn channel_fk_composes_rotations_in_listed_order_and_adds_positions() {
        let s = Skeleton::new(vec![
            crate::skeleton::Joint::new(
                "root",
                None,
                [1.0, 0.0, 0.0],
                vec![Channel::Xposition, Channel::Zrotation, Channel::Xrotation],
            ),
            crate::skeleton::Joint::end_site("tip", 0, [0.0, 1.0, 0.0]),
        ])
        .unwrap();
        let frame = [2.0, 90.0, 90.0];
        let mut out = [[0.0; 3]; 2];
        ChannelFk::new(&s).frame(&s, &frame, &mut out);
        assert_eq!(out[0], [3.0, 0.0, 0.0]);
        // Rz(90) · Rx(90) · (0, 1, 0) = Rz(90) · (0, 0, 1) = (0, 0, 1).
        assert!(dist(&out[1], &[3.0, 0.0, 1.0]) < 1e-12, "{:?}", out[1]);
    }

    #[test]
    fn per_frame_fk_matches_batch() {
        let s = Skeleton::h36m();
        let frames = wavy_frames(10, 99, 0.6);
        let batch = expmap_positions(&s, frames.view(), RootEncoding::Deltas, 2).unwrap();
        let mut fk = ExpMapFk::new(&s);
        let mut it = crate::root::RootIntegrator::new(2);
        let mut out = vec![[0.0; 3]; s.len()];
        for t in 0..10 {
            let f = frames.row(t).to_vec();
            let pose = it.push(&f);
            fk.frame(&s, &f, &pose, &mut out);
            for j in 0..s.len() {
                for k in 0..3 {
                    assert_eq!(out[j][k], batch[[t, j, k]]);
                }
            }
        }
    }
}
