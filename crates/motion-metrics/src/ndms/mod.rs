//! NDMS, the motion-quality score of Tanke et al. 2021 (section 4), exactly as `metrics.md` defines it:
//! every query word of a forecast is scored against its **exact** nearest neighbour in a database
//! of motion words with the normalized directional motion similarity.
//!
//! - [`word`]: motion words and their per-word normalization;
//! - [`similarity`]: NDMS of two words;
//! - [`index`]: exact nearest-neighbour search (blocked brute force or kd-tree over PCA);
//! - this module: the configuration, the database and the scoring of sets of forecasts.
pub mod index;
pub mod similarity;
pub mod word;

use motion_core::skeleton::{H36M_LEFT_HIP, H36M_NDMS_JOINTS, H36M_RIGHT_HIP};
use motion_core::Skeleton;

/// H3.6M left shoulder joint (LeftArm), for [`WordFrame::Body`].
const H36M_LEFT_SHOULDER: usize = 17;
/// H3.6M right shoulder joint (RightArm), for [`WordFrame::Body`].
const H36M_RIGHT_SHOULDER: usize = 25;

/// The frame each motion word is expressed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WordFrame {
    /// `metrics.md`'s recipe for gravity-aligned positions: centre = first frame's hip midpoint
    /// with vertical 0, rotation about the vertical only (heading).
    Heading,
    /// A rigid body frame from the first frame: origin at the hip midpoint, x along left→right hip,
    /// vertical along the hip→shoulder midpoint direction (orthogonalized). Invariant to any rigid
    /// transform of the sequence, as needed for FK of integrated root deltas (H3.6M), whose world
    /// frame is the tilted pelvis frame wherever integration started.
    Body {
        /// Left shoulder joint.
        left_shoulder: usize,
        /// Right shoulder joint.
        right_shoulder: usize,
    },
}
use ndarray::{Array3, ArrayView3, Axis};
use rayon::prelude::*;

use crate::error::{check_finite, MetricError};
pub use index::{NearestIndex, Neighbour, NnMethod};

/// What NDMS compares and how: motion-word length, joints, hips and the vertical axis.
#[derive(Debug, Clone, PartialEq)]
pub struct NdmsConfig {
    /// Frames per motion word (κ = 8 at 25 Hz in Tanke et al. 2021).
    pub kappa: usize,
    /// Skeleton joints kept in a word, in this order.
    pub joints: Vec<usize>,
    /// Skeleton index of the left hip (normalization).
    pub left_hip: usize,
    /// Skeleton index of the right hip (normalization).
    pub right_hip: usize,
    /// The vertical axis of the input positions (1 = y-up, as H3.6M).
    pub vertical_axis: usize,
    /// Words per reporting bin (10 = 0.4 s at 25 Hz, as Tanke et al. 2021 Tables 2-3).
    pub words_per_bin: usize,
    /// The frame words are expressed in.
    pub frame: WordFrame,
}

impl NdmsConfig {
    /// Tanke et al. 2021's setting on the 32-joint H3.6M skeleton: κ = 8, the 12 joints (wrists, elbows,
    /// shoulders, hips, knees, ankles), hips LeftUpLeg / RightUpLeg, y up, 0.4 s bins, the
    /// heading-only recipe of `metrics.md` (for gravity-aligned positions).
    pub fn h36m() -> Self {
        Self {
            kappa: 8,
            joints: H36M_NDMS_JOINTS.to_vec(),
            left_hip: H36M_LEFT_HIP,
            right_hip: H36M_RIGHT_HIP,
            vertical_axis: 1,
            words_per_bin: 10,
            frame: WordFrame::Heading,
        }
    }

    /// [`NdmsConfig::h36m`] with the rigid [`WordFrame::Body`], for positions from FK of
    /// integrated root deltas.
    pub fn h36m_body_frame() -> Self {
        Self {
            frame: WordFrame::Body {
                left_shoulder: H36M_LEFT_SHOULDER,
                right_shoulder: H36M_RIGHT_SHOULDER,
            },
            ..Self::h36m()
        }
    }

