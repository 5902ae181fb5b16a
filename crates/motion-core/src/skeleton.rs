//! Skeletons: joint names, parents, rest offsets and per-joint BVH channel layouts, plus the
//! built-in H3.6M 32-joint and CMU 38-joint skeletons and the protocol's joint/dim constants.
use crate::error::SkeletonError;

/// One BVH channel of a joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Translation along x.
    Xposition,
    /// Translation along y.
    Yposition,
    /// Translation along z.
    Zposition,
    /// Rotation about x (degrees, as in BVH files).
    Xrotation,
    /// Rotation about y (degrees, as in BVH files).
    Yrotation,
    /// Rotation about z (degrees, as in BVH files).
    Zrotation,
}

impl Channel {
    /// The channel's name as written in BVH files (`Xposition`, ..., `Zrotation`).
    pub fn bvh_name(self) -> &'static str {
        match self {
            Channel::Xposition => "Xposition",
            Channel::Yposition => "Yposition",
            Channel::Zposition => "Zposition",
            Channel::Xrotation => "Xrotation",
            Channel::Yrotation => "Yrotation",
            Channel::Zrotation => "Zrotation",
        }
    }

    /// Parses a BVH channel name (case-sensitive, as written by exporters).
    pub fn from_bvh_name(name: &str) -> Option<Channel> {
        Some(match name {
            "Xposition" => Channel::Xposition,
            "Yposition" => Channel::Yposition,
            "Zposition" => Channel::Zposition,
            "Xrotation" => Channel::Xrotation,
            "Yrotation" => Channel::Yrotation,
            "Zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }

    /// The axis, 0 = x, 1 = y, 2 = z.
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }

    /// True for the three rotation channels.
    pub fn is_rotation(self) -> bool {
        matches!(
            self,
            Channel::Xrotation | Channel::Yrotation | Channel::Zrotation
        )
    }
}

/// One joint (or BVH End Site) of a [`Skeleton`].
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Joint name (End Sites get a generated name such as `"HeadSite"` or `"<parent>_end"`).
    pub name: String,
    /// Index of the parent joint; `None` for the root (joint 0).
    pub parent: Option<usize>,
    /// Rest offset from the parent (mm, y up).
    pub offset: [f64; 3],
    /// BVH channels in file order (empty for End Sites).
    pub channels: Vec<Channel>,
    /// True for a BVH `End Site`: a leaf with an offset and no channels.
    pub is_end_site: bool,
}

impl Joint {
    /// A regular joint.
    pub fn new(
        name: impl Into<String>,
        parent: Option<usize>,
        offset: [f64; 3],
        channels: Vec<Channel>,
    ) -> Joint {
        Joint {
            name: name.into(),
            parent,
            offset,
            channels,
            is_end_site: false,
        }
    }

    /// A BVH End Site (no channels).
    pub fn end_site(name: impl Into<String>, parent: usize, offset: [f64; 3]) -> Joint {
        Joint {
            name: name.into(),
            parent: Some(parent),
            offset,
            channels: Vec::new(),
            is_end_site: true,
        }
    }
}

/// A validated joint hierarchy: joint 0 is the only root and every parent comes before its
/// children, so a single forward pass over the joints is a valid FK order.
#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    joints: Vec<Joint>,
    children: Vec<Vec<usize>>,
    /// Index of each joint's first channel in a frame (BVH channel layout).
    channel_start: Vec<usize>,
    channel_count: usize,
}

