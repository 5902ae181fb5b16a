//! Steering responsiveness (`motion_metrics::responsiveness`) of the shipped models, steered by
//! root-motion warping (`Character::set_goal`, `motion_core::steering`) or, for the `goal-gru`
//! model, by the control it reads (`motion_core::model::goal_gru`), beside a motion-matching
//! baseline (`motion_core::matching`) built from the same training data: every frame of the
//! H3.6M training subjects' (S1, S6, S7, S8, S9, S11) walking, walkingdog and walkingtogether takes
//! at 25 Hz. Body speed is against real S5 walking (the test subject); NDMS (Tanke et al. 2021)
//! against the motion words of the same training takes (their poses decoded as the engine
//! decodes a model's, positions in metres, words in the body frame), beside real S5 walking's own.
//!
//! ```text
//! cargo run --release --example steering_compare -- [DATA_ROOT] [--json OUT.json]
//! ```
//! `DATA_ROOT` holds `h3.6m/dataset` (default: `$MOTION_DATA_DIR`, then `../shared/data`). The
//! models start from `examples/walk_seed.bvh` with the action `walking` and noise seed 3, as
//! `tests/steering.rs` does; the matcher starts on the first frame of S1's first walking take.
//! Prints a table (times in seconds, `-` where the target was not reached within 4 s).
use std::error::Error;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::matching::{Matcher, MatchingDatabase};
use motion_core::model::{Character, MotionModel, Noise};
use motion_core::pose::PoseDecoder;
use motion_core::protocol::{dataset_dir, load_subject_sequences};
use motion_core::root::RootEncoding;
use motion_core::seed::load_seed;
use motion_core::skeleton::Skeleton;
use motion_core::steering::Steering;
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod};
use motion_metrics::responsiveness::{
    body_speed, measure, positions_of, RealMotion, ResponsivenessReport,
};

type BoxError = Box<dyn Error + Send + Sync>;

const TRAINING_SUBJECTS: [&str; 6] = ["S1", "S6", "S7", "S8", "S9", "S11"];
const LOCOMOTION: [&str; 3] = ["walking", "walkingdog", "walkingtogether"];

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let json = args
        .iter()
        .position(|a| a == "--json")
        .and_then(|i| args.get(i + 1).cloned());
    let root = args
        .iter()
        .find(|a| !a.starts_with("--") && Some(*a) != json.as_ref())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("MOTION_DATA_DIR").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("../shared/data"));
    let dataset = dataset_dir(&root);
    if !dataset.is_dir() {
        return Err(format!("no H3.6M dataset under {}", root.display()).into());
    }
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));

    let mut clips = Vec::new();
    for subject in TRAINING_SUBJECTS {
        for action in LOCOMOTION {
            clips.extend(load_subject_sequences(&dataset, subject, action)?);
        }
    }
    let views: Vec<_> = clips.iter().map(|c| c.view()).collect();
    let built = Instant::now();
    let database = Arc::new(MatchingDatabase::h36m(&views)?);
    println!(
        "motion-matching database: {} takes, {} frames ({} searchable), {:.1} MB, built in {:.1} s",
        clips.len(),
        database.frames(),
        database.searchable_frames(),
        database.bytes() as f64 / 1e6,
        built.elapsed().as_secs_f64()
    );
    let real_speed = real_walking_body_speed(&dataset)?;
    println!("real S5 walking body speed: {real_speed:.3} m/s");
    let built = Instant::now();
    let training: Vec<_> = clips.iter().map(|c| positions_of_clip(c.view())).collect();
    let views: Vec<_> = training.iter().map(|p| p.view()).collect();
    let words =
        NdmsDatabase::from_sequences(NdmsConfig::h36m_body_frame(), &views, NnMethod::default())?;
    let s5: Vec<_> = load_subject_sequences(&dataset, "S5", "walking")?
        .iter()
        .map(|c| positions_of_clip(c.view()))
        .collect();
    let real_ndms: Vec<f64> = s5
        .iter()
        .map(|p| words.score_forecasts(&[p.view()], None).map(|r| r.mean))
        .collect::<Result<_, _>>()?;
    println!(
        "NDMS database: {} words of the same takes, built in {:.1} s; real S5 walking's NDMS against it: {:.3}\n",
        words.len(),
        built.elapsed().as_secs_f64(),
        real_ndms.iter().sum::<f64>() / real_ndms.len().max(1) as f64
    );
    let real = RealMotion {
        body_speed: real_speed,
        ndms: Some(&words),
    };

    let mut reports = Vec::new();
    for (file, how) in [
        ("vgru_d_multi", "warping"),
        ("intention_actions", "warping"),
        ("goal_gru_h36m", "control"),
    ] {
        let path = repo.join(format!("weights/{file}.safetensors"));
        if !path.exists() {
            println!("{} not found: its row is left out", path.display());
            continue;
        }
        let bytes = std::fs::metadata(&path)?.len() as usize;
        let model = Arc::new(MotionModel::load(&path)?);
        let seed = load_seed(
            &repo.join("examples/walk_seed.bvh"),
            ExpMapTarget::H36m,
            model.config().fps,
            50.0,
            None,
        )?;
        let make = || -> Result<Character, BoxError> {
            let mut character = Character::new(model.clone())?;
            character.start_from_clip(seed.frames.view(), Some("walking"), Noise::Seed(3))?;
            Ok(character)
        };
        reports.push(measure(&format!("{file} ({how})"), make, real, bytes)?);
    }
    let make = || -> Result<Matcher, BoxError> { Ok(Matcher::new(database.clone())) };
    reports.push(measure("motion matching", make, real, database.bytes())?);
    print_table(&reports);
    if let Some(out) = json {
        std::fs::write(&out, serde_json::to_string_pretty(&reports)?)?;
        println!("\nwrote {out}");
    }
    Ok(())
}

