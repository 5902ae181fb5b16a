//! Grounding: generated motion kept on a floor, upright, with planted feet — the one rule every
//! front end applies (`Character`, `predict`, `render`, the C ABI, Bevy, web, Python), on by
//! default and switchable off ([`GroundingConfig::enabled`]) so raw model output stays
//! scorable.
//!
//! ## What it does to each frame after the seed, in this order
//! 1. **Floor frame** ([`floor`]): a plane fitted to the seed's lowest foot points becomes
//!    `y = 0` (rigid: the seed's own floor, levelled).
//! 2. **Lean**: the torso vector (root → torso top, [`legs`]) is held within the action's limit
//!    ([`lean_limit_deg`]: the 95th percentile of real H3.6M motion) by tilting the root about
//!    the hips, softly ([`LEAN_SOFTNESS_DEG`] below the limit it starts to give).
//! 3. **Height**: the root moves vertically so that the supporting foot's lowest point is on the
//!    floor (the character is always supported; there are no jumps in the training data), or,
//!    over the **seat** a seed that ends seated or kneeling leaves ([`seat`]), on that seat: the
//!    root no lower than the seed's, and not sliding while it rests there. The
//!    supporting foot is the one moving slower horizontally, or the lower one when both are
//!    slower than [`GroundingConfig::contact_speed_m_s`]. Then the **hip-height hold**: a root
//!    lower than the action's limit ([`hip_floor_fraction`] of the rig's standing root height:
//!    the 5th percentile of real H3.6M motion, plus [`HIP_HOLD_MARGIN`]) is raised to it, softly ([`HIP_SOFTNESS`] of the
//!    standing height above the limit it starts to give), and step 4's IK straightens the legs
//!    to keep the feet on the floor (a held foot too far away to stand over steps, one foot at a
//!    time and only while the body stands on the other: to where the model has it when that is
//!    near enough, else in towards under its hip; a body on one held foot it cannot rise over
//!    moves over it, at most 1.5 m/s and only while the model's root travels slower than 0.6 m/s
//!    (a walker passes over its stance foot by itself), the offset kept once it has stood on that
//!    foot for 0.5 s and returning over about a second otherwise;
//!    a straight leg that cannot reach brings the body down again in step 5): a model that
//!    sinks into a crouch stands as tall as real people do.
//! 4. **Foot locking** (then the lowest foot point is put on the floor once more): a foot is in contact while its lowest point is below
//!    [`GroundingConfig::contact_height_m`] and its ankle moves slower than
//!    [`GroundingConfig::contact_speed_m_s`] horizontally; from the first frame of a contact its
//!    ankle is held over where it was, the foot's lowest point on the floor, by two-bone IK of
//!    hip and knee, and the foot keeps the world rotation it had then (a held foot behind the
//!    body that its straight leg cannot reach rolls onto its toes instead, about its toe tip,
//!    up to 40 degrees of heel rise, as a walker's rear foot does before it leaves the floor;
//!    so does the supporting foot when the hip-height hold raised it out of reach); a body whose
//!    held foot is out of reach is held back horizontally to where the flat foot reaches, or,
//!    while the root leads ([`Grounder::set_root_leads`]: a steered character), to where the
//!    foot rolled onto its toes reaches; released when the model lifts or speeds up the foot or the leg cannot reach,
//!    blending back to the model's foot over [`GroundingConfig::release_s`] (a foot held more
//!    than `STEP_MIN_M` (5 cm) from where the model has it steps there, lifted up to
//!    `STEP_HEIGHT_M` (8 cm), instead of sliding over the floor). A foot that lands within
//!    5 cm of where it was drawn on the frame before is held there, with the rotation it was
//!    drawn with (it does not slide the end of the model's swing along the floor). A foot
//!    that is not held is lifted by the same IK when it dips under the floor, and, when it
//!    swings faster than half the contact speed, towards
//!    [`GroundingConfig::swing_clearance_m`] (all of it from the contact speed on, risen to
//!    over 0.06 s).
//!
//! Lengths are metres in the floor frame, +y up; thresholds hold for any rig because the
//! skeleton's units are given ([`Grounder::new`]'s `metres_per_unit`).
//!
//! ```
//! use glam::{Quat, Vec3};
//! use motion_core::grounding::{Grounder, GroundingConfig};
//! use motion_core::Skeleton;
//!
//! let skeleton = Skeleton::h36m();
//! let mut grounder = Grounder::new(&skeleton, 1e-3, GroundingConfig::default())?;
//! let rest = vec![Quat::IDENTITY; skeleton.len()];
//! for _ in 0..10 {
//!     grounder.observe_seed(Vec3::new(0.0, 1.0, 0.0), &rest); // the seed's feet: 0.1 m up
//! }
//! let (mut root, mut rotations) = (Vec3::new(0.0, 1.5, 0.0), rest.clone()); // floats 0.5 m
//! grounder.ground(&mut root, &mut rotations, 0.04);
//! assert!((root.y - 0.897).abs() < 1e-3); // toes back on the seed's floor, now y = 0
//! # Ok::<(), motion_core::grounding::GroundingError>(())
//! ```
pub mod clip;
mod feet;
pub mod floor;
mod ik;
pub mod legs;
mod pose;
pub mod seat;

