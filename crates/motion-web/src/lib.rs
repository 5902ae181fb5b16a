//! motion-core in a web page: the built-in model, or the shipped motion-matching database,
//! driving a character from JavaScript.
//!
//! Built for `wasm32-unknown-unknown` thread-free (motion-core without its `parallel` feature:
//! no rayon, one thread, the portable kernels) and bound by `wasm-bindgen`; `web/` is the page
//! that uses it (three.js skeleton, action selector, live at the display's frame rate).
//!
//! ```js
//! import init, { WebCharacter } from "./pkg/motion_web.js";
//! await init();
//! const character = WebCharacter.walk("walking", 1n); // the bundled walk seed, rng seed 1
//! character.advance(1 / 60);                        // the clock moves 1/60 s
//! const xyz = character.positions();                // Float32Array, 3 per joint, metres
//! character.set_action("eating");                   // from the next model frame on
//! const matched = WebCharacter.walk_matching();      // the CMU motion-matching database
//! ```
//!
//! Conventions are motion-core's engine ones ([`motion_core::pose`]): metres, +y up,
//! right-handed; joints in the model skeleton's order, [`WebCharacter::parents`] gives the
//! bones. [`Animator`] is the same character without the JavaScript binding (tested natively).
use std::path::Path;
use std::sync::Arc;

use glam::{Quat, Vec3};
use motion_core::formats::bvh::parse_bvh;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::matching::MatchingDatabase;
use motion_core::model::batch::Noise;
use motion_core::model::builtin::game_model;
use motion_core::model::{Character, MotionModel};
use motion_core::pose::Pose;
use motion_core::rig_target::{RigJoint, RigPose, RigTarget};
use motion_core::seed::seed_from_bvh;
use motion_core::takes::seed_poses_on_rig;
use motion_core::weights::WeightStore;
use motion_core::Skeleton;
use wasm_bindgen::prelude::*;

/// The walk seed shipped with the crate (`examples/walk_seed.bvh`, made by
/// `examples/make_seed.rs`), built into the module so the page needs no file.
pub const WALK_SEED_BVH: &str = include_str!("../../../examples/walk_seed.bvh");

thread_local! {
    /// The built-in model, parsed once per thread (a page has one) and shared by its characters.
    static MODEL: Result<Arc<MotionModel>, String> = match game_model() {
        Some(Ok(model)) => Ok(Arc::new(model)),
        Some(Err(e)) => Err(e.to_string()),
        None => Err("this build has no built-in weights (weights/ was empty at build time)".into()),
    };
}

/// The shipped motion-matching database (`weights/matching_cmu.safetensors`: CMU takes, free for
/// products), built into the module.
pub const MATCHING_DATABASE: &[u8] = include_bytes!("../../../weights/matching_cmu.safetensors");

thread_local! {
    /// The built-in database, parsed once per thread and shared by its characters.
    static DATABASE: Result<Arc<MatchingDatabase>, String> =
        WeightStore::from_bytes(MATCHING_DATABASE, "matching_cmu.safetensors")
            .map_err(|e| e.to_string())
            .and_then(|store| MatchingDatabase::from_store(&store).map_err(|e| e.to_string()))
            .map(Arc::new);
}

/// The built-in motion-matching database (shared).
pub fn builtin_database() -> Result<Arc<MatchingDatabase>, String> {
    DATABASE.with(Clone::clone)
}

/// The built-in model (shared).
pub fn builtin_model() -> Result<Arc<MotionModel>, String> {
    MODEL.with(Clone::clone)
}

/// One character: a [`Character`] on the built-in model and its joint positions, with every
/// buffer allocated once.
#[derive(Debug)]
pub struct Animator {
    character: Character,
    skeleton: Arc<Skeleton>,
    action: String,
    positions: Vec<Vec3>,
    world: Vec<Quat>,
    flat: Vec<f32>,
    poses: u64,
    floor: f32,
    rig: Option<Box<SkinnedRig>>,
}

