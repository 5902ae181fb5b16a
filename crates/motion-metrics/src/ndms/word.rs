//! Motion words: `κ` consecutive frames of the selected joints, normalized per word as the public
//! NDMS implementation does (its SMPL recipe applied to H3.6M, `metrics.md`):
//! 1. make the vertical axis the last one (y-up H3.6M: reorder to x, z, y);
//! 2. centre = midpoint of the first frame's left and right hip, with its vertical coordinate 0;
//! 3. rotate about the vertical so that the first frame's left→right hip direction in the floor
//!    plane points along +x;
//! 4. subtract the centre, rotate, keep the selected joints.
//!
//! That recipe assumes gravity-aligned positions. For FK of integrated root deltas (H3.6M), whose
//! world is the tilted pelvis frame of wherever integration started, [`WordFrame::Body`]
//! expresses the word in a rigid frame of its first frame's hips and shoulders instead.
//!
//! A normalized word is flattened frame-major, then joint, then coordinate: `κ x joints x 3`.
use ndarray::ArrayView3;
use rayon::prelude::*;

use super::{NdmsConfig, WordFrame};

/// Writes the normalized word of `positions` (`T x J x 3`) starting at frame `start` into `out`
/// (`config.word_len()` numbers). The caller guarantees `start + κ <= T` and valid joint indices.
pub fn normalize_word(
    positions: ArrayView3<'_, f64>,
    start: usize,
    config: &NdmsConfig,
    out: &mut [f64],
) {
    debug_assert_eq!(out.len(), config.word_len());
    let order = config.axis_order();
    // A joint of a frame with the vertical axis last, by plain indexing (a slice view per point
    // would cost more than the arithmetic); each layout gets its own inlined copy.
    match positions.to_slice() {
        Some(values) => {
            let joints = positions.dim().1;
            let at = |t: usize, joint: usize| {
                let p = &values[(t * joints + joint) * 3..][..3];
                order.map(|c| p[c])
            };
            write_word(at, start, config, out);
        }
        None => write_word(
            |t, joint| order.map(|c| positions[[t, joint, c]]),
            start,
            config,
            out,
        ),
    }
}

/// [`normalize_word`] with `at(t, joint)` giving a joint's position, vertical axis last.
#[inline(always)]
fn write_word(
    at: impl Fn(usize, usize) -> [f64; 3],
    start: usize,
    config: &NdmsConfig,
    out: &mut [f64],
) {
    let point = |joint: usize| at(start, joint);
    let (left, right) = (point(config.left_hip), point(config.right_hip));
    let (origin, axes) = match config.frame {
        WordFrame::Heading => heading_frame(left, right),
        WordFrame::Body {
            left_shoulder,
            right_shoulder,
        } => body_frame(left, right, point(left_shoulder), point(right_shoulder)),
    };
    let mut slots = out.chunks_exact_mut(3);
    for t in start..start + config.kappa {
        for &joint in &config.joints {
            let p = at(t, joint);
            let d = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
            let slot = slots.next().expect("out has word_len numbers");
            for (value, axis) in slot.iter_mut().zip(&axes) {
                *value = axis[0] * d[0] + axis[1] * d[1] + axis[2] * d[2];
            }
        }
    }
}

/// `metrics.md`'s recipe: origin = hip midpoint with vertical 0; rotation about the vertical by
/// minus the heading of left→right hip. A degenerate (vertical or zero) hip vector keeps the
/// heading as it is. Returns the origin and the new axes as rows.
fn heading_frame(left: [f64; 3], right: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let origin = [(left[0] + right[0]) * 0.5, (left[1] + right[1]) * 0.5, 0.0];
    let direction = [right[0] - left[0], right[1] - left[1]];
    let length = direction[0].hypot(direction[1]);
    // (cos a, sin a) is the unit hip direction; rows of the rotation by -a.
    let (cos, sin) = if length > 0.0 {
        (direction[0] / length, direction[1] / length)
    } else {
        (1.0, 0.0)
    };
    (origin, [[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]])
}

/// The rigid body frame: origin = hip midpoint; x = left→right hip; vertical = hip→shoulder
/// midpoint made orthogonal to x; y = vertical × x. Falls back to the heading frame when the hips
/// coincide or the spine is parallel to them.
fn body_frame(
    left: [f64; 3],
    right: [f64; 3],
    left_shoulder: [f64; 3],
    right_shoulder: [f64; 3],
) -> ([f64; 3], [[f64; 3]; 3]) {
    let origin = [0, 1, 2].map(|c| (left[c] + right[c]) * 0.5);
    let x = [0, 1, 2].map(|c| right[c] - left[c]);
    let x_len = norm(x);
    if x_len == 0.0 {
        return heading_frame(left, right);
    }
    let x = x.map(|v| v / x_len);
    let up = [0, 1, 2].map(|c| (left_shoulder[c] + right_shoulder[c]) * 0.5 - origin[c]);
    let along = dot(up, x);
    let z = [0, 1, 2].map(|c| up[c] - along * x[c]);
    let z_len = norm(z);
    if z_len <= 1e-9 * norm(up) || z_len == 0.0 {
        return heading_frame(left, right);
    }
    let z = z.map(|v| v / z_len);
    let y = [
        z[1] * x[2] - z[2] * x[1],
        z[2] * x[0] - z[0] * x[2],
        z[0] * x[1] - z[1] * x[0],
    ];
    (origin, [x, y, z])
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
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
    out[first..]
        .par_chunks_exact_mut(len)
        .enumerate()
        .with_min_len(256)
        .for_each(|(start, word)| normalize_word(positions, start, config, word));
    count
}
