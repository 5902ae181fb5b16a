//! Rotations: the H3.6M evaluation conversions (bit-exact to the reference code) and general
//! conversions between exponential maps, quaternions, matrices and Euler angles in any of the 12
//! orders.
//!
//! ## Two conventions, one transpose apart
//! - **H3.6M row vectors** ([`Mat3`], `[[f64; 3]; 3]`, row-major, `m[i][j]` = row `i` column `j`,
//!   exactly like numpy indexing in the reference code): a point `x` (row vector) is rotated as
//!   `x · R`. [`expmap2rotmat`] and [`rotmat2euler`] live in this convention.
//! - **Column vectors** (glam's [`DMat3`] / [`DQuat`], BVH): a point is rotated as `M · x`.
//!
//! The same physical rotation has `M = Rᵀ`. [`mat3_to_dmat3`] / [`dmat3_to_mat3`] copy elements
//! *position for position* (no transpose: `dmat3.col(j)[i] == m[i][j]`), so the column-vector matrix
//! of an H3.6M rotation `R` is `mat3_to_dmat3(&R).transpose()`; [`row_mat3_to_quat`] and
//! [`quat_to_row_mat3`] do that transpose for you.
//!
//! Note that the Rodrigues formula of [`expmap2rotmat`] gives, read as a column-vector matrix, the
//! rotation about `r` by `|r|` (what [`axis_angle_to_quat`] returns). Read as a row-vector matrix
//! (as the H3.6M FK does) it is the *inverse* rotation. Hence the column-vector (BVH, engine)
//! local rotation of an H3.6M joint with exp-map `r` is [`h36m_joint_quat`]`(r)` =
//! `axis_angle_to_quat(r).conjugate()`.
//!
//! ## Euler angles
//! [`EulerOrder`] names the axis sequence as BVH lists its rotation channels. Angles `[a, b, c]`
//! are **intrinsic**, applied in the listed order, to **column vectors**:
//! `M = R_first(a) · R_second(b) · R_third(c)` (e.g. `ZXY`: `M = Rz(a) · Rx(b) · Ry(c)`), which is
//! what a BVH file with `CHANNELS 3 Zrotation Xrotation Yrotation` means and what glam's intrinsic
//! `EulerRot` variants compute.
use glam::{DMat3, DQuat, DVec3, EulerRot};

/// A 3x3 rotation matrix in the H3.6M **row-vector** convention, row-major (`m[i][j]` = row i,
/// column j, as numpy indexes it).
pub type Mat3 = [[f64; 3]; 3];

/// The identity [`Mat3`].
pub const MAT3_IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// float32 machine epsilon as used by the reference `expmap2rotmat` (`np.finfo(np.float32).eps`,
/// printed `1.1920929e-07`). numpy widens the float32 value exactly when adding it to the float64
/// angle, so this is `2^-23` = `1.1920928955078125e-07`, not the rounded decimal literal.
pub const EXPMAP_EPS: f64 = f32::EPSILON as f64;

/// Exponential map to rotation matrix exactly as the H3.6M evaluation code does it:
/// `θ = |r|`, `k = r / (θ + ε)` with ε = float32 epsilon, `R = I + sin θ K + (1 - cos θ) K²`.
///
/// Because of ε the result is not exactly orthonormal (errors ~1e-7 relative); that is deliberate,
/// the published numbers were computed with it.
pub fn expmap2rotmat(r: [f64; 3]) -> Mat3 {
    let theta = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let d = theta + EXPMAP_EPS;
    let (kx, ky, kz) = (r[0] / d, r[1] / d, r[2] / d);
    // K = [[0,-kz,ky],[kz,0,-kx],[-ky,kx,0]]
    let k = [[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]];
    let k2 = mat3_mul(&k, &k);
    let s = theta.sin();
    let c1 = 1.0 - theta.cos();
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let eye = if i == j { 1.0 } else { 0.0 };
            // Same association as numpy: (I + sin*K) + (1-cos)*K².
            out[i][j] = (eye + s * k[i][j]) + c1 * k2[i][j];
        }
    }
    out
}

