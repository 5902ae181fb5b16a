//! Plausibility of generated motion without ground truth (issue 14): `speed_ratio`, `drift` and
//! `foot_contact`, per window of the horizon, judged against real data of the same action.
//!
//! ## Definitions (stated once; `score`, `eval`, tables, JSON and plots use these)
//! Inputs are H3.6M exp-map frames at the protocol's 25 Hz (99 dims; dims 0..5 are root deltas,
//! each applied [`ROOT_STEP_25HZ`] = 2 times when the root is integrated, `motion_core::root`):
//! a **seed** of `S >= 1` frames and the **motion** after it, `T` frames. Motion frame `i`
//! (0-based) lies `(i + 1) / 25` s after the last seed frame.
//!
//! - **Windows** ([`horizon_windows`]): 0-2, 2-4, 4-8 and 8-12 s, i.e. motion frames
//!   `[0, 50)`, `[50, 100)`, `[100, 200)`, `[200, 300)`, then 12-20, 20-30, 30-40, 40-50 and
//!   50-60 s for long horizons; a window is cut at the horizon `T` (its `end_s` says where) and
//!   left out when it starts at or after `T`. Frames past 60 s are in no window
//!   ([`MAX_HORIZON_FRAMES`]). Real windows (the drift p95) are 12 s long
//!   ([`REAL_WINDOW_FRAMES`]).
//! - **Root-frame positions** `q_t,j`: forward kinematics of all 32 joints with the root's
//!   translation and rotation set to zero (identity root pose).
//! - **Joint speed** of motion frame `i`: `v_i = 25 Hz · (1/32) · Σ_j |q_i,j − q_i−1,j|` in mm/s,
//!   where frame `i − 1` of motion frame 0 is the last seed frame.
//! - **`speed_ratio`** of a window: the mean of `v_i` over the window's frames (and over the
//!   sequences that cover the window), divided by the action's **reference speed**: the mean of
//!   the same `v` over every frame step of the action's S5 files at 25 Hz (both subactions, steps
//!   pooled; [`reference::ActionReference`]). 1 moves like the data, 0 is frozen.
//! - **World positions** `x_t,j = (q_t,j − o_0) · R_t + o_0 + T_t` (row vectors; `o_0` the root
//!   offset, 0 for H3.6M): the root pose `(R_t, T_t)` integrated over seed + motion from the first
//!   seed frame, exactly as FK of the joined frames (`expmap_positions`): from the identity for a
//!   seed that starts a file, and for a seed cut from a take (a test window, a real drift window)
//!   from the take's own root pose before it (`motion_core::protocol::WindowData::root_before`,
//!   integrated from the take's first frame), so a seated or bending body keeps the orientation it really had.
//! - **Floor frame**: the seed's floor (`motion_core::grounding::floor`: a plane fitted to the
//!   lowest of each seed frame's foot points [`FEET`], lowest in the frame the fit levels) made
//!   the plane `y = 0`
//!   by a rigid transform; every measure below is taken in it, so a walk whose integrated root is
//!   tilted is not read as climbing.
//! - **Hip height** `h_t`: the floor-frame y of `Hips` (joint 0), mm. **Torso lean** `λ_t`: the
//!   angle in degrees between +y and the floor-frame vector `Hips (0) → Neck (13)` (H3.6M's
//!   `Neck` joint is the top of the thorax, where the shoulders attach).
//! - **`drift`** of one sequence in a window: `max_i |h_i − h_s|` (mm) and `max_i |λ_i − λ_s|`
//!   (degrees) over the window's frames, `s` = the last seed frame. Reported per window: the mean
//!   over sequences, the largest, and the fraction of sequences at or below the action's **p95**:
//!   the 95th percentile (linear interpolation between order statistics, numpy's default) of the
//!   same per-window drift over real 12 s windows of the action, every subject (S1, S5, S6, S7,
//!   S8, S9, S11), a window starting every 25 frames, each seeded like a prediction by the 50
//!   frames before it (its root integrated from the take's first frame, as a test window's).
//!   Integrated H3.6M roots carry the capture's small orientation errors, so real motion drifts
//!   too (a walk tilted by 3° climbs 400 mm in 8 m): drift is judged against the data, never
//!   against zero.
//! - **`foot_contact`**: a frame is *airborne* when both feet (each foot = the lowest of its
//!   points [`FEET`]) are more than [`FOOT_CLEARANCE_MM`] = 100 mm above the floor (`y = 0` of the
//!   floor frame). `foot_contact` of a window = the fraction of its frames (over the covering
//!   sequences) that are airborne: 0 keeps contact (a still pose gives 0), 1 floats.
//! - **On the floor**: the lowest foot point within [`ON_FLOOR_MM`] of the floor.
//!   **Penetration**: the lowest foot point more than [`PENETRATION_MM`] under it.
//! - **Foot skating** (the motion-diffusion literature's definition): a frame skates when a foot
//!   point under [`SKATING_HEIGHT_MM`] moves faster than [`SKATING_SPEED_MM_S`] horizontally
//!   (floor frame, against the previous frame).
//!
//! A sequence shorter than the horizon (real continuations that the file ends) contributes to the
//! windows it covers completely; each window reports how many sequences it averages.
//!
//! ## Example
//! ```
//! use motion_metrics::plausibility::{horizon_windows, Measurer};
//! use ndarray::Array2;
//!
//! let still = Array2::<f64>::zeros((60, 99)); // 10 seed frames + 50 frames of a still rest pose
//! let mut measurer = Measurer::new();
//! let m = measurer.measure(still.slice(ndarray::s![..10, ..]), still.slice(ndarray::s![10.., ..]))?;
//! let w = m.window(&horizon_windows(50)[0]).unwrap();
//! assert_eq!((w.mean_speed_mm_s, w.hip_height_mm, w.lean_deg, w.airborne_fraction), (0.0, 0.0, 0.0, 0.0));
//! # Ok::<(), motion_metrics::MetricError>(())
//! ```
pub mod reference;

