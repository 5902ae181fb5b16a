//! `motion-cli convert` (being built).

/// Arguments of `motion-cli convert`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("convert is not built yet".into()).into())
}
