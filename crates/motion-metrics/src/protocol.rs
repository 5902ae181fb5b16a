//! The H3.6M test protocol scored for one action: a model's (or the zero-velocity baseline's)
//! predictions of the 8 test windows, `K` samples each, against the ground truth, with every
//! metric of `motion-cli eval` ([`ActionTruth::score`]).
//!
//! How `K` samples enter each metric:
//! - Euler error: every sample is scored against its window's ground truth; the mean over all
//!   `8 x K` sequences (= the mean over samples of the per-sample means over windows).
//! - NPSS: sample index `k` of the 8 windows is one set of 8 sequences, scored as the metric
//!   defines (power-weighted over sequences and dims); the mean over `k`.
//! - NDMS: f_sim over all words of all `8 x K` forecasts (Tanke et al. 2021 eq. 9).
//! - APD: per window over its `K` samples, then the mean over windows.
//! - Joint speed (mm per frame of the 12 NDMS joints over the last second): the mean over all
//!   `8 x K` forecasts.
//!
//! Horizons past the test windows' guaranteed 100 frames (up to 300, 12 s): a window's ground
//! truth ends where its S5 file does. The Euler error of frame `t` is the mean over the windows
//! that cover `t` (each window's dims chosen over its covered frames); NPSS `whole` is over the
//! frames every window covers, and each NPSS window (0-1 .. 8-12 s) over the windows covering
//! it completely; the ground truth's last-second speed over the windows covering the horizon.
//! With every window covering the horizon (always up to 100 frames) this is the protocol as
//! before.
use std::sync::Arc;

use ndarray::{concatenate, s, Array2, Array3, Array4, ArrayView2, ArrayView3, ArrayView4, Axis};

use motion_core::error::MotionError;
use motion_core::protocol::{expmap_batch_to_euler_protocol, WindowData};
use motion_core::skeleton::H36M_NDMS_JOINTS;
use motion_core::Skeleton;

use crate::baselines::{protocol_positions, zero_velocity_held_root};
use crate::ndms::{NdmsConfig, NdmsDatabase, NdmsReport};
use crate::npss::{Npss, NpssWindow, SpectrumPower, NPSS_LONG_WINDOWS_25HZ, NPSS_WINDOWS_25HZ};
use crate::{apd, euler_error, MetricError};

/// Why one action's protocol could not be scored.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ProtocolError {
    /// A metric refused the arrays (non-finite predictions, too few frames, ...).
    #[error("{what}: {source}")]
    Metric {
        /// What was being scored.
        what: &'static str,
        /// The metric's error.
        source: MetricError,
    },
    /// Forward kinematics refused a frame (positions of a window or a prediction).
    #[error("{what}: {source}")]
    Kinematics {
        /// Whose positions.
        what: &'static str,
        /// The kinematics error.
        source: MotionError,
    },
    /// The predictions do not have the windows' shape.
    #[error(
        "predictions have shape {found:?}; expected [{windows}, samples >= 1, {horizon}, {width}]"
    )]
    Shape {
        /// The shape given.
        found: Vec<usize>,
        /// Test windows of the action.
        windows: usize,
        /// Predicted frames.
        horizon: usize,
        /// Dims per frame.
        width: usize,
    },
    /// No test windows, or a horizon of 0 frames.
    #[error("nothing to score: {windows} test windows, horizon {horizon} frames")]
    NoWindows {
        /// Test windows given.
        windows: usize,
        /// Predicted frames asked for.
        horizon: usize,
    },
}

fn metric(what: &'static str) -> impl FnOnce(MetricError) -> ProtocolError {
    move |source| ProtocolError::Metric { what, source }
}

fn kinematics(what: &'static str) -> impl FnOnce(MotionError) -> ProtocolError {
    move |source| ProtocolError::Kinematics { what, source }
}

/// Shape errors of `concatenate` / `stack` here come from arrays this module sized itself.
fn joined<A: Clone, D: ndarray::RemoveAxis>(
    result: Result<ndarray::Array<A, D>, ndarray::ShapeError>,
) -> ndarray::Array<A, D> {
    result.expect("arrays sized by this module")
}

