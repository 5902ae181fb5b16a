//! A skinned glTF character in a headless Bevy app (no window, no renderer): the committed
//! mannequin (`assets/mannequin.glb`) loaded by Bevy's own glTF loader, a `MotionCharacter` with
//! `MotionSkinned` on its scene root, 240 ticks at 60 Hz. The mapped joints' `GlobalTransform`s
//! are checked against motion-core's `RigTarget` of the same file and the same poses, and for
//! what a game sees: feet on the floor, the hips at the rig's height, the joints moving, the
//! fingers at their rest rotation. The female mannequin of `../shared/assets/characters` (another
//! body: its own proportions and rest pose) must pass the same walking checks unchanged; without
//! the shared assets that test says it skipped.
use std::path::Path;
use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::WorldAssetRoot;
use motion_bevy::{
    MotionCharacter, MotionFailed, MotionPlugin, MotionPose, MotionRig, MotionSkinned,
};

fn assets_dir() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets")
        .to_string_lossy()
        .into_owned()
}

/// The shared characters (`../shared/assets/characters` beside the repository), if present.
fn shared_characters_dir() -> Option<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/assets/characters");
    dir.join(FEMALE)
        .is_file()
        .then(|| dir.to_string_lossy().into_owned())
}

const MALE: &str = "mannequin.glb";
const FEMALE: &str = "quaternius_mannequin_female.glb";

fn app() -> App {
    app_with_assets(assets_dir())
}

fn app_with_assets(dir: String) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: dir,
            ..default()
        },
        TransformPlugin,
        bevy::image::ImagePlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy::world_serialization::WorldSerializationPlugin,
        bevy::gltf::GltfPlugin::default(),
        MotionPlugin,
    ));
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    // The components a glTF scene holds, registered as the renderer's plugins would (a scene
    // spawns only reflected types).
    use bevy::camera::{primitives::Aabb, visibility};
    app.register_type::<visibility::Visibility>()
        .register_type::<visibility::InheritedVisibility>()
        .register_type::<visibility::ViewVisibility>()
        .register_type::<visibility::DynamicSkinnedMeshBounds>()
        .register_type::<visibility::NoFrustumCulling>()
        .register_type::<Aabb>()
        .register_type::<bevy::mesh::Mesh3d>()
        .register_type::<bevy::mesh::skinning::SkinnedMesh>()
        .register_type::<bevy::gltf::GltfMeshName>()
        .register_type::<bevy::gltf::GltfMaterialName>()
        .register_type::<bevy::gltf::GltfSceneName>()
        .register_type::<bevy::gltf::GltfExtras>()
        .register_type::<Name>()
        .register_type::<ChildOf>()
        .register_type::<Children>()
        .register_type::<Transform>()
        .register_type::<GlobalTransform>()
        .register_type::<bevy::transform::components::TransformTreeChanged>();
    // What `App::run` does before its first update: the glTF plugin registers its loader here.
    app.finish();
    app.cleanup();
    app
}

/// Spawns the mannequin with a walking character and runs until it has started.
fn spawn_walker(app: &mut App, map: Option<String>) -> Entity {
    spawn_character(app, MALE, map)
}

