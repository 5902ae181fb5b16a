//! Motion words: `κ` consecutive frames of the selected joints, normalized per word as the public
//! NDMS implementation does (its SMPL recipe applied to H3.6M, `metrics.md`):
//! 1. make the vertical axis the last one (y-up H3.6M: reorder to x, z, y);
//! 2. centre = midpoint of the first frame's left and right hip, with its vertical coordinate 0;
//! 3. rotate about the vertical so that the first frame's left→right hip direction in the floor
//!    plane points along +x;
//! 4. subtract the centre, rotate, keep the selected joints.
//!
//! A normalized word is flattened frame-major, then joint, then coordinate: `κ x joints x 3`.
use ndarray::ArrayView3;

use super::NdmsConfig;

/// Writes the normalized word of `positions` (`T x J x 3`) starting at frame `start` into `out`
/// (`config.word_len()` numbers). The caller guarantees `start + κ <= T` and valid joint indices.
pub fn normalize_word(
    positions: ArrayView3<'_, f64>,
    start: usize,
    config: &NdmsConfig,
    out: &mut [f64],
) {
    debug_assert_eq!(out.len(), config.word_len());
    let [h0, h1, v] = config.axis_order();
    let left = positions.slice(ndarray::s![start, config.left_hip, ..]);
    let right = positions.slice(ndarray::s![start, config.right_hip, ..]);
    let centre = [(left[h0] + right[h0]) * 0.5, (left[h1] + right[h1]) * 0.5];
    let direction = [right[h0] - left[h0], right[h1] - left[h1]];
    let length = direction[0].hypot(direction[1]);
    // Rotation by minus the heading angle: (cos a, sin a) is the unit hip direction. A degenerate
    // (vertical or zero) hip vector keeps the heading as it is.
    let (cos, sin) = if length > 0.0 {
        (direction[0] / length, direction[1] / length)
    } else {
        (1.0, 0.0)
    };
    let mut slots = out.chunks_exact_mut(3);
    for t in start..start + config.kappa {
        for &joint in &config.joints {
            let p = positions.slice(ndarray::s![t, joint, ..]);
            let x = p[h0] - centre[0];
            let y = p[h1] - centre[1];
            let slot = slots.next().expect("out has word_len numbers");
            slot[0] = cos * x + sin * y;
            slot[1] = -sin * x + cos * y;
            slot[2] = p[v];
        }
    }
}

/// The normalized words of every start frame `0..=T-κ` of `positions`, appended to `out` (row-major,
/// one word per row). Returns the number of words.
pub fn append_all_words(
    positions: ArrayView3<'_, f64>,
    config: &NdmsConfig,
    out: &mut Vec<f64>,
) -> usize {
    let frames = positions.dim().0;
    if frames < config.kappa {
        return 0;
    }
    let count = frames - config.kappa + 1;
    let len = config.word_len();
    let first = out.len();
    out.resize(first + count * len, 0.0);
    for (start, word) in out[first..].chunks_exact_mut(len).enumerate() {
        normalize_word(positions, start, config, word);
    }
    count
}
