//! The test-window sampler of the 3-D position protocols (LTD `find_indices_srnn`, HRI and siMLPe
//! `find_indices_256`; `protocols_modern.md` §1.3), reproduced draw for draw.
//!
//! Per action, numpy's legacy `RandomState(1234567890)` is created once and draws
//! `a = randint(16, T1 - 150)`, then `b = randint(16, T2 - 150)`, alternately, `n` times (`T1`,
//! `T2`: the 25 Hz frame counts of `S5/{action}_1` and `_2`). A draw `a` gives a window whose first
//! predicted frame is `a + 50` and whose first observed frame is `a + 50 - input`. With `n = 4`
//! these are the 8 windows of [`super::TEST_WINDOWS`] (the Martinez set); with `n = 128` the 256
//! windows of HRI and siMLPe, whose first 8 are the Martinez windows. Windows may repeat: they are
//! kept, as the reference keeps them.
//!
//! ```
//! use motion_core::protocol::sampler::{sample_windows, MARTINEZ_DRAWS};
//! // S5 walking: 1,638 and 1,166 frames at 25 Hz give the protocol's 8 walking windows.
//! let windows = sample_windows(1638, 1166, MARTINEZ_DRAWS, 50).unwrap();
//! assert_eq!(windows.len(), 8);
//! assert_eq!((windows[0].subaction, windows[1].subaction), (1, 2));
//! ```
use std::fmt;

/// The sampler's fixed seed.
pub const SAMPLER_SEED: u32 = 1_234_567_890;
/// Draws per take of the Martinez set (8 windows per action).
pub const MARTINEZ_DRAWS: usize = 4;
/// Draws per take of HRI and siMLPe's set (256 windows per action).
pub const HRI_DRAWS: usize = 128;
/// The lowest draw (`randint`'s inclusive lower bound).
pub const LOWEST_DRAW: usize = 16;
/// `randint`'s exclusive upper bound is the take's 25 Hz frame count minus this.
pub const END_MARGIN: usize = 150;
/// A draw `a` predicts from frame `a + PREDICT_OFFSET`.
pub const PREDICT_OFFSET: usize = 50;
/// The input length LTD's loader passes to the sampler whatever its `--input_n` (its quirk: it
/// calls `find_indices_srnn` without `input_n`, so the default 10 is used).
pub const LTD_SAMPLER_INPUT: usize = 10;

/// numpy's legacy `RandomState` for the calls the sampler makes: MT19937 seeded by
/// `init_genrand`, and `randint(low, high)` as numpy computes it for a range below 2³² (the
/// masked rejection on 32-bit outputs).
#[derive(Clone)]
pub struct NumpyRandomState {
    state: [u32; 624],
    index: usize,
}

impl fmt::Debug for NumpyRandomState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("NumpyRandomState")
            .field("index", &self.index)
            .finish_non_exhaustive()
    }
}

impl NumpyRandomState {
    /// `numpy.random.RandomState(seed)` for an integer seed.
    pub fn new(seed: u32) -> NumpyRandomState {
        let mut state = [0u32; 624];
        state[0] = seed;
        for i in 1..624 {
            let prev = state[i - 1];
            state[i] = 1_812_433_253u32
                .wrapping_mul(prev ^ (prev >> 30))
                .wrapping_add(i as u32);
        }
        NumpyRandomState { state, index: 624 }
    }

    /// The next 32-bit output of MT19937 (`genrand_int32`).
    pub fn next_u32(&mut self) -> u32 {
        if self.index >= 624 {
            self.twist();
        }
        let mut y = self.state[self.index];
        self.index += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^ (y >> 18)
    }

    fn twist(&mut self) {
        const UPPER: u32 = 0x8000_0000;
        const LOWER: u32 = 0x7fff_ffff;
        for i in 0..624 {
            let y = (self.state[i] & UPPER) | (self.state[(i + 1) % 624] & LOWER);
            let mut next = self.state[(i + 397) % 624] ^ (y >> 1);
            if y & 1 == 1 {
                next ^= 0x9908_b0df;
            }
            self.state[i] = next;
        }
        self.index = 0;
    }

    /// `randint(low, high)`: an integer in `[low, high)`, or `None` when `high <= low` (numpy
    /// raises) or the range does not fit 32 bits (not a call the sampler makes).
    pub fn randint(&mut self, low: i64, high: i64) -> Option<i64> {
        if high <= low {
            return None;
        }
        let range = u32::try_from(high - low - 1).ok()?;
        if range == 0 {
            return Some(low);
        }
        // The smallest all-ones mask covering the range; draws above it are rejected.
        let mask = u32::MAX >> range.leading_zeros();
        loop {
            let v = self.next_u32() & mask;
            if v <= range {
                return Some(low + i64::from(v));
            }
        }
    }
}

/// One sampled window, in 25 Hz frames of `S5/{action}_{subaction}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampledWindow {
    /// The take: 1 or 2.
    pub subaction: u8,
    /// The window's draw number within its take (0-based).
    pub draw: usize,
    /// First observed frame: `predict_start - input`.
    pub seed_start: usize,
    /// First predicted frame: the draw plus [`PREDICT_OFFSET`].
    pub predict_start: usize,
}

