//! Analytic two-bone IK (hip, knee, ankle), column-vector quaternions (glam).
use glam::{Quat, Vec3};

/// The chain's world state before the solve.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chain {
    /// Hip, knee and ankle world positions.
    pub a: Vec3,
    pub b: Vec3,
    pub c: Vec3,
    /// World rotation of the hip's parent, the hip and the knee.
    pub parent_rotation: Quat,
    pub hip_rotation: Quat,
    pub knee_rotation: Quat,
    /// The direction the knee bends towards when the leg is straight (world; the foot's
    /// forward).
    pub forward: Vec3,
}

/// New local rotations of hip and knee that bring the ankle to `target` (or as near as the leg
/// reaches, along the same direction), keeping the knee in its plane. Returns
/// `(hip_local, knee_local)`.
pub(crate) fn solve(chain: &Chain, knee_local: Quat, target: Vec3) -> (Quat, Quat) {
    const EPS: f32 = 1e-4;
    let Chain { a, b, c, .. } = *chain;
    let lab = (b - a).length();
    let lcb = (c - b).length();
    if lab < EPS || lcb < EPS {
        return (
            (chain.parent_rotation.inverse() * chain.hip_rotation).normalize(),
            knee_local,
        );
    }
    let lat = (target - a).length().clamp(EPS, lab + lcb - EPS);
    let cos = |x: f32| x.clamp(-1.0, 1.0).acos();
    // Interior angle at the knee now and wanted (law of cosines).
    let now = cos((a - b).normalize().dot((c - b).normalize()));
    let want = cos((lab * lab + lcb * lcb - lat * lat) / (2.0 * lab * lcb));
    // (a - b) x (c - b): rotating about it by +δ opens the knee by δ.
    let mut axis = (a - b).cross(c - b);
    if axis.length_squared() < 1e-10 {
        // Straight leg: bend so that the knee goes forward, the foot back.
        axis = (c - a).cross(chain.forward);
        if axis.length_squared() < 1e-10 {
            axis = (c - a).any_orthonormal_vector();
        }
    }
    let axis = axis.normalize();
    let bend = Quat::from_axis_angle(chain.knee_rotation.inverse() * axis, want - now);
    let knee_local = (knee_local * bend).normalize();
    // The ankle after the bend (hip unchanged), then swing the whole leg onto the target.
    let knee_world = chain.knee_rotation * bend;
    let ankle_local = chain.knee_rotation.inverse() * (c - b);
    let c_bent = b + knee_world * ankle_local;
    let from = (c_bent - a).normalize_or_zero();
    let to = (target - a).normalize_or_zero();
    let swing = if from == Vec3::ZERO || to == Vec3::ZERO {
        Quat::IDENTITY
    } else {
        Quat::from_rotation_arc(from, to)
    };
    let hip_world = (swing * chain.hip_rotation).normalize();
    (
        (chain.parent_rotation.inverse() * hip_world).normalize(),
        knee_local,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// World positions of a chain from local rotations (offsets of knee and ankle in the parent).
    fn fk(parent: Quat, hip_local: Quat, knee_local: Quat, a: Vec3) -> (Vec3, Vec3, Quat, Quat) {
        let hip = parent * hip_local;
        let b = a + hip * Vec3::new(0.0, -0.44, 0.0);
        let knee = hip * knee_local;
        let c = b + knee * Vec3::new(0.0, -0.45, 0.0);
        (b, c, hip, knee)
    }

    #[test]
    fn reaches_targets_within_reach_and_points_at_the_others() {
        let mut worst = 0.0f32;
        for i in 0..200 {
            let f = i as f32;
            let parent = Quat::from_euler(glam::EulerRot::YXZ, f * 0.7, 0.2 * (f * 1.3).sin(), 0.1);
            let hip_local = Quat::from_euler(glam::EulerRot::XYZ, 0.5 * (f * 0.9).sin(), 0.3, 0.1);
            let knee_local = Quat::from_rotation_x(0.8 * (f * 0.37).sin().abs());
            let a = Vec3::new(0.1, 0.9, 0.0);
            let (b, c, hip, knee) = fk(parent, hip_local, knee_local, a);
            let chain = Chain {
                a,
                b,
                c,
                parent_rotation: parent,
                hip_rotation: hip,
                knee_rotation: knee,
                forward: parent * Vec3::Z,
            };
            let reach = 0.2 + 0.65 * ((f * 0.53).sin() * 0.5 + 0.5);
            let dir = Vec3::new((f * 0.3).sin(), -1.0, (f * 0.7).cos() * 0.5).normalize();
            let target = a + dir * reach;
            let (h, k) = solve(&chain, knee_local, target);
            let (_, c2, _, _) = fk(parent, h, k, a);
            worst = worst.max((c2 - target).length());
            // Out of reach: the leg points at the target, straight.
            let far = a + dir * 1.5;
            let (h, k) = solve(&chain, knee_local, far);
            let (_, c3, _, _) = fk(parent, h, k, a);
            assert!((c3 - a).normalize().dot(dir) > 0.9999, "case {i}");
            assert!((c3 - a).length() > 0.88, "case {i}");
        }
        assert!(worst < 1e-3, "worst {worst} m");
    }

    #[test]
    fn a_straight_leg_bends_its_knee_forward() {
        let a = Vec3::new(0.0, 0.9, 0.0);
        let (b, c, hip, knee) = fk(Quat::IDENTITY, Quat::IDENTITY, Quat::IDENTITY, a);
        let chain = Chain {
            a,
            b,
            c,
            parent_rotation: Quat::IDENTITY,
            hip_rotation: hip,
            knee_rotation: knee,
            forward: Vec3::Z,
        };
        let target = Vec3::new(0.0, 0.2, 0.0);
        let (h, k) = solve(&chain, Quat::IDENTITY, target);
        let (b2, c2, _, _) = fk(Quat::IDENTITY, h, k, a);
        assert!((c2 - target).length() < 1e-3);
        assert!(b2.z > 0.1, "knee at {b2}");
    }
}
