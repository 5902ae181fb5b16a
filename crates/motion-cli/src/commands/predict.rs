//! `motion-cli predict` (being built).

/// Arguments of `motion-cli predict`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("predict is not built yet".into()).into())
}