use glam::{Quat, Vec3};

use crate::skeleton::Skeleton;
pub use clip::{ground_expmap_clip, ClipSpec, GroundedClip};
use feet::FootState;
pub use floor::Floor;
pub use legs::{find_body_parts, BodyParts, Leg, LegsError};
pub use pose::PoseGrounder;

/// The lean limit starts to give this far below its value (degrees).
pub const LEAN_SOFTNESS_DEG: f32 = 6.0;

/// The 95th percentile of the torso lean (degrees from +y, in the floor frame of each window's
/// seed) of real H3.6M motion per action: every subject, the first 2 s after the seed of real
/// windows every 1 s, each root integrated from its take's first frame
/// (`motion_metrics::plausibility::RealRanges`; its data test recomputes it), within 0.02° under
/// it. `discussion` and `waiting` have no S5 file and no reference: they
/// get the widest limit.
pub const LEAN_P95_DEG: [(&str, f32); 13] = [
    ("directions", 22.75),
    ("eating", 28.54),
    ("greeting", 38.13),
    ("phoning", 26.81),
    ("posing", 43.72),
    ("purchases", 108.25),
    ("sitting", 56.20),
    ("sittingdown", 91.81),
    ("smoking", 34.51),
    ("takingphoto", 68.44),
    ("walking", 31.69),
    ("walkingdog", 85.89),
    ("walkingtogether", 15.21),
];

/// Rest-pose root height above the lowest foot point of [`Skeleton::h36m`] (mm): the standing
/// height [`HIP_P5_MM`] is measured against.
pub const H36M_STANDING_HEIGHT_MM: f32 = 897.1;

/// The 5th percentile of the root's height above the floor (mm, on the H3.6M skeleton, whose
/// standing root height is [`H36M_STANDING_HEIGHT_MM`]) of real H3.6M motion per action, from
/// the same frames as [`LEAN_P95_DEG`] (`motion_metrics::plausibility::RealRanges`; its data
/// test recomputes it), within 0.2 mm over it. Actions without a reference get the lowest.
/// Sitting's and sitting down's lie near the floor or under it (people in those takes also sit
/// on the floor and lie down): no hold to speak of; a seated seed's [`seat`] holds its root.
pub const HIP_P5_MM: [(&str, f32); 13] = [
    ("directions", 870.0),
    ("eating", 492.7),
    ("greeting", 857.5),
    ("phoning", 473.2),
    ("posing", 782.2),
    ("purchases", 518.2),
    ("sitting", 130.7),
    ("sittingdown", -88.6),
    ("smoking", 491.7),
    ("takingphoto", 395.7),
    ("walking", 847.2),
    ("walkingdog", 484.8),
    ("walkingtogether", 853.6),
];

/// The hip-height hold starts to give this far above its limit (a fraction of the standing
/// root height).
pub const HIP_SOFTNESS: f32 = 0.04;

/// The hip-height hold sits this far above the action's real 5th percentile (a fraction of the
/// standing root height: 13.5 mm on H3.6M), because a body held there still dips under it where
/// a straight leg cannot reach (a step with the other foot in the air): with it, the grounded
/// root's 5th percentile meets the real one on every action of the 60 s validation windows.
/// Chosen with the game default by `training/select_game.py --rule targets --readme` over
/// 0, 0.005, 0.01 and 0.015 (2026-12-07, `docs/models.md`).
pub const HIP_HOLD_MARGIN: f32 = 0.015;

