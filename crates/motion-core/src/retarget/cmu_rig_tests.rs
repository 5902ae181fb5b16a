//! The CMU ASF-named and 3dsMax-friendly rigs, built in code (no data files): detection, the
//! map checks on them, optional spine joints, and the round trip rig → model → rig.
use glam::{DQuat, DVec3};
use ndarray::Array2;

use super::*;
use crate::kinematics::{channel_positions, local_transform};

/// A rig from `(name, parent, offset)` rows, every joint with rotation `order`.
fn rows_rig(rows: &[(&str, &str, [f64; 3])], order: &str) -> Skeleton {
    let rows: Vec<(&str, &str, [f64; 3], &str)> =
        rows.iter().map(|&(n, p, o)| (n, p, o, order)).collect();
    rig_from_rows(&rows)
}

/// Mirrors a left-side row (`l…` / `L…` / `Left…` names) to the right: x negated.
fn mirrored(rows: &[(&str, &str, [f64; 3])]) -> Vec<(String, String, [f64; 3])> {
    let right = |n: &str| {
        if let Some(rest) = n.strip_prefix("Left") {
            format!("Right{rest}")
        } else if let Some(rest) = n.strip_prefix('L') {
            format!("R{rest}")
        } else if let Some(rest) = n.strip_prefix('l') {
            format!("r{rest}")
        } else {
            n.to_string()
        }
    };
    rows.iter()
        .map(|&(n, p, o)| (right(n), right(p), [-o[0], o[1], o[2]]))
        .collect()
}

/// `rows` with the right side added after the left (each side's rows given left only).
fn both_sides(
    trunk: &[(&str, &str, [f64; 3])],
    left: &[(&str, &str, [f64; 3])],
    order: &str,
) -> Skeleton {
    let right = mirrored(left);
    let mut all: Vec<(&str, &str, [f64; 3])> = trunk.to_vec();
    all.extend_from_slice(left);
    all.extend(right.iter().map(|(n, p, o)| (n.as_str(), p.as_str(), *o)));
    rows_rig(&all, order)
}

/// The 19 joints of the ASF-named CMU takes retargeted onto a `pelvis → thorax → head` spine
/// (centimetres, y up, arms hanging at rest, `ZXY` channels): no `Spine` or `Neck` counterpart.
fn asf_short() -> Skeleton {
    both_sides(
        &[
            ("pelvis", "", [0.0, 0.0, 0.0]),
            ("thorax", "pelvis", [0.0, 11.3, -5.0]),
            ("head", "thorax", [0.0, 43.8, 0.0]),
        ],
        &[
            ("lfemur", "pelvis", [11.4, 0.0, 0.0]),
            ("ltibia", "lfemur", [0.0, -42.0, 0.0]),
            ("lfoot", "ltibia", [0.0, -40.0, 0.0]),
            ("ltoes", "lfoot", [0.0, 0.0, 11.8]),
            ("lclavicle", "thorax", [0.0, 39.9, 0.0]),
            ("lhumerus", "lclavicle", [17.4, 5.0, 0.0]),
            ("lradius", "lhumerus", [0.0, -27.6, 0.0]),
            ("lhand", "lradius", [0.0, -26.9, 0.0]),
        ],
        "ZXY",
    )
}

