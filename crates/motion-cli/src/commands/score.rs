//! `motion-cli score` (being built).

/// Arguments of `motion-cli score`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("score is not built yet".into()).into())
}