    /// [`NdmsConfig::h36m`] (heading frame, for gravity-aligned positions) on another rig: each
    /// NDMS joint and hip is found in `skeleton` by its H3.6M name (LeftHand, RightHand,
    /// LeftForeArm, ..., LeftUpLeg, RightUpLeg, LeftLeg, RightLeg, LeftFoot, RightFoot).
    /// `Err` holds the first H3.6M joint name `skeleton` lacks.
    pub fn h36m_by_name(skeleton: &Skeleton) -> Result<Self, String> {
        let h36m = Skeleton::h36m();
        let lookup = |j: usize| {
            let name = &h36m.joint(j).name;
            skeleton.joint_index(name).ok_or_else(|| name.clone())
        };
        let config = Self::h36m();
        Ok(Self {
            joints: config
                .joints
                .iter()
                .map(|&j| lookup(j))
                .collect::<Result<_, _>>()?,
            left_hip: lookup(config.left_hip)?,
            right_hip: lookup(config.right_hip)?,
            ..config
        })
    }

    /// Numbers in one flattened word: `κ · joints · 3`.
    pub fn word_len(&self) -> usize {
        self.kappa * self.joints.len() * 3
    }

    /// The input axes in normalized order: the two horizontal axes (ascending), then the vertical.
    pub(crate) fn axis_order(&self) -> [usize; 3] {
        match self.vertical_axis {
            0 => [1, 2, 0],
            1 => [0, 2, 1],
            _ => [0, 1, 2],
        }
    }

    /// Checks the configuration against a skeleton of `joint_count` joints.
    pub fn validate(&self, joint_count: usize) -> Result<(), MetricError> {
        let bad = |m: String| Err(MetricError::InvalidConfig(m));
        if self.kappa < 2 {
            return bad(format!(
                "κ = {} but a motion word needs at least 2 frames",
                self.kappa
            ));
        }
        if self.joints.is_empty() {
            return bad("no joints selected".into());
        }
        if self.vertical_axis > 2 {
            return bad(format!(
                "vertical axis {} is not 0, 1 or 2",
                self.vertical_axis
            ));
        }
        if self.words_per_bin == 0 {
            return bad("words_per_bin is 0".into());
        }
        let largest = self
            .joints
            .iter()
            .chain([&self.left_hip, &self.right_hip])
            .max();
        if let Some(&j) = largest.filter(|&&j| j >= joint_count) {
            return bad(format!(
                "joint index {j} but the positions have {joint_count} joints"
            ));
        }
        Ok(())
    }
}

/// The NDMS of a set of forecasts.
#[derive(Debug, Clone, PartialEq)]
pub struct NdmsReport {
    /// Mean over forecasts of each word's score; word `k` ends at forecast frame
    /// `first_word_end + k`.
    pub per_word: Vec<f64>,
    /// The forecast frame (0-based) at which the first word ends: 0 with the seed's last κ-1
    /// frames prepended, κ-1 without.
    pub first_word_end: usize,
    /// f_sim (Tanke et al. 2021 eq. 9): the mean over all words of all forecasts.
    pub mean: f64,
    /// Means over bins of `words_per_bin` forecast frames by word end frame (0.4 s at 25 Hz);
    /// bin `b` holds the words ending at frames `b·words_per_bin ..`. Bins without words are left out.
    pub bins: Vec<f64>,
    /// The nearest neighbours were exact (always true in this crate).
    pub exact: bool,
}

/// A database of normalized motion words with an exact nearest-neighbour index.
#[derive(Debug)]
pub struct NdmsDatabase {
    config: NdmsConfig,
    index: NearestIndex,
}

