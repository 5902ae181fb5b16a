//! Validation windows: fixed S5 windows that avoid every test window, for choosing checkpoints
//! and settings without touching the test windows. The same rule as `training/data.py`
//! (`validation_windows(per_action=8, stride=50)`, the windows of
//! `python -m training.evaluate --val-per-action 8 --val-stride 50`), so a checkpoint chosen in
//! training and one chosen with `motion-cli eval --windows validation` can be judged on the same
//! frames:
//!
//! - per take of the action (subactions 1 and 2, those present), candidate starts tiled left to
//!   right from frame [`MIN_WINDOW_START`] every [`VALIDATION_STRIDE`] frames (windows of
//!   [`VALIDATION_WINDOW_FRAMES`] may overlap each other); a candidate that overlaps a test
//!   window's `[seed_start, predict_start + 100)` moves to the end of the latest such interval;
//! - the chosen windows alternate between the takes (1, 2, 1, ...), each take's candidates taken
//!   in a spreading order (the middle one, then the quarters, the eighths, ...).
use super::{test_windows, TestWindow, LONG_TERM_HORIZON, SEED_FRAMES};

/// Frames of a validation window: the seed and the long-term horizon (150 at 25 Hz).
pub const VALIDATION_WINDOW_FRAMES: usize = SEED_FRAMES + LONG_TERM_HORIZON;
/// The smallest start frame of a window (25 Hz), as in the protocol's sampler.
pub const MIN_WINDOW_START: usize = 16;
/// Frames between candidate starts: with 150-frame windows, 8 per action fit every action
/// with test windows (greeting and posing hold only 6 and 4 windows that do not overlap).
pub const VALIDATION_STRIDE: usize = 50;

/// Which S5 windows an evaluation runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WindowSet {
    /// The protocol's fixed test windows (8 per action): report numbers on these.
    #[default]
    Test,
    /// Windows disjoint from every test window ([`validation_windows`]): choose on these.
    Validation,
}

impl WindowSet {
    /// `test` or `validation`.
    pub fn name(self) -> &'static str {
        match self {
            WindowSet::Test => "test",
            WindowSet::Validation => "validation",
        }
    }

    /// The set named `test` or `validation` (what [`WindowSet::name`] gives); `None` for any
    /// other name.
    pub fn from_name(name: &str) -> Option<WindowSet> {
        [WindowSet::Test, WindowSet::Validation]
            .into_iter()
            .find(|set| set.name() == name)
    }
}

/// Window starts (25 Hz) of `length` frames in a take of `frames` frames, tiled from
/// [`MIN_WINDOW_START`] every `stride` frames (at least 1), skipping past each blocked half-open
/// interval they would overlap.
pub fn free_window_starts(
    frames: usize,
    blocked: &[(usize, usize)],
    length: usize,
    stride: usize,
) -> Vec<usize> {
    let stride = stride.max(1);
    let mut starts = Vec::new();
    let mut t = MIN_WINDOW_START;
    while t + length <= frames {
        let clash = blocked
            .iter()
            .filter(|&&(a, b)| t < b && a < t + length)
            .map(|&(_, b)| b)
            .max();
        match clash {
            Some(end) => t = end,
            None => {
                starts.push(t);
                t += stride;
            }
        }
    }
    starts
}

/// Indices `0 .. n` in an order that spreads early picks over the range: the middle, then the
/// quarters, the eighths, ..., then whatever is left in order.
pub fn spread_order(n: usize) -> Vec<usize> {
    if n == 0 {
        return Vec::new();
    }
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut fractions = vec![0.5f64];
    while order.len() < n {
        for &f in &fractions {
            let i = ((f * n as f64) as usize).min(n - 1);
            if !seen[i] {
                seen[i] = true;
                order.push(i);
            }
        }
        let step = 1.0 / (2.0 * fractions.len() as f64 * 2.0);
        fractions = fractions
            .iter()
            .flat_map(|&f| [f - step, f + step])
            .collect();
        if step < 1.0 / (4.0 * n as f64) {
            break;
        }
    }
    order.extend((0..n).filter(|&i| !seen[i]));
    order
}

/// Up to `per_action` validation windows of `action`, given the frame count at 25 Hz of each S5
/// take present (`takes`: (subaction, frames)), in the order they are picked (module docs).
/// `even_frames_in_file` of each is its take's frame count; `sample` counts from 0.
pub fn validation_windows(
    action: &'static str,
    takes: &[(u8, usize)],
    per_action: usize,
) -> Vec<TestWindow> {
    let mut candidates: Vec<(u8, usize, Vec<usize>)> = takes
        .iter()
        .map(|&(sub, frames)| {
            let blocked: Vec<(usize, usize)> = test_windows(action)
                .filter(|w| w.subaction == sub)
                .map(|w| (w.seed_start, w.predict_start + LONG_TERM_HORIZON))
                .collect();
            let starts = free_window_starts(
                frames,
                &blocked,
                VALIDATION_WINDOW_FRAMES,
                VALIDATION_STRIDE,
            );
            let order = spread_order(starts.len())
                .into_iter()
                .map(|i| starts[i])
                .collect();
            (sub, frames, order)
        })
        .collect();
    candidates.sort_by_key(|c| c.0);
    let mut out = Vec::new();
    let mut next = vec![0usize; candidates.len()];
    while out.len() < per_action && next.iter().zip(&candidates).any(|(&k, c)| k < c.2.len()) {
        for (k, (sub, frames, order)) in next.iter_mut().zip(&candidates) {
            if *k < order.len() && out.len() < per_action {
                let start = order[*k];
                *k += 1;
                out.push(TestWindow {
                    action,
                    sample: out.len(),
                    subaction: *sub,
                    seed_start: start,
                    predict_start: start + SEED_FRAMES,
                    even_frames_in_file: *frames,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiling_skips_blocked_intervals() {
        // 16..66 free, 70..220 blocked: the next start is 220.
        assert_eq!(
            free_window_starts(400, &[(70, 220)], 50, 50),
            vec![16, 220, 270, 320]
        );
        assert_eq!(free_window_starts(60, &[], 50, 50), Vec::<usize>::new());
        assert_eq!(free_window_starts(66, &[], 50, 50), vec![16]);
        assert_eq!(free_window_starts(400, &[(70, 220)], 150, 50), vec![220]);
    }

    #[test]
    fn spread_order_visits_every_index_once() {
        // The values training/data.py's _spread gives.
        assert_eq!(spread_order(1), vec![0]);
        assert_eq!(spread_order(4), vec![2, 1, 3, 0]);
        assert_eq!(spread_order(7), vec![3, 1, 5, 0, 2, 4, 6]);
        for n in 0..40 {
            let mut order = spread_order(n);
            order.sort_unstable();
            assert_eq!(order, (0..n).collect::<Vec<_>>());
        }
    }

    #[test]
    fn windows_alternate_takes_and_avoid_test_windows() {
        let windows = validation_windows("walking", &[(2, 1200), (1, 1600)], 8);
        assert_eq!(windows.len(), 8);
        for (k, w) in windows.iter().enumerate() {
            assert_eq!(w.sample, k);
            assert_eq!(w.subaction, if k % 2 == 0 { 1 } else { 2 });
            for t in test_windows("walking").filter(|t| t.subaction == w.subaction) {
                let end = w.seed_start + VALIDATION_WINDOW_FRAMES;
                assert!(end <= t.seed_start || w.seed_start >= t.predict_start + 100);
            }
        }
    }
}
