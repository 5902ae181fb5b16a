//! `motion-cli predict --seed SEQ --out OUT`: closed-loop prediction from a seed sequence (BVH,
//! exp-map text or `.npy`), one file or a whole directory in parallel.

use anyhow::Context;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::formats::FileFormat;
use motion_core::grounding::GroundingConfig;
use motion_core::limits::check_clip;
use motion_core::model::samples::check_sample_size;
use motion_core::model::{
    generate_samples, ActionClassifier, GenerateError, ModelConfig, MotionModel,
};
use motion_core::motion::compact_number;
use motion_core::resample::resampled_len;
use ndarray::{s, Array2, Array3};
use rayon::prelude::*;
use serde_json::{json, Value};

use super::UsageError;
use crate::model_source::{describe, load_model, BuiltIn};

mod steered;
use motion_core::clip::{check_not_an_input, check_output, write_clips, Clips};
use motion_core::seed::{load_seed, model_window, WrittenClip};

/// The long help after the options: formats, conventions, examples.
const LONG_HELP: &str = "\
The seed is a BVH on the model's skeleton (H3.6M for the shipped weights: the 32 joint names of \
h36m_skeleton.json, as `motion-cli convert` writes them), exp-map text (.txt, .txt.gz) or a \
frames x 99 .npy. A BVH at another frame rate is resampled to the model's (rotations by slerp); \
exp-map files carry no rate and are read as --input-fps (50 Hz, H3.6M's rate), then every 2nd \
frame is kept for a 25 Hz model, as in the evaluation protocol. The last seed-length frames \
(the model's seed_frames) are used.

OUT's extension picks the format: .bvh (seed + prediction, the root integrated so the character \
moves; --prediction-only drops the seed), .npy or .txt (exp-map frames, root as per-50 Hz-frame \
deltas). With --samples N > 1, .bvh and .txt outputs become OUT_0, OUT_1, ... and .npy one array \
samples x frames x 99. Stochastic models draw each sample's noise from --rng-seed + sample \
(VGRU-d its plan noise, the intention model its z); GRU-d and DAE-LSTM give identical samples.

Batch mode: --seed DIR --out DIR predicts every .bvh/.txt/.txt.gz/.npy in DIR in parallel into \
DIR/<name>.<--format> (seeds whose names would give the same output are told apart: a.bvh and a.npy \
give a_bvh and a_npy, a name still taken gets _2, _3, ...); a bad file is reported and the others go on. \
Each output is written whole (a temporary file, then a rename); an interrupted batch keeps the outputs \
already completed and leaves no partial file.

Examples:
  motion-cli predict --seed examples/walk_seed.bvh --out pred.bvh
  motion-cli predict --seed examples/walk_seed.bvh --action walking --frames 250 --out pred.bvh
  motion-cli predict --seed S5/walking_1.txt.gz --samples 8 --rng-seed 7 --out walks.npy
  motion-cli predict --seed seeds/ --out predictions/ --format bvh

  # 4 s after the first 40 s of an H3.6M take, and the take's real 4 s beside it
  motion-cli predict --seed S5/walking_1.txt.gz --seed-end 1000 --truth truth.bvh --out pred.bvh
  motion-cli render pred.bvh --compare truth.bvh --seed-frames 50 --out walking.gif

