//! `motion-cli`: a thin command-line front end over `motion-core` and `motion-metrics`.
//!
//! Exit codes: 0 success, 2 bad input or usage (the error chain is printed once to stderr),
//! 1 any other failure.
mod commands;
mod model_source;
mod plot;
mod raster;
mod usage;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Real-time human motion synthesis and its evaluation.
#[derive(Parser, Debug)]
#[command(name = "motion-cli", version, about, long_about = None)]
struct Cli {
    /// On an error, print every cause on its own line (the libraries' source chain) instead of
    /// one line.
    #[arg(long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Convert between H3.6M exp-map text (.txt/.txt.gz), BVH and .npy.
    Convert(commands::convert::Args),
    /// Describe a weights or motion-matching database file: architecture or rig, sizes, fps,
    /// actions or takes, licence, provenance.
    Info(commands::info::Args),
    /// Score predictions against ground truth: NPSS, Euler error, NDMS, APD.
    Score(commands::score::Args),
    /// Reproduce the papers' H3.6M tables: run a model on the protocol's test windows and score it.
    Eval(commands::eval::Args),
    /// Predict future motion from a seed sequence (BVH, H3.6M text or .npy) in closed loop.
    Predict(commands::predict::Args),
    /// Draw a skeleton animation or contact sheet (SVG, GIF or PNG), optionally beside a second motion.
    Render(commands::render::Args),
    /// Time closed-loop generation steps per batch size (µs/step, character-steps/s, peak RSS).
    Bench(commands::bench::Args),
    /// Motion matching on your own takes: `matching build` makes a database from a folder of BVH
    /// takes on any rig (play it with `predict --model DB.safetensors`).
    Matching(commands::matching::Args),
    /// Takes as training data: `takes export` writes a folder of BVH takes (any rig) as exp-map
    /// frames on their rig for `training/locomotion.py --takes`.
    Takes(commands::takes::Args),
}

/// `text` with its control characters escaped (`\u{7}`), so that a name a user typed is never
/// sent raw to the terminal; line breaks between causes are kept.
fn printable(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            if c.is_control() && c != '\n' {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// Help and version print as clap writes them (exit 0); a usage error prints one line, clap's
/// message without its usage block and tip, and exits 2 like every other bad input.
fn usage_error(e: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        let _ = e.print();
        return ExitCode::SUCCESS;
    }
    if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        use clap::CommandFactory;
        let commands: Vec<String> = Cli::command()
            .get_subcommands()
            .map(|c| c.get_name().to_string())
            .filter(|name| name != "help")
            .collect();
        eprintln!(
            "error: no command given: one of {} (see --help)",
            commands.join(", ")
        );
        return ExitCode::from(2);
    }
    let text = e.render().to_string();
    // The message is everything before clap's usage block and tip, on one line.
    let message: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .filter(|l| !l.is_empty() && !l.starts_with("tip:"))
        .collect();
    let message = message.join(" ");
    let message = message.strip_prefix("error: ").unwrap_or(&message);
    eprintln!("error: {} (see --help)", printable(message));
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(&e),
    };
    // SIGINT / SIGTERM: remove the temporary files of outputs being written, then exit 1 (an
    // interruption is the environment's doing, not bad input). A handler that cannot be
    // installed (another one is) changes nothing else.
    let _ = ctrlc::set_handler(|| {
        let removed = motion_core::formats::atomic::remove_live_temp_files();
        eprintln!("error: interrupted; {removed} unfinished output file(s) removed");
        std::process::exit(1);
    });
    // MOTION_SIMD=avx512|avx2|neon|portable picks the kernels; a bad value is bad input.
    if let Err(err) = motion_core::nn::simd::init_from_env() {
        let err = anyhow::Error::new(err);
        eprintln!("error: {}", printable(&commands::error_chain(&err)));
        return ExitCode::from(commands::exit_code(&err));
    }
    let verbose = cli.verbose;
    let result = match cli.command {
        Command::Convert(args) => commands::convert::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Score(args) => commands::score::run(args),
        Command::Eval(args) => commands::eval::run(args),
        Command::Predict(args) => commands::predict::run(args),
        Command::Render(args) => commands::render::run(args),
        Command::Bench(args) => commands::bench::run(args),
        Command::Matching(args) => commands::matching::run(args),
        Command::Takes(args) => commands::takes::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) if verbose => {
            eprintln!("{}", printable(&commands::error_causes(&err)));
            ExitCode::from(commands::exit_code(&err))
        }
        Err(err) => {
            eprintln!("error: {}", printable(&commands::error_chain(&err)));
            ExitCode::from(commands::exit_code(&err))
        }
    }
}
