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
//!
//! Horizons past the test windows' guaranteed 100 frames (up to 300, 12 s): a window's ground
//! truth ends where its S5 file does. The Euler error of frame `t` is the mean over the windows
//! that cover `t` (each window's dims chosen over its covered frames); NPSS `whole` is over the
//! frames every window covers, and each NPSS window (0-1 .. 8-12 s) over the windows covering
//! it completely; the ground truth's last-second speed over the windows covering the horizon.
//! With every window covering the horizon (always up to 100 frames) this is the protocol as
//! before.
use std::sync::Arc;

use anyhow::Result;
use ndarray::{concatenate, s, Array2, Array3, ArrayView2, ArrayView4, Axis};

use motion_core::protocol::{expmap_batch_to_euler_protocol, protocol_positions, WindowData};
use motion_core::skeleton::H36M_NDMS_JOINTS;
use motion_core::Skeleton;
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NdmsReport};
use motion_metrics::npss::{
    Npss, NpssWindow, SpectrumPower, NPSS_LONG_WINDOWS_25HZ, NPSS_WINDOWS_25HZ,
};
use motion_metrics::{apd, euler_error};

/// Frames of the last second at 25 Hz (joint-speed check).
const LAST_SECOND_FRAMES: usize = 25;

/// NPSS on the whole horizon and on the paper's windows that fit in it.
#[derive(Debug, Clone, PartialEq)]
pub struct NpssScores {
    /// Over all predicted frames (that every test window's ground truth covers).
    pub whole: f64,
    /// `(label, value)` for 0-1 s, 1-2 s, 2-4 s, 4-8 s, 8-12 s (those inside the horizon and
    /// covered by at least one window's ground truth).
    pub windows: Vec<(&'static str, f64)>,
}

/// How much of the horizon the test windows' ground truth covers.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    /// Frames of ground truth per test window (at most the horizon).
    pub frames_per_window: Vec<usize>,
    /// Per second of the horizon (the last one possibly partial): windows covering all of it.
    pub windows_per_second: Vec<usize>,
    /// Frames every window covers: NPSS `whole` is over these.
    pub npss_whole_frames: usize,
    /// Per NPSS window label: the test windows covering it (the NPSS of that window is over them).
    pub npss_windows: Vec<(String, usize)>,
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
    /// The predicted frames per window.
    horizon: usize,
    /// Euler sequences of each window's ground truth (`covered x 99`).
    gt_euler: Vec<Array2<f64>>,
    /// The frames every window covers (`min(horizon, shortest ground truth)`).
    common: usize,
    database: NdmsDatabase,
    skeleton: Arc<Skeleton>,
    /// Mean joint speed of the ground truth over the last second (windows covering the horizon;
    /// `None` when none does).
    pub speed_last_second: Option<Speed>,
}

/// The NPSS windows of a horizon of `frames`.
fn npss_windows(frames: usize) -> impl Iterator<Item = NpssWindow> {
    NPSS_WINDOWS_25HZ
        .into_iter()
        .chain(NPSS_LONG_WINDOWS_25HZ)
        .filter(move |w| w.end <= frames)
}

impl ActionTruth {
    /// Prepares the windows' ground truth (each at most `horizon` frames, shorter where its file
    /// ends) and the NDMS database of `reference_sequences` (the action's S5 files at 25 Hz).
    pub fn new(
        windows: Vec<WindowData>,
        reference_sequences: &[Array2<f64>],
        horizon: usize,
    ) -> Result<Self> {
        let skeleton = Arc::new(Skeleton::h36m());
        let gt_euler: Vec<Array2<f64>> = windows
            .iter()
            .map(|w| motion_core::protocol::expmap_to_euler_protocol(w.ground_truth.view()))
            .collect();
        let common = windows
            .iter()
            .map(|w| w.ground_truth.nrows())
            .min()
            .unwrap_or(0)
            .min(horizon);
        let mut positions = Vec::with_capacity(reference_sequences.len());
        for sequence in reference_sequences {
            positions.push(protocol_positions(&skeleton, sequence.view())?);
        }
        let position_views: Vec<_> = positions.iter().map(|p| p.view()).collect();
        let database = NdmsDatabase::from_sequences(
            NdmsConfig::h36m_body_frame(),
            &position_views,
            motion_metrics::NnMethod::default(),
        )?;
        let mut speeds = Vec::new();
        for w in windows.iter().filter(|w| w.ground_truth.nrows() >= horizon) {
            speeds.push(joined_speed(&skeleton, &w.seed, w.ground_truth.view())?);
        }
        let speed_last_second = (!speeds.is_empty()).then(|| mean_speed(&speeds));
        Ok(Self {
            windows,
            horizon,
            gt_euler,
            common,
            database,
            skeleton,
            speed_last_second,
        })
    }

    /// Whether every window's ground truth covers the whole horizon.
    fn fully_covered(&self) -> bool {
        self.common == self.horizon
    }