Steering (--path FILE.json): the character is steered frame by frame toward the goal a path \
gives, one JSON object of either kind (metres, seconds; the floor is x-z, +y up; a facing is a \
yaw in radians, 0 facing +z, pi/2 facing +x):
  {\"waypoints\": [[x, z], ...], \"speed\": 1.2, \"radius\": 0.5, \"loop\": false}
      walk to each point in turn at speed (m/s, default 1.2), the next once within radius \
(m, default 0.5); after the last, stand (or start again with \"loop\": true)
  {\"goals\": [{\"t\": 0.0, \"velocity\": [vx, vz], \"facing\": 1.57}, ...]}
      from t seconds after the seed's end (increasing), move at velocity facing facing \
(default: where the velocity goes)
Coordinates are those of the written BVH, in which the seed's end is said in a notice (--json: \
seed_end). The output is BVH only; it lasts --frames, --seconds, the path's own time (timed \
goals: the last goal's t; waypoints: their length at their speed plus 3 s) or 10 s.

Motion matching (--model DB.safetensors, from `motion-cli matching build`): the seed is a BVH \
take on any rig (the database's rig by joint names, any units; another rig is retargeted onto \
it, --joint-map if the built-in maps do not fit), resampled to the database's rate; the whole \
seed (or its first --seed-end frames) is written, then the frames the database plays, steered \
by --path (without it, it plays on from the seed), as BVH on the database's rig in its own units.

  motion-cli matching build --takes ../shared/data/cmu_locomotion --out db.safetensors
  echo '{\"waypoints\": [[0, 4], [4, 4], [4, 0], [0, 0]], \"speed\": 1.2}' > square.json
  motion-cli predict --model db.safetensors --seed ../shared/data/cmu_locomotion/16_15.bvh \
      --path square.json --seconds 40 --out square.bvh
  motion-cli predict --seed examples/walk_seed.bvh --path square.json --seconds 20 --out steered.bvh

Bad input (missing or malformed file, skeleton mismatch, NaN, too few frames, unknown action, \
invalid weights, missing output directory, a malformed path) prints one line naming the file \
and exits with 2; outputs are written to a temporary file and renamed, so they are never left \
half-written.";

/// Arguments of `motion-cli predict`.
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
pub struct Args {
    /// Seed sequence (.bvh, .txt, .txt.gz, .npy), or a directory of them (batch mode).
    #[arg(long, value_name = "SEQ")]
    pub seed: PathBuf,
    /// Weights file, or a motion-matching database from `matching build` (default: the
    /// weights built into this binary).
    #[arg(long, value_name = "W")]
    pub model: Option<PathBuf>,
    /// Action label to condition on. Default: the seed's action as the built-in action classifier
    /// (Ghosh et al. 2017) sees it in the seed's last 2 s, said in a notice and in --json.
    #[arg(long, value_name = "NAME")]
    pub action: Option<String>,
    /// Action classifier weights used to infer the seed's action when --action is not given
    /// (default: the built-in action_classifier.safetensors).
    #[arg(long, value_name = "FILE")]
    pub classifier: Option<PathBuf>,
    /// Frames to predict, at the model's (or database's) frame rate [default: 100; with --path
    /// or a database: the path's own time, else 10 s].
    #[arg(long, value_name = "N", conflicts_with = "seconds")]
    pub frames: Option<usize>,
    /// Seconds to predict (instead of --frames).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Steer along a path file (JSON waypoints or timed goals; see below). Output .bvh only.
    #[arg(long, value_name = "FILE.json")]
    pub path: Option<PathBuf>,
    /// Number of samples (different noise: VGRU-d's plan noise, the intention model's z).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub samples: usize,
    /// Seed of sample 0's noise (sample i uses S + i).
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub rng_seed: u64,
    /// Output file (.bvh, .npy, .txt, .txt.gz), or a directory in batch mode.
    #[arg(long, value_name = "OUT")]
    pub out: PathBuf,
    /// Write only the predicted frames, not the seed before them.
    #[arg(long)]
    pub prediction_only: bool,
    /// Predict after the seed's first N frames (at the model's rate) instead of after its end,
    /// so that the file's later frames can serve as ground truth (see --truth).
    #[arg(long, value_name = "N")]
    pub seed_end: Option<usize>,
    /// Also write the seed file's real continuation (the seed window and the --frames frames
    /// after it, same format rules as OUT) for `render --compare` or `score`.
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Output format in batch mode.
    #[arg(long, value_name = "EXT", default_value = "bvh", value_parser = ["bvh", "npy", "txt"])]
    pub format: String,
    /// Frame rate of exp-map seeds (.txt, .txt.gz, .npy), which files do not store.
    #[arg(long, value_name = "HZ", default_value_t = motion_core::seed::DEFAULT_EXPMAP_FILE_FPS)]
    pub input_fps: f64,
    /// A JSON file mapping the H3.6M body joints to a BVH seed's own joint names
    /// (`{"Hips": "pelvis", "LeftArm": "upperarm_l", ...}`, all 21 of them), for rigs the
    /// built-in maps (CMU mocap BVH, Mixamo, Unreal mannequin) do not fit.
    #[arg(long, value_name = "FILE.json")]
    pub joint_map: Option<PathBuf>,
    /// Write BVH output on this character's own skeleton: a glTF/GLB skin or a BVH rig (its joint
    /// names, its rest translations as OFFSETs, metres; the built-in joint maps or --rig-map find
    /// its joints). Blender then imports a file that matches the character.
    #[arg(long, value_name = "FILE.glb|FILE.gltf|FILE.bvh")]
    pub rig: Option<PathBuf>,
    /// A JSON joint map for --rig's skeleton (H3.6M joint -> its joint names), when the built-in
    /// maps do not fit it.
    #[arg(long, value_name = "FILE.json", requires = "rig")]
    pub rig_map: Option<PathBuf>,
    /// Write BVH output at this rate (any, >= 1; rotations by slerp, the root linearly) instead
    /// of the model's (25 Hz for H3.6M models).
    #[arg(long, value_name = "HZ")]
    pub fps: Option<f64>,
    /// Write the model's raw motion: no grounding (by default every predicted frame is put on
    /// the seed's floor, levelled, held upright and its planted feet locked: see the crate docs
    /// of motion_core::grounding). For research scoring of raw output.
    #[arg(long)]
    pub no_grounding: bool,
    #[command(flatten)]
    pub reporting: super::output::Output,
}

/// Frames predicted without --frames, --seconds or --path (4 s at 25 Hz).
const DEFAULT_FRAMES: usize = 100;

/// Everything one prediction needs besides the seed and output paths.
struct Job {
    model: Arc<MotionModel>,
    target: ExpMapTarget,
    action: Option<String>,
    /// Set when the action is to be inferred from each seed (no --action, conditioned model).
    infer: Option<Arc<ActionClassifier>>,
    /// No --action and no classifier: `action` is the model's first label (said in a notice).
    defaulted: bool,
    frames: usize,
    samples: usize,
    rng_seed: u64,
    prediction_only: bool,
    input_fps: f64,
    seed_end: Option<usize>,
    /// BVH output rate (`--fps`).
    out_fps: Option<f64>,
    /// `--joint-map`.
    joint_map: Option<PathBuf>,
    /// `--rig`: the character BVH output is written on.
    rig_target: Option<motion_core::rig_target::RigTarget>,
    /// Grounding of written predictions (off with `--no-grounding`).
    grounding: GroundingConfig,
}

/// What one prediction produced.
struct Done {
    outputs: Vec<PathBuf>,
    /// The action the prediction was conditioned on, and whether it was inferred from the seed.
    action: Option<String>,
    inferred: bool,
    seed_frames: usize,
    notices: Vec<String>,
    /// The seed's floor the grounding fitted (grounding on).
    floor: Option<motion_core::grounding::Floor>,
}

/// The seed's floor for `--json`: where grounding put the floor frame (the output itself stays
/// in the seed's coordinates).
fn floor_json(floor: Option<&motion_core::grounding::Floor>) -> Value {
    floor.map_or(Value::Null, |f| {
        json!({
            "height_m": f.height,
            "slope_x": f.slope_x,
            "slope_z": f.slope_z,
            "tilt_deg": f.tilt_degrees(),
            "levelling_xyzw": f.level.to_array(),
            "pivot_m": f.pivot.to_array(),
        })
    })
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.frames == Some(0) {
        return Err(UsageError("--frames must be at least 1".into()).into());
    }
    steered::check_seconds(args.seconds)?;
    if let Some(store) = steered::open_rig_source(args.model.as_deref()) {
        return steered::run_rig_source(&args, &store);
    }
    if args.samples == 0 {
        return Err(UsageError("--samples must be at least 1".into()).into());
    }
    if let Some(fps) = args.fps {
        if let Err(problem) = motion_core::motion::check_fps(fps) {
            return Err(UsageError(format!("--fps: {problem}")).into());
        }
        let bvh = if args.seed.is_dir() {
            args.format == "bvh"
        } else {
            check_output(&args.out)? == FileFormat::Bvh
        };
        if !bvh {
            return Err(UsageError(format!(
                "--fps resamples BVH output; {} would be exp-map frames, which keep the model's rate (resample them later with `convert --fps`)",
                args.out.display()
            ))
            .into());
        }
    }
    // The one frame-rate rule, whatever the seed's format.
    if let Err(problem) = motion_core::motion::check_fps(args.input_fps) {
        return Err(UsageError(format!("--input-fps: {problem}")).into());
    }
    let batch = args.seed.is_dir();
    if !batch {
        if !args.seed.exists() {
            return Err(UsageError(format!("{}: no such file", args.seed.display())).into());
        }
        check_output(&args.out)?;
        // Every file the command reads: none may be overwritten.
        let mut inputs: Vec<&Path> = vec![&args.seed];
        inputs.extend(
            [
                &args.joint_map,
                &args.model,
                &args.classifier,
                &args.rig,
                &args.rig_map,
            ]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path),
        );
        check_not_an_input(&args.out, &inputs)?;
        // With several samples every output is numbered (`OUT_0.bvh`, ...): none may be an input.
        if args.samples > 1 && check_output(&args.out)? != FileFormat::Npy {
            for i in 0..args.samples {
                check_not_an_input(&motion_core::clip::numbered(&args.out, i), &inputs)?;
            }
        }
        // A joint map maps a BVH seed's rig; other seeds have none.
        if let Some(map) = &args.joint_map {
            let seed_format = FileFormat::from_path(&args.seed)?;
            if seed_format != FileFormat::Bvh {
                return Err(UsageError(format!(
                    "--joint-map {}: it maps a BVH seed's rig; {} is {} frames, which have no rig to map",
                    map.display(),
                    args.seed.display(),
                    match seed_format {
                        FileFormat::Npy => ".npy",
                        _ => "exp-map text",
                    }
                ))
                .into());
            }
        }
        if let Some(truth) = &args.truth {
            check_output(truth)?;
            inputs.push(&args.out);
            check_not_an_input(truth, &inputs)?;
        }
    } else if args.truth.is_some() {
        return Err(UsageError("--truth takes one seed file, not a directory".into()).into());
    } else if !args.out.is_dir() {
        return Err(UsageError(format!(
            "{}: with a seed directory, --out must be an existing directory",
            args.out.display()
        ))
        .into());
    }
    let model = load_model(args.model.as_deref(), BuiltIn::Game)?;
    let frames = match (args.frames, args.seconds) {
        (Some(n), _) => n,
        (None, Some(seconds)) => ((seconds * model.config().fps).round() as usize).max(1),
        (None, None) => DEFAULT_FRAMES,
    };
    check_sample_size(args.samples, frames, model.config().frame_dims)
        .map_err(|e| UsageError(format!("--samples {} --frames {frames}: {e}", args.samples)))?;
    if let Some(fps) = args.fps {
        // BVH output at --fps: refused before anything is generated if it would be too long.
        let config = model.config();
        let written = resampled_len(config.seed_frames + frames, config.fps, fps);
        check_clip(
            written,
            config.frame_dims,
            "ask for fewer --frames or a lower --fps",
        )
        .map_err(|e| {
            UsageError(format!(
                "--fps {} --frames {frames}: {e}",
                compact_number(fps),
            ))
        })?;
    }
    let model_skeleton = Arc::clone(model.skeleton());
    let action = choose_action(model.config(), args.action.as_deref())?;
    let infer = if args.action.is_none() && model.config().actions.len() > 1 {
        inference_classifier(&model, args.classifier.as_deref())?
    } else {
        None
    };
    let defaulted = args.action.is_none() && infer.is_none() && model.config().actions.len() > 1;
    let job = Job {
        target: target_of(
            model.config(),
            &describe(args.model.as_deref(), BuiltIn::Game),
        )?,
        action,
        infer,
        defaulted,
        model,
        frames,
        samples: args.samples,
        rng_seed: args.rng_seed,
        prediction_only: args.prediction_only,
        input_fps: args.input_fps,
        seed_end: args.seed_end,
        out_fps: args.fps,
        joint_map: args.joint_map.clone(),
        rig_target: rig_target_of(&args, &model_skeleton)?,
        grounding: if args.no_grounding {
            GroundingConfig::off()
        } else {
            GroundingConfig::default()
        },
    };
    let architecture = job.model.config().architecture();
    if args.samples > 1 && !architecture.is_stochastic() {
        args.reporting.notice(format_args!(
            "note: the model is deterministic ({}): all {} samples are identical",
            architecture.name(),
            args.samples
        ));
    }
    if args.path.is_some() {
        let name = describe(args.model.as_deref(), BuiltIn::Game);
        steered::run_model_path(&args, &job, &name)
    } else if batch {
        run_batch(&args, &job)
    } else {
        let done = predict_one(&job, &args.seed, &args.out, args.truth.as_deref())?;
        done.notices.iter().for_each(|n| args.reporting.notice(n));
        if args.reporting.json {
            let report = json!({
                "model": describe(args.model.as_deref(), BuiltIn::Game),
                "action": done.action,
                "action_inferred": done.inferred,
                "fps": job.model.config().fps,
                "output_fps": job.out_fps.unwrap_or(job.model.config().fps),
                "seed": args.seed,
                "seed_frames": done.seed_frames,
                "predicted_frames": job.frames,
                "samples": job.samples,
                "rng_seed": job.rng_seed,
                "outputs": done.outputs,
                "notices": done.notices,
                "seed_floor": floor_json(done.floor.as_ref()),
            });
            args.reporting.print_json(&report)?;
        } else {
            for path in &done.outputs {
                args.reporting.notice(format_args!(
                    "wrote {} ({} seed + {} predicted frames at {} Hz{})",
                    path.display(),
                    if job.prediction_only {
                        0
                    } else {
                        done.seed_frames
                    },
                    job.frames,
                    job.model.config().fps,
                    job.out_fps
                        .map(|f| format!(", written at {f} Hz"))
                        .unwrap_or_default()
                ));
            }
        }
        Ok(())
    }
}

/// The built-in skeleton of the model's frames.
fn target_of(config: &ModelConfig, model: &str) -> anyhow::Result<ExpMapTarget> {
    ExpMapTarget::for_frame_dims(config.frame_dims).ok_or_else(|| {
        UsageError(format!(
            "{model}: frames of {} values fit no built-in skeleton (99 = H3.6M, 117 = CMU)",
            config.frame_dims
        ))
        .into()
    })
}

/// The classifier that infers each seed's action, if it can read the model's frames; otherwise
/// `None` (the model's first label is then used, and each seed's notice says so).
fn inference_classifier(
    model: &MotionModel,
    path: Option<&Path>,
) -> anyhow::Result<Option<Arc<ActionClassifier>>> {
    if path.is_none() && !crate::model_source::has_default_classifier() {
        return Ok(None); // each seed's notice says which label is used
    }
    let classifier = crate::model_source::load_classifier(path)?;
    match classifier.fits(model.config()) {
        Ok(()) => {}
        Err(problem) if path.is_some() => {
            return Err(UsageError(format!(
                "{}: this classifier cannot label the model's seeds: {problem}",
                classifier.path().display()
            ))
            .into())
        }
        Err(_) => return Ok(None), // each seed's notice says which label is used
    }
    Ok(Some(classifier))
}

/// The action of one prediction: `--action`, or the seed's as the classifier sees it (with a
/// notice), or the model's first label when no classifier is available (with a notice).
fn resolve_action(
    job: &Job,
    seed: &Array2<f64>,
    seed_path: &Path,
) -> anyhow::Result<(Option<String>, bool, Option<String>)> {
    let Some(classifier) = &job.infer else {
        let notice = job.defaulted.then(|| {
            format!(
                "{}: no --action and no action classifier: conditioned on the model's first label `{}`",
                seed_path.display(),
                job.action.as_deref().unwrap_or("")
            )
        });
        return Ok((job.action.clone(), false, notice));
    };
    let (label, p) = classifier
        .infer_action(seed.view())
        .with_context(|| format!("{}: action classifier", seed_path.display()))?;
    let notice = format!(
        "{}: action `{label}` inferred from the seed (classifier probability {p:.2}; --action NAME overrides)",
        seed_path.display()
    );
    Ok((Some(label), true, Some(notice)))
}

/// `--action`, checked, or the model's first label (None for unconditioned models).
fn choose_action(config: &ModelConfig, action: Option<&str>) -> anyhow::Result<Option<String>> {
    match action {
        None => Ok(config.actions.first().cloned()),
        Some(_) if config.actions.is_empty() => Err(UsageError(
            "--action: this model is not action-conditioned (it has no action labels)".into(),
        )
        .into()),
        Some(label) if config.action_index(label).is_some() => Ok(Some(label.to_string())),
        Some(label) => Err(UsageError(format!(
            "unknown action `{label}`; valid actions: {}",
            config.actions.join(", ")
        ))
        .into()),
    }
}

/// Predicts from one seed file into `out` (format by extension); with `truth`, also writes the
/// file's real frames over the same span there.
fn predict_one(
    job: &Job,
    seed_path: &Path,
    out: &Path,
    truth: Option<&Path>,
) -> anyhow::Result<Done> {
    let format = check_output(out)?;
    let config = job.model.config();
    let seed = load_seed(
        seed_path,
        job.target,
        config.fps,
        job.input_fps,
        job.joint_map.as_deref(),
    )?;
    let needed = config.seed_frames.max(1);
    let total = seed.frames.nrows();
    let end = job.seed_end.unwrap_or(total);
    if end > total {
        return Err(UsageError(format!(
            "{}: --seed-end {end} is past the last frame ({total} frames at {} Hz)",
            seed_path.display(),
            config.fps
        ))
        .into());
    }
    if end < needed {
        return Err(UsageError(format!(
            "{}: {end} frames at {} Hz, the model needs at least {needed} ({:.2} s)",
            seed_path.display(),
            config.fps,
            needed as f64 / config.fps
        ))
        .into());
    }
    let start = end - needed;
    let truth_end = end + job.frames;
    if truth.is_some() && truth_end > total {
        return Err(UsageError(format!(
            "{}: --truth needs {} frames after the seed window, the file has {} (at {} Hz)",
            seed_path.display(),
            job.frames,
            total - end,
            config.fps
        ))
        .into());
    }
    let input = model_window(&seed.frames, start, end, job.target);
    let (action, inferred, action_notice) = resolve_action(job, &input, seed_path)?;
    let predictions = generate(job, action.as_deref(), &input)?;
    // What is written runs from the seed window's start (or, with --prediction-only, from the
    // first predicted frame) to the last predicted frame, cut from the seed file's frames up to
    // `end` followed by a continuation (a prediction, or the file's own frames for --truth).
    let first_written = if job.prediction_only { end } else { start };
    // Only the poses of the history anchor raw BVH output: a continuation's first frame is
    // placed by its own delta.
    let known = seed.poses.as_deref().map(|p| &p[..end.min(p.len())]);
    let rule = |format: FileFormat| WrittenClip {
        target: job.target,
        fps: config.fps,
        seed: start..end,
        first_written,
        action: action.as_deref(),
        grounding: job.grounding,
        anchor: (format == FileFormat::Bvh).then_some(known),
    };
    let history = seed.frames.slice(s![..end, ..]);
    let mut floor = None;
    let mut written = |continuation: ndarray::ArrayView2<'_, f64>,
                       format: FileFormat,
                       predicted: bool|
     -> anyhow::Result<Array2<f64>> {
        let (frames, fitted) = rule(format)
            .frames_and_floor(history, continuation, predicted)
            .with_context(|| format!("{}", seed_path.display()))?;
        floor = floor.or(fitted);
        Ok(frames)
    };
    let samples: Vec<Array2<f64>> = predictions
        .outer_iter()
        .map(|prediction| written(prediction, format, true))
        .collect::<anyhow::Result<_>>()?;
    // A seed on the user's own rig: BVH output goes back onto it, the rig's joints the model
    // lacks taken from the written seed frames (then the last seed frame).
    let rig = seed.rig.as_ref().map(|r| {
        let last = end.max(1) - 1;
        let from = first_written.min(last);
        (
            &r.retargeter,
            r.frames.slice(s![from..end.max(from + 1), ..]),
        )
    });
    let clips = |samples| Clips {
        samples,
        fps: config.fps,
        out_fps: job.out_fps,
        target: job.target,
        rig,
        rig_target: job.rig_target.as_ref(),
    };
    let mut outputs = write_clips(out, format, &clips(&samples))?;
    if let Some(truth) = truth {
        let format = check_output(truth)?;
        let real = [written(
            seed.frames.slice(s![end..truth_end, ..]),
            format,
            false,
        )?];
        outputs.extend(write_clips(truth, format, &clips(&real))?);
    }
    let mut notices = seed.notices;
    notices.extend(action_notice);
    if let Some(tilt) = floor
        .map(|f| f.tilt_degrees())
        .filter(|t| *t >= motion_core::grounding::floor::NOTABLE_TILT_DEG)
    {
        notices.push(format!(
            "{}: the seed's floor is tilted {tilt:.2} degrees (fitted to its feet); the motion was \
             grounded on it levelled and is written in the seed's own coordinates (--json: seed_floor)",
            seed_path.display()
        ));
    }
    Ok(Done {
        outputs,
        action,
        inferred,
        seed_frames: needed,
        notices,
        floor,
    })
}

/// The character of `--rig` (with `--rig-map`), its joints mapped from `source`'s.
fn rig_target_of(
    args: &Args,
    source: &motion_core::Skeleton,
) -> anyhow::Result<Option<motion_core::rig_target::RigTarget>> {
    use motion_core::rig_target::RigTarget;
    let Some(rig) = &args.rig else {
        return Ok(None);
    };
    let bvh_out = if args.seed.is_dir() {
        args.format == "bvh"
    } else {
        check_output(&args.out)? == FileFormat::Bvh
    };
    if !bvh_out {
        return Err(UsageError(format!(
            "--rig {}: the motion is written on a rig as BVH: give an --out ending in .bvh",
            rig.display()
        ))
        .into());
    }
    let map = match &args.rig_map {
        Some(path) => Some(
            std::fs::read_to_string(path)
                .map_err(|e| UsageError(format!("--rig-map {}: {e}", path.display())))?,
        ),
        None => None,
    };
    let ext = rig
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let target = match ext.as_str() {
        "glb" | "gltf" => RigTarget::from_gltf(rig, map.as_deref(), source)?,
        "bvh" => {
            let bvh = motion_core::formats::bvh::read_bvh(rig)?;
            let mm = motion_core::grounding::find_body_parts(&bvh.skeleton)
                .ok()
                .and_then(|parts| motion_core::takes::guess_mm_per_unit(&parts))
                .ok_or_else(|| {
                    UsageError(format!(
                        "--rig {}: no legs of a person's length in any unit",
                        rig.display()
                    ))
                })?;
            let skeleton = motion_core::seed::rescale_bvh(&bvh, mm)
                .map_err(|e| UsageError(format!("--rig {}: {e}", rig.display())))?
                .skeleton;
            RigTarget::from_skeleton(&skeleton, map.as_deref(), source)
                .map_err(|e| UsageError(format!("--rig {}: {e}", rig.display())))?
        }
        _ => {
            return Err(UsageError(format!(
                "--rig {}: a character is read from .glb, .gltf or .bvh",
                rig.display()
            ))
            .into())
        }
    };
    Ok(Some(target))
}

/// `job.samples` predictions of `job.frames` frames each: `[samples, frames, frame_dims]`.
fn generate(job: &Job, action: Option<&str>, seed: &Array2<f64>) -> anyhow::Result<Array3<f64>> {
    generate_samples(
        &job.model,
        seed.view(),
        action,
        job.frames,
        job.samples,
        job.rng_seed,
    )
    .map_err(|e| match e {
        e @ (GenerateError::TooFewSeedFrames { .. }
        | GenerateError::WrongWidth { .. }
        | GenerateError::NonFiniteSeed { .. }
        | GenerateError::UnknownAction { .. }
        | GenerateError::MissingAction { .. }) => UsageError(format!("seed: {e}")).into(),
        e => anyhow::Error::from(e),
    })
}

/// Output names `DIR/<stem>.<ext>`; two seeds with one stem (`a.bvh`, `a.npy`) keep their
/// extension in the name (`a_bvh.<ext>`, `a_npy.<ext>`) so that neither overwrites the other.
fn output_names(files: &[PathBuf], out_dir: &Path, ext: &str) -> Vec<PathBuf> {
    let split = |p: &PathBuf| {
        let name = p
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let lower = name.to_ascii_lowercase();
        let cut = if lower.ends_with(".txt.gz") {
            name.len() - 7
        } else {
            name.rfind('.').unwrap_or(name.len())
        };
        (
            name[..cut].to_string(),
            name[cut..].trim_start_matches('.').replace('.', "_"),
        )
    };
    let stems: Vec<(String, String)> = files.iter().map(split).collect();
    // Names still equal after that (`a.npy` and `a_npy.bvh` both give `a_npy`), compared without
    // case (case-insensitive file systems), get `_2`, `_3`, ... in file order: one output per seed.
    let mut taken: std::collections::HashSet<String> = std::collections::HashSet::new();
    stems
        .iter()
        .map(|(stem, in_ext)| {
            let shared = stems.iter().filter(|(s, _)| s == stem).count() > 1;
            let base = if shared {
                format!("{stem}_{in_ext}")
            } else {
                stem.clone()
            };
            let mut name = format!("{base}.{ext}");
            let mut k = 2;
            while !taken.insert(name.to_lowercase()) {
                name = format!("{base}_{k}.{ext}");
                k += 1;
            }
            out_dir.join(name)
        })
        .collect()
}

/// Batch mode: every seed of a directory, in parallel, with a progress bar and a summary.
fn run_batch(args: &Args, job: &Job) -> anyhow::Result<()> {
    let files = motion_core::file_sets::motion_files_in(&args.seed)?;
    if files.is_empty() {
        return Err(UsageError(format!(
            "{}: no .bvh, .txt, .txt.gz or .npy files in this directory",
            args.seed.display()
        ))
        .into());
    }
    if let (Ok(a), Ok(b)) = (args.seed.canonicalize(), args.out.canonicalize()) {
        if a == b {
            return Err(UsageError(format!(
                "{}: --out must be another directory than the seeds'",
                args.out.display()
            ))
            .into());
        }
    }
    let outputs = output_names(&files, &args.out, &args.format);
    let bar = args.reporting.progress_bar(
        files.len() as u64,
        "{bar:40} {pos}/{len} seeds {elapsed} {msg}",
    );
    let results: Vec<anyhow::Result<Done>> = files
        .par_iter()
        .zip(&outputs)
        .map(|(seed, out)| {
            let result = predict_one(job, seed, out, None);
            bar.inc(1);
            result
        })
        .collect();
    bar.finish_and_clear();

    let failed = results.iter().filter(|r| r.is_err()).count();
    let mut entries: Vec<Value> = Vec::with_capacity(files.len());
    for (seed, result) in files.iter().zip(&results) {
        match result {
            Ok(done) => {
                done.notices.iter().for_each(|n| args.reporting.notice(n));
                entries.push(json!({
                    "seed": seed,
                    "outputs": done.outputs,
                    "action": done.action,
                    "action_inferred": done.inferred,
                    "seed_floor": floor_json(done.floor.as_ref()),
                }));
            }
            Err(err) => {
                let message = super::error_chain(err);
                if !args.reporting.json {
                    eprintln!("failed: {message}");
                }
                entries.push(json!({"seed": seed, "error": message}));
            }
        }
    }
    let succeeded = files.len() - failed;
    if args.reporting.json {
        let report = json!({
            "model": describe(args.model.as_deref(), BuiltIn::Game),
            "action": if job.infer.is_some() { Value::Null } else { json!(job.action) },
            "action_inferred": job.infer.is_some(),
            "fps": job.model.config().fps,
            "predicted_frames": job.frames,
            "samples": job.samples,
            "rng_seed": job.rng_seed,
            "succeeded": succeeded,
            "failed": failed,
            "seeds": entries,
        });
        args.reporting.print_json(&report)?;
    } else {
        args.reporting.notice(format_args!(
            "predicted {succeeded} of {} seeds into {} ({failed} failed)",
            files.len(),
            args.out.display()
        ));
    }
    if failed > 0 {
        return Err(UsageError(format!(
            "{failed} of {} seeds in {} failed",
            files.len(),
            args.seed.display()
        ))
        .into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_names_avoid_collisions() {
        let files = [
            PathBuf::from("s/a.bvh"),
            PathBuf::from("s/a.npy"),
            PathBuf::from("s/b.txt.gz"),
        ];
        let names = output_names(&files, Path::new("o"), "bvh");
        assert_eq!(
            names,
            [
                PathBuf::from("o/a_bvh.bvh"),
                PathBuf::from("o/a_npy.bvh"),
                PathBuf::from("o/b.bvh")
            ]
        );
        // `a.npy` and `a_npy.bvh` would both be `a_npy`: the second is numbered.
        let files = [
            PathBuf::from("s/a.bvh"),
            PathBuf::from("s/a.npy"),
            PathBuf::from("s/a_npy.bvh"),
        ];
        let names = output_names(&files, Path::new("o"), "bvh");
        assert_eq!(
            names,
            [
                PathBuf::from("o/a_bvh.bvh"),
                PathBuf::from("o/a_npy.bvh"),
                PathBuf::from("o/a_npy_2.bvh")
            ]
        );
    }
}
