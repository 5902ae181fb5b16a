//! Posture realism (issue 58): how far the distribution of generated body postures lies from real
//! ones of the same action, on any rig: a Fréchet distance over body-frame pose features, the
//! earth mover's distance of upper-arm and thigh elevation histograms, and the share of frames
//! whose arms rise above what real people of the action do.
//!
//! ## Example
//! ```
//! use motion_metrics::posture::{h36m_joints, h36m_positions, PostureReference};
//! use ndarray::Array2;
//!
//! // 25 Hz H3.6M exp-map frames: every joint angle swinging with amplitude `amp` (radians).
//! let frames = |amp: f64, phase: f64| {
//!     Array2::from_shape_fn((250, 99), |(t, d)| {
//!         if d < 6 { 0.0 } else { amp * (0.25 * t as f64 + phase + d as f64).sin() }
//!     })
//! };
//! let real = h36m_positions(frames(0.2, 0.0).view(), None)?; // world positions, T x 32 x 3
//! let reference = PostureReference::from_takes(&h36m_joints(), &[real.view()])?;
//!
//! let same = reference.measure(&[real.view()])?;
//! assert!(same.frechet < 1e-9 && same.arm_elevation_emd_deg == 0.0);
//! assert!(same.arms_above_real_p99 < 0.01 + 1.0 / 250.0); // p99 of itself: about 1 %
//!
//! let wild = h36m_positions(frames(0.9, 1.0).view(), None)?;
//! let report = reference.measure(&[wild.view()])?;
//! assert!(report.frechet > 0.1 && report.arm_elevation_emd_deg > 10.0);
//! println!("{}", serde_json::to_string(&report).unwrap());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Definitions (stated once; reports, tables and JSON use these)
//! Input: world joint positions per frame (`T x J x 3`, the rig's units, **+y up**), e.g.
//! [`h36m_positions`] of exp-map frames, [`take_positions`] of an H3.6M take, or
//! `motion_core::kinematics::channel_positions` of a BVH.
//!
//! **Joints** ([`PostureJoints::find`], from the skeleton's topology and rest offsets, any naming
//! and units; or given explicitly, its fields are public):
//! - legs (hip, knee, ankle), the **torso top** and the leg length: `motion_core::grounding::
//!   find_body_parts` (the legs' rule; the torso top is a joint named `Neck`, else the first joint
//!   off the legs where two or more chains branch);
//! - **pelvis**: the lowest common ancestor of the two hips; when the finder's torso top is the
//!   pelvis or above it (a rig rooted on the floor, without a `Neck`), the torso top is the first
//!   joint below the pelvis, off the legs, where two or more chains branch;
//! - **chains off the spine**: the subtrees hanging from a joint of the path root → torso top
//!   (the torso top included) that are not on that path and hold no hip, knee or ankle; each one's
//!   *reach* is the summed rest bone length from its spine joint to its farthest leaf;
//! - **arms**: the two chains of largest reach; the **head**: the farthest leaf, highest in the
//!   rest pose, of the other chains (none when there are none);
//! - **shoulder, elbow, wrist** of an arm, on the path from its spine joint to its farthest leaf
//!   with joints at zero-length bones merged into their parent: the elbow is the first joint
//!   named like one ([`ELBOW_NAME_WORDS`]), the shoulder and wrist the path joints on either side
//!   of it; for rigs without such names, the forearm is the last bone at least half as long as the
//!   longest bone of the path and the upper arm the bone before it;
//! - arms are ordered by their wrists' rest x (then joint index): the order carries no meaning
//!   for the measures, which pool both sides or compare them on the same rig.
//!
//! On H3.6M's 32 joints ([`h36m_joints`]): hips `*UpLeg`, knees `*Leg`, ankles `*Foot`, pelvis
//! `Hips`, torso top `Neck`, head `HeadSite`, shoulders `*Arm`, elbows `*ForeArm`, wrists `*Hand`,
//! leg length 897.1 mm.
//!
//! **Pelvis heading frame** of a frame: origin at the pelvis; `y` = world +y; `z` = the forward
//! direction `forward_sign · (lateral × y)` made horizontal and unit, `lateral` = hip of
//! `legs[0]` → hip of `legs[1]` (`forward_sign` makes the rest pose's toes point forward); `x = y ×
//! z`. Only the yaw is removed: lean and roll stay in the features. (When the hips are vertically
//! stacked the yaw is left as it is.)
//!
//! **Features** of a frame (`f64`, [`PostureJoints::feature_dims`] = 66 with a head):
//! - the heading-frame positions, divided by the leg length (so subjects and rigs compare), of
//!   both hips, knees, ankles, the torso top, the head, both shoulders, elbows, wrists (the pelvis
//!   itself is the origin);
//! - the heading-frame unit directions of the upper arms (shoulder → elbow), forearms (elbow →
//!   wrist), thighs (hip → knee) and shins (knee → ankle), two sides each.
//!
//! **`frechet`**: the Fréchet distance between the Gaussian fits of the generated and the real
//! feature sets, `||μ_g − μ_r||² + Tr(S_g + S_r − 2 (S_r S_g)^{1/2})` (mean and covariance over
//! frames, the covariance normalised by `N − 1`, 0 for one frame). Exact in `f64`: `S_r = V Λ Vᵀ`
//! by a cyclic Jacobi eigensolver, `Tr (S_r S_g)^{1/2}` = `Σ_k sqrt(μ_k)` over the eigenvalues
//! `μ_k` of `Λ^{1/2} Vᵀ S_g V Λ^{1/2}` (similar to `S_r^{1/2} S_g S_r^{1/2}`; eigenvalues below 0,
//! rounding of semi-definite matrices, count as 0). 0 is identical distributions; the unit is
//! leg lengths squared. The Gaussian needs many more frames than the 66 dimensions to be a fit:
//! compare values from sets of similar size.
//!
//! **Elevation** of a limb in a frame: the angle in degrees between the limb (upper arm: shoulder
//! → elbow; thigh: hip → knee) and the **trunk axis** pointing down the body (torso top →
//! pelvis): 0 for a hanging arm or a standing leg, 90 for an arm held out at shoulder height or a
//! thigh of a seated body, 180 straight up. **Histograms**: [`ELEVATION_BINS`] = 18 bins of
//! [`ELEVATION_BIN_DEG`] = 10° over 0-180° (the last bin holds 180°), both sides pooled, as
//! fractions of the limb-frames.
//!
//! **`arm_elevation_emd_deg`**, **`thigh_elevation_emd_deg`**: the earth mover's distance
//! between the generated and the real histogram, each bin's mass at its centre, ground distance
//! in degrees; exact for 1-D histograms: `10° · Σ_{k<17} |G_k − R_k|` over the cumulative
//! fractions `G_k`, `R_k` ([`elevation_emd_deg`]). 0 is the same histogram; 90 moves every arm
//! from hanging to shoulder height.
//!
//! **`arms_above_real_p99`**: the fraction of generated frames whose higher upper arm's elevation
//! exceeds the **real p99**: the 99th percentile (numpy's linear interpolation) of the same
//! per-frame value over the reference's frames. A real set of `N` frames measured against itself
//! gives about 0.01 (less than `0.01 + 1/N`).
//!
//! ## References and windows
//! A [`PostureReference`] is built once per action from real takes (H3.6M:
//! [`h36m_reference`] over [`REFERENCE_SUBJECTS`], the six training subjects, each take from
//! frame [`REFERENCE_START_FRAME`] on; S5's takes read the same way and measured against it give
//! the real-vs-real values that a number is read against). [`PostureReference::
//! measure`] measures a set of generated windows pooled as one distribution (one per sequence, or
//! one window of every sequence of the action). A window of 60 s (1500 frames at 25 Hz) is
//! measured **whole**, as one set of frames, not cut into the plausibility module's shorter
//! windows: the Gaussian fit needs the frames, and drift into a posture shows as the share of the
//! minute spent there. Shorter windows are measured the same way, pooled over the action's
//! sequences so that each set holds well over 66 frames.
//!
//! Cost: one pass over the frames (features, a streaming mean and co-moment update, O(66²) per
//! frame), then one 66 x 66 Jacobi eigendecomposition per measurement (the reference's own is
//! made once).
mod h36m;
mod joints;
mod linalg;

