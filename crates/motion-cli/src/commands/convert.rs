//! `motion-cli convert IN OUT [--fps HZ] [--positions]`: between exp-map text, BVH and `.npy`,
//! or from any of them to world joint positions.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use motion_core::formats::bvh::{read_bvh, write_bvh, Bvh};
use motion_core::formats::expmap_bvh::{
    bvh_to_expmap, expmap_to_bvh, offset_difference, ExpMapTarget,
};
use motion_core::formats::h36m_text::{read_expmap_text, write_expmap_text};
use motion_core::formats::npy::{read_npy_frames, write_npy};
use motion_core::formats::FileFormat;
use motion_core::kinematics::channel_positions;
use motion_core::motion::{Motion, MotionLayout, RootEncoding};
use motion_core::resample::resample_bvh;
use motion_core::skeleton::{Skeleton, CMU_FRAME_DIMS, H36M_FRAME_DIMS, H36M_SOURCE_FPS};
use ndarray::{s, Array2, Array3};
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
    #[arg(long, value_name = "HZ", default_value_t = H36M_SOURCE_FPS)]
    pub input_fps: f64,
    /// Write world joint positions (frames x joints x 3, millimetres for H3.6M) to OUT.npy
    /// instead of converting the channels. For BVH input, End Sites are included, in file order.
    #[arg(long)]
    pub positions: bool,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// A loaded input.
enum Loaded {
    /// Exp-map frames on a built-in skeleton.
    ExpMap(Motion),
    /// Exp-map frames of a width no built-in skeleton has (copy only).
    Unknown { frames: Array2<f64>, fps: f64 },
    /// A BVH file.
    Bvh(Bvh),
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
    // H3.6M root deltas are per 50 Hz source frame: below 1 fps one frame would span more than 50.
    for (flag, rate) in [("--input-fps", Some(args.input_fps)), ("--fps", args.fps)] {
        if let Some(rate) = rate.filter(|r| !(r.is_finite() && *r >= 1.0)) {
            return Err(UsageError(format!(
                "{flag} must be at least 1 (frames per second), got {rate}"
            ))
            .into());
        }
    }

