//! What makes a joint map usable, checked before any retargeting (and on each built-in map that
//! a rig's names fit): a JSON object without repeated keys, one rig joint per H3.6M joint, the
//! H3.6M hierarchy kept (each mapped joint below the rig joint its nearest mapped H3.6M ancestor
//! goes to; unmapped optional spine joints are skipped) and the left arm on the same side as the
//! left leg. Each error names the offending entries.
use std::fmt;

use glam::DVec3;
use serde::de::{Deserialize, Deserializer, MapAccess, Visitor};

use super::{key, RetargetError, MAPPED_JOINTS};
use crate::skeleton::Skeleton;

/// A JSON object's entries in file order, repeated keys kept (serde_json keeps only the last).
pub(super) struct Entries(pub Vec<(String, serde_json::Value)>);

impl<'de> Deserialize<'de> for Entries {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct EntriesVisitor;
        impl<'de> Visitor<'de> for EntriesVisitor {
            type Value = Entries;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a JSON object of H3.6M name -> rig name")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Entries, A::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry::<String, serde_json::Value>()? {
                    entries.push(entry);
                }
                Ok(Entries(entries))
            }
        }
        deserializer.deserialize_map(EntriesVisitor)
    }
}

/// The first H3.6M name given twice (names compare as rigs match them, [`key`]).
pub(super) fn repeated_entry(pairs: &[(String, String)]) -> Result<(), RetargetError> {
    for (i, (model, rig)) in pairs.iter().enumerate() {
        if let Some((_, earlier)) = pairs[..i].iter().find(|(m, _)| key(m) == key(model)) {
            return Err(RetargetError::MapRepeated {
                model: model.clone(),
                first: earlier.clone(),
                second: rig.clone(),
            });
        }
    }
    Ok(())
}

/// The entry of [`MAPPED_JOINTS`] that is the nearest mapped H3.6M ancestor of entry `slot`
/// (skipping unmapped optional spine joints; `None` for the hips).
pub(super) fn mapped_parent(
    model: &Skeleton,
    model_index: &[usize; 21],
    user: &[Option<usize>; 21],
    slot: usize,
) -> Option<usize> {
    let mut j = model.joint(model_index[slot]).parent;
    while let Some(p) = j {
        if let Some(s) = model_index.iter().position(|&m| m == p) {
            if user[s].is_some() {
                return Some(s);
            }
        }
        j = model.joint(p).parent;
    }
    None
}

/// Whether rig joint `joint` lies strictly below `ancestor`.
fn is_below(rig: &Skeleton, joint: usize, ancestor: usize) -> bool {
    let mut j = rig.joint(joint).parent;
    while let Some(p) = j {
        if p == ancestor {
            return true;
        }
        j = rig.joint(p).parent;
    }
    false
}

