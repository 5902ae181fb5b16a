//! Seats: a seed that ends with the body resting on something other than its feet (seated on
//! a chair, kneeling) leaves that support where the root was (step 3 of the
//! [module docs](super)).
//!
//! A standing or crouching body keeps its root over its feet (its balance needs it: real H3.6M
//! S5 frames with the root under [`SEATED_HEIGHT`] of the standing height hold it 50-250 mm
//! from the ankles' midpoint, horizontally, in crouches), while a seated or kneeling one has it
//! 350-700 mm away (S5 sitting, eating, phoning and smoking; `motion-cli convert --positions`
//! of the S5 takes). Such a seed's last frame leaves a seat: while the root is within
//! [`SEAT_RADIUS`] of where it was, it is never lower than it was (the body can rise off the seat
//! onto its feet, not sink through it), and feet the legs cannot bring to the floor from there
//! stay off it, as a seated person's do.

use glam::Vec3;

/// A seed's root lower than this share of the rig's standing root height can be seated.
pub const SEATED_HEIGHT: f32 = 0.8;

/// ... and is seated when it is at least this share of the standing root height away from the
/// ankles' midpoint, horizontally.
pub const SEATED_OFFSET: f32 = 0.33;

/// A seat holds the root while it is within this share of the standing root height of where
/// the seed left it, horizontally.
pub const SEAT_RADIUS: f32 = 0.5;

/// A root at most this share of the standing root height above its seat rests on it (and does
/// not slide over it).
pub const SEAT_CLEARANCE: f32 = 0.05;

/// Where a seed's last frame leaves a seat (floor frame, metres): `root` and both `ankles`,
/// for a rig whose standing root height is `standing` metres. The seat is the root's position:
/// its `y` the lowest the root goes while over it.
pub fn seat_of(root: Vec3, ankles: [Vec3; 2], standing: f32) -> Option<Vec3> {
    let mid = 0.5 * (ankles[0] + ankles[1]);
    let offset = (root.x - mid.x).hypot(root.z - mid.z);
    let seated = root.y < SEATED_HEIGHT * standing && offset >= SEATED_OFFSET * standing;
    (seated && standing > 0.0 && root.is_finite() && mid.is_finite()).then_some(root)
}

/// The lowest height a `seat` lets a root at `root` go to (floor frame, metres), or `None`
/// when the root is not over it.
pub fn height_under(seat: Vec3, root: Vec3, standing: f32) -> Option<f32> {
    ((root.x - seat.x).hypot(root.z - seat.z) <= SEAT_RADIUS * standing).then_some(seat.y)
}
