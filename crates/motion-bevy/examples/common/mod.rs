//! What the examples share: the rigs drawn as gizmo lines, failures printed.
use bevy::prelude::*;
use motion_bevy::{MotionFailed, MotionRig};

/// Each rig's bones as gizmo lines between each driven joint's and its parent's global position.
pub fn draw_rigs(
    gizmos: &mut Gizmos,
    rigs: &Query<&MotionRig>,
    joints: &Query<(&GlobalTransform, &ChildOf)>,
) {
    for rig in rigs {
        for &joint in &rig.joints()[1..] {
            let Ok((at, parent)) = joints.get(joint) else {
                continue;
            };
            let Ok((from, _)) = joints.get(parent.parent()) else {
                continue;
            };
            gizmos.line(
                from.translation(),
                at.translation(),
                Color::srgb(1.0, 0.7, 0.3),
            );
        }
    }
}

/// Prints why a character could not start or go on.
pub fn report_failures(failed: Query<(Entity, &MotionFailed), Added<MotionFailed>>) {
    for (entity, failure) in &failed {
        eprintln!("character {entity}: {}", failure.0);
    }
}
