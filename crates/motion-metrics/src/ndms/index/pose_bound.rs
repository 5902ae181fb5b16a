//! Exact nearest neighbour by a scan of mean-pose lower bounds: every word is bounded cheaply, few
//! are bounded closely, a handful are measured.
//!
//! A word of `κ` frames (`x_t`, `P` numbers each) splits orthogonally into its mean pose
//! `m = Σ_t x_t / κ` and the motion around it `r_t = x_t - m`:
//! `‖x - y‖² = κ‖m_x - m_y‖² + ‖r_x - r_y‖²`, and `‖r_x - r_y‖ >= |ρ_x - ρ_y|` with `ρ = ‖r‖`.
//! Within `κ` frames (0.32 s at 25 Hz) the pose changes little, so the first term carries most of
//! the distance: the **pose bound** `κ‖m_x - m_y‖² + (ρ_x - ρ_y)²` leaves a handful of candidates
//! per query on H3.6M words (S1 queries against S5 databases: 4-9 of 1,000-3,900).
//!
//! The pose bound itself is bounded by a **coarse bound** in [`COARSE_DIMS`] numbers per word:
//! `√κ` times the mean pose's coordinates in [`PCA_DIMS`] orthonormal principal directions, the
//! length `σ` of its residual outside them (times `√κ`), and `ρ`. Coarse points are stored
//! coordinate-major in `f32`, so one query's coarse bounds to every word are a few vectorized
//! passes (AVX2 when the CPU has it).
//!
//! A query: its coarse bounds to all words; a first guess (the neighbour of the previous query
//! and its successor, as consecutive words of a motion usually share or follow their neighbour;
//! else the word of smallest coarse bound), measured exactly; then every word whose coarse bound,
//! and then pose bound, is within the best exact distance so far (widened by a rounding margin)
//! is measured, frame by frame, abandoned once the partial sum exceeds the best (its terms are
//! non-negative, so partial sums only grow, also in floating point). The result is what
//! [`super::nearest_naive`] returns, ties to the lower index.
use rayon::prelude::*;

use super::{pca::principal_basis, Neighbour};

/// Principal directions of the mean poses in the coarse bound.
pub const PCA_DIMS: usize = 8;
/// Numbers per word in the coarse bound: the PCA coordinates, `σ` and `ρ`.
pub const COARSE_DIMS: usize = PCA_DIMS + 2;
/// Mean poses sampled for the principal directions.
const PCA_SAMPLE_ROWS: usize = 1024;
/// Coarse bounds tested together before looking at any one of them.
const SCAN_BLOCK: usize = 32;
/// Queries answered in sequence by one task (each starts from its predecessor's neighbour).
const QUERY_CHUNK: usize = 32;

/// Exact nearest neighbour by a scan of mean-pose lower bounds (see the module docs).
pub struct PoseBoundIndex {
    words: Vec<f64>,
    dim: usize,
    /// Frames per word (`κ`); a frame has `dim / frames` numbers.
    frames: usize,
    /// Mean pose of every word, `dim / frames` numbers each.
    poses: Vec<f64>,
    /// `ρ` of every word.
    motion_norms: Vec<f64>,
    /// The mean of the mean poses.
    centre: Vec<f64>,
    /// `PCA_DIMS` orthonormal directions in pose space, transposed: `PCA_DIMS` numbers per pose
    /// coordinate (zero directions past the pose size).
    basis_t: Vec<f64>,
    /// Coarse points, coordinate-major: coordinate `c` of word `i` at `c * count + i`.
    coarse: Vec<f32>,
    /// Slack of the `f32` coarse bound: 1e-5 of the largest coarse point norm plus the query's.
    coarse_slack: f64,
    /// Largest norm of a word, for the rounding margins.
    max_norm: f64,
}

impl std::fmt::Debug for PoseBoundIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PoseBoundIndex")
            .field("words", &self.len())
            .field("dim", &self.dim)
            .field("frames", &self.frames)
            .finish()
    }
}

/// A word's mean pose, `ρ` and coarse point.
pub(super) struct Summary {
    pub(super) pose: Vec<f64>,
    pub(super) motion_norm: f64,
    pub(super) point: [f64; COARSE_DIMS],
}

