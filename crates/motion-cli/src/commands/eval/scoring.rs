//! Scores of one action: the model's (or the zero-velocity baseline's) predictions of the 8 test
//! windows, `K` samples each, against the ground truth, with every metric of `eval`.
//!
//! How `K` samples enter each metric (also stated in the output):
//! - Euler error: every sample is scored against its window's ground truth; the mean over all
//!   `8 x K` sequences (= the mean over samples of the per-sample means over windows).
//! - NPSS: sample index `k` of the 8 windows is one set of 8 sequences, scored as the metric
//!   defines (power-weighted over sequences and dims); the mean over `k`.
//! - NDMS: f_sim over all words of all `8 x K` forecasts (paper 003 eq. 9).
//! - APD: per window over its `K` samples, then the mean over windows.
//! - Joint speed: the mean over all `8 x K` forecasts.
use std::sync::Arc;

use anyhow::Result;
use ndarray::{concatenate, s, Array2, Array3, ArrayView2, ArrayView4, Axis};

use motion_core::kinematics::expmap_positions;
use motion_core::protocol::{expmap_batch_to_euler_protocol, WindowData};
use motion_core::skeleton::H36M_NDMS_JOINTS;
use motion_core::{RootEncoding, Skeleton};
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NdmsReport};
use motion_metrics::npss::{Npss, SpectrumPower, NPSS_WINDOWS_25HZ};
use motion_metrics::{apd, euler_error};

/// Source frames per 25 Hz step: protocol frames are every other 50 Hz frame, so each root delta
/// is applied twice when the root is integrated (`h36m.md`).
const ROOT_STEP_25HZ: usize = 2;
/// Frames of the last second at 25 Hz (joint-speed check).
const LAST_SECOND_FRAMES: usize = 25;

/// NPSS on the whole horizon and on the paper's windows that fit in it.
#[derive(Debug, Clone, PartialEq)]
pub struct NpssScores {
    /// Over all predicted frames.
    pub whole: f64,
    /// `(label, value)` for 0-1 s, 1-2 s, 2-4 s (those inside the horizon).
    pub windows: Vec<(&'static str, f64)>,
}

/// Mean joint speed in mm per 25 Hz frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Speed {
    /// World positions (root trajectory integrated).
    pub world: f64,
    /// Body only: FK with the root's translation and rotation deltas set to 0.
    pub pose: f64,
}

/// Every metric of one set of predictions of one action.
#[derive(Debug, Clone)]
pub struct Scores {
    /// Mean Euler error per predicted frame.
    pub euler_per_frame: Vec<f64>,
    /// NPSS with `|DFT|²` (the paper's definition).
    pub npss: NpssScores,
    /// NPSS with `Re(DFT)²` (the published code's variant, comparable to the tables).
    pub npss_reference: NpssScores,
    /// NDMS against the action's S5 word database.
    pub ndms: NdmsReport,
    /// APD (mm) when there are at least 2 samples.
    pub apd: Option<f64>,
    /// Mean joint speed over the last second, 12 NDMS joints.
    pub speed_last_second: Speed,
}

/// The ground truth side of one action, shared by the model's and the baseline's scoring.
pub struct ActionTruth {
    windows: Vec<WindowData>,
    /// Euler sequences of the ground truth, `8 x H x 99`.
    gt_euler: Array3<f64>,
    database: NdmsDatabase,
    skeleton: Arc<Skeleton>,
    /// Mean joint speed of the ground truth over the last second.
    pub speed_last_second: Speed,
}

