//! NPSS, the normalized power spectrum similarity of Gopalakrishnan et al. 2019 (section 3.5), exactly as
//! `metrics.md` defines it: per sequence and dim, the earth mover's distance between the
//! normalized power spectra (the L1 distance of their **cumulative** sums), averaged with the
//! ground truth's total power as weight.
//!
//! Two spectra are offered: the paper's `|DFT|²` ([`SpectrumPower::Modulus`], the default) and
//! the published implementation's `Re(DFT)²` ([`SpectrumPower::RealPart`]), which is what every
//! published NPSS number was computed with.
use ndarray::{s, ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;
use realfft::{num_complex::Complex, RealFftPlanner, RealToComplex};

use crate::error::{check_finite, check_not_empty, MetricError};

/// Which power spectrum NPSS compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumPower {
    /// `|DFT|²`, the paper's definition.
    Modulus,
    /// `Re(DFT)²`: the published code stored the complex coefficients in a real array, dropping
    /// the imaginary part. Reproduces the papers' tables.
    RealPart,
}

/// A time window of the prediction on which NPSS is computed with its own DFT (Gopalakrishnan et al. 2019 Table 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NpssWindow {
    /// Human-readable name, e.g. `"0-1 s"`.
    pub label: &'static str,
    /// First frame (inclusive).
    pub start: usize,
    /// One past the last frame.
    pub end: usize,
}

/// The windows 0-1 s, 1-2 s and 2-4 s at 25 Hz: frames 0-24, 25-49, 50-99.
pub const NPSS_WINDOWS_25HZ: [NpssWindow; 3] = [
    NpssWindow {
        label: "0-1 s",
        start: 0,
        end: 25,
    },
    NpssWindow {
        label: "1-2 s",
        start: 25,
        end: 50,
    },
    NpssWindow {
        label: "2-4 s",
        start: 50,
        end: 100,
    },
];

/// Windows past the paper's 4 s for 12 s horizons (Ghosh et al. 2017): 4-8 s and 8-12 s at 25 Hz, frames
/// 100-199 and 200-299.
pub const NPSS_LONG_WINDOWS_25HZ: [NpssWindow; 2] = [
    NpssWindow {
        label: "4-8 s",
        start: 100,
        end: 200,
    },
    NpssWindow {
        label: "8-12 s",
        start: 200,
        end: 300,
    },
];

/// The NPSS of one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowScore {
    /// The window.
    pub window: NpssWindow,
    /// Its NPSS.
    pub value: f64,
}

/// A reusable NPSS evaluator: keeps one real-input FFT planner so that repeated calls with the
/// same sequence length reuse the plan.
pub struct Npss {
    planner: RealFftPlanner<f64>,
}

impl Default for Npss {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for Npss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Npss")
    }
}

impl Npss {
    /// A new evaluator with an empty plan cache.
    pub fn new() -> Self {
        Self {
            planner: RealFftPlanner::new(),
        }
    }

    /// NPSS of `pred` against `gt`, both `N x T x D` (sequences x frames x dims).
    ///
    /// Errors: shapes differ, an axis is empty, a value is not finite, or every ground-truth
    /// (sequence, dim) has zero total power (NPSS is then undefined).
    pub fn score(
        &mut self,
        gt: ArrayView3<'_, f64>,
        pred: ArrayView3<'_, f64>,
        power: SpectrumPower,
    ) -> Result<f64, MetricError> {
        check_shapes(&gt, &pred)?;
        let fft = self.planner.plan_fft_forward(gt.dim().1);
        // Finiteness is checked inside the one pass over the data (the arrays can be hundreds of
        // MB); only when something is not finite are they walked again to name the first place.
        let per_sequence = weighted_emd_per_sequence(&*fft, gt, pred, power);
        let Some(per_sequence) = per_sequence else {
            check_finite("ground truth", &gt)?;
            check_finite("prediction", &pred)?;
            unreachable!("a non-finite value was seen, so one of the checks fails");
        };
        // Summed in sequence order so that the result does not depend on the thread count.
        let (weighted, total) = per_sequence
            .iter()
            .fold((0.0, 0.0), |(a, b), (w, t)| (a + w, b + t));
        if total == 0.0 {
            return Err(MetricError::Undefined {
                metric: "NPSS",
                reason:
                    "the ground truth has zero power in every sequence and dim (all weights are 0)"
                        .into(),
            });
        }
        Ok(weighted / total)
    }

