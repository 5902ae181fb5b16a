//! The Fréchet distance between Gaussians, exactly in `f64`: a cyclic Jacobi eigensolver for
//! symmetric matrices and the trace of `(S1 S2)^{1/2}` through it.
use ndarray::{Array1, Array2, ArrayView1, ArrayView2};

use crate::error::{check_finite, MetricError};

/// Most Jacobi sweeps (convergence is quadratic; 66 x 66 covariances take about 10).
const MAX_SWEEPS: usize = 100;

/// Eigen-decomposes the symmetric `n x n` row-major matrix `a` in place by the cyclic Jacobi
/// method: on return the diagonal of `a` holds the eigenvalues and column `k` of `v` (row-major,
/// `n x n`) the unit eigenvector of eigenvalue `a[k * n + k]`.
///
/// A rotation is skipped when `|a_pq| <= eps · sqrt(|a_pp a_qq|)` (the criterion of Demmel and
/// Veselić, which keeps small eigenvalues of positive semi-definite matrices accurate); the
/// iteration stops after a sweep without rotations.
pub(crate) fn jacobi(a: &mut [f64], n: usize, v: &mut [f64]) {
    debug_assert_eq!(a.len(), n * n);
    debug_assert_eq!(v.len(), n * n);
    v.fill(0.0);
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _ in 0..MAX_SWEEPS {
        let mut rotated = false;
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                let (app, aqq) = (a[p * n + p], a[q * n + q]);
                if apq == 0.0 || apq.abs() <= f64::EPSILON * (app * aqq).abs().sqrt() {
                    continue;
                }
                rotated = true;
                let theta = (aqq - app) / (2.0 * apq);
                let t = if theta.abs() > 1e150 {
                    0.5 / theta
                } else {
                    theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
                };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A <- A J (columns p, q), then A <- J^T A (rows p, q); V <- V J.
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                a[p * n + q] = 0.0;
                a[q * n + p] = 0.0;
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
        if !rotated {
            break;
        }
    }
}

/// Eigenvalues (ascending) and unit eigenvectors (the columns, in the same order) of the
/// symmetric matrix `a` (only its upper triangle is read), by the cyclic Jacobi method.
///
/// # Errors
/// A matrix that is not square, is empty or holds a non-finite value.
pub fn symmetric_eigen(a: ArrayView2<'_, f64>) -> Result<(Array1<f64>, Array2<f64>), MetricError> {
    let n = check_square("matrix", a)?;
    let mut m = symmetric_copy(a);
    let mut v = vec![0.0; n * n];
    jacobi(&mut m, n, &mut v);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| m[i * n + i].total_cmp(&m[j * n + j]));
    let values = Array1::from_iter(order.iter().map(|&k| m[k * n + k]));
    let vectors = Array2::from_shape_fn((n, n), |(r, c)| v[r * n + order[c]]);
    Ok((values, vectors))
}

fn check_square(what: &str, a: ArrayView2<'_, f64>) -> Result<usize, MetricError> {
    let n = a.nrows();
    if n == 0 {
        return Err(MetricError::Empty {
            what: format!("{what} has no rows"),
        });
    }
    if a.ncols() != n {
        return Err(MetricError::ShapeMismatch {
            what: format!("{what} (square)"),
            found: a.shape().to_vec(),
            expected: vec![n, n],
        });
    }
    check_finite(what, &a)?;
    Ok(n)
}

/// Row-major copy of a symmetric matrix from its upper triangle.
fn symmetric_copy(a: ArrayView2<'_, f64>) -> Vec<f64> {
    let n = a.nrows();
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        for j in i..n {
            m[i * n + j] = a[[i, j]];
            m[j * n + i] = a[[i, j]];
        }
    }
    m
}

/// One Gaussian's side of the Fréchet distance prepared once: `S = V diag(λ) V^T` with the square
/// roots of the eigenvalues (negative ones, rounding of a semi-definite matrix, taken as 0).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PreparedGaussian {
    pub(crate) n: usize,
    pub(crate) mean: Vec<f64>,
    pub(crate) trace: f64,
    /// Eigenvectors, row-major, column k for eigenvalue k.
    vectors: Vec<f64>,
    /// `sqrt(max(λ_k, 0))`.
    sqrt_values: Vec<f64>,
}