/// The full ASF skeleton's names (`root`, hip joints, six spine and neck bones, wrist, hand,
/// fingers and thumb), ASF units (≈ 56 mm), a T-pose, `ZYX` channels.
fn asf_full() -> Skeleton {
    both_sides(
        &[
            ("root", "", [0.0, 0.0, 0.0]),
            ("lowerback", "root", [0.0, 0.3, 0.0]),
            ("upperback", "lowerback", [0.0, 2.0, -0.1]),
            ("thorax", "upperback", [0.0, 2.0, 0.0]),
            ("lowerneck", "thorax", [0.0, 2.0, 0.0]),
            ("upperneck", "lowerneck", [0.0, 1.5, 0.2]),
            ("head", "upperneck", [0.0, 1.5, 0.0]),
        ],
        &[
            ("lhipjoint", "root", [0.0, 0.0, 0.0]),
            ("lfemur", "lhipjoint", [1.6, -1.7, 0.7]),
            ("ltibia", "lfemur", [0.0, -7.4, 0.0]),
            ("lfoot", "ltibia", [0.0, -7.1, 0.0]),
            ("ltoes", "lfoot", [0.0, -0.4, 2.2]),
            ("lclavicle", "thorax", [0.0, 2.0, 0.0]),
            ("lhumerus", "lclavicle", [3.0, 0.3, 0.0]),
            ("lradius", "lhumerus", [5.0, 0.0, 0.0]),
            ("lwrist", "lradius", [3.3, 0.0, 0.0]),
            ("lhand", "lwrist", [0.6, 0.0, 0.0]),
            ("lfingers", "lhand", [0.5, 0.0, 0.0]),
            ("lthumb", "lwrist", [0.4, 0.0, 0.4]),
        ],
        "ZYX",
    )
}

/// The cgspeed 3dsMax-friendly CMU names (`LeftShoulder` is the upper arm, `LeftCollar` the
/// clavicle), with the zero-length `LHipJoint`, `lowerback`, `lowerneck`, `LeftCollar` and
/// `lhand` bones of those files, ASF units, arms hanging at rest, `ZYX` channels.
fn max_rig() -> Skeleton {
    both_sides(
        &[
            ("Hips", "", [0.0, 0.0, 0.0]),
            ("lowerback", "Hips", [0.0, 0.0, 0.0]),
            ("Chest", "lowerback", [0.0, 2.0, 0.0]),
            ("Chest2", "Chest", [0.0, 2.0, 0.0]),
            ("lowerneck", "Chest2", [0.0, 0.0, 0.0]),
            ("Neck", "lowerneck", [0.0, 1.6, 0.1]),
            ("Head", "Neck", [0.0, 1.6, 0.0]),
        ],
        &[
            ("LHipJoint", "Hips", [0.0, 0.0, 0.0]),
            ("LeftHip", "LHipJoint", [1.25, -1.6, 0.7]),
            ("LeftKnee", "LeftHip", [0.0, -7.3, 0.0]),
            ("LeftAnkle", "LeftKnee", [0.0, -6.9, 0.0]),
            ("LeftToe", "LeftAnkle", [0.0, -0.4, 2.2]),
            ("LeftCollar", "Chest2", [0.0, 0.0, 0.0]),
            ("LeftShoulder", "LeftCollar", [3.05, 1.47, 0.0]),
            ("LeftElbow", "LeftShoulder", [0.0, -4.25, 0.0]),
            ("LeftWrist", "LeftElbow", [0.0, -3.28, 0.0]),
            ("lhand", "LeftWrist", [0.0, 0.0, 0.0]),
            ("LFingers", "lhand", [0.0, -0.66, 0.0]),
            ("LThumb", "LeftWrist", [0.0, 0.0, 0.0]),
        ],
        "ZYX",
    )
}

/// `rig` with joint names changed by `rename`.
fn renamed(rig: &Skeleton, rename: impl Fn(&str) -> Option<&'static str>) -> Skeleton {
    let joints = rig
        .joints()
        .iter()
        .map(|j| {
            let mut j = j.clone();
            if let Some(n) = rename(&j.name) {
                j.name = n.into();
            }
            j
        })
        .collect();
    Skeleton::new(joints).unwrap()
}

/// Smooth rig frames: every rotation channel moving, the root walking.
fn frames(rig: &Skeleton, n: usize) -> Array2<f64> {
    Array2::from_shape_fn((n, rig.channel_count()), |(t, c)| {
        if c < 3 {
            [3.0 * t as f64, 13.0, 0.5 * t as f64][c]
        } else {
            25.0 * ((t as f64) * 0.1 + c as f64 * 1.3).sin()
        }
    })
}

fn local_quat(rig: &Skeleton, j: usize, frame: &[f64]) -> DQuat {
    DQuat::from_mat3(&local_transform(rig, j, frame).0)
}