impl Skeleton {
    /// Validates and builds a skeleton: at least one joint, joint 0 is the only root, parents come
    /// before children, names are unique, End Sites have no channels nor children, no channel is
    /// repeated within a joint, offsets are finite.
    pub fn new(joints: Vec<Joint>) -> Result<Skeleton, SkeletonError> {
        if joints.is_empty() {
            return Err(SkeletonError::Empty);
        }
        let mut children = vec![Vec::new(); joints.len()];
        let mut channel_start = Vec::with_capacity(joints.len());
        let mut channel_count = 0;
        let mut names: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
        for (index, joint) in joints.iter().enumerate() {
            let name = || joint.name.clone();
            match (index, joint.parent) {
                (0, Some(_)) => return Err(SkeletonError::RootHasParent { name: name() }),
                (0, None) => {}
                (_, None) => {
                    return Err(SkeletonError::MultipleRoots {
                        index,
                        name: name(),
                    })
                }
                (_, Some(parent)) => {
                    if parent >= index {
                        return Err(SkeletonError::ParentNotBefore {
                            index,
                            name: name(),
                            parent,
                        });
                    }
                    if joints[parent].is_end_site {
                        return Err(SkeletonError::BadEndSite {
                            index: parent,
                            name: joints[parent].name.clone(),
                            problem: "has children",
                        });
                    }
                    children[parent].push(index);
                }
            }
            if let Some(&first) = names.get(joint.name.as_str()) {
                return Err(SkeletonError::DuplicateName {
                    name: name(),
                    first,
                    second: index,
                });
            }
            names.insert(joint.name.as_str(), index);
            if joint.is_end_site && !joint.channels.is_empty() {
                return Err(SkeletonError::BadEndSite {
                    index,
                    name: name(),
                    problem: "has channels",
                });
            }
            for (k, c) in joint.channels.iter().enumerate() {
                if joint.channels[..k].contains(c) {
                    return Err(SkeletonError::DuplicateChannel {
                        index,
                        name: name(),
                        channel: c.bvh_name(),
                    });
                }
            }
            if joint.offset.iter().any(|v| !v.is_finite()) {
                return Err(SkeletonError::NonFiniteOffset {
                    index,
                    name: name(),
                });
            }
            channel_start.push(channel_count);
            channel_count += joint.channels.len();
        }
        Ok(Skeleton {
            joints,
            children,
            channel_start,
            channel_count,
        })
    }

    /// The names of the joints that carry channels (End Sites aside), in skeleton order.
    pub fn body_joint_names(&self) -> Vec<&str> {
        self.joints
            .iter()
            .filter(|j| !j.is_end_site)
            .map(|j| j.name.as_str())
            .collect()
    }

    /// All joints (including End Sites) in FK order (parents first).
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Number of joints, End Sites included.
    pub fn len(&self) -> usize {
        self.joints.len()
    }

    /// Always false: a valid skeleton has a root.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// Joint `j`.
    ///
    /// # Panics
    /// If `j >= len()`.
    pub fn joint(&self, j: usize) -> &Joint {
        &self.joints[j]
    }

    /// Index of the joint called `name`.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Parent of joint `j` (`None` for the root).
    ///
    /// # Panics
    /// If `j >= len()`.
    pub fn parent(&self, j: usize) -> Option<usize> {
        self.joints[j].parent
    }

    /// Children of joint `j`, in index order.
    ///
    /// # Panics
    /// If `j >= len()`.
    pub fn children(&self, j: usize) -> &[usize] {
        &self.children[j]
    }

    /// Total number of BVH channels of a frame.
    pub fn channel_count(&self) -> usize {
        self.channel_count
    }

    /// Index in a BVH frame of joint `j`'s first channel.
    ///
    /// # Panics
    /// If `j >= len()`.
    pub fn channel_start(&self, j: usize) -> usize {
        self.channel_start[j]
    }

    /// Width of an exp-map frame for this skeleton: 3 root-translation dims plus one exp-map
    /// triple per joint (`3 + 3 * len()`: 99 for H3.6M, 117 for CMU).
    pub fn expmap_width(&self) -> usize {
        3 + 3 * self.joints.len()
    }