use ndarray::ArrayView2;
use rayon::prelude::*;
use serde::Serialize;

use glam::DVec3;
use motion_core::grounding::Floor;
use motion_core::kinematics::ExpMapFk;
use motion_core::root::{RootIntegrator, RootPose};
use motion_core::rotation::vec_mul_mat3;
use motion_core::skeleton::{H36M_FRAME_DIMS, H36M_PROTOCOL_FPS};
use motion_core::Skeleton;

use crate::error::{check_finite, MetricError};

pub use motion_core::protocol::ROOT_STEP_25HZ;
pub use reference::{action_reference, ActionReference, RealRanges, ReferenceError};

/// The windows' bounds in seconds after the seed.
pub const WINDOW_BOUNDS_S: [(u32, u32); 9] = [
    (0, 2),
    (2, 4),
    (4, 8),
    (8, 12),
    (12, 20),
    (20, 30),
    (30, 40),
    (40, 50),
    (50, 60),
];
/// The frames the windows cover at 25 Hz (60 s).
pub const MAX_HORIZON_FRAMES: usize = 1500;
/// Motion frames of a real window of the drift reference (12 s: Ghosh et al. 2017's horizon).
pub const REAL_WINDOW_FRAMES: usize = 300;
/// Both feet higher than this above the seed's floor: airborne (mm).
pub const FOOT_CLEARANCE_MM: f64 = 100.0;
/// The hip joint (height) and the root of the torso vector.
pub const HIPS: usize = 0;
/// The top of the torso vector (`Neck`, the top of the thorax).
pub const TORSO_TOP: usize = 13;
/// The points of each foot (`motion_core::grounding::legs` on the H3.6M skeleton): right and
/// left ankle, toe and toe end site.
pub const FEET: [[usize; 3]; 2] = [[3, 4, 5], [8, 9, 10]];
/// A lowest foot point within this of the floor is on it (mm).
pub const ON_FLOOR_MM: f64 = 100.0;
/// A lowest foot point deeper than this under the floor penetrates it (mm).
pub const PENETRATION_MM: f64 = 20.0;
/// Foot points below this height can skate (mm).
pub const SKATING_HEIGHT_MM: f64 = 50.0;
/// ... when they move faster than this horizontally (mm/s).
pub const SKATING_SPEED_MM_S: f64 = 500.0;
/// The percentile of real drift reported beside a prediction's.
pub const DRIFT_PERCENTILE: f64 = 95.0;

