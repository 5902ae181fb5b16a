//! Finding a rig's legs and torso from its topology and rest offsets, any naming, any units.
//!
//! The rule (one place; the grounding and the plausibility measures both use it):
//! - **Rest heights**: each joint's y in the rest pose (offsets summed from the root, no rotation).
//! - **Foot leaves**: leaves (joints without children) whose rest height lies in the lowest 15 %
//!   of the span between the lowest and the highest leaf.
//! - **A leg**: the highest ancestor of a foot leaf whose subtree holds foot leaves only; foot
//!   leaves under the same such joint are one leg. Exactly two legs are needed.
//! - **Hip, knee, ankle**: on the path from the leg's top joint to its lowest leaf, the two
//!   consecutive bones with the largest summed length (thigh and shin); the **foot points** are
//!   the ankle and everything below it.
//! - **Torso top**: a joint named `Neck` (any case) when there is one, else the first joint below
//!   the root, off the legs, with two or more children (where the arms branch).
use crate::skeleton::Skeleton;

/// Why a rig's legs could not be found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LegsError {
    /// Fewer than two joints: nothing stands.
    #[error("the skeleton has {0} joint(s): grounding needs two legs")]
    TooFewJoints(usize),
    /// The lowest leaves of the rest pose do not form exactly two legs.
    #[error(
        "no two legs found: the rest pose's lowest leaves ({leaves}) form {legs} leg(s), \
         grounding needs exactly 2 (a standing rest pose, legs down +y's opposite)"
    )]
    Legs {
        /// The foot leaves' names.
        leaves: String,
        /// How many legs they form.
        legs: usize,
    },
    /// A leg without two bones of non-zero length above its foot.
    #[error(
        "the leg ending at {0:?} has no thigh and shin (two consecutive bones of non-zero length)"
    )]
    NoKnee(String),
}

/// One leg: the joints two-bone IK moves and the points that touch the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    /// Top of the thigh.
    pub hip: usize,
    /// Between thigh and shin.
    pub knee: usize,
    /// Bottom of the shin.
    pub ankle: usize,
    /// The ankle and every joint below it (toes, end sites).
    pub foot_points: Vec<usize>,
}

/// The joints the grounding reads: two legs (the first is the one whose rest ankle has the lower
/// x) and the torso's top, when found.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyParts {
    /// Two legs.
    pub legs: [Leg; 2],
    /// Top of the torso vector from the root (lean), if the rig has one.
    pub torso_top: Option<usize>,
    /// Rest-pose hip-to-ankle length of the longer leg, in the skeleton's units.
    pub leg_length: f64,
    /// Rest-pose height of the root above the lowest foot point (the standing root height; the
    /// rest pose stands, see the module docs), in the skeleton's units.
    pub standing_height: f64,
}

/// Rest-pose positions (offsets summed from the root), skeleton units.
pub fn rest_positions(skeleton: &Skeleton) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; skeleton.len()];
    for (j, joint) in skeleton.joints().iter().enumerate() {
        if let Some(p) = joint.parent {
            let base = out[p];
            out[j] = [
                base[0] + joint.offset[0],
                base[1] + joint.offset[1],
                base[2] + joint.offset[2],
            ];
        }
    }
    out
}