/// Rotation matrix to Euler angles `[E1, E2, E3]` exactly as the H3.6M evaluation code does it
/// (including its exact `R[0][2] == ±1` test for gimbal lock).
///
/// For a non-degenerate `R`, the column-vector rotation `Rᵀ` equals
/// `DMat3::from_euler(EulerRot::ZYX, E3, E2, E1)` (equivalently `R = Rx(-E1)·Ry(-E2)·Rz(-E3)`).
pub fn rotmat2euler(r: &Mat3) -> [f64; 3] {
    let r02 = r[0][2];
    if r02 == 1.0 || r02 == -1.0 {
        let e3 = 0.0;
        let dlta = r[0][1].atan2(r[0][2]);
        if r02 == -1.0 {
            let e2 = std::f64::consts::PI / 2.0;
            let e1 = e3 + dlta;
            [e1, e2, e3]
        } else {
            let e2 = -std::f64::consts::PI / 2.0;
            let e1 = -e3 + dlta;
            [e1, e2, e3]
        }
    } else {
        let e2 = -r02.asin();
        let c2 = e2.cos();
        let e1 = (r[1][2] / c2).atan2(r[2][2] / c2);
        let e3 = (r[0][1] / c2).atan2(r[0][0] / c2);
        [e1, e2, e3]
    }
}

/// The protocol's per-frame Euler conversion: every exp-map triple at dims `3, 6, ..` is replaced
/// by `rotmat2euler(expmap2rotmat(triple))`, then dims 0..5 are set to 0.
///
/// Works for any width `3 + 3k` (99 for H3.6M, 117 for CMU). `out` must have the same length as
/// `frame`.
///
/// # Panics
/// If `frame.len() != out.len()` or the width is not `3 + 3k` with `k >= 1` (a programming error,
/// not bad input: callers validate widths when they read files).
pub fn expmap_frame_to_euler_protocol(frame: &[f64], out: &mut [f64]) {
    assert_eq!(frame.len(), out.len(), "frame and output widths differ");
    assert!(
        frame.len() >= 6 && frame.len().is_multiple_of(3),
        "frame width {} is not 3 + 3k",
        frame.len()
    );
    for k in (3..frame.len()).step_by(3) {
        let e = rotmat2euler(&expmap2rotmat([frame[k], frame[k + 1], frame[k + 2]]));
        out[k..k + 3].copy_from_slice(&e);
    }
    out[..6].fill(0.0);
}

/// Product `a · b` of two [`Mat3`].
pub fn mat3_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    out
}

/// Transpose of a [`Mat3`].
pub fn mat3_transpose(m: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] = m[j][i];
        }
    }
    out
}

/// Row vector times matrix: `v · m` (the H3.6M way of rotating a point).
#[inline]
pub fn vec_mul_mat3(v: [f64; 3], m: &Mat3) -> [f64; 3] {
    [
        v[0] * m[0][0] + v[1] * m[1][0] + v[2] * m[2][0],
        v[0] * m[0][1] + v[1] * m[1][1] + v[2] * m[2][1],
        v[0] * m[0][2] + v[1] * m[1][2] + v[2] * m[2][2],
    ]
}

/// Copies a [`Mat3`] into a glam [`DMat3`] element for element (`out.col(j)[i] == m[i][j]`),
/// **without** transposing. The column-vector matrix of the H3.6M row-vector rotation `m` is
/// `mat3_to_dmat3(m).transpose()`.
pub fn mat3_to_dmat3(m: &Mat3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(m[0][0], m[1][0], m[2][0]),
        DVec3::new(m[0][1], m[1][1], m[2][1]),
        DVec3::new(m[0][2], m[1][2], m[2][2]),
    )
}

/// Copies a glam [`DMat3`] into a [`Mat3`] element for element (`out[i][j] == m.col(j)[i]`),
/// **without** transposing (inverse of [`mat3_to_dmat3`]).
pub fn dmat3_to_mat3(m: &DMat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (j, col) in [m.x_axis, m.y_axis, m.z_axis].iter().enumerate() {
        out[0][j] = col.x;
        out[1][j] = col.y;
        out[2][j] = col.z;
    }
    out
}