/// One window of the horizon.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HorizonWindow {
    /// Start, seconds after the last seed frame.
    pub start_s: f64,
    /// End (cut at the horizon), seconds after the last seed frame.
    pub end_s: f64,
    /// First motion frame (inclusive).
    pub start_frame: usize,
    /// One past the last motion frame.
    pub end_frame: usize,
}

/// The windows of [`WINDOW_BOUNDS_S`] that a horizon of `frames` motion frames allows (cut at it).
pub fn horizon_windows(frames: usize) -> Vec<HorizonWindow> {
    let fps = H36M_PROTOCOL_FPS;
    WINDOW_BOUNDS_S
        .iter()
        .filter_map(|&(a, b)| {
            let start = (f64::from(a) * fps).round() as usize;
            let end = ((f64::from(b) * fps).round() as usize).min(frames);
            (start < end).then(|| HorizonWindow {
                start_s: f64::from(a),
                end_s: end as f64 / fps,
                start_frame: start,
                end_frame: end,
            })
        })
        .collect()
}

/// Per-frame measures of one sequence (one value per motion frame).
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceMeasures {
    /// Joint speed `v_i` in the root frame (mm/s).
    pub speed_mm_s: Vec<f64>,
    /// `|h_i − h_s|`: hip height change from the last seed frame (mm).
    pub hip_height_change_mm: Vec<f64>,
    /// `|λ_i − λ_s|`: torso lean change from the last seed frame (degrees).
    pub lean_change_deg: Vec<f64>,
    /// Both feet more than [`FOOT_CLEARANCE_MM`] above the seed's floor.
    pub airborne: Vec<bool>,
    /// Torso lean `λ_i` (degrees, floor frame).
    pub lean_deg: Vec<f64>,
    /// Hip height above the floor (mm).
    pub hip_height_mm: Vec<f64>,
    /// Height of the lowest foot point above the floor (mm; negative under it).
    pub lowest_foot_mm: Vec<f64>,
    /// Foot skating ([`SKATING_HEIGHT_MM`], [`SKATING_SPEED_MM_S`]).
    pub skating: Vec<bool>,
}

/// One sequence's values in one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowMeasures {
    /// Mean joint speed (mm/s).
    pub mean_speed_mm_s: f64,
    /// Largest hip height change (mm).
    pub hip_height_mm: f64,
    /// Largest torso lean change (degrees).
    pub lean_deg: f64,
    /// Fraction of airborne frames.
    pub airborne_fraction: f64,
    /// 95th percentile of the torso lean (degrees).
    pub lean_p95_deg: f64,
    /// 5th and 95th percentiles of the hip height above the floor (mm).
    pub hip_height_p5_p95_mm: (f64, f64),
    /// Fraction of frames whose lowest foot point is within [`ON_FLOOR_MM`] of the floor.
    pub on_floor_fraction: f64,
    /// Fraction of frames that penetrate the floor ([`PENETRATION_MM`]).
    pub penetration_fraction: f64,
    /// Fraction of frames that skate.
    pub skating_fraction: f64,
}

impl SequenceMeasures {
    /// Motion frames measured.
    pub fn frames(&self) -> usize {
        self.speed_mm_s.len()
    }