fn name_of(rig: &Skeleton, map: &JointMap, model_joint: &str) -> Option<String> {
    map.rig_joint(model_joint)
        .map(|j| rig.joint(j).name.clone())
}

/// The JSON map `{H3.6M: rig name}` of `map` on `rig` (unmapped entries left out), with
/// `edit` applied to the pairs.
fn json_of(rig: &Skeleton, map: &JointMap, edit: impl Fn(&mut Vec<(String, String)>)) -> String {
    let mut pairs: Vec<(String, String)> = MAPPED_JOINTS
        .iter()
        .filter_map(|m| name_of(rig, map, m).map(|u| (m.to_string(), u)))
        .collect();
    edit(&mut pairs);
    let body: Vec<String> = pairs.iter().map(|(m, u)| format!("{m:?}: {u:?}")).collect();
    format!("{{{}}}", body.join(", "))
}

#[test]
fn cmu_asf_and_3dsmax_rigs_are_detected_with_their_own_spines_and_arms() {
    let expect = |rig: &Skeleton, name: &str, pairs: &[(&str, Option<&str>)]| {
        let map = JointMap::detect(rig).unwrap();
        assert_eq!(map.name, name);
        for &(model, user) in pairs {
            assert_eq!(
                name_of(rig, &map, model).as_deref(),
                user,
                "{name}: {model}"
            );
        }
        map
    };
    let short = expect(
        &asf_short(),
        "CMU ASF-named",
        &[
            ("Hips", Some("pelvis")),
            ("Spine", None),
            ("Spine1", Some("thorax")),
            ("Neck", None),
            ("Head", Some("head")),
            ("LeftShoulder", Some("lclavicle")),
            ("LeftArm", Some("lhumerus")),
            ("LeftHand", Some("lhand")),
            ("RightToeBase", Some("rtoes")),
        ],
    );
    assert_eq!(short.user.iter().flatten().count(), 19);
    expect(
        &asf_full(),
        "CMU ASF-named",
        &[
            ("Hips", Some("root")),
            ("LeftUpLeg", Some("lfemur")),
            ("Spine", Some("lowerback")),
            ("Spine1", Some("upperback")),
            ("Neck", Some("lowerneck")),
            ("Head", Some("head")),
            ("LeftHand", Some("lwrist")),
            ("RightForeArm", Some("rradius")),
        ],
    );
    expect(
        &max_rig(),
        "CMU 3dsMax-friendly BVH",
        &[
            ("Hips", Some("Hips")),
            ("RightUpLeg", Some("RightHip")),
            ("RightFoot", Some("RightAnkle")),
            ("Spine", Some("lowerback")),
            ("Spine1", Some("Chest")),
            ("Neck", Some("lowerneck")),
            ("LeftShoulder", Some("LeftCollar")),
            ("LeftArm", Some("LeftShoulder")),
            ("LeftForeArm", Some("LeftElbow")),
            ("LeftHand", Some("LeftWrist")),
            ("RightArm", Some("RightShoulder")),
        ],
    );
    // The other rigs keep their maps, every spine joint mapped.
    for (rig, name) in [
        (demo_rig("", false, 1.0), "CMU mocap BVH"),
        (demo_mixamo_rig(), "Mixamo"),
        (Skeleton::h36m(), "H3.6M"),
    ] {
        let map = JointMap::detect(&rig).unwrap();
        assert_eq!(map.name, name);
        assert_eq!(map.user.iter().flatten().count(), 21, "{name}");
    }
    assert_eq!(
        name_of(
            &demo_mixamo_rig(),
            &JointMap::detect(&demo_mixamo_rig()).unwrap(),
            "Spine1"
        )
        .as_deref(),
        Some("mixamorig:Spine2")
    );
    // A short-spined rig missing a required joint is named as before.
    let no_head = renamed(&asf_short(), |n| (n == "head").then_some("skull"));
    let err = JointMap::detect(&no_head).unwrap_err();
    assert!(
        matches!(err, RetargetError::Unmapped { ref joint, ref rig, .. } if joint == "Head" && rig == "CMU ASF-named"),
        "{err}"
    );
}

