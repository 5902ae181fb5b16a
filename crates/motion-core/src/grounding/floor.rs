//! The floor under a seed: a plane fitted to the seed's lowest foot points, and the rigid
//! transform that makes it the plane `y = 0` ("the floor frame").
//!
//! ## The rule (stated once; grounding and the plausibility measures use it)
//! 1. Per seed frame, the lowest of both feet's foot points ([`super::legs`]), metres: lowest
//!    in the frame each round of step 2 levels (so the choice does not depend on the tilt the
//!    seed was recorded with).
//! 2. A plane `y = a·x + b·z + c` fitted by least squares to those points, its slope measured
//!    only along the horizontal directions in which the points spread (the principal axes of
//!    their horizontal positions with a standard deviation of at least [`MIN_SPREAD_M`]; level
//!    along the others: a seed standing on one spot gives a level floor), refitted once on the points no more than [`AIRBORNE_M`]
//!    above the first fit (steps and swings are not floor); repeated in the frame each round
//!    levels until the slope left is under 1e-12 (at most 16 rounds), so the fit is its own
//!    fixed point: the points moved into the floor frame fit the level plane `y = 0` again (a
//!    levelled seed written to a file and measured again keeps its floor); the tilt then
//!    steeper than [`MAX_TILT_DEG`] taken for noise: level then.
//! 3. The floor frame: the rotation taking the plane's normal to +y, about the point of the plane
//!    under the last seed point, then that point moved to height 0. Integrated H3.6M roots start
//!    from an unknown orientation (a few degrees of tilt are common in real data), which this
//!    removes.
use glam::{DQuat, DVec3, Quat, Vec3};

/// The floor's slope is measured along a horizontal direction only where the points' standard
/// deviation along it is at least this (metres): see the module docs.
pub const MIN_SPREAD_M: f64 = 0.05;
/// Points higher than this above the first fit are left out of the second (metres).
pub const AIRBORNE_M: f64 = 0.03;
/// Rounds of the fit (see [`Floor::fit`]).
const FIT_ROUNDS: usize = 16;
/// The smallest tilt (degrees) front ends tell the user about: below it a floor is level.
pub const NOTABLE_TILT_DEG: f64 = 0.01;
/// The steepest floor the fit reports (degrees); a steeper fit gives a level floor.
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

    /// Fits the floor to `points` (world, metres), one per seed frame (the lowest foot point of
    /// each); the pivot lies under the last point. `None` without points or with non-finite
    /// ones.
    pub fn fit(points: &[Vec3]) -> Option<Floor> {
        Floor::fit_frames(points, 1)
    }

    /// Fits the floor to the foot points of seed frames (world, metres): `points` holds
    /// `per_frame` points of each frame in turn, and each round of the fit takes the lowest of
    /// each frame in the frame it levels (module docs), so the points moved into the floor
    /// frame fit the level floor again. `None` without a whole frame, with non-finite points or
    /// a `per_frame` of 0.
    pub fn fit_frames(points: &[Vec3], per_frame: usize) -> Option<Floor> {
        if per_frame == 0 || points.len() < per_frame || points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let frames = || points.chunks_exact(per_frame);
        // Each frame's lowest point in the frame `level` makes, moved into it.
        let lowest = move |level: DQuat| {
            frames().map(move |frame| {
                frame
                    .iter()
                    .map(|p| level * p.as_dvec3())
                    .min_by(|a, b| a.y.total_cmp(&b.y))
                    .expect("per_frame > 0")
            })
        };
        // Fitted again in the frame the last fit levelled until nothing is left to level (least
        // squares in y is not rotation-invariant: each round leaves a much smaller slope).
        let mut level = DQuat::IDENTITY;
        let mut height = 0.0;
        for _ in 0..FIT_ROUNDS {
            let moved = lowest(level);
            let (mut a, mut b, mut c) = fit_plane(moved.clone(), None)?;
            if let Some(refit) = fit_plane(moved.clone(), Some((a, b, c, AIRBORNE_M))) {
                (a, b, c) = refit;
            }
            let normal = DVec3::new(-a, 1.0, -b).normalize();
            let here = moved.clone().next_back().expect("a frame");
            // The plane's height under the last point, in this round's frame.
            height = a * here.x + b * here.z + c;
            if a.abs() + b.abs() < 1e-12 {
                break;
            }
            let turn = DQuat::from_rotation_arc(normal, DVec3::Y);
            level = turn * level;
            // The new frame's height: the plane point under the last point, rotated.
            let on_plane = DVec3::new(here.x, a * here.x + b * here.z + c, here.z);
            height = (turn * on_plane).y;
        }
        let mut up = level.inverse() * DVec3::Y;
        let max = MAX_TILT_DEG.to_radians();
        let tilt = up.angle_between(DVec3::Y);
        if tilt > max {
            // A steeper fit is the seed's noise (a few centimetres of foot spread), not a floor:
            // level (and a fit of the levelled points is level again).
            up = DVec3::Y;
            level = DQuat::IDENTITY;
            let moved: Vec<DVec3> = lowest(level).collect();
            let mean = moved.iter().map(|p| p.y).sum::<f64>() / moved.len() as f64;
            height = mean.min(moved.last().expect("a frame").y);
        }
        let here = lowest(level).next_back().expect("a frame");
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

    /// A position in the floor frame back in the world the floor was fitted in (the inverse of
    /// [`to_floor_frame`](Self::to_floor_frame)).
    pub fn from_floor_frame(&self, p: Vec3) -> Vec3 {
        self.from_floor_frame_f64(p.as_dvec3()).as_vec3()
    }

    /// [`from_floor_frame`](Self::from_floor_frame) in f64.
    pub fn from_floor_frame_f64(&self, p: DVec3) -> DVec3 {
        let pivot = self.pivot.as_dvec3();
        self.level.as_dquat().inverse() * (p - DVec3::new(pivot.x, 0.0, pivot.z)) + pivot
    }

    /// The floor's tilt from level (degrees).
    pub fn tilt_degrees(&self) -> f64 {
        (self.slope_x.hypot(self.slope_z)).atan().to_degrees()
    }

    /// A root pose (translation metres, world rotation) in the floor frame.
    pub fn root_to_floor_frame(&self, translation: Vec3, rotation: Quat) -> (Vec3, Quat) {
        (
            self.to_floor_frame(translation),
            (self.level * rotation).normalize(),
        )
    }
}

