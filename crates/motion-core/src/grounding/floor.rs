//! The floor under a seed: a plane fitted to the seed's lowest foot points, and the rigid
//! transform that makes it the plane `y = 0` ("the floor frame").
//!
//! ## The rule (stated once; grounding and the plausibility measures use it)
//! 1. Per seed frame, the lowest of both feet's foot points ([`super::legs`]), metres.
//! 2. A plane `y = a·x + b·z + c` fitted by least squares to those points with a ridge penalty
//!    [`SLOPE_RIDGE_M2`]` · n · (a² + b²)` (a seed standing on one spot gives a level floor, a
//!    seed walking straight no sideways slope; a slow 2 s walk of 0.8 m keeps ~90 % of its
//!    measured slope), refitted once on the points no more
//!    than [`AIRBORNE_M`] above the first fit (steps and swings are not floor); repeated in the
//!    frame each round levels (4 rounds), so the ridge keeps a still seed level without
//!    shrinking a walking seed's slope; the tilt then limited to [`MAX_TILT_DEG`].
//! 3. The floor frame: the rotation taking the plane's normal to +y, about the point of the plane
//!    under the last seed point, then that point moved to height 0. Integrated H3.6M roots start
//!    from an unknown orientation (a few degrees of tilt are common in real data), which this
//!    removes.
use glam::{DQuat, DVec3, Quat, Vec3};

/// Ridge weight on the floor's slope, m²: see the module docs.
pub const SLOPE_RIDGE_M2: f64 = 0.005;
/// Points higher than this above the first fit are left out of the second (metres).
pub const AIRBORNE_M: f64 = 0.03;
/// Rounds of the fit (see [`Floor::fit`]).
const FIT_ROUNDS: usize = 4;
/// The largest floor tilt the fit may report (degrees).
pub const MAX_TILT_DEG: f64 = 30.0;

/// A fitted floor and its floor frame (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    /// Slope `a` of `y = a·x + b·z + c` (metres per metre).
    pub slope_x: f64,
    /// Slope `b`.
    pub slope_z: f64,
    /// Height `c` at `x = z = 0` (metres).
    pub height: f64,
    /// The rotation of the floor frame (normal to +y).
    pub level: Quat,
    /// The pivot on the floor plane (world, metres).
    pub pivot: Vec3,
}

impl Floor {
    /// A level floor at height `height` (no slope).
    pub fn level_at(height: f64) -> Floor {
        Floor {
            slope_x: 0.0,
            slope_z: 0.0,
            height,
            level: Quat::IDENTITY,
            pivot: Vec3::new(0.0, height as f32, 0.0),
        }
    }

    /// Fits the floor to `points` (world, metres; the lowest foot point of each seed frame);
    /// the pivot lies under the last point. `None` without points or with non-finite ones.
    pub fn fit(points: &[Vec3]) -> Option<Floor> {
        let last = points.last()?.as_dvec3();
        if points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        // Fitted again in the frame the last fit levelled, so that the ridge's pull towards
        // level leaves no slope behind (each round keeps the ridge's share of the last one's).
        let mut level = DQuat::IDENTITY;
        let mut height = 0.0;
        for _ in 0..FIT_ROUNDS {
            let moved = points.iter().map(|p| level * p.as_dvec3());
            let (mut a, mut b, mut c) = fit_plane(moved.clone(), None)?;
            if let Some(refit) = fit_plane(moved, Some((a, b, c, AIRBORNE_M))) {
                (a, b, c) = refit;
            }
            let normal = DVec3::new(-a, 1.0, -b).normalize();
            let here = level * last;
            // The plane's height under the last point, in this round's frame.
            height = a * here.x + b * here.z + c;
            if a.abs() + b.abs() < 1e-12 {
                break;
            }
            level = DQuat::from_rotation_arc(normal, DVec3::Y) * level;
            // The new frame's height: the plane point under the last point, rotated.
            let on_plane = DVec3::new(here.x, a * here.x + b * here.z + c, here.z);
            height = (DQuat::from_rotation_arc(normal, DVec3::Y) * on_plane).y;
        }
        let mut up = level.inverse() * DVec3::Y;
        let max = MAX_TILT_DEG.to_radians();
        let tilt = up.angle_between(DVec3::Y);
        if tilt > max {
            let axis = up.cross(DVec3::Y).normalize();
            up = DQuat::from_axis_angle(axis, tilt - max) * up;
            level = DQuat::from_rotation_arc(up, DVec3::Y);
            let here = level * last;
            let moved: Vec<DVec3> = points.iter().map(|p| level * p.as_dvec3()).collect();
            let mean = moved.iter().map(|p| p.y).sum::<f64>() / moved.len() as f64;
            height = mean.min(here.y);
        }
        let here = level * last;
        let pivot = level.inverse() * DVec3::new(here.x, height, here.z);
        let a = -up.x / up.y;
        let b = -up.z / up.y;
        Some(Floor {
            slope_x: a,
            slope_z: b,
            height: pivot.y - a * pivot.x - b * pivot.z,
            level: level.as_quat(),
            pivot: pivot.as_vec3(),
        })
    }

