//! `predict` frame by frame through a steerable character: a motion-matching database
//! (`--model DB.safetensors`, `motion_core::matching::Matcher`) with or without `--path`, and a
//! learned model along a `--path` (`motion_core::model::Character`). The goal in force comes
//! from `motion_core::steering::path::PathFollower` every frame; the rules live in motion-core,
//! this module parses, loops and writes.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use motion_core::clip::{check_not_an_input, check_output};
use motion_core::formats::bvh::{read_bvh, write_bvh, Bvh};
use motion_core::formats::pose_bvh::poses_to_bvh;
use motion_core::formats::FileFormat;
use motion_core::grounding::GroundingConfig;
use motion_core::limits::check_clip;
use motion_core::matching::Matcher;
use motion_core::model::{Character, MotionSource, Noise, WeightStore};
use motion_core::pose::{Pose, PoseDecoder};
use motion_core::resample::{resample_bvh, resampled_len};
use motion_core::root::RootEncoding;
use motion_core::skeleton::{Skeleton, H36M_SOURCE_FPS};
use motion_core::steering::path::{read_path, PathFollower, PathSpec};
use motion_core::steering::{Steerable, Vec2};
use motion_core::takes::{seed_poses_on_rig, unit_name};
use ndarray::s;
use serde_json::{json, Value};

use super::{Args, Job, UsageError};

/// Seconds generated when neither `--frames`, `--seconds` nor the path says how long.
pub const DEFAULT_STEERED_SECONDS: f64 = 10.0;
/// The longest `--seconds` asked for (a day).
const MAX_SECONDS: f64 = 86_400.0;

/// Whether `--model` names a source that plays on a rig: a motion-matching database, or a
/// learned model whose file holds its rig (`skeleton: "rig"`). An unreadable file is left to
/// the learned-model loader, which names the problem.
pub(super) fn open_rig_source(model: Option<&Path>) -> Option<WeightStore> {
    let store = WeightStore::open(model?).ok()?;
    let rig_model = store.metadata("config").is_some_and(|config| {
        serde_json::from_str::<Value>(config)
            .ok()
            .and_then(|c| c.get("skeleton").and_then(Value::as_str).map(str::to_owned))
            .is_some_and(|name| name == motion_core::model::config::RIG_SKELETON)
    });
    (motion_core::matching::is_database(&store) || rig_model).then_some(store)
}

/// `--seconds`, checked.
pub(super) fn check_seconds(seconds: Option<f64>) -> anyhow::Result<()> {
    match seconds {
        Some(s) if !(s.is_finite() && s > 0.0 && s <= MAX_SECONDS) => Err(UsageError(format!(
            "--seconds {s}: give a duration above 0 and at most {MAX_SECONDS} s"
        ))
        .into()),
        _ => Ok(()),
    }
}

/// Frames to make at `fps`: `--frames`, `--seconds`, the path's own duration
/// ([`PathSpec::suggested_seconds`] from `start`), or `fallback_s` seconds.
fn frames_to_make(
    args: &Args,
    fps: f64,
    path: Option<&PathSpec>,
    start: Vec2,
    fallback_s: f64,
) -> usize {
    if let Some(n) = args.frames {
        return n;
    }
    let seconds = args
        .seconds
        .or_else(|| path.and_then(|p| p.suggested_seconds(start)))
        .unwrap_or(fallback_s);
    ((seconds * fps).round() as usize).max(1)
}

/// The checks of a steered prediction's arguments: one seed file, one BVH output that is no
/// input, one sample, no `--truth`.
fn check_steered_args(args: &Args, what: &str) -> anyhow::Result<()> {
    if args.seed.is_dir() {
        return Err(UsageError(format!(
            "{}: {what} predicts from one seed file, not a directory",
            args.seed.display()
        ))
        .into());
    }
    if !args.seed.exists() {
        return Err(UsageError(format!("{}: no such file", args.seed.display())).into());
    }
    if check_output(&args.out)? != FileFormat::Bvh {
        return Err(UsageError(format!(
            "{}: {what} writes poses as BVH: give an --out ending in .bvh",
            args.out.display()
        ))
        .into());
    }
    let inputs: Vec<&Path> = [
        Some(&args.seed),
        args.model.as_ref(),
        args.joint_map.as_ref(),
        args.classifier.as_ref(),
        args.path.as_ref(),
    ]
    .into_iter()
    .flatten()
    .map(PathBuf::as_path)
    .collect();
    check_not_an_input(&args.out, &inputs)?;
    if args.samples != 1 {
        return Err(UsageError(format!(
            "--samples {}: {what} makes one motion (steered frame by frame)",
            args.samples
        ))
        .into());
    }
    if args.truth.is_some() {
        return Err(UsageError(format!("--truth: not with {what}")).into());
    }
    if let Some(fps) = args.fps {
        motion_core::motion::check_fps(fps)
            .map_err(|problem| UsageError(format!("--fps: {problem}")))?;
    }
    Ok(())
}

