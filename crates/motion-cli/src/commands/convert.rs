//! `motion-cli convert IN OUT [--fps HZ] [--positions]`: between exp-map text, BVH and `.npy`,
//! or from any of them to world joint positions.
use std::path::PathBuf;

use motion_core::any_format::{
    format_name, positions, read_any, resample_any, write_channels, Described,
};
use motion_core::formats::npy::write_npy;
use motion_core::formats::FileFormat;
use motion_core::motion::check_fps;
use serde_json::json;

use super::UsageError;

/// The long help after the options: what the conversions mean, then examples.
const LONG_HELP: &str = "\
Formats come from the file extensions. Exp-map files (.txt, .txt.gz, .npy with frames x \
channels) carry no frame rate: they are read as 50 Hz (H3.6M's rate) unless --input-fps says \
otherwise. 99 columns are read as the H3.6M 32-joint skeleton (root stored as per-50 Hz-frame \
deltas, integrated so the character moves), 117 columns as the CMU 38-joint skeleton (absolute \
root); other column counts can only be copied between .txt and .npy.

A BVH written from H3.6M data has the joint names of h36m_skeleton.json, millimetres, y up, \
every joint a JOINT with Zrotation Xrotation Yrotation channels (the root also Xposition \
Yposition Zposition), and the same world positions as the exp-map forward kinematics. A BVH \
is converted back to exp-map frames when its joints are the H3.6M (or CMU) ones, in any \
rotation order.

--fps N takes any rate >= 1: a whole ratio keeps every k-th frame (the evaluation protocol's \
downsampling, H3.6M root deltas untouched); any other ratio interpolates in BVH space, where the \
root is absolute (rotations by slerp, positions linearly). Exp-map output then stores H3.6M root \
deltas per output frame.

Examples:
  # H3.6M exp-map text to BVH (50 Hz), and back
  motion-cli convert S5/walking_1.txt.gz walking.bvh
  motion-cli convert walking.bvh walking.txt

  # The evaluation protocol's 25 Hz (keep the even frames) before converting
  motion-cli convert S5/walking_1.txt.gz walking_25hz.bvh --fps 25

  # World joint positions, frames x joints x 3, millimetres
  motion-cli convert S5/walking_1.txt.gz walking_positions.npy --positions
  motion-cli convert some_capture.bvh positions.npy --positions

  # Exp-map frames as a frames x channels .npy
  motion-cli convert S5/walking_1.txt.gz walking.npy

Bad input (unreadable file, parse error with its line, unknown extension, impossible rate) \
prints one line and exits with status 2; the output is written to a temporary file next to \
it and renamed, so it is never left half-written.";

/// Arguments of `motion-cli convert`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
pub struct Args {
    /// Input file: .txt, .txt.gz, .bvh or .npy.
    pub input: PathBuf,
    /// Output file: .txt, .txt.gz, .bvh or .npy (with --positions: .npy).
    pub output: PathBuf,
    /// Resample to this rate (any, >= 1): a whole ratio keeps every k-th frame (`--fps 25` on
    /// 50 Hz H3.6M is the evaluation protocol's downsampling), others interpolate by slerp.
    #[arg(long, value_name = "HZ")]
    pub fps: Option<f64>,
    /// Frame rate of exp-map input (.txt, .txt.gz, .npy), which files do not store.
    #[arg(long, value_name = "HZ", default_value_t = motion_core::seed::DEFAULT_EXPMAP_FILE_FPS)]
    pub input_fps: f64,
    /// Write world joint positions (frames x joints x 3, millimetres for H3.6M) to OUT.npy
    /// instead of converting the channels. For BVH input, End Sites are included, in file order.
    #[arg(long)]
    pub positions: bool,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let in_format = FileFormat::from_path(&args.input)?;
    let out_format = FileFormat::from_path(&args.output)?;
    if args.positions && out_format != FileFormat::Npy {
        return Err(UsageError(format!(
            "--positions writes a .npy array (frames x joints x 3), not {}",
            args.output.display()
        ))
        .into());
    }
    // The one frame-rate rule of every command (motion_core::motion::check_fps).
    for (flag, rate) in [("--input-fps", Some(args.input_fps)), ("--fps", args.fps)] {
        if let Some(Err(problem)) = rate.map(check_fps) {
            return Err(UsageError(format!("{flag}: {problem}")).into());
        }
    }

    motion_core::clip::check_not_an_input(&args.output, &[&args.input])?;
    let mut loaded = read_any(&args.input, args.input_fps)?;
    let input = Described::of(&loaded);
    let mut notices = Vec::new();
    if let Some(target) = args.fps {
        let how;
        (loaded, how) = resample_any(loaded, target, &args.input)?;
        notices.push(format!(
            "note: resampled {} fps to {} fps by {how} ({} -> {} frames)",
            input.fps,
            target,
            input.frames,
            Described::of(&loaded).frames
        ));
    }
    let written = Described::of(&loaded);

    let (what, shape) = if args.positions {
        let positions = positions(&loaded, &args.input)?;
        write_npy(&args.output, &positions)?;
        ("positions", positions.shape().to_vec())
    } else {
        let shape = write_channels(loaded, &args.input, &args.output, out_format, &mut notices)?;
        ("channels", shape)
    };

    if args.reporting.json {
        args.reporting.print_json(&json!({
            "input": {
                "path": args.input,
                "format": format_name(in_format),
                "frames": input.frames,
                "fps": input.fps,
                "skeleton": input.skeleton,
            },
            "output": {
                "path": args.output,
                "format": format_name(out_format),
                "content": what,
                "shape": shape,
                "frames": written.frames,
                "fps": written.fps,
                "skeleton": written.skeleton,
            },
            "notices": notices,
        }))?;
    } else {
        notices.iter().for_each(|n| args.reporting.notice(n));
        args.reporting.notice(format_args!(
            "wrote {} ({} frames at {} fps{})",
            args.output.display(),
            written.frames,
            written.fps,
            written
                .skeleton
                .map(|s| format!(", {s} skeleton"))
                .unwrap_or_default()
        ));
    }
    Ok(())
}
