//! Rig targets against their definition: the H3.6M skeleton as its own target reproduces the
//! source's world rotations; a rig whose joints have arbitrary rest rotations but the same rest
//! positions gives the same world pose as the identity-rest rig (the rest pose composed in); the
//! committed mannequin's skin reads, maps and stands on the floor.
use std::sync::Arc;

use glam::{DQuat, DVec3, Quat, Vec3};

use super::*;
use crate::motion::RootEncoding;
use crate::pose::PoseDecoder;

/// H3.6M-like walking frames (25 Hz): the root forward, every joint swinging.
fn walk_poses(n: usize) -> Vec<Pose> {
    let frames = ndarray::Array2::from_shape_fn((n, 99), |(t, d)| match d {
        0 => 0.0,
        2 => 12.0,
        1 | 3..=5 => 0.0,
        _ => 0.3 * ((t as f64) * 0.25 + d as f64 * 0.9).sin(),
    });
    let mut decoder = PoseDecoder::new(Arc::new(Skeleton::h36m()), RootEncoding::Deltas, 2);
    decoder.decode_all(frames.view())
}

/// World rotations and positions of a rig pose.
fn fk(target: &RigTarget, out: &RigPose) -> (Vec<DQuat>, Vec<DVec3>) {
    let joints = target.joints();
    let mut rot: Vec<DQuat> = Vec::new();
    let mut pos: Vec<DVec3> = Vec::new();
    for (j, joint) in joints.iter().enumerate() {
        let r = out.local_rotations[j].as_dquat();
        let t = if j == target.hips() {
            out.hips_translation.as_dvec3()
        } else {
            joint.rest_translation.as_dvec3()
        };
        match joint.parent {
            None => {
                rot.push(r);
                pos.push(t);
            }
            Some(p) => {
                rot.push(rot[p] * r);
                pos.push(pos[p] + rot[p] * t);
            }
        }
    }
    (rot, pos)
}

fn same_rotation(a: DQuat, b: DQuat) -> bool {
    a.dot(b).abs() > 1.0 - 1e-6
}

#[test]
fn the_source_skeleton_as_its_own_target_keeps_every_mapped_world_rotation() {
    let h36m = Skeleton::h36m();
    let mut target = RigTarget::from_skeleton(&h36m, None, &h36m).unwrap();
    let mut out = RigPose::for_target(&target);
    for pose in walk_poses(20) {
        target.write(&pose, &mut out);
        let (rot, pos) = fk(&target, &out);
        // The source's world rotations.
        let mut world = vec![DQuat::IDENTITY; h36m.len()];
        for (j, joint) in h36m.joints().iter().enumerate() {
            let r = pose.local_rotations[j].as_dquat();
            world[j] = joint.parent.map_or(r, |p| world[p] * r);
        }
        for name in MAPPED_JOINTS {
            let j = h36m.joint_index(name).unwrap();
            assert!(target.is_mapped(j), "{name}");
            assert!(
                same_rotation(rot[j], world[j]),
                "{name}: {} vs {}",
                rot[j],
                world[j]
            );
        }
        // Same legs: the hips move with the source's.
        let hips = pos[target.hips()];
        assert!(
            (hips - pose.root_translation.as_dvec3()).length() < 1e-4,
            "{hips} vs {}",
            pose.root_translation
        );
    }
}

#[test]
fn rest_rotations_are_composed_in_so_the_world_pose_is_the_same() {
    let h36m = Skeleton::h36m();
    let mut plain = RigTarget::from_skeleton(&h36m, None, &h36m).unwrap();
    // The same rest positions, each joint with its own rest rotation (as Blender exports).
    let rest: Vec<DQuat> = (0..h36m.len())
        .map(|j| {
            DQuat::from_euler(
                glam::EulerRot::XYZ,
                0.3 * j as f64,
                -0.7 + 0.11 * j as f64,
                1.1,
            )
        })
        .collect();
    let mut world = vec![DQuat::IDENTITY; h36m.len()];
    let joints: Vec<RigJoint> = h36m
        .joints()
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            world[j] = joint.parent.map_or(rest[j], |p| world[p] * rest[j]);
            let offset = DVec3::from_array(joint.offset) * METRES_PER_MM;
            let t = joint.parent.map_or(offset, |p| world[p].inverse() * offset);
            RigJoint {
                name: joint.name.clone(),
                parent: joint.parent,
                rest_rotation: rest[j].as_quat(),
                rest_translation: t.as_vec3(),
            }
        })
        .collect();
    let mut turned = RigTarget::from_joints(joints, None, &h36m).unwrap();
    let (mut a, mut b) = (RigPose::for_target(&plain), RigPose::for_target(&turned));
    for pose in walk_poses(12) {
        plain.write(&pose, &mut a);
        turned.write(&pose, &mut b);
        let (_, pa) = fk(&plain, &a);
        let (_, pb) = fk(&turned, &b);
        for (j, (x, y)) in pa.iter().zip(&pb).enumerate() {
            assert!((*x - *y).length() < 1e-4, "joint {j}: {x} vs {y}");
        }
    }
}

