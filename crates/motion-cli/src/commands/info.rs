//! `motion-cli info` (being built).

/// Arguments of `motion-cli info`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("info is not built yet".into()).into())
}
