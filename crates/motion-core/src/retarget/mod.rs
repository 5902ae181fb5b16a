//! Retargeting between a user's BVH rig and the H3.6M skeleton the models are trained on, both
//! ways, through world-space rotations (`../shared/reference/skeletons.md`).
//!
//! ## Method
//! - A [`JointMap`] pairs each of the 21 H3.6M body joints ([`MAPPED_JOINTS`]) with a joint of the
//!   user's rig: built in for the CMU mocap BVH conversions (MotionBuilder-friendly
//!   `Hips, LeftUpLeg, ...` and 3dsMax-friendly `Hips, LeftHip, LeftCollar, ...`), rigs with
//!   CMU's own ASF bone names (`root`/`pelvis`, `lfemur`, `thorax`, `lhumerus`, ...), Mixamo (any
//!   `prefix:`), the Unreal mannequin, and the H3.6M names themselves; or read from a JSON file
//!   (`{"LeftArm": "upperarm_l", ...}`: H3.6M name → rig name, [`JointMap::from_json`]).
//!   Names match case-insensitively, on the part after the last `:`.
//! - The spine joints of [`OPTIONAL_JOINTS`] (`Spine`, `Spine1`, `Neck`) may go unmapped on a
//!   rig with fewer spine bones (CMU takes retargeted onto a `pelvis, thorax, head` spine). An
//!   unmapped H3.6M joint keeps an identity local rotation both ways: on the model it turns with
//!   its nearest mapped ancestor, and going back to the rig its rotation is carried by the next
//!   mapped joint below it (whose world rotation is what the rig receives).
//! - Rest poses: both skeletons with every channel 0. A global rotation `G` takes the rig's world
//!   axes to the model's (from the hips → head and right → left hip directions, so z-up rigs
//!   work); per mapped joint `m` an offset `Q_m` turns the model's rest bone direction (towards
//!   its next mapped joint down the bone chain: its child, or past unmapped spine joints) onto
//!   the rig's (T-pose or A-pose against H3.6M's arms-up rest).
//! - Rig → model: world rotation `W_m = G W_u G⁻¹ Q_m` for each mapped pair, identity local
//!   rotation for unmapped model joints (fingers, sites, spine joints the rig lacks); the hips'
//!   world position scaled from the rig's units to millimetres by the ratio of body sizes.
//! - Model → rig: `W_u = G⁻¹ W_m Q_m⁻¹ G` for mapped joints; every unmapped rig joint (an extra
//!   spine or neck bone, fingers, twist bones, a `root` above the pelvis) keeps its local rotation
//!   from a reference frame of the rig (the seed's own frames, then its last one), and the rig's
//!   root position is solved so that its hips land where the model's are. A rig frame taken to
//!   the model and back is unchanged (to float rounding).
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};
use ndarray::{Array2, ArrayView2};

use crate::formats::bvh::Bvh;
use crate::formats::expmap_bvh::continuous_euler_degrees;
use crate::kinematics::local_transform;
use crate::rotation::EulerOrder;
use crate::skeleton::Skeleton;

#[cfg(test)]
mod cmu_rig_tests;
mod map_check;

/// The H3.6M joints a rig must provide, in skeleton order (the thumbs, wrist ends and sites are
/// left at rest).
pub const MAPPED_JOINTS: [&str; 21] = [
    "Hips",
    "RightUpLeg",
    "RightLeg",
    "RightFoot",
    "RightToeBase",
    "LeftUpLeg",
    "LeftLeg",
    "LeftFoot",
    "LeftToeBase",
    "Spine",
    "Spine1",
    "Neck",
    "Head",
    "LeftShoulder",
    "LeftArm",
    "LeftForeArm",
    "LeftHand",
    "RightShoulder",
    "RightArm",
    "RightForeArm",
    "RightHand",
];

/// Each mapped H3.6M joint's child that gives its bone direction (`None`: the joint keeps its
/// nearest mapped ancestor's rest offset; the hips use the global alignment). An unmapped child
/// passes on to its own direction child: the next mapped joint down the chain.
const DIRECTION_CHILD: [Option<&str>; 21] = [
    None,
    Some("RightLeg"),
    Some("RightFoot"),
    Some("RightToeBase"),
    None,
    Some("LeftLeg"),
    Some("LeftFoot"),
    Some("LeftToeBase"),
    None,
    Some("Spine1"),
    Some("Neck"),
    Some("Head"),
    None,
    Some("LeftArm"),
    Some("LeftForeArm"),
    Some("LeftHand"),
    None,
    Some("RightArm"),
    Some("RightForeArm"),
    Some("RightHand"),
    None,
];

/// The CMU mocap BVH conversions' joint for each of [`MAPPED_JOINTS`] (the built-in map of
/// those rigs, and what a joint map for them names).
pub const CMU_NAMES: [&str; 21] = [
    "Hips",
    "RightUpLeg",
    "RightLeg",
    "RightFoot",
    "RightToeBase",
    "LeftUpLeg",
    "LeftLeg",
    "LeftFoot",
    "LeftToeBase",
    "LowerBack",
    "Spine",
    "Neck",
    "Head",
    "LeftShoulder",
    "LeftArm",
    "LeftForeArm",
    "LeftHand",
    "RightShoulder",
    "RightArm",
    "RightForeArm",
    "RightHand",
];

/// The entries of [`MAPPED_JOINTS`] a rig (a built-in map, or a JSON joint map) may leave
/// unmapped: spine joints a rig with fewer spine bones has no counterpart for. Every other one
/// is required.
pub const OPTIONAL_JOINTS: [&str; 3] = ["Spine", "Spine1", "Neck"];

/// Whether entry `slot` of [`MAPPED_JOINTS`] is one of [`OPTIONAL_JOINTS`].
fn is_optional(slot: usize) -> bool {
    OPTIONAL_JOINTS.contains(&MAPPED_JOINTS[slot])
}

