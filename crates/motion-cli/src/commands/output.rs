//! `--json` and `--quiet`: how every subcommand reports, defined once.
//!
//! - Text mode: results (tables, descriptions) on stdout; notices ("wrote ...", warnings, notes)
//!   and progress bars on stderr.
//! - `--json`: exactly one JSON object on stdout describing what was done or measured; notices
//!   go into that object (`"notices"`) instead of stderr, and no progress bar is drawn.
//! - `--quiet`: no notices and no progress bars on stderr; results still print.
//!
//! Errors are never silenced: one line on stderr and exit status 2 (bad input) or 1, whatever
//! the flags (`main`).
use std::fmt::Display;
use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// The reporting flags shared by every subcommand (`#[command(flatten)]`).
#[derive(clap::Args, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Output {
    /// Print one JSON object on stdout describing what was done or measured (notices included),
    /// and nothing else there.
    #[arg(long)]
    pub json: bool,
    /// No notices and no progress bars on stderr (errors still print there).
    #[arg(long, short = 'q')]
    pub quiet: bool,
}

impl Output {
    /// Whether notices go to stderr: text mode without `--quiet`.
    pub fn notices_on_stderr(&self) -> bool {
        !self.quiet && !self.json
    }

    /// Prints a notice on stderr when [`Output::notices_on_stderr`].
    pub fn notice(&self, message: impl Display) {
        if self.notices_on_stderr() {
            eprintln!("{message}");
        }
    }

    /// A progress bar of `total` steps on stderr, drawn `template` (`{bar}`, `{pos}`, `{len}`,
    /// `{elapsed}`, `{msg}`); hidden with `--json`, `--quiet` or when stderr is not a terminal.
    pub fn progress_bar(&self, total: u64, template: &str) -> ProgressBar {
        if !self.notices_on_stderr() || !std::io::stderr().is_terminal() {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        bar
    }

    /// Prints `value` as the command's one JSON object on stdout.
    pub fn print_json<T: serde::Serialize + ?Sized>(&self, value: &T) -> anyhow::Result<()> {
        println!("{}", serde_json::to_string_pretty(value)?);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_and_quiet_each_keep_notices_off_stderr() {
        let text = Output::default();
        assert!(text.notices_on_stderr());
        for out in [
            Output {
                json: true,
                quiet: false,
            },
            Output {
                json: false,
                quiet: true,
            },
            Output {
                json: true,
                quiet: true,
            },
        ] {
            assert!(!out.notices_on_stderr(), "{out:?}");
            assert!(out.progress_bar(10, "{bar}").is_hidden());
        }
    }
}
