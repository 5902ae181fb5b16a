//! The plugin in a headless Bevy app (no window, no renderer): 120 ticks at 60 Hz for two
//! characters, every joint's GlobalTransform checked against motion-core's own forward
//! kinematics of the same poses, and the poses against a motion-core `Crowd` of the same two
//! members (the plugin batches its characters of one model in a `Crowd`; a batch computes to
//! within float rounding of standalone `Character`s, and grounding's contact decisions can turn
//! that rounding into a different step, so the reference is batched the same way).
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use motion_bevy::{
    MotionCharacter, MotionFailed, MotionGoal, MotionModelSource, MotionPlugin, MotionPose,
    MotionRig, MotionSeed, MotionWeights,
};
use motion_core::formats::bvh::parse_bvh;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::GroundingConfig;
use motion_core::model::builtin::game_model;
use motion_core::model::{Crowd, MemberId};
use motion_core::pose::Pose;
use motion_core::seed::seed_from_bvh;

const WALK_SEED: &str = include_str!("../../../examples/walk_seed.bvh");

fn app(assets: &str) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: assets.into(),
            ..default()
        },
        TransformPlugin,
        MotionPlugin,
    ));
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    app
}

/// A motion-core `Crowd` of the built-in model with one grounded member per `(action, rng seed)`
/// after the example seed, in that order, as the plugin starts its characters.
fn reference_crowd(members: &[(&str, u64)]) -> (Crowd, Vec<MemberId>) {
    let model = Arc::new(game_model().expect("built-in weights").unwrap());
    let fps = model.config().fps;
    let bvh = parse_bvh(WALK_SEED, "walk_seed.bvh").unwrap();
    let seed = seed_from_bvh(
        bvh,
        Path::new("walk_seed.bvh"),
        ExpMapTarget::H36m,
        fps,
        None,
    )
    .unwrap();
    let mut crowd = Crowd::new(model).unwrap();
    let ids = members
        .iter()
        .map(|&(action, rng_seed)| {
            crowd
                .add(
                    seed.frames.view(),
                    Some(action),
                    rng_seed,
                    GroundingConfig::default(),
                )
                .unwrap()
        })
        .collect();
    (crowd, ids)
}