use ndarray::{Array2, ArrayView3};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::{check_finite, MetricError};
use crate::plausibility::reference::percentile;

pub use h36m::{
    h36m_joints, h36m_positions, h36m_reference, h36m_take_positions, take_positions,
    REFERENCE_START_FRAME, REFERENCE_SUBJECTS,
};
pub use joints::{Elevations, Limb, PostureError, PostureJoints, ELBOW_NAME_WORDS};
use linalg::PreparedGaussian;
pub use linalg::{frechet_distance, symmetric_eigen};

/// Width of an elevation histogram's bin (degrees).
pub const ELEVATION_BIN_DEG: f64 = 10.0;
/// Bins of an elevation histogram (0-180°).
pub const ELEVATION_BINS: usize = 18;
/// The percentile of the real upper-arm elevation that `arms_above_real_p99` counts frames above.
pub const ARM_PERCENTILE: f64 = 99.0;

/// An elevation histogram: the fraction of limb-frames per 10° bin, 0-180°.
pub type ElevationHistogram = [f64; ELEVATION_BINS];

fn bin(deg: f64) -> usize {
    ((deg / ELEVATION_BIN_DEG).floor().max(0.0) as usize).min(ELEVATION_BINS - 1)
}

/// The earth mover's distance (degrees) between two elevation histograms of equal mass, each
/// bin's mass at its centre: `10° · Σ_{k<17} |A_k − B_k|` over their cumulative sums.
pub fn elevation_emd_deg(a: &ElevationHistogram, b: &ElevationHistogram) -> f64 {
    let (mut ca, mut cb, mut sum) = (0.0, 0.0, 0.0);
    for k in 0..ELEVATION_BINS - 1 {
        ca += a[k];
        cb += b[k];
        sum += (ca - cb).abs();
    }
    ELEVATION_BIN_DEG * sum
}