/// Checks `user` (rig joint per entry of [`MAPPED_JOINTS`], `None` for an unmapped optional
/// one) against the rig: distinct joints, the H3.6M hierarchy kept (each mapped joint below the
/// rig joint of its nearest mapped H3.6M ancestor), left and right arms on the legs' sides
/// (`rest`: the rig's rest world positions). The arms and legs are required joints.
pub(super) fn check_map(
    rig: &Skeleton,
    model: &Skeleton,
    model_index: &[usize; 21],
    user: &[Option<usize>; 21],
    rest: &[DVec3],
) -> Result<(), RetargetError> {
    let rig_joint = |s: usize| user[s].expect("a mapped joint");
    let rig_name = |s: usize| rig.joint(rig_joint(s)).name.clone();
    let mapped = || (0..21).filter(|&s| user[s].is_some());
    for s in mapped() {
        if let Some(t) = mapped()
            .take_while(|&t| t < s)
            .find(|&t| user[t] == user[s])
        {
            return Err(RetargetError::MapShared {
                rig_joint: rig_name(s),
                first: MAPPED_JOINTS[t].into(),
                second: MAPPED_JOINTS[s].into(),
            });
        }
    }
    for s in mapped() {
        let Some(p) = mapped_parent(model, model_index, user, s) else {
            continue;
        };
        if !is_below(rig, rig_joint(s), rig_joint(p)) {
            return Err(RetargetError::MapHierarchy {
                model: MAPPED_JOINTS[s].into(),
                rig_joint: rig_name(s),
                parent: MAPPED_JOINTS[p].into(),
                parent_rig: rig_name(p),
            });
        }
    }
    let slot = |name: &str| {
        MAPPED_JOINTS
            .iter()
            .position(|m| *m == name)
            .expect("a mapped joint")
    };
    let at = |name: &str| rest[rig_joint(slot(name))];
    let legs = at("LeftUpLeg") - at("RightUpLeg");
    let arms = at("LeftArm") - at("RightArm");
    if legs.dot(arms) < 0.0 {
        return Err(RetargetError::MapSides {
            left: rig_name(slot("LeftArm")),
            right: rig_name(slot("RightArm")),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::{demo_rig, JointMap, PRESETS};
    use super::*;

    /// The CMU-style demo rig's map as JSON, with `edit` applied to the (H3.6M, rig) pairs.
    fn map_json(edit: impl Fn(&mut Vec<(String, String)>)) -> String {
        let mut pairs: Vec<(String, String)> = MAPPED_JOINTS
            .iter()
            .zip(PRESETS[0].1)
            .map(|(m, u)| (m.to_string(), u.to_string()))
            .collect();
        edit(&mut pairs);
        let body: Vec<String> = pairs.iter().map(|(m, u)| format!("{m:?}: {u:?}")).collect();
        format!("{{{}}}", body.join(", "))
    }

    fn set(pairs: &mut [(String, String)], model: &str, rig: &str) {
        pairs.iter_mut().find(|(m, _)| m == model).unwrap().1 = rig.into();
    }

    fn error(json: &str) -> RetargetError {
        JointMap::from_json(&demo_rig("", false, 1.0), json).unwrap_err()
    }

    #[test]
    fn the_right_map_passes_and_each_wrong_one_is_named() {
        let rig = demo_rig("", false, 1.0);
        assert!(JointMap::from_json(&rig, &map_json(|_| ())).is_ok());
        // Conflicting repeated keys (serde_json alone keeps the last silently).
        let twice = map_json(|p| p.push(("Head".into(), "Neck".into())));
        assert!(
            matches!(error(&twice), RetargetError::MapRepeated { ref model, .. } if model == "Head")
        );
        // Two H3.6M joints on one rig joint.
        let shared = map_json(|p| set(p, "LeftHand", "LeftForeArm"));
        let e = error(&shared);
        assert!(
            matches!(e, RetargetError::MapShared { ref rig_joint, .. } if rig_joint == "LeftForeArm"),
            "{e}"
        );
        // Hips and head swapped.
        let swapped = map_json(|p| {
            set(p, "Hips", "Head");
            set(p, "Head", "Hips");
        });
        assert!(matches!(
            error(&swapped),
            RetargetError::MapHierarchy { .. }
        ));
        // An arm sent to a leg.
        let arm_on_leg = map_json(|p| {
            set(p, "LeftArm", "LeftUpLeg");
            set(p, "LeftForeArm", "LeftLeg");
            set(p, "LeftHand", "LeftFoot");
            set(p, "LeftUpLeg", "LeftArm");
            set(p, "LeftLeg", "LeftForeArm");
            set(p, "LeftFoot", "LeftHand");
        });
        let e = error(&arm_on_leg);
        assert!(matches!(e, RetargetError::MapHierarchy { .. }), "{e}");
        assert!(e.to_string().contains("not below"), "{e}");
        // Left and right arms swapped wholesale: the hierarchy holds, the sides do not.
        let mirrored = map_json(|p| {
            for part in ["Shoulder", "Arm", "ForeArm", "Hand"] {
                set(p, &format!("Left{part}"), &format!("Right{part}"));
                set(p, &format!("Right{part}"), &format!("Left{part}"));
            }
        });
        assert!(matches!(error(&mirrored), RetargetError::MapSides { .. }));
        // Not an object.
        assert!(matches!(error("[1, 2]"), RetargetError::MapSyntax(_)));
    }
}