/// The column-vector quaternion of an H3.6M **row-vector** rotation matrix (`Mᵀ` as a quaternion).
/// The matrix is re-orthonormalised by glam's conversion; it should be (close to) a rotation.
pub fn row_mat3_to_quat(m: &Mat3) -> DQuat {
    DQuat::from_mat3(&mat3_to_dmat3(m).transpose()).normalize()
}

/// The H3.6M **row-vector** matrix of a column-vector quaternion (inverse of [`row_mat3_to_quat`]).
pub fn quat_to_row_mat3(q: DQuat) -> Mat3 {
    dmat3_to_mat3(&DMat3::from_quat(q).transpose())
}

/// The unit quaternion (column-vector convention) of the rotation about `r` by `|r|` radians:
/// the plain axis-angle reading of a scaled axis (exact, no ε).
///
/// This is **not** the rotation an H3.6M exp-map frame gives its joint: the data's row-vector FK
/// makes that the inverse, [`h36m_joint_quat`].
pub fn axis_angle_to_quat(r: [f64; 3]) -> DQuat {
    DQuat::from_scaled_axis(DVec3::from_array(r))
}

/// The local rotation (column-vector quaternion, as glam, engines and BVH use it) of a joint whose
/// H3.6M exp-map triple is `r`: the rotation about `r` by `-|r|`, i.e. the conjugate of
/// [`axis_angle_to_quat`]`(r)`. It is `row_mat3_to_quat(&expmap2rotmat(r))` without the
/// evaluation code's float32-ε (see the module docs).
pub fn h36m_joint_quat(r: [f64; 3]) -> DQuat {
    axis_angle_to_quat(r).conjugate()
}

/// The H3.6M exp-map triple of a joint whose local (column-vector) rotation is `q`: inverse of
/// [`h36m_joint_quat`] for angles below π.
pub fn h36m_joint_expmap(q: DQuat) -> [f64; 3] {
    quat_to_axis_angle(q.conjugate())
}

/// Unit quaternion to scaled axis (axis times angle) with the angle in `[0, π]` (the quaternion
/// is taken with `w >= 0`). Inverse of [`axis_angle_to_quat`] for `|r| < π`.
pub fn quat_to_axis_angle(q: DQuat) -> [f64; 3] {
    let q = if q.w < 0.0 { -q } else { q };
    let v = DVec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-300 {
        // Identity (or numerically so): the small-angle limit of 2·v/s·atan2(s, w) is 2·v/w.
        return (v * (2.0 / q.w.max(1e-300))).to_array();
    }
    let angle = 2.0 * s.atan2(q.w);
    (v * (angle / s)).to_array()
}

/// An Euler angle axis sequence, named as BVH lists its rotation channels.
///
/// Convention: angles `[a, b, c]` are intrinsic, applied in the listed order, column vectors:
/// `M = R_first(a) · R_second(b) · R_third(c)`. The 6 Tait-Bryan orders (three distinct axes) are
/// the ones BVH uses; the 6 proper Euler orders (first axis repeated) are here for completeness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EulerOrder {
    /// `Rx · Ry · Rz`
    XYZ,
    /// `Rx · Rz · Ry`
    XZY,
    /// `Ry · Rx · Rz`
    YXZ,
    /// `Ry · Rz · Rx`
    YZX,
    /// `Rz · Rx · Ry`
    ZXY,
    /// `Rz · Ry · Rx`
    ZYX,
    /// `Rx · Ry · Rx`
    XYX,
    /// `Rx · Rz · Rx`
    XZX,
    /// `Ry · Rx · Ry`
    YXY,
    /// `Ry · Rz · Ry`
    YZY,
    /// `Rz · Rx · Rz`
    ZXZ,
    /// `Rz · Ry · Rz`
    ZYZ,
}