/// The streaming statistics of a set of frames: feature mean and co-moment (Welford), elevation
/// histograms and each frame's higher upper-arm elevation. Frames are added with
/// [`Self::push_frame`] / [`Self::push_frames`]; sets combine with [`Self::merge`].
#[derive(Debug, Clone, PartialEq)]
pub struct PostureStats {
    joints: PostureJoints,
    dims: usize,
    frames: usize,
    mean: Vec<f64>,
    /// Σ (x − mean)(x − mean)ᵀ, upper triangle (row-major `dims x dims`).
    comoment: Vec<f64>,
    arm_counts: [u64; ELEVATION_BINS],
    thigh_counts: [u64; ELEVATION_BINS],
    arm_max_deg: Vec<f64>,
    features: Vec<f64>,
    delta: Vec<f64>,
    scratch: Vec<[f64; 3]>,
}

impl PostureStats {
    /// No frames yet, for `joints`.
    pub fn new(joints: &PostureJoints) -> Self {
        let dims = joints.feature_dims();
        Self {
            joints: joints.clone(),
            dims,
            frames: 0,
            mean: vec![0.0; dims],
            comoment: vec![0.0; dims * dims],
            arm_counts: [0; ELEVATION_BINS],
            thigh_counts: [0; ELEVATION_BINS],
            arm_max_deg: Vec::new(),
            features: vec![0.0; dims],
            delta: vec![0.0; dims],
            scratch: Vec::new(),
        }
    }

