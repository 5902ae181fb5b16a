//! Grounding of a whole exp-map clip (history, seed, continuation), for file outputs: the same
//! [`Grounder`] a [`crate::model::Character`] runs, applied to frames and written back as
//! frames.
//!
//! Frames before the seed's end are moved rigidly into the floor frame (their motion is the
//! data's, untouched); every frame after it is grounded. The root is re-encoded as the clip had
//! it (H3.6M deltas, exact inverse of the integration, or absolute), the legs' joints whose
//! rotations the foot locking changed are written back as exp maps.
//!
//! **Which frame the clip is written in.** Grounding works in the floor frame of the seed (its
//! floor fitted, levelled, at `y = 0`). Evaluation reads that frame ([`ClipSpec::in_input_frame`]
//! `false`); a file written for the user keeps the user's coordinates (`true`): the seed's frames
//! are the input's own root poses, exactly, and every grounded frame after them is moved back
//! from the floor frame by the inverse of the seed floor's levelling, so the prediction continues
//! the user's clip where it ends. [`GroundedClip::floor`] says what the floor frame was.
use std::ops::Range;

use glam::{DVec3, Quat, Vec3};
use ndarray::{Array2, ArrayView2};

use super::{Grounder, GroundingConfig, GroundingError};
use crate::formats::expmap_bvh::ExpMapTarget;
use crate::motion::RootEncoding;
use crate::pose::METRES_PER_MM;
use crate::root::{
    delta_between, integrate_root_after, root_deltas, write_absolute_root, RootPose,
};
use crate::rotation::{h36m_joint_expmap, h36m_joint_quat, quat_to_row_mat3, row_mat3_to_quat};
use crate::skeleton::{Skeleton, H36M_SOURCE_FPS};

/// What a clip is and where its seed lies.
#[derive(Debug, Clone)]
pub struct ClipSpec<'a> {
    /// The skeleton of the frames (exp-map layout: root dims 0..5, joint `j` at `3 + 3j`).
    pub skeleton: Skeleton,
    /// How dims 0..5 store the root.
    pub root: RootEncoding,
    /// Source frames per frame of the deltas (2 for H3.6M at 25 Hz).
    pub step: usize,
    /// Frames per second.
    pub fps: f64,
    /// The seed's frames: their feet give the floor; frames from its end on are grounded.
    pub seed: Range<usize>,
    /// For root deltas: the absolute root pose of the frame before the first one, when the
    /// frames continue a take ([`crate::protocol::WindowData::root_before`]); `None` integrates from the
    /// identity (a take's first frame). A window cut from a take needs it for its true
    /// orientation: a seated body integrated from the identity at the window's start is tilted
    /// by its pelvis' tilt.
    pub root_before: Option<RootPose>,
    /// The action (lean limit).
    pub action: Option<&'a str>,
    /// `false`: every frame is only moved into the floor frame (real motion shown beside a
    /// grounded prediction).
    pub ground_after_seed: bool,
    /// The grounding.
    pub config: GroundingConfig,
    /// `true`: the clip is written in the input's coordinates, not the floor frame (module docs).
    pub in_input_frame: bool,
}

/// A grounded clip: frames and their absolute root poses.
#[derive(Debug, Clone)]
pub struct GroundedClip {
    /// The frames, root re-encoded as the input's.
    pub frames: Array2<f64>,
    /// Absolute root pose of every frame (mm, row-vector rotation).
    pub root_poses: Vec<RootPose>,
    /// Whether the root is stored as deltas.
    deltas: bool,
    /// The seed's floor the clip was grounded on (world metres; `None` with grounding off).
    pub floor: Option<super::Floor>,
}

impl GroundedClip {
    /// Rows `range` as a clip of their own: with deltas, the first row's root is its absolute
    /// pose (applied once from the identity, as a first frame is).
    pub fn window(&self, range: Range<usize>) -> Array2<f64> {
        let mut out = self.frames.slice(ndarray::s![range.clone(), ..]).to_owned();
        if self.deltas && !range.is_empty() {
            let (d, rd) = delta_between(&RootPose::IDENTITY, &self.root_poses[range.start], 1);
            for k in 0..3 {
                out[[0, k]] = d[k];
                out[[0, 3 + k]] = rd[k];
            }
        }
        out
    }
}