/// Built-in rig name maps, in [`MAPPED_JOINTS`] order. An entry may give alternatives
/// (`"root|pelvis"`: the first the rig has); an entry of [`OPTIONAL_JOINTS`] the rig lacks stays
/// unmapped. [`JointMap::detect`] takes, among the maps whose required names the rig has and
/// whose result passes the hierarchy check, the one that maps the most joints; ties go to the
/// earlier one here (a CMU MotionBuilder rig also fits the H3.6M names, a Mixamo rig the CMU
/// names without `LowerBack`). The 3dsMax-friendly CMU names reuse `LeftShoulder` for the upper
/// arm (the clavicle is `LeftCollar`), where MotionBuilder and Mixamo rigs use it for the
/// clavicle: the two maps require different leg names (`LeftHip` against `LeftUpLeg`), and a
/// map that sends the clavicle below the upper arm fails the hierarchy check.
const PRESETS: [(&str, [&str; 21]); 6] = [
    ("CMU mocap BVH", CMU_NAMES),
    (
        "CMU 3dsMax-friendly BVH",
        [
            "Hips",
            "RightHip",
            "RightKnee",
            "RightAnkle",
            "RightToe",
            "LeftHip",
            "LeftKnee",
            "LeftAnkle",
            "LeftToe",
            "lowerback",
            "Chest",
            "lowerneck",
            "Head",
            "LeftCollar",
            "LeftShoulder",
            "LeftElbow",
            "LeftWrist",
            "RightCollar",
            "RightShoulder",
            "RightElbow",
            "RightWrist",
        ],
    ),
    (
        "CMU ASF-named",
        [
            "root|pelvis",
            "rfemur",
            "rtibia",
            "rfoot",
            "rtoes",
            "lfemur",
            "ltibia",
            "lfoot",
            "ltoes",
            "lowerback",
            "upperback|thorax",
            "lowerneck",
            "head",
            "lclavicle",
            "lhumerus",
            "lradius",
            "lwrist|lhand",
            "rclavicle",
            "rhumerus",
            "rradius",
            "rwrist|rhand",
        ],
    ),
    (
        "Mixamo",
        [
            "Hips",
            "RightUpLeg",
            "RightLeg",
            "RightFoot",
            "RightToeBase",
            "LeftUpLeg",
            "LeftLeg",
            "LeftFoot",
            "LeftToeBase",
            "Spine",
            "Spine2",
            "Neck",
            "Head",
            "LeftShoulder",
            "LeftArm",
            "LeftForeArm",
            "LeftHand",
            "RightShoulder",
            "RightArm",
            "RightForeArm",
            "RightHand",
        ],
    ),
    (
        "Unreal mannequin",
        [
            "pelvis",
            "thigh_r",
            "calf_r",
            "foot_r",
            "ball_r",
            "thigh_l",
            "calf_l",
            "foot_l",
            "ball_l",
            "spine_01",
            "spine_03",
            "neck_01",
            "head",
            "clavicle_l",
            "upperarm_l",
            "lowerarm_l",
            "hand_l",
            "clavicle_r",
            "upperarm_r",
            "lowerarm_r",
            "hand_r",
        ],
    ),
    ("H3.6M", MAPPED_JOINTS),
];

/// Why a rig cannot be retargeted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RetargetError {
    /// No built-in map fits and no joint map was given: names the first required H3.6M joint
    /// without a match under the closest map.
    #[error("the rig has no joint matching H3.6M {joint:?} (looked for {looked_for:?} as in a {rig} rig); give a joint map (--joint-map FILE.json)")]
    Unmapped {
        /// The H3.6M joint.
        joint: String,
        /// The name looked for (alternatives separated by `|`).
        looked_for: String,
        /// The built-in map tried.
        rig: String,
    },
    /// The rig has every name of a built-in map, but that map fails the checks of a joint map
    /// (the bones are not where the names say).
    #[error("the rig's joint names fit the built-in {rig} map, but {reason}; give a joint map (--joint-map FILE.json)")]
    PresetRefused {
        /// The built-in map.
        rig: String,
        /// Why it was refused (a [`RetargetError`] of the map check, as text).
        reason: String,
    },
    /// A joint map names a rig joint the rig does not have, or an H3.6M joint that does not exist.
    #[error("the joint map names {name:?}, which the {side} has not")]
    MapNamesMissingJoint {
        /// The name.
        name: String,
        /// "rig" or "H3.6M skeleton".
        side: &'static str,
    },
    /// A joint map leaves a required H3.6M joint out.
    #[error(
        "the joint map has no entry for H3.6M {0:?} (all of {required} are needed; {optional} may be left out when the rig has no such spine bone)",
        required = MAPPED_JOINTS.iter().filter(|m| !OPTIONAL_JOINTS.contains(m)).copied().collect::<Vec<_>>().join(", "),
        optional = OPTIONAL_JOINTS.join(", ")
    )]
    MapIncomplete(String),
    /// The joint map file is not a JSON object of strings.
    #[error("the joint map is not a JSON object of H3.6M name -> rig name strings: {0}")]
    MapSyntax(String),
    /// A rig joint whose rotation channels are not three about distinct axes.
    #[error("rig joint {0:?} needs 3 rotation channels about distinct axes")]
    Channels(String),
    /// A joint map gives one H3.6M joint twice (a repeated JSON key, or two spellings of it).
    #[error("the joint map gives H3.6M {model:?} twice (to {first:?} and to {second:?}); keep one entry")]
    MapRepeated {
        /// The H3.6M joint.
        model: String,
        /// Its first rig joint.
        first: String,
        /// Its second.
        second: String,
    },
    /// A joint map sends two H3.6M joints to one rig joint.
    #[error("the joint map sends both H3.6M {first:?} and {second:?} to rig joint {rig_joint:?}; each needs its own")]
    MapShared {
        /// The rig joint.
        rig_joint: String,
        /// The first H3.6M joint sent there.
        first: String,
        /// The second.
        second: String,
    },
    /// A joint map breaks the H3.6M hierarchy: a joint's rig joint is not below the rig joint
    /// its nearest mapped H3.6M ancestor goes to (swapped hips and head, an arm sent to a leg,
    /// a clavicle sent below its upper arm).
    #[error("the joint map sends H3.6M {model:?} to {rig_joint:?}, which is not below {parent_rig:?} (where its H3.6M parent {parent:?} goes) in the rig's hierarchy")]
    MapHierarchy {
        /// The H3.6M joint.
        model: String,
        /// Its rig joint.
        rig_joint: String,
        /// Its nearest mapped H3.6M ancestor.
        parent: String,
        /// That ancestor's rig joint.
        parent_rig: String,
    },
    /// A joint map puts the left arm on the side of the right leg.
    #[error("the joint map's LeftArm ({left:?}) is on the side of its RightUpLeg and its RightArm ({right:?}) on the side of its LeftUpLeg: left and right are swapped in the arms or the legs")]
    MapSides {
        /// The rig joint of LeftArm.
        left: String,
        /// The rig joint of RightArm.
        right: String,
    },
    /// The rig's rest pose is degenerate (bones of zero length where a direction is needed).
    #[error("the rig's rest pose gives no direction for {0:?} (zero-length bones)")]
    Degenerate(String),
}

/// The largest joint-map text read (bytes): 21 entries of names fit many times over.
pub const MAX_MAP_BYTES: usize = 1 << 20;
/// The most entries a joint map may have (it needs 21).
pub const MAX_MAP_ENTRIES: usize = 1_000;

/// Which rig joint stands for each of [`MAPPED_JOINTS`] (none for an unmapped one of
/// [`OPTIONAL_JOINTS`]).
#[derive(Debug, Clone, PartialEq)]
pub struct JointMap {
    /// Rig joint index per entry of [`MAPPED_JOINTS`].
    pub(crate) user: [Option<usize>; 21],
    /// What the map is (a built-in rig's name, or "joint map").
    pub name: String,
}

/// A name as rigs are matched: after the last `:`, lower case.
fn key(name: &str) -> String {
    name.rsplit(':').next().unwrap_or(name).to_ascii_lowercase()
}

fn find(rig: &Skeleton, name: &str) -> Option<usize> {
    let k = key(name);
    rig.joints()
        .iter()
        .position(|j| !j.is_end_site && key(&j.name) == k)
}

/// A preset entry's rig joint: the first of its `|`-separated alternatives the rig has.
fn find_any(rig: &Skeleton, names: &str) -> Option<usize> {
    names.split('|').find_map(|n| find(rig, n))
}

/// The H3.6M skeleton and the index in it of each of [`MAPPED_JOINTS`].
fn model_and_index() -> (Skeleton, [usize; 21]) {
    let model = Skeleton::h36m();
    let index = MAPPED_JOINTS.map(|n| find(&model, n).expect("H3.6M joint"));
    (model, index)
}