    /// Adds one frame of world positions (`positions[j]` = joint `j`).
    ///
    /// # Errors
    /// Fewer positions than the joints read, or a non-finite one.
    pub fn push_frame(&mut self, positions: &[[f64; 3]]) -> Result<(), MetricError> {
        self.check_joint_count(positions.len())?;
        if let Some(j) = positions
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(MetricError::NonFinite {
                what: "positions".into(),
                index: vec![j],
            });
        }
        self.add(positions);
        Ok(())
    }

    /// Adds every frame of `positions` (`T x J x 3`).
    ///
    /// # Errors
    /// A shape other than `T x J x 3` with `J` covering the joints read, or a non-finite value.
    pub fn push_frames(&mut self, positions: ArrayView3<'_, f64>) -> Result<(), MetricError> {
        let (_, joints, three) = positions.dim();
        if three != 3 {
            return Err(MetricError::ShapeMismatch {
                what: "positions (frames x joints x 3)".into(),
                found: positions.shape().to_vec(),
                expected: vec![positions.shape()[0], joints, 3],
            });
        }
        self.check_joint_count(joints)?;
        check_finite("positions", &positions)?;
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.resize(joints, [0.0; 3]);
        for frame in positions.outer_iter() {
            for (p, row) in scratch.iter_mut().zip(frame.outer_iter()) {
                *p = [row[0], row[1], row[2]];
            }
            self.add(&scratch);
        }
        self.scratch = scratch;
        Ok(())
    }

    fn check_joint_count(&self, joints: usize) -> Result<(), MetricError> {
        self.joints
            .check(joints)
            .map_err(|e| MetricError::InvalidConfig(format!("posture joints: {e}")))
    }

    fn add(&mut self, positions: &[[f64; 3]]) {
        let e = self.joints.frame_features(positions, &mut self.features);
        self.frames += 1;
        let n = self.frames as f64;
        let d = self.dims;
        for i in 0..d {
            self.delta[i] = self.features[i] - self.mean[i];
            self.mean[i] += self.delta[i] / n;
        }
        // C += (x − m_old)(x − m_new)ᵀ = δ δᵀ (n − 1) / n.
        let w = (n - 1.0) / n;
        for i in 0..d {
            let di = self.delta[i] * w;
            if di != 0.0 {
                let row = &mut self.comoment[i * d + i..(i + 1) * d];
                for (c, dj) in row.iter_mut().zip(&self.delta[i..]) {
                    *c += di * dj;
                }
            }
        }
        for a in e.upper_arm_deg {
            self.arm_counts[bin(a)] += 1;
        }
        for t in e.thigh_deg {
            self.thigh_counts[bin(t)] += 1;
        }
        self.arm_max_deg
            .push(e.upper_arm_deg[0].max(e.upper_arm_deg[1]));
    }

    /// Adds the frames of `other` (made for the same joints): the statistics of the union.
    ///
    /// # Errors
    /// `other` was made for other joints.
    pub fn merge(&mut self, other: &PostureStats) -> Result<(), MetricError> {
        if other.joints != self.joints {
            return Err(MetricError::InvalidConfig(
                "posture statistics of different joints cannot be merged".into(),
            ));
        }
        if other.frames == 0 {
            return Ok(());
        }
        if self.frames == 0 {
            *self = other.clone();
            return Ok(());
        }
        let (na, nb) = (self.frames as f64, other.frames as f64);
        let n = na + nb;
        let d = self.dims;
        for i in 0..d {
            self.delta[i] = other.mean[i] - self.mean[i];
        }
        let w = na * nb / n;
        for i in 0..d {
            for j in i..d {
                self.comoment[i * d + j] +=
                    other.comoment[i * d + j] + self.delta[i] * self.delta[j] * w;
            }
            self.mean[i] += self.delta[i] * nb / n;
        }
        self.frames += other.frames;
        for k in 0..ELEVATION_BINS {
            self.arm_counts[k] += other.arm_counts[k];
            self.thigh_counts[k] += other.thigh_counts[k];
        }
        self.arm_max_deg.extend_from_slice(&other.arm_max_deg);
        Ok(())
    }

    /// Frames added.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The joints the features are read from.
    pub fn joints(&self) -> &PostureJoints {
        &self.joints
    }

    /// The feature mean.
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// The feature covariance (normalised by `N − 1`; zeros for fewer than two frames).
    pub fn covariance(&self) -> Array2<f64> {
        let d = self.dims;
        Array2::from_shape_vec((d, d), self.covariance_vec()).expect("d x d")
    }

    fn covariance_vec(&self) -> Vec<f64> {
        let d = self.dims;
        let scale = if self.frames > 1 {
            1.0 / (self.frames - 1) as f64
        } else {
            0.0
        };
        let mut out = vec![0.0; d * d];
        for i in 0..d {
            for j in i..d {
                let c = self.comoment[i * d + j] * scale;
                out[i * d + j] = c;
                out[j * d + i] = c;
            }
        }
        out
    }

    /// The upper-arm elevation histogram (fractions of arm-frames, both sides pooled).
    pub fn arm_elevation_histogram(&self) -> ElevationHistogram {
        fractions(&self.arm_counts)
    }

    /// The thigh elevation histogram (fractions of thigh-frames, both sides pooled).
    pub fn thigh_elevation_histogram(&self) -> ElevationHistogram {
        fractions(&self.thigh_counts)
    }

    /// Each frame's higher upper-arm elevation (degrees), in the order added.
    pub fn arm_max_elevations_deg(&self) -> &[f64] {
        &self.arm_max_deg
    }
}