    /// NPSS on each window of `windows` that lies inside the `T` frames (a window reaching past
    /// the end is left out), each with its own DFT.
    pub fn score_windows(
        &mut self,
        gt: ArrayView3<'_, f64>,
        pred: ArrayView3<'_, f64>,
        power: SpectrumPower,
        windows: &[NpssWindow],
    ) -> Result<Vec<WindowScore>, MetricError> {
        check_shapes(&gt, &pred)?;
        check_finite("ground truth", &gt)?;
        check_finite("prediction", &pred)?;
        let frames = gt.dim().1;
        windows
            .iter()
            .filter(|w| w.start < w.end && w.end <= frames)
            .map(|&window| {
                let range = s![.., window.start..window.end, ..];
                let value = self.score(gt.slice(range), pred.slice(range), power)?;
                Ok(WindowScore { window, value })
            })
            .collect()
    }
}

fn check_shapes(gt: &ArrayView3<'_, f64>, pred: &ArrayView3<'_, f64>) -> Result<(), MetricError> {
    check_not_empty("ground truth", gt)?;
    if gt.shape() != pred.shape() {
        return Err(MetricError::ShapeMismatch {
            what: "prediction".into(),
            found: pred.shape().to_vec(),
            expected: gt.shape().to_vec(),
        });
    }
    Ok(())
}

/// Per-thread work buffers, allocated once per rayon job and reused for every sequence.
struct SpectrumBuffers {
    /// The ground truth's `D` series of `T` frames, dim-major (the FFT overwrites its input).
    gt_series: Vec<f64>,
    /// The prediction's series.
    pred_series: Vec<f64>,
    /// The `T/2 + 1` non-redundant DFT coefficients of one series.
    spectrum: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    /// The ground truth's half power spectrum (`T/2 + 1` values) of the dim being compared.
    gt_power: Vec<f64>,
    /// The prediction's half power spectrum.
    pred_power: Vec<f64>,
}

impl SpectrumBuffers {
    fn new(fft: &dyn RealToComplex<f64>, dims: usize) -> Self {
        let frames = fft.len();
        Self {
            gt_series: vec![0.0; dims * frames],
            pred_series: vec![0.0; dims * frames],
            spectrum: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            gt_power: vec![0.0; fft.complex_len()],
            pred_power: vec![0.0; fft.complex_len()],
        }
    }

    /// (Σ_j w_ij · emd_ij, Σ_j w_ij) of one sequence (`T x D` each); `None` if a value of
    /// either is not finite.
    ///
    /// `next` is the sequence this thread most likely scores next: its memory is prefetched
    /// while this one's FFTs run, so that its transpose does not wait for DRAM.
    fn sequence(
        &mut self,
        fft: &dyn RealToComplex<f64>,
        (gt, pred): (ArrayView2<'_, f64>, ArrayView2<'_, f64>),
        next: Option<(ArrayView2<'_, f64>, ArrayView2<'_, f64>)>,
        power: SpectrumPower,
    ) -> Option<(f64, f64)> {
        let (frames, dims) = gt.dim();
        if !(load_dim_major(gt, &mut self.gt_series) & load_dim_major(pred, &mut self.pred_series))
        {
            return None;
        }
        let next = next.and_then(|(g, p)| Some([g.to_slice()?, p.to_slice()?]));
        // Cache lines of the next sequence to prefetch per dim.
        let lines_per_dim = (2 * frames * dims).div_ceil(8 * dims);
        let mut weighted = 0.0;
        let mut total = 0.0;
        for (j, (gt, pred)) in self
            .gt_series
            .chunks_exact_mut(frames)
            .zip(self.pred_series.chunks_exact_mut(frames))
            .enumerate()
        {
            if let Some(next) = next {
                for line in j * lines_per_dim..(j + 1) * lines_per_dim {
                    let (half, offset) = (line % 2, 8 * (line / 2));
                    if let Some(value) = next[half].get(offset) {
                        prefetch(value);
                    }
                }
            }
            // The DFT of a real series is conjugate-symmetric, and so are both power spectra:
            // the T/2 + 1 coefficients of the real FFT determine them.
            for (input, out) in [(gt, &mut self.gt_power), (pred, &mut self.pred_power)] {
                fft.process_with_scratch(input, &mut self.spectrum, &mut self.scratch)
                    .expect("buffers made by this plan");
                match power {
                    SpectrumPower::Modulus => {
                        for (p, c) in out.iter_mut().zip(&self.spectrum) {
                            *p = c.re * c.re + c.im * c.im;
                        }
                    }
                    SpectrumPower::RealPart => {
                        for (p, c) in out.iter_mut().zip(&self.spectrum) {
                            *p = c.re * c.re;
                        }
                    }
                }
            }
            let (emd, weight) = spectral_emd(&mut self.gt_power, &mut self.pred_power, frames);
            weighted += weight * emd;
            total += weight;
        }
        Some((weighted, total))
    }
}

