//! Blocked brute force: squared distances of a block of queries to a block of words from one
//! matrix product, `‖q‖² - 2 q·d + ‖d‖²`. That expansion loses precision (cancellation), so it is
//! only used to *exclude* words: a word is re-checked with the exact [`squared_distance`] unless
//! its expanded distance minus a rigorous rounding-error bound already exceeds the best exact
//! distance found so far.
use rayon::prelude::*;

use super::{squared_distance, Neighbour};

/// Queries per block (rows of the product).
const QUERY_BLOCK: usize = 32;
/// Words per block (columns of the product).
const WORD_BLOCK: usize = 1024;

/// Exact nearest neighbour by blocked brute force.
#[derive(Debug)]
pub struct BruteForceIndex {
    words: Vec<f64>,
    dim: usize,
    norms: Vec<f64>,
    norms_sq: Vec<f64>,
    /// Relative rounding-error factor γ of a length-`dim` dot product, with a safety factor.
    gamma: f64,
}

impl BruteForceIndex {
    /// Indexes `words` (row-major, `dim` numbers per word).
    pub fn new(words: Vec<f64>, dim: usize) -> Self {
        assert!(
            dim > 0 && words.len().is_multiple_of(dim),
            "words must hold whole rows of {dim}"
        );
        let norms_sq: Vec<f64> = words
            .chunks_exact(dim)
            .map(|w| w.iter().map(|x| x * x).sum())
            .collect();
        let norms = norms_sq.iter().map(|n| n.sqrt()).collect();
        // |fl(q·d) - q·d| <= γ_n Σ|q_i d_i| <= γ_n ‖q‖‖d‖ with γ_n ≈ n u for any summation order
        // (FMA only helps); the same bound covers ‖q‖², ‖d‖² and the exact re-check itself.
        // Factor 4 for the terms combined, and again 4 for safety: still negligible for pruning.
        let gamma = 16.0 * (dim as f64 + 4.0) * f64::EPSILON;
        Self {
            words,
            dim,
            norms,
            norms_sq,
            gamma,
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        &self.words
    }

    /// The exact nearest word of every query (row-major, `dim` numbers per query).
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        let dim = self.dim;
        let mut out = vec![Neighbour::NONE; queries.len() / dim];
        out.par_chunks_mut(QUERY_BLOCK)
            .zip(queries.par_chunks(QUERY_BLOCK * dim))
            .for_each_init(
                || vec![0.0; QUERY_BLOCK * WORD_BLOCK],
                |products, (best, block)| self.search_block(block, best, products),
            );
        out
    }

    fn search_block(&self, queries: &[f64], best: &mut [Neighbour], products: &mut [f64]) {
        let dim = self.dim;
        let rows = best.len();
        let query_norms_sq: Vec<f64> = queries
            .chunks_exact(dim)
            .map(|q| q.iter().map(|x| x * x).sum())
            .collect();
        let word_count = self.norms.len();
        for first in (0..word_count).step_by(WORD_BLOCK) {
            let cols = WORD_BLOCK.min(word_count - first);
            let block = &self.words[first * dim..(first + cols) * dim];
            // products (rows x cols) = queries (rows x dim) · blockᵀ (dim x cols)
            // SAFETY: the pointers and strides describe the slices' row-major extents exactly.
            unsafe {
                matrixmultiply::dgemm(
                    rows,
                    dim,
                    cols,
                    1.0,
                    queries.as_ptr(),
                    dim as isize,
                    1,
                    block.as_ptr(),
                    1,
                    dim as isize,
                    0.0,
                    products.as_mut_ptr(),
                    cols as isize,
                    1,
                );
            }
            for (r, best) in best.iter_mut().enumerate() {
                let query = &queries[r * dim..(r + 1) * dim];
                let query_norm = query_norms_sq[r].sqrt();
                for c in 0..cols {
                    let w = first + c;
                    let expanded =
                        query_norms_sq[r] - 2.0 * products[r * cols + c] + self.norms_sq[w];
                    let reach = query_norm + self.norms[w];
                    if expanded - self.gamma * reach * reach <= best.distance_sq {
                        best.offer(
                            w,
                            squared_distance(query, &self.words[w * dim..(w + 1) * dim]),
                        );
                    }
                }
            }
        }
    }
}
