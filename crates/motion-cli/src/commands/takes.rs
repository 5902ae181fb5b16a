//! `motion-cli takes export --takes DIR --out DIR`: a folder of BVH takes on any rig written as
//! training data for a learned model on that rig (`motion_core::takes::training`; what
//! `training/locomotion.py --takes` reads). Also the take-reading arguments `matching build`
//! shares. The CLI only parses, reports and writes; the rules live in motion-core.
use std::path::{Path, PathBuf};

use motion_core::takes::{
    bvh_files, exclude_takes, read_take_files, unit_name, write_training_folder, TakeOptions, Takes,
};
use serde_json::json;

const EXPORT_HELP: &str = "\
Reads every .bvh file of --takes onto one rig exactly as `matching build` does (--rig, \
--joint-map, --fps, --min-seconds, --exclude) and writes a new folder --out holding takes.json \
(rate, frame layout, the rig's rest forward, the takes used and left out), rig.bvh and one \
NAME.npy per take: its frames as exp-map frames on the rig, the root as per-frame deltas. \
`python -m training.locomotion --takes DIR` trains a goal-conditioned model on them; the \
folder is what it exports by itself when given a folder of BVH takes.

--out must not exist: it is written under a temporary name and renamed when complete.

Examples:
  motion-cli takes export --takes ../shared/data/cmu_locomotion --exclude 16_16,16_18 --out cmu_takes
  motion-cli takes export --takes takes/ --joint-map map.json --fps 30 --out my_takes --json";

/// Which takes to read and how (shared by `takes export` and `matching build`).
#[derive(clap::Args, Debug)]
pub struct TakeArgs {
    /// Folder of BVH takes (every *.bvh in it, not recursive).
    #[arg(long, value_name = "DIR")]
    pub takes: PathBuf,
    /// A BVH whose rig every take goes onto (default: the first readable take's).
    #[arg(long, value_name = "FILE.bvh")]
    pub rig: Option<PathBuf>,
    /// A JSON joint map (H3.6M joint -> rig joint names) for rigs the built-in maps do not know.
    #[arg(long, value_name = "FILE.json")]
    pub joint_map: Option<PathBuf>,
    /// The rate every take is resampled to (Hz).
    #[arg(long, value_name = "HZ", default_value_t = motion_core::takes::DEFAULT_FPS)]
    pub fps: f64,
    /// Takes shorter than this after resampling are skipped (seconds).
    #[arg(long, value_name = "S", default_value_t = motion_core::takes::DEFAULT_MIN_SECONDS)]
    pub min_seconds: f64,
    /// Takes to leave out, by name (file name without .bvh), comma-separated.
    #[arg(long, value_name = "NAME,...", value_delimiter = ',')]
    pub exclude: Vec<String>,
}

impl TakeArgs {
    /// The files the arguments name (every input, for the output check).
    pub fn inputs(&self) -> Vec<&Path> {
        let mut inputs: Vec<&Path> = vec![&self.takes];
        inputs.extend(
            [&self.rig, &self.joint_map]
                .into_iter()
                .flatten()
                .map(PathBuf::as_path),
        );
        inputs
    }

    /// Reads the takes; returns them and the names left out by `--exclude`.
    pub fn read(&self) -> anyhow::Result<(Takes, Vec<String>)> {
        let (files, excluded) = exclude_takes(&self.takes, bvh_files(&self.takes)?, &self.exclude)?;
        let options = TakeOptions {
            fps: self.fps,
            rig: self.rig.clone(),
            joint_map: self.joint_map.clone(),
            min_seconds: self.min_seconds,
        };
        Ok((read_take_files(&files, &options, &self.takes)?, excluded))
    }
}

/// Arguments of `motion-cli takes`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `motion-cli takes`.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Write a folder of BVH takes (any rig) as training data on their rig.
    Export(ExportArgs),
}

/// Arguments of `motion-cli takes export`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = EXPORT_HELP)]
pub struct ExportArgs {
    #[command(flatten)]
    pub source: TakeArgs,
    /// The folder to write (must not exist).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Export(args) => export(args),
    }
}

fn export(args: ExportArgs) -> anyhow::Result<()> {
    motion_core::clip::check_not_an_input(&args.out, &args.source.inputs())?;
    let (takes, excluded) = args.source.read()?;
    for skipped in &takes.skipped {
        args.reporting.notice(format!(
            "skipped {}: {}",
            skipped.path.display(),
            skipped.reason
        ));
    }
    let manifest = write_training_folder(&takes, &excluded, &args.out)?;
    let frames: usize = manifest.takes.iter().map(|t| t.frames).sum();
    if args.reporting.json {
        args.reporting.print_json(&json!({
            "out": args.out,
            "frames": frames,
            "seconds": frames as f64 / manifest.fps,
            "units": unit_name(manifest.mm_per_unit),
            "manifest": manifest,
        }))?;
    } else {
        println!(
            "wrote {} ({} takes, {} frames, {:.0} s at {} Hz, {} joints, {} values per frame)",
            args.out.display(),
            manifest.takes.len(),
            frames,
            frames as f64 / manifest.fps,
            manifest.fps,
            manifest.joints,
            manifest.frame_dims
        );
    }
    Ok(())
}
