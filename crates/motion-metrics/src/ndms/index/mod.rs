//! Exact nearest-neighbour search over normalized motion words (flattened, `κ·joints·3` numbers,
//! 288 for H3.6M). A kd-tree over 288 raw dimensions degenerates into brute force, so three exact
//! strategies are offered:
//! - [`PoseBoundIndex`] (the default): lower bounds from the words' mean poses (a word is `κ`
//!   frames, and its mean pose carries most of its distance to another word), scanned for all
//!   words in `f32`, then in `f64` for the few that pass, then exact distances for a handful;
//! - [`BruteForceIndex`]: blocked brute force, the squared distances of a block of queries to a
//!   block of words as one matrix product (`‖q‖² - 2 q·d + ‖d‖²`), with every candidate that the
//!   product's rounding error cannot exclude re-checked exactly in `f64`;
//! - [`PcaKdIndex`]: a kiddo kd-tree over the same low-dimensional bound as the pose-bound scan,
//!   radius queries for the best exact distance, exact re-ranking.
//!
//! All return exactly what [`nearest_naive`] returns: the smallest [`squared_distance`], ties to
//! the lowest word index.
mod brute_force;
mod pca;
mod pca_kd;
mod pose_bound;

pub use brute_force::BruteForceIndex;
pub use pca_kd::PcaKdIndex;
pub use pose_bound::{PoseBoundIndex, COARSE_DIMS, PCA_DIMS};

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
/// The default is the pose-bound scan. On the H3.6M evaluation's words (13 actions' S5
/// databases, 1,027-3,894 words each, 800 S1 query words each; `motion-cli bench --ndms`, one
/// thread, on a busy 2-core machine) its search of all 10,400 queries took 40-130 ms, against
/// 200-310 ms for the kd-tree over the same coarse bound, whose radius queries visit many nodes:
/// on these words the nearest neighbour is about as far as the data's spread along its first
/// principal axes. Brute force computes all `words x queries` distances (288 numbers each).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NnMethod {
    /// Blocked brute force as matrix products with exact re-checks.
    BruteForce,
    /// kiddo kd-tree over the coarse mean-pose bound, with exact re-ranking.
    PcaKdTree,
    /// Scan of mean-pose lower bounds with exact re-ranking.
    #[default]
    PoseBound,
}

/// An exact nearest-neighbour index built with one of the [`NnMethod`]s.
#[derive(Debug)]
pub enum NearestIndex {
    /// See [`BruteForceIndex`].
    BruteForce(BruteForceIndex),
    /// See [`PcaKdIndex`].
    PcaKdTree(PcaKdIndex),
    /// See [`PoseBoundIndex`].
    PoseBound(PoseBoundIndex),
}

impl NearestIndex {
    /// Builds the index over `words` (row-major, `dim` numbers per word; at least one word).
    pub fn build(method: NnMethod, words: Vec<f64>, dim: usize) -> Self {
        Self::build_frames(method, words, dim, 1)
    }

    /// Builds the index over words of `frames` equal frames each (motion words: `κ`, which
    /// must divide `dim`); the pose-bound scan and the kd-tree bound distances by the words'
    /// mean poses (with 1 frame, by the words themselves).
    pub fn build_frames(method: NnMethod, words: Vec<f64>, dim: usize, frames: usize) -> Self {
        match method {
            NnMethod::BruteForce => NearestIndex::BruteForce(BruteForceIndex::new(words, dim)),
            NnMethod::PcaKdTree => {
                NearestIndex::PcaKdTree(PcaKdIndex::with_frames(words, dim, frames))
            }
            NnMethod::PoseBound => NearestIndex::PoseBound(PoseBoundIndex::new(words, dim, frames)),
        }
    }

    /// The indexed words, row-major.
    pub fn words(&self) -> &[f64] {
        match self {
            NearestIndex::BruteForce(i) => i.words(),
            NearestIndex::PcaKdTree(i) => i.words(),
            NearestIndex::PoseBound(i) => i.words(),
        }
    }

    /// The exact nearest word of every query (`queries` row-major, `dim` numbers per query).
    pub fn nearest_batch(&self, queries: &[f64]) -> Vec<Neighbour> {
        match self {
            NearestIndex::BruteForce(i) => i.nearest_batch(queries),
            NearestIndex::PcaKdTree(i) => i.nearest_batch(queries),
            NearestIndex::PoseBound(i) => i.nearest_batch(queries),
        }
    }
}
