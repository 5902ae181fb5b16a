//! BVH from engine [`Pose`]s: the root's position and every joint's local rotation written as the
//! skeleton's BVH channels (degrees, each joint's own rotation order, continuous through ±180°).
//!
//! The inverse direction is the usual one: [`read_bvh`](super::bvh::read_bvh), then
//! [`bvh_to_expmap`](super::expmap_bvh::bvh_to_expmap) and a
//! [`PoseDecoder`](crate::pose::PoseDecoder) give the same poses back.
use glam::DVec3;
use ndarray::Array2;

use super::bvh::Bvh;
use super::expmap_bvh::{continuous_euler_degrees, joint_channels, ConvertError};
use crate::pose::{Pose, METRES_PER_MM};
use crate::skeleton::Skeleton;

/// The BVH of `poses` (metres, column-vector rotations) on `skeleton` (offsets in millimetres,
/// BVH channels on every joint: 3 rotations, the root also 3 positions) at `fps`.
///
/// # Errors
/// A joint whose channels cannot hold a rotation (or a root without positions), a pose with
/// another joint count, or a non-finite value.
pub fn poses_to_bvh(skeleton: &Skeleton, poses: &[Pose], fps: f64) -> Result<Bvh, ConvertError> {
    let layouts = (0..skeleton.len())
        .map(|j| joint_channels(skeleton, j))
        .collect::<Result<Vec<_>, _>>()?;
    let channels = skeleton.channel_count();
    let mut frames = Array2::zeros((poses.len(), channels));
    let mut previous = vec![0.0; channels];
    let root_offset = DVec3::from_array(skeleton.joint(0).offset);
    for (t, pose) in poses.iter().enumerate() {
        if pose.local_rotations.len() != skeleton.len() {
            return Err(ConvertError::Channels {
                joint: skeleton.joint(0).name.clone(),
                problem: format!(
                    "pose {t} has {} joints, the skeleton {}",
                    pose.local_rotations.len(),
                    skeleton.len()
                ),
            });
        }
        let finite =
            pose.root_translation.is_finite() && pose.local_rotations.iter().all(|q| q.is_finite());
        if !finite {
            return Err(ConvertError::NonFinite { frame: t });
        }
        let mut row = frames.row_mut(t);
        for (j, layout) in layouts.iter().enumerate() {
            if let Some(position) = layout.position {
                let p = pose.root_translation.as_dvec3() / METRES_PER_MM - root_offset;
                for axis in 0..3 {
                    row[layout.start + position[axis]] = p[axis];
                }
            }
            let q = pose.local_rotations[j].as_dquat().normalize();
            let (order, columns) = layout.rotation;
            let before = (t > 0).then(|| columns.map(|c| previous[layout.start + c]));
            let angles = continuous_euler_degrees(order, q, before);
            for axis in 0..3 {
                row[layout.start + columns[axis]] = angles[axis];
            }
        }
        previous
            .iter_mut()
            .zip(row.iter())
            .for_each(|(p, v)| *p = *v);
    }
    Ok(Bvh {
        skeleton: skeleton.clone(),
        frames,
        frame_time: 1.0 / fps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::bvh::{read_bvh, write_bvh};
    use crate::formats::expmap_bvh::{bvh_to_expmap, ExpMapTarget};
    use crate::motion::RootEncoding;
    use crate::pose::PoseDecoder;
    use std::sync::Arc;

    #[test]
    fn bvh_written_from_poses_reimports_to_the_same_poses() {
        let skeleton = Arc::new(Skeleton::h36m());
        let frames = ndarray::Array2::from_shape_fn((50, 99), |(t, d)| match d {
            0 => 9.0,
            2 => -2.0,
            4 => 0.02,
            5 => 0.001 * t as f64,
            _ => 1.4 * ((t as f64) * 0.11 + d as f64 * 0.9).sin(),
        });
        let poses = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, 2)
            .decode_all(frames.view());
        let bvh = poses_to_bvh(&skeleton, &poses, 25.0).unwrap();
        let dir = std::env::temp_dir().join(format!("pose-bvh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("poses.bvh");
        write_bvh(&path, &bvh).unwrap();
        let back = read_bvh(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let motion = bvh_to_expmap(&back, ExpMapTarget::H36m).unwrap();
        let mut again = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, 2);
        let (mut worst_joint, mut worst_root, mut worst_p) = (0.0f32, 0.0f32, 0.0f32);
        for (t, row) in motion.frames().rows().into_iter().enumerate() {
            let pose = again.push(row.as_slice().unwrap());
            worst_p = worst_p.max((pose.root_translation - poses[t].root_translation).length());
            let pairs = pose.local_rotations.iter().zip(&poses[t].local_rotations);
            for (j, (a, b)) in pairs.enumerate() {
                // The vector part of the difference: precise for small angles (acos is not).
                let d = a.as_dquat().inverse() * b.as_dquat();
                let e = 2.0 * d.xyz().length() as f32;
                if j == 0 {
                    worst_root = worst_root.max(e);
                } else {
                    worst_joint = worst_joint.max(e);
                }
            }
        }
        let (joint, root) = (worst_joint.to_degrees(), worst_root.to_degrees());
        eprintln!("worst joint rotation {joint} deg, root {root} deg, root position {worst_p} m");
        assert!(joint < 1e-4, "{joint} deg");
        // The root goes through H3.6M deltas: re-derived and re-integrated with the data's
        // float32-epsilon exp map, whose matrices are not exactly orthonormal (~1e-6 rad here).
        assert!(root < 5e-4, "{root} deg");
        assert!(worst_p < 1e-6, "{worst_p} m");
    }
}
