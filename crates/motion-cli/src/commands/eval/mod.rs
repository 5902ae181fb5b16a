//! `motion-cli eval` (being built).

/// Arguments of `motion-cli eval`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the command.
pub fn run(_args: Args) -> anyhow::Result<()> {
    Err(super::UsageError("eval is not built yet".into()).into())
}
