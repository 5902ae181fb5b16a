//! NDMS, the normalized directional motion similarity of two motion words (Tanke et al. 2021 eq. 11-12,
//! with the public implementation's ε handling, `metrics.md`):
//! `mean over t = 1..κ-1 and joints j of ½(1 + cos(v_a, v_b)) · min(|v_a|, |v_b|) / max(|v_a|, |v_b|)`
//! where `v` are the joint's frame-to-frame velocities, the magnitudes are clamped to at least
//! [`EPSILON`], and `cos = v_a·v_b / (|v_a| |v_b|)` with the clamped magnitudes.
//!
//! Consequence of the clamping: a joint at rest in both words contributes ½ (cos = 0, ratio = 1),
//! so NDMS(w, w) = 1 holds for words whose joints all move.

/// Lower clamp of velocity magnitudes (the public implementation's `eps`).
pub const EPSILON: f64 = 1e-7;

/// NDMS of two flattened words (`κ x joints x 3`, see `word`). Symmetric, in `[0, 1]`.
pub fn ndms(a: &[f64], b: &[f64], kappa: usize) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let frame_len = a.len() / kappa;
    let joints = frame_len / 3;
    let mut total = 0.0;
    for t in 1..kappa {
        let mut frame_sum = 0.0;
        for j in 0..joints {
            let now = t * frame_len + 3 * j;
            let before = now - frame_len;
            let va = [
                a[now] - a[before],
                a[now + 1] - a[before + 1],
                a[now + 2] - a[before + 2],
            ];
            let vb = [
                b[now] - b[before],
                b[now + 1] - b[before + 1],
                b[now + 2] - b[before + 2],
            ];
            let norm_a = (va[0] * va[0] + va[1] * va[1] + va[2] * va[2])
                .sqrt()
                .max(EPSILON);
            let norm_b = (vb[0] * vb[0] + vb[1] * vb[1] + vb[2] * vb[2])
                .sqrt()
                .max(EPSILON);
            let cos = (va[0] * vb[0] + va[1] * vb[1] + va[2] * vb[2]) / (norm_a * norm_b);
            // Rounding can push cos a hair past ±1; the score stays in [0, 1].
            let cos = cos.clamp(-1.0, 1.0);
            let ratio = norm_a.min(norm_b) / norm_a.max(norm_b);
            frame_sum += 0.5 * (1.0 + cos) * ratio;
        }
        total += frame_sum / joints as f64;
    }
    total / (kappa - 1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// NDMS is symmetric and in [0, 1].
        #[test]
        fn ndms_is_symmetric_and_bounded(
            a in proptest::collection::vec(-100.0f64..100.0, 8 * 2 * 3),
            b in proptest::collection::vec(-100.0f64..100.0, 8 * 2 * 3),
        ) {
            let ab = ndms(&a, &b, 8);
            prop_assert!((0.0..=1.0).contains(&ab), "{ab}");
            prop_assert_eq!(ab, ndms(&b, &a, 8));
        }
    }
}