    /// The values in `window`; `None` when the sequence ends before the window does.
    pub fn window(&self, window: &HorizonWindow) -> Option<WindowMeasures> {
        if self.frames() < window.end_frame {
            return None;
        }
        let range = window.start_frame..window.end_frame;
        let n = range.len() as f64;
        let max = |v: &[f64]| v[range.clone()].iter().copied().fold(0.0, f64::max);
        let fraction = |v: &[bool]| v[range.clone()].iter().filter(|&&a| a).count() as f64 / n;
        let share = |v: &[f64], keep: &dyn Fn(f64) -> bool| {
            v[range.clone()].iter().filter(|&&x| keep(x)).count() as f64 / n
        };
        let mut lean = self.lean_deg[range.clone()].to_vec();
        let mut hips = self.hip_height_mm[range.clone()].to_vec();
        Some(WindowMeasures {
            lean_p95_deg: reference::percentile(&mut lean, 95.0),
            hip_height_p5_p95_mm: (
                reference::percentile(&mut hips, 5.0),
                reference::percentile(&mut hips, 95.0),
            ),
            on_floor_fraction: share(&self.lowest_foot_mm, &|h| h.abs() <= ON_FLOOR_MM),
            penetration_fraction: share(&self.lowest_foot_mm, &|h| h < -PENETRATION_MM),
            skating_fraction: fraction(&self.skating),
            mean_speed_mm_s: self.speed_mm_s[range.clone()].iter().sum::<f64>() / n,
            hip_height_mm: max(&self.hip_height_change_mm),
            lean_deg: max(&self.lean_change_deg),
            airborne_fraction: fraction(&self.airborne),
        })
    }
}

/// Computes [`SequenceMeasures`]: one forward kinematics per frame into scratch allocated once.
#[derive(Debug, Clone)]
pub struct Measurer {
    skeleton: Skeleton,
    fk: ExpMapFk,
    frame: Vec<f64>,
    previous: Vec<[f64; 3]>,
    current: Vec<[f64; 3]>,
}

impl Default for Measurer {
    fn default() -> Self {
        Self::new()
    }
}

/// The state of a seed's last frame that the motion is measured against.
#[derive(Debug, Clone, Copy)]
struct Anchor {
    hip_height: f64,
    lean: f64,
}

impl Measurer {
    /// Scratch for the H3.6M skeleton.
    pub fn new() -> Self {
        let skeleton = Skeleton::h36m();
        let joints = skeleton.len();
        Self {
            fk: ExpMapFk::new(&skeleton),
            frame: vec![0.0; skeleton.expmap_width()],
            previous: vec![[0.0; 3]; joints],
            current: vec![[0.0; 3]; joints],
            skeleton,
        }
    }

    /// Measures `motion` (`T x 99`) after `seed` (`S x 99`), both 25 Hz H3.6M exp-map frames.
    ///
    /// Errors: a width other than 99, an empty seed or motion, a non-finite value.
    pub fn measure(
        &mut self,
        seed: ArrayView2<'_, f64>,
        motion: ArrayView2<'_, f64>,
    ) -> Result<SequenceMeasures, MetricError> {
        self.measure_after(None, seed, motion)
    }

    /// [`Self::measure`] of a seed that continues a take after `root_before`, the absolute
    /// root pose of the frame before it (`motion_core::protocol::WindowData::root_before`; `None`: the seed
    /// starts the take, integrated from the identity).
    pub fn measure_after(
        &mut self,
        root_before: Option<RootPose>,
        seed: ArrayView2<'_, f64>,
        motion: ArrayView2<'_, f64>,
    ) -> Result<SequenceMeasures, MetricError> {
        self.measure_with(root_before, None, seed, motion)
    }

    /// [`Self::measure`] of frames already in their floor frame, the plane `y = 0` (a grounded
    /// clip: grounding moved its seed there, `motion_core::grounding::clip`), measured on that
    /// floor rather than a floor fitted again (the fit of a levelled seed can come out a
    /// degree or two off level, which reads a body that walks a few metres as sinking).
    pub fn measure_in_floor_frame(
        &mut self,
        seed: ArrayView2<'_, f64>,
        motion: ArrayView2<'_, f64>,
    ) -> Result<SequenceMeasures, MetricError> {
        self.measure_with(None, Some(Floor::level_at(0.0)), seed, motion)
    }