impl EulerOrder {
    /// All 12 orders.
    pub const ALL: [EulerOrder; 12] = [
        EulerOrder::XYZ,
        EulerOrder::XZY,
        EulerOrder::YXZ,
        EulerOrder::YZX,
        EulerOrder::ZXY,
        EulerOrder::ZYX,
        EulerOrder::XYX,
        EulerOrder::XZX,
        EulerOrder::YXY,
        EulerOrder::YZY,
        EulerOrder::ZXZ,
        EulerOrder::ZYZ,
    ];

    /// The 6 Tait-Bryan orders (three distinct axes), the ones BVH files use.
    pub const TAIT_BRYAN: [EulerOrder; 6] = [
        EulerOrder::XYZ,
        EulerOrder::XZY,
        EulerOrder::YXZ,
        EulerOrder::YZX,
        EulerOrder::ZXY,
        EulerOrder::ZYX,
    ];

    /// The axes in application order, 0 = x, 1 = y, 2 = z.
    pub fn axes(self) -> [usize; 3] {
        match self {
            EulerOrder::XYZ => [0, 1, 2],
            EulerOrder::XZY => [0, 2, 1],
            EulerOrder::YXZ => [1, 0, 2],
            EulerOrder::YZX => [1, 2, 0],
            EulerOrder::ZXY => [2, 0, 1],
            EulerOrder::ZYX => [2, 1, 0],
            EulerOrder::XYX => [0, 1, 0],
            EulerOrder::XZX => [0, 2, 0],
            EulerOrder::YXY => [1, 0, 1],
            EulerOrder::YZY => [1, 2, 1],
            EulerOrder::ZXZ => [2, 0, 2],
            EulerOrder::ZYZ => [2, 1, 2],
        }
    }

    /// The Tait-Bryan order with these three distinct axes (0 = x, 1 = y, 2 = z), if any.
    /// (A BVH joint with rotation channels `Z X Y` has order `from_axes([2, 0, 1])`.)
    pub fn from_axes(axes: [usize; 3]) -> Option<EulerOrder> {
        EulerOrder::ALL.into_iter().find(|o| o.axes() == axes)
    }

    /// The equivalent intrinsic glam [`EulerRot`].
    pub fn to_glam(self) -> EulerRot {
        match self {
            EulerOrder::XYZ => EulerRot::XYZ,
            EulerOrder::XZY => EulerRot::XZY,
            EulerOrder::YXZ => EulerRot::YXZ,
            EulerOrder::YZX => EulerRot::YZX,
            EulerOrder::ZXY => EulerRot::ZXY,
            EulerOrder::ZYX => EulerRot::ZYX,
            EulerOrder::XYX => EulerRot::XYX,
            EulerOrder::XZX => EulerRot::XZX,
            EulerOrder::YXY => EulerRot::YXY,
            EulerOrder::YZY => EulerRot::YZY,
            EulerOrder::ZXZ => EulerRot::ZXZ,
            EulerOrder::ZYZ => EulerRot::ZYZ,
        }
    }
}

/// Unit quaternion of the elementary rotation by `angle` about axis `axis` (0 = x, 1 = y, 2 = z).
///
/// # Panics
/// If `axis > 2`.
pub fn axis_quat(axis: usize, angle: f64) -> DQuat {
    match axis {
        0 => DQuat::from_rotation_x(angle),
        1 => DQuat::from_rotation_y(angle),
        2 => DQuat::from_rotation_z(angle),
        _ => panic!("axis index {axis} is not 0, 1 or 2"),
    }
}

/// Euler angles (radians, see [`EulerOrder`] for the convention) to a unit quaternion.
pub fn euler_to_quat(order: EulerOrder, angles: [f64; 3]) -> DQuat {
    DQuat::from_euler(order.to_glam(), angles[0], angles[1], angles[2])
}

/// Unit quaternion to Euler angles (radians) in `order`; inverse of [`euler_to_quat`] away from
/// gimbal lock (middle angle in `(-π/2, π/2)` for Tait-Bryan, in `(0, π)` for proper orders).
pub fn quat_to_euler(order: EulerOrder, q: DQuat) -> [f64; 3] {
    let (a, b, c) = q.to_euler(order.to_glam());
    canonical_proper(order, [a, b, c])
}

