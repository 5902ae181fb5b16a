//! Frame-rate conversion of BVH motion: each joint's rotation by quaternion slerp between the two
//! nearest source frames, position channels linearly.
//!
//! Why in BVH space: there the root is absolute, so interpolating it is meaningful; H3.6M root
//! deltas are per 50 Hz source frame and cannot be interpolated directly.
use glam::DQuat;
use motion_core::formats::bvh::Bvh;
use motion_core::formats::expmap_bvh::{bvh_euler_to_quat, continuous_euler_degrees};
use motion_core::rotation::EulerOrder;
use motion_core::skeleton::Skeleton;
use ndarray::Array2;

/// How one joint's channels are interpolated.
enum JointPlan {
    /// Three rotation channels about distinct axes: slerp. `columns` are absolute channel
    /// indices in the order of `order`'s axes.
    Slerp {
        order: EulerOrder,
        columns: [usize; 3],
    },
    /// Anything else (odd rotation channel sets): each angle linearly.
    Linear,
}

fn plan(skeleton: &Skeleton, j: usize) -> JointPlan {
    let joint = skeleton.joint(j);
    let start = skeleton.channel_start(j);
    let rotations: Vec<(usize, usize)> = joint
        .channels
        .iter()
        .enumerate()
        .filter(|(_, c)| c.is_rotation())
        .map(|(k, c)| (c.axis(), start + k))
        .collect();
    if let [a, b, c] = rotations[..] {
        if let Some(order) = EulerOrder::from_axes([a.0, b.0, c.0]) {
            return JointPlan::Slerp {
                order,
                columns: [a.1, b.1, c.1],
            };
        }
    }
    JointPlan::Linear
}

/// Number of frames of a clip of `frames` frames at `from` Hz resampled to `to` Hz: every output
/// time `k / to` that lies within the source clip.
pub fn resampled_len(frames: usize, from: f64, to: f64) -> usize {
    if frames == 0 {
        return 0;
    }
    let span = (frames - 1) as f64 / from;
    // The small tolerance keeps the last frame when the span is a whole number of output frames.
    (span * to + 1e-6).floor() as usize + 1
}

/// `bvh` resampled to `fps` (see the module docs). Frame `k` of the result is at time `k / fps`.
pub fn resample_bvh(bvh: &Bvh, fps: f64) -> Bvh {
    let skeleton = &bvh.skeleton;
    let source_fps = bvh.fps();
    let frames_in = bvh.frames.nrows();
    let frames_out = resampled_len(frames_in, source_fps, fps);
    let channels = skeleton.channel_count();
    let plans: Vec<JointPlan> = (0..skeleton.len()).map(|j| plan(skeleton, j)).collect();
    let mut rotation_columns = vec![false; channels];
    for p in &plans {
        if let JointPlan::Slerp { columns, .. } = p {
            columns.iter().for_each(|&c| rotation_columns[c] = true);
        }
    }
    let mut out = Array2::zeros((frames_out, channels));
    for k in 0..frames_out {
        let at = k as f64 / fps * source_fps;
        let i = (at.floor() as usize).min(frames_in - 1);
        let next = (i + 1).min(frames_in - 1);
        let f = (at - i as f64).clamp(0.0, 1.0);
        let (a, b) = (bvh.frames.row(i), bvh.frames.row(next));
        for c in 0..channels {
            if !rotation_columns[c] {
                out[[k, c]] = a[c] + (b[c] - a[c]) * f;
            }
        }
        for p in &plans {
            let JointPlan::Slerp { order, columns } = *p else {
                continue;
            };
            let angles = |row: &ndarray::ArrayView1<f64>| columns.map(|c| row[c]);
            let qa = bvh_euler_to_quat(order, angles(&a));
            let qb = bvh_euler_to_quat(order, angles(&b));
            let q: DQuat = qa.slerp(qb, f);
            let previous = (k > 0).then(|| columns.map(|c| out[[k - 1, c]]));
            let degrees = continuous_euler_degrees(order, q, previous);
            for (axis, &c) in columns.iter().enumerate() {
                out[[k, c]] = degrees[axis];
            }
        }
    }
    Bvh {
        skeleton: skeleton.clone(),
        frames: out,
        frame_time: 1.0 / fps,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motion_core::formats::expmap_bvh::expmap_to_bvh;
    use motion_core::kinematics::channel_positions;
    use motion_core::motion::Motion;

    fn clip(frames: usize, fps: f64) -> Bvh {
        let data = Array2::from_shape_fn((frames, 99), |(t, d)| {
            let phase = t as f64 / fps * 6.0 + d as f64;
            if d < 3 {
                5.0
            } else if d < 6 {
                0.01 * phase.sin()
            } else {
                0.3 * phase.sin()
            }
        });
        expmap_to_bvh(&Motion::h36m(data, fps).unwrap()).unwrap()
    }

    #[test]
    fn lengths_cover_the_source_span() {
        assert_eq!(resampled_len(101, 50.0, 25.0), 51);
        assert_eq!(resampled_len(100, 50.0, 25.0), 50);
        assert_eq!(resampled_len(121, 120.0, 25.0), 26);
        assert_eq!(resampled_len(1, 120.0, 25.0), 1);
        assert_eq!(resampled_len(0, 120.0, 25.0), 0);
    }

    #[test]
    fn whole_ratio_keeps_the_source_frames() {
        let bvh = clip(41, 50.0);
        let half = resample_bvh(&bvh, 25.0);
        assert_eq!(half.frames.nrows(), 21);
        let p_in = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
        let p_out = channel_positions(&half.skeleton, half.frames.view()).unwrap();
        for k in 0..21 {
            let d = (&p_in.index_axis(ndarray::Axis(0), 2 * k)
                - &p_out.index_axis(ndarray::Axis(0), k))
                .mapv(f64::abs)
                .fold(0.0f64, |m, &v| m.max(v));
            assert!(d < 1e-6, "frame {k}: {d} mm");
        }
    }

    #[test]
    fn in_between_frames_lie_between_their_neighbours() {
        let bvh = clip(13, 120.0);
        let out = resample_bvh(&bvh, 50.0);
        assert_eq!(out.frames.nrows(), 6);
        let p_in = channel_positions(&bvh.skeleton, bvh.frames.view()).unwrap();
        let p_out = channel_positions(&out.skeleton, out.frames.view()).unwrap();
        // Output frame 1 is at source time 2.4 frames: 40 % of the way from frame 2 to 3.
        for j in 0..32 {
            for axis in 0..3 {
                let (a, b) = (p_in[[2, j, axis]], p_in[[3, j, axis]]);
                let v = p_out[[1, j, axis]];
                assert!(
                    (v - (a + 0.4 * (b - a))).abs() < 0.5,
                    "joint {j}: {a} {v} {b}"
                );
            }
        }
    }
}