/// The required joint a map lacks.
fn first_missing(user: &[Option<usize>; 21]) -> Option<usize> {
    (0..21).find(|&s| user[s].is_none() && !is_optional(s))
}

impl JointMap {
    /// The built-in map that fits the rig: every required name found (optional spine joints may
    /// be missing) and the result passing the checks of a joint map (hierarchy, sides); of
    /// several, the one mapping the most joints, then the first in the built-in order. The error
    /// names the first required H3.6M joint without a match under the map that matched most, or
    /// why a map whose names all fit was refused.
    pub fn detect(rig: &Skeleton) -> Result<JointMap, RetargetError> {
        let (model, model_index) = model_and_index();
        let rest = rest_positions(rig);
        let mut fit: Option<(usize, JointMap)> = None;
        let mut refused: Option<RetargetError> = None;
        let mut closest: Option<(usize, usize, usize)> = None; // (hits, preset, missing slot)
        for (p, (name, names)) in PRESETS.iter().enumerate() {
            let user: [Option<usize>; 21] = std::array::from_fn(|s| find_any(rig, names[s]));
            let hits = user.iter().flatten().count();
            if let Some(missing) = first_missing(&user) {
                if closest.is_none_or(|(h, _, _)| hits > h) {
                    closest = Some((hits, p, missing));
                }
                continue;
            }
            match map_check::check_map(rig, &model, &model_index, &user, &rest) {
                Ok(()) => {
                    if fit.as_ref().is_none_or(|(h, _)| hits > *h) {
                        let map = JointMap {
                            user,
                            name: name.to_string(),
                        };
                        fit = Some((hits, map));
                    }
                }
                Err(e) => {
                    refused.get_or_insert(RetargetError::PresetRefused {
                        rig: name.to_string(),
                        reason: e.to_string(),
                    });
                }
            }
        }
        if let Some((_, map)) = fit {
            return Ok(map);
        }
        if let Some(e) = refused {
            return Err(e);
        }
        let (_, p, missing) = closest.expect("presets exist");
        Err(RetargetError::Unmapped {
            joint: MAPPED_JOINTS[missing].to_string(),
            looked_for: PRESETS[p].1[missing].to_string(),
            rig: PRESETS[p].0.to_string(),
        })
    }

    /// A map from `(H3.6M name, rig name)` pairs covering every one of [`MAPPED_JOINTS`] except,
    /// if the rig lacks them, those of [`OPTIONAL_JOINTS`].
    pub fn from_pairs(
        rig: &Skeleton,
        pairs: &[(String, String)],
    ) -> Result<JointMap, RetargetError> {
        map_check::repeated_entry(pairs)?;
        let mut user = [None; 21];
        for (model, rig_name) in pairs {
            let slot = MAPPED_JOINTS
                .iter()
                .position(|m| key(m) == key(model))
                .ok_or_else(|| RetargetError::MapNamesMissingJoint {
                    name: model.clone(),
                    side: "H3.6M skeleton (or it is not one of the mapped body joints)",
                })?;
            user[slot] =
                Some(
                    find(rig, rig_name).ok_or_else(|| RetargetError::MapNamesMissingJoint {
                        name: rig_name.clone(),
                        side: "rig",
                    })?,
                );
        }
        if let Some(missing) = first_missing(&user) {
            return Err(RetargetError::MapIncomplete(
                MAPPED_JOINTS[missing].to_string(),
            ));
        }
        let (model, model_index) = model_and_index();
        map_check::check_map(rig, &model, &model_index, &user, &rest_positions(rig))?;
        Ok(JointMap {
            user,
            name: "joint map".into(),
        })
    }

