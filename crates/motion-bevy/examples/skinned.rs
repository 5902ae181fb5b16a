//! A skinned glTF humanoid (the committed CC0 mannequin, `assets/mannequin.glb`) driven by the
//! built-in model: `MotionSkinned` beside a `MotionCharacter` on the spawned scene makes the plugin
//! find the scene's joints by name, map them (the Unreal-style names fit a built-in map) and write
//! their transforms every frame. Steer with the arrow keys or WASD; 1-5 switch the action; G
//! toggles a gizmo skeleton of the driven joints. The camera follows.
//!
//! `cargo run --release -p motion-bevy --example skinned --features render [-- CHARACTER.glb]`:
//! any other glTF humanoid whose joint names a built-in map knows (the female mannequin of
//! `../shared/assets/characters`, for example) is driven unchanged.
mod common;

use bevy::prelude::*;
use bevy::transform::TransformSystems;
use bevy::world_serialization::WorldAssetRoot;
use motion_bevy::{MotionCharacter, MotionGoal, MotionPlugin, MotionRig, MotionSkinned};

/// Walking speed when steered (m/s): about the built-in model's own pace.
const SPEED: f32 = 0.6;
const ACTIONS: [&str; 5] = ["walking", "eating", "smoking", "discussion", "greeting"];

#[derive(Resource, Default)]
struct ShowSkeleton(bool);

/// The glTF file the character is drawn with (its name inside the asset folder).
#[derive(Resource)]
struct CharacterFile(String);

/// The asset folder and file of the character: the first argument, or the committed mannequin.
fn character() -> (String, String) {
    let Some(arg) = std::env::args().nth(1) else {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets");
        return (dir.into(), "mannequin.glb".into());
    };
    let path = std::path::Path::new(&arg);
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let dir = std::path::absolute(&dir).unwrap_or(dir);
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !path.is_file() {
        eprintln!("error: {arg}: no such glTF file");
        std::process::exit(2);
    }
    (dir.to_string_lossy().into_owned(), file)
}

fn main() {
    let (dir, file) = character();
    App::new()
        .add_plugins((
            DefaultPlugins.set(AssetPlugin {
                file_path: dir,
                ..default()
            }),
            MotionPlugin,
        ))
        .insert_resource(CharacterFile(file))
        .init_resource::<ShowSkeleton>()
        .add_systems(Startup, setup)
        .add_systems(Update, (steer, switch_action, common::report_failures))
        .add_systems(
            PostUpdate,
            (follow_camera, draw_skeleton).after(TransformSystems::Propagate),
        )
        .run();
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    file: Res<CharacterFile>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(200.0, 200.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.25, 0.27, 0.3))),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((Camera3d::default(), Transform::from_xyz(3.0, 1.7, 3.0)));
    commands.spawn((
        WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset(file.0.clone()))),
        MotionCharacter::new("walking", 1),
        MotionSkinned::default(),
    ));
}

/// Arrow keys / WASD set a goal velocity in world axes; none held: the model's own motion.
fn steer(keys: Res<ButtonInput<KeyCode>>, mut characters: Query<&mut MotionCharacter>) {
    let held = |a: KeyCode, b: KeyCode| keys.pressed(a) || keys.pressed(b);
    let mut v = Vec2::ZERO;
    if held(KeyCode::ArrowUp, KeyCode::KeyW) {
        v.y += 1.0;
    }
    if held(KeyCode::ArrowDown, KeyCode::KeyS) {
        v.y -= 1.0;
    }
    if held(KeyCode::ArrowLeft, KeyCode::KeyA) {
        v.x += 1.0;
    }
    if held(KeyCode::ArrowRight, KeyCode::KeyD) {
        v.x -= 1.0;
    }
    for mut character in &mut characters {
        character.goal = (v != Vec2::ZERO).then(|| MotionGoal::towards(v.normalize() * SPEED));
    }
}

fn switch_action(
    keys: Res<ButtonInput<KeyCode>>,
    mut show: ResMut<ShowSkeleton>,
    mut characters: Query<&mut MotionCharacter>,
) {
    let digits = [
        KeyCode::Digit1,
        KeyCode::Digit2,
        KeyCode::Digit3,
        KeyCode::Digit4,
        KeyCode::Digit5,
    ];
    for (key, action) in digits.iter().zip(ACTIONS) {
        if keys.just_pressed(*key) {
            for mut character in &mut characters {
                character.action = action.into();
            }
        }
    }
    if keys.just_pressed(KeyCode::KeyG) {
        show.0 = !show.0;
    }
}

/// The camera looks at the character's hips from behind and to the side.
fn follow_camera(
    rigs: Query<&MotionRig>,
    joints: Query<&GlobalTransform>,
    mut camera: Query<&mut Transform, With<Camera3d>>,
) {
    let Some(hips) = rigs.iter().next().and_then(|rig| {
        let i = rig.names().iter().position(|n| n == "pelvis")?;
        joints.get(rig.joints()[i]).ok().map(|t| t.translation())
    }) else {
        return;
    };
    for mut t in &mut camera {
        *t = Transform::from_translation(hips + Vec3::new(3.0, 0.7, 3.0)).looking_at(hips, Vec3::Y);
    }
}

/// The driven joints as gizmo lines (G toggles).
fn draw_skeleton(
    show: Res<ShowSkeleton>,
    mut gizmos: Gizmos,
    rigs: Query<&MotionRig>,
    joints: Query<(&GlobalTransform, &ChildOf)>,
) {
    if show.0 {
        common::draw_rigs(&mut gizmos, &rigs, &joints);
    }
}
