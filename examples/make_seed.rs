//! Writes `examples/walk_seed.bvh`: a procedural walking gait on the H3.6M skeleton, made by this
//! project's own code (no clip of motion-capture data involved), as a seed for `motion-cli predict`.
//!
//! ```text
//! cargo run --example make_seed            # writes examples/walk_seed.bvh
//! cargo run --example make_seed -- out.bvh # or anywhere else
//! ```
//!
//! How it is made:
//! - Rest pose: the H3.6M training-set **mean frame** (the `norm.mean` statistic stored in
//!   `weights/vgru_d_multi.safetensors`, rounded to 3 decimals), so that every joint angle lies
//!   where the model has seen joint angles: H3.6M's local exp-maps are far from zero at rest
//!   (shoulders turned ~107°, elbows bent, neck and head compensating).
//! - Gait (3 s at 25 Hz, a 1.1 s stride): the hips swing forward and back (exp-map x, ±0.32 rad),
//!   the knees bend early in each swing (x, down to -0.85 rad), the feet roll, the arms swing
//!   against the legs about whichever local axis moves the hand forward most (found by forward
//!   kinematics), the elbows (less bent than the mean) flex a little; the left side half a
//!   stride after the right.
//! - Root: one constant orientation that stands the mean pose upright (head above hips) and turns
//!   its toes towards +z, then translation deltas of 0.7 m/s forward with a 25 mm bob twice per
//!   stride, written as the H3.6M per-50 Hz-frame deltas in the root's frame (each 25 Hz frame's
//!   delta counts twice), with the feet's lowest point on y = 0.
//!
//! The frames go through `expmap_to_bvh`, exactly the path a recorded H3.6M clip takes.
use std::f64::consts::{PI, TAU};
use std::path::PathBuf;

use motion_core::formats::bvh::write_bvh;
use motion_core::formats::expmap_bvh::expmap_to_bvh;
use motion_core::kinematics::expmap_positions;
use motion_core::motion::{Motion, RootEncoding};
use motion_core::root::rotmat_to_expmap_pow;
use motion_core::rotation::{mat3_mul, mat3_transpose, vec_mul_mat3, Mat3};
use motion_core::skeleton::{Skeleton, H36M_SOURCE_FPS};
use ndarray::{Array2, Array3};

/// Frame rate of the seed (the shipped model's).
const FPS: f64 = 25.0;
/// 3 s: more than the default model's 50 seed frames.
const FRAMES: usize = 75;
/// Walking speed, mm/s.
const SPEED: f64 = 700.0;
/// One stride (two steps), s.
const STRIDE: f64 = 1.1;
/// Vertical bob amplitude, mm.
const BOB: f64 = 25.0;

/// The H3.6M training-set mean frame (see the module docs); dims 0..5 (root deltas) unused.
#[rustfmt::skip]
const MEAN: [f64; 99] = [
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.449, 0.006, -0.093, -0.716, 0.0, 0.0, -0.077, 0.110, -0.268, 0.363, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.467, -0.097, -0.024, -0.713, 0.0, 0.0, -0.011, -0.080, 0.069, 0.364, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.052, -0.048, -0.087, -0.276, 0.016, 0.015, -0.711, 0.002, -0.099, 1.199, -0.037, 0.044,
    0.0, 0.0, 0.0,
    -0.080, -0.030, 1.874, -0.442, -0.156, 0.522, -1.280, 0.0, 0.0, 0.103, 0.0, -0.464,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    -0.084, 0.085, -1.901, -0.446, -0.071, -0.504, -1.360, 0.0, 0.0, -0.013, -0.107, 0.395,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];

/// H3.6M joint indices used here.
const RIGHT_UP_LEG: usize = 1;
const LEFT_UP_LEG: usize = 6;
const LEFT_ARM: usize = 17;
const LEFT_FORE_ARM: usize = 18;
const LEFT_HAND: usize = 19;
const RIGHT_ARM: usize = 25;
const RIGHT_FORE_ARM: usize = 26;
const RIGHT_HAND: usize = 27;
const HEAD: usize = 14;
const RIGHT_FOOT: usize = 3;
const RIGHT_TOE: usize = 4;
const LEFT_FOOT: usize = 8;
const LEFT_TOE: usize = 9;

