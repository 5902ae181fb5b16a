//! The sizes a file or a request may ask for, checked before memory is allocated for them, so
//! that a hostile or mistaken input is refused with a message instead of exhausting memory.
//!
//! Every front end (CLI, Python, C ABI, web) goes through these: a file read whole is at most
//! [`MAX_INPUT_BYTES`]; a clip held in memory (read, resampled, generated or written) is at most
//! [`MAX_CLIP_VALUES`] values. Together they keep one command under about 2 GB of memory.

/// The largest file read whole (BVH, `.npy`, weights, joint maps): 256 MiB. Exp-map text is
/// streamed and has its own bounds ([`crate::formats::h36m_text::MAX_TEXT_BYTES`]).
pub const MAX_INPUT_BYTES: u64 = 256 << 20;

/// The most values (frames x channels) of one clip in memory: 2^25, 256 MiB of f64 (for example
/// 339,000 frames of H3.6M's 99 values, 3.8 hours at 25 Hz).
pub const MAX_CLIP_VALUES: usize = 1 << 25;

/// A clip that would hold more than [`MAX_CLIP_VALUES`] values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{frames} frames x {width} values is over the limit of {} values one clip may hold in memory (MAX_CLIP_VALUES); {hint}",
    MAX_CLIP_VALUES
)]
pub struct ClipTooLarge {
    /// Frames asked for.
    pub frames: usize,
    /// Values per frame.
    pub width: usize,
    /// How to lower the request.
    pub hint: &'static str,
}

/// Checks that a clip of `frames` frames of `width` values fits [`MAX_CLIP_VALUES`]; `hint`
/// says how to ask for less (it ends the message).
pub fn check_clip(frames: usize, width: usize, hint: &'static str) -> Result<(), ClipTooLarge> {
    match frames.checked_mul(width) {
        Some(values) if values <= MAX_CLIP_VALUES => Ok(()),
        _ => Err(ClipTooLarge {
            frames,
            width,
            hint,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clips_over_the_limit_are_refused_without_overflow() {
        assert!(check_clip(MAX_CLIP_VALUES / 99, 99, "").is_ok());
        let e = check_clip(MAX_CLIP_VALUES / 99 + 1, 99, "use fewer frames").unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("MAX_CLIP_VALUES") && text.ends_with("use fewer frames"),
            "{text}"
        );
        assert!(check_clip(usize::MAX, 2, "").is_err());
    }
}