/// For proper orders (first axis repeated), the equivalent angles with the middle one in
/// `[0, π]`: `R_i(a) R_j(b) R_i(c) = R_i(a + π) R_j(-b) R_i(c + π)`. Tait-Bryan angles pass.
fn canonical_proper(order: EulerOrder, [a, b, c]: [f64; 3]) -> [f64; 3] {
    let [first, _, last] = order.axes();
    if first != last || b >= 0.0 {
        return [a, b, c];
    }
    let wrap = |x: f64| {
        let y = x + std::f64::consts::PI;
        if y > std::f64::consts::PI {
            y - 2.0 * std::f64::consts::PI
        } else {
            y
        }
    };
    [wrap(a), -b, wrap(c)]
}

/// Euler angles (radians) to a column-vector rotation matrix.
pub fn euler_to_dmat3(order: EulerOrder, angles: [f64; 3]) -> DMat3 {
    DMat3::from_euler(order.to_glam(), angles[0], angles[1], angles[2])
}

/// Column-vector rotation matrix to Euler angles (radians) in `order`.
pub fn dmat3_to_euler(order: EulerOrder, m: &DMat3) -> [f64; 3] {
    let (a, b, c) = m.to_euler(order.to_glam());
    canonical_proper(order, [a, b, c])
}

/// The exp-map `r` with `expmap2rotmat(r)^times == m`, solving the float32-epsilon formula
/// exactly, so that integrating and differentiating root deltas round-trips to ~1e-12 at every
/// angle scale (also for angles near or below ε, where the formula is far from Rodrigues').
///
/// `expmap2rotmat(r)` keeps the axis of `r` exactly (only the angle is deformed by ε), so the
/// axis comes from the exact logarithm of `m` and the angle from a secant solve of the scalar
/// equation `angle(expmap2rotmat(θ · axis)^times) = angle(m)`. For `times > 1` the rotation of
/// one step must stay below `π / times` (root deltas are a few degrees at most).
pub fn rotmat_to_expmap_pow(m: &Mat3, times: usize) -> [f64; 3] {
    let times = times.max(1);
    let target = log_rotation(m);
    let psi_t = (target[0] * target[0] + target[1] * target[1] + target[2] * target[2]).sqrt();
    if psi_t == 0.0 {
        return [0.0; 3];
    }
    let axis = [target[0] / psi_t, target[1] / psi_t, target[2] / psi_t];
    let at = |theta: f64| [axis[0] * theta, axis[1] * theta, axis[2] * theta];
    // Signed angle of expmap2rotmat(θ·axis)^times about `axis`, minus the target angle.
    let residual = |theta: f64| {
        let e = expmap2rotmat(at(theta));
        let mut p = e;
        for _ in 1..times {
            p = mat3_mul(&p, &e);
        }
        let got = log_rotation(&p);
        got[0] * axis[0] + got[1] * axis[1] + got[2] * axis[2] - psi_t
    };
    let mut x0 = psi_t / times as f64;
    let mut f0 = residual(x0);
    if f0 == 0.0 {
        return at(x0);
    }
    // First step assumes the Rodrigues slope `times`; then secant steps.
    let mut x1 = x0 - f0 / times as f64;
    let mut f1 = residual(x1);
    let mut best = if f1.abs() < f0.abs() { x1 } else { x0 };
    let mut best_f = f1.abs().min(f0.abs());
    for _ in 0..60 {
        if f1 == 0.0 || f1 == f0 {
            break;
        }
        let x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
        if !x2.is_finite() || x2 == x1 {
            break;
        }
        x0 = x1;
        f0 = f1;
        x1 = x2;
        f1 = residual(x1);
        if f1.abs() < best_f {
            best = x1;
            best_f = f1.abs();
        }
    }
    at(best)
}

/// Logarithm of a (near-)rotation matrix in the convention of [`expmap2rotmat`] without its ε:
/// the `r` with exact Rodrigues `I + sin θ K + (1 - cos θ) K² = m`, angle in `[0, π]`.
fn log_rotation(m: &Mat3) -> [f64; 3] {
    // expmap2rotmat read as a column-vector matrix is the rotation about r: use glam's robust
    // matrix -> quaternion conversion on the element-wise copy (no transpose).
    let q = glam::DQuat::from_mat3(&mat3_to_dmat3(m)).normalize();
    quat_to_axis_angle(q)
}