/// The clips of [`ActionTruth::real_motion_ndms`]: `count` pieces of `len` frames as
/// `(sequence index, first frame)`, deterministic. Clip `i` comes from the `i mod n`-th of the `n`
/// sequences at least `len` frames long (in the given order); the clips of one sequence start
/// evenly spread over it (`(frames - len) · (j + 1) / (clips + 1)` for its `j`-th of `clips`).
/// Empty when no sequence is long enough or `count` is 0.
pub fn real_motion_clips(
    sequences: &[Array2<f64>],
    count: usize,
    len: usize,
) -> Vec<(usize, usize)> {
    let long: Vec<usize> = (0..sequences.len())
        .filter(|&k| sequences[k].nrows() >= len)
        .collect();
    if long.is_empty() {
        return Vec::new();
    }
    let n = long.len();
    (0..count)
        .map(|i| {
            let (which, j) = (i % n, i / n);
            let clips = (count - which).div_ceil(n);
            let free = sequences[long[which]].nrows() - len;
            (long[which], free * (j + 1) / (clips + 1))
        })
        .collect()
}

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
    ) -> Result<Self, ProtocolError> {
        if windows.is_empty() || horizon == 0 {
            return Err(ProtocolError::NoWindows {
                windows: windows.len(),
                horizon,
            });
        }
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
            positions.push(
                protocol_positions(&skeleton, sequence.view())
                    .map_err(kinematics("the NDMS reference sequences"))?,
            );
        }
        let position_views: Vec<_> = positions.iter().map(|p| p.view()).collect();
        let database = NdmsDatabase::from_sequences(
            NdmsConfig::h36m_body_frame(),
            &position_views,
            crate::NnMethod::default(),
        )
        .map_err(metric("the NDMS database"))?;
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

    /// The zero-velocity baseline of every window, root held
    /// ([`crate::baselines::zero_velocity_held_root`]): `windows x 1 x horizon x 99`. Its
    /// angles are the protocol's repeated last frame, so its Euler error and NPSS are Gopalakrishnan et al. 2019
    /// Table 6's baseline.
    pub fn zero_velocity(&self) -> Array4<f64> {
        let width = self.skeleton.expmap_width();
        let mut out = Array4::zeros((self.windows.len(), 1, self.horizon, width));
        for (w, window) in self.windows.iter().enumerate() {
            out.slice_mut(s![w, 0, .., ..])
                .assign(&zero_velocity_held_root(window.seed.view(), self.horizon));
        }
        out
    }

    /// NDMS of *real* motion that is not the truth: one clip (the windows' seed length plus the
    /// horizon, at 25 Hz) of `other_sequences` (the action's takes of other subjects, e.g. the
    /// training subjects) per test window, chosen by [`real_motion_clips`], scored as a forecast
    /// exactly as [`ActionTruth::score`] scores one (seed seam, same database). What a model whose
    /// motion is perfectly real, but not the test subject's continuation, scores under this
    /// protocol. `None` when no sequence is long enough for a clip.
    pub fn real_motion_ndms(
        &self,
        other_sequences: &[Array2<f64>],
    ) -> Result<Option<NdmsReport>, ProtocolError> {
        let seed = self.windows.first().map_or(0, |w| w.seed.nrows());
        let prefix = NdmsConfig::h36m().kappa - 1;
        let clips = real_motion_clips(other_sequences, self.windows.len(), seed + self.horizon);
        if clips.is_empty() || seed < prefix {
            return Ok(None);
        }
        let mut forecasts = Vec::with_capacity(clips.len());
        let mut seeds = Vec::with_capacity(clips.len());
        for (k, start) in clips {
            let frames = other_sequences[k].slice(s![start..start + seed + self.horizon, ..]);
            let positions = protocol_positions(&self.skeleton, frames)
                .map_err(kinematics("the other subjects' real motion"))?;
            seeds.push(positions.slice(s![seed - prefix..seed, .., ..]).to_owned());
            forecasts.push(positions.slice(s![seed.., .., ..]).to_owned());
        }
        let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
        let seed_views: Vec<_> = seeds.iter().map(|f| f.view()).collect();
        self.database
            .score_forecasts(&forecast_views, Some(&seed_views))
            .map(Some)
            .map_err(metric("NDMS of real motion"))
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
    ) -> Result<Scores, ProtocolError> {
        let (windows, samples, horizon, width) = predictions.dim();
        if windows != self.windows.len()
            || samples == 0
            || horizon != self.horizon
            || width != self.skeleton.expmap_width()
        {
            return Err(ProtocolError::Shape {
                found: predictions.shape().to_vec(),
                windows: self.windows.len(),
                horizon: self.horizon,
                width: self.skeleton.expmap_width(),
            });
        }

        // Euler error and NPSS: one set of 8 windows per sample index.
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
        let common_gt = joined(ndarray::stack(Axis(0), &common_gt));
        for k in 0..samples {
            let set = predictions.slice(s![.., k, .., ..]);
            let euler = expmap_batch_to_euler_protocol(set);
            if self.fully_covered() {
                // The protocol: all 8 windows over the whole horizon.
                let per_frame =
                    euler_error(common_gt.view(), euler.view()).map_err(metric("Euler error"))?;
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
                    )
                    .map_err(metric("Euler error"))?;
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
                let joined = joined(concatenate(Axis(0), &[window.seed.view(), forecast]));
                let positions = protocol_positions(&self.skeleton, joined.view())
                    .map_err(kinematics("the predictions"))?;
                let split = window.seed.nrows();
                let future = positions.slice(s![split.., .., ..]);
                flattened
                    .row_mut(k)
                    .iter_mut()
                    .zip(future.iter())
                    .for_each(|(d, v)| *d = *v);
                speeds.push(Speed {
                    world: last_second_speed(positions.view(), split),
                    pose: pose_speed(&self.skeleton, joined.view(), split)
                        .map_err(kinematics("the predictions"))?,
                });
                seeds.push(
                    positions
                        .slice(s![split - prefix..split, .., ..])
                        .to_owned(),
                );
                forecasts.push(future.to_owned());
            }
            if samples > 1 {
                apd_sum += apd(flattened.view()).map_err(metric("APD"))?;
            }
            on_window();
        }
        let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
        let seed_views: Vec<_> = seeds.iter().map(|f| f.view()).collect();
        let ndms = self
            .database
            .score_forecasts(&forecast_views, Some(&seed_views))
            .map_err(metric("NDMS"))?;
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
    ) -> Result<NpssScores, ProtocolError> {
        let common = self.common;
        let pred_common = pred.slice(s![.., ..common, ..]);
        let whole = npss
            .score(common_gt.view(), pred_common, power)
            .map_err(metric("NPSS"))?;
        let mut windows = Vec::new();
        for window in npss_windows(self.horizon) {
            let range = window.start..window.end;
            let value = if window.end <= common {
                npss.score(
                    common_gt.slice(s![.., range.clone(), ..]),
                    pred.slice(s![.., range, ..]),
                    power,
                )
                .map_err(metric("NPSS"))?
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
                    joined(ndarray::stack(Axis(0), &gt)).view(),
                    joined(ndarray::stack(Axis(0), &p)).view(),
                    power,
                )
                .map_err(metric("NPSS"))?
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
fn last_second_speed(positions: ArrayView3<'_, f64>, split: usize) -> f64 {
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
fn pose_speed(
    skeleton: &Skeleton,
    frames: ArrayView2<'_, f64>,
    split: usize,
) -> Result<f64, MotionError> {
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
) -> Result<Speed, ProtocolError> {
    let joined = joined(concatenate(Axis(0), &[seed.view(), future]));
    let positions =
        protocol_positions(skeleton, joined.view()).map_err(kinematics("the ground truth"))?;
    Ok(Speed {
        world: last_second_speed(positions.view(), seed.nrows()),
        pose: pose_speed(skeleton, joined.view(), seed.nrows())
            .map_err(kinematics("the ground truth"))?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use motion_core::protocol::TestWindow;

    const WIDTH: usize = 99;

    /// Smooth exp-map frames: small joint-angle sines, a root moving `root_step` per frame.
    fn frames(n: usize, phase: f64, root_step: f64) -> Array2<f64> {
        Array2::from_shape_fn((n, WIDTH), |(t, d)| match d {
            0 => root_step,
            1..=5 => 0.0,
            _ => 0.3 * (0.2 * t as f64 + 0.7 * d as f64 + phase).sin(),
        })
    }

    fn window(sample: usize, ground_truth: usize) -> WindowData {
        let all = frames(50 + ground_truth, sample as f64, 0.0);
        WindowData {
            window: TestWindow {
                action: "walking",
                sample,
                subaction: 1,
                seed_start: 0,
                predict_start: 50,
                even_frames_in_file: 50 + ground_truth,
            },
            seed: all.slice(s![..50, ..]).to_owned(),
            root_before: None,
            ground_truth: all.slice(s![50.., ..]).to_owned(),
        }
    }

    #[test]
    fn real_motion_clips_alternate_over_the_long_sequences_and_spread_inside_each() {
        let seqs = [
            frames(200, 0.0, 0.0),
            frames(50, 0.0, 0.0),
            frames(300, 0.0, 0.0),
        ];
        let clips = real_motion_clips(&seqs, 5, 100);
        assert_eq!(clips, vec![(0, 25), (2, 66), (0, 50), (2, 133), (0, 75)]);
        assert!(real_motion_clips(&seqs, 3, 301).is_empty());
        assert!(real_motion_clips(&seqs, 0, 10).is_empty());
        for (k, start) in real_motion_clips(&seqs, 9, 200) {
            assert!(start + 200 <= seqs[k].nrows());
        }
    }

    #[test]
    fn real_motion_in_the_database_scores_one_and_other_motion_less() {
        let windows = (0..2).map(|i| window(i, 40)).collect();
        let references = [frames(160, 0.3, 4.0), frames(140, 1.1, 4.0)];
        let truth = ActionTruth::new(windows, &references, 40).unwrap();
        let same = truth.real_motion_ndms(&references).unwrap().unwrap();
        assert_eq!(same.per_word.len(), 40);
        assert!(
            same.per_word.iter().all(|&v| (v - 1.0).abs() < 1e-9),
            "{:?}",
            same.per_word
        );
        let other = truth
            .real_motion_ndms(&[frames(120, 2.0, 9.0)])
            .unwrap()
            .unwrap();
        assert!(other.mean < 0.99 && other.mean > 0.0, "{}", other.mean);
        assert!(truth
            .real_motion_ndms(&[frames(60, 0.0, 4.0)])
            .unwrap()
            .is_none());
    }

    fn truth(ground_truth: &[usize], horizon: usize) -> ActionTruth {
        let windows = ground_truth
            .iter()
            .enumerate()
            .map(|(i, &n)| window(i, n))
            .collect();
        let references = [frames(120, 0.3, 0.0), frames(90, 1.1, 0.0)];
        ActionTruth::new(windows, &references, horizon).unwrap()
    }

    /// The ground truth itself as `windows x 1 x horizon x 99` predictions.
    fn perfect(truth: &ActionTruth) -> Array4<f64> {
        let mut out = Array4::zeros((truth.windows().len(), 1, truth.horizon, WIDTH));
        for (w, window) in truth.windows().iter().enumerate() {
            out.slice_mut(s![w, 0, .., ..])
                .assign(&window.ground_truth.slice(s![..truth.horizon, ..]));
        }
        out
    }

    #[test]
    fn the_ground_truth_scores_zero_error_and_its_own_speed() {
        let truth = truth(&[40; 4], 40);
        let scores = truth.score(perfect(&truth).view(), || {}).unwrap();
        assert!(scores.euler_per_frame.iter().all(|e| e.abs() < 1e-12));
        assert!(scores.npss.whole.abs() < 1e-12 && scores.npss_reference.whole.abs() < 1e-12);
        let real = truth.speed_last_second.unwrap();
        assert!(real.pose > 1.0, "the sines move the joints: {real:?}");
        assert!((scores.speed_last_second.pose - real.pose).abs() < 1e-9);
        assert!((scores.speed_last_second.world - real.world).abs() < 1e-9);
        assert_eq!(scores.apd, None, "one sample: no APD");
    }

    #[test]
    fn zero_velocity_holds_the_last_pose_and_the_root() {
        let truth = truth(&[30; 3], 30);
        let baseline = truth.zero_velocity();
        assert_eq!(baseline.shape(), &[3, 1, 30, WIDTH]);
        for (w, window) in truth.windows().iter().enumerate() {
            let last = window.seed.row(49);
            for t in 0..30 {
                for d in 0..WIDTH {
                    let expected = if d < 6 { 0.0 } else { last[d] };
                    assert_eq!(baseline[[w, 0, t, d]], expected);
                }
            }
        }
        let scores = truth.score(baseline.view(), || {}).unwrap();
        assert!(scores.speed_last_second.pose < 1e-9 && scores.speed_last_second.world < 1e-9);
        assert!(scores.euler_per_frame[29] > scores.euler_per_frame[0]);
    }

    #[test]
    fn pose_speed_ignores_the_root_and_world_speed_does_not() {
        // A frozen body carried along by the root: world speed > 0, pose speed 0.
        let truth = truth(&[30; 2], 30);
        let mut gliding = truth.zero_velocity();
        gliding.slice_mut(s![.., .., .., 0]).fill(5.0);
        let scores = truth.score(gliding.view(), || {}).unwrap();
        assert!(scores.speed_last_second.pose < 1e-9);
        assert!(scores.speed_last_second.world > 1.0);
    }

    #[test]
    fn windows_that_end_early_only_count_where_they_cover() {
        // Window 1's file ends 20 frames into a 40-frame horizon.
        let truth = truth(&[40, 20, 40], 40);
        let coverage = truth.coverage();
        assert_eq!(coverage.frames_per_window, vec![40, 20, 40]);
        assert_eq!(coverage.npss_whole_frames, 20);
        assert_eq!(coverage.windows_per_second, vec![2, 2]);
        assert!(truth.speed_last_second.is_some());
        // Predictions: perfect where there is truth, anything past it (zeros).
        let mut predictions = Array4::zeros((3, 2, 40, WIDTH));
        for (w, window) in truth.windows().iter().enumerate() {
            let n = window.ground_truth.nrows();
            for k in 0..2 {
                predictions
                    .slice_mut(s![w, k, ..n, ..])
                    .assign(&window.ground_truth);
            }
        }
        let scores = truth.score(predictions.view(), || {}).unwrap();
        assert_eq!(scores.euler_per_frame.len(), 40);
        assert!(scores.euler_per_frame.iter().all(|e| e.abs() < 1e-12));
        assert_eq!(scores.apd, Some(0.0), "two identical samples");
    }

    #[test]
    fn bad_shapes_and_empty_input_are_typed_errors() {
        let truth = truth(&[30; 2], 30);
        for shape in [
            (3, 1, 30, WIDTH),
            (2, 0, 30, WIDTH),
            (2, 1, 29, WIDTH),
            (2, 1, 30, 54),
        ] {
            let err = truth.score(Array4::zeros(shape).view(), || {}).unwrap_err();
            assert!(
                matches!(err, ProtocolError::Shape { .. }),
                "{shape:?}: {err}"
            );
        }
        let mut nan = perfect(&truth);
        nan[[1, 0, 3, 7]] = f64::NAN;
        let err = truth.score(nan.view(), || {}).unwrap_err();
        assert!(err.to_string().contains("non-finite"), "{err}");
        let err = ActionTruth::new(Vec::new(), &[frames(40, 0.0, 0.0)], 10)
            .err()
            .unwrap();
        assert!(
            matches!(err, ProtocolError::NoWindows { windows: 0, .. }),
            "{err}"
        );
        let err = ActionTruth::new(vec![window(0, 10)], &[frames(40, 0.0, 0.0)], 0)
            .err()
            .unwrap();
        assert!(
            matches!(err, ProtocolError::NoWindows { horizon: 0, .. }),
            "{err}"
        );
    }
}
