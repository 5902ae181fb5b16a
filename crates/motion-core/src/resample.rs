//! Frame-rate conversion at any rate: whole clips ([`resample_bvh`]) and streams of engine poses
//! ([`PoseResampler`]). Joint rotations are interpolated by quaternion slerp between the two
//! nearest source frames, positions linearly.
//!
//! Why clips go through BVH space: there the root is absolute, so interpolating it is meaningful;
//! H3.6M root deltas are per 50 Hz source frame and cannot be interpolated directly.
use glam::DQuat;
use ndarray::Array2;

use crate::formats::bvh::Bvh;
use crate::formats::expmap_bvh::{bvh_euler_to_quat, continuous_euler_degrees};
use crate::limits::{check_clip, ClipTooLarge};
use crate::pose::{root_motion_between, Pose};
use crate::rotation::EulerOrder;
use crate::skeleton::Skeleton;

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
///
/// # Errors
/// A result over [`crate::limits::MAX_CLIP_VALUES`], refused before it is allocated.
pub fn resample_bvh(bvh: &Bvh, fps: f64) -> Result<Bvh, ClipTooLarge> {
    let skeleton = &bvh.skeleton;
    let source_fps = bvh.fps();
    let frames_in = bvh.frames.nrows();
    let frames_out = resampled_len(frames_in, source_fps, fps);
    let channels = skeleton.channel_count();
    check_clip(
        frames_out,
        channels,
        "ask for a lower frame rate or fewer frames",
    )?;
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
    Ok(Bvh {
        skeleton: skeleton.clone(),
        frames: out,
        frame_time: 1.0 / fps,
    })
}

/// How many source poses a [`PoseResampler`] holds (the two it interpolates and look-ahead).
pub const RESAMPLER_CAPACITY: usize = 4;

/// Why a [`PoseResampler`] could not do what was asked.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ResampleError {
    /// `advance` would go past the newest source pose: push more first ([`PoseResampler::needs`]).
    #[error("the output time {time} s is past the newest source pose ({available} s): push the next model frame first")]
    NeedsFrame {
        /// The output time asked for, seconds after the oldest held pose.
        time: f64,
        /// The newest held pose's time on that clock.
        available: f64,
    },
    /// [`RESAMPLER_CAPACITY`] poses are held and none can be dropped yet.
    #[error("the resampler already holds {RESAMPLER_CAPACITY} source poses: advance before pushing more")]
    Full,
    /// A step that is negative or not finite.
    #[error("the time step must be finite and >= 0, got {0}")]
    BadStep(f64),
    /// A pose with another joint count.
    #[error("the pose has {got} joints, the resampler {expected}")]
    Joints {
        /// The resampler's joint count.
        expected: usize,
        /// The pose's.
        got: usize,
    },
}

/// Engine poses at any output rate from a stream of poses at the model's rate: the root position
/// and the pelvis offset lerped, every rotation slerped, the root motion recomputed from the
/// interpolated root (its deltas are between consecutive *outputs*). Holds one model frame of
/// look-ahead; no allocation after [`PoseResampler::new`].
///
/// ```
/// use motion_core::pose::Pose;
/// use motion_core::resample::PoseResampler;
///
/// let mut resampler = PoseResampler::new(32, 25.0);
/// let mut model_frames = (0..).map(|k| {
///     let mut pose = Pose::rest(32);
///     pose.root_translation.x = 0.04 * k as f32; // 1 m/s at 25 Hz
///     pose
/// });
/// for _ in 0..60 {
///     let dt = 1.0 / 60.0;
///     while resampler.needs(dt) {
///         resampler.push(&model_frames.next().unwrap())?;
///     }
///     let pose = resampler.advance(dt)?; // one 60 Hz frame
///     assert!(pose.root_translation.x <= 1.0 + 1e-5);
/// }
/// # Ok::<(), motion_core::resample::ResampleError>(())
/// ```
#[derive(Debug, Clone)]
pub struct PoseResampler {
    source_dt: f64,
    /// Ring of held source poses; `held[head]` is at time 0 of the output clock.
    held: Vec<Pose>,
    head: usize,
    len: usize,
    /// Output time after `held[head]`, seconds; `None` before the first output.
    time: Option<f64>,
    out: Pose,
}