    fn measure_with(
        &mut self,
        root_before: Option<RootPose>,
        floor: Option<Floor>,
        seed: ArrayView2<'_, f64>,
        motion: ArrayView2<'_, f64>,
    ) -> Result<SequenceMeasures, MetricError> {
        for (what, a) in [("seed", &seed), ("motion", &motion)] {
            if a.ncols() != H36M_FRAME_DIMS {
                return Err(MetricError::ShapeMismatch {
                    what: format!("{what} (H3.6M exp-map frames)"),
                    found: a.shape().to_vec(),
                    expected: vec![a.nrows(), H36M_FRAME_DIMS],
                });
            }
            if a.nrows() == 0 {
                return Err(MetricError::Empty {
                    what: format!("{what} has no frames"),
                });
            }
            check_finite(what, a)?;
        }
        let mut root = RootIntegrator::after(root_before, ROOT_STEP_25HZ);
        let mut feet = Vec::with_capacity(seed.nrows() * 6);
        let mut pose = RootPose::IDENTITY;
        for row in seed.rows() {
            pose = self.push(&mut root, row);
            feet.extend(
                FEET.iter()
                    .flatten()
                    .map(|&j| (DVec3::from_array(self.world(j, &pose)) * 1e-3).as_vec3()),
            );
        }
        let floor = match floor {
            Some(floor) => floor,
            None => Floor::fit_frames(&feet, 6).unwrap_or_else(|| Floor::level_at(0.0)),
        };
        let on_floor =
            |p: [f64; 3]| (floor.to_floor_frame_f64(DVec3::from_array(p) * 1e-3) * 1e3).to_array();
        let lean_of = |m: &Self, pose: &RootPose| {
            let (a, b) = (
                on_floor(m.world(HIPS, pose)),
                on_floor(m.world(TORSO_TOP, pose)),
            );
            let v = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            (v[0] * v[0] + v[2] * v[2]).sqrt().atan2(v[1]).to_degrees()
        };
        let anchor = Anchor {
            hip_height: on_floor(self.world(HIPS, &pose))[1],
            lean: lean_of(self, &pose),
        };
        let mut previous_feet = FEET.map(|foot| foot.map(|j| on_floor(self.world(j, &pose))));
        let frames = motion.nrows();
        let mut out = SequenceMeasures {
            speed_mm_s: Vec::with_capacity(frames),
            hip_height_change_mm: Vec::with_capacity(frames),
            lean_change_deg: Vec::with_capacity(frames),
            airborne: Vec::with_capacity(frames),
            lean_deg: Vec::with_capacity(frames),
            hip_height_mm: Vec::with_capacity(frames),
            lowest_foot_mm: Vec::with_capacity(frames),
            skating: Vec::with_capacity(frames),
        };
        for row in motion.rows() {
            pose = self.push(&mut root, row);
            out.speed_mm_s.push(self.speed());
            let hips = on_floor(self.world(HIPS, &pose))[1];
            let lean = lean_of(self, &pose);
            out.hip_height_change_mm
                .push((hips - anchor.hip_height).abs());
            out.lean_change_deg.push((lean - anchor.lean).abs());
            out.hip_height_mm.push(hips);
            out.lean_deg.push(lean);
            let feet = FEET.map(|foot| foot.map(|j| on_floor(self.world(j, &pose))));
            let low =
                |foot: &[[f64; 3]; 3]| foot.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
            out.airborne
                .push(feet.iter().all(|foot| low(foot) > FOOT_CLEARANCE_MM));
            out.lowest_foot_mm
                .push(feet.iter().map(low).fold(f64::INFINITY, f64::min));
            let mut skating = false;
            for (foot, before) in feet.iter().zip(&previous_feet) {
                for (p, q) in foot.iter().zip(before) {
                    let horizontal = ((p[0] - q[0]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                    skating |= p[1] < SKATING_HEIGHT_MM
                        && horizontal * H36M_PROTOCOL_FPS > SKATING_SPEED_MM_S;
                }
            }
            out.skating.push(skating);
            previous_feet = feet;
        }
        Ok(out)
    }

    /// Integrates the root of `row`, keeps the previous frame's root-frame positions and computes
    /// this frame's into `current`.
    fn push(&mut self, root: &mut RootIntegrator, row: ndarray::ArrayView1<'_, f64>) -> RootPose {
        for (d, s) in self.frame.iter_mut().zip(row.iter()) {
            *d = *s;
        }
        let pose = root.push(&self.frame);
        std::mem::swap(&mut self.previous, &mut self.current);
        self.fk.frame(
            &self.skeleton,
            &self.frame,
            &RootPose::IDENTITY,
            &mut self.current,
        );
        pose
    }

    /// The world position of joint `j` of the current frame under the root pose `pose`.
    fn world(&self, j: usize, pose: &RootPose) -> [f64; 3] {
        let o = self.skeleton.joint(0).offset;
        let q = self.current[j];
        let r = vec_mul_mat3([q[0] - o[0], q[1] - o[1], q[2] - o[2]], &pose.rotation);
        [0, 1, 2].map(|k| r[k] + o[k] + pose.translation[k])
    }

    /// Mean joint speed (mm/s) between the previous and the current frame.
    fn speed(&self) -> f64 {
        let sum: f64 = self
            .previous
            .iter()
            .zip(&self.current)
            .map(|(p, c)| {
                ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2) + (c[2] - p[2]).powi(2)).sqrt()
            })
            .sum();
        sum / self.current.len() as f64 * H36M_PROTOCOL_FPS
    }
}