    let mut loaded = load(&args.input, in_format, args.input_fps)?;
    let input = Described::of(&loaded);
    let mut notices = Vec::new();
    if let Some(target) = args.fps {
        let how;
        (loaded, how) = resample(loaded, target, &args.input)?;
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
        let shape = write_channels(&args, loaded, out_format, &mut notices)?;
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

/// Writes the channels of `loaded` (BVH, exp-map text or `.npy`); returns the written shape
/// (BVH: frames x channels).
fn write_channels(
    args: &Args,
    loaded: Loaded,
    out_format: FileFormat,
    notices: &mut Vec<String>,
) -> anyhow::Result<Vec<usize>> {
    match out_format {
        FileFormat::Bvh => {
            let bvh = match loaded {
                Loaded::Bvh(bvh) => bvh,
                Loaded::ExpMap(motion) => expmap_to_bvh(&motion)
                    .map_err(|e| UsageError(format!("{}: {e}", args.input.display())))?,
                Loaded::Unknown { frames, .. } => {
                    return Err(no_skeleton(&args.input, frames.ncols()))
                }
            };
            write_bvh(&args.output, &bvh)?;
            Ok(bvh.frames.shape().to_vec())
        }
        FileFormat::ExpMapText | FileFormat::Npy => {
            let frames = match loaded {
                Loaded::ExpMap(motion) => motion.into_frames(),
                Loaded::Unknown { frames, .. } => frames,
                Loaded::Bvh(bvh) => {
                    let bad = |e: motion_core::formats::expmap_bvh::ConvertError| {
                        UsageError(format!("{}: {e}", args.input.display()))
                    };
                    let target = ExpMapTarget::detect(&bvh).map_err(bad)?;
                    let difference = offset_difference(&bvh, target);
                    if difference > 1e-6 {
                        notices.push(format!(
                            "warning: {}: joint offsets differ from the built-in {} skeleton by up to {difference}; exp-map frames keep only rotations and the root motion (in the BVH's units)",
                            args.input.display(),
                            target.name()
                        ));
                    }
                    bvh_to_expmap(&bvh, target).map_err(bad)?.into_frames()
                }
            };
            if out_format == FileFormat::Npy {
                write_npy(&args.output, &frames)?;
            } else {
                write_expmap_text(&args.output, frames.view())?;
            }
            Ok(frames.shape().to_vec())
        }
    }
}

/// Frames, rate and skeleton of a loaded motion, for the report.
struct Described {
    frames: usize,
    fps: f64,
    /// `None` for exp-map columns no built-in skeleton has.
    skeleton: Option<String>,
}

impl Described {
    fn of(loaded: &Loaded) -> Described {
        match loaded {
            Loaded::ExpMap(motion) => Described {
                frames: motion.len(),
                fps: motion.fps(),
                // `load` puts H3.6M (root deltas) and CMU (absolute root) frames on their skeletons.
                skeleton: Some(match motion.layout() {
                    MotionLayout::ExpMap {
                        root: RootEncoding::Deltas,
                    } => format!("H3.6M {}-joint", motion.skeleton().len()),
                    _ => format!("CMU {}-joint", motion.skeleton().len()),
                }),
            },
            Loaded::Unknown { frames, fps } => Described {
                frames: frames.nrows(),
                fps: *fps,
                skeleton: None,
            },
            Loaded::Bvh(bvh) => Described {
                frames: bvh.frames.nrows(),
                fps: bvh.fps(),
                skeleton: Some(match ExpMapTarget::detect(bvh) {
                    Ok(target) => format!("{} {}-joint", target.name(), target.skeleton().len()),
                    Err(_) => format!("BVH {}-joint", bvh.skeleton.len()),
                }),
            },
        }
    }
}

fn format_name(format: FileFormat) -> &'static str {
    match format {
        FileFormat::ExpMapText => "exp-map text",
        FileFormat::Bvh => "bvh",
        FileFormat::Npy => "npy",
    }
}

fn load(path: &Path, format: FileFormat, input_fps: f64) -> anyhow::Result<Loaded> {
    let frames = match format {
        FileFormat::Bvh => return Ok(Loaded::Bvh(read_bvh(path)?)),
        FileFormat::ExpMapText => read_expmap_text(path)?,
        FileFormat::Npy => read_npy_frames(path)?,
    };
    let (skeleton, root) = match frames.ncols() {
        H36M_FRAME_DIMS => (Skeleton::h36m(), RootEncoding::Deltas),
        CMU_FRAME_DIMS => (Skeleton::cmu(), RootEncoding::Absolute),
        _ => {
            return Ok(Loaded::Unknown {
                frames,
                fps: input_fps,
            })
        }
    };
    let motion = Motion::new(
        Arc::new(skeleton),
        MotionLayout::ExpMap { root },
        frames,
        input_fps,
    )
    .with_context(|| format!("{}: cannot be read as a motion", path.display()))?;
    Ok(Loaded::ExpMap(motion))
}

/// `loaded` at `target` fps: a whole ratio k keeps every k-th frame (0, k, 2k, ...; for H3.6M the
/// protocol's downsampling, root deltas untouched); any other ratio resamples by slerp in BVH
/// space ([`motion_core::resample::resample_bvh`]). Returns the result and how it was done.
fn resample(loaded: Loaded, target: f64, input: &Path) -> anyhow::Result<(Loaded, String)> {
    let source_fps = match &loaded {
        Loaded::ExpMap(motion) => motion.fps(),
        Loaded::Unknown { fps, .. } => *fps,
        Loaded::Bvh(bvh) => bvh.fps(),
    };
    let ratio = source_fps / target;
    let k = ratio.round();
    // BVH frame times are rounded in files (0.00833333 for 120 Hz): allow for that.
    if k >= 1.0 && (ratio - k).abs() < 1e-3 * k {
        let k = k as usize;
        let keep = |frames: &Array2<f64>| frames.slice(s![..;k, ..]).to_owned();
        let resampled = match loaded {
            Loaded::ExpMap(motion) => {
                let frames = keep(&motion.frames().to_owned());
                Loaded::ExpMap(Motion::new(
                    motion.skeleton().clone(),
                    motion.layout(),
                    frames,
                    target,
                )?)
            }
            Loaded::Unknown { frames, .. } => Loaded::Unknown {
                frames: keep(&frames),
                fps: target,
            },
            Loaded::Bvh(bvh) => Loaded::Bvh(Bvh {
                frames: keep(&bvh.frames),
                frame_time: bvh.frame_time * k as f64,
                skeleton: bvh.skeleton,
            }),
        };
        return Ok((resampled, format!("keeping 1 frame in {k}")));
    }
    let bvh = match loaded {
        Loaded::Bvh(bvh) => bvh,
        Loaded::ExpMap(motion) => expmap_to_bvh(&motion)
            .map_err(|e| UsageError(format!("{}: {e}", input.display())))?,
        Loaded::Unknown { frames, .. } => {
            return Err(UsageError(format!(
                "{}: {} columns fit no built-in skeleton, so only whole-ratio resampling (keeping every k-th frame) is possible, not {source_fps} fps to {target} fps",
                input.display(),
                frames.ncols()
            ))
            .into())
        }
    };
    Ok((
        Loaded::Bvh(resample_bvh(&bvh, target)),
        "interpolating (rotations by slerp, positions linearly)".into(),
    ))
}

fn positions(loaded: &Loaded, input: &Path) -> anyhow::Result<Array3<f64>> {
    Ok(match loaded {
        Loaded::ExpMap(motion) => motion.positions(),
        Loaded::Bvh(bvh) => channel_positions(&bvh.skeleton, bvh.frames.view())
            .with_context(|| format!("{}: forward kinematics", input.display()))?,
        Loaded::Unknown { frames, .. } => return Err(no_skeleton(input, frames.ncols())),
    })
}

fn no_skeleton(input: &Path, columns: usize) -> anyhow::Error {
    UsageError(format!(
        "{}: {columns} columns per frame fit no built-in skeleton ({H36M_FRAME_DIMS} = H3.6M, {CMU_FRAME_DIMS} = CMU), so there is no skeleton for BVH or positions",
        input.display()
    ))
    .into()
}