/// The real 5th percentile of the root height of `action` ([`HIP_P5_MM`], mm on the H3.6M
/// skeleton), or the lowest of them for an unknown action or none.
pub fn hip_p5_mm(action: Option<&str>) -> f32 {
    per_action(&HIP_P5_MM, action).unwrap_or_else(|| {
        HIP_P5_MM
            .iter()
            .map(|&(_, v)| v)
            .fold(f32::INFINITY, f32::min)
    })
}

/// The lowest root height the hip-height hold keeps for `action`, as a fraction of the
/// standing root height: its [`hip_p5_mm`] over [`H36M_STANDING_HEIGHT_MM`], plus
/// [`HIP_HOLD_MARGIN`].
pub fn hip_floor_fraction(action: Option<&str>) -> f32 {
    hip_p5_mm(action) / H36M_STANDING_HEIGHT_MM + HIP_HOLD_MARGIN
}

/// `action`'s value in a per-action table.
fn per_action(table: &[(&str, f32)], action: Option<&str>) -> Option<f32> {
    let action = action?;
    table
        .iter()
        .find(|(name, _)| *name == action)
        .map(|&(_, v)| v)
}

/// The lean limit of `action` (degrees): its [`LEAN_P95_DEG`], or the largest of them for an
/// unknown action or none.
pub fn lean_limit_deg(action: Option<&str>) -> f32 {
    per_action(&LEAN_P95_DEG, action)
        .unwrap_or_else(|| LEAN_P95_DEG.iter().map(|&(_, v)| v).fold(0.0, f32::max))
}

/// Why grounding cannot run on a rig.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GroundingError {
    /// The rig's legs were not found ([`legs`]'s rule).
    #[error("grounding: {0}")]
    Legs(#[from] LegsError),
    /// A unit scale that is not a positive finite number.
    #[error("grounding: metres per skeleton unit must be positive and finite, got {0:e}")]
    Units(f32),
}

/// How grounding treats generated frames (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundingConfig {
    /// Whether to ground at all (`false`: frames pass unchanged).
    pub enabled: bool,
    /// Lean limit in degrees; `None`: the current action's [`lean_limit_deg`].
    pub max_lean_deg: Option<f32>,
    /// Lowest root height as a fraction of the rig's standing root height (0: no hold);
    /// `None`: the current action's [`hip_floor_fraction`].
    pub min_hip_fraction: Option<f32>,
    /// A foot below this above the floor can be in contact (metres).
    pub contact_height_m: f32,
    /// A foot whose ankle moves slower than this horizontally can be in contact (m/s).
    pub contact_speed_m_s: f32,
    /// Whether feet in contact are held by IK.
    pub foot_locking: bool,
    /// Whether a seed that ends seated or kneeling leaves a seat under its root ([`seat`]).
    pub seats: bool,
    /// Seconds over which a released foot blends back to the model's.
    pub release_s: f32,
    /// A free foot moving faster than `contact_speed_m_s` keeps its lowest point at least this
    /// high (metres; from half that speed, a share of it): a swinging foot clears the floor.
    pub swing_clearance_m: f32,
}

impl Default for GroundingConfig {
    fn default() -> Self {
        GroundingConfig {
            enabled: true,
            max_lean_deg: None,
            min_hip_fraction: None,
            contact_height_m: 0.05,
            contact_speed_m_s: 1.0,
            foot_locking: true,
            seats: true,
            release_s: 0.12,
            swing_clearance_m: 0.06,
        }
    }
}

impl GroundingConfig {
    /// Grounding switched off (research scoring of raw model output).
    pub fn off() -> Self {
        GroundingConfig {
            enabled: false,
            ..GroundingConfig::default()
        }
    }
}