/// Grounds `frames` as `spec` says (see the module docs).
///
/// # Errors
/// A skeleton without two legs ([`super::legs`]).
///
/// # Panics
/// If the frames are narrower than the skeleton's exp-map layout.
pub fn ground_expmap_clip(
    frames: ArrayView2<'_, f64>,
    spec: &ClipSpec<'_>,
) -> Result<GroundedClip, GroundingError> {
    let skeleton = &spec.skeleton;
    let n = skeleton.len();
    assert!(frames.ncols() >= 3 + 3 * n, "exp-map frames too narrow");
    let mut grounder = Grounder::new(skeleton, METRES_PER_MM as f32, spec.config)?;
    grounder.set_action(spec.action);
    let poses = match spec.root {
        RootEncoding::Deltas => integrate_root_after(spec.root_before, frames, spec.step),
        RootEncoding::Absolute => frames
            .rows()
            .into_iter()
            .map(|r| RootPose::from_absolute_frame(&r.to_vec()))
            .collect(),
    };
    let offset = DVec3::from_array(skeleton.joint(0).offset);
    let mut rotations = vec![Quat::IDENTITY; n];
    let read = |t: usize, rotations: &mut [Quat]| {
        let row = frames.row(t);
        for (j, q) in rotations.iter_mut().enumerate().skip(1) {
            let k = 3 + 3 * j;
            *q = h36m_joint_quat([row[k], row[k + 1], row[k + 2]]).as_quat();
        }
        let pose = &poses[t];
        rotations[0] = row_mat3_to_quat(&pose.rotation).as_quat();
        ((DVec3::from_array(pose.translation) + offset) * METRES_PER_MM).as_vec3()
    };
    let seed_end = spec.seed.end.min(frames.nrows());
    for t in spec.seed.start.min(seed_end)..seed_end {
        let root = read(t, &mut rotations);
        grounder.observe_seed(root, &rotations);
    }
    let mut out = frames.to_owned();
    let mut new_poses = poses.clone();
    let mut floor = None;
    let leg_joints: Vec<usize> = grounder
        .body_parts()
        .legs
        .iter()
        .flat_map(|l| [l.hip, l.knee, l.ankle])
        .collect();
    let dt = (1.0 / spec.fps) as f32;
    let to_pose = |root: Vec3, rotation: Quat| RootPose {
        rotation: quat_to_row_mat3(rotation.as_dquat().normalize()),
        translation: (root.as_dvec3() / METRES_PER_MM - offset).to_array(),
    };
    if spec.config.enabled {
        for t in 0..frames.nrows() {
            let mut root = read(t, &mut rotations);
            if t < seed_end || !spec.ground_after_seed {
                grounder.level(&mut root, &mut rotations[0]);
            } else {
                grounder.ground(&mut root, &mut rotations, dt);
                for &j in &leg_joints {
                    let r = h36m_joint_expmap(rotations[j].as_dquat());
                    let k = 3 + 3 * j;
                    for a in 0..3 {
                        out[[t, k + a]] = r[a];
                    }
                }
            }
            new_poses[t] = to_pose(root, rotations[0]);
        }
        let fitted = grounder.floor();
        floor = Some(fitted);
        if spec.in_input_frame {
            // The seed's own poses, and the grounded frames moved back from the floor frame.
            let level_inv = fitted.level.as_dquat().inverse();
            for (t, pose) in new_poses.iter_mut().enumerate() {
                if t < seed_end || !spec.ground_after_seed {
                    *pose = poses[t];
                    continue;
                }
                let root = (DVec3::from_array(pose.translation) + offset) * METRES_PER_MM;
                let user = fitted.from_floor_frame_f64(root);
                let rotation = level_inv * row_mat3_to_quat(&pose.rotation);
                *pose = RootPose {
                    rotation: quat_to_row_mat3(rotation.normalize()),
                    translation: (user / METRES_PER_MM - offset).to_array(),
                };
            }
        }
        match spec.root {
            RootEncoding::Deltas => {
                let deltas = root_deltas(&new_poses, spec.step);
                out.slice_mut(ndarray::s![.., 0..6]).assign(&deltas);
            }
            RootEncoding::Absolute => write_absolute_root(&new_poses, &mut out),
        }
    }
    Ok(GroundedClip {
        frames: out,
        root_poses: new_poses,
        deltas: spec.root == RootEncoding::Deltas,
        floor,
    })
}