fn fractions(counts: &[u64; ELEVATION_BINS]) -> ElevationHistogram {
    let total: u64 = counts.iter().sum();
    counts.map(|c| {
        if total > 0 {
            c as f64 / total as f64
        } else {
            0.0
        }
    })
}

/// The statistics of each item's frames, computed in parallel and merged in order.
fn stats_of(
    joints: &PostureJoints,
    sets: &[ArrayView3<'_, f64>],
) -> Result<PostureStats, MetricError> {
    let parts: Vec<PostureStats> = sets
        .par_iter()
        .map(|p| {
            let mut s = PostureStats::new(joints);
            s.push_frames(*p).map(|()| s)
        })
        .collect::<Result<_, _>>()?;
    let mut all = PostureStats::new(joints);
    for p in &parts {
        all.merge(p)?;
    }
    Ok(all)
}

/// The real side of posture realism for one action (or any set of real frames): the Gaussian fit
/// of the features (its eigendecomposition made once), the elevation histograms and the p99 of
/// the upper-arm elevation.
#[derive(Debug, Clone, PartialEq)]
pub struct PostureReference {
    stats: PostureStats,
    gaussian: PreparedGaussian,
    arm_p99_deg: f64,
}

/// Posture realism of a set of generated frames against a [`PostureReference`] (definitions in
/// the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PostureReport {
    /// Generated frames measured.
    pub frames: usize,
    /// Fréchet distance between the feature Gaussians (leg lengths squared; 0 = identical).
    pub frechet: f64,
    /// Earth mover's distance of the upper-arm elevation histograms (degrees).
    pub arm_elevation_emd_deg: f64,
    /// Earth mover's distance of the thigh elevation histograms (degrees).
    pub thigh_elevation_emd_deg: f64,
    /// Fraction of frames whose higher upper arm is above the real p99 of the elevation.
    pub arms_above_real_p99: f64,
    /// Real frames behind the reference.
    pub real_frames: usize,
    /// The real p99 of the per-frame higher upper-arm elevation (degrees).
    pub real_arm_elevation_p99_deg: f64,
    /// The generated upper-arm elevation histogram (fractions per 10° bin, 0-180°).
    pub arm_elevation_histogram: ElevationHistogram,
    /// The generated thigh elevation histogram.
    pub thigh_elevation_histogram: ElevationHistogram,
}