impl NdmsDatabase {
    /// All motion words (stride 1) of the reference `sequences` (each `T x J x 3` positions).
    /// Sequences shorter than κ add no words; at least one word overall is required.
    pub fn from_sequences(
        config: NdmsConfig,
        sequences: &[ArrayView3<'_, f64>],
        method: NnMethod,
    ) -> Result<Self, MetricError> {
        let mut words = Vec::new();
        for (i, sequence) in sequences.iter().enumerate() {
            check_positions(&format!("reference sequence {i}"), sequence)?;
            config.validate(sequence.dim().1)?;
            word::append_all_words(*sequence, &config, &mut words);
        }
        if words.is_empty() {
            return Err(MetricError::Empty {
                what: format!(
                    "NDMS database: no reference sequence has κ = {} frames",
                    config.kappa
                ),
            });
        }
        let index = NearestIndex::build_frames(method, words, config.word_len(), config.kappa);
        Ok(Self { config, index })
    }

    /// A database of already normalized words (row-major, [`NdmsConfig::word_len`] numbers each,
    /// as [`words`](Self::words) gives them): the index is rebuilt, the words are not
    /// recomputed. For sharing one database between processes.
    pub fn from_words(
        config: NdmsConfig,
        words: Vec<f64>,
        method: NnMethod,
    ) -> Result<Self, MetricError> {
        let len = config.word_len();
        if words.is_empty() || len == 0 || !words.len().is_multiple_of(len) {
            return Err(MetricError::ShapeMismatch {
                what: "NDMS database words".into(),
                found: vec![words.len()],
                expected: vec![len],
            });
        }
        check_finite(
            "NDMS database words",
            &ndarray::ArrayView1::from(&words[..]),
        )?;
        let index = NearestIndex::build_frames(method, words, len, config.kappa);
        Ok(Self { config, index })
    }

    /// Every normalized word, row-major ([`NdmsConfig::word_len`] numbers each).
    pub fn words(&self) -> &[f64] {
        self.index.words()
    }

    /// The configuration.
    pub fn config(&self) -> &NdmsConfig {
        &self.config
    }

    /// Number of words.
    pub fn len(&self) -> usize {
        self.index.words().len() / self.config.word_len()
    }

    /// True when there are no words (never, for a constructed database).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Normalized word `i`.
    pub fn word(&self, i: usize) -> &[f64] {
        let len = self.config.word_len();
        &self.index.words()[i * len..(i + 1) * len]
    }

    /// The NDMS of each normalized query word (row-major) against its exact nearest neighbour.
    pub fn score_words(&self, queries: &[f64]) -> Vec<f64> {
        let neighbours = self.index.nearest_batch(queries);
        queries
            .par_chunks(self.config.word_len())
            .zip(neighbours.par_iter())
            .map(|(q, n)| similarity::ndms(self.word(n.index), q, self.config.kappa))
            .collect()
    }

    /// Scores forecasts (each `F x J x 3`, all with the same `F`). With `seeds` (one per
    /// forecast, each at least κ-1 frames, continuous with its forecast) the last κ-1 seed
    /// frames are prepended so that the first word straddles the seam and a forecast gives `F`
    /// words; without, it gives `F - κ + 1` words.
    pub fn score_forecasts(
        &self,
        forecasts: &[ArrayView3<'_, f64>],
        seeds: Option<&[ArrayView3<'_, f64>]>,
    ) -> Result<NdmsReport, MetricError> {
        let kappa = self.config.kappa;
        let Some(first) = forecasts.first() else {
            return Err(MetricError::Empty {
                what: "NDMS: no forecasts".into(),
            });
        };
        if let Some(seeds) = seeds {
            if seeds.len() != forecasts.len() {
                return Err(MetricError::ShapeMismatch {
                    what: "seeds (count)".into(),
                    found: vec![seeds.len()],
                    expected: vec![forecasts.len()],
                });
            }
        }
        let shape = first.shape().to_vec();
        let prefix = if seeds.is_some() { kappa - 1 } else { 0 };
        let mut sequences = Vec::with_capacity(forecasts.len());
        for (i, forecast) in forecasts.iter().enumerate() {
            let what = format!("forecast {i}");
            check_positions(&what, forecast)?;
            if forecast.shape() != shape.as_slice() {
                return Err(MetricError::ShapeMismatch {
                    what,
                    found: forecast.shape().to_vec(),
                    expected: shape.clone(),
                });
            }
            self.config.validate(forecast.dim().1)?;
            let joined = match seeds {
                Some(seeds) => {
                    let seed = &seeds[i];
                    let what = format!("seed {i}");
                    check_positions(&what, seed)?;
                    if seed.dim().0 < prefix {
                        return Err(MetricError::TooShort {
                            what,
                            frames: seed.dim().0,
                            kappa,
                        });
                    }
                    if seed.dim().1 != forecast.dim().1 {
                        return Err(MetricError::ShapeMismatch {
                            what,
                            found: seed.shape().to_vec(),
                            expected: vec![seed.dim().0, forecast.dim().1, 3],
                        });
                    }
                    let tail = seed.slice(ndarray::s![seed.dim().0 - prefix.., .., ..]);
                    ndarray::concatenate(Axis(0), &[tail, *forecast]).expect("matching shapes")
                }
                None => forecast.to_owned(),
            };
            if joined.dim().0 < kappa {
                return Err(MetricError::TooShort {
                    what: format!("forecast {i}"),
                    frames: joined.dim().0,
                    kappa,
                });
            }
            sequences.push(joined);
        }
        Ok(self.score_joined(&sequences, prefix))
    }

    fn score_joined(&self, sequences: &[Array3<f64>], prefix: usize) -> NdmsReport {
        let kappa = self.config.kappa;
        let words_per_sequence = sequences[0].dim().0 - kappa + 1;
        let len = self.config.word_len();
        let mut queries = vec![0.0; sequences.len() * words_per_sequence * len];
        queries
            .par_chunks_mut(words_per_sequence * len)
            .zip(sequences.par_iter())
            .for_each(|(out, sequence)| {
                for (start, word) in out.chunks_exact_mut(len).enumerate() {
                    word::normalize_word(sequence.view(), start, &self.config, word);
                }
            });
        let scores = self.score_words(&queries);
        let mut per_word = vec![0.0; words_per_sequence];
        for sequence_scores in scores.chunks_exact(words_per_sequence) {
            for (p, s) in per_word.iter_mut().zip(sequence_scores) {
                *p += s;
            }
        }
        for p in &mut per_word {
            *p /= sequences.len() as f64;
        }
        let first_word_end = kappa - 1 - prefix;
        let mean = per_word.iter().sum::<f64>() / per_word.len() as f64;
        let bins = bin_means(&per_word, first_word_end, self.config.words_per_bin);
        NdmsReport {
            per_word,
            first_word_end,
            mean,
            bins,
            exact: true,
        }
    }
}

/// Means of `series` (element k at frame `first + k`) over bins of `width` frames from frame 0.
fn bin_means(series: &[f64], first: usize, width: usize) -> Vec<f64> {
    let last_frame = first + series.len();
    let mut bins = Vec::new();
    let mut bin_start = 0;
    while bin_start < last_frame {
        let from = bin_start.max(first) - first;
        let to = (bin_start + width).min(last_frame) - first;
        if from < to {
            let values = &series[from..to];
            bins.push(values.iter().sum::<f64>() / values.len() as f64);
        }
        bin_start += width;
    }
    bins
}

fn check_positions(what: &str, positions: &ArrayView3<'_, f64>) -> Result<(), MetricError> {
    if positions.dim().2 != 3 {
        return Err(MetricError::ShapeMismatch {
            what: format!("{what} (positions T x J x 3)"),
            found: positions.shape().to_vec(),
            expected: vec![positions.dim().0, positions.dim().1, 3],
        });
    }
    if positions.dim().0 == 0 || positions.dim().1 == 0 {
        return Err(MetricError::Empty {
            what: format!("{what} has shape {:?}", positions.shape()),
        });
    }
    check_finite(what, positions)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn h36m_by_name_finds_the_h36m_joints_and_names_a_missing_one() {
        let h36m = Skeleton::h36m();
        assert_eq!(NdmsConfig::h36m_by_name(&h36m), Ok(NdmsConfig::h36m()));
        let mut joints: Vec<_> = (0..h36m.len()).map(|j| h36m.joint(j).clone()).collect();
        let left_hip = joints[H36M_LEFT_HIP].name.clone();
        joints[H36M_LEFT_HIP].name = "LeftHip".into();
        let renamed = Skeleton::new(joints).unwrap();
        assert_eq!(NdmsConfig::h36m_by_name(&renamed), Err(left_hip));
    }
}