    /// A map from JSON text `{"Hips": "pelvis", "LeftArm": "upperarm_l", ...}` (H3.6M name → rig
    /// name). Every one of [`MAPPED_JOINTS`] needs an entry, except the spine joints of
    /// [`OPTIONAL_JOINTS`] (`Spine`, `Spine1`, `Neck`), which a map leaves out when the rig has
    /// no such bone (a `pelvis → thorax → head` spine maps `Spine1` only): the H3.6M joint then
    /// keeps an identity local rotation and turns with its nearest mapped ancestor.
    pub fn from_json(rig: &Skeleton, text: &str) -> Result<JointMap, RetargetError> {
        if text.len() > MAX_MAP_BYTES {
            return Err(RetargetError::MapSyntax(format!(
                "{} bytes: a joint map names 21 joints and is read up to {MAX_MAP_BYTES} bytes",
                text.len()
            )));
        }
        let entries: map_check::Entries =
            serde_json::from_str(text).map_err(|e| RetargetError::MapSyntax(e.to_string()))?;
        if entries.0.len() > MAX_MAP_ENTRIES {
            return Err(RetargetError::MapSyntax(format!(
                "{} entries: a joint map names the 21 H3.6M body joints (at most {MAX_MAP_ENTRIES} entries are read)",
                entries.0.len()
            )));
        }
        let pairs = entries
            .0
            .iter()
            .map(|(k, v)| {
                v.as_str()
                    .map(|s| (k.clone(), s.to_string()))
                    .ok_or_else(|| {
                        RetargetError::MapSyntax(format!("{k:?} maps to {v}, not a name"))
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        JointMap::from_pairs(rig, &pairs)
    }

    /// Whether the rig is the H3.6M skeleton itself (no retargeting needed).
    pub fn is_identity(&self, rig: &Skeleton) -> bool {
        self.name == "H3.6M" && rig.joints().iter().filter(|j| !j.is_end_site).count() == 32
    }

    /// The rig joint (index in the rig's skeleton) standing for H3.6M joint `model_joint` (a
    /// name of [`MAPPED_JOINTS`], matched as rig names are); `None` for an unmapped optional
    /// joint or a name that is not a mapped H3.6M joint.
    pub fn rig_joint(&self, model_joint: &str) -> Option<usize> {
        let k = key(model_joint);
        let slot = MAPPED_JOINTS.iter().position(|m| key(m) == k)?;
        self.user[slot]
    }

    /// Reads a joint map file (see [`JointMap::from_json`]); errors carry the path.
    pub fn read(rig: &Skeleton, path: &Path) -> Result<JointMap, String> {
        let text = crate::input_file::read_regular_text(path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        JointMap::from_json(rig, &text).map_err(|e| format!("{}: {e}", path.display()))
    }
}
/// A rig joint's channel layout.
#[derive(Debug, Clone)]
struct Layout {
    start: usize,
    rotation: Option<(EulerOrder, [usize; 3])>,
    position: Vec<(usize, usize)>,
}

fn layouts(skeleton: &Skeleton) -> Result<Vec<Layout>, RetargetError> {
    skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let start = skeleton.channel_start(j);
            let mut axes = Vec::new();
            let mut cols = Vec::new();
            let mut position = Vec::new();
            for (k, c) in joint.channels.iter().enumerate() {
                if c.is_rotation() {
                    axes.push(c.axis());
                    cols.push(k);
                } else {
                    position.push((c.axis(), k));
                }
            }
            let rotation = match axes.len() {
                0 => None,
                3 => {
                    let order = EulerOrder::from_axes([axes[0], axes[1], axes[2]])
                        .ok_or_else(|| RetargetError::Channels(joint.name.clone()))?;
                    Some((order, [cols[0], cols[1], cols[2]]))
                }
                _ => return Err(RetargetError::Channels(joint.name.clone())),
            };
            Ok(Layout {
                start,
                rotation,
                position,
            })
        })
        .collect()
}

/// Rest world positions (every channel 0).
fn rest_positions(skeleton: &Skeleton) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::with_capacity(skeleton.len());
    for joint in skeleton.joints() {
        let p = DVec3::from_array(joint.offset);
        out.push(joint.parent.map_or(p, |q| out[q] + p));
    }
    out
}

/// A rest spine within this angle (degrees) of a world axis stands along that axis (it leans, as
/// many rigs' do: Mixamo's head sits forward of its hips); one farther from every axis belongs to
/// a rig turned obliquely, whose up is the spine itself.
pub const UPRIGHT_SPINE_DEG: f64 = 20.0;

/// A skeleton's up direction from its rest spine `v` (hips to head): the nearest world axis when
/// the spine is within [`UPRIGHT_SPINE_DEG`] of it, the spine's own direction otherwise (a rig
/// turned obliquely: the same take on a rig turned any way gives the same model motion).
fn up_of_spine(v: DVec3) -> DVec3 {
    let axis = nearest_axis(v);
    match v.try_normalize() {
        Some(n) if n.dot(axis).clamp(-1.0, 1.0).acos().to_degrees() > UPRIGHT_SPINE_DEG => n,
        _ => axis,
    }
}

/// The world axis (±x, ±y or ±z) nearest to `v`.
fn nearest_axis(v: DVec3) -> DVec3 {
    let length = v.length_squared();
    if length.is_nan() || length <= 0.0 {
        return v; // no direction: `frame` refuses it
    }
    let a = v.abs();
    if a.x >= a.y && a.x >= a.z {
        DVec3::X * v.x.signum()
    } else if a.y >= a.z {
        DVec3::Y * v.y.signum()
    } else {
        DVec3::Z * v.z.signum()
    }
}

/// The rotation whose columns are the orthonormal frame of `up` and `side` (side made
/// perpendicular).
fn frame(up: DVec3, side: DVec3) -> Option<DMat3> {
    let e1 = up.try_normalize()?;
    let e2 = (side - e1 * side.dot(e1)).try_normalize()?;
    Some(DMat3::from_cols(e1, e2, e1.cross(e2)))
}

/// Rig ↔ H3.6M retargeting (see the module docs).
#[derive(Debug, Clone)]
pub struct Retargeter {
    model: Skeleton,
    rig: Skeleton,
    pub(crate) map: JointMap,
    /// Rig world axes → model world axes.
    pub(crate) g: DQuat,
    /// Per entry of [`MAPPED_JOINTS`]: the rest offset `Q_m`.
    pub(crate) q: [DQuat; 21],
    /// Model index per entry of [`MAPPED_JOINTS`].
    pub(crate) model_index: [usize; 21],
    /// Rig length units per millimetre of the model (body size ratio).
    scale: f64,
    rig_layouts: Vec<Layout>,
    /// For each rig joint, its entry in [`MAPPED_JOINTS`], if mapped.
    pub(crate) rig_slot: Vec<Option<usize>>,
    /// For each model joint, its entry in [`MAPPED_JOINTS`] and rig joint, if mapped.
    model_slot: Vec<Option<(usize, usize)>>,
    /// The rig joints from the hips up to the root (exclusive), whose offsets place the hips.
    hips_chain: Vec<usize>,
}

impl Retargeter {
    /// Prepares retargeting between `rig` and the H3.6M skeleton under `map`.
    pub fn new(rig: &Skeleton, map: JointMap) -> Result<Retargeter, RetargetError> {
        let (model, model_index) = model_and_index();
        if let Some(missing) = first_missing(&map.user) {
            return Err(RetargetError::MapIncomplete(
                MAPPED_JOINTS[missing].to_string(),
            ));
        }
        let (pm, pu) = (rest_positions(&model), rest_positions(rig));
        let slot_of = |name: &str| {
            MAPPED_JOINTS
                .iter()
                .position(|m| *m == name)
                .expect("mapped")
        };
        map_check::check_map(rig, &model, &model_index, &map.user, &pu)?;
        // Each skeleton's joint per entry of MAPPED_JOINTS (the required ones, which `at` reads,
        // are mapped on both).
        let model_at = model_index.map(Some);
        let at = |p: &[DVec3], idx: &[Option<usize>; 21], name: &str| {
            p[idx[slot_of(name)].expect("a required joint")]
        };
        let span = |p: &[DVec3], idx: &[Option<usize>; 21]| {
            (
                at(p, idx, "Head") - at(p, idx, "Hips"),
                at(p, idx, "LeftUpLeg") - at(p, idx, "RightUpLeg"),
            )
        };
        // World axes: up is the world axis nearest each rest spine (hips to head), so that the
        // world's vertical maps onto the model's and a rest spine that leans does not tilt the
        // floor (a tilted map sinks or lifts the body as it travels); a rig turned obliquely has
        // its spine as up ([`up_of_spine`]); the side axis is the hips'.
        let (mu, ms) = span(&pm, &model_at);
        let (uu, us) = span(&pu, &map.user);
        let (mu, uu) = (up_of_spine(mu), up_of_spine(uu));
        let fm = frame(mu, ms).expect("the H3.6M rest pose has a frame");
        let fu = frame(uu, us).ok_or_else(|| RetargetError::Degenerate("Hips".into()))?;
        let g = DQuat::from_mat3(&(fm * fu.transpose())).normalize();
        // Body size: hips to head plus a leg, in each skeleton's units.
        let size = |p: &[DVec3], idx: &[Option<usize>; 21]| {
            (at(p, idx, "Head") - at(p, idx, "Hips")).length()
                + (at(p, idx, "LeftFoot") - at(p, idx, "LeftUpLeg")).length()
        };
        let scale = size(&pu, &map.user) / size(&pm, &model_at);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(RetargetError::Degenerate("Head".into()));
        }
        // Rest offsets, in slot order (ancestors first). An unmapped joint has none: it keeps an
        // identity local rotation, so the model's bones from a mapped joint down to the next
        // mapped one (past unmapped spine joints) turn rigidly with it, and that whole span's
        // rest direction is matched to the rig's.
        let mut q = [DQuat::IDENTITY; 21];
        for s in 0..21 {
            let Some(user_s) = map.user[s] else { continue };
            let mut next = DIRECTION_CHILD[s].map(slot_of);
            while let Some(c) = next.filter(|&c| map.user[c].is_none()) {
                next = DIRECTION_CHILD[c].map(slot_of);
            }
            let Some(c) = next else {
                // Leaves keep their nearest mapped ancestor's offset (the hips: none).
                if let Some(a) = map_check::mapped_parent(&model, &model_index, &map.user, s) {
                    q[s] = q[a];
                }
                continue;
            };
            let user_c = map.user[c].expect("mapped");
            let dm = pm[model_index[c]] - pm[model_index[s]];
            let du = g * (pu[user_c] - pu[user_s]);
            let (dm, du) = (
                dm.try_normalize().expect("H3.6M bones have length"),
                du.try_normalize()
                    .ok_or_else(|| RetargetError::Degenerate(rig.joint(user_s).name.clone()))?,
            );
            q[s] = DQuat::from_rotation_arc(dm, du);
        }
        let mut rig_slot = vec![None; rig.len()];
        let mut model_slot = vec![None; model.len()];
        for (s, &u) in map.user.iter().enumerate() {
            if let Some(u) = u {
                rig_slot[u] = Some(s);
                model_slot[model_index[s]] = Some((s, u));
            }
        }
        // The rig joints from the hips up to (not including) the root.
        let mut hips_chain = Vec::new();
        let mut j = map.user[0].expect("the hips are required");
        while let Some(p) = rig.joint(j).parent {
            hips_chain.push(j);
            j = p;
        }
        Ok(Retargeter {
            rig_layouts: layouts(rig)?,
            model,
            rig: rig.clone(),
            map,
            g,
            q,
            model_index,
            scale,
            rig_slot,
            model_slot,
            hips_chain,
        })
    }

    /// The rig's size against the H3.6M skeleton's (rig units per millimetre).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The map in use.
    pub fn map(&self) -> &JointMap {
        &self.map
    }

    /// Rig BVH frames → a BVH on the H3.6M skeleton (millimetres, the rig's rate): mapped joints'
    /// world rotations carried over, the others (unmapped spine joints included) at rest, the
    /// hips' path scaled to millimetres.
    pub fn to_model(&self, rig_frames: ArrayView2<'_, f64>, frame_time: f64) -> Bvh {
        let model = &self.model;
        let mut frames = Array2::zeros((rig_frames.nrows(), model.channel_count()));
        let (mut wu, mut pu) = (
            vec![DQuat::IDENTITY; self.rig.len()],
            vec![DVec3::ZERO; self.rig.len()],
        );
        let mut wm = vec![DQuat::IDENTITY; model.len()];
        let layouts = layouts(model).expect("the H3.6M skeleton has BVH channels");
        let g_inv = self.g.inverse();
        let hips = self.map.user[0].expect("the hips are required");
        for (t, row) in rig_frames.rows().into_iter().enumerate() {
            let row = row.to_vec();
            Retargeter::model_world(&self.rig, &row, &mut wu, &mut pu);
            for (m, joint) in model.joints().iter().enumerate() {
                let parent = joint.parent.map_or(DQuat::IDENTITY, |p| wm[p]);
                wm[m] = match self.model_slot[m] {
                    Some((s, u)) => (self.g * wu[u] * g_inv * self.q[s]).normalize(),
                    None => parent,
                };
            }
            let hips_mm = self.g * pu[hips] / self.scale;
            let mut out = vec![0.0; model.channel_count()];
            for (m, joint) in model.joints().iter().enumerate() {
                let layout = &layouts[m];
                let parent = joint.parent.map_or(DQuat::IDENTITY, |p| wm[p]);
                if joint.parent.is_none() {
                    let p = hips_mm - DVec3::from_array(joint.offset);
                    for &(axis, k) in &layout.position {
                        out[layout.start + k] = p[axis];
                    }
                }
                if let Some((order, cols)) = layout.rotation {
                    let before = (t > 0).then(|| cols.map(|c| frames[[t - 1, layout.start + c]]));
                    let angles = continuous_euler_degrees(order, parent.inverse() * wm[m], before);
                    for axis in 0..3 {
                        out[layout.start + cols[axis]] = angles[axis];
                    }
                }
            }
            frames.row_mut(t).assign(&ndarray::ArrayView1::from(&out));
        }
        Bvh {
            skeleton: model.clone(),
            frames,
            frame_time,
        }
    }

    /// A BVH on the H3.6M skeleton → the rig's BVH at the same rate. Rig joints the map leaves
    /// out take their local rotation (and non-root position channels) from `references` (row
    /// `min(t, rows - 1)` for frame `t`: the seed's own frames, then its last).
    pub fn to_rig(&self, model_bvh: &Bvh, references: ArrayView2<'_, f64>) -> Bvh {
        let rig = &self.rig;
        let model = &model_bvh.skeleton;
        let n = model_bvh.frames.nrows();
        let mut frames = Array2::zeros((n, rig.channel_count()));
        let mut wm = vec![DQuat::IDENTITY; model.len()];
        let mut pm = vec![DVec3::ZERO; model.len()];
        let mut wu = vec![DQuat::IDENTITY; rig.len()];
        let g_inv = self.g.inverse();
        for t in 0..n {
            Retargeter::model_world(
                model,
                model_bvh.frames.row(t).as_slice().expect("contiguous"),
                &mut wm,
                &mut pm,
            );
            let reference = references.row(t.min(references.nrows() - 1));
            let mut row = reference.to_vec();
            for (j, joint) in rig.joints().iter().enumerate() {
                let parent = joint.parent.map_or(DQuat::IDENTITY, |p| wu[p]);
                wu[j] = match self.rig_slot[j] {
                    Some(s) => {
                        (g_inv * wm[self.model_index[s]] * self.q[s].inverse() * self.g).normalize()
                    }
                    None => {
                        let (r, _) =
                            local_transform(rig, j, reference.as_slice().expect("contiguous"));
                        parent * DQuat::from_mat3(&r).normalize()
                    }
                };
                let layout = &self.rig_layouts[j];
                if let Some((order, cols)) = layout.rotation {
                    let local = parent.inverse() * wu[j];
                    let before = (t > 0).then(|| cols.map(|c| frames[[t - 1, layout.start + c]]));
                    let angles = continuous_euler_degrees(order, local, before);
                    for axis in 0..3 {
                        row[layout.start + cols[axis]] = angles[axis];
                    }
                }
            }
            // The root's position: the hips where the model's are (in rig units), through the
            // chain of offsets (and position channels) from the root down to the hips.
            let target = g_inv * pm[self.model_index[0]] * self.scale;
            let mut offset = DVec3::ZERO;
            for &k in &self.hips_chain {
                let (_, local_t) = local_transform(rig, k, &row);
                let parent = rig.joint(k).parent.expect("in the chain");
                offset += wu[parent] * local_t;
            }
            let root = rig.joint(0);
            let p = target - offset - DVec3::from_array(root.offset);
            let layout = &self.rig_layouts[0];
            for &(axis, k) in &layout.position {
                row[layout.start + k] = p[axis];
            }
            frames.row_mut(t).assign(&ndarray::ArrayView1::from(&row));
        }
        Bvh {
            skeleton: rig.clone(),
            frames,
            frame_time: model_bvh.frame_time,
        }
    }

    /// World rotations and positions (column vectors) of one frame of a BVH on `skeleton`.
    fn model_world(
        skeleton: &Skeleton,
        frame: &[f64],
        world: &mut [DQuat],
        position: &mut [DVec3],
    ) {
        for (j, joint) in skeleton.joints().iter().enumerate() {
            let (r, t) = local_transform(skeleton, j, frame);
            let r = DQuat::from_mat3(&r).normalize();
            match joint.parent {
                None => {
                    world[j] = r;
                    position[j] = t;
                }
                Some(p) => {
                    world[j] = world[p] * r;
                    position[j] = position[p] + world[p] * t;
                }
            }
        }
    }
}

/// A CMU-style rig for examples and tests (not from any dataset): the 26 bones of the CMU mocap
/// BVH conversions without fingers (extra hip, lower-back and neck bones), a T-pose, `ZYX`
/// rotation channels, sized like an adult at `units_per_mm` (0.1: centimetres), names with
/// `prefix` (e.g. `"mixamorig:"`), y up or (`z_up`) z up.
pub fn demo_rig(prefix: &str, z_up: bool, units_per_mm: f64) -> Skeleton {
    use crate::skeleton::{Channel::*, Joint};
    let rot = vec![Zrotation, Yrotation, Xrotation];
    let s = units_per_mm;
    let o = |x: f64, y: f64, z: f64| {
        let v = [x * s, y * s, z * s];
        if z_up {
            [v[0], -v[2], v[1]]
        } else {
            v
        }
    };
    let spec: Vec<(&str, Option<usize>, [f64; 3])> = vec![
        ("Hips", None, o(0.0, 0.0, 0.0)),                 // 0
        ("LHipJoint", Some(0), o(60.0, -60.0, 20.0)),     // 1
        ("LeftUpLeg", Some(1), o(60.0, -40.0, -20.0)),    // 2
        ("LeftLeg", Some(2), o(0.0, -430.0, 0.0)),        // 3
        ("LeftFoot", Some(3), o(0.0, -420.0, 0.0)),       // 4
        ("LeftToeBase", Some(4), o(0.0, -30.0, 140.0)),   // 5
        ("RHipJoint", Some(0), o(-60.0, -60.0, 20.0)),    // 6
        ("RightUpLeg", Some(6), o(-60.0, -40.0, -20.0)),  // 7
        ("RightLeg", Some(7), o(0.0, -430.0, 0.0)),       // 8
        ("RightFoot", Some(8), o(0.0, -420.0, 0.0)),      // 9
        ("RightToeBase", Some(9), o(0.0, -30.0, 140.0)),  // 10
        ("LowerBack", Some(0), o(0.0, 20.0, 0.0)),        // 11
        ("Spine", Some(11), o(0.0, 200.0, 0.0)),          // 12
        ("Spine1", Some(12), o(0.0, 200.0, 0.0)),         // 13
        ("Neck", Some(13), o(0.0, 80.0, 0.0)),            // 14
        ("Neck1", Some(14), o(0.0, 60.0, 0.0)),           // 15
        ("Head", Some(15), o(0.0, 80.0, 0.0)),            // 16
        ("LeftShoulder", Some(13), o(30.0, 60.0, 0.0)),   // 17
        ("LeftArm", Some(17), o(150.0, 0.0, 0.0)),        // 18
        ("LeftForeArm", Some(18), o(280.0, 0.0, 0.0)),    // 19
        ("LeftHand", Some(19), o(250.0, 0.0, 0.0)),       // 20
        ("LThumb", Some(20), o(30.0, 0.0, 30.0)),         // 21
        ("RightShoulder", Some(13), o(-30.0, 60.0, 0.0)), // 22
        ("RightArm", Some(22), o(-150.0, 0.0, 0.0)),      // 23
        ("RightForeArm", Some(23), o(-280.0, 0.0, 0.0)),  // 24
        ("RightHand", Some(24), o(-250.0, 0.0, 0.0)),     // 25
    ];
    let joints = spec
        .into_iter()
        .map(|(name, parent, offset)| {
            let mut channels = rot.clone();
            if parent.is_none() {
                channels = vec![
                    Xposition, Yposition, Zposition, Zrotation, Yrotation, Xrotation,
                ];
            }
            Joint::new(format!("{prefix}{name}"), parent, offset, channels)
        })
        .collect();
    Skeleton::new(joints).unwrap()
}

/// A Mixamo-style rig for examples and tests (not from any asset): the `mixamorig:` bone names of
/// a Mixamo export without fingers, centimetres, y up, a T-pose, three spine bones, per-joint
/// rotation orders.
pub fn demo_mixamo_rig() -> Skeleton {
    let m = |n: &str| format!("mixamorig:{n}");
    let names: Vec<String> = [
        "Hips",
        "Spine",
        "Spine1",
        "Spine2",
        "Neck",
        "Head",
        "LeftShoulder",
        "LeftArm",
        "LeftForeArm",
        "LeftHand",
        "LeftHandIndex1",
        "RightShoulder",
        "RightArm",
        "RightForeArm",
        "RightHand",
        "LeftUpLeg",
        "LeftLeg",
        "LeftFoot",
        "LeftToeBase",
        "RightUpLeg",
        "RightLeg",
        "RightFoot",
        "RightToeBase",
    ]
    .iter()
    .map(|n| m(n))
    .collect();
    let n = |k: usize| names[k].as_str();
    rig_from_rows(&[
        (n(0), "", [0.0, 100.0, 0.0], "YXZ"),
        (n(1), n(0), [0.0, 10.0, 0.0], "ZXY"),
        (n(2), n(1), [0.0, 12.0, 0.0], "ZXY"),
        (n(3), n(2), [0.0, 14.0, 0.0], "ZXY"),
        (n(4), n(3), [0.0, 16.0, 0.0], "ZXY"),
        (n(5), n(4), [0.0, 10.0, 2.0], "ZXY"),
        (n(6), n(3), [6.0, 12.0, 0.0], "ZXY"),
        (n(7), n(6), [12.0, 0.0, 0.0], "ZXY"),
        (n(8), n(7), [27.0, 0.0, 0.0], "XZY"),
        (n(9), n(8), [26.0, 0.0, 0.0], "ZXY"),
        (n(10), n(9), [9.0, 0.0, 2.0], "ZXY"),
        (n(11), n(3), [-6.0, 12.0, 0.0], "ZXY"),
        (n(12), n(11), [-12.0, 0.0, 0.0], "ZXY"),
        (n(13), n(12), [-27.0, 0.0, 0.0], "XZY"),
        (n(14), n(13), [-26.0, 0.0, 0.0], "ZXY"),
        (n(15), n(0), [9.0, -6.0, 0.0], "ZXY"),
        (n(16), n(15), [0.0, -42.0, 0.0], "ZXY"),
        (n(17), n(16), [0.0, -41.0, 0.0], "ZXY"),
        (n(18), n(17), [0.0, -8.0, 11.0], "ZXY"),
        (n(19), n(0), [-9.0, -6.0, 0.0], "ZXY"),
        (n(20), n(19), [0.0, -42.0, 0.0], "ZXY"),
        (n(21), n(20), [0.0, -41.0, 0.0], "ZXY"),
        (n(22), n(21), [0.0, -8.0, 11.0], "ZXY"),
    ])
}

/// A rig from rows `(name, parent ("" for the root), offset, rotation order)`; the root gets
/// position channels too.
fn rig_from_rows(rows: &[(&str, &str, [f64; 3], &str)]) -> Skeleton {
    use crate::skeleton::{Channel, Joint};
    let mut names: Vec<&str> = Vec::new();
    let joints = rows
        .iter()
        .map(|&(name, parent, offset, order)| {
            let parent = names.iter().position(|n| *n == parent);
            names.push(name);
            let mut channels: Vec<Channel> = order
                .chars()
                .map(|c| match c {
                    'X' => Channel::Xrotation,
                    'Y' => Channel::Yrotation,
                    _ => Channel::Zrotation,
                })
                .collect();
            if parent.is_none() {
                channels.splice(
                    0..0,
                    [Channel::Xposition, Channel::Yposition, Channel::Zposition],
                );
            }
            Joint::new(name, parent, offset, channels)
        })
        .collect();
    Skeleton::new(joints).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::channel_positions;
    use crate::skeleton::Joint;

    fn cmu_rig(prefix: &str, z_up: bool) -> Skeleton {
        demo_rig(prefix, z_up, 1.0 / 70.0)
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

    fn local_quats(rig: &Skeleton, frame: &[f64]) -> Vec<DQuat> {
        (0..rig.len())
            .map(|j| DQuat::from_mat3(&local_transform(rig, j, frame).0))
            .collect()
    }

    #[test]
    fn built_in_rigs_are_detected_and_a_missing_joint_is_named() {
        assert_eq!(
            JointMap::detect(&cmu_rig("", false)).unwrap().name,
            "CMU mocap BVH"
        );
        assert_eq!(JointMap::detect(&Skeleton::h36m()).unwrap().name, "H3.6M");
        let joints: Vec<Joint> = cmu_rig("", false)
            .joints()
            .iter()
            .map(|j| {
                let mut j = j.clone();
                if j.name == "LeftForeArm" {
                    j.name = "LeftElbow".into();
                }
                j
            })
            .collect();
        let err = JointMap::detect(&Skeleton::new(joints).unwrap()).unwrap_err();
        assert!(err.to_string().contains("\"LeftForeArm\""), "{err}");
    }

    #[test]
    fn a_joint_map_file_maps_any_names_and_bad_maps_are_named() {
        let rig = cmu_rig("Beta:", false);
        let preset = PRESETS[0].1;
        let pairs: Vec<String> = MAPPED_JOINTS
            .iter()
            .zip(preset)
            .map(|(m, u)| format!("\"{m}\": \"Beta:{u}\""))
            .collect();
        let json = format!("{{{}}}", pairs.join(", "));
        let map = JointMap::from_json(&rig, &json).unwrap();
        assert_eq!(
            map,
            JointMap {
                name: "joint map".into(),
                ..JointMap::detect(&rig).unwrap()
            }
        );
        let bad = json.replace("Beta:LeftHand\"", "Beta:LeftPaw\"");
        assert!(JointMap::from_json(&rig, &bad)
            .unwrap_err()
            .to_string()
            .contains("LeftPaw"));
        let short = json.replace("\"Head\": \"Beta:Head\", ", "");
        assert_eq!(
            JointMap::from_json(&rig, &short),
            Err(RetargetError::MapIncomplete("Head".into()))
        );
    }

    #[test]
    fn rig_to_model_and_back_is_the_identity_and_bones_keep_their_world_directions() {
        for (prefix, z_up) in [("", false), ("mixamorig:", false), ("", true)] {
            let rig = cmu_rig(prefix, z_up);
            let r = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
            assert!((r.scale() - 1.0 / 70.0).abs() < 0.2 / 70.0, "{}", r.scale());
            let rig_frames = frames(&rig, 40);
            let model = r.to_model(rig_frames.view(), 1.0 / 120.0);
            // Bone directions: the model's bone towards its direction child points where the
            // rig's does (in the model's axes).
            let pm = channel_positions(&model.skeleton, model.frames.view()).unwrap();
            let pu = channel_positions(&rig, rig_frames.view()).unwrap();
            let h36m = Skeleton::h36m();
            for t in [0, 17, 39] {
                for (s, child) in DIRECTION_CHILD.iter().enumerate() {
                    let Some(child) = child else { continue };
                    let c = MAPPED_JOINTS.iter().position(|m| m == child).unwrap();
                    // Only rigid segments: an unmapped rig bone between the two (CMU's Neck1)
                    // moves the child in ways the model's one bone cannot show.
                    let (Some(us), Some(uc)) = (r.map.user[s], r.map.user[c]) else {
                        continue;
                    };
                    if rig.joint(uc).parent != Some(us) {
                        continue;
                    }
                    let point = |p: &ndarray::Array3<f64>, j: usize| {
                        DVec3::new(p[[t, j, 0]], p[[t, j, 1]], p[[t, j, 2]])
                    };
                    let (mj, mc) = (
                        find(&h36m, MAPPED_JOINTS[s]).unwrap(),
                        find(&h36m, child).unwrap(),
                    );
                    let dm = (point(&pm, mc) - point(&pm, mj)).normalize();
                    let du = r.g * (point(&pu, uc) - point(&pu, us)).normalize();
                    assert!(
                        (dm - du).length() < 1e-9,
                        "{prefix} t {t} {}: {dm} vs {du}",
                        MAPPED_JOINTS[s]
                    );
                }
            }
            // And back: every local rotation and the root position as they were.
            let back = r.to_rig(&model, rig_frames.view());
            let mut worst: f64 = 0.0;
            for t in 0..40 {
                let a = local_quats(&rig, rig_frames.row(t).as_slice().unwrap());
                let b = local_quats(&rig, back.frames.row(t).as_slice().unwrap());
                for (qa, qb) in a.iter().zip(&b) {
                    worst = worst.max(2.0 * (qa.inverse() * *qb).xyz().length());
                }
                for c in 0..3 {
                    assert!((rig_frames[[t, c]] - back.frames[[t, c]]).abs() < 1e-9);
                }
            }
            assert!(
                worst.to_degrees() < 1e-4,
                "{prefix}: {} deg",
                worst.to_degrees()
            );
        }
    }

    /// A rig from `(name, parent, offset, rotation order)` rows (the root also gets positions).
    /// `rig` and its `frames` turned rigidly by `o`: every offset and every world rotation turned
    /// (the local rotations conjugated), the same motion on a rig standing another way.
    fn turned(rig: &Skeleton, frames: &Array2<f64>, o: DQuat) -> (Skeleton, Array2<f64>) {
        use crate::formats::expmap_bvh::continuous_euler_degrees;
        let joints = rig
            .joints()
            .iter()
            .map(|j| {
                let mut j = j.clone();
                j.offset = (o * DVec3::from_array(j.offset)).to_array();
                j
            })
            .collect();
        let out_rig = Skeleton::new(joints).unwrap();
        let layouts = layouts(rig).unwrap();
        let mut out = frames.clone();
        for t in 0..frames.nrows() {
            let row = frames.row(t).to_vec();
            for (j, layout) in layouts.iter().enumerate() {
                let (r, p) = local_transform(rig, j, &row);
                if let Some((order, cols)) = layout.rotation {
                    let q = o * DQuat::from_mat3(&r) * o.inverse();
                    let before = (t > 0).then(|| cols.map(|c| out[[t - 1, layout.start + c]]));
                    let a = continuous_euler_degrees(order, q, before);
                    for k in 0..3 {
                        out[[t, layout.start + cols[k]]] = a[k];
                    }
                }
                if !layout.position.is_empty() {
                    let world = o * p - DVec3::from_array(out_rig.joint(j).offset);
                    for &(axis, k) in &layout.position {
                        out[[t, layout.start + k]] = world[axis];
                    }
                }
            }
        }
        (out_rig, out)
    }

    #[test]
    fn a_rig_turned_obliquely_gives_the_model_the_same_motion() {
        let rig = cmu_rig("", false);
        let rig_frames = frames(&rig, 30);
        let model = |rig: &Skeleton, f: &Array2<f64>| {
            Retargeter::new(rig, JointMap::detect(rig).unwrap())
                .unwrap()
                .to_model(f.view(), 1.0 / 120.0)
                .frames
        };
        let upright = model(&rig, &rig_frames);
        let turns = [
            DQuat::from_rotation_x(30f64.to_radians())
                * DQuat::from_rotation_y(40f64.to_radians())
                * DQuat::from_rotation_z(50f64.to_radians()),
            DQuat::from_rotation_z(35f64.to_radians()),
            DQuat::from_rotation_x(90f64.to_radians()), // z-up
            DQuat::from_rotation_x(180f64.to_radians()), // upside down
        ];
        for o in turns {
            let (r, f) = turned(&rig, &rig_frames, o);
            let again = model(&r, &f);
            let worst = (&again - &upright)
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                worst < 1e-6,
                "turned by {o}: the model frames differ by {worst}"
            );
        }
    }

    fn rig(rows: &[(&str, &str, [f64; 3], &str)]) -> Skeleton {
        rig_from_rows(rows)
    }

    fn mixamo() -> Skeleton {
        demo_mixamo_rig()
    }

    /// An Unreal-mannequin-style rig: centimetres, z up (x forward, y left), A-pose arms, a
    /// `root` bone under the pelvis' parent, twist bones.
    fn unreal() -> Skeleton {
        let a = std::f64::consts::FRAC_1_SQRT_2;
        rig(&[
            ("root", "", [0.0, 0.0, 0.0], "ZXY"),
            ("pelvis", "root", [0.0, 0.0, 96.0], "ZXY"),
            ("spine_01", "pelvis", [0.0, 0.0, 11.0], "ZXY"),
            ("spine_02", "spine_01", [0.0, 0.0, 14.0], "ZXY"),
            ("spine_03", "spine_02", [0.0, 0.0, 14.0], "ZXY"),
            ("neck_01", "spine_03", [0.0, 0.0, 16.0], "ZXY"),
            ("head", "neck_01", [2.0, 0.0, 10.0], "ZXY"),
            ("clavicle_l", "spine_03", [0.0, 6.0, 12.0], "ZXY"),
            ("upperarm_l", "clavicle_l", [0.0, 14.0, 0.0], "ZXY"),
            (
                "upperarm_twist_01_l",
                "upperarm_l",
                [0.0, 5.0 * a, -5.0 * a],
                "ZXY",
            ),
            (
                "lowerarm_l",
                "upperarm_l",
                [0.0, 28.0 * a, -28.0 * a],
                "ZXY",
            ),
            ("hand_l", "lowerarm_l", [0.0, 26.0 * a, -26.0 * a], "ZXY"),
            ("clavicle_r", "spine_03", [0.0, -6.0, 12.0], "ZXY"),
            ("upperarm_r", "clavicle_r", [0.0, -14.0, 0.0], "ZXY"),
            (
                "lowerarm_r",
                "upperarm_r",
                [0.0, -28.0 * a, -28.0 * a],
                "ZXY",
            ),
            ("hand_r", "lowerarm_r", [0.0, -26.0 * a, -26.0 * a], "ZXY"),
            ("thigh_l", "pelvis", [0.0, 9.0, -5.0], "ZXY"),
            ("calf_l", "thigh_l", [0.0, 0.0, -43.0], "ZXY"),
            ("foot_l", "calf_l", [0.0, 0.0, -42.0], "ZXY"),
            ("ball_l", "foot_l", [12.0, 0.0, -8.0], "ZXY"),
            ("thigh_r", "pelvis", [0.0, -9.0, -5.0], "ZXY"),
            ("calf_r", "thigh_r", [0.0, 0.0, -43.0], "ZXY"),
            ("foot_r", "calf_r", [0.0, 0.0, -42.0], "ZXY"),
            ("ball_r", "foot_r", [12.0, 0.0, -8.0], "ZXY"),
        ])
    }

    #[test]
    fn a_rig_whose_rest_spine_leans_keeps_the_floor_level_as_it_travels() {
        let rig = demo_mixamo_rig();
        let rest = rest_positions(&rig);
        let (hips, head) = (
            find(&rig, "mixamorig:Hips").unwrap(),
            find(&rig, "mixamorig:Head").unwrap(),
        );
        let spine = rest[head] - rest[hips];
        assert!(
            spine.z.abs() > 0.01 * spine.y,
            "the demo spine leans: {spine}"
        );
        let r = Retargeter::new(&rig, JointMap::detect(&rig).unwrap()).unwrap();
        let still = Array2::zeros((1, rig.channel_count()));
        let one = r.to_model(still.view(), 1.0 / 30.0);
        // The model's hips walk 4 m forward and 3 m sideways at one height.
        let mut model = one.clone();
        model.frames = Array2::from_shape_fn((41, one.frames.ncols()), |(t, c)| match c {
            0 => 75.0 * t as f64,
            2 => 100.0 * t as f64,
            _ => one.frames[[0, c]],
        });
        let back = r.to_rig(&model, still.view());
        let p = channel_positions(&rig, back.frames.view()).unwrap();
        for t in 0..41 {
            let dy = p[[t, hips, 1]] - p[[0, hips, 1]];
            assert!(
                dy.abs() < 1e-6,
                "frame {t}: the hips moved {dy} units vertically"
            );
        }
        let (dx, dz) = (
            p[[40, hips, 0]] - p[[0, hips, 0]],
            p[[40, hips, 2]] - p[[0, hips, 2]],
        );
        let travelled = dx.hypot(dz) / r.scale();
        assert!((travelled - 5000.0).abs() < 1e-6, "{travelled} mm");
    }

    #[test]
    fn mixamo_and_unreal_rigs_round_trip_and_stand_upright_on_the_model() {
        for (rig, name) in [(mixamo(), "Mixamo"), (unreal(), "Unreal mannequin")] {
            let map = JointMap::detect(&rig).unwrap();
            assert_eq!(map.name, name);
            let r = Retargeter::new(&rig, map).unwrap();
            assert!(
                (r.scale() - 0.1).abs() < 0.03,
                "{name}: {} (centimetres)",
                r.scale()
            );
            // The rest pose on the model: the head above the hips, the feet below, whatever
            // the rig's up axis.
            let rest = Array2::zeros((1, rig.channel_count()));
            let model = r.to_model(rest.view(), 1.0 / 30.0);
            let p = channel_positions(&model.skeleton, model.frames.view()).unwrap();
            let h36m = Skeleton::h36m();
            let y = |joint: &str| p[[0, find(&h36m, joint).unwrap(), 1]] - p[[0, 0, 1]];
            assert!(
                y("Head") > 400.0 && y("LeftFoot") < -600.0,
                "{name}: {} {}",
                y("Head"),
                y("LeftFoot")
            );
            // T-pose / A-pose arms become the model's arms: hands level with or below the neck.
            assert!(
                y("LeftHand") < y("Neck") + 50.0,
                "{name}: hand {} neck {}",
                y("LeftHand"),
                y("Neck")
            );
            let frames = frames(&rig, 30);
            let model = r.to_model(frames.view(), 1.0 / 30.0);
            let back = r.to_rig(&model, frames.view());
            let mut worst: f64 = 0.0;
            for t in 0..30 {
                let a = local_quats(&rig, frames.row(t).as_slice().unwrap());
                let b = local_quats(&rig, back.frames.row(t).as_slice().unwrap());
                for (qa, qb) in a.iter().zip(&b) {
                    worst = worst.max(2.0 * (qa.inverse() * *qb).xyz().length());
                }
                for c in 0..3 {
                    assert!(
                        (frames[[t, c]] - back.frames[[t, c]]).abs() < 1e-9,
                        "{name}"
                    );
                }
            }
            assert!(
                worst.to_degrees() < 1e-4,
                "{name}: {} deg",
                worst.to_degrees()
            );
        }
    }
}
