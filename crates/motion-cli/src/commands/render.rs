//! `motion-cli render IN [--compare OTHER] --out FILE.svg|FILE.gif|FILE.png`: the skeleton over
//! time from a fixed camera, as an animation (SVG, GIF) or a contact sheet of frames (PNG).
mod gif_anim;
mod paint;
mod scene;
mod sheet;
mod style;
mod svg_anim;

use std::path::{Path, PathBuf};

use serde_json::json;

use super::UsageError;
use motion_core::formats::atomic::write_bytes_atomically;
use paint::Picture;
use scene::{floor_grid, floor_height, load_track, rotate_track, timeline, Camera, Upright};

/// The long help after the options.
const LONG_HELP: &str = "\
IN and OTHER are .bvh (any skeleton), exp-map .txt/.txt.gz/.npy (99 columns = H3.6M, 117 = \
CMU; read at --input-fps, since these files store no rate: pass --input-fps 25 for the output \
of `predict`), a .npy of samples x frames x 99 (--sample picks one) or of positions frames x \
joints x 3 (32 = H3.6M, 38 = CMU joints).

The camera looks from the character's front right (a 3/4 view, H3.6M characters face +z), \
slightly from above, orthographic, y up. Animations (.svg: SMIL, plays in browsers; .gif) keep \
one frame that fits the whole trajectory over a floor grid; the .png contact sheet shows \
--cells moments, each cell following the character. With --compare, OTHER is drawn over IN in \
orange (IN in blue); with --seed-frames N, IN's first N frames are drawn grey and the \
seed/prediction boundary is marked in red.

Lean is never hidden: H3.6M takes start from an unknown root orientation, so a motion may start \
tilted; by default one rotation, judged on IN's first frame alone (the seed's first frame), \
turns the whole drawing upright when that frame leans 8-60°, and every later change of lean (a \
prediction tipping over) is drawn as it is. --upright instead straightens the average lean of \
the whole motion (for recordings; it can hide what a prediction does); --no-upright draws the \
coordinates untouched.

Examples:
  motion-cli predict --seed examples/walk_seed.bvh --out pred.bvh
  motion-cli render pred.bvh --seed-frames 50 --out pred.gif
  motion-cli render pred.bvh --seed-frames 50 --out pred.png
  motion-cli render pred.bvh --compare truth.bvh --seed-frames 50 --out compare.svg";

/// Arguments of `motion-cli render`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
pub struct Args {
    /// Motion to draw (.bvh, .txt, .txt.gz, .npy).
    pub input: PathBuf,
    /// A second motion drawn over the first in another colour (e.g. the ground truth).
    #[arg(long, value_name = "OTHER")]
    pub compare: Option<PathBuf>,
    /// Output: .svg or .gif (animation) or .png (contact sheet).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// IN's first N frames are the seed: drawn grey, the boundary marked.
    #[arg(long, value_name = "N")]
    pub seed_frames: Option<usize>,
    /// Frame rate of exp-map inputs (.txt, .txt.gz, .npy), which files do not store (1 to
    /// 10,000; a BVH's Frame Time must give a rate in that range too). Animations are limited
    /// to 30,000 frames.
    #[arg(long, value_name = "HZ", default_value_t = motion_core::seed::DEFAULT_EXPMAP_FILE_FPS)]
    pub input_fps: f64,
    /// Which sample of a samples x frames x dims .npy to draw.
    #[arg(long, default_value_t = 0)]
    pub sample: usize,
    /// Cells of the PNG contact sheet (1 to 400).
    #[arg(long, default_value_t = 12)]
    pub cells: usize,
    /// Cells per row of the PNG contact sheet (1 to 400).
    #[arg(long, default_value_t = 6)]
    pub columns: usize,
    /// Animation width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: usize,
    /// Animation height in pixels.
    #[arg(long, default_value_t = 400)]
    pub height: usize,
    /// Straighten the whole motion: turn its average lean over all frames upright (opt-in: it
    /// can hide a lean that grows during a prediction). By default only IN's first frame sets
    /// the upright reference, so later lean stays visible.
    #[arg(long, conflicts_with = "no_upright")]
    pub upright: bool,
    /// No turn at all: draw the coordinates as they are.
    #[arg(long)]
    pub no_upright: bool,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Most cells of a contact sheet (and cells per row).
pub const MAX_CELLS: usize = 400;
/// Most frames of an animation (20 minutes at 25 fps); a longer one is refused up front.
pub const MAX_FRAMES: usize = 30_000;
/// Most pixels a GIF paints over all its frames (2^31: about 45 s of drawing on a 2-core VM at
/// ~20 ns a pixel; 8,192 frames at the default 640 x 400); more is refused before drawing.
pub const MAX_GIF_PIXELS: u64 = 1 << 31;

/// What the output extension asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Svg,
    Gif,
    Png,
}

