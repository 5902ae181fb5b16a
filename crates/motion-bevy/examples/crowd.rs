//! A crowd: N characters on the built-in model (default 16), skeletons drawn with gizmos, the
//! camera circling them. Every other character walks a 3 m square of waypoints around where it
//! was spawned (`motion_core::steering::Waypoints` setting `MotionCharacter::goal` every frame,
//! the square drawn in blue); the others switch actions every few seconds.
//!
//! `cargo run --release -p motion-bevy --example crowd --features render -- 32`
mod common;

use bevy::prelude::*;
use bevy::transform::TransformSystems;
use motion_bevy::{MotionCharacter, MotionGoal, MotionPlugin, MotionRig};
use motion_core::steering::{Vec2 as FloorVec, Waypoints};

/// Side of each walker's square (metres) and its walking speed (m/s).
const SQUARE_M: f32 = 3.0;
const WALK_SPEED: f32 = 0.5;

/// The actions the crowd cycles through.
const ACTIONS: [&str; 6] = [
    "walking",
    "eating",
    "smoking",
    "discussion",
    "greeting",
    "walking",
];

#[derive(Resource)]
struct Switch(Timer);

#[derive(Component)]
struct Member(usize);

/// A walker's waypoints (world `x`, `z`).
#[derive(Component)]
struct Route(Waypoints);

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(16);
    App::new()
        .add_plugins((DefaultPlugins, MotionPlugin))
        .insert_resource(Switch(Timer::from_seconds(4.0, TimerMode::Repeating)))
        .add_systems(
            Startup,
            move |commands: Commands,
                  meshes: ResMut<Assets<Mesh>>,
                  materials: ResMut<Assets<StandardMaterial>>| {
                setup(n, commands, meshes, materials)
            },
        )
        .add_systems(
            Update,
            (
                follow_routes,
                switch_actions,
                orbit_camera,
                common::report_failures,
            ),
        )
        .add_systems(
            PostUpdate,
            (draw_skeletons, draw_routes).after(TransformSystems::Propagate),
        )
        .run();
}

fn setup(
    n: usize,
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(80.0, 80.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.25, 0.27, 0.3))),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8000.0,
            ..default()
        },
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((Camera3d::default(), Transform::from_xyz(0.0, 6.0, 14.0)));
    let side = (n as f32).sqrt().ceil() as usize;
    for i in 0..n {
        let (row, col) = (i / side, i % side);
        let at = Vec3::new(
            (col as f32 - side as f32 / 2.0) * 2.0,
            0.0, // the plugin stands the first pose on the entity's origin
            (row as f32 - side as f32 / 2.0) * 2.0,
        );
        let heading = Quat::from_rotation_y(i as f32 * 0.7);
        let placed = Transform::from_translation(at).with_rotation(heading);
        if i % 2 == 0 {
            let corner = |x: f32, z: f32| FloorVec::new(at.x + x, at.z + z);
            let half = SQUARE_M / 2.0;
            let square = vec![
                corner(half, half),
                corner(-half, half),
                corner(-half, -half),
                corner(half, -half),
            ];
            commands.spawn((
                MotionCharacter::new("walking", i as u64),
                placed,
                Member(i),
                Route(Waypoints::new(square, WALK_SPEED, 0.4, true)),
            ));
        } else {
            commands.spawn((
                MotionCharacter::new(ACTIONS[i % ACTIONS.len()], i as u64),
                placed,
                Member(i),
            ));
        }
    }
}

/// Every frame each walker's goal: toward its next waypoint (the character entity's transform
/// is where its root motion has taken it).
fn follow_routes(mut walkers: Query<(&mut MotionCharacter, &mut Route, &Transform)>) {
    for (mut character, mut route, at) in &mut walkers {
        let forward = at.rotation * Vec3::Z;
        let facing = forward.x.atan2(forward.z);
        let goal = route
            .0
            .goal(FloorVec::new(at.translation.x, at.translation.z), facing);
        character.goal = Some(MotionGoal {
            velocity: Vec2::new(goal.velocity.x, goal.velocity.y),
            facing: goal.facing,
        });
    }
}

/// Every few seconds each character without a route moves on to the next action of the list.
fn switch_actions(
    time: Res<Time>,
    mut timer: ResMut<Switch>,
    mut characters: Query<(&mut MotionCharacter, &Member), Without<Route>>,
    mut round: Local<usize>,
) {
    if !timer.0.tick(time.delta()).just_finished() {
        return;
    }
    *round += 1;
    for (mut character, member) in &mut characters {
        character.action = ACTIONS[(member.0 + *round) % ACTIONS.len()].into();
    }
}

fn orbit_camera(time: Res<Time>, mut camera: Query<&mut Transform, With<Camera3d>>) {
    let angle = time.elapsed_secs() * 0.1;
    for mut t in &mut camera {
        *t = Transform::from_xyz(14.0 * angle.sin(), 6.0, 14.0 * angle.cos())
            .looking_at(Vec3::new(0.0, 0.8, 0.0), Vec3::Y);
    }
}

/// Each walker's square, its next waypoint marked.
fn draw_routes(mut gizmos: Gizmos, routes: Query<&Route>) {
    let blue = Color::srgb(0.3, 0.6, 1.0);
    for route in &routes {
        let points = route.0.points();
        let floor = |p: &FloorVec| Vec3::new(p.x, 0.02, p.y);
        gizmos.linestrip(points.iter().chain(points.first()).map(floor), blue);
        let Some(next) = route.0.target() else {
            continue;
        };
        gizmos.sphere(
            Isometry3d::from_translation(Vec3::new(next.x, 0.05, next.y)),
            0.1,
            blue,
        );
    }
}

/// Bones as gizmo lines between each joint's and its parent's global position.
fn draw_skeletons(
    mut gizmos: Gizmos,
    rigs: Query<&MotionRig>,
    joints: Query<(&GlobalTransform, &ChildOf)>,
) {
    common::draw_rigs(&mut gizmos, &rigs, &joints);
}
