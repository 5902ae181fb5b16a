//! Exact nearest neighbour with a kiddo kd-tree over the coarse points of [`super::pose_bound`]
//! (PCA coordinates of the words' mean poses, the residual `σ` and the motion norm `ρ`), the
//! pose bound and exact re-ranking.
//!
//! A query: a first guess (the neighbour of the previous query and its successor, else the
//! nearest few in the tree), measured exactly; then a radius query in the tree for the best exact
//! distance `b` (widened by a rounding margin); each word found is kept only if its pose bound is
//! within `b` too, and then measured frame by frame, abandoned once the partial sum exceeds `b²`.
//! On H3.6M words the tree's radius queries cost more than [`super::PoseBoundIndex`]'s scan.
use std::num::NonZeroUsize;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::pose_bound::{distance_within, pose_summaries, summarize, Summary, COARSE_DIMS};
use super::{squared_distance, Neighbour};

/// Tree dimensions: the coarse points.
const TREE_DIMS: usize = COARSE_DIMS;
/// Tree neighbours re-ranked exactly when there is no previous query to start from.
const FIRST_CANDIDATES: usize = 4;
/// Queries answered in sequence by one task (each starts from its predecessor's neighbour).
const QUERY_CHUNK: usize = 50;

/// Exact nearest neighbour: kd-tree over the PCA of mean poses, pose bound, exact re-ranking.
pub struct PcaKdIndex {
    words: Vec<f64>,
    dim: usize,
    /// Frames per word (`κ`); a frame has `dim / frames` numbers.
    frames: usize,
    /// Mean pose of every word, `dim / frames` numbers each.
    poses: Vec<f64>,
    /// `ρ`: the norm of every word's motion around its mean pose.
    motion_norms: Vec<f64>,
    /// The mean of the mean poses.
    centre: Vec<f64>,
    /// The principal directions of the mean poses, transposed.
    basis_t: Vec<f64>,
    tree: ImmutableKdTree<f64, TREE_DIMS>,
    /// Largest norm of a word, for the rounding margin.
    max_norm: f64,
}

impl std::fmt::Debug for PcaKdIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PcaKdIndex")
            .field("words", &(self.words.len() / self.dim))
            .field("dim", &self.dim)
            .field("frames", &self.frames)
            .finish()
    }
}

impl PcaKdIndex {
    /// Indexes `words` (row-major, `dim` numbers per word, at least one word), each taken as a
    /// single frame (the pose bound is then the distance itself).
    pub fn new(words: Vec<f64>, dim: usize) -> Self {
        Self::with_frames(words, dim, 1)
    }

    /// Indexes `words` of `frames` equal frames each (motion words: `κ`); `frames` must divide
    /// `dim`.
    pub fn with_frames(words: Vec<f64>, dim: usize, frames: usize) -> Self {
        assert!(
            dim > 0 && words.len().is_multiple_of(dim) && !words.is_empty(),
            "need whole rows of {dim}"
        );
        assert!(
            frames > 0 && dim.is_multiple_of(frames),
            "{frames} frames do not divide {dim}"
        );
        let (poses, motion_norms, centre, basis_t) = pose_summaries(&words, dim, frames);
        let points: Vec<[f64; TREE_DIMS]> = words
            .par_chunks(dim)
            .map(|w| summarize(w, frames, &centre, &basis_t).point)
            .collect();
        let max_norm = words
            .chunks_exact(dim)
            .map(|w| w.iter().map(|x| x * x).sum::<f64>())
            .fold(0.0, f64::max)
            .sqrt();
        let tree =
            ImmutableKdTree::new_from_slice(&points).expect("a non-empty set of finite points");
        Self {
            words,
            dim,
            frames,
            poses,
            motion_norms,
            centre,
            basis_t,
            tree,
            max_norm,
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        &self.words
    }

    /// The exact nearest word of every query (row-major, `dim` numbers per query). Queries are
    /// answered in order within chunks, each starting from its predecessor's neighbour, so
    /// consecutive words of one motion are fastest kept together.
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        let mut out = vec![Neighbour::NONE; queries.len() / self.dim];
        out.par_chunks_mut(QUERY_CHUNK)
            .zip(queries.par_chunks(QUERY_CHUNK * self.dim))
            .for_each(|(best, block)| {
                let mut previous = None;
                for (b, q) in best.iter_mut().zip(block.chunks_exact(self.dim)) {
                    *b = self.nearest_after(q, previous);
                    previous = Some(b.index);
                }
            });
        out
    }

    /// The exact nearest word of one query.
    pub fn nearest(&self, query: &[f64]) -> Neighbour {
        self.nearest_after(query, None)
    }

    /// The exact nearest word of `query`, trying the successor of `previous` (the previous
    /// query's neighbour) first.
    fn nearest_after(&self, query: &[f64], previous: Option<usize>) -> Neighbour {
        let count = self.motion_norms.len();
        let summary = summarize(query, self.frames, &self.centre, &self.basis_t);
        let mut best = Neighbour::NONE;
        match previous {
            Some(p) => {
                for i in [p, p + 1] {
                    if i < count {
                        best.offer(i, squared_distance(query, self.word(i)));
                    }
                }
            }
            None => {
                let first = NonZeroUsize::new(FIRST_CANDIDATES.min(count)).expect("non-empty");
                for hit in self
                    .tree
                    .query(&summary.point)
                    .nearest_n::<SquaredEuclidean<f64>>(first)
                    .execute()
                {
                    let i = hit.item as usize;
                    best.offer(i, squared_distance(query, self.word(i)));
                }
            }
        }
        // Every bound and distance here rounds: widen the radius by far more than their error
        // (relative 1e-12, absolute 1e-9 of the data's extent), which costs nothing in pruning.
        let norm = query.iter().map(|x| x * x).sum::<f64>().sqrt();
        let slack = 1e-9 * (norm + self.max_norm);
        let radius_sq = |best: &Neighbour| {
            let r = best.distance_sq.sqrt() * (1.0 + 1e-12) + slack;
            r * r
        };
        let hits = self
            .tree
            .query(&summary.point)
            .within::<SquaredEuclidean<f64>>(radius_sq(&best))
            .unsorted()
            .execute();
        for hit in hits {
            let i = hit.item as usize;
            let limit = radius_sq(&best);
            if hit.distance > limit || self.pose_bound(&summary, i) > limit {
                continue;
            }
            if let Some(d) = distance_within(query, self.word(i), self.dim / self.frames, best) {
                best.offer(i, d);
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
        let poses: f64 = query
            .pose
            .iter()
            .zip(pose)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        let motion = query.motion_norm - self.motion_norms[i];
        self.frames as f64 * poses + motion * motion
    }
}