/// A skinned character's rig (a three.js skeleton, or any joint arrays) and its buffers.
#[derive(Debug)]
struct SkinnedRig {
    target: RigTarget,
    out: RigPose,
    /// The character's pose raised onto the floor (what the target reads).
    scratch: Pose,
    /// Per joint `x, y, z, w`, then the hips' translation.
    flat: Vec<f32>,
}

impl Animator {
    /// A character seeded from the BVH text `bvh` (`label` names it in errors; any rig and
    /// rate [`motion_core::seed`] accepts), doing `action`, with noise from `rng_seed`.
    pub fn from_bvh(bvh: &str, label: &str, action: &str, rng_seed: u64) -> Result<Self, String> {
        let model = builtin_model()?;
        let fps = model.config().fps;
        let label = Path::new(label);
        let parsed = parse_bvh(bvh, label).map_err(|e| e.to_string())?;
        let seed = seed_from_bvh(parsed, label, ExpMapTarget::H36m, fps, None)
            .map_err(|e| e.to_string())?;
        let mut character = Character::new(model).map_err(|e| e.to_string())?;
        character
            .start_from_clip(seed.frames.view(), Some(action), Noise::Seed(rng_seed))
            .map_err(|e| e.to_string())?;
        Self::around(character, action)
    }

    /// A character of the built-in motion-matching database seeded from the BVH text `bvh` (any
    /// rig the built-in maps fit, retargeted onto the database's CMU rig): it plays on that rig
    /// and has no actions.
    pub fn from_bvh_matching(bvh: &str, label: &str) -> Result<Self, String> {
        let db = builtin_database()?;
        let path = Path::new(label);
        let parsed = parse_bvh(bvh, path).map_err(|e| e.to_string())?;
        let seed = seed_poses_on_rig(parsed, db.skeleton(), db.mm_per_unit(), db.fps(), None)
            .map_err(|e| format!("{label}: {e}"))?;
        let mut character = Character::new(db).map_err(|e| e.to_string())?;
        character
            .start_poses(&seed)
            .map_err(|e| format!("{label}: {e}"))?;
        Self::around(character, "motion matching")
    }

    /// The animator of a started character.
    fn around(character: Character, action: &str) -> Result<Self, String> {
        let skeleton = Arc::clone(character.skeleton());
        let joints = skeleton.len();
        let mut animator = Animator {
            character,
            skeleton,
            action: action.to_owned(),
            positions: vec![Vec3::ZERO; joints],
            world: vec![Quat::IDENTITY; joints],
            flat: vec![0.0; 3 * joints],
            poses: 0,
            floor: 0.0,
            rig: None,
        };
        let first = animator.character.advance(0.0).map_err(|e| e.to_string())?;
        animator.floor = first.floor_offset(&animator.skeleton);
        animator.advance(0.0)?;
        animator.poses = 0;
        Ok(animator)
    }

    /// Whether the motion-matching database drives it.
    pub fn is_database(&self) -> bool {
        self.character.is_database()
    }

    /// The actions the built-in model knows.
    pub fn actions() -> Result<Vec<String>, String> {
        Ok(builtin_model()?.config().actions.clone())
    }

    /// Moves the clock `dt` seconds (any rate) and computes the joint positions there.
    pub fn advance(&mut self, dt: f64) -> Result<(), String> {
        let pose = self.character.advance(dt).map_err(|e| e.to_string())?;
        pose.world_positions_into(&self.skeleton, &mut self.positions, &mut self.world);
        for (dst, p) in self.flat.chunks_exact_mut(3).zip(&self.positions) {
            dst.copy_from_slice(&p.to_array());
        }
        if let Some(rig) = self.rig.as_deref_mut() {
            rig.scratch.clone_from(pose);
            rig.scratch.root_translation.y += self.floor;
            rig.target.write(&rig.scratch, &mut rig.out);
            let n = rig.out.local_rotations.len();
            for (dst, q) in rig.flat.chunks_exact_mut(4).zip(&rig.out.local_rotations) {
                dst.copy_from_slice(&q.to_array());
            }
            rig.flat[4 * n..].copy_from_slice(&rig.out.hips_translation.to_array());
        }
        self.poses += 1;
        Ok(())
    }