/// The path file of `--path`, read.
fn path_of(args: &Args) -> anyhow::Result<Option<PathSpec>> {
    Ok(args.path.as_deref().map(read_path).transpose()?)
}

/// Steps `character` `frames` times at `fps` from `start`, its goal from `follower` (when one
/// is given) every frame: seconds after the seed's last frame, its ground position and heading.
fn follow<S: Steerable>(
    character: &mut S,
    start: &Pose,
    mut follower: Option<&mut PathFollower>,
    frames: usize,
    fps: f64,
) -> anyhow::Result<Vec<Pose>> {
    let dt = 1.0 / fps;
    let mut poses = Vec::with_capacity(frames);
    let ground = |p: &Pose| Vec2::new(p.root_translation.x, p.root_translation.z);
    let mut here = ground(start);
    let mut heading = character.heading_of(start);
    for k in 0..frames {
        if let Some(follower) = follower.as_deref_mut() {
            character.set_goal(follower.goal(k as f64 * dt, here, heading));
        }
        let pose = character
            .advance(dt)
            .map_err(|e| anyhow::Error::new(e).context(format!("frame {k}")))?
            .clone();
        here = ground(&pose);
        heading = character.heading_of(&pose);
        poses.push(pose);
    }
    Ok(poses)
}

/// What a steered prediction wrote, for the report.
struct Written {
    seed_frames: usize,
    frames: usize,
    fps: f64,
    start: Vec2,
    heading: f32,
    rig: String,
    path: Option<(PathSpec, PathFollower)>,
    notices: Vec<String>,
}

/// The BVH of `poses` on `skeleton` (millimetres) at `fps`, End Sites included. [`poses_to_bvh`]
/// asks every joint for rotation channels and End Sites have none, so the frames are made on the
/// skeleton without them (the same channel columns) and the End Sites put back in the hierarchy.
fn bvh_of_poses(skeleton: &Skeleton, poses: &[Pose], fps: f64) -> anyhow::Result<Bvh> {
    let joints = skeleton.joints();
    if !joints.iter().any(|j| j.is_end_site) {
        return Ok(poses_to_bvh(skeleton, poses, fps)?);
    }
    let kept: Vec<usize> = (0..joints.len())
        .filter(|&j| !joints[j].is_end_site)
        .collect();
    let mut index = vec![0; joints.len()];
    for (k, &j) in kept.iter().enumerate() {
        index[j] = k;
    }
    let stripped = Skeleton::new(
        kept.iter()
            .map(|&j| {
                let mut joint = joints[j].clone();
                joint.parent = joint.parent.map(|p| index[p]);
                joint
            })
            .collect(),
    )?;
    let poses: Vec<Pose> = poses
        .iter()
        .map(|p| {
            let mut pose = p.clone();
            pose.local_rotations = kept.iter().map(|&j| p.local_rotations[j]).collect();
            pose
        })
        .collect();
    let bvh = poses_to_bvh(&stripped, &poses, fps)?;
    Ok(Bvh {
        skeleton: skeleton.clone(),
        frames: bvh.frames,
        frame_time: bvh.frame_time,
    })
}

/// `bvh` resampled to `--fps` when asked, then written to `--out` (atomically).
fn write_output(args: &Args, bvh: &Bvh) -> anyhow::Result<()> {
    let bvh = match args.fps {
        Some(fps) => resample_bvh(bvh, fps).map_err(|e| UsageError(format!("--fps {fps}: {e}")))?,
        None => bvh.clone(),
    };
    write_bvh(&args.out, &bvh)?;
    Ok(())
}

/// Prints what was written (text or `--json`).
fn report(args: &Args, model: &str, kind: &str, done: &Written) -> anyhow::Result<()> {
    let path = done.path.as_ref().map(|(spec, follower)| {
        json!({
            "file": args.path,
            "kind": spec.kind(),
            "entries": spec.len(),
            "waypoints_reached": follower.next_waypoint(),
        })
    });
    let written_seed = if args.prediction_only {
        0
    } else {
        done.seed_frames
    };
    if args.reporting.json {
        let report = json!({
            "model": model,
            "kind": kind,
            "seed": args.seed,
            "seed_frames": written_seed,
            "predicted_frames": done.frames,
            "fps": done.fps,
            "output_fps": args.fps.unwrap_or(done.fps),
            "rig": done.rig,
            "seed_end": {"x": done.start.x, "z": done.start.y, "heading": done.heading},
            "path": path.unwrap_or(Value::Null),
            "outputs": [&args.out],
            "notices": done.notices,
        });
        args.reporting.print_json(&report)?;
        return Ok(());
    }
    done.notices.iter().for_each(|n| args.reporting.notice(n));
    args.reporting.notice(format_args!(
        "the seed ends at x {:.2} m, z {:.2} m, heading {:.2} rad (the path's coordinates)",
        done.start.x, done.start.y, done.heading
    ));
    if let Some((spec, follower)) = &done.path {
        if let (PathSpec::Waypoints { looping: false, .. }, Some(reached)) =
            (spec, follower.next_waypoint())
        {
            args.reporting.notice(format_args!(
                "waypoints reached: {reached} of {}",
                spec.len()
            ));
        }
    }
    args.reporting.notice(format_args!(
        "wrote {} ({written_seed} seed + {} predicted frames at {} Hz{}, {})",
        args.out.display(),
        done.frames,
        done.fps,
        args.fps
            .map(|f| format!(", written at {f} Hz"))
            .unwrap_or_default(),
        done.rig
    ));
    Ok(())
}

