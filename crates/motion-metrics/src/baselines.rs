//! The baselines and positions of the H3.6M protocol: the zero-velocity forecasts (the angle
//! protocols' and the root-aware one) and world joint positions of protocol frames.
use ndarray::{s, Array2, Array3, ArrayView2};

use motion_core::protocol::ROOT_STEP_25HZ;

/// World joint positions (mm, `T x J x 3`) of protocol frames (25 Hz H3.6M exp-map frames, root
/// deltas each applied [`motion_core::protocol::ROOT_STEP_25HZ`] times, integrated from the first frame).
pub fn protocol_positions(
    skeleton: &motion_core::Skeleton,
    frames: ArrayView2<'_, f64>,
) -> Result<Array3<f64>, motion_core::MotionError> {
    motion_core::kinematics::expmap_positions(
        skeleton,
        frames,
        motion_core::RootEncoding::Deltas,
        ROOT_STEP_25HZ,
    )
}

/// The zero-velocity baseline of the angle protocols (Euler error, NPSS): the last seed frame
/// repeated `horizon` times, dims 0..5 included.
///
/// Those protocols drop dims 0..5, so this is Gopalakrishnan et al. 2019 Table 6's baseline exactly. Do not use it
/// where the root is integrated (world positions, NDMS, speed, drift): in the H3.6M encoding
/// dims 0..5 are per-frame root **deltas**, so repeating them keeps the seed's last root velocity
/// and yaw rate — a frozen pose gliding and turning. Use [`zero_velocity_held_root`] there.
///
/// # Panics
/// If `seed` has no frames.
pub fn zero_velocity(seed: ArrayView2<'_, f64>, horizon: usize) -> Array2<f64> {
    let last = seed.row(seed.nrows() - 1);
    let mut out = Array2::zeros((horizon, seed.ncols()));
    for mut row in out.rows_mut() {
        row.assign(&last);
    }
    out
}

/// The zero-velocity baseline for root-aware measures of H3.6M frames (root deltas in dims 0..5):
/// the last seed pose repeated `horizon` times with zero root translation and rotation deltas,
/// so the integrated root stays exactly where the seed left it (no translation, no turning).
///
/// Its joint angles (dims 6..) equal [`zero_velocity`]'s, so the angle protocols score the two
/// identically.
///
/// # Panics
/// If `seed` has no frames or fewer than 6 dims.
pub fn zero_velocity_held_root(seed: ArrayView2<'_, f64>, horizon: usize) -> Array2<f64> {
    let mut out = zero_velocity(seed, horizon);
    out.slice_mut(s![.., ..6]).fill(0.0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use motion_core::protocol::SEED_FRAMES;
    use ndarray::Axis;

    #[test]
    fn zero_velocity_repeats_the_last_seed_frame_and_the_held_root_variant_zeroes_the_root() {
        let seed = Array2::from_shape_fn((SEED_FRAMES, 9), |(t, j)| (t * 10 + j) as f64);
        let zv = zero_velocity(seed.view(), 4);
        assert!(zv
            .rows()
            .into_iter()
            .all(|r| r == seed.row(SEED_FRAMES - 1)));
        // The root-held variant: the same angles, zero root deltas.
        let held = zero_velocity_held_root(seed.view(), 4);
        assert!(held.slice(s![.., ..6]).iter().all(|&v| v == 0.0));
        assert_eq!(held.slice(s![.., 6..]), zv.slice(s![.., 6..]));
    }

    #[test]
    fn the_root_held_baseline_does_not_move_the_integrated_root() {
        use motion_core::kinematics::expmap_positions;
        use motion_core::{RootEncoding, Skeleton};
        // A seed that walks and turns: constant root deltas, moving joints.
        let seed = Array2::from_shape_fn((SEED_FRAMES, 99), |(t, d)| match d {
            0 => 12.0,
            2 => 3.0,
            4 => 0.002,
            _ => 0.3 * ((t as f64) * 0.2 + d as f64).sin(),
        });
        let skeleton = Skeleton::h36m();
        let root_path = |forecast: Array2<f64>| {
            let joined = ndarray::concatenate(Axis(0), &[seed.view(), forecast.view()]).unwrap();
            let p = expmap_positions(&skeleton, joined.view(), RootEncoding::Deltas, 2).unwrap();
            p.slice(s![SEED_FRAMES - 1.., 0, ..]).to_owned()
        };
        let held = root_path(zero_velocity_held_root(seed.view(), 300));
        let first = held.row(0).to_owned();
        for row in held.rows() {
            assert_eq!(row, first, "the root moved");
        }
        // The angle protocol's baseline keeps the seed's root velocity: it glides (about 24 mm a
        // frame on a wide curve).
        let glide = root_path(zero_velocity(seed.view(), 300));
        let moved = (&glide.row(300) - &glide.row(0))
            .mapv(|v| v * v)
            .sum()
            .sqrt();
        assert!(moved > 1000.0, "{moved}");
    }
}
