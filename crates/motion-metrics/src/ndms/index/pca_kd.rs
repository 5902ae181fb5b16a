//! Exact nearest neighbour with a kiddo kd-tree over a PCA projection.
//!
//! Each word `x` is embedded as `e(x) = (P(x - μ), ‖r(x)‖)`: its coordinates in a few orthonormal
//! PCA directions `P` and the length of its residual `r(x) = (x - μ) - Pᵀ P (x - μ)` outside them.
//! Pythagoras and the reverse triangle inequality in the residual space give
//! `‖e(q) - e(d)‖² = ‖P(q - d)‖² + (‖r(q)‖ - ‖r(d)‖)² <= ‖q - d‖²`: a lower bound. So: take the few
//! nearest words in the embedding, re-rank them exactly, giving a best exact distance `b`; every
//! word that could be nearer lies within `b` in the embedding, so a radius query for `b` (widened
//! by a rounding margin) yields all remaining candidates, which are re-ranked exactly too.
use std::num::NonZeroUsize;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::{pca::principal_basis, squared_distance, Neighbour};

/// PCA directions of the embedding (kd-trees work best below about ten dimensions).
pub const PCA_DIMS: usize = 11;
/// Embedding dimensions: the PCA coordinates and the residual length.
const TREE_DIMS: usize = PCA_DIMS + 1;
/// Projected nearest words re-ranked before the radius query.
const FIRST_CANDIDATES: usize = 8;

/// Exact nearest neighbour: kd-tree over a PCA projection plus exact re-ranking.
pub struct PcaKdIndex {
    words: Vec<f64>,
    dim: usize,
    mean: Vec<f64>,
    basis: Vec<f64>,
    tree: ImmutableKdTree<f64, TREE_DIMS>,
    /// Largest distance of a word to the mean, for the rounding margin.
    max_radius: f64,
}

impl std::fmt::Debug for PcaKdIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PcaKdIndex")
            .field("words", &(self.words.len() / self.dim))
            .field("dim", &self.dim)
            .field("projected_dims", &PCA_DIMS)
            .finish()
    }
}

impl PcaKdIndex {
    /// Indexes `words` (row-major, `dim` numbers per word, at least one word).
    pub fn new(words: Vec<f64>, dim: usize) -> Self {
        assert!(
            dim > 0 && words.len().is_multiple_of(dim) && !words.is_empty(),
            "need whole rows of {dim}"
        );
        let (mean, basis) = principal_basis(&words, dim, PCA_DIMS.min(dim));
        let mut basis = basis;
        // Fewer data dims than projected dims: pad with zero directions (still a contraction).
        basis.resize(PCA_DIMS * dim, 0.0);
        let projected: Vec<[f64; TREE_DIMS]> = words
            .par_chunks(dim)
            .map(|w| embed(w, &mean, &basis, dim))
            .collect();
        let max_radius = words
            .chunks_exact(dim)
            .map(|w| squared_distance(w, &mean).sqrt())
            .fold(0.0, f64::max);
        let tree =
            ImmutableKdTree::new_from_slice(&projected).expect("a non-empty set of finite points");
        Self {
            words,
            dim,
            mean,
            basis,
            tree,
            max_radius,
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        &self.words
    }

    /// The exact nearest word of every query (row-major, `dim` numbers per query).
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        queries
            .par_chunks(self.dim)
            .map(|q| self.nearest(q))
            .collect()
    }

    /// The exact nearest word of one query.
    pub fn nearest(&self, query: &[f64]) -> Neighbour {
        let z = embed(query, &self.mean, &self.basis, self.dim);
        let word = |i: usize| &self.words[i * self.dim..(i + 1) * self.dim];
        let mut best = Neighbour::NONE;
        let first = NonZeroUsize::new(FIRST_CANDIDATES).expect("non-zero");
        for hit in self
            .tree
            .query(&z)
            .nearest_n::<SquaredEuclidean<f64>>(first)
            .execute()
        {
            let i = hit.item as usize;
            best.offer(i, squared_distance(query, word(i)));
        }
        // The embedding and kiddo's arithmetic round: widen the radius by far more than their
        // error (relative 1e-12, absolute 1e-9 of the data's extent), which costs nothing in pruning.
        let extent = squared_distance(query, &self.mean).sqrt() + self.max_radius;
        let radius = best.distance_sq.sqrt() * (1.0 + 1e-12) + 1e-9 * extent;
        for hit in self
            .tree
            .query(&z)
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .unsorted()
            .execute()
        {
            let i = hit.item as usize;
            best.offer(i, squared_distance(query, word(i)));
        }
        best
    }
}

/// `(basis · (x - mean), ‖residual‖)`, the residual computed explicitly (no cancellation).
fn embed(x: &[f64], mean: &[f64], basis: &[f64], dim: usize) -> [f64; TREE_DIMS] {
    let mut e = [0.0; TREE_DIMS];
    for (k, out) in e.iter_mut().take(PCA_DIMS).enumerate() {
        let direction = &basis[k * dim..(k + 1) * dim];
        *out = x
            .iter()
            .zip(mean)
            .zip(direction)
            .map(|((x, m), d)| (x - m) * d)
            .sum();
    }
    let mut residual_sq = 0.0;
    for i in 0..dim {
        let mut r = x[i] - mean[i];
        for k in 0..PCA_DIMS {
            r -= e[k] * basis[k * dim + i];
        }
        residual_sq += r * r;
    }
    e[PCA_DIMS] = residual_sq.sqrt();
    e
}