/// [`Measurer::measure`] of many `(seed, motion)` pairs in parallel, in order.
pub fn measure_sequences(
    pairs: &[(ArrayView2<'_, f64>, ArrayView2<'_, f64>)],
) -> Result<Vec<SequenceMeasures>, MetricError> {
    measure_all(pairs, |m, &(seed, motion)| m.measure(seed, motion))
}

/// Each item measured in parallel, one [`Measurer`] per worker.
fn measure_all<T: Sync>(
    items: &[T],
    measure: impl Fn(&mut Measurer, &T) -> Result<SequenceMeasures, MetricError> + Sync + Send,
) -> Result<Vec<SequenceMeasures>, MetricError> {
    items.par_iter().map_init(Measurer::new, measure).collect()
}

/// [`measure_sequences`] of clips already in their floor frame
/// ([`Measurer::measure_in_floor_frame`]).
pub fn measure_sequences_in_floor_frame(
    pairs: &[(ArrayView2<'_, f64>, ArrayView2<'_, f64>)],
) -> Result<Vec<SequenceMeasures>, MetricError> {
    measure_all(pairs, |m, &(seed, motion)| {
        m.measure_in_floor_frame(seed, motion)
    })
}

/// [`measure_sequences`] of seeds that continue takes, each after its root pose
/// ([`Measurer::measure_after`]).
pub fn measure_sequences_after(
    triples: &[(Option<RootPose>, ArrayView2<'_, f64>, ArrayView2<'_, f64>)],
) -> Result<Vec<SequenceMeasures>, MetricError> {
    measure_all(triples, |m, &(before, seed, motion)| {
        m.measure_after(before, seed, motion)
    })
}

/// `speed_ratio` in one window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedRatioWindow {
    /// Window start (s after the seed).
    pub start_s: f64,
    /// Window end (s).
    pub end_s: f64,
    /// Sequences that cover the window.
    pub sequences: usize,
    /// Their mean joint speed in the root frame (mm/s); `None` when no sequence covers it.
    pub mean_speed_mm_s: Option<f64>,
    /// `mean_speed_mm_s` / the action's reference speed.
    pub ratio: Option<f64>,
}

