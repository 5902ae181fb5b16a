//! The joints posture realism reads, found on any rig ([`PostureJoints::find`]) or given
//! ([`PostureJoints`]'s fields are public), and the per-frame features computed from them.
use serde::Serialize;

use motion_core::grounding::legs::rest_positions;
use motion_core::grounding::{find_body_parts, LegsError};
use motion_core::Skeleton;

/// Words that name the elbow joint (the top of the forearm) in common rigs, matched
/// case-insensitively anywhere in a joint's name: H3.6M and Mixamo `LeftForeArm`, UE `lowerarm_l`,
/// Unity `LeftLowerArm`, CMU ASF `lradius`, cgspeed `LeftElbow`.
pub const ELBOW_NAME_WORDS: [&str; 4] = ["forearm", "lowerarm", "elbow", "radius"];

/// Why a rig's posture joints cannot be found or are invalid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PostureError {
    /// The legs (and torso) finder failed.
    #[error(transparent)]
    Legs(#[from] LegsError),
    /// The rig has no torso top (`motion_core::grounding::find_body_parts`).
    #[error("no torso top found: no joint named Neck and no joint off the legs where two or more chains branch")]
    NoTorsoTop,
    /// Fewer than two chains branch off the spine outside the legs.
    #[error("no two arms found: {found} chain(s) branch off the spine outside the legs ({names})")]
    Arms {
        /// How many chains were found.
        found: usize,
        /// Their first joints' names.
        names: String,
    },
    /// An arm chain without an upper arm and a forearm.
    #[error("the arm chain starting at {0:?} has no upper arm and forearm (two bones of non-zero length)")]
    NoElbow(String),
    /// Explicitly given joints that do not fit the skeleton or each other.
    #[error("invalid posture joints: {0}")]
    Invalid(String),
}

/// A three-joint limb: hip, knee and ankle of a leg, or shoulder, elbow and wrist of an arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Limb {
    /// Hip or shoulder (the top of the thigh or upper arm).
    pub start: usize,
    /// Knee or elbow.
    pub middle: usize,
    /// Ankle or wrist (the bottom of the shin or forearm).
    pub end: usize,
}

/// The joints of a rig that posture realism reads, and the rig's scale.
///
/// Built by [`PostureJoints::find`] from the skeleton alone, or by hand (every field is public;
/// [`PostureJoints::check`] validates a hand-made one against the joint count).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PostureJoints {
    /// The pelvis: the origin of the heading frame (found: the lowest common ancestor of the hips).
    pub pelvis: usize,
    /// The top of the trunk (the neck's base, where the arms attach; the trunk axis runs from
    /// the pelvis to it).
    pub torso_top: usize,
    /// The top of the head (found: the farthest leaf of the head chain), when the rig has one.
    pub head: Option<usize>,
    /// The two legs (hip, knee, ankle); the heading's lateral axis runs from `legs[0].start` to
    /// `legs[1].start`.
    pub legs: [Limb; 2],
    /// The two arms (shoulder, elbow, wrist).
    pub arms: [Limb; 2],
    /// The length unit of the position features, in the rig's units (found: the rest-pose
    /// thigh + shin of the longer leg, `BodyParts::leg_length`).
    pub leg_length: f64,
    /// `+1.0` when the body faces `lateral × +y` (lateral = `legs[0].start → legs[1].start`),
    /// `-1.0` when it faces the opposite way (found: the rest pose's toes point forward).
    pub forward_sign: f64,
}

/// Upper-arm and thigh elevations of one frame (degrees, `0` = along the trunk axis pointing
/// down the body, `180` = up along it), in the order of [`PostureJoints::arms`] and
/// [`PostureJoints::legs`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Elevations {
    /// Upper arm (shoulder → elbow) against the downward trunk axis.
    pub upper_arm_deg: [f64; 2],
    /// Thigh (hip → knee) against the downward trunk axis.
    pub thigh_deg: [f64; 2],
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The angle between `a` and `b` in degrees (0 when either is zero).
fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b)).to_degrees()
}

/// Whether `j` is `ancestor` or below it.
fn is_under(skeleton: &Skeleton, mut j: usize, ancestor: usize) -> bool {
    loop {
        if j == ancestor {
            return true;
        }
        match skeleton.parent(j) {
            Some(p) => j = p,
            None => return false,
        }
    }
}

