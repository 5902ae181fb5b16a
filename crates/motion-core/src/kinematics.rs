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
use crate::motion::RootEncoding;
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