/// For every sequence: (Σ_j w_ij · emd_ij, Σ_j w_ij); `None` if a value is not finite.
fn weighted_emd_per_sequence(
    fft: &dyn RealToComplex<f64>,
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
    power: SpectrumPower,
) -> Option<Vec<(f64, f64)>> {
    let sequences = gt.dim().0;
    // Few, long jobs: each allocates its buffers once (fresh pages cost more than the FFTs).
    let per_job = sequences.div_ceil(4 * rayon::current_num_threads()).max(1);
    (0..sequences)
        .into_par_iter()
        .with_min_len(per_job)
        .map_init(
            || SpectrumBuffers::new(fft, gt.dim().2),
            |buffers, i| {
                let at = |i: usize| (gt.index_axis(Axis(0), i), pred.index_axis(Axis(0), i));
                let next = (i + 1 < sequences).then(|| at(i + 1));
                buffers.sequence(fft, at(i), next, power)
            },
        )
        .collect()
}

/// Copies a `T x D` sequence into `D` contiguous series of length `T` (`out` is `D x T`);
/// false if a value is not finite.
fn load_dim_major(sequence: ArrayView2<'_, f64>, out: &mut [f64]) -> bool {
    let frames = sequence.nrows();
    match sequence.to_slice() {
        Some(values) => {
            // Reading row by row streams through memory; the 8 frames of one cache line of
            // each series are written while its line is still in L1.
            for (t, row) in values.chunks_exact(sequence.ncols()).enumerate() {
                for (series, &v) in out.chunks_exact_mut(frames).zip(row) {
                    series[t] = v;
                }
            }
            all_finite(values)
        }
        None => {
            for (t, row) in sequence.rows().into_iter().enumerate() {
                for (series, &v) in out.chunks_exact_mut(frames).zip(row) {
                    series[t] = v;
                }
            }
            all_finite(out)
        }
    }
}