/// Streaming grounding of one character (see the module docs): observe the seed's frames, then
/// ground each later frame in place. No allocation per grounded frame.
#[derive(Debug, Clone)]
pub struct Grounder {
    config: GroundingConfig,
    parts: BodyParts,
    parents: Vec<Option<usize>>,
    offsets: Vec<Vec3>,
    lean_limit: f32,
    /// The rig's standing root height (metres).
    standing_height: f32,
    /// The hip-height hold in force (fraction of `standing_height`).
    hip_fraction: f32,
    seed_points: Vec<Vec3>,
    /// The last seed frame's root and ankles (world, metres).
    seed_last: Option<(Vec3, [Vec3; 2])>,
    floor: Option<Floor>,
    /// The seat the seed left ([`seat`]; floor frame), found with the floor.
    seat: Option<Vec3>,
    /// The grounded root of the last frame (floor frame).
    last_root: Option<Vec3>,
    positions: Vec<Vec3>,
    rotations: Vec<Quat>,
    feet: [FootState; 2],
    /// The horizontal offset held feet have added to the root so far.
    held_offset: Vec3,
    /// The horizontal offset the hip-height hold has added to put the body over a lone held
    /// foot (it returns to zero over [`BALANCE_RETURN_S`] when not needed).
    balance: Vec3,
    /// The leg whose foot alone was held on the last frame, and for how long it has been
    /// (seconds): the balance offset does not return while the body stands on one foot for
    /// longer than a step does.
    one_foot: Option<(usize, f32)>,
    /// The model's root on the last frame (floor frame, before grounding's offsets).
    model_root: Option<Vec3>,
    /// Whether the root leads (a steered character): see [`Grounder::set_root_leads`].
    root_leads: bool,
    /// The source's own foot contacts for the next frame: see [`Grounder::set_source_contacts`].
    source_contacts: Option<[bool; 2]>,
}