/// Position-joint slots of the feature vector (see the module docs).
const POSITION_SLOTS: usize = 13;
/// Limb-direction slots: upper arm, forearm, thigh, shin, two sides each.
const DIRECTION_SLOTS: usize = 8;

impl PostureJoints {
    /// Finds the posture joints of `skeleton` from its topology and rest offsets (any naming, any
    /// units; the rule is in the module docs).
    ///
    /// # Errors
    /// The legs finder's errors; no torso top; fewer than two arm chains; an arm chain without two
    /// bones of non-zero length.
    pub fn find(skeleton: &Skeleton) -> Result<PostureJoints, PostureError> {
        let parts = find_body_parts(skeleton)?;
        let rest = rest_positions(skeleton);
        let bone = |j: usize| norm(skeleton.joint(j).offset);
        let legs = [0, 1].map(|k| Limb {
            start: parts.legs[k].hip,
            middle: parts.legs[k].knee,
            end: parts.legs[k].ankle,
        });
        // The pelvis: the lowest common ancestor of the hips.
        let pelvis = {
            let mut j = legs[1].start;
            while !is_under(skeleton, legs[0].start, j) {
                j = skeleton
                    .parent(j)
                    .expect("joint 0 is every joint's ancestor");
            }
            j
        };
        let leg_joints: Vec<usize> = parts
            .legs
            .iter()
            .flat_map(|l| [l.hip, l.knee, l.ankle])
            .collect();
        let off_legs = |j: usize| {
            !leg_joints.iter().any(|&l| is_under(skeleton, l, j))
                && !legs.iter().any(|l| is_under(skeleton, j, l.start))
        };
        // The finder's torso top, unless it is the pelvis or above it (a rig rooted on the floor
        // without a `Neck`): then the first joint below the pelvis, off the legs, where two or
        // more chains branch.
        let torso_top = match parts.torso_top {
            Some(t) if !is_under(skeleton, pelvis, t) => t,
            _ => (pelvis + 1..skeleton.len())
                .find(|&j| {
                    is_under(skeleton, j, pelvis) && off_legs(j) && skeleton.children(j).len() >= 2
                })
                .ok_or(PostureError::NoTorsoTop)?,
        };
        // The spine: root ..= torso top.
        let mut spine = vec![torso_top];
        while let Some(p) = skeleton.parent(*spine.last().expect("non-empty")) {
            spine.push(p);
        }
        spine.reverse();
        // Chains off the spine outside the legs: (spine joint, first joint, farthest leaf, reach).
        let n = skeleton.len();
        let mut chains: Vec<(usize, usize, usize, f64)> = Vec::new();
        for &s in &spine {
            for &c in skeleton.children(s) {
                if spine.contains(&c) || leg_joints.iter().any(|&l| is_under(skeleton, l, c)) {
                    continue;
                }
                let mut reach = vec![f64::NAN; n];
                reach[c] = bone(c);
                let mut far = (c, reach[c]);
                for j in c + 1..n {
                    if let Some(p) = skeleton.parent(j) {
                        if reach[p].is_finite() {
                            reach[j] = reach[p] + bone(j);
                            if skeleton.children(j).is_empty() && reach[j] > far.1 {
                                far = (j, reach[j]);
                            }
                        }
                    }
                }
                chains.push((s, c, far.0, far.1));
            }
        }
        if chains.len() < 2 {
            return Err(PostureError::Arms {
                found: chains.len(),
                names: chains
                    .iter()
                    .map(|c| skeleton.joint(c.1).name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        // Arms: the two chains reaching farthest (stable: ties keep skeleton order).
        chains.sort_by(|a, b| b.3.total_cmp(&a.3));
        let head = chains[2..]
            .iter()
            .max_by(|a, b| rest[a.2][1].total_cmp(&rest[b.2][1]))
            .map(|c| c.2);
        let mut arms = [
            arm_limb(skeleton, chains[0].0, chains[0].2)?,
            arm_limb(skeleton, chains[1].0, chains[1].2)?,
        ];
        arms.sort_by(|a, b| {
            rest[a.end][0]
                .total_cmp(&rest[b.end][0])
                .then(a.end.cmp(&b.end))
        });
        // Facing: the rest pose's toes (foot points below the ankles) point forward.
        let lateral = sub(rest[legs[1].start], rest[legs[0].start]);
        let forward = cross(lateral, [0.0, 1.0, 0.0]);
        let rest = &rest;
        let toes: f64 = parts
            .legs
            .iter()
            .flat_map(|l| {
                l.foot_points
                    .iter()
                    .map(move |&p| dot(sub(rest[p], rest[l.ankle]), forward))
            })
            .sum();
        let joints = PostureJoints {
            pelvis,
            torso_top,
            head,
            legs,
            arms: [arms[0], arms[1]],
            leg_length: parts.leg_length,
            forward_sign: if toes < 0.0 { -1.0 } else { 1.0 },
        };
        joints.check(n)?;
        Ok(joints)
    }

    /// Checks that every joint is below `joint_count`, the two hips differ, `leg_length` is
    /// finite and positive and `forward_sign` is `±1`.
    ///
    /// # Errors
    /// [`PostureError::Invalid`] naming the problem.
    pub fn check(&self, joint_count: usize) -> Result<(), PostureError> {
        let bad = |what: String| Err(PostureError::Invalid(what));
        if let Some(j) = self.joint_list().into_iter().find(|&j| j >= joint_count) {
            return bad(format!(
                "joint {j} beyond the skeleton's {joint_count} joints"
            ));
        }
        if self.legs[0].start == self.legs[1].start {
            return bad("both legs start at the same hip joint".into());
        }
        if !(self.leg_length.is_finite() && self.leg_length > 0.0) {
            return bad(format!("leg length {} is not positive", self.leg_length));
        }
        if self.forward_sign != 1.0 && self.forward_sign != -1.0 {
            return bad(format!("forward sign {} is not ±1", self.forward_sign));
        }
        Ok(())
    }

    /// The joints whose heading-frame positions are features, in feature order: both hips, both
    /// knees, both ankles, the torso top, the head (when present), both shoulders, both elbows,
    /// both wrists.
    pub fn position_joints(&self) -> Vec<usize> {
        let [l0, l1] = self.legs;
        let [a0, a1] = self.arms;
        let mut out = vec![l0.start, l1.start, l0.middle, l1.middle, l0.end, l1.end];
        out.push(self.torso_top);
        out.extend(self.head);
        out.extend([a0.start, a1.start, a0.middle, a1.middle, a0.end, a1.end]);
        out
    }

    fn joint_list(&self) -> Vec<usize> {
        let mut out = self.position_joints();
        out.push(self.pelvis);
        out
    }

    /// Length of the feature vector: 3 per position joint (13 or 14) + 3 per limb direction (8).
    pub fn feature_dims(&self) -> usize {
        3 * (POSITION_SLOTS + usize::from(self.head.is_some()) + DIRECTION_SLOTS)
    }

    /// Names of the features, in order (`"<joint>.x"` for positions, `"<limb>_dir.x"` for
    /// directions), with the skeleton's joint names.
    pub fn feature_names(&self, skeleton: &Skeleton) -> Vec<String> {
        let mut out = Vec::with_capacity(self.feature_dims());
        for j in self.position_joints() {
            for axis in ["x", "y", "z"] {
                out.push(format!("{}.{axis}", skeleton.joint(j).name));
            }
        }
        for limb in [
            "upper_arm0",
            "upper_arm1",
            "forearm0",
            "forearm1",
            "thigh0",
            "thigh1",
            "shin0",
            "shin1",
        ] {
            for axis in ["x", "y", "z"] {
                out.push(format!("{limb}_dir.{axis}"));
            }
        }
        out
    }

    /// The features of one frame of world positions (`positions[j]` = joint `j`, +y up) written
    /// into `out` (length [`Self::feature_dims`]), and the frame's elevations. No allocation.
    ///
    /// # Panics
    /// If `out` has the wrong length or a joint is beyond `positions`.
    pub fn frame_features(&self, positions: &[[f64; 3]], out: &mut [f64]) -> Elevations {
        assert_eq!(out.len(), self.feature_dims(), "feature vector length");
        let p = |j: usize| positions[j];
        let pelvis = p(self.pelvis);
        let lateral = sub(p(self.legs[1].start), p(self.legs[0].start));
        // forward = sign · (lateral × +y) = sign · (−l_z, 0, l_x), made unit; none: no yaw removed.
        let (fx, fz) = (
            -self.forward_sign * lateral[2],
            self.forward_sign * lateral[0],
        );
        let h = fx.hypot(fz);
        let (fx, fz) = if h > 0.0 {
            (fx / h, fz / h)
        } else {
            (0.0, 1.0)
        };
        // Basis x' = +y × forward, y' = +y, z' = forward.
        let to_frame = |v: [f64; 3]| [v[0] * fz - v[2] * fx, v[1], v[0] * fx + v[2] * fz];
        let scale = 1.0 / self.leg_length;
        let mut k = 0;
        let mut put = |v: [f64; 3]| {
            out[k..k + 3].copy_from_slice(&v);
            k += 3;
        };
        let [l0, l1] = self.legs;
        let [a0, a1] = self.arms;
        let mut position = |j: usize| put(to_frame(sub(p(j), pelvis)).map(|c| c * scale));
        for j in [
            l0.start,
            l1.start,
            l0.middle,
            l1.middle,
            l0.end,
            l1.end,
            self.torso_top,
        ] {
            position(j);
        }
        if let Some(head) = self.head {
            position(head);
        }
        for j in [a0.start, a1.start, a0.middle, a1.middle, a0.end, a1.end] {
            position(j);
        }
        let mut direction = |a: usize, b: usize| {
            let v = sub(p(b), p(a));
            let l = norm(v);
            put(if l > 0.0 {
                to_frame(v.map(|c| c / l))
            } else {
                [0.0; 3]
            });
        };
        for (a, b) in [
            (a0.start, a0.middle),
            (a1.start, a1.middle),
            (a0.middle, a0.end),
            (a1.middle, a1.end),
            (l0.start, l0.middle),
            (l1.start, l1.middle),
            (l0.middle, l0.end),
            (l1.middle, l1.end),
        ] {
            direction(a, b);
        }
        self.elevations(positions)
    }

    /// The upper-arm and thigh elevations of one frame of world positions (rotation invariant).
    ///
    /// # Panics
    /// If a joint is beyond `positions`.
    pub fn elevations(&self, positions: &[[f64; 3]]) -> Elevations {
        let p = |j: usize| positions[j];
        let down = sub(p(self.pelvis), p(self.torso_top));
        let elevation = |l: &Limb| angle_deg(sub(p(l.middle), p(l.start)), down);
        Elevations {
            upper_arm_deg: [elevation(&self.arms[0]), elevation(&self.arms[1])],
            thigh_deg: [elevation(&self.legs[0]), elevation(&self.legs[1])],
        }
    }
}

/// The shoulder, elbow and wrist on the path from spine joint `spine` to the arm chain's farthest
/// leaf `leaf` (rule in the module docs).
fn arm_limb(skeleton: &Skeleton, spine: usize, leaf: usize) -> Result<Limb, PostureError> {
    let mut path = vec![leaf];
    while *path.last().expect("non-empty") != spine {
        let p = skeleton
            .parent(*path.last().expect("non-empty"))
            .expect("the leaf is below the spine joint");
        path.push(p);
    }
    path.reverse();
    // Joints at a bone of zero length coincide with their parent: each path joint is represented
    // by the last joint at or above it with a bone of non-zero length (the spine joint for none).
    let mut kept: Vec<usize> = vec![spine];
    let mut representative = vec![0usize; path.len()]; // index into `kept`
    for (i, &j) in path.iter().enumerate().skip(1) {
        if norm(skeleton.joint(j).offset) > 0.0 {
            kept.push(j);
        }
        representative[i] = kept.len() - 1;
    }
    let first = skeleton.joint(path[1]).name.clone();
    // 1. Names: the first path joint below the spine named like an elbow.
    let named = path.iter().enumerate().skip(1).find(|(_, &j)| {
        let name = skeleton.joint(j).name.to_ascii_lowercase();
        ELBOW_NAME_WORDS.iter().any(|w| name.contains(w))
    });
    if let Some((i, _)) = named {
        let e = representative[i];
        if e >= 1 && e + 1 < kept.len() {
            return Ok(Limb {
                start: kept[e - 1],
                middle: kept[e],
                end: kept[e + 1],
            });
        }
    }
    // 2. Lengths: the forearm is the last bone at least half as long as the longest bone of the
    // path, the upper arm the bone before it.
    let bone = |b: usize| norm(skeleton.joint(kept[b + 1]).offset); // kept[b] -> kept[b + 1]
    let bones = kept.len() - 1;
    let longest = (0..bones).map(bone).fold(0.0, f64::max);
    match (0..bones).rev().find(|&b| bone(b) >= 0.5 * longest) {
        Some(fore) if fore >= 1 && longest > 0.0 => Ok(Limb {
            start: kept[fore - 1],
            middle: kept[fore],
            end: kept[fore + 1],
        }),
        _ => Err(PostureError::NoElbow(first)),
    }
}