/// Why windows cannot be sampled from a pair of takes.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SamplerError {
    /// A take is too short for `randint(16, T - 150)`.
    #[error("subaction {subaction} has {frames} frames at 25 Hz; the sampler draws from [16, frames - 150) and needs more than 166")]
    TooShort {
        /// The take.
        subaction: u8,
        /// Its 25 Hz frame count.
        frames: usize,
    },
    /// The observed frames would start before the take.
    #[error("{input} observed frames are more than the sampler's offset of 50 + the lowest draw 16 allow")]
    InputTooLong {
        /// The observed frames asked for.
        input: usize,
    },
}

/// The windows of one action, in the reference's draw order (take 1, take 2, take 1, ...):
/// `draws` per take from takes of `frames_1` and `frames_2` 25 Hz frames, each observing `input`
/// frames before its first predicted frame.
///
/// Errors: a take of 166 frames or fewer, or `input` over 66 (the first observed frame would be
/// negative for the lowest draw).
pub fn sample_windows(
    frames_1: usize,
    frames_2: usize,
    draws: usize,
    input: usize,
) -> Result<Vec<SampledWindow>, SamplerError> {
    if input > LOWEST_DRAW + PREDICT_OFFSET {
        return Err(SamplerError::InputTooLong { input });
    }
    let bound = |subaction: u8, frames: usize| {
        let high = frames.saturating_sub(END_MARGIN);
        if high <= LOWEST_DRAW {
            Err(SamplerError::TooShort { subaction, frames })
        } else {
            Ok(high as i64)
        }
    };
    let highs = [bound(1, frames_1)?, bound(2, frames_2)?];
    let mut rng = NumpyRandomState::new(SAMPLER_SEED);
    let mut out = Vec::with_capacity(2 * draws);
    for draw in 0..draws {
        for (k, &high) in highs.iter().enumerate() {
            let a = rng
                .randint(LOWEST_DRAW as i64, high)
                .expect("16 < high < 2^32") as usize;
            let predict_start = a + PREDICT_OFFSET;
            out.push(SampledWindow {
                subaction: k as u8 + 1,
                draw,
                seed_start: predict_start - input,
                predict_start,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{actions_with_windows, test_windows};

    #[test]
    fn mt19937_gives_the_reference_outputs() {
        // The reference implementation's check values (mt19937ar.c, init_genrand(5489)): the first
        // output and the 10,000th.
        let mut rng = NumpyRandomState::new(5489);
        assert_eq!(rng.next_u32(), 3_499_211_612);
        for _ in 1..9_999 {
            rng.next_u32();
        }
        assert_eq!(rng.next_u32(), 4_123_659_995);
    }

    #[test]
    fn four_draws_per_take_are_the_protocols_test_windows() {
        let mut checked = 0;
        for action in actions_with_windows() {
            let table: Vec<_> = test_windows(action).collect();
            let frames = |sub: u8| {
                table
                    .iter()
                    .find(|w| w.subaction == sub)
                    .expect("both takes have windows")
                    .even_frames_in_file
            };
            let sampled = sample_windows(frames(1), frames(2), MARTINEZ_DRAWS, 50).unwrap();
            assert_eq!(sampled.len(), table.len(), "{action}");
            for (s, t) in sampled.iter().zip(&table) {
                assert_eq!(
                    (s.subaction, s.seed_start, s.predict_start),
                    (t.subaction, t.seed_start, t.predict_start),
                    "{action} window {}",
                    t.sample
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 88);
    }

    #[test]
    fn the_256_set_starts_with_the_martinez_windows() {
        let small = sample_windows(1638, 1166, MARTINEZ_DRAWS, 50).unwrap();
        let large = sample_windows(1638, 1166, HRI_DRAWS, 50).unwrap();
        assert_eq!(large.len(), 256);
        assert_eq!(&large[..8], &small[..]);
        for w in &large {
            let frames = if w.subaction == 1 { 1638 } else { 1166 };
            assert!(w.predict_start >= 66 && w.predict_start < frames - 100);
        }
    }

    #[test]
    fn randint_stays_in_range_and_refuses_empty_ranges() {
        let mut rng = NumpyRandomState::new(7);
        for high in [17, 18, 33, 1000, 65_537] {
            for _ in 0..200 {
                let v = rng.randint(16, high).unwrap();
                assert!((16..high).contains(&v));
            }
        }
        assert_eq!(rng.randint(5, 5), None);
        assert_eq!(rng.randint(0, 1 << 40), None);
    }

    #[test]
    fn short_takes_and_long_inputs_are_refused() {
        assert_eq!(
            sample_windows(166, 1000, 4, 50),
            Err(SamplerError::TooShort {
                subaction: 1,
                frames: 166
            })
        );
        assert_eq!(
            sample_windows(1000, 1000, 4, 67),
            Err(SamplerError::InputTooLong { input: 67 })
        );
        assert!(sample_windows(167, 167, 4, 66).is_ok());
    }
}