impl<'a> ClipSpec<'a> {
    /// The spec of `target`'s frames at `fps` (the root's step from H3.6M's 50 Hz source rate),
    /// grounded after `seed`.
    pub fn new(
        target: ExpMapTarget,
        fps: f64,
        seed: Range<usize>,
        action: Option<&'a str>,
        config: GroundingConfig,
    ) -> ClipSpec<'a> {
        ClipSpec {
            skeleton: target.skeleton(),
            root: target.root(),
            step: ((H36M_SOURCE_FPS / fps).round() as usize).max(1),
            fps,
            seed,
            root_before: None,
            action,
            ground_after_seed: true,
            config,
            in_input_frame: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::expmap_positions;
    use crate::root::integrate_root;

    /// 50 seed frames standing, then 100 frames whose root climbs 20 mm a frame.
    fn floating() -> Array2<f64> {
        Array2::from_shape_fn((150, 99), |(t, d)| match d {
            0 => 5.0,
            1 if t >= 50 => 10.0,
            1 => 0.0,
            2..6 => 0.0,
            _ => 0.05 * ((t as f64) * 0.1 + d as f64).sin(),
        })
    }

    fn spec(skeleton: &Skeleton, config: GroundingConfig) -> ClipSpec<'static> {
        ClipSpec {
            skeleton: skeleton.clone(),
            root: RootEncoding::Deltas,
            step: 2,
            fps: 25.0,
            seed: 0..50,
            root_before: None,
            action: Some("walking"),
            ground_after_seed: true,
            config,
            in_input_frame: false,
        }
    }

    #[test]
    fn a_floating_continuation_is_written_back_on_the_floor() {
        let skeleton = Skeleton::h36m();
        let frames = floating();
        let grounded =
            ground_expmap_clip(frames.view(), &spec(&skeleton, Default::default())).unwrap();
        let lowest = |frames: &Array2<f64>, t: usize| {
            let p = expmap_positions(&skeleton, frames.view(), RootEncoding::Deltas, 2).unwrap();
            [3, 4, 5, 8, 9, 10]
                .map(|j| p[[t, j, 1]])
                .into_iter()
                .fold(f64::INFINITY, f64::min)
        };
        let raw_rise = lowest(&frames, 149) - lowest(&frames, 49);
        assert!(raw_rise > 1500.0, "{raw_rise}");
        for t in [50, 100, 149] {
            let y = lowest(&grounded.frames, t);
            // Within a centimetre: a straight leg locked behind the hips reaches a little short.
            assert!(y.abs() < 10.0, "frame {t}: lowest foot point {y} mm");
        }
        // The seed keeps its motion (moved rigidly): same joint rotations, same step lengths.
        for t in 0..50 {
            for d in 6..99 {
                assert_eq!(grounded.frames[[t, d]], frames[[t, d]]);
            }
        }
        // A window of it integrates to the same poses.
        let w = grounded.window(100..150);
        let again = integrate_root(w.view(), 2);
        for (a, b) in again.iter().zip(&grounded.root_poses[100..]) {
            for k in 0..3 {
                assert!((a.translation[k] - b.translation[k]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn switched_off_the_frames_are_unchanged() {
        let skeleton = Skeleton::h36m();
        let frames = floating();
        let clip =
            ground_expmap_clip(frames.view(), &spec(&skeleton, GroundingConfig::off())).unwrap();
        assert_eq!(clip.frames, frames);
    }
}