fn kind_of(out: &Path) -> anyhow::Result<Kind> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "svg" => Ok(Kind::Svg),
        "gif" => Ok(Kind::Gif),
        "png" => Ok(Kind::Png),
        _ => Err(UsageError(format!(
            "{}: unknown picture format (expected .svg, .gif or .png)",
            out.display()
        ))
        .into()),
    }
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let kind = kind_of(&args.out)?;
    let inputs: Vec<&Path> = std::iter::once(args.input.as_path())
        .chain(args.compare.as_deref())
        .collect();
    motion_core::clip::check_not_an_input(&args.out, &inputs)?;
    let dir = match args.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(UsageError(format!(
            "{}: the output directory {} does not exist",
            args.out.display(),
            dir.display()
        ))
        .into());
    }
    if let Err(problem) = motion_core::motion::check_fps(args.input_fps) {
        return Err(UsageError(format!("--input-fps: {problem}")).into());
    }
    if !(1..=MAX_CELLS).contains(&args.cells) || !(1..=MAX_CELLS).contains(&args.columns) {
        return Err(UsageError(format!(
            "--cells and --columns must be between 1 and {MAX_CELLS}"
        ))
        .into());
    }
    if !(64..=4096).contains(&args.width) || !(64..=4096).contains(&args.height) {
        return Err(
            UsageError("--width and --height must be between 64 and 4096 pixels".into()).into(),
        );
    }
    let mut first = load_track(&args.input, args.input_fps, args.sample)?;
    let mut second = match &args.compare {
        Some(path) => Some(load_track(path, args.input_fps, args.sample)?),
        None => None,
    };
    if let Some(n) = args.seed_frames {
        if n > first.len() {
            return Err(UsageError(format!(
                "{}: --seed-frames {n} but the motion has only {} frames",
                args.input.display(),
                first.len()
            ))
            .into());
        }
    }
    let mode = if args.no_upright {
        Upright::Off
    } else if args.upright {
        Upright::WholeMotion
    } else {
        Upright::FirstFrame
    };
    let mut notices = Vec::new();
    if let Some((r, degrees)) = mode.rotation(&first) {
        let centre = first.root(0);
        rotate_track(&mut first, &r, centre);
        if let Some(s) = second.as_mut() {
            rotate_track(s, &r, centre);
        }
        notices.push(match mode {
            Upright::WholeMotion => format!(
                "note: {} leans {degrees:.0}° on average; the whole motion is drawn upright (--upright)",
                first.name
            ),
            _ => format!(
                "note: {}'s first frame leans {degrees:.0}°; the drawing is turned by that one rotation, later lean is drawn as it is (--no-upright: no turn)",
                first.name
            ),
        });
    }
    let mut tracks = vec![&first];
    tracks.extend(second.as_ref());
    if let Some(s) = &second {
        if (s.fps - first.fps).abs() > 1e-3 * first.fps {
            notices.push(format!(
                "note: {} is {} Hz, {} {} Hz: frames are matched by time",
                s.name, s.fps, first.name, first.fps
            ));
        }
    }
    notices.iter().for_each(|n| args.reporting.notice(n));
    let floor = floor_height(&tracks, args.seed_frames);
    // Grid lines every ~0.5 m of a person of the first track's size, in the file's units.
    let unit = first.extent / 900.0;
    let picture = Picture {
        grid: floor_grid(&tracks, floor, 500.0 * unit, 600.0 * unit),
        tracks,
        camera: Camera::three_quarter(35f64.to_radians(), 12f64.to_radians()),
        seed_frames: args.seed_frames,
    };
    let times = timeline(&picture.tracks, MAX_FRAMES).map_err(|frames| {
        UsageError(format!(
            "{}: {frames} frames to draw at {} fps, over the limit of {MAX_FRAMES}: render a shorter clip",
            args.input.display(),
            first.fps
        ))
    })?;
    let bytes = match kind {
        Kind::Svg => svg_anim::animate(&picture, &times, args.width, args.height).into_bytes(),
        Kind::Gif => {
            let drawn = gif_anim::drawn_frames(&picture, &times);
            let pixels = drawn as u64 * (args.width * args.height) as u64;
            if pixels > MAX_GIF_PIXELS {
                return Err(UsageError(format!(
                    "{}: {drawn} GIF frames of {} x {} pixels is {} pixels to paint, over the limit of {} (MAX_GIF_PIXELS): lower --width/--height or render a shorter clip",
                    args.input.display(),
                    args.width,
                    args.height,
                    pixels,
                    MAX_GIF_PIXELS
                ))
                .into());
            }
            let bar = args
                .reporting
                .progress_bar(drawn as u64, "GIF frames {bar:40} {pos}/{len} {eta}");
            let bytes = gif_anim::animate(&picture, &times, args.width, args.height, &bar)?;
            bar.finish_and_clear();
            bytes
        }
        Kind::Png => {
            sheet::contact_sheet(&picture, &times, args.cells, args.columns).encode_png()?
        }
    };
    write_bytes_atomically(&args.out, &bytes)?;
    if args.reporting.json {
        let report = json!({
            "input": args.input,
            "compare": args.compare,
            "out": args.out,
            "frames": times.len(),
            "fps": first.fps,
            "seed_frames": args.seed_frames,
            "upright": match mode {
                Upright::Off => "off",
                Upright::FirstFrame => "first frame",
                Upright::WholeMotion => "whole motion",
            },
            "bytes": bytes.len(),
            "notices": notices,
        });
        args.reporting.print_json(&report)?;
    } else {
        args.reporting.notice(format_args!(
            "wrote {} ({} frames, {:.2} s)",
            args.out.display(),
            times.len(),
            times.len() as f64 / first.fps
        ));
    }
    Ok(())
}