/// Inverse of a 3x3 matrix (adjugate / determinant); `None` if singular.
pub fn mat3_inverse(m: &Mat3) -> Option<Mat3> {
    let c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    let c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    let c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if det.abs() < 1e-300 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    Some([
        [
            c00 * inv_det,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv_det,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv_det,
        ],
        [
            c01 * inv_det,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv_det,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv_det,
        ],
        [
            c02 * inv_det,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv_det,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv_det,
        ],
    ])
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// `(exp-map, expmap2rotmat, rotmat2euler)` computed by the reference numpy code.
    #[allow(clippy::type_complexity)]
    const GOLDEN: [([f64; 3], Mat3, [f64; 3]); 7] = [
        (
            [0.0, 0.0, 0.0],
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [0.0, -0.0, 0.0],
        ),
        (
            [1e-09, -2e-09, 3e-09],
            [
                [1.0, -9.129634573715653e-11, -6.086423049143769e-11],
                [9.129634573715653e-11, 1.0, -3.0432115245718846e-11],
                [6.086423049143769e-11, 3.0432115245718846e-11, 1.0],
            ],
            [
                -3.0432115245718846e-11,
                6.086423049143769e-11,
                -9.129634573715653e-11,
            ],
        ),
        (
            [0.1, -0.2, 0.3],
            [
                [
                    0.9357548442149679,
                    -0.30293261373923314,
                    -0.1805400238978114,
                ],
                [
                    0.28316487349768477,
                    0.9505806493961292,
                    -0.12733452490180883,
                ],
                [0.2101916342601339, 0.06803130417716383, 0.9752903246980645],
            ],
            [
                -0.12982628301821764,
                0.18153546963067724,
                -0.3130834742286407,
            ],
        ),
        (
            [-1.2, 0.4, 2.0],
            [
                [
                    -0.2734862247738108,
                    -0.7384057533655652,
                    -0.6164105841911734,
                ],
                [0.44452431687930116, -0.6653281400888293, 0.5997802181453467],
                [
                    -0.8529965982401467,
                    -0.10997782400157324,
                    0.5101976058562266,
                ],
            ],
            [0.8659302841397992, 0.6641761019840882, -1.9255050899475423],
        ),
        (
            [3.0, 0.1, -0.5],
            [
                [
                    0.9439807828216752,
                    0.08080704661757745,
                    -0.31995389374643346,
                ],
                [
                    0.048468069947787525,
                    -0.99299138038271,
                    -0.10778985638981683,
                ],
                [-0.3264216890803915, 0.08624400362892268, -0.941281333756564],
            ],
            [-3.0275753457175925, 0.32568082250578, 0.08539425032871426],
        ),
        (
            [0.0, 0.0, FRAC_PI_2],
            [
                [1.517819644414331e-07, -0.999999924109015, 0.0],
                [0.999999924109015, 1.517819644414331e-07, 0.0],
                [0.0, 0.0, 1.0],
            ],
            [0.0, -0.0, -1.5707961750129207],
        ),
        (
            [-0.31415, 2.5, -1.1],
            [
                [
                    -0.898916341688853,
                    -0.046955379978372846,
                    0.4355964716323828,
                ],
                [-0.35287341944626066, 0.6668775804673363, -0.656318967375106],
                [-0.259671799885544, -0.7436863783740486, -0.6160364090918888],
            ],
            [-2.32454522921576, -0.45070081228000336, -3.0894045456893227],
        ),
    ];

    fn close3(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    fn dmat_close(a: &DMat3, b: &DMat3, tol: f64) -> bool {
        a.abs_diff_eq(*b, tol)
    }

    #[test]
    fn expmap2rotmat_and_rotmat2euler_match_the_reference_code() {
        for (r, want_r, want_e) in GOLDEN {
            let got = expmap2rotmat(r);
            for i in 0..3 {
                assert!(
                    close3(got[i], want_r[i], 1e-15),
                    "{r:?}: {got:?} vs {want_r:?}"
                );
            }
            let e = rotmat2euler(&want_r);
            assert!(close3(e, want_e, 1e-15), "{r:?}: {e:?} vs {want_e:?}");
        }
    }

    #[test]
    fn epsilon_is_float32_epsilon() {
        assert_eq!(EXPMAP_EPS, 2f64.powi(-23));
    }

    #[test]
    fn rotmat2euler_exact_gimbal_lock_branches() {
        // R[0][2] == -1 exactly: E2 = π/2, E3 = 0, E1 = atan2(R01, R02).
        let m = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        let e = rotmat2euler(&m);
        assert_eq!(e, [0.0f64.atan2(-1.0), FRAC_PI_2, 0.0]);
        let m = [[0.0, 0.5, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]];
        let e = rotmat2euler(&m);
        assert_eq!(e, [0.5f64.atan2(1.0), -FRAC_PI_2, 0.0]);
        // One ulp away from -1 takes the general branch (no tolerance in the reference code).
        let m = [
            [0.0, 0.0, -1.0 + f64::EPSILON],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let e = rotmat2euler(&m);
        assert!(e[1] < FRAC_PI_2 && e[1] > 1.5);
    }

    #[test]
    fn protocol_frame_conversion_zeroes_root_and_converts_every_triple() {
        let frame: Vec<f64> = (0..99).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut out = vec![f64::NAN; 99];
        expmap_frame_to_euler_protocol(&frame, &mut out);
        assert!(out[..6].iter().all(|&v| v == 0.0));
        for k in (6..99).step_by(3) {
            let e = rotmat2euler(&expmap2rotmat([frame[k], frame[k + 1], frame[k + 2]]));
            assert_eq!(&out[k..k + 3], &e);
        }
        // Other widths (CMU 117) work too.
        let frame = vec![0.1; 117];
        let mut out = vec![0.0; 117];
        expmap_frame_to_euler_protocol(&frame, &mut out);
        assert!(out[6..].iter().all(|v| v.is_finite() && *v != 0.0));
    }

    #[test]
    fn euler_order_convention_is_intrinsic_column_vector_in_listed_order() {
        let (a, b, c) = (0.3, -0.7, 1.1);
        let rx = DMat3::from_rotation_x;
        let ry = DMat3::from_rotation_y;
        let rz = DMat3::from_rotation_z;
        let elementary = [rx, ry, rz];
        for order in EulerOrder::ALL {
            let [i, j, k] = order.axes();
            let want = elementary[i](a) * elementary[j](b) * elementary[k](c);
            assert!(
                dmat_close(&euler_to_dmat3(order, [a, b, c]), &want, 1e-14),
                "{order:?}"
            );
            let q = axis_quat(i, a) * axis_quat(j, b) * axis_quat(k, c);
            assert!(
                euler_to_quat(order, [a, b, c]).abs_diff_eq(q, 1e-14),
                "{order:?}"
            );
            assert_eq!(EulerOrder::from_axes(order.axes()), Some(order));
        }
    }

    #[test]
    fn row_and_column_conventions_are_transposes() {
        let r = [0.4, -0.9, 0.2];
        let row = expmap2rotmat(r);
        // Element-wise copy round trips.
        assert_eq!(dmat3_to_mat3(&mat3_to_dmat3(&row)), row);
        // Read as a column-vector matrix, Rodrigues is the rotation about r ...
        let col = DMat3::from_quat(axis_angle_to_quat(r));
        assert!(dmat_close(&mat3_to_dmat3(&row), &col, 1e-6));
        // ... so the row-vector rotation is its inverse.
        assert!(row_mat3_to_quat(&row).abs_diff_eq(axis_angle_to_quat([-0.4, 0.9, -0.2]), 1e-6));
        // And a row vector times R equals Rᵀ times the column vector.
        let v = [1.0, 2.0, 3.0];
        let a = vec_mul_mat3(v, &row);
        let b = mat3_to_dmat3(&row).transpose() * DVec3::from_array(v);
        assert!(close3(a, b.to_array(), 1e-12));
        let back = quat_to_row_mat3(row_mat3_to_quat(&row));
        for i in 0..3 {
            assert!(close3(back[i], row[i], 1e-6));
        }
    }

    #[test]
    fn quat_to_expmap_handles_identity_and_sign() {
        assert_eq!(quat_to_axis_angle(DQuat::IDENTITY), [0.0, 0.0, 0.0]);
        let q = axis_angle_to_quat([0.0, 1.0, 0.0]);
        assert!(close3(quat_to_axis_angle(-q), [0.0, 1.0, 0.0], 1e-15));
        let q = axis_angle_to_quat([0.0, 0.0, PI]);
        let r = quat_to_axis_angle(q);
        assert!((r[2].abs() - PI).abs() < 1e-12);
    }

    fn angle() -> impl Strategy<Value = f64> {
        -PI..PI
    }

    fn expmap_in_ball(max: f64) -> impl Strategy<Value = [f64; 3]> {
        (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0.0..max).prop_filter_map(
            "non-zero axis",
            |(x, y, z, a)| {
                let n = (x * x + y * y + z * z).sqrt();
                (n > 1e-3).then(|| [x / n * a, y / n * a, z / n * a])
            },
        )
    }

    proptest! {
        #[test]
        fn euler_quat_round_trip_all_orders(a in angle(), b in -1.5f64..1.5, c in angle(), proper_b in 0.05f64..3.09) {
            for order in EulerOrder::ALL {
                let mid = if order.axes()[0] == order.axes()[2] { proper_b } else { b };
                let q = euler_to_quat(order, [a, mid, c]);
                let back = quat_to_euler(order, q);
                prop_assert!(close3(back, [a, mid, c], 1e-9), "{:?}: {:?} vs {:?}", order, back, [a, mid, c]);
                let m = euler_to_dmat3(order, [a, mid, c]);
                prop_assert!(close3(dmat3_to_euler(order, &m), [a, mid, c], 1e-8));
            }
        }

        #[test]
        fn expmap_quat_round_trip(r in expmap_in_ball(PI - 1e-6)) {
            let back = quat_to_axis_angle(axis_angle_to_quat(r));
            prop_assert!(close3(back, r, 1e-12), "{:?} vs {:?}", back, r);
        }

        #[test]
        fn expmap2rotmat_is_orthonormal(r in expmap_in_ball(2.0 * PI)) {
            let m = mat3_to_dmat3(&expmap2rotmat(r));
            let mtm = m.transpose() * m;
            prop_assert!(dmat_close(&mtm, &DMat3::IDENTITY, 1e-6));
            prop_assert!((m.determinant() - 1.0).abs() < 1e-6);
        }

        #[test]
        fn expmap2rotmat_matches_glam_rotation(r in expmap_in_ball(2.0 * PI)) {
            let m = mat3_to_dmat3(&expmap2rotmat(r));
            prop_assert!(dmat_close(&m, &DMat3::from_quat(axis_angle_to_quat(r)), 1e-6));
        }

        #[test]
        fn rotmat2euler_is_glam_zyx_of_the_transpose(r in expmap_in_ball(PI)) {
            let row = expmap2rotmat(r);
            let [e1, e2, e3] = rotmat2euler(&row);
            // Near gimbal lock the ~1e-7 non-orthonormality of expmap2rotmat is amplified.
            prop_assume!(e2.cos() > 0.1);
            let col = DMat3::from_euler(EulerRot::ZYX, e3, e2, e1);
            prop_assert!(dmat_close(&col, &mat3_to_dmat3(&row).transpose(), 1e-5));
            // Equivalently R = Rx(-E1) Ry(-E2) Rz(-E3) read element-wise.
            let alt = euler_to_dmat3(EulerOrder::XYZ, [-e1, -e2, -e3]);
            prop_assert!(dmat_close(&alt, &mat3_to_dmat3(&row), 1e-5));
        }
    }
}