impl PoseBoundIndex {
    /// Indexes `words` (row-major, `dim` numbers per word, at least one word) of `frames` equal
    /// frames each (motion words: `κ`; `frames` must divide `dim`; with 1 the pose bound is the
    /// distance itself).
    pub fn new(words: Vec<f64>, dim: usize, frames: usize) -> Self {
        assert!(
            dim > 0 && words.len().is_multiple_of(dim) && !words.is_empty(),
            "need whole rows of {dim}"
        );
        assert!(
            frames > 0 && dim.is_multiple_of(frames),
            "{frames} frames do not divide {dim}"
        );
        let (poses, motion_norms, centre, basis_t) = pose_summaries(&words, dim, frames);
        let pose_len = dim / frames;
        let count = motion_norms.len();
        let scale = (frames as f64).sqrt();
        let mut coarse = vec![0.0f32; COARSE_DIMS * count];
        let mut largest = 0.0f64;
        for (i, (pose, &norm)) in poses.chunks_exact(pose_len).zip(&motion_norms).enumerate() {
            let point = coarse_point(pose, norm, &centre, &basis_t, scale);
            largest = largest.max(point.iter().map(|x| x * x).sum::<f64>().sqrt());
            for (c, &x) in point.iter().enumerate() {
                coarse[c * count + i] = x as f32;
            }
        }
        let max_norm = poses
            .chunks_exact(pose_len)
            .zip(&motion_norms)
            .map(|(pose, &rho)| word_norm(pose, rho, frames))
            .fold(0.0, f64::max);
        Self {
            words,
            dim,
            frames,
            poses,
            motion_norms,
            centre,
            basis_t,
            coarse,
            coarse_slack: 1e-5 * largest,
            max_norm,
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        &self.words
    }

    fn len(&self) -> usize {
        self.motion_norms.len()
    }

    /// The exact nearest word of every query (row-major, `dim` numbers per query). Queries are
    /// answered in order within chunks, each starting from its predecessor's neighbour, so
    /// consecutive words of one motion are fastest kept together.
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        let mut out = vec![Neighbour::NONE; queries.len() / self.dim];
        out.par_chunks_mut(QUERY_CHUNK)
            .zip(queries.par_chunks(QUERY_CHUNK * self.dim))
            .for_each_init(
                || vec![0.0f32; self.len()],
                |bounds, (best, block)| {
                    let mut previous = None;
                    for (b, q) in best.iter_mut().zip(block.chunks_exact(self.dim)) {
                        *b = self.nearest_after(q, previous, bounds);
                        previous = Some(b.index);
                    }
                },
            );
        out
    }

    /// The exact nearest word of one query.
    pub fn nearest(&self, query: &[f64]) -> Neighbour {
        self.nearest_after(query, None, &mut vec![0.0; self.len()])
    }

    /// The exact nearest word of `query`, trying `previous` (the previous query's neighbour)
    /// and its successor first; `bounds` is scratch for the coarse bounds.
    fn nearest_after(
        &self,
        query: &[f64],
        previous: Option<usize>,
        bounds: &mut [f32],
    ) -> Neighbour {
        let count = self.len();
        let summary = summarize(query, self.frames, &self.centre, &self.basis_t);
        let point = summary.point.map(|x| x as f32);
        coarse_bounds(&self.coarse, count, &point, bounds);
        let mut best = Neighbour::NONE;
        let frame_len = self.dim / self.frames;
        let guesses = match previous {
            Some(p) => [Some(p), Some(p + 1).filter(|&i| i < count)],
            None => {
                let smallest = (0..count)
                    .min_by(|&a, &b| bounds[a].total_cmp(&bounds[b]))
                    .expect("non-empty");
                [Some(smallest), None]
            }
        };
        for i in guesses.into_iter().flatten() {
            if let Some(d) = distance_within(query, self.word(i), frame_len, best) {
                best.offer(i, d);
            }
        }
        // Every bound and distance here rounds: widen the radius by far more than their error
        // (f32 coarse bound: relative 1e-5 and 1e-5 of the coarse points' extent; f64 pose
        // bound: relative 1e-12 and 1e-9 of the words' extent), which costs nothing in pruning.
        let norm = word_norm(&summary.pose, summary.motion_norm, self.frames);
        let query_coarse = summary.point.iter().map(|x| x * x).sum::<f64>().sqrt();
        let coarse_slack = self.coarse_slack + 1e-5 * query_coarse;
        let slack = 1e-9 * (norm + self.max_norm);
        let widen = |best: &Neighbour, relative: f64, slack: f64| {
            let r = best.distance_sq.sqrt() * (1.0 + relative) + slack;
            r * r
        };
        let mut coarse_limit = widen(&best, 1e-5, coarse_slack) as f32;
        for (first, block) in (0..count)
            .step_by(SCAN_BLOCK)
            .zip(bounds.chunks(SCAN_BLOCK))
        {
            // Most blocks hold no candidate: count them without branches (vectorized) first.
            let hits = block
                .iter()
                .fold(0u32, |n, &b| n + u32::from(b <= coarse_limit));
            if hits == 0 {
                continue;
            }
            for (i, &bound) in (first..).zip(block) {
                if bound > coarse_limit {
                    continue;
                }
                let limit = widen(&best, 1e-12, slack);
                if self.pose_bound(&summary, i) > limit || sum_sq_diff(query, self.word(i)) > limit
                {
                    continue;
                }
                if let Some(d) = distance_within(query, self.word(i), frame_len, best) {
                    best.offer(i, d);
                    coarse_limit = widen(&best, 1e-5, coarse_slack) as f32;
                }
            }
        }
        best
    }