    /// Drives a skinned character's own skeleton from now on: its joints in parents-first order
    /// (joint 0 the rig's root, whose space is the character's world: +y up, metres, the floor at
    /// `y = 0`), each with a name, a parent (-1 for the root), a rest rotation `x, y, z, w` and a
    /// rest translation (metres) in `rest` (7 values per joint), mapped by the built-in joint maps
    /// (`motion_core::rig_target`). Returns the hips joint (the one whose translation moves).
    pub fn attach_rig(
        &mut self,
        names: Vec<String>,
        parents: &[i32],
        rest: &[f32],
    ) -> Result<usize, String> {
        let n = names.len();
        if rest.len() != 7 * n {
            return Err(format!(
                "{n} joints need 7 rest values each ({}), got {}",
                7 * n,
                rest.len()
            ));
        }
        let (mut rotations, mut translations) =
            (Vec::with_capacity(4 * n), Vec::with_capacity(3 * n));
        for joint in rest.chunks_exact(7) {
            rotations.extend_from_slice(&joint[..4]);
            translations.extend_from_slice(&joint[4..]);
        }
        let parents: Vec<i64> = parents.iter().map(|&p| i64::from(p)).collect();
        let joints = RigJoint::from_arrays(names, &parents, &rotations, &translations)
            .map_err(|e| e.to_string())?;
        let target =
            RigTarget::from_joints(joints, None, &self.skeleton).map_err(|e| e.to_string())?;
        let hips = target.hips();
        let out = RigPose::for_target(&target);
        self.rig = Some(Box::new(SkinnedRig {
            scratch: Pose::rest(self.skeleton.len()),
            flat: vec![0.0; 4 * n + 3],
            target,
            out,
        }));
        self.advance(0.0)?;
        self.poses -= 1;
        Ok(hips)
    }

    /// The attached rig's pose at the last [`advance`](Self::advance): each joint's local rotation
    /// `x, y, z, w` (unmapped joints: their rest rotation), then the hips' local translation
    /// (metres, in the parent space of the hips); empty without a rig.
    pub fn rig_pose(&self) -> &[f32] {
        self.rig.as_deref().map_or(&[], |r| &r.flat)
    }

    /// The attached rig's mapped joints (`true` where the motion drives the joint).
    pub fn rig_mapped(&self) -> Vec<bool> {
        self.rig.as_deref().map_or_else(Vec::new, |r| {
            (0..r.target.joints().len())
                .map(|j| r.target.is_mapped(j))
                .collect()
        })
    }

    /// Joint world positions of the last pose, `x, y, z` per joint, metres.
    pub fn positions(&self) -> &[f32] {
        &self.flat
    }

    /// Poses computed by [`advance`](Self::advance) since the start.
    pub fn poses(&self) -> u64 {
        self.poses
    }

    /// Each joint's parent index, -1 for the root.
    pub fn parents(&self) -> Vec<i32> {
        self.skeleton
            .joints()
            .iter()
            .map(|j| j.parent.map_or(-1, |p| p as i32))
            .collect()
    }

    /// How far to raise the first pose (metres) so its lowest joint is on the floor.
    pub fn floor_offset(&self) -> f32 {
        self.floor
    }

    /// The current action.
    pub fn action(&self) -> &str {
        &self.action
    }

    /// Switches the action from the next model frame on (refused for the database, which has
    /// no actions).
    pub fn set_action(&mut self, action: &str) -> Result<(), String> {
        if self.is_database() {
            return Err(format!(
                "{action}: the motion-matching database has no actions (it plays its takes)"
            ));
        }
        self.character
            .set_action(action, 0)
            .map_err(|e| e.to_string())?;
        self.action = action.to_owned();
        Ok(())
    }

    /// Steers toward a velocity on the floor (`vx`, `vz` m/s) and a facing (yaw about +y, 0 =
    /// +z) from the next model frame on ([`motion_core::steering`]); non-finite values are
    /// refused.
    pub fn set_goal(&mut self, vx: f32, vz: f32, facing: f32) -> Result<(), String> {
        if !(vx.is_finite() && vz.is_finite() && facing.is_finite()) {
            return Err(format!(
                "goal ({vx}, {vz}) facing {facing}: values must be finite"
            ));
        }
        self.character.set_goal(Some(motion_core::steering::Goal {
            velocity: motion_core::steering::Vec2::new(vx, vz),
            facing,
        }));
        Ok(())
    }