#[test]
fn the_map_checks_hold_for_rigs_with_optional_spine_joints() {
    // 3dsMax names with clavicle and upper arm swapped (MotionBuilder's meaning of
    // `LeftShoulder`): the names fit, the hierarchy does not, and detection says so.
    let swapped = renamed(&max_rig(), |n| match n {
        "LeftCollar" => Some("LeftShoulder"),
        "LeftShoulder" => Some("LeftCollar"),
        "RightCollar" => Some("RightShoulder"),
        "RightShoulder" => Some("RightCollar"),
        _ => None,
    });
    let err = JointMap::detect(&swapped).unwrap_err();
    assert!(
        matches!(err, RetargetError::PresetRefused { ref rig, ref reason } if rig == "CMU 3dsMax-friendly BVH" && reason.contains("not below")),
        "{err}"
    );
    // The same mistake in a joint map.
    let rig = max_rig();
    let map = JointMap::detect(&rig).unwrap();
    let json = json_of(&rig, &map, |p| {
        for (m, u) in p.iter_mut() {
            match (m.as_str(), u.as_str()) {
                ("LeftShoulder", _) => *u = "LeftShoulder".into(),
                ("LeftArm", _) => *u = "LeftCollar".into(),
                _ => {}
            }
        }
    });
    let e = JointMap::from_json(&rig, &json).unwrap_err();
    assert!(
        matches!(e, RetargetError::MapHierarchy { ref model, .. } if model == "LeftArm"),
        "{e}"
    );
    // A JSON map may leave the optional spine joints out, and then equals the built-in map.
    let rig = asf_short();
    let map = JointMap::detect(&rig).unwrap();
    let json = json_of(&rig, &map, |_| ());
    assert!(
        !json.contains("\"Spine\"") && !json.contains("\"Neck\""),
        "{json}"
    );
    assert_eq!(
        JointMap::from_json(&rig, &json).unwrap(),
        JointMap {
            name: "joint map".into(),
            ..map.clone()
        }
    );
    // A required one it may not; the error says which may be left out.
    let no_head = json_of(&rig, &map, |p| p.retain(|(m, _)| m != "Head"));
    let e = JointMap::from_json(&rig, &no_head).unwrap_err();
    assert_eq!(e, RetargetError::MapIncomplete("Head".into()));
    assert!(
        e.to_string()
            .contains("Spine, Spine1, Neck may be left out"),
        "{e}"
    );
    // An optional joint that is given is checked like any other: a neck on a thumb leaves the
    // head outside its subtree.
    let full = asf_full();
    let bad_neck = json_of(&full, &JointMap::detect(&full).unwrap(), |p| {
        p.iter_mut().find(|(m, _)| m == "Neck").unwrap().1 = "lthumb".into();
    });
    let e = JointMap::from_json(&full, &bad_neck).unwrap_err();
    assert!(
        matches!(e, RetargetError::MapHierarchy { ref model, ref parent, .. } if model == "Head" && parent == "Neck"),
        "{e}"
    );
    // And it cannot share a joint with another entry.
    let shared = json_of(&rig, &map, |p| p.push(("Spine".into(), "thorax".into())));
    assert!(matches!(
        JointMap::from_json(&rig, &shared).unwrap_err(),
        RetargetError::MapShared { .. }
    ));
}