impl ActionTruth {
    /// Prepares the windows' ground truth and the NDMS database of `reference_sequences` (the
    /// action's S5 files at 25 Hz).
    pub fn new(windows: Vec<WindowData>, reference_sequences: &[Array2<f64>]) -> Result<Self> {
        let skeleton = Arc::new(Skeleton::h36m());
        let views: Vec<ArrayView2<'_, f64>> =
            windows.iter().map(|w| w.ground_truth.view()).collect();
        let gt = ndarray::stack(Axis(0), &views)?;
        let gt_euler = expmap_batch_to_euler_protocol(gt.view());
        let mut positions = Vec::with_capacity(reference_sequences.len());
        for sequence in reference_sequences {
            positions.push(expmap_positions(
                &skeleton,
                sequence.view(),
                RootEncoding::Deltas,
                ROOT_STEP_25HZ,
            )?);
        }
        let position_views: Vec<_> = positions.iter().map(|p| p.view()).collect();
        let database = NdmsDatabase::from_sequences(
            NdmsConfig::h36m_body_frame(),
            &position_views,
            motion_metrics::NnMethod::default(),
        )?;
        let mut speeds = Vec::new();
        for w in &windows {
            speeds.push(joined_speed(&skeleton, &w.seed, w.ground_truth.view())?);
        }
        let speed_last_second = mean_speed(&speeds);
        Ok(Self {
            windows,
            gt_euler,
            database,
            skeleton,
            speed_last_second,
        })
    }

    /// The test windows.
    pub fn windows(&self) -> &[WindowData] {
        &self.windows
    }

    /// Words in the NDMS database.
    pub fn database_words(&self) -> usize {
        self.database.len()
    }

    /// Scores `predictions` (`8 x K x H x 99` exp-map frames, window-major); `on_window` is
    /// called once per window as its positions are done (progress).
    pub fn score(
        &self,
        predictions: ArrayView4<'_, f64>,
        mut on_window: impl FnMut(),
    ) -> Result<Scores> {
        let (windows, samples, horizon, width) = predictions.dim();
        debug_assert_eq!(windows, self.windows.len());

        // Euler error and NPSS: one set of 8 windows per sample index.
        let mut euler_sum = vec![0.0; horizon];
        let mut npss_sets = Vec::with_capacity(samples);
        let mut reference_sets = Vec::with_capacity(samples);
        let mut npss = Npss::new();
        for k in 0..samples {
            let set = predictions.slice(s![.., k, .., ..]);
            let euler = expmap_batch_to_euler_protocol(set);
            let per_frame = euler_error(self.gt_euler.view(), euler.view())?;
            euler_sum
                .iter_mut()
                .zip(&per_frame)
                .for_each(|(s, e)| *s += e);
            npss_sets.push(npss_scores(
                &mut npss,
                &self.gt_euler,
                &euler,
                SpectrumPower::Modulus,
            )?);
            reference_sets.push(npss_scores(
                &mut npss,
                &self.gt_euler,
                &euler,
                SpectrumPower::RealPart,
            )?);
        }
        let euler_per_frame = euler_sum.iter().map(|s| s / samples as f64).collect();

        // Positions: FK of seed + forecast so the root trajectory continues across the seam.
        let prefix = NdmsConfig::h36m().kappa - 1;
        let mut forecasts = Vec::with_capacity(windows * samples);
        let mut seeds = Vec::with_capacity(windows * samples);
        let mut speeds = Vec::with_capacity(windows * samples);
        let mut apd_sum = 0.0;
        for (w, window) in self.windows.iter().enumerate() {
            let mut flattened = Array2::zeros((samples, horizon * self.skeleton.len() * 3));
            for k in 0..samples {
                let forecast = predictions.slice(s![w, k, .., ..]);
                let joined = concatenate(Axis(0), &[window.seed.view(), forecast])?;
                let positions = expmap_positions(
                    &self.skeleton,
                    joined.view(),
                    RootEncoding::Deltas,
                    ROOT_STEP_25HZ,
                )?;
                let split = window.seed.nrows();
                let future = positions.slice(s![split.., .., ..]);
                flattened
                    .row_mut(k)
                    .iter_mut()
                    .zip(future.iter())
                    .for_each(|(d, v)| *d = *v);
                speeds.push(Speed {
                    world: last_second_speed(positions.view(), split),
                    pose: pose_speed(&self.skeleton, joined.view(), split)?,
                });
                seeds.push(
                    positions
                        .slice(s![split - prefix..split, .., ..])
                        .to_owned(),
                );
                forecasts.push(future.to_owned());
            }
            if samples > 1 {
                apd_sum += apd(flattened.view())?;
            }
            on_window();
        }
        debug_assert_eq!(width, self.skeleton.expmap_width());
        let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
        let seed_views: Vec<_> = seeds.iter().map(|f| f.view()).collect();
        let ndms = self
            .database
            .score_forecasts(&forecast_views, Some(&seed_views))?;
        Ok(Scores {
            euler_per_frame,
            npss: mean_npss(&npss_sets),
            npss_reference: mean_npss(&reference_sets),
            ndms,
            apd: (samples > 1).then(|| apd_sum / windows as f64),
            speed_last_second: mean_speed(&speeds),
        })
    }
}