/// World positions (metres) of a 25 Hz H3.6M take decoded into engine poses.
fn positions_of_clip(take: ndarray::ArrayView2<'_, f64>) -> ndarray::Array3<f64> {
    let skeleton = Arc::new(Skeleton::h36m());
    let poses = PoseDecoder::new(skeleton.clone(), RootEncoding::Deltas, 2).decode_all(take);
    positions_of(&skeleton, &poses)
}

/// Body speed of real S5 walking (both takes, 25 Hz).
fn real_walking_body_speed(dataset: &Path) -> Result<f64, BoxError> {
    let skeleton = Arc::new(Skeleton::h36m());
    let steering = Steering::new(&skeleton, 0.04)?;
    let mut speeds = Vec::new();
    for take in load_subject_sequences(dataset, "S5", "walking")? {
        let poses =
            PoseDecoder::new(skeleton.clone(), RootEncoding::Deltas, 2).decode_all(take.view());
        speeds.push(body_speed(&skeleton, &poses, |p| steering.heading_of(p)));
    }
    if speeds.is_empty() {
        return Err("no S5 walking take".into());
    }
    Ok(speeds.iter().sum::<f64>() / speeds.len() as f64)
}

fn print_table(reports: &[ResponsivenessReport]) {
    let t = |v: Option<f64>| v.map_or("-".to_string(), |s| format!("{s:.2}"));
    println!(
        "| controller | own speed m/s | turn 90: heading / speed s | turn 180: heading / speed s | stop: speed s | speed up: speed s | speed 2-4 s after: turn 90 / 180 / stop / speed up, m/s | skating turn 90 / 180 / stop / speed up | body speed / real | NDMS | us per frame | memory MB |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in reports {
        let s = &r.scenarios;
        println!(
            "| {} | {:.2} | {} / {} | {} / {} | {} | {} | {:.2} / {:.2} / {:.2} / {:.2} | {:.2} / {:.2} / {:.2} / {:.2} | {:.2} | {} | {:.0} | {:.2} |",
            r.controller,
            r.warm_up_speed_m_s,
            t(s[0].heading_s),
            t(s[0].speed_s),
            t(s[1].heading_s),
            t(s[1].speed_s),
            t(s[2].speed_s),
            t(s[3].speed_s),
            s[0].late_speed_m_s,
            s[1].late_speed_m_s,
            s[2].late_speed_m_s,
            s[3].late_speed_m_s,
            s[0].skating,
            s[1].skating,
            s[2].skating,
            s[3].skating,
            r.body_speed_ratio,
            r.ndms.map_or("-".to_string(), |v| format!("{v:.3}")),
            r.us_per_frame,
            r.memory_bytes as f64 / 1e6,
        );
    }
}