/// Spawns the glTF `file` (in the app's asset folder) with a walking character and runs until it
/// has started.
fn spawn_character(app: &mut App, file: &'static str, map: Option<String>) -> Entity {
    let scene: Handle<bevy::world_serialization::WorldAsset> = app
        .world()
        .resource::<AssetServer>()
        .load(GltfAssetLabel::Scene(0).from_asset(file));
    let entity = app
        .world_mut()
        .spawn((
            WorldAssetRoot(scene),
            MotionCharacter::new("walking", 3),
            MotionSkinned { joint_map: map },
            Transform::from_xyz(1.0, 0.0, -2.0),
        ))
        .id();
    for _ in 0..2000 {
        app.update();
        if app.world().get::<MotionRig>(entity).is_some()
            || app.world().get::<MotionFailed>(entity).is_some()
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    entity
}

fn joint(rig: &MotionRig, name: &str) -> Entity {
    let i = rig
        .names()
        .iter()
        .position(|n| n == name)
        .unwrap_or_else(|| panic!("{name}"));
    rig.joints()[i]
}

fn world_position(app: &App, e: Entity) -> Vec3 {
    app.world().get::<GlobalTransform>(e).unwrap().translation()
}

#[test]
fn the_mannequin_walks_on_the_floor_driven_by_its_own_joints() {
    walks_on_the_floor(app(), MALE);
}

#[test]
fn the_female_mannequin_walks_on_the_floor_unchanged() {
    let Some(dir) = shared_characters_dir() else {
        eprintln!("skipped: no ../shared/assets/characters/{FEMALE} beside the repository");
        return;
    };
    walks_on_the_floor(app_with_assets(dir), FEMALE);
}

/// A walking character on `file`: the scene's own joints driven, the feet on the floor, the hips
/// at the rig's own height, the hand swinging, the body travelling, the fingers at rest.
fn walks_on_the_floor(mut app: App, file: &'static str) {
    let walker = spawn_character(&mut app, file, None);
    if let Some(f) = app.world().get::<MotionFailed>(walker) {
        panic!("the character failed: {}", f.0);
    }
    let rig = app
        .world()
        .get::<MotionRig>(walker)
        .expect("started")
        .clone();
    // The plugin drives the scene's own joints: no joints of its own were spawned.
    assert!(
        rig.names().iter().any(|n| n == "pelvis") && rig.names().iter().any(|n| n == "thigh_l")
    );
    let feet = ["foot_l", "foot_r", "ball_l", "ball_r"].map(|n| joint(&rig, n));
    let (pelvis, hand, finger) = (
        joint(&rig, "pelvis"),
        joint(&rig, "hand_l"),
        joint(&rig, "index_01_l"),
    );
    let finger_rest = app.world().get::<Transform>(finger).unwrap().rotation;
    let rest_pelvis_height = world_position(&app, pelvis).y;
    let mut lowest = Vec::new();
    let mut hips = Vec::new();
    let mut hands = Vec::new();
    let mut travelled = Vec::new();
    for _ in 0..240 {
        app.update();
        let feet_y = feet.map(|f| world_position(&app, f).y);
        lowest.push(feet_y.iter().copied().fold(f32::INFINITY, f32::min));
        hips.push(world_position(&app, pelvis).y);
        hands.push(world_position(&app, hand));
        travelled.push(world_position(&app, pelvis));
        assert_eq!(
            app.world().get::<Transform>(finger).unwrap().rotation,
            finger_rest
        );
    }
    assert!(app.world().get::<MotionFailed>(walker).is_none());
    // Feet on the floor (the scene root's y = 0): the lowest foot joint within a few cm of it.
    lowest.sort_by(f32::total_cmp);
    let median = lowest[lowest.len() / 2];
    assert!(
        (-0.03..0.12).contains(&median),
        "{file}: lowest foot joint median {median} m"
    );
    // The hips at the rig's own height (its rest pelvis height, less a walking knee bend).
    let mean_hips = hips.iter().sum::<f32>() / hips.len() as f32;
    assert!(
        mean_hips > 0.85 * rest_pelvis_height && mean_hips < 1.05 * rest_pelvis_height,
        "{file}: hips {mean_hips} m against rest {rest_pelvis_height} m"
    );
    // Moving: the hand swings and the body walks.
    let swing = hands
        .iter()
        .map(|h| (*h - hands[0]).length())
        .fold(0.0, f32::max);
    let walked = (travelled[239] - travelled[0]).with_y(0.0).length();
    assert!(
        swing > 0.1 && walked > 0.5,
        "{file}: hand swing {swing} m, walked {walked} m in 4 s"
    );
}

#[test]
fn the_joints_match_motion_cores_rig_target_of_the_same_file() {
    use motion_core::rig_target::{RigPose, RigTarget};
    use motion_core::skeleton::Skeleton;
    let mut app = app();
    let walker = spawn_walker(&mut app, None);
    for _ in 0..30 {
        app.update();
    }
    let rig = app.world().get::<MotionRig>(walker).unwrap().clone();
    let pose = app.world().get::<MotionPose>(walker).unwrap().0.clone();
    let file = Path::new(&assets_dir()).join("mannequin.glb");
    let mut target = RigTarget::from_gltf(&file, None, &Skeleton::h36m()).unwrap();
    let mut out = RigPose::for_target(&target);
    // The pose the plugin hands the target: the pelvis in the ground frame, raised onto the floor.
    let mut source = pose.clone();
    source.local_rotations[0] = pose.root_motion.pelvis_rotation;
    source.root_translation = pose.root_motion.pelvis_offset;
    source.root_translation.y += rig.floor_offset();
    target.write(&source, &mut out);
    let mut checked = 0;
    for (j, rig_joint) in target.joints().iter().enumerate() {
        if !target.is_mapped(j) {
            continue;
        }
        let e = joint(&rig, &rig_joint.name);
        let got = app.world().get::<Transform>(e).unwrap().rotation;
        let want = Quat::from_array(out.local_rotations[j].to_array());
        assert!(
            got.dot(want).abs() > 1.0 - 1e-5,
            "{}: {got} against {want}",
            rig_joint.name
        );
        checked += 1;
    }
    assert!(checked >= 15, "{checked} mapped joints");
    let hips = joint(&rig, &target.joints()[target.hips()].name);
    let got = app.world().get::<Transform>(hips).unwrap().translation;
    let want = Vec3::from_array(out.hips_translation.to_array());
    assert!((got - want).length() < 1e-4, "hips {got} against {want}");
}

#[test]
fn a_joint_map_naming_missing_joints_fails_the_character_with_a_message() {
    let mut app = app();
    let walker = spawn_walker(&mut app, Some(r#"{"Hips": "no_such_joint"}"#.into()));
    let failed = app.world().get::<MotionFailed>(walker).expect("refused");
    assert!(failed.0.contains("no_such_joint"), "{}", failed.0);
    assert!(app.world().get::<MotionRig>(walker).is_none());
}