/// World joint positions of one frame (root at the origin, identity or given root rotation).
fn fk(frame: &[f64]) -> Array3<f64> {
    let frames = Array2::from_shape_vec((1, 99), frame.to_vec()).expect("99 dims");
    expmap_positions(&Skeleton::h36m(), frames.view(), RootEncoding::Deltas, 1).expect("99 dims")
}

fn joint(p: &Array3<f64>, j: usize) -> [f64; 3] {
    [0, 1, 2].map(|a| p[[0, j, a]])
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The exp-map component of `joint` (and its sign) whose increase moves `probe` forward (+z in
/// the world of `pose`) the most.
fn forward_axis(pose: &[f64], joint: usize, probe: usize) -> (usize, f64) {
    let base = joint_of(pose, probe);
    (0..3)
        .map(|axis| {
            let mut moved = pose.to_vec();
            moved[3 + 3 * joint + axis] += 0.05;
            let dz = joint_of(&moved, probe)[2] - base[2];
            (axis, dz)
        })
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|(axis, dz)| (axis, dz.signum()))
        .expect("three axes")
}

fn joint_of(pose: &[f64], j: usize) -> [f64; 3] {
    joint(&fk(pose), j)
}

/// Column-convention rotation about unit `k` by `angle` (Rodrigues).
fn rodrigues(k: [f64; 3], angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    let skew = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let id = if i == j { 1.0 } else { 0.0 };
            m[i][j] = id + s * skew[i][j] + (1.0 - c) * (k[i] * k[j] - id);
        }
    }
    m
}

/// The row-convention root rotation that stands `pose` upright (head above hips) with its toes
/// towards +z.
fn upright_root(pose: &[f64]) -> Mat3 {
    let p = fk(pose);
    let up = sub(joint(&p, HEAD), joint(&p, 0));
    let n = (up[0] * up[0] + up[1] * up[1] + up[2] * up[2]).sqrt();
    let up = up.map(|v| v / n);
    let axis = [-up[2], 0.0, up[0]]; // up x y
    let s = (axis[0] * axis[0] + axis[2] * axis[2]).sqrt();
    let tilt = if s > 1e-12 {
        rodrigues(axis.map(|v| v / s), up[1].clamp(-1.0, 1.0).acos())
    } else {
        rodrigues([1.0, 0.0, 0.0], 0.0)
    };
    // Heading after the tilt: the mean toe direction, turned onto +z about y.
    let toes = [(RIGHT_FOOT, RIGHT_TOE), (LEFT_FOOT, LEFT_TOE)];
    let mut forward = [0.0; 3];
    for (foot, toe) in toes {
        let d = sub(joint(&p, toe), joint(&p, foot));
        for (f, v) in forward.iter_mut().zip(d) {
            *f += v;
        }
    }
    let forward = vec_mul_mat3(forward, &mat3_transpose(&tilt)); // tilt · forward
    let yaw = -forward[0].atan2(forward[2]);
    let column = mat3_mul(&rodrigues([0.0, 1.0, 0.0], yaw), &tilt);
    mat3_transpose(&column)
}