/// Least squares of `y = a x + b z + c` with the slope along the well-spread horizontal axes
/// only (module docs); with `keep = (a, b, c, h)` only points at most `h` above that plane take
/// part.
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
    let (mut cxx, mut cxz, mut czz, mut cxy, mut czy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in kept {
        let d = p - mean;
        cxx += d.x * d.x / n;
        cxz += d.x * d.z / n;
        czz += d.z * d.z / n;
        cxy += d.x * d.y / n;
        czy += d.z * d.y / n;
    }
    // Principal axes of the horizontal spread: along each, centred coordinates are uncorrelated,
    // so the slope along an axis is its own regression.
    let half_gap = (((cxx - czz) / 2.0).powi(2) + cxz * cxz).sqrt();
    let major_var = (cxx + czz) / 2.0 + half_gap;
    let minor_var = (cxx + czz) / 2.0 - half_gap;
    let major = if cxz.abs() > 1e-300 {
        let (x, z) = (major_var - czz, cxz);
        let len = (x * x + z * z).sqrt();
        (x / len, z / len)
    } else if cxx >= czz {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let minor = (-major.1, major.0);
    let (mut a, mut b) = (0.0, 0.0);
    for (var, (ux, uz)) in [(major_var, major), (minor_var, minor)] {
        if var >= MIN_SPREAD_M * MIN_SPREAD_M {
            let slope = (ux * cxy + uz * czy) / var;
            a += ux * slope;
            b += uz * slope;
        }
    }
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
        // Jitter on one spot: level too.
        let jitter: Vec<Vec3> = (0..50)
            .map(|i| {
                let t = i as f32;
                Vec3::new(
                    0.03 * t.sin(),
                    0.01 * (1.7 * t).cos(),
                    0.05 * (0.3 * t).cos(),
                )
            })
            .collect();
        assert_eq!(Floor::fit(&jitter).unwrap().tilt_deg(), 0.0);
        assert!(Floor::fit(&[Vec3::NAN]).is_none());
    }

    #[test]
    fn points_moved_into_the_floor_frame_fit_the_level_floor_again() {
        // A walk on a tilted plane with swing points and sideways sway, a slow walk, a diagonal.
        let seeds: [Vec<Vec3>; 3] = [
            (0..50)
                .map(|i| {
                    let t = i as f32;
                    let lift = if i % 4 == 0 { 0.08 } else { 0.0 };
                    Vec3::new(0.05 * t, 0.01 * t + lift - 0.9, 0.1 * (0.8 * t).sin())
                })
                .collect(),
            (0..50)
                .map(|i| {
                    let t = i as f32;
                    Vec3::new(0.016 * t, 0.02 * (0.5 * t).sin(), -0.01 * t)
                })
                .collect(),
            (0..50)
                .map(|i| {
                    let t = i as f32;
                    Vec3::new(0.04 * t, 0.3 + 0.01 * t + 0.015 * (1.3 * t).cos(), 0.04 * t)
                })
                .collect(),
        ];
        for (k, points) in seeds.iter().enumerate() {
            let floor = Floor::fit(points).unwrap();
            let moved: Vec<Vec3> = points.iter().map(|&p| floor.to_floor_frame(p)).collect();
            let again = Floor::fit(&moved).unwrap();
            assert!(again.tilt_deg() < 1e-3, "seed {k}: {}", again.tilt_deg());
            assert!(again.height.abs() < 1e-4, "seed {k}: {}", again.height);
        }
    }

    #[test]
    fn a_fit_steeper_than_the_limit_is_level_and_stays_level() {
        let steep: Vec<Vec3> = (0..50)
            .map(|i| Vec3::new(i as f32 * 0.1, i as f32 * 0.1, 0.0))
            .collect();
        let floor = Floor::fit(&steep).unwrap();
        assert_eq!(floor.tilt_deg(), 0.0);
        let moved: Vec<Vec3> = steep.iter().map(|&p| floor.to_floor_frame(p)).collect();
        let again = Floor::fit(&moved).unwrap();
        assert_eq!(again.tilt_deg(), 0.0);
        assert!(again.height.abs() < 1e-5, "{}", again.height);
        // Under the limit, the slope is kept.
        let gentle: Vec<Vec3> = (0..50)
            .map(|i| Vec3::new(i as f32 * 0.1, i as f32 * 0.02, 0.0))
            .collect();
        let tilt = Floor::fit(&gentle).unwrap().tilt_deg();
        assert!((tilt - 0.2f64.atan().to_degrees()).abs() < 1e-3, "{tilt}");
    }
}