/// Seed frames kept for the floor fit (the last ones).
const MAX_SEED_FRAMES: usize = 4096;
impl Grounder {
    /// A grounder for `skeleton`, whose offsets are in units of `metres_per_unit` metres (1e-3
    /// for the millimetre skeletons of this crate).
    ///
    /// # Errors
    /// A rig without two legs ([`legs`]) or a bad unit scale.
    pub fn new(
        skeleton: &Skeleton,
        metres_per_unit: f32,
        config: GroundingConfig,
    ) -> Result<Grounder, GroundingError> {
        if !(metres_per_unit.is_finite() && metres_per_unit > 0.0) {
            return Err(GroundingError::Units(metres_per_unit));
        }
        let parts = find_body_parts(skeleton)?;
        let n = skeleton.len();
        Ok(Grounder {
            lean_limit: config.max_lean_deg.unwrap_or_else(|| lean_limit_deg(None)),
            standing_height: (parts.standing_height as f32 * metres_per_unit).max(0.0),
            hip_fraction: config
                .min_hip_fraction
                .unwrap_or_else(|| hip_floor_fraction(None)),
            config,
            parts,
            parents: skeleton.joints().iter().map(|j| j.parent).collect(),
            offsets: skeleton
                .joints()
                .iter()
                .map(|j| Vec3::from_array(j.offset.map(|v| v as f32)) * metres_per_unit)
                .collect(),
            seed_points: Vec::with_capacity(256),
            seed_last: None,
            floor: None,
            seat: None,
            last_root: None,
            positions: vec![Vec3::ZERO; n],
            rotations: vec![Quat::IDENTITY; n],
            feet: [FootState::default(); 2],
            held_offset: Vec3::ZERO,
            balance: Vec3::ZERO,
            one_foot: None,
            model_root: None,
            root_leads: false,
            source_contacts: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &GroundingConfig {
        &self.config
    }

    /// The legs and torso found on the rig.
    pub fn body_parts(&self) -> &BodyParts {
        &self.parts
    }

    /// Forgets the seed, the floor and the locks (a new seed follows).
    pub fn reset(&mut self) {
        self.seed_points.clear();
        self.seed_last = None;
        self.floor = None;
        self.seat = None;
        self.last_root = None;
        self.feet = [FootState::default(); 2];
        self.held_offset = Vec3::ZERO;
        self.balance = Vec3::ZERO;
        self.one_foot = None;
        self.model_root = None;
    }

    /// Sets the lean limit ([`lean_limit_deg`]) and the hip-height hold
    /// ([`hip_floor_fraction`]) for `action` unless the configuration fixes them.
    pub fn set_action(&mut self, action: Option<&str>) {
        self.lean_limit = self
            .config
            .max_lean_deg
            .unwrap_or_else(|| lean_limit_deg(action));
        self.hip_fraction = self
            .config
            .min_hip_fraction
            .unwrap_or_else(|| hip_floor_fraction(action));
    }

    /// Whether the root leads the feet (off by default): a steered character's root goes where
    /// its goal sends it, so a held foot behind the body rolls onto its toes (as far as the heel
    /// rise allows) before it holds the body back; otherwise the body travels only as far as its
    /// flat held feet reach, the model's legs setting the pace. Kept across [`Self::reset`].
    pub fn set_root_leads(&mut self, leads: bool) {
        self.root_leads = leads;
    }

    /// The source's own foot contacts for the frames that follow (`None`, the default: found by
    /// the contact rule). A source that knows them (a motion-matching database plays real takes
    /// whose contacts were found before the root was steered) gives them here: the supporting
    /// foot is the one in contact, the source's height is kept (only a foot under the floor
    /// lifts the body: a run keeps its flight, a blend into a contact does not pull the body
    /// down), a foot is locked while the source says it is in contact and let go once the
    /// source's foot is 0.2 m away, and held feet never hold the body back (the source's root
    /// goes where it is steered) nor move it (no hip-height hold or balance over a lone foot).
    /// Kept across [`Self::reset`].
    pub fn set_source_contacts(&mut self, contacts: Option<[bool; 2]>) {
        self.source_contacts = contacts;
    }

    /// The lean limit in force (degrees).
    pub fn lean_limit(&self) -> f32 {
        self.lean_limit
    }

    /// The lowest root height the hip-height hold keeps (metres above the floor).
    pub fn min_hip_height(&self) -> f32 {
        self.hip_fraction * self.standing_height
    }

    /// The foot points of both legs: the floor fit's points per seed frame.
    fn foot_points_per_frame(&self) -> usize {
        self.parts.legs.iter().map(|l| l.foot_points.len()).sum()
    }

    /// Feeds one seed frame (root world position in metres, local rotations; joint 0's is the
    /// root's world rotation): its foot points join the floor fit ([`Floor::fit_frames`]).
    ///
    /// # Panics
    /// If `rotations` does not have one entry per joint.
    pub fn observe_seed(&mut self, root: Vec3, rotations: &[Quat]) {
        self.forward_kinematics(root, rotations);
        let per_frame = self.foot_points_per_frame();
        if self.seed_points.len() >= MAX_SEED_FRAMES * per_frame {
            self.seed_points.drain(..per_frame);
        }
        for leg in &self.parts.legs {
            self.seed_points
                .extend(leg.foot_points.iter().map(|&j| self.positions[j]));
        }
        let [left, right] = &self.parts.legs;
        self.seed_last = Some((
            root,
            [self.positions[left.ankle], self.positions[right.ankle]],
        ));
        self.floor = None;
    }

    /// The floor fitted on the seed frames seen so far (a level floor through the origin
    /// without any).
    pub fn floor(&mut self) -> Floor {
        if let Some(floor) = self.floor {
            return floor;
        }
        let floor = Floor::fit_frames(&self.seed_points, self.foot_points_per_frame())
            .unwrap_or_else(|| Floor::level_at(0.0));
        self.set_floor(floor);
        floor
    }

    /// The floor the grounding works on, once it has been fitted (after the seed and the first
    /// grounded frame): the seed's floor in the world the seed was given in (its height, slope,
    /// the rotation `level` that levels it and the `pivot` it turns about). Poses come out in
    /// the floor frame; `Floor::from_floor_frame` takes a position back into the seed's world.
    pub fn fitted_floor(&self) -> Option<Floor> {
        self.floor
    }

    /// Grounds on `floor` instead of the one fitted on the seed (a source that knows its floor:
    /// a motion-matching database continues a seed it has put on a level floor). Call it after
    /// the last [`Self::observe_seed`], which forgets it.
    pub fn set_floor(&mut self, floor: Floor) {
        self.floor = Some(floor);
        self.seat = self
            .seed_last
            .filter(|_| self.config.seats)
            .and_then(|(root, [a, b])| {
                let to_floor = |p| floor.to_floor_frame(p);
                seat::seat_of(
                    to_floor(root),
                    [to_floor(a), to_floor(b)],
                    self.standing_height,
                )
            });
    }

    /// The seat the seed left (floor frame, metres; its `y` the lowest the root goes while
    /// over it), if it ended seated or kneeling ([`seat`]).
    pub fn seat(&mut self) -> Option<Vec3> {
        self.floor();
        self.seat
    }

    /// How a seat moves a root at `root` (metres): up to the seat when it is lower, and back
    /// to where it was on the last frame while it rests on the seat (a seated body does not
    /// slide over its seat); zero off the seat or clear above it.
    fn seat_hold(&self, root: Vec3) -> Vec3 {
        let Some(y) = self
            .seat
            .and_then(|s| seat::height_under(s, root, self.standing_height))
        else {
            return Vec3::ZERO;
        };
        if root.y > y + seat::SEAT_CLEARANCE * self.standing_height {
            return Vec3::ZERO;
        }
        let slide = self
            .last_root
            .map_or(Vec3::ZERO, |p| Vec3::new(p.x - root.x, 0.0, p.z - root.z));
        slide + Vec3::Y * (y - root.y).max(0.0)
    }

    /// Which feet (in [`BodyParts::legs`] order) were in contact on the last grounded frame.
    pub fn contacts(&self) -> [bool; 2] {
        [self.feet[0].contact, self.feet[1].contact]
    }

    /// Moves a root pose into the floor frame only (the rigid part of grounding: seed frames that
    /// are written beside grounded ones).
    pub fn level(&mut self, root: &mut Vec3, root_rotation: &mut Quat) {
        if !self.config.enabled {
            return;
        }
        let floor = self.floor();
        (*root, *root_rotation) = floor.root_to_floor_frame(*root, *root_rotation);
    }

    /// Grounds one frame after the seed in place: `root` (world position of joint 0, metres) and
    /// `rotations` (local rotations, joint 0's the world one); `dt` seconds since the previous
    /// frame. Nothing changes when grounding is off.
    ///
    /// # Panics
    /// If `rotations` does not have one entry per joint.
    pub fn ground(&mut self, root: &mut Vec3, rotations: &mut [Quat], dt: f32) {
        if !self.config.enabled {
            return;
        }
        assert_eq!(
            rotations.len(),
            self.offsets.len(),
            "one rotation per joint"
        );
        if !(root.is_finite() && rotations.iter().all(|q| q.is_finite())) {
            return;
        }
        // 1. Floor frame, and where held feet have held the body back so far.
        self.level(root, &mut rotations[0]);
        let dt = if dt.is_finite() && dt > 0.0 {
            dt
        } else {
            1.0 / 25.0
        };
        // How fast the model's root moved over the floor into this frame (m/s).
        let model_speed = self.model_root.map_or(0.0, |p| {
            let d = *root - p;
            (d.x * d.x + d.z * d.z).sqrt() / dt
        });
        self.model_root = Some(*root);
        let carried = self.carried(dt);
        *root += carried;
        // 2. Lean.
        if let Some(top) = self.parts.torso_top {
            self.forward_kinematics(*root, rotations);
            let torso = self.positions[top] - self.positions[0];
            if torso.length_squared() > 0.0 {
                let lean = torso
                    .normalize()
                    .dot(Vec3::Y)
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees();
                let held = soft_limit(lean, self.lean_limit, LEAN_SOFTNESS_DEG);
                let axis = torso.cross(Vec3::Y);
                if held < lean && axis.length_squared() > 1e-12 {
                    let tilt = Quat::from_axis_angle(axis.normalize(), (lean - held).to_radians());
                    rotations[0] = (tilt * rotations[0]).normalize();
                }
            }
        }
        // 3. Height: the supporting foot's lowest point on the floor. It is the slower foot
        // (horizontally), or the lower one when both are slow enough for contact: a swinging
        // foot that dips is lifted over the floor in step 4 instead of holding the body.
        self.forward_kinematics(*root, rotations);
        let mut heights = [0.0f32; 2];
        let mut speeds = [0.0f32; 2];
        for side in 0..2 {
            let leg = &self.parts.legs[side];
            heights[side] = leg
                .foot_points
                .iter()
                .map(|&j| self.positions[j].y)
                .fold(f32::INFINITY, f32::min);
            let ankle = self.positions[leg.ankle];
            speeds[side] = self.feet[side].previous.map_or(0.0, |p| {
                let d = ankle - carried - p;
                (d.x * d.x + d.z * d.z).sqrt() / dt
            });
        }
        let slow = self.config.contact_speed_m_s;
        let lower = usize::from(heights[1] < heights[0]);
        let support = match self.source_contacts {
            Some([true, true]) => lower,
            Some([left, right]) if left || right => usize::from(right),
            Some(_) => lower,
            None if speeds[0] < slow && speeds[1] < slow => lower,
            None => usize::from(speeds[1] < speeds[0]),
        };
        // A source that gives its contacts stands on its own floor already: it is only lifted
        // out of it (a blend into a contact does not pull the body down to the landing foot).
        let own_height = self.source_contacts.is_some();
        let lift = if own_height {
            (-heights[0].min(heights[1])).max(0.0)
        } else {
            -heights[support]
        };
        root.y += lift;
        for p in &mut self.positions {
            p.y += lift;
        }
        // 4. Foot locking: locks taken or released (on the model's pose with its support foot
        // on the floor), the hip-height hold, the body held back (horizontally, for good: the
        // character travels as far as its held feet allow) where a held foot would be out of
        // reach, then the legs' IK; swing feet kept over the floor.
        for side in 0..2 {
            self.update_lock(side, dt, heights[side] + lift, speeds[side], carried);
        }
        if self.config.foot_locking {
            let back = self.held_back();
            self.held_offset += back;
            *root += back;
            for p in &mut self.positions {
                *p += back;
            }
        }
        // The seat the seed left, if any, holds the root up (before the hip-height hold, which
        // then has nothing left to raise).
        let seat_hold = self.seat_hold(*root);
        let seated = seat_hold.y;
        self.held_offset += Vec3::new(seat_hold.x, 0.0, seat_hold.z);
        *root += seat_hold;
        for p in &mut self.positions {
            *p += seat_hold;
        }
        let raise = if self.config.foot_locking && !own_height {
            self.hip_raise(root.y, model_speed, dt)
        } else {
            Vec3::ZERO
        };
        self.balance += Vec3::new(raise.x, 0.0, raise.z);
        *root += raise;
        for p in &mut self.positions {
            *p += raise;
        }
        for side in 0..2 {
            let (height, speed) = (heights[side] + lift + seated + raise.y, speeds[side]);
            self.place(side, rotations, height, speed, side == support, dt);
        }
        // 5. The placed legs' lowest point on the floor (a held foot a straight leg could not
        // bring down, or one pushed under the floor, moves the body instead).
        if self.config.foot_locking {
            self.forward_kinematics(*root, rotations);
            // Not through a seat: feet the legs could not bring down from it stay off the floor.
            let seat_floor = self
                .seat
                .and_then(|s| seat::height_under(s, *root, self.standing_height))
                .map_or(f32::NEG_INFINITY, |y| y.min(root.y));
            let mut lowest = root.y - (root.y - self.lowest_foot_point().y).max(seat_floor);
            if own_height {
                lowest = lowest.min(0.0);
            }
            root.y -= lowest;
            for (leg, state) in self.parts.legs.iter().zip(&mut self.feet) {
                let ankle = self.positions[leg.ankle] - Vec3::Y * lowest;
                state.drawn = Some((ankle, self.rotations[leg.ankle]));
            }
        }
        self.last_root = Some(*root);
    }

    /// World positions and rotations of every joint into the scratch.
    fn forward_kinematics(&mut self, root: Vec3, rotations: &[Quat]) {
        assert_eq!(
            rotations.len(),
            self.offsets.len(),
            "one rotation per joint"
        );
        for (j, &local) in rotations.iter().enumerate() {
            match self.parents[j] {
                None => {
                    self.rotations[j] = local;
                    self.positions[j] = root;
                }
                Some(p) => {
                    self.rotations[j] = self.rotations[p] * local;
                    self.positions[j] = self.positions[p] + self.rotations[p] * self.offsets[j];
                }
            }
        }
    }

    /// The lowest of both feet's points in the scratch positions.
    fn lowest_foot_point(&self) -> Vec3 {
        let mut lowest = Vec3::new(0.0, f32::INFINITY, 0.0);
        for leg in &self.parts.legs {
            for &j in &leg.foot_points {
                if self.positions[j].y < lowest.y {
                    lowest = self.positions[j];
                }
            }
        }
        lowest
    }
}

/// `x` below `limit - softness` unchanged, then compressed smoothly so it never passes `limit`.
fn soft_limit(x: f32, limit: f32, softness: f32) -> f32 {
    let knee = limit - softness;
    if x <= knee || softness <= 0.0 {
        x.min(limit)
    } else {
        knee + softness * ((x - knee) / softness).tanh()
    }
}

#[cfg(test)]
mod tests;