impl PreparedGaussian {
    /// `cov` row-major `n x n`, symmetric.
    pub(crate) fn new(mean: Vec<f64>, cov: &[f64]) -> Self {
        let n = mean.len();
        let trace = (0..n).map(|i| cov[i * n + i]).sum();
        let mut a = cov.to_vec();
        let mut vectors = vec![0.0; n * n];
        jacobi(&mut a, n, &mut vectors);
        let sqrt_values = (0..n).map(|k| a[k * n + k].max(0.0).sqrt()).collect();
        Self {
            n,
            mean,
            trace,
            vectors,
            sqrt_values,
        }
    }

    /// `||μ1 − μ2||² + Tr S1 + Tr S2 − 2 Tr (S1^{1/2} S2 S1^{1/2})^{1/2}` with this Gaussian as 1:
    /// the trace term is `Σ sqrt(max(μ_k, 0))` over the eigenvalues `μ_k` of
    /// `B = D V^T S2 V D` (`D = diag(sqrt λ)`), which is similar to `S1^{1/2} S2 S1^{1/2}`.
    /// Negative results of rounding are returned as 0.
    pub(crate) fn frechet(&self, mean: &[f64], cov: &[f64]) -> f64 {
        let n = self.n;
        let (v, d) = (&self.vectors, &self.sqrt_values);
        let mean_term: f64 = self
            .mean
            .iter()
            .zip(mean)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        let trace2: f64 = (0..n).map(|i| cov[i * n + i]).sum();
        // T = S2 V, then B = D V^T T D.
        let mut t = vec![0.0; n * n];
        for i in 0..n {
            for k in 0..n {
                let s = cov[i * n + k];
                if s != 0.0 {
                    for j in 0..n {
                        t[i * n + j] += s * v[k * n + j];
                    }
                }
            }
        }
        let mut b = vec![0.0; n * n];
        for i in 0..n {
            for j in i..n {
                let mut sum = 0.0;
                for k in 0..n {
                    sum += v[k * n + i] * t[k * n + j];
                }
                let x = d[i] * sum * d[j];
                b[i * n + j] = x;
                b[j * n + i] = x;
            }
        }
        let mut w = vec![0.0; n * n];
        jacobi(&mut b, n, &mut w);
        let trace_sqrt: f64 = (0..n).map(|k| b[k * n + k].max(0.0).sqrt()).sum();
        (mean_term + self.trace + trace2 - 2.0 * trace_sqrt).max(0.0)
    }
}

/// The Fréchet distance between the Gaussians `N(mu1, s1)` and `N(mu2, s2)`:
/// `||mu1 − mu2||² + Tr(s1 + s2 − 2 (s1 s2)^{1/2})`, exactly in `f64` (the module docs of
/// [`crate::posture`] give the computation). The covariances must be symmetric positive
/// semi-definite (only their upper triangles are read; negative eigenvalues of rounding count
/// as 0). Not a square root: the squared 2-Wasserstein distance, as FID reports it.
///
/// # Errors
/// Empty or non-finite inputs, a covariance that is not square or disagrees with its mean.
pub fn frechet_distance(
    mu1: ArrayView1<'_, f64>,
    s1: ArrayView2<'_, f64>,
    mu2: ArrayView1<'_, f64>,
    s2: ArrayView2<'_, f64>,
) -> Result<f64, MetricError> {
    let n = check_square("s1", s1)?;
    check_square("s2", s2)?;
    for (what, mu, s) in [("mu1", mu1, s1), ("mu2", mu2, s2)] {
        if mu.len() != n || s.nrows() != n {
            return Err(MetricError::ShapeMismatch {
                what: format!("{what} and its covariance"),
                found: vec![mu.len(), s.nrows(), s.ncols()],
                expected: vec![n, n, n],
            });
        }
        check_finite(what, &mu)?;
    }
    let g1 = PreparedGaussian::new(mu1.to_vec(), &symmetric_copy(s1));
    Ok(g1.frechet(&mu2.to_vec(), &symmetric_copy(s2)))
}