    /// The floor's height at the horizontal place of `p` (metres).
    pub fn height_at(&self, p: Vec3) -> f64 {
        self.slope_x * f64::from(p.x) + self.slope_z * f64::from(p.z) + self.height
    }

    /// The tilt of the floor (degrees).
    pub fn tilt_deg(&self) -> f64 {
        (self.slope_x * self.slope_x + self.slope_z * self.slope_z)
            .sqrt()
            .atan()
            .to_degrees()
    }

    /// A world point in the floor frame (the floor is `y = 0` there).
    pub fn to_floor_frame(&self, p: Vec3) -> Vec3 {
        self.level * (p - self.pivot) + Vec3::new(self.pivot.x, 0.0, self.pivot.z)
    }

    /// [`to_floor_frame`](Self::to_floor_frame) in f64 (the floor's own parameters are f32).
    pub fn to_floor_frame_f64(&self, p: DVec3) -> DVec3 {
        let pivot = self.pivot.as_dvec3();
        self.level.as_dquat() * (p - pivot) + DVec3::new(pivot.x, 0.0, pivot.z)
    }

    /// A root pose (translation metres, world rotation) in the floor frame.
    pub fn root_to_floor_frame(&self, translation: Vec3, rotation: Quat) -> (Vec3, Quat) {
        (
            self.to_floor_frame(translation),
            (self.level * rotation).normalize(),
        )
    }
}

/// Ridge least squares of `y = a x + b z + c`; with `keep = (a, b, c, h)` only points at most
/// `h` above that plane take part.
fn fit_plane(
    points: impl Iterator<Item = DVec3> + Clone,
    keep: Option<(f64, f64, f64, f64)>,
) -> Option<(f64, f64, f64)> {
    let kept =
        points.filter(|p| keep.is_none_or(|(a, b, c, h)| p.y - (a * p.x + b * p.z + c) <= h));
    let (mut n, mut sum) = (0.0, DVec3::ZERO);
    for p in kept.clone() {
        n += 1.0;
        sum += p;
    }
    if n == 0.0 {
        return None;
    }
    let mean = sum / n;
    let (mut sxx, mut sxz, mut szz, mut sxy, mut szy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in kept {
        let d = p - mean;
        sxx += d.x * d.x;
        sxz += d.x * d.z;
        szz += d.z * d.z;
        sxy += d.x * d.y;
        szy += d.z * d.y;
    }
    let ridge = SLOPE_RIDGE_M2 * n;
    let (m11, m12, m22) = (sxx + ridge, sxz, szz + ridge);
    let det = m11 * m22 - m12 * m12;
    let a = (sxy * m22 - szy * m12) / det;
    let b = (szy * m11 - sxy * m12) / det;
    let c = mean.y - a * mean.x - b * mean.z;
    (a.is_finite() && b.is_finite() && c.is_finite()).then_some((a, b, c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilted_walk_gives_its_tilt_and_a_still_seed_a_level_floor() {
        // 3 m of steps on a plane climbing 3° along x, every 4th point a swinging foot 10 cm up.
        let slope = 3f64.to_radians().tan();
        let walk: Vec<Vec3> = (0..50)
            .map(|i| {
                let x = i as f64 * 0.06;
                let lift = if i % 4 == 0 { 0.1 } else { 0.0 };
                Vec3::new(x as f32, (slope * x + 0.2 + lift) as f32, 0.3)
            })
            .collect();
        let floor = Floor::fit(&walk).unwrap();
        assert!((floor.tilt_deg() - 3.0).abs() < 0.5, "{}", floor.tilt_deg());
        let last = *walk.last().unwrap();
        let on = floor.to_floor_frame(last);
        assert!(on.y.abs() < 0.01, "{on}");
        let still = vec![Vec3::new(0.1, -0.9, 0.2); 30];
        let floor = Floor::fit(&still).unwrap();
        assert_eq!(floor.tilt_deg(), 0.0);
        assert!((floor.height + 0.9).abs() < 1e-6);
        assert!(Floor::fit(&[]).is_none());
        assert!(Floor::fit(&[Vec3::NAN]).is_none());
    }

    #[test]
    fn tilt_is_limited() {
        let steep: Vec<Vec3> = (0..50)
            .map(|i| Vec3::new(i as f32 * 0.1, i as f32 * 0.1, 0.0))
            .collect();
        let floor = Floor::fit(&steep).unwrap();
        assert!((floor.tilt_deg() - MAX_TILT_DEG).abs() < 1e-6);
    }
}