#[test]
fn bad_joints_are_refused_by_name() {
    let h36m = Skeleton::h36m();
    let joint = |name: &str, parent| RigJoint {
        name: name.into(),
        parent,
        rest_rotation: Quat::IDENTITY,
        rest_translation: Vec3::Y,
    };
    let err = RigTarget::from_joints(vec![joint("a", None)], None, &h36m).unwrap_err();
    assert!(err.to_string().contains("at least two"), "{err}");
    let err = RigTarget::from_joints(vec![joint("a", None), joint("b", Some(1))], None, &h36m)
        .unwrap_err();
    assert!(err.to_string().contains("parents come before"), "{err}");
    let mut bad = joint("b", Some(0));
    bad.rest_rotation = Quat::from_xyzw(0.0, 0.0, 0.0, 2.0);
    let err = RigTarget::from_joints(vec![joint("a", None), bad], None, &h36m).unwrap_err();
    assert!(err.to_string().contains("unit quaternion"), "{err}");
    let err = RigTarget::from_joints(vec![joint("a", None), joint("b", Some(0))], None, &h36m)
        .unwrap_err();
    assert!(matches!(err, RigTargetError::Map(_)), "{err}");
}

#[test]
fn the_mannequin_reads_maps_and_walks_on_the_floor() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/mannequin.glb");
    mannequin_reads_maps_and_walks_on_the_floor(&path);
}

#[test]
fn the_female_mannequin_reads_maps_and_walks_on_the_floor() {
    // Other proportions, the same joint names: the second CC0 mannequin of the shared assets.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/characters/quaternius_mannequin_female.glb");
    if !path.is_file() {
        eprintln!("SKIPPED: no {}", path.display());
        return;
    }
    mannequin_reads_maps_and_walks_on_the_floor(&path);
}

fn mannequin_reads_maps_and_walks_on_the_floor(path: &std::path::Path) {
    let path = path.to_path_buf();
    let joints = read_gltf_joints(&path).unwrap();
    assert_eq!(joints.len(), 66);
    assert_eq!(joints[0].name, "root");
    assert!(joints
        .iter()
        .any(|j| j.name == "thigh_l" && j.rest_rotation != Quat::IDENTITY));
    let h36m = Skeleton::h36m();
    let mut target = RigTarget::from_gltf(&path, None, &h36m).unwrap();
    assert_eq!(target.joints()[target.hips()].name, "pelvis");
    let finger = target
        .joints()
        .iter()
        .position(|j| j.name == "index_02_l")
        .unwrap();
    assert!(!target.is_mapped(finger));
    let mut out = RigPose::for_target(&target);
    let (_, rest) = fk(&target, &out);
    let rest_feet = rest.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(rest_feet.abs() < 0.05, "rest feet at {rest_feet} m");
    // A grounded-like source: the H3.6M rest pose stood on the floor, then walking poses.
    let mut standing = Pose::rest(h36m.len());
    standing.root_translation.y = standing.floor_offset(&h36m);
    target.write(&standing, &mut out);
    let (_, pos) = fk(&target, &out);
    let lowest = pos.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(lowest.abs() < 0.03, "standing: lowest joint at {lowest} m");
    let head = target
        .joints()
        .iter()
        .position(|j| j.name == "head")
        .unwrap();
    assert!(
        (pos[head].y - rest[head].y).abs() < 0.05,
        "head at {} m, rest {} m",
        pos[head].y,
        rest[head].y
    );
    assert_eq!(out.local_rotations[finger], joints[finger].rest_rotation);
    // Walking swings the thighs: their local rotation moves by tens of degrees.
    let thigh = target
        .joints()
        .iter()
        .position(|j| j.name == "thigh_l")
        .unwrap();
    let rotations: Vec<Quat> = walk_poses(40)
        .iter()
        .map(|pose| {
            target.write(pose, &mut out);
            out.local_rotations[thigh]
        })
        .collect();
    let swing = rotations
        .iter()
        .map(|q| q.angle_between(rotations[0]).to_degrees())
        .fold(0.0f32, f32::max);
    assert!(swing > 20.0, "thigh_l turns {swing:.1} degrees at most");
}

#[test]
fn the_rig_bvh_holds_the_rig_pose() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/mannequin.glb");
    let h36m = Skeleton::h36m();
    let mut target = RigTarget::from_gltf(&path, None, &h36m).unwrap();
    let poses = walk_poses(8);
    let bvh = target.to_bvh(&poses, 25.0).unwrap();
    assert_eq!(bvh.skeleton.len(), 66);
    assert_eq!(bvh.skeleton.joint(1).name, "pelvis");
    let text = crate::formats::bvh::to_bvh_string(&bvh).unwrap();
    let back = crate::formats::bvh::parse_bvh(&text, "m.bvh").unwrap();
    let mut out = RigPose::for_target(&target);
    let got = crate::kinematics::channel_positions(&back.skeleton, back.frames.view()).unwrap();
    for (t, pose) in poses.iter().enumerate() {
        target.write(pose, &mut out);
        let (_, want) = fk(&target, &out);
        // Every joint but the root, which the file moves to carry the hips (the mannequin's
        // root is unmapped and sits on the floor).
        for (j, w) in want.iter().enumerate().skip(1) {
            let g = DVec3::new(got[[t, j, 0]], got[[t, j, 1]], got[[t, j, 2]]);
            assert!((*w - g).length() < 1e-4, "frame {t} joint {j}: {w} vs {g}");
        }
    }
}