    /// How much of the horizon the ground truth covers.
    pub fn coverage(&self) -> Coverage {
        let frames: Vec<usize> = self
            .windows
            .iter()
            .map(|w| w.ground_truth.nrows())
            .collect();
        let seconds = self.horizon.div_ceil(LAST_SECOND_FRAMES);
        let windows_per_second = (0..seconds)
            .map(|s| {
                let end = ((s + 1) * LAST_SECOND_FRAMES).min(self.horizon);
                frames.iter().filter(|&&f| f >= end).count()
            })
            .collect();
        let npss_windows = npss_windows(self.horizon)
            .map(|w| {
                (
                    w.label.to_string(),
                    frames.iter().filter(|&&f| f >= w.end).count(),
                )
            })
            .collect();
        Coverage {
            frames_per_window: frames,
            windows_per_second,
            npss_whole_frames: self.common,
            npss_windows,
        }
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
        debug_assert_eq!(horizon, self.horizon);
        let covered = self
            .gt_euler
            .iter()
            .map(|g| g.nrows())
            .max()
            .unwrap_or(0)
            .min(horizon);
        let mut euler_sum = vec![0.0; covered];
        let mut euler_count = vec![0usize; covered];
        let mut npss_sets = Vec::with_capacity(samples);
        let mut reference_sets = Vec::with_capacity(samples);
        let mut npss = Npss::new();
        let common_gt: Vec<ArrayView2<'_, f64>> = self
            .gt_euler
            .iter()
            .map(|g| g.slice(s![..self.common, ..]))
            .collect();
        let common_gt = ndarray::stack(Axis(0), &common_gt)?;
        for k in 0..samples {
            let set = predictions.slice(s![.., k, .., ..]);
            let euler = expmap_batch_to_euler_protocol(set);
            if self.fully_covered() {
                // The protocol: all 8 windows over the whole horizon.
                let per_frame = euler_error(common_gt.view(), euler.view())?;
                euler_sum
                    .iter_mut()
                    .zip(&per_frame)
                    .for_each(|(s, e)| *s += e);
                euler_count.iter_mut().for_each(|c| *c += 1);
            } else {
                for (w, gt) in self.gt_euler.iter().enumerate() {
                    let n = gt.nrows().min(horizon);
                    let per_frame = euler_error(
                        gt.slice(s![..n, ..]).insert_axis(Axis(0)),
                        euler.slice(s![w..w + 1, ..n, ..]),
                    )?;
                    for (t, e) in per_frame.iter().enumerate() {
                        euler_sum[t] += e;
                        euler_count[t] += 1;
                    }
                }
            }
            for (power, sets) in [
                (SpectrumPower::Modulus, &mut npss_sets),
                (SpectrumPower::RealPart, &mut reference_sets),
            ] {
                sets.push(self.npss_scores(&mut npss, &common_gt, &euler, power)?);
            }
        }
        // Fully covered: the sum over samples of the 8-window means, over K; otherwise the sum
        // of every covering (window, sample), over their count.
        let euler_per_frame = euler_sum
            .iter()
            .zip(&euler_count)
            .map(|(s, &c)| s / c as f64)
            .collect();

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
                let positions = protocol_positions(&self.skeleton, joined.view())?;
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

impl ActionTruth {
    /// NPSS of one sample set (`pred`: `8 x H x 99` Euler): `whole` over the frames every
    /// window covers (`common_gt`: `8 x common x 99`), each NPSS window over the test windows
    /// covering it.
    fn npss_scores(
        &self,
        npss: &mut Npss,
        common_gt: &Array3<f64>,
        pred: &Array3<f64>,
        power: SpectrumPower,
    ) -> Result<NpssScores> {
        let common = self.common;
        let pred_common = pred.slice(s![.., ..common, ..]);
        let whole = npss.score(common_gt.view(), pred_common, power)?;
        let mut windows = Vec::new();
        for window in npss_windows(self.horizon) {
            let range = window.start..window.end;
            let value = if window.end <= common {
                npss.score(
                    common_gt.slice(s![.., range.clone(), ..]),
                    pred.slice(s![.., range, ..]),
                    power,
                )?
            } else {
                let covering: Vec<usize> = (0..self.gt_euler.len())
                    .filter(|&w| self.gt_euler[w].nrows() >= window.end)
                    .collect();
                if covering.is_empty() {
                    continue;
                }
                let gt: Vec<_> = covering
                    .iter()
                    .map(|&w| self.gt_euler[w].slice(s![range.clone(), ..]))
                    .collect();
                let p: Vec<_> = covering
                    .iter()
                    .map(|&w| pred.slice(s![w, range.clone(), ..]))
                    .collect();
                npss.score(
                    ndarray::stack(Axis(0), &gt)?.view(),
                    ndarray::stack(Axis(0), &p)?.view(),
                    power,
                )?
            };
            windows.push((window.label, value));
        }
        Ok(NpssScores { whole, windows })
    }
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
    let positions = protocol_positions(skeleton, still.view())?;
    Ok(last_second_speed(positions.view(), split))
}

/// Speed of the ground truth of one window (seed + ground truth joined like the predictions).
fn joined_speed(
    skeleton: &Skeleton,
    seed: &Array2<f64>,
    future: ArrayView2<'_, f64>,
) -> Result<Speed> {
    let joined = concatenate(Axis(0), &[seed.view(), future])?;
    let positions = protocol_positions(skeleton, joined.view())?;
    Ok(Speed {
        world: last_second_speed(positions.view(), seed.nrows()),
        pose: pose_speed(skeleton, joined.view(), seed.nrows())?,
    })
}