/// `speed_ratio` of a set of sequences.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedRatioReport {
    /// The action whose data is the reference.
    pub action: String,
    /// The reference: mean joint speed over every 25 Hz frame step of the action's S5 files (mm/s).
    pub reference_mean_speed_mm_s: f64,
    /// Per window.
    pub windows: Vec<SpeedRatioWindow>,
}

/// `drift` in one window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriftWindow {
    /// Window start (s after the seed).
    pub start_s: f64,
    /// Window end (s).
    pub end_s: f64,
    /// Sequences that cover the window.
    pub sequences: usize,
    /// Mean over sequences of the largest hip height change in the window (mm).
    pub hip_height_mm: Option<f64>,
    /// The largest over sequences (mm).
    pub hip_height_max_mm: Option<f64>,
    /// p95 of the same over real windows of the action (mm).
    pub hip_height_p95_mm: f64,
    /// Fraction of sequences whose hip height change is at most the p95 (1 = all within).
    pub hip_height_within_p95: Option<f64>,
    /// Mean over sequences of the largest torso lean change in the window (degrees).
    pub lean_deg: Option<f64>,
    /// The largest over sequences (degrees).
    pub lean_max_deg: Option<f64>,
    /// p95 of the same over real windows of the action (degrees).
    pub lean_p95_deg: f64,
    /// Fraction of sequences whose lean change is at most the p95.
    pub lean_within_p95: Option<f64>,
}

/// `drift` of a set of sequences.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriftReport {
    /// The action whose data is the reference.
    pub action: String,
    /// Real 12 s windows behind the p95.
    pub reference_windows: usize,
    /// Per window.
    pub windows: Vec<DriftWindow>,
}

/// `foot_contact` in one window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FootContactWindow {
    /// Window start (s after the seed).
    pub start_s: f64,
    /// Window end (s).
    pub end_s: f64,
    /// Sequences that cover the window.
    pub sequences: usize,
    /// Fraction of frames with both feet more than the clearance above the seed's floor.
    pub airborne_fraction: Option<f64>,
}

/// `foot_contact` of a set of sequences.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FootContactReport {
    /// Both feet higher than this above the seed's lowest foot joint: airborne (mm).
    pub clearance_mm: f64,
    /// Per window.
    pub windows: Vec<FootContactWindow>,
}

/// The floor-frame measures (lean, hip height, floor contact, penetration, skating) in one
/// window: means over the sequences covering it of each one's value in the window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroundWindow {
    /// Window start (s after the seed).
    pub start_s: f64,
    /// Window end (s).
    pub end_s: f64,
    /// Sequences that cover the window.
    pub sequences: usize,
    /// 95th percentile of the torso lean (degrees).
    pub lean_p95_deg: Option<f64>,
    /// 5th percentile of the hip height above the floor (mm).
    pub hip_height_p5_mm: Option<f64>,
    /// 95th percentile of the hip height above the floor (mm).
    pub hip_height_p95_mm: Option<f64>,
    /// Fraction of frames with the lowest foot point within [`ON_FLOOR_MM`] of the floor.
    pub on_floor_fraction: Option<f64>,
    /// Fraction of frames penetrating the floor by more than [`PENETRATION_MM`].
    pub penetration_fraction: Option<f64>,
    /// Fraction of frames that skate.
    pub skating_fraction: Option<f64>,
}

/// The floor-frame measures of a set of sequences, beside real motion's ranges.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroundReport {
    /// What real motion of the action does ([`reference::RealRanges`]).
    pub real: reference::RealRanges,
    /// Per window.
    pub windows: Vec<GroundWindow>,
}

/// The three measures of a set of sequences of one action, per window of a horizon.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlausibilityReport {
    /// Motion frames per sequence asked for (the windows are cut at it).
    pub horizon_frames: usize,
    /// Sequences measured.
    pub sequences: usize,
    /// `speed_ratio`.
    pub speed_ratio: SpeedRatioReport,
    /// `drift`.
    pub drift: DriftReport,
    /// `foot_contact`.
    pub foot_contact: FootContactReport,
    /// Floor-frame measures.
    pub ground: GroundReport,
}

