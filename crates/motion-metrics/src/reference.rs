//! Naive references: the metrics computed term by term from their definitions (`metrics.md`),
//! slowly and without any of the fast paths, for the accuracy tests to compare the real
//! implementations against (as RustFFT tests its FFTs against a naive DFT). Not for production
//! use: NPSS here is O(T²) per feature.
use ndarray::ArrayView3;

/// NPSS of `pred` against `gt` (`sequences x frames x features`) from the definition with a
/// naive DFT `X[f] = Σ_t x[t] e^{-2πi f t / T}` over all `T` frequencies: `|X|²` as the power
/// (Gopalakrishnan et al. 2019), or `Re(X)²` with `real_only` (the published code). Per feature, the earth
/// mover's distance between the cumulative normalized spectra, weighted by the ground truth's
/// total power; a spectrum of zero power normalizes to zeros.
pub fn npss_naive(gt: ArrayView3<'_, f64>, pred: ArrayView3<'_, f64>, real_only: bool) -> f64 {
    let (n, t_len, d) = gt.dim();
    let power = |x: &[f64]| -> Vec<f64> {
        (0..t_len)
            .map(|f| {
                let (mut re, mut im) = (0.0, 0.0);
                for (t, v) in x.iter().enumerate() {
                    let angle = -2.0 * std::f64::consts::PI * (f * t) as f64 / t_len as f64;
                    re += v * angle.cos();
                    im += v * angle.sin();
                }
                if real_only {
                    re * re
                } else {
                    re * re + im * im
                }
            })
            .collect()
    };
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..n {
        for j in 0..d {
            let x: Vec<f64> = (0..t_len).map(|t| gt[[i, t, j]]).collect();
            let y: Vec<f64> = (0..t_len).map(|t| pred[[i, t, j]]).collect();
            let (px, py) = (power(&x), power(&y));
            let (sx, sy): (f64, f64) = (px.iter().sum(), py.iter().sum());
            let (mut cx, mut cy, mut emd) = (0.0, 0.0, 0.0);
            for f in 0..t_len {
                cx += if sx > 0.0 { px[f] / sx } else { 0.0 };
                cy += if sy > 0.0 { py[f] / sy } else { 0.0 };
                emd += (cy - cx).abs();
            }
            num += sx * emd;
            den += sx;
        }
    }
    num / den
}