fn npss_scores(
    npss: &mut Npss,
    gt: &Array3<f64>,
    pred: &Array3<f64>,
    power: SpectrumPower,
) -> Result<NpssScores> {
    let whole = npss.score(gt.view(), pred.view(), power)?;
    let windows = npss
        .score_windows(gt.view(), pred.view(), power, &NPSS_WINDOWS_25HZ)?
        .into_iter()
        .map(|w| (w.window.label, w.value))
        .collect();
    Ok(NpssScores { whole, windows })
}

/// The mean over sample sets of NPSS scores with the same windows.
fn mean_npss(sets: &[NpssScores]) -> NpssScores {
    let n = sets.len() as f64;
    let whole = sets.iter().map(|s| s.whole).sum::<f64>() / n;
    let windows = sets[0]
        .windows
        .iter()
        .enumerate()
        .map(|(i, (label, _))| (*label, sets.iter().map(|s| s.windows[i].1).sum::<f64>() / n))
        .collect();
    NpssScores { whole, windows }
}

fn mean_speed(speeds: &[Speed]) -> Speed {
    let n = speeds.len() as f64;
    Speed {
        world: speeds.iter().map(|s| s.world).sum::<f64>() / n,
        pose: speeds.iter().map(|s| s.pose).sum::<f64>() / n,
    }
}

/// Mean displacement per frame of the 12 NDMS joints over the last second of `positions`
/// (`T x J x 3`, the forecast starting at `split`): the last `min(25, T - split)` frame-to-frame
/// steps, the first of which may start at the last seed frame.
fn last_second_speed(positions: ndarray::ArrayView3<'_, f64>, split: usize) -> f64 {
    let frames = positions.dim().0;
    let steps = LAST_SECOND_FRAMES.min(frames - split);
    let mut sum = 0.0;
    for t in frames - steps..frames {
        for &j in &H36M_NDMS_JOINTS {
            let d: f64 = (0..3)
                .map(|c| positions[[t, j, c]] - positions[[t - 1, j, c]])
                .map(|v| v * v)
                .sum();
            sum += d.sqrt();
        }
    }
    sum / (steps * H36M_NDMS_JOINTS.len()) as f64
}

/// [`last_second_speed`] of the body alone: FK of `frames` with the root-delta dims 0..5 zeroed.
fn pose_speed(skeleton: &Skeleton, frames: ArrayView2<'_, f64>, split: usize) -> Result<f64> {
    let mut still = frames.to_owned();
    still.slice_mut(s![.., ..6]).fill(0.0);
    let positions = expmap_positions(skeleton, still.view(), RootEncoding::Deltas, ROOT_STEP_25HZ)?;
    Ok(last_second_speed(positions.view(), split))
}

/// Speed of the ground truth of one window (seed + ground truth joined like the predictions).
fn joined_speed(
    skeleton: &Skeleton,
    seed: &Array2<f64>,
    future: ArrayView2<'_, f64>,
) -> Result<Speed> {
    let joined = concatenate(Axis(0), &[seed.view(), future])?;
    let positions = expmap_positions(
        skeleton,
        joined.view(),
        RootEncoding::Deltas,
        ROOT_STEP_25HZ,
    )?;
    Ok(Speed {
        world: last_second_speed(positions.view(), seed.nrows()),
        pose: pose_speed(skeleton, joined.view(), seed.nrows())?,
    })
}