impl PlausibilityReport {
    /// Aggregates `measures` (sequences of one action; each covers the windows it is long enough
    /// for) over the windows of `horizon_frames`, against `reference`.
    pub fn new(
        measures: &[SequenceMeasures],
        horizon_frames: usize,
        reference: &ActionReference,
    ) -> Self {
        let windows = horizon_windows(horizon_frames);
        let mut speed = Vec::new();
        let mut drift = Vec::new();
        let mut feet = Vec::new();
        let mut ground = Vec::new();
        for w in &windows {
            let values: Vec<WindowMeasures> = measures.iter().filter_map(|m| m.window(w)).collect();
            let n = values.len();
            let mean = |f: fn(&WindowMeasures) -> f64| {
                (n > 0).then(|| values.iter().map(f).sum::<f64>() / n as f64)
            };
            let max = |f: fn(&WindowMeasures) -> f64| {
                (n > 0).then(|| values.iter().map(f).fold(f64::NEG_INFINITY, f64::max))
            };
            let p95 = reference.drift_p95(w);
            let within = |f: fn(&WindowMeasures) -> f64, limit: f64| {
                (n > 0).then(|| values.iter().filter(|v| f(v) <= limit).count() as f64 / n as f64)
            };
            let mean_speed = mean(|v| v.mean_speed_mm_s);
            speed.push(SpeedRatioWindow {
                start_s: w.start_s,
                end_s: w.end_s,
                sequences: n,
                mean_speed_mm_s: mean_speed,
                ratio: mean_speed.map(|s| s / reference.s5_mean_speed_mm_s),
            });
            drift.push(DriftWindow {
                start_s: w.start_s,
                end_s: w.end_s,
                sequences: n,
                hip_height_mm: mean(|v| v.hip_height_mm),
                hip_height_max_mm: max(|v| v.hip_height_mm),
                hip_height_p95_mm: p95.hip_height_mm,
                hip_height_within_p95: within(|v| v.hip_height_mm, p95.hip_height_mm),
                lean_deg: mean(|v| v.lean_deg),
                lean_max_deg: max(|v| v.lean_deg),
                lean_p95_deg: p95.lean_deg,
                lean_within_p95: within(|v| v.lean_deg, p95.lean_deg),
            });
            feet.push(FootContactWindow {
                start_s: w.start_s,
                end_s: w.end_s,
                sequences: n,
                airborne_fraction: mean(|v| v.airborne_fraction),
            });
            ground.push(GroundWindow {
                start_s: w.start_s,
                end_s: w.end_s,
                sequences: n,
                lean_p95_deg: mean(|v| v.lean_p95_deg),
                hip_height_p5_mm: mean(|v| v.hip_height_p5_p95_mm.0),
                hip_height_p95_mm: mean(|v| v.hip_height_p5_p95_mm.1),
                on_floor_fraction: mean(|v| v.on_floor_fraction),
                penetration_fraction: mean(|v| v.penetration_fraction),
                skating_fraction: mean(|v| v.skating_fraction),
            });
        }
        Self {
            horizon_frames,
            sequences: measures.len(),
            speed_ratio: SpeedRatioReport {
                action: reference.action.clone(),
                reference_mean_speed_mm_s: reference.s5_mean_speed_mm_s,
                windows: speed,
            },
            drift: DriftReport {
                action: reference.action.clone(),
                reference_windows: reference.drift_windows(),
                windows: drift,
            },
            foot_contact: FootContactReport {
                clearance_mm: FOOT_CLEARANCE_MM,
                windows: feet,
            },
            ground: GroundReport {
                real: reference.real,
                windows: ground,
            },
        }
    }
}

#[cfg(test)]
mod tests;
