//! `motion-cli render` (being built).

/// Arguments of `motion-cli render`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("render is not built yet".into()).into())
}