/// Asks the CPU to bring the cache line of `value` into its caches (no effect on the program's
/// results; a no-op off x86-64).
#[inline(always)]
fn prefetch(value: &f64) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and does not change memory; the pointer is valid anyway.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((value as *const f64).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// True if no value is NaN or infinite: `v · 0` is ±0 for finite `v` and NaN otherwise.
/// Eight running sums keep the loop free of a serial dependency.
fn all_finite(values: &[f64]) -> bool {
    let mut sums = [0.0; 8];
    let mut chunks = values.chunks_exact(8);
    for chunk in &mut chunks {
        for (s, &v) in sums.iter_mut().zip(chunk) {
            *s += v * 0.0;
        }
    }
    for (s, &v) in sums.iter_mut().zip(chunks.remainder()) {
        *s += v * 0.0;
    }
    sums.iter().sum::<f64>() == 0.0
}

/// The EMD between the normalized power spectra of one dim (the L1 distance of their cumulative
/// sums over all `T` frequencies) and the ground truth's total power (the weight). A spectrum
/// of total power 0 stays 0.
///
/// `gt` and `pred` hold the half spectra `P[0..=T/2]` on entry (a real series has
/// `P[T - f] = P[f]`) and their running sums `C` on return. With `D[f] = ĉ_pred[f] - ĉ_gt[f]`
/// (normalized cumulative sums), symmetry gives `D[T - 1 - g] = K - D[g]` for the upper
/// frequencies, `K = D[h - 1] + D[T - h]` with `h = T/2 + 1` (in exact arithmetic `K = D[0]`,
/// both normalized sums ending at 1), so one pass over `h` frequencies covers all `T`.
fn spectral_emd(gt: &mut [f64], pred: &mut [f64], frames: usize) -> (f64, f64) {
    let half = gt.len();
    let upper = frames - half;
    let (mut gt_running, mut pred_running) = (0.0, 0.0);
    for (g, p) in gt.iter_mut().zip(pred.iter_mut()) {
        gt_running += *g;
        *g = gt_running;
        pred_running += *p;
        *p = pred_running;
    }
    // Σ_f P[f] = C[h - 1] + C[T - h] - P[0], with P[0] = C[0].
    let total = |c: &[f64]| c[half - 1] + if upper > 0 { c[upper] - c[0] } else { 0.0 };
    let (gt_total, pred_total) = (total(gt), total(pred));
    let gt_scale = if gt_total > 0.0 { 1.0 / gt_total } else { 0.0 };
    let pred_scale = if pred_total > 0.0 {
        1.0 / pred_total
    } else {
        0.0
    };
    let d = |f: usize| pred[f] * pred_scale - gt[f] * gt_scale;
    // The upper frequencies f = h..T have cumulative sums C[h - 1] + (C[T - h] - C[T - 1 - f]).
    let k = d(half - 1) + if upper > 0 { d(upper) } else { 0.0 };
    let mut lower_sum = 0.0;
    let mut upper_sum = 0.0;
    for f in 0..half {
        let diff = d(f);
        lower_sum += diff.abs();
        if f < upper {
            upper_sum += (k - diff).abs();
        }
    }
    (lower_sum + upper_sum, gt_total)
}

/// NPSS with the paper's `|DFT|²` power spectrum over the whole sequences (`N x T x D`).
pub fn npss(gt: ArrayView3<'_, f64>, pred: ArrayView3<'_, f64>) -> Result<f64, MetricError> {
    Npss::new().score(gt, pred, SpectrumPower::Modulus)
}

/// NPSS as the published implementation computes it (`Re(DFT)²`), reproducing the papers' numbers.
pub fn npss_reference(
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
) -> Result<f64, MetricError> {
    Npss::new().score(gt, pred, SpectrumPower::RealPart)
}

/// NPSS on the 0-1 s, 1-2 s and 2-4 s windows of 25 Hz sequences (those that fit in `T`).
pub fn npss_windows(
    gt: ArrayView3<'_, f64>,
    pred: ArrayView3<'_, f64>,
    power: SpectrumPower,
) -> Result<Vec<WindowScore>, MetricError> {
    Npss::new().score_windows(gt, pred, power, &NPSS_WINDOWS_25HZ)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// 0 <= NPSS <= T - 1 (each EMD of cumulative spectra is at most T - 1), NPSS(x, x) = 0.
        #[test]
        fn npss_is_bounded(
            frames in 2usize..40,
            values in proptest::collection::vec(-10.0f64..10.0, 2 * 40 * 3 * 2),
        ) {
            let len = 2 * frames * 3;
            let gt = Array3::from_shape_vec((2, frames, 3), values[..len].to_vec()).unwrap();
            let pred = Array3::from_shape_vec((2, frames, 3), values[len..2 * len].to_vec()).unwrap();
            for power in [SpectrumPower::Modulus, SpectrumPower::RealPart] {
                let mut npss = Npss::new();
                if let Ok(v) = npss.score(gt.view(), pred.view(), power) {
                    prop_assert!(v >= 0.0 && v <= (frames - 1) as f64 + 1e-9, "{v}");
                    prop_assert_eq!(npss.score(gt.view(), gt.view(), power).unwrap(), 0.0);
                }
            }
        }
    }
}