/// Joint exp-maps (dims 6..98) of the gait at time `t`; dims 0..5 are left 0.
fn pose(t: f64, arm_axes: [(usize, f64); 4]) -> Vec<f64> {
    let phase = TAU * t / STRIDE;
    let mut frame = MEAN.to_vec();
    frame[..6].fill(0.0);
    for (up_leg, phase) in [(RIGHT_UP_LEG, phase), (LEFT_UP_LEG, phase + PI)] {
        let x = |j: usize| 3 + 3 * j;
        frame[x(up_leg)] = 0.12 + 0.32 * phase.sin();
        frame[x(up_leg + 1)] = -(0.12 + 0.73 * (phase + 0.7).cos().max(0.0).powi(2));
        frame[x(up_leg + 2)] += 0.15 * (phase - 2.2).sin();
    }
    // Elbows less bent than the all-actions mean (eating, phoning, ...) for walking.
    frame[3 + 3 * LEFT_FORE_ARM] = -0.6;
    frame[3 + 3 * RIGHT_FORE_ARM] = -0.6;
    // Arms swing against the legs: the left arm with the right leg.
    let [(la, ls), (lf, lfs), (ra, rs), (rf, rfs)] = arm_axes;
    frame[3 + 3 * LEFT_ARM + la] += ls * 0.3 * phase.sin();
    frame[3 + 3 * LEFT_FORE_ARM + lf] += lfs * 0.1 * (0.5 + 0.5 * phase.sin());
    frame[3 + 3 * RIGHT_ARM + ra] += rs * 0.3 * (phase + PI).sin();
    frame[3 + 3 * RIGHT_FORE_ARM + rf] += rfs * 0.1 * (0.5 + 0.5 * (phase + PI).sin());
    frame
}

/// The whole clip as H3.6M exp-map frames at 25 Hz.
fn walk() -> Array2<f64> {
    let mut rest = MEAN.to_vec();
    rest[..6].fill(0.0);
    let root = upright_root(&rest);
    let r0 = rotmat_to_expmap_pow(&root, 1);
    let mut upright = rest.clone();
    upright[3..6].copy_from_slice(&r0);
    let arm_axes = [
        forward_axis(&upright, LEFT_ARM, LEFT_HAND),
        forward_axis(&upright, LEFT_FORE_ARM, LEFT_HAND),
        forward_axis(&upright, RIGHT_ARM, RIGHT_HAND),
        forward_axis(&upright, RIGHT_FORE_ARM, RIGHT_HAND),
    ];
    let mut frames = Array2::zeros((FRAMES, 99));
    for k in 0..FRAMES {
        let mut frame = pose(k as f64 / FPS, arm_axes);
        frame[3..6].copy_from_slice(&r0);
        frames.row_mut(k).assign(&ndarray::Array1::from(frame));
    }
    // The lowest joint over the clip, with the root at the origin, goes to the floor.
    let still = expmap_positions(&Skeleton::h36m(), frames.view(), RootEncoding::Deltas, 2)
        .expect("99 dims");
    let lowest = still
        .iter()
        .skip(1)
        .step_by(3)
        .fold(f64::INFINITY, |m, &v| m.min(v));
    let height = -lowest;
    // Root translation: absolute on frame 0, then per-source-frame deltas in the root's frame.
    let step = (H36M_SOURCE_FPS / FPS).round();
    let inverse = mat3_transpose(&root);
    let position = |t: f64| {
        [
            0.0,
            height + BOB * (2.0 * TAU * t / STRIDE).cos(),
            SPEED * t,
        ]
    };
    for k in 0..FRAMES {
        let t = k as f64 / FPS;
        let d = if k == 0 {
            position(0.0)
        } else {
            let world = sub(position(t), position(t - 1.0 / FPS)).map(|v| v / step);
            vec_mul_mat3(world, &inverse)
        };
        for a in 0..3 {
            frames[[k, a]] = d[a];
        }
        if k > 0 {
            for a in 3..6 {
                frames[[k, a]] = 0.0; // the root keeps its orientation
            }
        }
    }
    frames
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/walk_seed.bvh")
        });
    let motion = Motion::h36m(walk(), FPS)?;
    let bvh = expmap_to_bvh(&motion)?;
    write_bvh(&out, &bvh)?;
    println!(
        "wrote {} ({} frames at {} Hz, {:.1} s)",
        out.display(),
        FRAMES,
        FPS,
        FRAMES as f64 / FPS
    );
    Ok(())
}
