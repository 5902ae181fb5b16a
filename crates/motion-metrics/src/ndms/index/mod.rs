//! Exact nearest-neighbour search over normalized motion words (flattened, `κ·joints·3` numbers,
//! 288 for H3.6M). A kd-tree over 288 raw dimensions degenerates into brute force, so two exact
//! strategies are offered:
//! - [`BruteForceIndex`]: blocked brute force, the squared distances of a block of queries to a
//!   block of words as one matrix product (`‖q‖² - 2 q·d + ‖d‖²`), with every candidate that the
//!   product's rounding error cannot exclude re-checked exactly in `f64`;
//! - [`PcaKdIndex`]: a kiddo kd-tree over a low-dimensional orthonormal PCA projection; the projected
//!   distance never exceeds the true one, so all words within the best exact distance in the
//!   projection are candidates, and they are re-ranked exactly.
//!
//! Both return exactly what [`nearest_naive`] returns: the smallest [`squared_distance`], ties to
//! the lowest word index.
mod brute_force;
mod pca;
mod pca_kd;

pub use brute_force::BruteForceIndex;
pub use pca_kd::{PcaKdIndex, PCA_DIMS};

/// The nearest word of a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Row of the word in the database.
    pub index: usize,
    /// Its squared Euclidean distance to the query, as [`squared_distance`] computes it.
    pub distance_sq: f64,
}

impl Neighbour {
    /// No neighbour yet: infinitely far.
    pub(crate) const NONE: Neighbour = Neighbour {
        index: usize::MAX,
        distance_sq: f64::INFINITY,
    };

    /// Keeps the better of `self` and the word `index` at `distance_sq` (ties: lower index).
    #[inline]
    pub(crate) fn offer(&mut self, index: usize, distance_sq: f64) {
        if distance_sq < self.distance_sq || (distance_sq == self.distance_sq && index < self.index)
        {
            *self = Neighbour { index, distance_sq };
        }
    }
}

/// The squared Euclidean distance, summed in index order: the reference every index agrees with.
#[inline]
pub fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The reference: scan every word (`words` is row-major, `dim` numbers per word).
pub fn nearest_naive(words: &[f64], dim: usize, query: &[f64]) -> Neighbour {
    let mut best = Neighbour::NONE;
    for (index, word) in words.chunks_exact(dim).enumerate() {
        best.offer(index, squared_distance(query, word));
    }
    best
}

/// Which exact nearest-neighbour strategy to use.
///
/// The default is the kd-tree: on real motion words (H3.6M S5 in the body word frame,
/// `benches/motion/metrics.rs`) it answered 800 queries 3.2x (2,747 words: 20 ms vs 64 ms) to
/// 12x (30,609 words: 52 ms vs 656 ms) faster than brute force, because motion words are nearly
/// low-rank; its build costs more (49 ms and 287 ms vs 1 ms and 73 ms). On high-rank data
/// (independent random signals) the projection prunes little and brute force is faster
/// (20,000 words, 100 queries: 52 ms vs 440 ms).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NnMethod {
    /// Blocked brute force as matrix products with exact re-checks.
    BruteForce,
    /// kiddo kd-tree over a PCA projection, with exact re-ranking.
    #[default]
    PcaKdTree,
}

/// An exact nearest-neighbour index built with one of the [`NnMethod`]s.
#[derive(Debug)]
pub enum NearestIndex {
    /// See [`BruteForceIndex`].
    BruteForce(BruteForceIndex),
    /// See [`PcaKdIndex`].
    PcaKdTree(PcaKdIndex),
}

impl NearestIndex {
    /// Builds the index over `words` (row-major, `dim` numbers per word; at least one word).
    pub fn build(method: NnMethod, words: Vec<f64>, dim: usize) -> Self {
        match method {
            NnMethod::BruteForce => NearestIndex::BruteForce(BruteForceIndex::new(words, dim)),
            NnMethod::PcaKdTree => NearestIndex::PcaKdTree(PcaKdIndex::new(words, dim)),
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        match self {
            NearestIndex::BruteForce(i) => i.words(),
            NearestIndex::PcaKdTree(i) => i.words(),
        }
    }

    /// The exact nearest word of every query (`queries` row-major, `dim` numbers per query).
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        match self {
            NearestIndex::BruteForce(i) => i.nearest_batch(queries),
            NearestIndex::PcaKdTree(i) => i.nearest_batch(queries),
        }
    }
}