/// `predict --model FILE` of a source on a rig (a motion-matching database, or a learned model
/// that holds its rig): the seed BVH (any rig) onto that rig, played on by a [`Matcher`] or a
/// [`Character`] (along `--path` when given), written as BVH on the rig in its units.
pub(super) fn run_rig_source(args: &Args, store: &WeightStore) -> anyhow::Result<()> {
    let source = MotionSource::from_store(store)?;
    let database = source.database().cloned();
    let what = if database.is_some() {
        "a motion-matching database"
    } else {
        "a model on a rig"
    };
    check_steered_args(args, what)?;
    if FileFormat::from_path(&args.seed)? != FileFormat::Bvh {
        return Err(UsageError(format!(
            "{}: {what} starts from a BVH take (on any rig), not exp-map frames",
            args.seed.display()
        ))
        .into());
    }
    if database.is_some() && (args.action.is_some() || args.classifier.is_some()) {
        return Err(UsageError(format!(
            "--action/--classifier: {what} has no actions; it plays its takes where --path steers"
        ))
        .into());
    }
    let skeleton = source.skeleton();
    let mm_per_unit = source.rig_mm_per_unit();
    let path = path_of(args)?;
    let fps = source.fps();
    let bvh = read_bvh(&args.seed)?;
    let channels = skeleton.channel_count();
    check_clip(
        resampled_len(bvh.frames.nrows(), bvh.fps(), fps),
        channels.max(bvh.skeleton.channel_count()),
        "give a shorter seed",
    )
    .map_err(|e| UsageError(format!("{}: {e}", args.seed.display())))?;
    let mut seed = seed_poses_on_rig(bvh, &skeleton, mm_per_unit, fps, args.joint_map.as_deref())
        .map_err(|problem| UsageError(format!("{}: {problem}", args.seed.display())))?;
    if let Some(end) = args.seed_end {
        if end == 0 || end > seed.len() {
            return Err(UsageError(format!(
                "{}: --seed-end {end} is not within the seed's {} frames at {fps} Hz",
                args.seed.display(),
                seed.len()
            ))
            .into());
        }
        seed.truncate(end);
    }
    let grounding = if args.no_grounding {
        GroundingConfig::off()
    } else {
        GroundingConfig::default()
    };
    let last = seed.last().expect("a seed has frames").clone();
    let start = Vec2::new(last.root_translation.x, last.root_translation.z);
    let mut follower = path.as_ref().map(PathFollower::new);
    let frames = frames_to_make(args, fps, path.as_ref(), start, DEFAULT_STEERED_SECONDS);
    check_clip(
        seed.len() + frames,
        channels,
        "ask for fewer --frames or --seconds",
    )
    .map_err(|e| UsageError(format!("--frames/--seconds: {e}")))?;
    let (heading, poses) = match database {
        Some(db) => {
            let mut matcher = Matcher::with_grounding(db, grounding);
            let heading = matcher.heading_of(&last);
            if let Some(follower) = &mut follower {
                matcher.set_goal(follower.goal(0.0, start, heading));
            }
            let first = matcher
                .start(&seed)
                .with_context(|| format!("{}", args.seed.display()))?
                .clone();
            (
                heading,
                follow(&mut matcher, &first, follower.as_mut(), frames, fps)?,
            )
        }
        None => {
            let mut character = Character::with_grounding(source.clone(), grounding)?;
            let heading = character.heading_of(&last);
            if let Some(follower) = &mut follower {
                character.set_goal(follower.goal(0.0, start, heading));
            }
            let first = character
                .start_poses_with(&seed, args.action.as_deref(), Noise::Seed(args.rng_seed))
                .with_context(|| format!("{}", args.seed.display()))?
                .clone();
            (
                heading,
                follow(&mut character, &first, follower.as_mut(), frames, fps)?,
            )
        }
    };
    let from = if args.prediction_only { seed.len() } else { 0 };
    let all: Vec<Pose> = seed.into_iter().chain(poses).skip(from).collect();
    let mm =
        bvh_of_poses(&skeleton, &all, fps).with_context(|| format!("{}", args.out.display()))?;
    let on_rig =
        motion_core::seed::rescale_bvh(&mm, 1.0 / mm_per_unit).map_err(anyhow::Error::msg)?;
    write_output(args, &on_rig)?;
    let done = Written {
        seed_frames: all.len() - frames,
        frames,
        fps,
        start,
        heading,
        rig: format!(
            "the {} rig: {} joints, root {}, {}",
            if source.database().is_some() {
                "database's"
            } else {
                "model's"
            },
            skeleton.body_joint_names().len(),
            skeleton.joint(0).name,
            unit_name(mm_per_unit)
        ),
        path: path.zip(follower),
        notices: Vec::new(),
    };
    report(
        args,
        &args
            .model
            .as_deref()
            .unwrap_or(Path::new(""))
            .display()
            .to_string(),
        if source.database().is_some() {
            "motion-matching"
        } else {
            "learned"
        },
        &done,
    )
}