    /// Rest-pose bone length of joint `j` (norm of its offset).
    pub fn bone_length(&self, j: usize) -> f64 {
        let o = self.joints[j].offset;
        (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
    }

    /// The built-in H3.6M 32-joint skeleton (names, parents and offsets in mm of
    /// `h36m_skeleton.json`). Every joint, the "Site" leaves included, is a regular joint because
    /// the data has an exp-map triple for each; the root has the channels
    /// `Xposition Yposition Zposition Zrotation Xrotation Yrotation`, every other joint
    /// `Zrotation Xrotation Yrotation`.
    pub fn h36m() -> Skeleton {
        build_builtin(
            H36M_JOINTS
                .iter()
                .map(|&(name, parent, offset)| (name.to_string(), parent, offset)),
        )
    }

    /// The built-in CMU 38-joint skeleton of the exp-map subset (parents and offsets of
    /// `cmu_skeleton.json`; y up). The source gives no names: the joints are called `joint_00` ..
    /// `joint_37`. Channels as in [`Skeleton::h36m`].
    ///
    /// Units are the loader's, **not mm**: the CMU ASF unit (1/0.45 inch ≈ 56.4 mm). The files'
    /// absolute root positions are in the same unit: with them the hips stand ≈ 16.7 units high
    /// and the lowest joint stays within ~2 units of y = 0 (`tests/foundations.rs` checks it).
    pub fn cmu() -> Skeleton {
        build_builtin(
            CMU_JOINTS
                .iter()
                .enumerate()
                .map(|(i, &(parent, offset))| (format!("joint_{i:02}"), parent, offset)),
        )
    }
}

fn build_builtin(joints: impl Iterator<Item = (String, i32, [f64; 3])>) -> Skeleton {
    use Channel::*;
    let joints = joints
        .map(|(name, parent, offset)| {
            let channels = if parent < 0 {
                vec![
                    Xposition, Yposition, Zposition, Zrotation, Xrotation, Yrotation,
                ]
            } else {
                vec![Zrotation, Xrotation, Yrotation]
            };
            Joint::new(name, usize::try_from(parent).ok(), offset, channels)
        })
        .collect();
    Skeleton::new(joints).expect("built-in skeleton is valid")
}

/// Number of joints of the H3.6M skeleton.
pub const H36M_JOINT_COUNT: usize = 32;
/// Number of dims of an H3.6M exp-map frame.
pub const H36M_FRAME_DIMS: usize = 99;
/// Number of joints of the CMU exp-map skeleton.
pub const CMU_JOINT_COUNT: usize = 38;
/// Number of dims of a CMU exp-map frame.
pub const CMU_FRAME_DIMS: usize = 117;
/// Frame rate of the H3.6M and CMU exp-map source files.
pub const H36M_SOURCE_FPS: f64 = 50.0;
/// Frame rate of the evaluation protocol (even frames of the 50 Hz files).
pub const H36M_PROTOCOL_FPS: f64 = 25.0;

/// The 54 dims of an H3.6M frame that the published models use (the others are constant).
pub const H36M_DIMS_USED: [usize; 54] = [
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15, 21, 22, 23, 24, 27, 28, 29, 30, 36, 37, 38, 39,
    40, 41, 42, 43, 44, 45, 46, 47, 51, 52, 53, 54, 55, 56, 57, 60, 61, 62, 75, 76, 77, 78, 79, 80,
    81, 84, 85, 86,
];

/// The 12 joints of the NDMS metric, in pairs (left, right) of wrists, elbows, shoulders, hips,
/// knees, ankles, as listed in `h36m_skeleton.json`.
pub const H36M_NDMS_JOINTS: [usize; 12] = [19, 27, 18, 26, 17, 25, 6, 1, 7, 2, 8, 3];

/// Index of the left hip (`LeftUpLeg`).
pub const H36M_LEFT_HIP: usize = 6;
/// Index of the right hip (`RightUpLeg`).
pub const H36M_RIGHT_HIP: usize = 1;

/// The 15 H3.6M actions in the order of h36m.md (also the one-hot order of conditioned models).
pub const H36M_ACTIONS: [&str; 15] = [
    "directions",
    "discussion",
    "eating",
    "greeting",
    "phoning",
    "posing",
    "purchases",
    "sitting",
    "sittingdown",
    "smoking",
    "takingphoto",
    "waiting",
    "walking",
    "walkingdog",
    "walkingtogether",
];

/// `(name, parent or -1, offset mm)` of the 32 H3.6M joints, from `h36m_skeleton.json`.
#[rustfmt::skip]
const H36M_JOINTS: [(&str, i32, [f64; 3]); 32] = [
    ("Hips", -1, [0.0, 0.0, 0.0]),
    ("RightUpLeg", 0, [-132.948591, 0.0, 0.0]),
    ("RightLeg", 1, [0.0, -442.894612, 0.0]),
    ("RightFoot", 2, [0.0, -454.206447, 0.0]),
    ("RightToeBase", 3, [0.0, 0.0, 162.767078]),
    ("RightToeSite", 4, [0.0, 0.0, 74.999437]),
    ("LeftUpLeg", 0, [132.948826, 0.0, 0.0]),
    ("LeftLeg", 6, [0.0, -442.894413, 0.0]),
    ("LeftFoot", 7, [0.0, -454.20659, 0.0]),
    ("LeftToeBase", 8, [0.0, 0.0, 162.767426]),
    ("LeftToeSite", 9, [0.0, 0.0, 74.999948]),
    ("Spine", 0, [0.0, 0.1, 0.0]),
    ("Spine1", 11, [0.0, 233.383263, 0.0]),
    ("Neck", 12, [0.0, 257.077681, 0.0]),
    ("Head", 13, [0.0, 121.134938, 0.0]),
    ("HeadSite", 14, [0.0, 115.002227, 0.0]),
    ("LeftShoulder", 12, [0.0, 257.077681, 0.0]),
    ("LeftArm", 16, [0.0, 151.034226, 0.0]),
    ("LeftForeArm", 17, [0.0, 278.882773, 0.0]),
    ("LeftHand", 18, [0.0, 251.733451, 0.0]),
    ("LeftHandThumb", 19, [0.0, 0.0, 0.0]),
    ("LeftThumbSite", 20, [0.0, 0.0, 99.999627]),
    ("LeftWristEnd", 19, [0.0, 100.000188, 0.0]),
    ("LeftWristSite", 22, [0.0, 0.0, 0.0]),
    ("RightShoulder", 12, [0.0, 257.077681, 0.0]),
    ("RightArm", 24, [0.0, 151.031437, 0.0]),
    ("RightForeArm", 25, [0.0, 278.892924, 0.0]),
    ("RightHand", 26, [0.0, 251.72868, 0.0]),
    ("RightHandThumb", 27, [0.0, 0.0, 0.0]),
    ("RightThumbSite", 28, [0.0, 0.0, 99.999888]),
    ("RightWristEnd", 27, [0.0, 137.499922, 0.0]),
    ("RightWristSite", 30, [0.0, 0.0, 0.0]),
];

/// `(parent or -1, offset)` of the 38 CMU joints, from `cmu_skeleton.json`.
#[rustfmt::skip]
const CMU_JOINTS: [(i32, [f64; 3]); 38] = [
    (-1, [0.0, 0.0, 0.0]),
    (0, [0.0, 0.0, 0.0]),
    (1, [1.65674, -1.80282, 0.62477]),
    (2, [2.5972, -7.13576, 0.0]),
    (3, [2.49236, -6.8477, 0.0]),
    (4, [0.19704, -0.54136, 2.14581]),
    (5, [0.0, 0.0, 1.11249]),
    (0, [0.0, 0.0, 0.0]),
    (7, [-1.6107, -1.80282, 0.62476]),
    (8, [-2.59502, -7.12977, 0.0]),
    (9, [-2.4678, -6.78024, 0.0]),
    (10, [-0.23024, -0.63258, 2.13368]),
    (11, [0.0, 0.0, 1.11569]),
    (0, [0.0, 0.0, 0.0]),
    (13, [0.01961, 2.0545, -0.14112]),
    (14, [0.01021, 2.06436, -0.05921]),
    (15, [0.0, 0.0, 0.0]),
    (16, [0.00713, 1.56711, 0.14968]),
    (17, [0.03429, 1.56041, -0.10006]),
    (18, [0.01305, 1.6256, -0.05265]),
    (15, [0.0, 0.0, 0.0]),
    (20, [3.54205, 0.90436, -0.17364]),
    (21, [4.86513, 0.0, 0.0]),
    (22, [3.35554, 0.0, 0.0]),
    (23, [0.0, 0.0, 0.0]),
    (24, [0.66117, 0.0, 0.0]),
    (25, [0.53306, 0.0, 0.0]),
    (23, [0.0, 0.0, 0.0]),
    (27, [0.5412, 0.0, 0.5412]),
    (15, [0.0, 0.0, 0.0]),
    (29, [-3.49802, 0.75994, -0.32616]),
    (30, [-5.02649, 0.0, 0.0]),
    (31, [-3.36431, 0.0, 0.0]),
    (32, [0.0, 0.0, 0.0]),
    (33, [-0.73041, 0.0, 0.0]),
    (34, [-0.58887, 0.0, 0.0]),
    (32, [0.0, 0.0, 0.0]),
    (36, [-0.59786, 0.0, 0.59786]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn h36m_skeleton_matches_the_reference_json_facts() {
        let s = Skeleton::h36m();
        assert_eq!(s.len(), H36M_JOINT_COUNT);
        assert_eq!(s.expmap_width(), H36M_FRAME_DIMS);
        assert_eq!(s.joint(0).name, "Hips");
        assert_eq!(s.joint_index("RightWristSite"), Some(31));
        assert_eq!(s.parent(13), Some(12));
        assert_eq!(s.children(0), &[1, 6, 11]);
        assert_eq!(s.children(12), &[13, 16, 24]);
        assert_eq!(s.joint(26).offset, [0.0, 278.892924, 0.0]);
        assert_eq!(s.channel_count(), 6 + 31 * 3);
        assert_eq!(s.channel_start(1), 6);
        assert_eq!(s.joint(H36M_LEFT_HIP).name, "LeftUpLeg");
        assert_eq!(s.joint(H36M_RIGHT_HIP).name, "RightUpLeg");
        let names: Vec<&str> = H36M_NDMS_JOINTS
            .iter()
            .map(|&j| s.joint(j).name.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "LeftHand",
                "RightHand",
                "LeftForeArm",
                "RightForeArm",
                "LeftArm",
                "RightArm",
                "LeftUpLeg",
                "RightUpLeg",
                "LeftLeg",
                "RightLeg",
                "LeftFoot",
                "RightFoot"
            ]
        );
        assert!(H36M_DIMS_USED.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(*H36M_DIMS_USED.last().unwrap(), 86);
    }

    #[test]
    fn cmu_skeleton_has_38_named_joints() {
        let s = Skeleton::cmu();
        assert_eq!(s.len(), CMU_JOINT_COUNT);
        assert_eq!(s.expmap_width(), CMU_FRAME_DIMS);
        assert_eq!(s.joint(7).name, "joint_07");
        assert_eq!(s.joint(2).offset, [1.65674, -1.80282, 0.62477]);
    }

    fn j(name: &str, parent: Option<usize>) -> Joint {
        Joint::new(name, parent, [0.0; 3], vec![Channel::Xrotation])
    }

    #[test]
    fn validation_rejects_bad_hierarchies() {
        assert_eq!(Skeleton::new(vec![]), Err(SkeletonError::Empty));
        assert!(matches!(
            Skeleton::new(vec![j("a", Some(0))]),
            Err(SkeletonError::RootHasParent { .. })
        ));
        assert!(matches!(
            Skeleton::new(vec![j("a", None), j("b", None)]),
            Err(SkeletonError::MultipleRoots { index: 1, .. })
        ));
        assert!(matches!(
            Skeleton::new(vec![j("a", None), j("b", Some(2)), j("c", Some(0))]),
            Err(SkeletonError::ParentNotBefore { index: 1, .. })
        ));
        assert!(matches!(
            Skeleton::new(vec![j("a", None), j("a", Some(0))]),
            Err(SkeletonError::DuplicateName {
                first: 0,
                second: 1,
                ..
            })
        ));
        let mut site = Joint::end_site("s", 0, [1.0, 0.0, 0.0]);
        site.channels.push(Channel::Xrotation);
        assert!(matches!(
            Skeleton::new(vec![j("a", None), site]),
            Err(SkeletonError::BadEndSite { .. })
        ));
        assert!(matches!(
            Skeleton::new(vec![
                j("a", None),
                Joint::end_site("s", 0, [1.0, 0.0, 0.0]),
                j("c", Some(1))
            ]),
            Err(SkeletonError::BadEndSite { index: 1, .. })
        ));
        let mut twice = j("a", None);
        twice.channels.push(Channel::Xrotation);
        assert!(matches!(
            Skeleton::new(vec![twice]),
            Err(SkeletonError::DuplicateChannel { .. })
        ));
        let mut nan = j("a", None);
        nan.offset[1] = f64::NAN;
        assert!(matches!(
            Skeleton::new(vec![nan]),
            Err(SkeletonError::NonFiniteOffset { .. })
        ));
    }

    #[test]
    fn end_sites_take_no_channels() {
        let s = Skeleton::new(vec![
            Joint::new(
                "root",
                None,
                [0.0; 3],
                vec![Channel::Yposition, Channel::Zrotation],
            ),
            Joint::end_site("root_end", 0, [0.0, 10.0, 0.0]),
            Joint::new("arm", Some(0), [1.0, 0.0, 0.0], vec![Channel::Xrotation]),
        ])
        .unwrap();
        assert_eq!(s.channel_count(), 3);
        assert_eq!(s.channel_start(1), 2);
        assert_eq!(s.channel_start(2), 2);
        assert!(s.joint(1).is_end_site);
        assert_eq!(s.bone_length(1), 10.0);
    }

    #[test]
    fn channel_names_round_trip() {
        use Channel::*;
        for c in [
            Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation,
        ] {
            assert_eq!(Channel::from_bvh_name(c.bvh_name()), Some(c));
        }
        assert_eq!(Channel::from_bvh_name("xrotation"), None);
    }
}
