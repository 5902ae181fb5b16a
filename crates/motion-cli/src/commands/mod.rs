//! One module per subcommand; each exposes `Args` (clap) and `run(Args) -> anyhow::Result<()>`.
pub mod bench;
pub mod classifier;
pub mod convert;
pub mod eval;
pub mod info;
pub mod matching;
pub mod output;

pub mod plausibility;
pub mod predict;
pub mod render;
pub mod score;
pub mod takes;

pub use crate::usage::UsageError;

/// The error and its causes on one line, each cause once, shortened to [`MAX_ERROR_CHARS`]
/// characters (a 10 MB joint name stays a readable line) and with line breaks flattened.
/// With `--verbose`: every cause of `err` on its own line, outermost first, as the libraries'
/// `source()` chains give them (each line capped like [`error_chain`]'s).
pub fn error_causes(err: &anyhow::Error) -> String {
    err.chain()
        .enumerate()
        .map(|(k, cause)| {
            let text = shorten(
                &cause.to_string().replace(['\n', '\r'], " "),
                MAX_ERROR_CHARS,
            );
            if k == 0 {
                format!("error: {text}")
            } else {
                format!("  caused by: {text}")
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

pub fn error_chain(err: &anyhow::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    for cause in err.chain() {
        let text = cause.to_string();
        // thiserror messages often embed their source; do not print the same text twice.
        if !parts.iter().any(|p| p.contains(&text)) {
            parts.push(text);
        }
    }
    shorten(
        &parts.join(": ").replace(['\n', '\r'], " "),
        MAX_ERROR_CHARS,
    )
}

/// The longest error line printed, in characters.
pub const MAX_ERROR_CHARS: usize = 1000;

/// `text` cut to `max` characters: its start and end kept, the middle replaced by a count.
fn shorten(text: &str, max: usize) -> String {
    let count = text.chars().count();
    if count <= max {
        return text.to_string();
    }
    let keep = max / 2;
    let head: String = text.chars().take(keep).collect();
    let tail: String = text.chars().skip(count - keep / 2).collect();
    format!(
        "{head} [... {} characters ...] {tail}",
        count - keep - keep / 2
    )
}

/// Bad input (typed library errors about files, shapes and values, or [`UsageError`]) exits
/// with 2; a failure of the environment (an output that cannot be written for any reason but a
/// missing directory, a full disk, an interrupted call, memory) and anything unexpected with 1.
pub fn exit_code(err: &anyhow::Error) -> u8 {
    use std::io::ErrorKind;
    // A failure of the machine rather than of what the user gave: exit 1.
    let environment = |kind: ErrorKind| {
        matches!(
            kind,
            ErrorKind::StorageFull
                | ErrorKind::QuotaExceeded
                | ErrorKind::FileTooLarge
                | ErrorKind::ReadOnlyFilesystem
                | ErrorKind::Interrupted
                | ErrorKind::OutOfMemory
                | ErrorKind::TimedOut
                | ErrorKind::ResourceBusy
        )
    };
    for cause in err.chain() {
        if let Some(write) = cause.downcast_ref::<motion_core::error::WriteFailure>() {
            // An output that cannot be written is the environment's failure (disk full,
            // permission denied), unless the path itself is wrong: a missing directory, a
            // directory where the file should go, a file where a directory should be.
            let wrong_path = matches!(
                write.0.kind(),
                ErrorKind::NotFound
                    | ErrorKind::IsADirectory
                    | ErrorKind::NotADirectory
                    | ErrorKind::InvalidFilename
                    | ErrorKind::InvalidInput
            );
            return if wrong_path { 2 } else { 1 };
        }
        if let Some(io) = cause.downcast_ref::<std::io::Error>() {
            if environment(io.kind()) {
                return 1;
            }
        }
    }
    // Every typed error of the libraries describes what the user gave (files, arguments, shapes,
    // values); only a `WriteFailure` (above) can be the machine's.
    let is_input = err.chain().any(|c| {
        c.is::<UsageError>()
            || c.is::<motion_core::FormatError>()
            || c.is::<motion_core::error::SkeletonError>()
            || c.is::<motion_core::error::MotionError>()
            || c.is::<motion_core::formats::expmap_bvh::ConvertError>()
            || c.is::<motion_core::model::WeightsError>()
            || c.is::<motion_core::model::GenerateError>()
            || c.is::<motion_core::model::ClassifyError>()
            || c.is::<motion_core::model::CharacterError>()
            || c.is::<motion_core::nn::SimdError>()
            || c.is::<motion_core::seed::SeedError>()
            || c.is::<motion_core::clip::ClipError>()
            || c.is::<motion_core::resample::ResampleError>()
            || c.is::<motion_core::retarget::RetargetError>()
            || c.is::<motion_core::any_format::AnyMotionError>()
            || c.is::<motion_core::file_sets::FileSetError>()
            || c.is::<motion_core::matching::MatchingError>()
            || c.is::<motion_core::model::source::SourceError>()
            || c.is::<motion_core::rig_target::RigTargetError>()
            || c.is::<motion_core::takes::TakesError>()
            || c.is::<motion_core::steering::path::PathError>()
            || c.is::<motion_metrics::MetricError>()
            || c.is::<motion_metrics::plausibility::ReferenceError>()
            || c.is::<motion_metrics::protocol::ProtocolError>()
            || c.is::<motion_metrics::evaluation::EvalError>()
            || c.is::<std::io::Error>()
    });
    if is_input {
        2
    } else {
        1
    }
}