fn bevy_vec(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

fn same_pose(a: &Pose, b: &Pose, tol: f32) -> bool {
    (a.root_translation - b.root_translation).length() < tol
        && a.local_rotations
            .iter()
            .zip(&b.local_rotations)
            .all(|(p, q)| p.dot(*q).abs() > 1.0 - tol)
}

#[test]
fn two_characters_for_120_ticks_match_forward_kinematics() {
    let mut app = app("assets");
    let origin_a = Transform::from_xyz(1.0, 0.0, 2.0).with_rotation(Quat::from_rotation_y(0.5));
    let a = app
        .world_mut()
        .spawn((MotionCharacter::new("walking", 3), origin_a))
        .id();
    let b = app
        .world_mut()
        .spawn((MotionCharacter::new("eating", 9), Transform::default()))
        .id();
    let (mut crowd, ids) = reference_crowd(&[("walking", 3), ("eating", 9)]);
    let reference = [(a, ids[0]), (b, ids[1])];
    let skeleton = crowd.skeleton().clone();
    let n = skeleton.len();
    let (mut positions, mut world) = (vec![Default::default(); n], vec![Default::default(); n]);
    let start_a = origin_a.translation;
    for tick in 0..120 {
        if tick == 60 {
            let mut c = app.world_mut().get_mut::<MotionCharacter>(a).unwrap();
            c.action = "sitting".into();
            crowd.set_action(ids[0], "sitting").unwrap();
        }
        app.update();
        let dt = app.world().resource::<Time>().delta_secs_f64();
        crowd.advance(dt).unwrap();
        for &(entity, id) in &reference {
            let expected = crowd.pose(id).unwrap().clone();
            let world_ref = app.world();
            assert!(world_ref.get::<MotionFailed>(entity).is_none());
            let pose = &world_ref.get::<MotionPose>(entity).expect("started").0;
            assert!(
                same_pose(pose, &expected, 1e-3),
                "tick {tick}: the plugin's pose left the reference crowd's"
            );
            // Bevy's propagated GlobalTransforms against motion-core's forward kinematics.
            let rig = world_ref.get::<MotionRig>(entity).unwrap();
            let origin = rig.origin();
            pose.world_positions_into(&skeleton, &mut positions, &mut world);
            for (j, &joint) in rig.joints().iter().enumerate() {
                let global = world_ref.get::<GlobalTransform>(joint).unwrap();
                let lifted = bevy_vec(positions[j].to_array()) + Vec3::Y * rig.floor_offset();
                let want = origin.transform_point(lifted);
                let got = global.translation();
                assert!(
                    got.distance(want) < 1e-3,
                    "tick {tick}, joint {j} ({}): {got} vs FK {want}",
                    rig.names()[j]
                );
                let want_rot = origin.rotation * Quat::from_array(world[j].to_array());
                assert!(
                    global.rotation().dot(want_rot).abs() > 1.0 - 1e-4,
                    "joint {j} rotation"
                );
            }
        }
    }
    // Grounded, the first pose already stands on the floor (nothing to raise); root motion moved
    // the walker's entity away.
    let floor = app.world().get::<MotionRig>(a).unwrap().floor_offset();
    assert!(floor.is_finite() && floor.abs() < 0.01, "raised {floor} m");
    let root_a = app.world().get::<Transform>(a).unwrap().translation;
    assert!(root_a.distance(start_a) > 0.3, "{root_a} from {start_a}");
}

#[test]
fn bad_characters_are_reported_not_panicked_and_others_go_on() {
    let fixtures = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fixtures/parity");
    let mut app = app(fixtures);
    let unknown = app
        .world_mut()
        .spawn(MotionCharacter::new("flying", 1))
        .id();
    let missing = {
        let handle = app
            .world()
            .resource::<AssetServer>()
            .load::<MotionWeights>("missing.safetensors");
        let mut c = MotionCharacter::new("walking", 1);
        c.model = MotionModelSource::Asset(handle);
        app.world_mut().spawn(c).id()
    };
    let from_file = {
        let handle = app
            .world()
            .resource::<AssetServer>()
            .load::<MotionWeights>("vgru_d.safetensors");
        let mut c = MotionCharacter::new("walking", 2);
        c.model = MotionModelSource::Asset(handle);
        app.world_mut().spawn(c).id()
    };
    let short = {
        let mut c = MotionCharacter::new("walking", 1);
        let text = WALK_SEED.replace("Frames: 75", "Frames: 3");
        let cut: Vec<&str> = text.lines().collect();
        let end = cut
            .iter()
            .position(|l| l.starts_with("Frame Time"))
            .unwrap()
            + 4;
        c.seed = MotionSeed::from_bvh_text(&cut[..end].join("\n"), "short.bvh").unwrap();
        app.world_mut().spawn(c).id()
    };
    let walker = app
        .world_mut()
        .spawn(MotionCharacter::new("walking", 5))
        .id();
    // Assets load on other threads: give them real time.
    for _ in 0..400 {
        app.update();
        let w = app.world();
        if w.get::<MotionFailed>(missing).is_some() && w.get::<MotionRig>(from_file).is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let failure = |app: &App, e: Entity| app.world().get::<MotionFailed>(e).map(|f| f.0.clone());
    assert!(failure(&app, unknown).unwrap().contains("flying"));
    assert!(
        failure(&app, missing)
            .unwrap()
            .contains("missing.safetensors"),
        "{:?}",
        failure(&app, missing)
    );
    assert!(
        failure(&app, short).unwrap().contains("short.bvh"),
        "{:?}",
        failure(&app, short)
    );
    assert!(
        failure(&app, from_file).is_none(),
        "{:?}",
        failure(&app, from_file)
    );
    assert!(
        app.world().get::<MotionRig>(from_file).is_some(),
        "the weights asset loaded"
    );
    // An unknown action at run time is reported; the character carries on.
    app.world_mut()
        .get_mut::<MotionCharacter>(walker)
        .unwrap()
        .action = "juggling".into();
    app.update();
    assert!(failure(&app, walker).unwrap().contains("juggling"));
    // A despawned character leaves its batch; the others go on.
    app.world_mut().despawn(from_file);
    let before = app
        .world()
        .get::<MotionPose>(walker)
        .unwrap()
        .0
        .root_translation;
    for _ in 0..30 {
        app.update();
    }
    let after = &app.world().get::<MotionPose>(walker).unwrap().0;
    assert!(after.local_rotations.iter().all(|q| q.is_finite()));
    assert!(after.root_translation != before);
}

#[test]
fn a_goal_in_world_axes_steers_the_character_that_way() {
    let mut app = app("assets");
    // Spawned turned by 0.5 rad: the goal is in world axes all the same (the heading turns at a
    // bounded rate, so the path curves in).
    let origin = Transform::from_xyz(0.0, 0.0, 0.0).with_rotation(Quat::from_rotation_y(0.5));
    let mut character = MotionCharacter::new("walking", 3);
    character.goal = Some(MotionGoal::towards(Vec2::new(0.5, 0.0)));
    let a = app.world_mut().spawn((character, origin)).id();
    // The first update places the character where its seed ends (the seed walks the spawn
    // heading); steering shows in the motion from there.
    app.update();
    let start = app.world().get::<Transform>(a).unwrap().translation;
    for _ in 0..240 {
        app.update();
        assert!(app.world().get::<MotionFailed>(a).is_none());
    }
    let moved = app.world().get::<Transform>(a).unwrap().translation - start;
    assert!(
        moved.x > 0.5 && moved.z.abs() < 0.5 * moved.x,
        "steered toward +x, moved {moved}"
    );
}

/// The shipped motion-matching database as a weights asset: the character starts from the
/// example seed (retargeted onto the database's CMU rig), its rig has that rig's joints, and a
/// goal sends it along +x on the floor.
#[test]
fn a_database_asset_drives_a_character_on_its_own_rig() {
    let weights = concat!(env!("CARGO_MANIFEST_DIR"), "/../../weights");
    let mut app = app(weights);
    let handle = app
        .world()
        .resource::<AssetServer>()
        .load::<MotionWeights>("matching_cmu.safetensors");
    let mut c = MotionCharacter::new("walking", 1);
    c.model = MotionModelSource::Asset(handle);
    c.goal = Some(MotionGoal::towards(Vec2::new(1.2, 0.0)));
    let walker = app.world_mut().spawn(c).id();
    for _ in 0..400 {
        app.update();
        let w = app.world();
        if w.get::<MotionRig>(walker).is_some() || w.get::<MotionFailed>(walker).is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let failed = app.world().get::<MotionFailed>(walker).map(|f| f.0.clone());
    assert!(failed.is_none(), "{failed:?}");
    let rig = app.world().get::<MotionRig>(walker).expect("started");
    let joints = rig.joints().len();
    assert!(
        joints > 15 && joints != 32,
        "{joints} joints: the database's rig"
    );
    let start = app
        .world()
        .get::<MotionPose>(walker)
        .unwrap()
        .0
        .root_translation;
    for _ in 0..240 {
        app.update();
    }
    let end = app
        .world()
        .get::<MotionPose>(walker)
        .unwrap()
        .0
        .root_translation;
    let moved = end - start;
    assert!(moved.x > 2.0 && moved.z.abs() < 1.5, "{moved:?}");
    assert!((0.6..1.2).contains(&end.y), "hips at {} m", end.y);
}