impl PostureReference {
    /// The reference of the frames in `stats`.
    ///
    /// # Errors
    /// No frames.
    pub fn from_stats(stats: PostureStats) -> Result<Self, MetricError> {
        if stats.frames == 0 {
            return Err(MetricError::Empty {
                what: "posture reference has no frames".into(),
            });
        }
        let gaussian = PreparedGaussian::new(stats.mean.clone(), &stats.covariance_vec());
        let arm_p99_deg = percentile(&mut stats.arm_max_deg.clone(), ARM_PERCENTILE);
        Ok(Self {
            stats,
            gaussian,
            arm_p99_deg,
        })
    }

    /// The reference of real takes (each `T x J x 3` world positions on the rig of `joints`),
    /// their frames pooled.
    ///
    /// # Errors
    /// No frames; a take of the wrong shape or with a non-finite value.
    pub fn from_takes(
        joints: &PostureJoints,
        takes: &[ArrayView3<'_, f64>],
    ) -> Result<Self, MetricError> {
        Self::from_stats(stats_of(joints, takes)?)
    }

    /// Measures generated windows (each `T x J x 3` world positions), their frames pooled.
    ///
    /// # Errors
    /// No frames; a window of the wrong shape or with a non-finite value.
    pub fn measure(&self, windows: &[ArrayView3<'_, f64>]) -> Result<PostureReport, MetricError> {
        self.measure_stats(&stats_of(&self.stats.joints, windows)?)
    }

    /// Measures frames already gathered in `stats`.
    ///
    /// # Errors
    /// No frames; `stats` made for other joints.
    pub fn measure_stats(&self, stats: &PostureStats) -> Result<PostureReport, MetricError> {
        if stats.joints != self.stats.joints {
            return Err(MetricError::InvalidConfig(
                "the generated frames were read with other joints than the reference".into(),
            ));
        }
        if stats.frames == 0 {
            return Err(MetricError::Empty {
                what: "no generated frames".into(),
            });
        }
        let arm = stats.arm_elevation_histogram();
        let thigh = stats.thigh_elevation_histogram();
        let above = stats
            .arm_max_deg
            .iter()
            .filter(|&&a| a > self.arm_p99_deg)
            .count();
        Ok(PostureReport {
            frames: stats.frames,
            frechet: self.gaussian.frechet(&stats.mean, &stats.covariance_vec()),
            arm_elevation_emd_deg: elevation_emd_deg(&arm, &self.stats.arm_elevation_histogram()),
            thigh_elevation_emd_deg: elevation_emd_deg(
                &thigh,
                &self.stats.thigh_elevation_histogram(),
            ),
            arms_above_real_p99: above as f64 / stats.frames as f64,
            real_frames: self.stats.frames,
            real_arm_elevation_p99_deg: self.arm_p99_deg,
            arm_elevation_histogram: arm,
            thigh_elevation_histogram: thigh,
        })
    }

    /// The real p99 of the per-frame higher upper-arm elevation (degrees).
    pub fn arm_p99_deg(&self) -> f64 {
        self.arm_p99_deg
    }

    /// The real frames' statistics.
    pub fn stats(&self) -> &PostureStats {
        &self.stats
    }

    /// The joints the features are read from.
    pub fn joints(&self) -> &PostureJoints {
        &self.stats.joints
    }

    /// Real frames behind the reference.
    pub fn frames(&self) -> usize {
        self.stats.frames
    }

    /// The real p99 of the per-frame higher upper-arm elevation (degrees).
    pub fn arm_elevation_p99_deg(&self) -> f64 {
        self.arm_p99_deg
    }
}
