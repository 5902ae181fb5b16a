//! Writes `examples/walk_seed.bvh`: a procedural walking gait on the H3.6M skeleton, made by this
//! project's own code (no motion-capture data involved), as a seed for `motion-cli predict`.
//!
//! ```text
//! cargo run --example make_seed            # writes examples/walk_seed.bvh
//! cargo run --example make_seed -- out.bvh # or anywhere else
//! ```
//!
//! The gait: 3 s at 25 Hz (75 frames), facing +z, the root moving forward at 0.7 m/s with a
//! 25 mm vertical bob twice per stride; hips, knees and ankles swing as sines of the stride phase
//! (left leg half a stride after the right), arms swing against the legs with slightly bent
//! elbows, the torso counter-rotates a little. Each joint's *world* orientation is built from
//! elementary rotations, its H3.6M local exp-map is `R_j = W_j · W_parent^T` (row vectors, as in
//! the data), and the root is written as the H3.6M per-50 Hz-frame translation deltas, so the clip
//! goes through exactly the path a recorded H3.6M clip takes (`expmap_to_bvh`).
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::PathBuf;

use motion_core::formats::bvh::write_bvh;
use motion_core::formats::expmap_bvh::expmap_to_bvh;
use motion_core::motion::Motion;
use motion_core::root::rotmat_to_expmap_pow;
use motion_core::rotation::{mat3_mul, mat3_transpose, Mat3};
use motion_core::skeleton::{Skeleton, H36M_SOURCE_FPS};
use ndarray::Array2;

/// Frame rate of the seed (the shipped model's).
const FPS: f64 = 25.0;
/// 3 s: more than the default model's 50 seed frames.
const FRAMES: usize = 75;
/// Walking speed, mm/s.
const SPEED: f64 = 700.0;
/// One stride (two steps), s.
const STRIDE: f64 = 1.1;
/// Hip height standing, mm (leg 897 mm + ankle height).
const HIP_HEIGHT: f64 = 940.0;
/// Vertical bob amplitude, mm.
const BOB: f64 = 25.0;

/// Elementary rotations, column-vector convention (`v' = M v`).
fn rx(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}
fn ry(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}
fn rz(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// World orientations (column convention) of one leg at stride phase `phase`.
/// Rx(a) turns the downward bones (`-y`) forward by `-a`, so flexion angles enter negated.
fn leg(phase: f64) -> [Mat3; 5] {
    let hip = 0.05 + 0.38 * phase.sin();
    // The knee bends most early in the swing (hip moving forward), little in stance.
    let knee = 0.12 + 0.75 * (phase + 0.7).cos().max(0.0).powi(2);
    let shank = hip - knee;
    // Foot: toes down at push-off, flat in stance, up before heel strike.
    let foot = 0.2 * (phase - 2.2).sin() - 0.05;
    [
        rx(-hip),   // UpLeg: thigh
        rx(-shank), // Leg: shank
        rx(foot),   // Foot: its child (ToeBase) is along +z
        rx(0.0),    // ToeBase: toes flat
        rx(0.0),    // ToeSite
    ]
}

/// World orientations of one arm: clavicle turned sideways (`side` = +1 left, -1 right), upper
/// arm hanging and swinging by `swing` rad forward, elbow bent.
fn arm(side: f64, swing: f64) -> [Mat3; 8] {
    let clavicle = rz(-side * FRAC_PI_2);
    // Rx(PI - b) turns the +y bones down and forward by b.
    let upper = mat3_mul(&rz(side * 0.08), &rx(PI - swing));
    let fore = rx(PI - swing - 0.35 - 0.15 * swing.max(0.0));
    [
        clavicle, upper, fore, fore, // Shoulder, Arm, ForeArm, Hand
        fore, fore, fore, fore, // HandThumb, ThumbSite, WristEnd, WristSite
    ]
}

/// The exp-map frame (99 dims) at time `t`; root dims are filled in by the caller.
fn pose(skeleton: &Skeleton, t: f64) -> Vec<f64> {
    let phase = TAU * t / STRIDE;
    let mut world = [[[0.0; 3]; 3]; 32];
    world[0] = rx(0.0);
    let right = leg(phase);
    let left = leg(phase + PI);
    world[1..6].copy_from_slice(&right);
    world[6..11].copy_from_slice(&left);
    // Torso: a slight forward lean and a counter-rotation against the hips' swing.
    let twist = 0.06 * phase.sin();
    let spine = mat3_mul(&ry(twist), &rx(0.05));
    world[11] = spine;
    world[12] = spine;
    world[13] = mat3_mul(&ry(-twist), &rx(-0.02)); // Neck: look ahead
    world[14] = world[13];
    world[15] = world[13];
    // Arms swing against the legs: the left arm with the right leg.
    let l = arm(1.0, 0.28 * phase.sin());
    let r = arm(-1.0, 0.28 * (phase + PI).sin());
    world[16..24].copy_from_slice(&l);
    world[24..32].copy_from_slice(&r);

    let mut frame = vec![0.0; 99];
    for j in 1..32 {
        let parent = skeleton.parent(j).expect("only joint 0 is the root");
        // Row-vector world rotations are the transposes; R_j = W_j · W_parent^T.
        let w_j = mat3_transpose(&world[j]);
        let w_p = mat3_transpose(&world[parent]);
        let local = mat3_mul(&w_j, &mat3_transpose(&w_p));
        let r = rotmat_to_expmap_pow(&local, 1);
        frame[3 + 3 * j..6 + 3 * j].copy_from_slice(&r);
    }
    frame
}

/// Absolute root position at time `t` (mm): forward along +z, bobbing twice per stride.
fn root_position(t: f64) -> [f64; 3] {
    let phase = TAU * t / STRIDE;
    [0.0, HIP_HEIGHT + BOB * (2.0 * phase).cos(), SPEED * t]
}

/// The whole clip as H3.6M exp-map frames at 25 Hz: root translation as per-50 Hz-frame deltas
/// (frame 0 holds the start position; each later 25 Hz frame's delta is applied twice).
fn walk() -> Array2<f64> {
    let skeleton = Skeleton::h36m();
    let step = (H36M_SOURCE_FPS / FPS).round();
    let mut frames = Array2::zeros((FRAMES, 99));
    for k in 0..FRAMES {
        let t = k as f64 / FPS;
        let mut frame = pose(&skeleton, t);
        let now = root_position(t);
        let delta = if k == 0 {
            now
        } else {
            let before = root_position((k - 1) as f64 / FPS);
            [0, 1, 2].map(|a| (now[a] - before[a]) / step)
        };
        frame[..3].copy_from_slice(&delta);
        frames.row_mut(k).assign(&ndarray::Array1::from(frame));
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
