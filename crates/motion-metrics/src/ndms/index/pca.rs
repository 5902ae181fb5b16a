//! A few leading principal directions of a set of rows, as an orthonormal basis.
//!
//! Only orthonormality matters for exactness (it makes projected distances lower bounds of true
//! ones); how close the basis is to the true principal directions only affects speed. So the
//! covariance is estimated from a bounded number of evenly spaced rows and the basis comes from a
//! fixed number of subspace iterations, re-orthonormalized by modified Gram-Schmidt.
/// Subspace iterations on the covariance.
const ITERATIONS: usize = 40;

/// The mean row and `k` orthonormal directions (row-major `k x dim`) of `rows` (`dim` per row),
/// the covariance estimated from at most `max_sample_rows` evenly spaced rows.
pub fn principal_basis(
    rows: &[f64],
    dim: usize,
    k: usize,
    max_sample_rows: usize,
) -> (Vec<f64>, Vec<f64>) {
    let count = rows.len() / dim;
    let mut mean = vec![0.0; dim];
    for row in rows.chunks_exact(dim) {
        for (m, x) in mean.iter_mut().zip(row) {
            *m += x;
        }
    }
    for m in &mut mean {
        *m /= count.max(1) as f64;
    }
    // Centred sample (s x dim).
    let stride = count.div_ceil(max_sample_rows.max(1)).max(1);
    let sample: Vec<f64> = rows
        .chunks_exact(dim)
        .step_by(stride)
        .flat_map(|row| row.iter().zip(&mean).map(|(x, m)| x - m))
        .collect();
    let s = sample.len() / dim;
    // covariance (dim x dim) = sampleᵀ · sample (the scale does not matter for the directions).
    let mut covariance = vec![0.0; dim * dim];
    // SAFETY: pointers and strides describe the slices' extents exactly.
    unsafe {
        matrixmultiply::dgemm(
            dim,
            s,
            dim,
            1.0,
            sample.as_ptr(),
            1,
            dim as isize,
            sample.as_ptr(),
            dim as isize,
            1,
            0.0,
            covariance.as_mut_ptr(),
            dim as isize,
            1,
        );
    }
    // Start from fixed, linearly independent directions (deterministic).
    let mut basis: Vec<f64> = (0..k * dim)
        .map(|i| {
            let (r, c) = (i / dim, i % dim);
            if c % k == r {
                1.0
            } else {
                1e-3 * (((r * 31 + c * 17) % 13) as f64 - 6.0)
            }
        })
        .collect();
    orthonormalize(&mut basis, dim);
    let mut next = vec![0.0; k * dim];
    for _ in 0..ITERATIONS {
        // next (k x dim) = basis (k x dim) · covariance (dim x dim), covariance symmetric.
        for (b, n) in basis.chunks_exact(dim).zip(next.chunks_exact_mut(dim)) {
            for (j, out) in n.iter_mut().enumerate() {
                *out = b
                    .iter()
                    .zip(&covariance[j * dim..(j + 1) * dim])
                    .map(|(x, y)| x * y)
                    .sum();
            }
        }
        std::mem::swap(&mut basis, &mut next);
        orthonormalize(&mut basis, dim);
    }
    (mean, basis)
}

/// Modified Gram-Schmidt on the rows (twice, for orthonormality to rounding); a row that
/// collapses is replaced by a unit axis not yet spanned.
fn orthonormalize(basis: &mut [f64], dim: usize) {
    let k = basis.len() / dim;
    for _pass in 0..2 {
        for r in 0..k {
            let (done, rest) = basis.split_at_mut(r * dim);
            let row = &mut rest[..dim];
            for prev in done.chunks_exact(dim) {
                let dot: f64 = row.iter().zip(prev).map(|(a, b)| a * b).sum();
                for (a, b) in row.iter_mut().zip(prev) {
                    *a -= dot * b;
                }
            }
            let norm = row.iter().map(|a| a * a).sum::<f64>().sqrt();
            if norm > 1e-12 {
                for a in row.iter_mut() {
                    *a /= norm;
                }
            } else {
                row.iter_mut().for_each(|a| *a = 0.0);
                row[r % dim] = 1.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_and_finds_the_dominant_axis() {
        // Rows spread mostly along axis 2 of 5.
        let rows: Vec<f64> = (0..200)
            .flat_map(|i| {
                let t = i as f64;
                [
                    0.01 * (t * 0.3).sin(),
                    0.02 * (t * 0.7).cos(),
                    10.0 * (t * 0.11).sin(),
                    0.0,
                    0.5 * (t * 0.9).sin(),
                ]
            })
            .collect();
        let (_, basis) = principal_basis(&rows, 5, 2, 4096);
        for a in 0..2 {
            for b in 0..2 {
                let dot: f64 = (0..5).map(|i| basis[a * 5 + i] * basis[b * 5 + i]).sum();
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((dot - expected).abs() < 1e-12, "{a} {b} {dot}");
            }
        }
        assert!(basis[2].abs() > 0.999, "{basis:?}");
    }
}