    fn word(&self, i: usize) -> &[f64] {
        &self.words[i * self.dim..(i + 1) * self.dim]
    }

    /// `κ‖m_q - m_i‖² + (ρ_q - ρ_i)²`, a lower bound of the squared distance to word `i`.
    fn pose_bound(&self, query: &Summary, i: usize) -> f64 {
        let len = query.pose.len();
        let pose = &self.poses[i * len..(i + 1) * len];
        let motion = query.motion_norm - self.motion_norms[i];
        self.frames as f64 * sum_sq_diff(&query.pose, pose) + motion * motion
    }
}

/// `‖x‖ = √(κ‖m‖² + ρ²)` of a word from its mean pose `m` and motion norm `ρ` (only used for
/// rounding margins, which are far wider than this identity's rounding).
pub(super) fn word_norm(pose: &[f64], motion_norm: f64, frames: usize) -> f64 {
    (frames as f64 * pose.iter().map(|p| p * p).sum::<f64>() + motion_norm * motion_norm).sqrt()
}

/// `Σ (a_i - b_i)²` with four running sums (no serial dependency; rounds differently from
/// [`super::squared_distance`], so only used for bounds with a margin).
#[inline]
pub(super) fn sum_sq_diff(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0; 4];
    let (mut ca, mut cb) = (a.chunks_exact(4), b.chunks_exact(4));
    for (x, y) in (&mut ca).zip(&mut cb) {
        for k in 0..4 {
            sums[k] += (x[k] - y[k]) * (x[k] - y[k]);
        }
    }
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        sums[0] += (x - y) * (x - y);
    }
    (sums[0] + sums[1]) + (sums[2] + sums[3])
}

/// Mean poses and `ρ` of all `words`, the centre of the poses and `PCA_DIMS` principal
/// directions, transposed (`PCA_DIMS` numbers per pose coordinate; zero directions are added
/// when a pose has fewer numbers).
pub(super) fn pose_summaries(
    words: &[f64],
    dim: usize,
    frames: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let pose_len = dim / frames;
    let count = words.len() / dim;
    let mut poses = vec![0.0; count * pose_len];
    let mut motion_norms = vec![0.0; count];
    poses
        .par_chunks_mut(pose_len)
        .zip(motion_norms.par_iter_mut())
        .zip(words.par_chunks(dim))
        .for_each(|((pose, norm), word)| *norm = mean_pose(word, frames, pose));
    let k = PCA_DIMS.min(pose_len);
    let (centre, mut basis) = principal_basis(&poses, pose_len, k, PCA_SAMPLE_ROWS);
    basis.resize(PCA_DIMS * pose_len, 0.0);
    let mut basis_t = vec![0.0; PCA_DIMS * pose_len];
    for (k, direction) in basis.chunks_exact(pose_len).enumerate() {
        for (i, &v) in direction.iter().enumerate() {
            basis_t[i * PCA_DIMS + k] = v;
        }
    }
    (poses, motion_norms, centre, basis_t)
}

/// The mean pose, `ρ` and coarse point of one word (`basis_t` as [`pose_summaries`] gives it).
pub(super) fn summarize(word: &[f64], frames: usize, centre: &[f64], basis_t: &[f64]) -> Summary {
    let mut pose = vec![0.0; centre.len()];
    let motion_norm = mean_pose(word, frames, &mut pose);
    let scale = (frames as f64).sqrt();
    let point = coarse_point(&pose, motion_norm, centre, basis_t, scale);
    Summary {
        pose,
        motion_norm,
        point,
    }
}