    /// Drops the goal: the model's own root motion.
    pub fn clear_goal(&mut self) {
        self.character.set_goal(None);
    }

    /// Runs `n` model steps directly (no pose, no resampling): what a benchmark times. The
    /// database's character plays `n` of its frames (searches, blends and grounding included).
    pub fn step_model(&mut self, n: u32) -> Result<(), String> {
        if self.is_database() {
            let dt = 1.0 / self.character.source_fps();
            for _ in 0..n {
                self.character.advance(dt).map_err(|e| e.to_string())?;
            }
            return Ok(());
        }
        for _ in 0..n {
            self.character
                .generator_mut()
                .ok_or("a motion-matching database has no model steps")?
                .step()
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

/// A character for JavaScript ([`Animator`] behind `wasm-bindgen`); errors are thrown as
/// `Error`s with motion-core's message.
#[wasm_bindgen]
pub struct WebCharacter {
    inner: Animator,
}

fn js(e: String) -> JsError {
    JsError::new(&e)
}

#[wasm_bindgen]
impl WebCharacter {
    /// A character seeded from the bundled walk seed.
    pub fn walk(action: &str, rng_seed: u64) -> Result<WebCharacter, JsError> {
        Self::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", action, rng_seed)
    }

    /// A character seeded from BVH text (a file the user picked: the model's skeleton or a
    /// CMU, Mixamo or Unreal rig, any units and rate).
    pub fn from_bvh(
        bvh: &str,
        label: &str,
        action: &str,
        rng_seed: u64,
    ) -> Result<WebCharacter, JsError> {
        Ok(WebCharacter {
            inner: Animator::from_bvh(bvh, label, action, rng_seed).map_err(js)?,
        })
    }

    /// A character of the built-in motion-matching database (CMU takes on their own rig, free
    /// for products) seeded from the bundled walk seed, retargeted onto its rig.
    pub fn walk_matching() -> Result<WebCharacter, JsError> {
        Self::from_bvh_matching(WALK_SEED_BVH, "walk_seed.bvh")
    }

    /// A character of the built-in motion-matching database seeded from BVH text (any rig the
    /// built-in maps fit).
    pub fn from_bvh_matching(bvh: &str, label: &str) -> Result<WebCharacter, JsError> {
        Ok(WebCharacter {
            inner: Animator::from_bvh_matching(bvh, label).map_err(js)?,
        })
    }

    /// Whether the motion-matching database drives it.
    pub fn is_database(&self) -> bool {
        self.inner.is_database()
    }

    /// The actions of the built-in model.
    pub fn actions() -> Result<Vec<String>, JsError> {
        Animator::actions().map_err(js)
    }

    /// Moves the character's clock by `dt` seconds and poses it there.
    pub fn advance(&mut self, dt: f64) -> Result<(), JsError> {
        self.inner.advance(dt).map_err(js)
    }

    /// Joint world positions (a copy): `x, y, z` per joint, metres, +y up.
    pub fn positions(&self) -> Vec<f32> {
        self.inner.positions().to_vec()
    }

    /// Each joint's parent (-1 for the root).
    pub fn parents(&self) -> Vec<i32> {
        self.inner.parents()
    }

    /// Poses computed since the start.
    pub fn poses(&self) -> f64 {
        self.inner.poses() as f64
    }

    /// How far to raise the character (metres) so that its first pose stands on the floor.
    pub fn floor_offset(&self) -> f32 {
        self.inner.floor_offset()
    }

    /// The current action.
    pub fn action(&self) -> String {
        self.inner.action().to_owned()
    }

    /// Switches the action.
    pub fn set_action(&mut self, action: &str) -> Result<(), JsError> {
        self.inner.set_action(action).map_err(js)
    }

    /// Steers toward a velocity on the floor (`vx`, `vz` m/s, world axes) and a facing (yaw in
    /// radians about +y, 0 = +z, pi/2 = +x): a keyboard or gamepad controller calls it every
    /// frame.
    pub fn set_goal(&mut self, vx: f32, vz: f32, facing: f32) -> Result<(), JsError> {
        self.inner.set_goal(vx, vz, facing).map_err(js)
    }

    /// Drops the goal: the model's own root motion.
    pub fn clear_goal(&mut self) {
        self.inner.clear_goal();
    }

    /// Runs `n` model steps (for timing one step in the page).
    pub fn step_model(&mut self, n: u32) -> Result<(), JsError> {
        self.inner.step_model(n).map_err(js)
    }

    /// Drives a skinned character's skeleton (a three.js `Skeleton`'s bones, any rig the
    /// built-in maps fit) from now on: names, parents (-1 for the root) and 7 rest values per
    /// joint (rotation `x, y, z, w`, translation in metres), parents first, joint 0 the root in
    /// the character's world. Returns the hips joint.
    pub fn attach_rig(
        &mut self,
        names: Vec<String>,
        parents: Vec<i32>,
        rest: Vec<f32>,
    ) -> Result<u32, JsError> {
        self.inner
            .attach_rig(names, &parents, &rest)
            .map(|h| h as u32)
            .map_err(js)
    }

    /// The rig's pose (a copy): 4 values per joint (its local rotation `x, y, z, w`), then the
    /// hips' local translation (3, metres); empty without a rig.
    pub fn rig_pose(&self) -> Vec<f32> {
        self.inner.rig_pose().to_vec()
    }

    /// Which of the rig's joints the motion drives.
    pub fn rig_mapped(&self) -> Vec<u8> {
        self.inner.rig_mapped().into_iter().map(u8::from).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walks_from_the_bundled_seed_and_switches_action() {
        let mut a = Animator::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", "walking", 1).unwrap();
        let joints = a.parents().len();
        assert_eq!(a.positions().len(), 3 * joints);
        assert_eq!(a.parents()[0], -1);
        let start = Vec3::from_slice(&a.positions()[..3]);
        for i in 0..240 {
            if i == 120 {
                a.set_action("sitting").unwrap();
            }
            a.advance(1.0 / 60.0).unwrap();
            assert!(a.positions().iter().all(|v| v.is_finite()));
        }
        assert_eq!(a.poses(), 240);
        assert_eq!(a.action(), "sitting");
        // Four seconds of walking then sitting moved the root.
        let end = Vec3::from_slice(&a.positions()[..3]);
        assert!((end - start).length() > 0.1, "{start} -> {end}");
        // Bones keep their lengths (forward kinematics of rotations only).
        let p = |j: usize| Vec3::from_slice(&a.positions()[3 * j..3 * j + 3]);
        let q = Animator::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", "walking", 1).unwrap();
        let p0 = |j: usize| Vec3::from_slice(&q.positions()[3 * j..3 * j + 3]);
        for (j, &parent) in a.parents().iter().enumerate().skip(1) {
            let parent = parent as usize;
            let (now, then) = ((p(j) - p(parent)).length(), (p0(j) - p0(parent)).length());
            assert!((now - then).abs() < 1e-4, "bone {j}: {now} vs {then}");
        }
    }

    #[test]
    fn the_database_walks_where_it_is_steered_on_its_own_rig() {
        let mut a = Animator::from_bvh_matching(WALK_SEED_BVH, "walk_seed.bvh").unwrap();
        assert!(a.is_database());
        let joints = a.parents().len();
        assert!(joints > 15 && joints != 32, "{joints} joints");
        assert!(a.set_action("sitting").is_err());
        let start = Vec3::from_slice(&a.positions()[..3]);
        a.set_goal(1.2, 0.0, std::f32::consts::FRAC_PI_2).unwrap();
        for _ in 0..240 {
            a.advance(1.0 / 60.0).unwrap();
            assert!(a.positions().iter().all(|v| v.is_finite()));
        }
        let end = Vec3::from_slice(&a.positions()[..3]);
        assert!(end.x - start.x > 2.5, "{start} -> {end}");
        a.step_model(30).unwrap();
        let e = Animator::from_bvh_matching("HIERARCHY\nROOT", "bad.bvh").unwrap_err();
        assert!(e.contains("bad.bvh"), "{e}");
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let e = Animator::from_bvh("HIERARCHY\nROOT", "bad.bvh", "walking", 1).unwrap_err();
        assert!(e.contains("bad.bvh"), "{e}");
        let e = Animator::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", "flying", 1).unwrap_err();
        assert!(e.contains("flying"), "{e}");
        let mut a = Animator::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", "walking", 1).unwrap();
        assert!(a.set_action("flying").is_err());
        assert!(a.advance(-1.0).is_err());
        assert!(Animator::actions()
            .unwrap()
            .contains(&"walking".to_string()));
    }

    /// The mannequin's skin as the page hands it over (names, parents, 7 rest values each).
    fn mannequin() -> (Vec<String>, Vec<i32>, Vec<f32>) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/mannequin.glb");
        let joints = motion_core::rig_target::read_gltf_joints(&path).unwrap();
        let names = joints.iter().map(|j| j.name.clone()).collect();
        let parents = joints
            .iter()
            .map(|j| j.parent.map_or(-1, |p| p as i32))
            .collect();
        let rest = joints
            .iter()
            .flat_map(|j| {
                let (q, t) = (j.rest_rotation.to_array(), j.rest_translation.to_array());
                [q[0], q[1], q[2], q[3], t[0], t[1], t[2]]
            })
            .collect();
        (names, parents, rest)
    }

    #[test]
    fn a_skinned_rig_follows_the_character_and_matches_the_rig_target() {
        let mut a = Animator::from_bvh(WALK_SEED_BVH, "walk_seed.bvh", "walking", 1).unwrap();
        assert!(a.rig_pose().is_empty());
        let (names, parents, rest) = mannequin();
        let n = names.len();
        let hips = a.attach_rig(names.clone(), &parents, &rest).unwrap();
        assert_eq!(names[hips], "pelvis");
        assert_eq!(a.rig_pose().len(), 4 * n + 3);
        let mapped = a.rig_mapped();
        assert!(mapped.iter().filter(|&&m| m).count() >= 15);
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/mannequin.glb");
        let mut target = RigTarget::from_gltf(&path, None, &a.skeleton).unwrap();
        let mut out = RigPose::for_target(&target);
        let first_hips = Vec3::from_slice(&a.rig_pose()[4 * n..]);
        for _ in 0..120 {
            a.advance(1.0 / 60.0).unwrap();
        }
        // The same pose through motion-core's target read from the file directly.
        let mut pose = a.character.current().clone();
        pose.root_translation.y += a.floor_offset();
        target.write(&pose, &mut out);
        for j in 0..n {
            let got = Quat::from_slice(&a.rig_pose()[4 * j..4 * j + 4]);
            assert!(
                got.dot(out.local_rotations[j]).abs() > 1.0 - 1e-6,
                "joint {j}"
            );
        }
        let hips_now = Vec3::from_slice(&a.rig_pose()[4 * n..]);
        assert!((hips_now - out.hips_translation).length() < 1e-5);
        // The hips in the rig's world (their parent, the skin's root, at its rest pose): walked
        // on, at a standing height.
        let root = mannequin().2;
        let (q, t) = (Quat::from_slice(&root[..4]), Vec3::from_slice(&root[4..7]));
        assert_eq!(parents[hips], 0);
        let (from, to) = (q * first_hips + t, q * hips_now + t);
        assert!(
            (to - from).with_y(0.0).length() > 0.2,
            "walked {from} -> {to}"
        );
        assert!(to.y > 0.7 && to.y < 1.1, "hips at {} m", to.y);
        // Bad arrays are errors.
        let e = a
            .attach_rig(names.clone(), &parents, &rest[1..])
            .unwrap_err();
        assert!(e.contains("7 rest values"), "{e}");
        let mut bad = parents.clone();
        bad[3] = -2;
        let e = a.attach_rig(names, &bad, &rest).unwrap_err();
        assert!(e.contains("parent -2"), "{e}");
    }
}
