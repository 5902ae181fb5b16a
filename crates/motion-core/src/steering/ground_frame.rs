//! A character's ground frame: where its root is on the floor and which way it faces, and the
//! floor vectors turned into and out of it (motion matching's features and a take's trajectory
//! are written in it).
use glam::{Vec2, Vec3};

/// A frame's ground frame: the root on the floor and the facing (yaw about +y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundFrame {
    /// The root's floor position `(x, z)`, metres.
    pub position: Vec2,
    /// Yaw about +y, radians (`0` facing +z).
    pub facing: f32,
}

impl GroundFrame {
    /// A world floor vector `(x, z)` in this frame (+z forward, +x to the facing's left).
    pub fn local(&self, v: Vec2) -> Vec2 {
        rotate(v, -self.facing)
    }

    /// A world 3-vector in this frame (its floor part turned, its height kept).
    pub fn local3(&self, v: Vec3) -> Vec3 {
        let f = self.local(Vec2::new(v.x, v.z));
        Vec3::new(f.x, v.y, f.y)
    }

    /// A floor vector of this frame in world axes (the inverse of [`GroundFrame::local`]).
    pub fn world(&self, v: Vec2) -> Vec2 {
        rotate(v, self.facing)
    }
}

/// `v` turned by `angle` about +y (a facing of `angle` maps +z to `direction_of(angle)`).
pub fn rotate(v: Vec2, angle: f32) -> Vec2 {
    let (s, c) = angle.sin_cos();
    Vec2::new(c * v.x + s * v.y, -s * v.x + c * v.y)
}