#[test]
fn asf_and_3dsmax_rigs_round_trip_and_the_model_spine_carries_over() {
    let h36m = Skeleton::h36m();
    for (rig, what) in [
        (asf_short(), "ASF short"),
        (asf_full(), "ASF full"),
        (max_rig(), "3dsMax"),
    ] {
        let r = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
        // The rest pose stands upright on the model, the arms hanging or level.
        let rest = Array2::zeros((1, rig.channel_count()));
        let model = r.to_model(rest.view(), 1.0 / 30.0);
        let p = channel_positions(&model.skeleton, model.frames.view()).unwrap();
        let y = |joint: &str| p[[0, find(&h36m, joint).unwrap(), 1]] - p[[0, 0, 1]];
        assert!(
            y("Head") > 400.0 && y("LeftFoot") < -600.0 && y("LeftHand") < y("Neck") + 50.0,
            "{what}: head {} foot {} hand {}",
            y("Head"),
            y("LeftFoot"),
            y("LeftHand")
        );
        // Rig → model → rig: every local rotation and the root position as they were.
        let rig_frames = frames(&rig, 30);
        let model = r.to_model(rig_frames.view(), 1.0 / 30.0);
        // Unmapped H3.6M spine joints stay at rest on the model.
        for (s, name) in MAPPED_JOINTS.iter().enumerate() {
            if r.map.user[s].is_none() {
                let start = h36m.channel_start(r.model_index[s]);
                for k in 0..3 {
                    let angle = model.frames[[7, start + k]];
                    assert!(angle.abs() < 1e-9, "{what} {name}: {angle}");
                }
            }
        }
        let back = r.to_rig(&model, rig_frames.view());
        let mut worst: f64 = 0.0;
        for t in 0..30 {
            let (a, b) = (rig_frames.row(t).to_vec(), back.frames.row(t).to_vec());
            for j in 0..rig.len() {
                let (qa, qb) = (local_quat(&rig, j, &a), local_quat(&rig, j, &b));
                worst = worst.max(2.0 * (qa.inverse() * qb).xyz().length());
            }
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 1e-9, "{what} frame {t} root {c}");
            }
        }
        assert!(
            worst.to_degrees() < 1e-4,
            "{what}: {} deg",
            worst.to_degrees()
        );

        // Model → rig with the model's own spine bent (a predicted frame moves `Spine` and
        // `Neck` too): each rig bone that spans the model's chain from a mapped joint to the
        // next mapped one (unmapped joints between them at identity) points where the model's
        // chain does, the spine included.
        let mut bent = model.clone();
        let spine = h36m.channel_start(find(&h36m, "Spine").unwrap());
        for t in 0..30 {
            for k in 0..3 {
                bent.frames[[t, spine + k]] = 20.0 * ((t as f64) * 0.2 + k as f64).sin();
            }
        }
        let back = r.to_rig(&bent, rig_frames.view());
        let pm = channel_positions(&h36m, bent.frames.view()).unwrap();
        let pu = channel_positions(&rig, back.frames.view()).unwrap();
        let slot_of = |n: &str| MAPPED_JOINTS.iter().position(|m| *m == n).unwrap();
        let mut compared = 0;
        for s in 0..21 {
            let Some(us) = r.map.user[s] else { continue };
            let mut next = DIRECTION_CHILD[s].map(slot_of);
            let mut rigid = true; // no moved model joint strictly between s and c
            while let Some(c) = next.filter(|&c| r.map.user[c].is_none()) {
                rigid &= MAPPED_JOINTS[c] != "Spine";
                next = DIRECTION_CHILD[c].map(slot_of);
            }
            let Some(c) = next else { continue };
            let uc = r.map.user[c].unwrap();
            if !rigid || rig.joint(uc).parent != Some(us) {
                continue;
            }
            for t in [0, 13, 29] {
                let point = |p: &ndarray::Array3<f64>, j: usize| {
                    DVec3::new(p[[t, j, 0]], p[[t, j, 1]], p[[t, j, 2]])
                };
                let (mj, mc) = (r.model_index[s], r.model_index[c]);
                let dm = (point(&pm, mc) - point(&pm, mj)).normalize();
                let du = r.g * (point(&pu, uc) - point(&pu, us)).normalize();
                assert!(
                    (dm - du).length() < 1e-9,
                    "{what} t {t} {}: {dm} vs {du}",
                    MAPPED_JOINTS[s]
                );
            }
            compared += 1;
        }
        assert!(compared >= 12, "{what}: {compared} bones compared");
        if what == "ASF short" {
            // thorax → head spans the model's Spine1 → Neck → Head.
            let thorax = r.map.user[slot_of("Spine1")].unwrap();
            assert_eq!(
                rig.joint(r.map.user[slot_of("Head")].unwrap()).parent,
                Some(thorax)
            );
        }
    }
}