fn length(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Finds the legs and torso of `skeleton` (see the module docs for the rule).
///
/// # Errors
/// A rig with fewer than two joints, without two legs, or a leg without a knee.
pub fn find_body_parts(skeleton: &Skeleton) -> Result<BodyParts, LegsError> {
    let n = skeleton.len();
    if n < 2 {
        return Err(LegsError::TooFewJoints(n));
    }
    let rest = rest_positions(skeleton);
    let leaves: Vec<usize> = (0..n)
        .filter(|&j| skeleton.children(j).is_empty())
        .collect();
    let (lo, hi) = leaves
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &j| {
            (a.min(rest[j][1]), b.max(rest[j][1]))
        });
    let cut = lo + 0.15 * (hi - lo);
    let is_foot_leaf: Vec<bool> = (0..n)
        .map(|j| skeleton.children(j).is_empty() && rest[j][1] <= cut && hi > lo)
        .collect();
    let foot_leaves: Vec<usize> = (0..n).filter(|&j| is_foot_leaf[j]).collect();
    // Whether a joint's subtree holds foot leaves only (children come after parents: go backwards).
    let mut only_feet = vec![true; n];
    for j in (0..n).rev() {
        if skeleton.children(j).is_empty() {
            only_feet[j] = is_foot_leaf[j];
        } else {
            only_feet[j] = skeleton.children(j).iter().all(|&c| only_feet[c]);
        }
    }
    let mut tops: Vec<usize> = Vec::new();
    for &leaf in &foot_leaves {
        let mut top = leaf;
        while let Some(p) = skeleton.parent(top) {
            if !only_feet[p] {
                break;
            }
            top = p;
        }
        if !tops.contains(&top) {
            tops.push(top);
        }
    }
    let names = || {
        foot_leaves
            .iter()
            .map(|&j| skeleton.joint(j).name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if tops.len() != 2 || tops.iter().any(|&t| skeleton.parent(t).is_none()) {
        return Err(LegsError::Legs {
            leaves: names(),
            legs: if tops.iter().any(|&t| skeleton.parent(t).is_none()) {
                1
            } else {
                tops.len()
            },
        });
    }
    let mut legs = Vec::with_capacity(2);
    let mut leg_length: f64 = 0.0;
    for &top in &tops {
        // The lowest foot leaf under this top, and the path down to it.
        let lowest = foot_leaves
            .iter()
            .copied()
            .filter(|&leaf| {
                let mut j = leaf;
                loop {
                    if j == top {
                        return true;
                    }
                    match skeleton.parent(j) {
                        Some(p) => j = p,
                        None => return false,
                    }
                }
            })
            .min_by(|&a, &b| rest[a][1].total_cmp(&rest[b][1]))
            .expect("a top has a foot leaf");
        let mut path = vec![lowest];
        while *path.last().expect("non-empty") != top {
            let p = skeleton
                .parent(*path.last().expect("non-empty"))
                .expect("below top");
            path.push(p);
        }
        // One joint above the top too: the thigh may start at the leg's top joint itself.
        if let Some(p) = skeleton.parent(top) {
            path.push(p);
        }
        path.reverse();
        // Bone k runs from path[k-1] to path[k].
        let bone = |k: usize| length(skeleton.joint(path[k]).offset);
        let mut best: Option<(f64, usize)> = None;
        for k in 1..path.len().saturating_sub(1) {
            let (a, b) = (bone(k), bone(k + 1));
            if a > 0.0 && b > 0.0 && best.is_none_or(|(s, _)| a + b > s) {
                best = Some((a + b, k));
            }
        }
        let Some((sum, k)) = best else {
            return Err(LegsError::NoKnee(skeleton.joint(lowest).name.clone()));
        };
        leg_length = leg_length.max(sum);
        let (hip, knee, ankle) = (path[k - 1], path[k], path[k + 1]);
        let mut foot_points = vec![ankle];
        for j in ankle + 1..n {
            if skeleton.parent(j).is_some_and(|p| foot_points.contains(&p)) {
                foot_points.push(j);
            }
        }
        legs.push(Leg {
            hip,
            knee,
            ankle,
            foot_points,
        });
    }
    legs.sort_by(|a, b| rest[a.ankle][0].total_cmp(&rest[b.ankle][0]));
    let in_legs = |j: usize| {
        legs.iter()
            .any(|l| j == l.hip || j == l.knee || l.foot_points.contains(&j))
    };
    let torso_top = skeleton
        .joints()
        .iter()
        .position(|j| j.name.eq_ignore_ascii_case("neck"))
        .or_else(|| {
            (1..n).find(|&j| {
                !in_legs(j)
                    && !tops.contains(&j)
                    && skeleton.children(j).len() >= 2
                    && length(rest[j]) > 0.0
            })
        });
    let standing_height = -legs
        .iter()
        .flat_map(|l| &l.foot_points)
        .map(|&j| rest[j][1])
        .fold(f64::INFINITY, f64::min);
    let [a, b]: [Leg; 2] = legs.try_into().expect("two legs");
    Ok(BodyParts {
        legs: [a, b],
        torso_top,
        leg_length,
        standing_height,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::{Channel, Joint};

    #[test]
    fn h36m_legs_are_up_leg_leg_foot() {
        let s = Skeleton::h36m();
        let parts = find_body_parts(&s).unwrap();
        let names = |l: &Leg| [l.hip, l.knee, l.ankle].map(|j| s.joint(j).name.clone());
        assert_eq!(
            names(&parts.legs[0]),
            ["RightUpLeg", "RightLeg", "RightFoot"]
        );
        assert_eq!(names(&parts.legs[1]), ["LeftUpLeg", "LeftLeg", "LeftFoot"]);
        assert_eq!(parts.legs[0].foot_points, vec![3, 4, 5]);
        assert_eq!(parts.torso_top, Some(13));
        assert!(
            (parts.leg_length - 897.1).abs() < 0.5,
            "{}",
            parts.leg_length
        );
        assert!(
            (parts.standing_height - f64::from(crate::grounding::H36M_STANDING_HEIGHT_MM)).abs()
                < 0.05,
            "{}",
            parts.standing_height
        );
    }

    #[test]
    fn cmu_legs_are_found_without_names() {
        let parts = find_body_parts(&Skeleton::cmu()).unwrap();
        for leg in &parts.legs {
            assert!(leg.hip < leg.knee && leg.knee < leg.ankle);
        }
        assert!(parts.leg_length > 0.0, "{}", parts.leg_length);
        assert_ne!(parts.legs[0].ankle, parts.legs[1].ankle);
    }

    #[test]
    fn a_one_joint_rig_and_a_stick_are_refused() {
        let root = Joint::new("root", None, [0.0; 3], vec![Channel::Xrotation]);
        let one = Skeleton::new(vec![root.clone()]).unwrap();
        assert_eq!(find_body_parts(&one), Err(LegsError::TooFewJoints(1)));
        let stick = Skeleton::new(vec![
            root,
            Joint::new("a", Some(0), [0.0, -1.0, 0.0], vec![Channel::Xrotation]),
            Joint::end_site("end", 1, [0.0, -1.0, 0.0]),
        ])
        .unwrap();
        let e = find_body_parts(&stick).unwrap_err();
        assert!(matches!(e, LegsError::Legs { legs: 0, .. }), "{e}");
    }
}
