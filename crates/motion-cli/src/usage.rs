//! [`UsageError`]: what the user gave us is wrong (exit code 2).

/// An error caused by what the user gave us (bad file, bad shape, bad flag): exit code 2.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}