impl PoseResampler {
    /// A resampler of poses with `joints` joints arriving at `source_fps`.
    ///
    /// # Panics
    /// If `source_fps` is not finite and positive.
    pub fn new(joints: usize, source_fps: f64) -> PoseResampler {
        assert!(
            source_fps.is_finite() && source_fps > 0.0,
            "source rate {source_fps}"
        );
        PoseResampler {
            source_dt: 1.0 / source_fps,
            held: vec![Pose::rest(joints); RESAMPLER_CAPACITY],
            head: 0,
            len: 0,
            time: None,
            out: Pose::rest(joints),
        }
    }

    /// Drops every held pose; the next output starts at the next pushed pose.
    pub fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
        self.time = None;
    }

    /// Whether [`advance`](Self::advance)`(dt)` needs another source pose first.
    pub fn needs(&self, dt: f64) -> bool {
        self.len == 0 || self.target(dt) > self.newest()
    }

    /// Holds the next source pose (the one `1 / source_fps` after the previous).
    pub fn push(&mut self, pose: &Pose) -> Result<(), ResampleError> {
        let expected = self.out.local_rotations.len();
        if pose.local_rotations.len() != expected {
            return Err(ResampleError::Joints {
                expected,
                got: pose.local_rotations.len(),
            });
        }
        if self.len == RESAMPLER_CAPACITY {
            return Err(ResampleError::Full);
        }
        let slot = (self.head + self.len) % RESAMPLER_CAPACITY;
        self.held[slot].clone_from(pose); // reuses the allocation (Pose's own clone_from)
        self.len += 1;
        Ok(())
    }

    /// Moves the output clock by `dt` seconds (0 for the first output: the first pushed pose) and
    /// returns the pose there.
    pub fn advance(&mut self, dt: f64) -> Result<&Pose, ResampleError> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(ResampleError::BadStep(dt));
        }
        let mut t = self.target(dt);
        if self.len == 0 || t > self.newest() {
            return Err(ResampleError::NeedsFrame {
                time: t,
                available: self.newest().max(0.0),
            });
        }
        // Drop poses the clock has passed, keeping the pair around `t`.
        while self.len > 1 && t >= self.source_dt {
            self.head = (self.head + 1) % RESAMPLER_CAPACITY;
            self.len -= 1;
            t -= self.source_dt;
        }
        let previous = self.time.map(|_| self.out.root_motion);
        self.time = Some(t);
        let a = &self.held[self.head];
        let b = &self.held[(self.head + 1.min(self.len - 1)) % RESAMPLER_CAPACITY];
        let f = (t / self.source_dt).clamp(0.0, 1.0);
        let out = &mut self.out;
        for ((o, qa), qb) in out
            .local_rotations
            .iter_mut()
            .zip(&a.local_rotations)
            .zip(&b.local_rotations)
        {
            *o = qa.slerp(*qb, f as f32);
        }
        out.root_translation = a.root_translation.lerp(b.root_translation, f as f32);
        out.root_motion = root_motion_between(
            out.root_translation.as_dvec3(),
            out.local_rotations[0].as_dquat(),
            previous,
        );
        Ok(&self.out)
    }

    /// The last pose [`advance`](Self::advance) returned (the rest pose before the first).
    pub fn current(&self) -> &Pose {
        &self.out
    }

    /// [`advance`](Self::advance) by any `dt`, calling `pull` to [`push`](Self::push) each
    /// source pose it needs: a step longer than the held poses cover (a game's hitch) is walked
    /// through one source frame at a time, and the returned root motion's deltas span the whole
    /// `dt`.
    pub fn advance_pulling<E: From<ResampleError>>(
        &mut self,
        dt: f64,
        mut pull: impl FnMut(&mut PoseResampler) -> Result<(), E>,
    ) -> Result<&Pose, E> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(ResampleError::BadStep(dt).into());
        }
        let previous = self.time.map(|_| self.out.root_motion);
        let mut left = dt;
        let long = dt > self.source_dt;
        while left > self.source_dt {
            while self.needs(self.source_dt) {
                pull(self)?;
            }
            self.advance(self.source_dt)?;
            left -= self.source_dt;
        }
        while self.needs(left) {
            pull(self)?;
        }
        self.advance(left)?;
        if long {
            let out = &mut self.out;
            out.root_motion = root_motion_between(
                out.root_translation.as_dvec3(),
                out.local_rotations[0].as_dquat(),
                previous,
            );
        }
        Ok(&self.out)
    }

    /// The output time `dt` from now, on the clock of the oldest held pose.
    fn target(&self, dt: f64) -> f64 {
        self.time.map_or(0.0, |t| t + dt)
    }

    /// The newest held pose's time (negative when none is held).
    fn newest(&self) -> f64 {
        (self.len as f64 - 1.0) * self.source_dt + 1e-9 * self.source_dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::expmap_bvh::expmap_to_bvh;
    use crate::kinematics::channel_positions;
    use crate::motion::Motion;

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
        let half = resample_bvh(&bvh, 25.0).unwrap();
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
        let out = resample_bvh(&bvh, 50.0).unwrap();
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

    /// A pose turning at a constant rate about a fixed axis and moving at constant speed.
    fn moving_pose(k: usize) -> Pose {
        let mut pose = Pose::rest(3);
        let axis = glam::Vec3::new(0.3, 1.0, -0.2).normalize();
        for (j, q) in pose.local_rotations.iter_mut().enumerate() {
            *q = glam::Quat::from_axis_angle(axis, 0.05 * (j + 1) as f32 * k as f32);
        }
        pose.root_translation = glam::Vec3::new(0.04 * k as f32, 0.9, -0.01 * k as f32);
        pose
    }

    #[test]
    fn the_source_rate_returns_the_source_poses() {
        let mut r = PoseResampler::new(3, 25.0);
        let mut k = 0;
        for n in 0..20 {
            while r.needs(0.04) {
                r.push(&moving_pose(k)).unwrap();
                k += 1;
            }
            let dt = if n == 0 { 0.0 } else { 0.04 };
            let pose = r.advance(dt).unwrap();
            let want = moving_pose(n);
            for (a, b) in pose.local_rotations.iter().zip(&want.local_rotations) {
                assert!(a.abs_diff_eq(*b, 1e-6), "frame {n}");
            }
            assert!((pose.root_translation - want.root_translation).length() < 1e-6);
        }
    }

    #[test]
    fn sixty_hz_follows_constant_motion_exactly_with_variable_steps() {
        let mut r = PoseResampler::new(3, 25.0);
        let mut k = 0;
        let mut time = 0.0f64;
        let mut first = true;
        for n in 0..200 {
            // 60 Hz with jitter, as a game loop delivers it.
            let dt = if first {
                0.0
            } else {
                (1.0 + 0.3 * ((n as f64) * 1.7).sin()) / 60.0
            };
            while r.needs(dt) {
                r.push(&moving_pose(k)).unwrap();
                k += 1;
            }
            time += dt;
            let pose = r.advance(dt).unwrap();
            first = false;
            let frames = (time * 25.0) as f32;
            let axis = glam::Vec3::new(0.3, 1.0, -0.2).normalize();
            for (j, q) in pose.local_rotations.iter().enumerate() {
                let want = glam::Quat::from_axis_angle(axis, 0.05 * (j + 1) as f32 * frames);
                assert!(
                    q.abs_diff_eq(want, 2e-5) || q.abs_diff_eq(-want, 2e-5),
                    "t {time}"
                );
            }
            let x = 0.04 * frames;
            assert!((pose.root_translation.x - x).abs() < 1e-4, "t {time}");
        }
        // One model frame of look-ahead at most: pushed frames stay just ahead of the clock.
        assert!(
            (k as f64) <= time * 25.0 + 3.0,
            "{k} frames pushed by {time} s"
        );
    }

    #[test]
    fn misuse_is_an_error_not_a_panic() {
        let mut r = PoseResampler::new(3, 25.0);
        assert!(matches!(
            r.advance(0.0),
            Err(ResampleError::NeedsFrame { .. })
        ));
        r.push(&moving_pose(0)).unwrap();
        r.advance(0.0).unwrap();
        assert!(matches!(
            r.advance(0.05),
            Err(ResampleError::NeedsFrame { .. })
        ));
        assert!(matches!(
            r.advance(f64::NAN),
            Err(ResampleError::BadStep(_))
        ));
        for k in 1..RESAMPLER_CAPACITY {
            r.push(&moving_pose(k)).unwrap();
        }
        assert_eq!(r.push(&moving_pose(9)), Err(ResampleError::Full));
        assert!(matches!(
            r.push(&Pose::rest(4)),
            Err(ResampleError::Joints { .. })
        ));
    }
}