/// Writes the mean over `frames` frames of `word` into `pose`; returns `ρ`, the norm of the
/// word minus its mean pose in every frame (computed explicitly: no cancellation).
fn mean_pose(word: &[f64], frames: usize, pose: &mut [f64]) -> f64 {
    pose.fill(0.0);
    for frame in word.chunks_exact(pose.len()) {
        for (p, x) in pose.iter_mut().zip(frame) {
            *p += x;
        }
    }
    let inverse = 1.0 / frames as f64;
    for p in pose.iter_mut() {
        *p *= inverse;
    }
    let mut motion = 0.0;
    for frame in word.chunks_exact(pose.len()) {
        motion += sum_sq_diff(frame, pose);
    }
    motion.sqrt()
}

/// `(√κ V(m - c), √κ‖residual of m - c outside V‖, ρ)`, the residual computed explicitly;
/// `basis_t` is `Vᵀ` (`PCA_DIMS` numbers per pose coordinate).
fn coarse_point(
    pose: &[f64],
    motion_norm: f64,
    centre: &[f64],
    basis_t: &[f64],
    scale: f64,
) -> [f64; COARSE_DIMS] {
    let mut coords = [0.0; PCA_DIMS];
    for ((p, m), directions) in pose.iter().zip(centre).zip(basis_t.chunks_exact(PCA_DIMS)) {
        let d = p - m;
        for (c, v) in coords.iter_mut().zip(directions) {
            *c += d * v;
        }
    }
    let mut residual_sq = [0.0; 4];
    for (i, ((p, m), directions)) in pose
        .iter()
        .zip(centre)
        .zip(basis_t.chunks_exact(PCA_DIMS))
        .enumerate()
    {
        let mut r = p - m;
        for (c, v) in coords.iter().zip(directions) {
            r -= c * v;
        }
        residual_sq[i % 4] += r * r;
    }
    let residual_sq = (residual_sq[0] + residual_sq[1]) + (residual_sq[2] + residual_sq[3]);
    let mut point = [0.0; COARSE_DIMS];
    for (p, c) in point.iter_mut().zip(coords) {
        *p = scale * c;
    }
    point[PCA_DIMS] = scale * residual_sq.sqrt();
    point[PCA_DIMS + 1] = motion_norm;
    point
}

/// [`super::squared_distance`] of `a` and `b` (same value: same order of summation), or `None`
/// once a partial sum over whole frames exceeds the best distance so far (the word cannot win,
/// not even a tie).
pub(super) fn distance_within(
    a: &[f64],
    b: &[f64],
    frame_len: usize,
    best: Neighbour,
) -> Option<f64> {
    let mut sum = 0.0;
    for (fa, fb) in a.chunks(frame_len).zip(b.chunks(frame_len)) {
        for (x, y) in fa.iter().zip(fb) {
            sum += (x - y) * (x - y);
        }
        if sum > best.distance_sq {
            return None;
        }
    }
    Some(sum)
}

/// The squared distances of `point` to every coarse point (`coarse` coordinate-major, `count`
/// words) into `out`, in `f32`.
fn coarse_bounds(coarse: &[f32], count: usize, point: &[f32; COARSE_DIMS], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        unsafe { coarse_bounds_avx2(coarse, count, point, out) };
        return;
    }
    coarse_bounds_portable(coarse, count, point, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn coarse_bounds_avx2(coarse: &[f32], count: usize, point: &[f32; COARSE_DIMS], out: &mut [f32]) {
    coarse_bounds_portable(coarse, count, point, out);
}

/// One pass per coordinate over all words: contiguous, vectorizable.
#[inline(always)]
fn coarse_bounds_portable(
    coarse: &[f32],
    count: usize,
    point: &[f32; COARSE_DIMS],
    out: &mut [f32],
) {
    let out = &mut out[..count];
    let mut columns = coarse.chunks_exact(count).zip(point);
    if let Some((column, &q)) = columns.next() {
        for (o, &x) in out.iter_mut().zip(column) {
            *o = (q - x) * (q - x);
        }
    }
    for (column, &q) in columns {
        for (o, &x) in out.iter_mut().zip(column) {
            *o += (q - x) * (q - x);
        }
    }
}