/// `predict --path` with a learned model: a [`Character`] seeded with the seed window, its goal
/// from the path every frame; the seed window and the prediction written as BVH (on the seed's
/// own rig when it came from one).
pub(super) fn run_model_path(args: &Args, job: &Job, model_name: &str) -> anyhow::Result<()> {
    let what = "--path";
    check_steered_args(args, what)?;
    let path = path_of(args)?.expect("--path given");
    let config = job.model.config();
    let fps = config.fps;
    let seed = motion_core::seed::load_seed(
        &args.seed,
        job.target,
        fps,
        job.input_fps,
        job.joint_map.as_deref(),
    )?;
    let needed = config.seed_frames.max(1);
    let total = seed.frames.nrows();
    let end = job.seed_end.unwrap_or(total);
    if end > total || end < needed {
        return Err(UsageError(format!(
            "{}: the seed window ends at frame {end} of {total} (at {fps} Hz); the model needs {needed} frames before it",
            args.seed.display()
        ))
        .into());
    }
    let window = motion_core::seed::model_window(&seed.frames, end - needed, end, job.target);
    let (action, inferred, action_notice) = super::resolve_action(job, &window, &args.seed)?;
    let mut character = Character::with_grounding(job.model.clone(), job.grounding)?;
    let first = character
        .start(window.view(), action.as_deref(), Noise::Seed(job.rng_seed))
        .with_context(|| format!("{}", args.seed.display()))?
        .clone();
    // The seed window's poses as the character placed them: decoded as its stream decodes
    // them, moved into the grounding's floor frame.
    let step = ((H36M_SOURCE_FPS / fps).round() as usize).max(1);
    let mut decoder = PoseDecoder::new(character.skeleton().clone(), RootEncoding::Deltas, step);
    let mut grounder = character.grounder().clone();
    let mut seed_poses = decoder.decode_all(window.view());
    for pose in &mut seed_poses {
        grounder.level(&mut pose.root_translation, &mut pose.local_rotations[0]);
    }
    let start = Vec2::new(first.root_translation.x, first.root_translation.z);
    let heading = character.heading_of(&first);
    let mut follower = PathFollower::new(&path);
    let frames = frames_to_make(args, fps, Some(&path), start, DEFAULT_STEERED_SECONDS);
    let skeleton: Arc<Skeleton> = character.skeleton().clone();
    let width = skeleton
        .channel_count()
        .max(seed.rig.as_ref().map_or(0, |r| r.frames.ncols()));
    check_clip(
        needed + frames,
        width,
        "ask for fewer --frames or --seconds",
    )
    .map_err(|e| UsageError(format!("--frames/--seconds: {e}")))?;
    let poses = follow(&mut character, &first, Some(&mut follower), frames, fps)?;
    let from = if args.prediction_only { needed } else { 0 };
    let all: Vec<Pose> = seed_poses.into_iter().chain(poses).skip(from).collect();
    let h36m =
        bvh_of_poses(&skeleton, &all, fps).with_context(|| format!("{}", args.out.display()))?;
    let (bvh, rig) = match &seed.rig {
        Some(rig) => {
            let references = rig.frames.slice(s![(end - needed).min(end - 1)..end, ..]);
            (
                rig.retargeter.to_rig(&h36m, references),
                "the seed's own rig".to_string(),
            )
        }
        None => (h36m, "the H3.6M skeleton (millimetres)".to_string()),
    };
    write_output(args, &bvh)?;
    let _ = inferred;
    let mut notices = seed.notices;
    notices.extend(action_notice);
    let done = Written {
        seed_frames: needed,
        frames,
        fps,
        start,
        heading,
        rig,
        path: Some((path, follower)),
        notices,
    };
    report(args, model_name, "learned", &done)
}
