//! Motion matching on CMU takes beside the learned H3.6M models (issue 57, "Measured side by
//! side"): a motion-matching database built from `../shared/data/cmu_locomotion` minus six held-out
//! **test takes** (16_16, 16_18, 16_24, 16_30, 16_38, 16_43), played on the takes' own rig
//! (`Character` over `MotionSource::Database`), against `intention_actions` (the game default,
//! action walking) and `vgru_d_multi` (walking) steered by root-motion warping, and
//! `goal_gru_h36m` steered by its control, all seeded from the test takes retargeted onto H3.6M.
//!
//! ```text
//! cargo run --release --example matching_compare -- [--takes DIR] [--db FILE] [--rig-model FILE] [--json OUT.json]
//! ```
//! `--rig-model` (default `weights/goal_gru_cmu.safetensors`) is a learned model on the CMU rig
//! (`training/locomotion.py --takes`, trained without the test takes), seeded with the test
//! take's poses and steered by its control like `goal_gru_h36m`, measured on the CMU rig.
//! `--takes` defaults to `$MOTION_DATA_DIR/cmu_locomotion`, then `../shared/data/cmu_locomotion`.
//! Without `--db` the database is built here from the takes (rig `16_15.bvh`, 30 Hz,
//! `DEFAULT_WEIGHTS`) minus the test takes; with `--db FILE` (e.g.
//! `weights/matching_cmu.safetensors`) it is loaded, and must not hold a test take.
//!
//! Every controller is advanced at 30 Hz (`Character::advance(1/30)`; the models make 25 Hz
//! frames, resampled). What is measured (the database on the CMU rig against the test takes on
//! the CMU rig; the models on H3.6M against the test takes retargeted onto H3.6M, 30 Hz, floor
//! at the median lowest foot point):
//!
//! - **Seeds**: a test take's first second (frames 0..=30 at 30 Hz; 0..=25 of its 25 Hz exp-map
//!   retarget for a model, whose training seed is 50 frames: shorter seeds are accepted).
//! - **NDMS**: 8-frame motion words (Tanke et al. 2021, body frame: `NdmsConfig::h36m_body_frame`
//!   and its joints found on the CMU rig through the built-in joint map) of everything a
//!   controller made in the four responsiveness runs and the six replays (words inside the
//!   generated frames only, averaged over words), against a database of every word of the six
//!   real test takes on the same rig. Real-vs-real: every word of the training takes (the
//!   database's takes) scored against the same test-take database.
//! - **Skating**: the plausibility definition (`motion_metrics::plausibility`: a frame skates
//!   when a foot point under 50 mm moves faster than 500 mm/s horizontally, against the
//!   previous frame), foot points from `grounding::find_body_parts`, at 30 Hz, over the same
//!   generated frames; for real motion over every frame of the six test takes.
//! - **Responsiveness** (seed 16_16 for all): 2 s toward a walk at 1.2 m/s along the seed's
//!   smoothed facing, then a turn of 90 or 180 degrees at 1.2 m/s, a stop, or a speed-up to
//!   2.5 m/s, each from a fresh start, 4 s long: seconds until the pelvis heading is within 10
//!   degrees of the goal's facing, and until the ground speed over the last 1 s is within 10 %
//!   of the goal's (stop: under 0.12 m/s), each held 0.4 s (`responsiveness`'s constants; the
//!   1 s speed window makes up to 1 s of the speed time); `-`: not within 4 s.
//! - **Replay**: from each test take's first second, the take's own smoothed root path as
//!   timed goals, one per frame (velocity: the smoothed trajectory's central difference; facing:
//!   its smoothed heading), rotated into the controller's world by the seed's last frame (root
//!   position and pelvis heading); distance between generated and real root (x, z) over the
//!   rest of the take (mean and max over frames, max over takes), and the NDMS of each replay
//!   against that take's own words (mean over takes).
//! - **Square**: 60 s from 16_16's first second, looping 4 m square waypoints (radius 0.5 m) at
//!   1.2 m/s, first leg straight ahead: corners reached (ideal 18 in 60 s), the first loop's
//!   corner times minus the ideal (3.33 s a side), skating and NDMS (against the test takes).
//! - **Cost**: microseconds per `advance(1/30)` over the square's 1800 frames, in a one-thread
//!   rayon pool; bytes held (`MatchingDatabase::bytes()`, its file size; a model's
//!   parameters x 4, its file size).
use std::error::Error;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec2;
use ndarray::{s, Array2, Array3, ArrayView3};

use motion_core::formats::bvh::read_bvh;
use motion_core::formats::expmap_bvh::ExpMapTarget;
use motion_core::grounding::find_body_parts;
use motion_core::matching::features::GroundFrame;
use motion_core::matching::{MatchingDatabase, DEFAULT_WEIGHTS};
use motion_core::model::{Character, MotionModel, MotionSource, Noise};
use motion_core::pose::Pose;
use motion_core::retarget::JointMap;
use motion_core::seed::{load_seed, model_window};
use motion_core::skeleton::{Skeleton, H36M_LEFT_HIP, H36M_NDMS_JOINTS, H36M_RIGHT_HIP};
use motion_core::steering::{direction_of, wrap_angle, Goal, Steering, Waypoints};
use motion_core::takes::{read_takes, seed_poses_on_rig, smoothed_trajectory, TakeOptions};
use motion_metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod, WordFrame};
use motion_metrics::plausibility::{SKATING_HEIGHT_MM, SKATING_SPEED_MM_S};
use motion_metrics::posture::{PostureJoints, PostureReference};
use motion_metrics::responsiveness::{
    positions_of, Hold, HEADING_TOLERANCE_DEG, SPEED_TOLERANCE, SPEED_WINDOW_S,
};

type BoxError = Box<dyn Error + Send + Sync>;

/// The held-out takes (fixed before the database was built).
const TEST_TAKES: [&str; 6] = ["16_16", "16_18", "16_24", "16_30", "16_38", "16_43"];
/// The take every responsiveness run and the square start from.
const WALK_SEED: &str = "16_16";
/// The rig the database's takes go onto.
const RIG_TAKE: &str = "16_15.bvh";
/// The rate everything is advanced and measured at (Hz).
const FPS: f64 = 30.0;
const DT: f64 = 1.0 / FPS;
/// The seed's last frame at 30 Hz (the first second).
const SEED_END: usize = 30;
/// The seed's last frame at the models' 25 Hz.
const SEED_END_25: usize = 25;
/// The walk of the warm-up and of the turns (m/s).
const WALK_SPEED: f32 = 1.2;
/// The speed-up's goal (m/s).
const FAST_SPEED: f32 = 2.5;
const WARM_UP_FRAMES: usize = 60;
const SCENARIO_FRAMES: usize = 120;
const SQUARE_FRAMES: usize = 1800;
const SQUARE_SIDE: f32 = 4.0;
const SQUARE_RADIUS: f32 = 0.5;
/// The noise seed of the models.
const NOISE_SEED: u64 = 3;

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let json = value("--json");
    let db_file = value("--db").map(PathBuf::from);
    let dir = value("--takes")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("MOTION_DATA_DIR").map(|d| PathBuf::from(d).join("cmu_locomotion"))
        })
        .unwrap_or_else(|| PathBuf::from("../shared/data/cmu_locomotion"));
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));

    // Takes on the CMU rig; the test takes split off.
    let started = Instant::now();
    let options = TakeOptions {
        rig: Some(dir.join(RIG_TAKE)),
        ..TakeOptions::default()
    };
    let mut takes = read_takes(&dir, &options)?;
    for skipped in &takes.skipped {
        println!("skipped {}: {}", skipped.path.display(), skipped.reason);
    }
    let (test, training): (Vec<_>, Vec<_>) = takes
        .takes
        .drain(..)
        .partition(|t| TEST_TAKES.contains(&t.name.as_str()));
    if test.len() != TEST_TAKES.len() {
        return Err(format!(
            "found {} of the 6 test takes in {}",
            test.len(),
            dir.display()
        )
        .into());
    }
    takes.takes = training;
    let (database, db_file_bytes, db_how) = match &db_file {
        Some(file) => {
            let db = MatchingDatabase::load(file)?;
            let bytes = std::fs::metadata(file)?.len() as usize;
            if let Some(t) = db
                .takes()
                .iter()
                .find(|t| TEST_TAKES.contains(&t.name.as_str()))
            {
                return Err(format!("{} holds test take {}", file.display(), t.name).into());
            }
            (db, bytes, format!("loaded from {}", file.display()))
        }
        None => {
            let db = MatchingDatabase::from_takes(&takes, DEFAULT_WEIGHTS)?;
            let bytes = db.to_bytes()?.len();
            (db, bytes, "built here".to_string())
        }
    };
    let database = Arc::new(database);
    println!(
        "database ({db_how}): {} takes, {} frames ({} searchable) at {} Hz on the {} rig; {:.2} MB held, file {:.2} MB; takes read in {:.1} s",
        database.takes().len(),
        database.frames(),
        database.searchable_frames(),
        database.fps(),
        RIG_TAKE,
        database.bytes() as f64 / 1e6,
        db_file_bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );

    // The two rigs and the real takes on each.
    let cmu = RigKit::new("CMU", takes.rig.skeleton.clone())?;
    let h36m = RigKit::new("H3.6M", Arc::new(Skeleton::h36m()))?;
    let mut tests = Vec::new();
    for take in &test {
        let bvh = read_bvh(&take.path)?;
        let h36m_poses = seed_poses_on_rig(bvh, &h36m.skeleton, 1.0, FPS, None)
            .map_err(|e| format!("{} onto H3.6M: {e}", take.name))?;
        let seed25 = load_seed(&take.path, ExpMapTarget::H36m, 25.0, 50.0, None)
            .map_err(|e| format!("{} as a model seed: {e}", take.name))?;
        if take.name == WALK_SEED {
            for notice in &seed25.notices {
                println!("model seed {}: {notice}", take.name);
            }
        }
        let frames25 = seed25.frames;
        if frames25.nrows() <= SEED_END_25 || take.len() <= SEED_END + 8 {
            return Err(format!("test take {} is shorter than its seed", take.name).into());
        }
        tests.push(TestTake {
            name: take.name.clone(),
            cmu: RealTake::new(&cmu, take.poses.clone(), Some(take.trajectory.clone())),
            h36m: RealTake::new(&h36m, h36m_poses, None),
            frames25,
        });
    }
    let mut real_skating = Vec::new();
    for t in &tests {
        let skating = (
            fraction(cmu.skating(t.cmu.positions.view())),
            fraction(h36m.skating(t.h36m.positions.view())),
        );
        println!(
            "test take {}: {:.2} s; root path {:.2} m on the CMU rig, {:.2} m on H3.6M; skating {:.3} / {:.3}",
            t.name,
            t.cmu.poses.len() as f64 / FPS,
            path_length(&t.cmu.poses),
            path_length(&t.h36m.poses),
            skating.0,
            skating.1
        );
        real_skating.push(skating);
    }
    let walk = tests
        .iter()
        .position(|t| t.name == WALK_SEED)
        .expect("16_16 is a test take");

    // NDMS databases of the test takes' words, and real-vs-real.
    let cmu_words = cmu.words(tests.iter().map(|t| t.cmu.positions.view()))?;
    let h36m_words = h36m.words(tests.iter().map(|t| t.h36m.positions.view()))?;
    let train_cmu: Vec<_> = takes
        .takes
        .iter()
        .map(|t| positions_of(&cmu.skeleton, &t.poses))
        .collect();
    let real_cmu_ndms = ndms_of(&cmu_words, train_cmu.iter().map(|p| p.view()))?;
    let mut train_h36m = Vec::new();
    for take in &takes.takes {
        let poses = seed_poses_on_rig(read_bvh(&take.path)?, &h36m.skeleton, 1.0, FPS, None)
            .map_err(|e| format!("{} onto H3.6M: {e}", take.name))?;
        train_h36m.push(RealTake::new(&h36m, poses, None).positions);
    }
    let real_h36m_ndms = ndms_of(&h36m_words, train_h36m.iter().map(|p| p.view()))?;
    let real_cmu_skating = pooled_skating(&cmu, tests.iter().map(|t| t.cmu.positions.view()));
    let real_h36m_skating = pooled_skating(&h36m, tests.iter().map(|t| t.h36m.positions.view()));
    println!(
        "real: test-take words {} (CMU rig) / {} (H3.6M); training takes' NDMS against them {:.3} (CMU rig) / {:.3} (H3.6M); test takes' skating {:.3} / {:.3}\n",
        cmu_words.len(),
        h36m_words.len(),
        real_cmu_ndms,
        real_h36m_ndms,
        real_cmu_skating,
        real_h36m_skating
    );

    // Posture realism: references of the test takes' postures on each rig, and real-vs-real
    // (the training takes measured against them).
    let cmu_posture = PostureReference::from_takes(
        &PostureJoints::find(&cmu.skeleton)?,
        &tests
            .iter()
            .map(|t| t.cmu.positions.view())
            .collect::<Vec<_>>(),
    )?;
    let h36m_posture = PostureReference::from_takes(
        &PostureJoints::find(&h36m.skeleton)?,
        &tests
            .iter()
            .map(|t| t.h36m.positions.view())
            .collect::<Vec<_>>(),
    )?;
    let real_cmu_posture =
        cmu_posture.measure(&train_cmu.iter().map(|p| p.view()).collect::<Vec<_>>())?;
    let real_h36m_posture =
        h36m_posture.measure(&train_h36m.iter().map(|p| p.view()).collect::<Vec<_>>())?;

    // The controllers.
    let mut controllers = vec![Controller {
        label: "motion matching (CMU database)".into(),
        source: Source::Database(database.clone()),
        held_bytes: database.bytes(),
        file_bytes: db_file_bytes,
    }];
    for (file, action, how) in [
        ("intention_actions", Some("walking"), "warping"),
        ("vgru_d_multi", Some("walking"), "warping"),
        ("goal_gru_h36m", None, "control"),
    ] {
        let path = repo.join(format!("weights/{file}.safetensors"));
        if !path.exists() {
            println!("{} not found: its row is left out", path.display());
            continue;
        }
        let model = Arc::new(MotionModel::load(&path)?);
        controllers.push(Controller {
            label: format!("{file} ({how})"),
            held_bytes: model.parameter_count() * 4,
            file_bytes: std::fs::metadata(&path)?.len() as usize,
            source: Source::Model { model, action },
        });
    }

    let rig_model = repo.join("weights/goal_gru_cmu.safetensors");
    let rig_model = value("--rig-model").map(PathBuf::from).unwrap_or(rig_model);
    if rig_model.exists() {
        let model = Arc::new(MotionModel::load(&rig_model)?);
        if model.skeleton().len() != cmu.skeleton.len() {
            return Err(format!(
                "{}: its rig has {} joints, the CMU rig {}",
                rig_model.display(),
                model.skeleton().len(),
                cmu.skeleton.len()
            )
            .into());
        }
        controllers.push(Controller {
            label: format!(
                "{} (control)",
                rig_model.file_stem().unwrap_or_default().to_string_lossy()
            ),
            held_bytes: model.parameter_count() * 4,
            file_bytes: std::fs::metadata(&rig_model)?.len() as usize,
            source: Source::RigModel(model),
        });
    } else {
        println!("{} not found: its row is left out", rig_model.display());
    }

    let mut rows = Vec::new();
    for controller in &controllers {
        let t0 = Instant::now();
        let (rig, words) = match controller.source {
            Source::Database(_) | Source::RigModel(_) => (&cmu, &cmu_words),
            Source::Model { .. } => (&h36m, &h36m_words),
        };
        let real_of = |t| real_for(controller, t);
        let mut generated: Vec<Array3<f64>> = Vec::new();
        let mut scenarios = Vec::new();
        for scenario in Scenario::ALL {
            let (answer, positions) = respond(
                controller,
                rig,
                &tests[walk],
                real_of(&tests[walk]),
                scenario,
            )?;
            scenarios.push(answer);
            generated.push(positions);
        }
        let mut replays = Vec::new();
        for t in &tests {
            let real = real_of(t);
            let (mut replay, positions) = replay(controller, rig, t, real)?;
            let own = rig.words(std::iter::once(real.positions.view()))?;
            replay.ndms = ndms_of(&own, std::iter::once(positions.view()))?;
            replay.skating = fraction(rig.skating(positions.view()));
            replays.push(replay);
            generated.push(positions);
        }
        let ndms = ndms_of(words, generated.iter().map(|p| p.view()))?;
        let skating = pooled_skating(rig, generated.iter().map(|p| p.view()));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
        let (square, positions) =
            pool.install(|| square(controller, rig, &tests[walk], real_of(&tests[walk])))?;
        let square_ndms = ndms_of(words, std::iter::once(positions.view()))?;
        let (reference, real_posture) = if rig.name == "CMU" {
            (&cmu_posture, &real_cmu_posture)
        } else {
            (&h36m_posture, &real_h36m_posture)
        };
        let mut all: Vec<ArrayView3<'_, f64>> = generated.iter().map(|p| p.view()).collect();
        all.push(positions.view());
        let posture = reference.measure(&all)?;
        let square_skating = pooled_skating(rig, std::iter::once(positions.view()));
        let row = Row {
            controller: controller.label.clone(),
            rig: rig.name,
            ndms,
            real_ndms: if rig.name == "CMU" {
                real_cmu_ndms
            } else {
                real_h36m_ndms
            },
            skating,
            real_skating: if rig.name == "CMU" {
                real_cmu_skating
            } else {
                real_h36m_skating
            },
            scenarios,
            replays,
            square,
            square_ndms,
            square_skating,
            posture: [
                posture.frechet,
                posture.arm_elevation_emd_deg,
                posture.arms_above_real_p99,
            ],
            real_posture: [
                real_posture.frechet,
                real_posture.arm_elevation_emd_deg,
                real_posture.arms_above_real_p99,
            ],
            held_bytes: controller.held_bytes,
            file_bytes: controller.file_bytes,
        };
        println!(
            "{} measured in {:.1} s; median lowest foot point of its frames {:.1} mm",
            row.controller,
            t0.elapsed().as_secs_f64(),
            median_lowest_foot_mm(rig, &generated)
        );
        rows.push(row);
    }
    println!();
    print_tables(&rows, &real_skating);
    print_posture(&rows);
    let db = &rows[0];
    let heading90 = db.scenarios[0].heading_s;
    println!(
        "\ndatabase targets: NDMS {:.3} vs real-vs-real {:.3} (within 0.05: {}); skating {:.3} vs real {:.3} ({}); 90-degree heading {} s (<= 0.6: {}); {:.1} us/frame (<= 30: {}); {:.2} MB held, {:.2} MB file (<= 10: {})",
        db.ndms,
        db.real_ndms,
        yes((db.ndms - db.real_ndms).abs() <= 0.05),
        db.skating,
        db.real_skating,
        yes(db.skating <= db.real_skating),
        secs(heading90),
        yes(heading90.is_some_and(|t| t <= 0.6)),
        db.square.us_per_frame,
        yes(db.square.us_per_frame <= 30.0),
        db.held_bytes as f64 / 1e6,
        db.file_bytes as f64 / 1e6,
        yes(db.held_bytes.max(db.file_bytes) <= 10_000_000)
    );
    if let Some(out) = json {
        std::fs::write(
            &out,
            serde_json::to_string_pretty(&rows_json(
                &rows,
                real_cmu_ndms,
                real_h36m_ndms,
                real_cmu_skating,
                real_h36m_skating,
            ))?,
        )?;
        println!("\nwrote {out}");
    }
    Ok(())
}

fn yes(ok: bool) -> &'static str {
    if ok {
        "met"
    } else {
        "NOT met"
    }
}

fn secs(v: Option<f64>) -> String {
    v.map_or("-".to_string(), |s| format!("{s:.2}"))
}

/// A rig: its skeleton, heading, foot points and NDMS words.
struct RigKit {
    name: &'static str,
    skeleton: Arc<Skeleton>,
    steering: Steering,
    feet: Vec<usize>,
    ndms: NdmsConfig,
}

impl RigKit {
    fn new(name: &'static str, skeleton: Arc<Skeleton>) -> Result<RigKit, BoxError> {
        let parts = find_body_parts(&skeleton)?;
        let feet = parts
            .legs
            .iter()
            .flat_map(|l| l.foot_points.iter().copied())
            .collect();
        // NDMS's joints (wrists, elbows, shoulders, hips, knees, ankles) and body frame, found
        // on the rig through the built-in joint map (the identity on H3.6M).
        let map = JointMap::detect(&skeleton)?;
        let h = Skeleton::h36m();
        let on_rig = |j: usize| {
            map.rig_joint(&h.joint(j).name)
                .ok_or_else(|| format!("{name} rig: no joint for {}", h.joint(j).name))
        };
        let reference = NdmsConfig::h36m_body_frame();
        let WordFrame::Body {
            left_shoulder,
            right_shoulder,
        } = reference.frame
        else {
            unreachable!("body frame")
        };
        let ndms = NdmsConfig {
            joints: H36M_NDMS_JOINTS
                .iter()
                .map(|&j| on_rig(j))
                .collect::<Result<_, _>>()?,
            left_hip: on_rig(H36M_LEFT_HIP)?,
            right_hip: on_rig(H36M_RIGHT_HIP)?,
            frame: WordFrame::Body {
                left_shoulder: on_rig(left_shoulder)?,
                right_shoulder: on_rig(right_shoulder)?,
            },
            ..reference
        };
        Ok(RigKit {
            name,
            steering: Steering::new(&skeleton, DT as f32)?,
            skeleton,
            feet,
            ndms,
        })
    }

    /// An NDMS database of every word of `sequences`.
    fn words<'a>(
        &self,
        sequences: impl Iterator<Item = ArrayView3<'a, f64>>,
    ) -> Result<NdmsDatabase, BoxError> {
        let views: Vec<_> = sequences.collect();
        Ok(NdmsDatabase::from_sequences(
            self.ndms.clone(),
            &views,
            NnMethod::default(),
        )?)
    }

    /// Skating frames and frames counted (every frame after the first).
    fn skating(&self, positions: ArrayView3<'_, f64>) -> (usize, usize) {
        let frames = positions.dim().0;
        let mut skating = 0;
        for t in 1..frames {
            let slides = self.feet.iter().any(|&j| {
                let (p, q) = (
                    positions.slice(s![t, j, ..]),
                    positions.slice(s![t - 1, j, ..]),
                );
                let horizontal = ((p[0] - q[0]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                p[1] * 1e3 < SKATING_HEIGHT_MM && horizontal * 1e3 * FPS > SKATING_SPEED_MM_S
            });
            skating += usize::from(slides);
        }
        (skating, frames.saturating_sub(1))
    }
}

fn fraction((count, of): (usize, usize)) -> f64 {
    count as f64 / of.max(1) as f64
}

/// The median over frames of the lowest foot point (mm): where the generated floor is.
fn median_lowest_foot_mm(rig: &RigKit, sequences: &[Array3<f64>]) -> f64 {
    let mut lowest: Vec<f64> = sequences
        .iter()
        .flat_map(|p| {
            (0..p.dim().0).map(move |t| {
                rig.feet
                    .iter()
                    .map(|&j| p[[t, j, 1]])
                    .fold(f64::INFINITY, f64::min)
            })
        })
        .collect();
    lowest.sort_by(f64::total_cmp);
    lowest.get(lowest.len() / 2).map_or(f64::NAN, |v| v * 1e3)
}

/// The skating fraction over several sequences (frames pooled).
fn pooled_skating<'a>(rig: &RigKit, sequences: impl Iterator<Item = ArrayView3<'a, f64>>) -> f64 {
    let (mut skating, mut frames) = (0, 0);
    for p in sequences {
        let (s, f) = rig.skating(p);
        skating += s;
        frames += f;
    }
    skating as f64 / frames.max(1) as f64
}

/// The mean NDMS over every word of `sequences` (no seed: words inside each) against `words`.
fn ndms_of<'a>(
    words: &NdmsDatabase,
    sequences: impl Iterator<Item = ArrayView3<'a, f64>>,
) -> Result<f64, BoxError> {
    let kappa = words.config().kappa;
    let (mut sum, mut count) = (0.0, 0usize);
    for p in sequences {
        let n = p.dim().0;
        if n < kappa {
            continue;
        }
        let report = words.score_forecasts(&[p], None)?;
        let k = n - kappa + 1;
        sum += report.mean * k as f64;
        count += k;
    }
    Ok(sum / count.max(1) as f64)
}

/// A real take on a rig: 30 Hz poses (floor at `y = 0`), smoothed trajectory and positions.
struct RealTake {
    poses: Vec<Pose>,
    trajectory: Vec<GroundFrame>,
    positions: Array3<f64>,
}

impl RealTake {
    fn new(rig: &RigKit, mut poses: Vec<Pose>, trajectory: Option<Vec<GroundFrame>>) -> RealTake {
        let positions = positions_of(&rig.skeleton, &poses);
        if trajectory.is_none() {
            // Retargeted poses: the floor at the median over frames of the lowest foot point.
            let mut lowest: Vec<f64> = (0..positions.dim().0)
                .map(|t| {
                    rig.feet
                        .iter()
                        .map(|&j| positions[[t, j, 1]])
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            lowest.sort_by(f64::total_cmp);
            let floor = lowest[lowest.len() / 2] as f32;
            for pose in &mut poses {
                pose.root_translation.y -= floor;
            }
        }
        let trajectory =
            trajectory.unwrap_or_else(|| smoothed_trajectory(&poses, &rig.steering, DT as f32));
        let positions = positions_of(&rig.skeleton, &poses);
        RealTake {
            poses,
            trajectory,
            positions,
        }
    }

    /// The smoothed goal at frame `i`: the trajectory's velocity (central difference) and facing.
    fn goal(&self, i: usize) -> (Vec2, f32) {
        let n = self.trajectory.len();
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let v = (self.trajectory[b].position - self.trajectory[a].position)
            / ((b - a).max(1) as f32 * DT as f32);
        (v, self.trajectory[i].facing)
    }
}

fn floor2(p: glam::Vec3) -> Vec2 {
    Vec2::new(p.x, p.z)
}

fn path_length(poses: &[Pose]) -> f32 {
    poses
        .windows(2)
        .map(|w| (floor2(w[1].root_translation) - floor2(w[0].root_translation)).length())
        .sum()
}

/// The real take a controller is measured against: on the CMU rig for the database, on
/// H3.6M for a model.
fn real_for<'a>(controller: &Controller, take: &'a TestTake) -> &'a RealTake {
    match controller.source {
        Source::Database(_) | Source::RigModel(_) => &take.cmu,
        Source::Model { .. } => &take.h36m,
    }
}

/// A test take on both rigs, and its 25 Hz H3.6M exp-map frames (the models' seed).
struct TestTake {
    name: String,
    cmu: RealTake,
    h36m: RealTake,
    frames25: Array2<f64>,
}

enum Source {
    Database(Arc<MatchingDatabase>),
    Model {
        model: Arc<MotionModel>,
        action: Option<&'static str>,
    },
    /// A learned model on the CMU rig (`skeleton: "rig"`), seeded with poses like the database.
    RigModel(Arc<MotionModel>),
}

struct Controller {
    label: String,
    source: Source,
    held_bytes: usize,
    file_bytes: usize,
}

/// `v` turned by `angle` about +y (`rotate(+z, a) = direction_of(a)`).
fn rotate(v: Vec2, angle: f32) -> Vec2 {
    let (s, c) = angle.sin_cos();
    Vec2::new(v.x * c + v.y * s, -v.x * s + v.y * c)
}

/// The rigid map on the floor from a controller's world to its real take's, fixed by the
/// seed's last frame (root position, pelvis heading).
struct Align {
    turn: f32,
    from: Vec2,
    to: Vec2,
}

impl Align {
    fn to_real(&self, p: Vec2) -> Vec2 {
        self.to + rotate(p - self.from, self.turn)
    }

    fn goal_to_controller(&self, velocity: Vec2, facing: f32) -> Goal {
        Goal {
            velocity: rotate(velocity, -self.turn),
            facing: wrap_angle(facing - self.turn),
        }
    }
}

/// A fresh character of `controller` started on `take`'s first second; the map from its world
/// to the real take's, and the positions of its start pose.
fn start(
    controller: &Controller,
    rig: &RigKit,
    take: &TestTake,
    real: &RealTake,
) -> Result<(Character, Align, Pose), BoxError> {
    let (character, pose) = match &controller.source {
        Source::Database(db) => {
            let mut c = Character::new(MotionSource::Database(db.clone()))?;
            let p = c.start_poses(&take.cmu.poses[..=SEED_END])?.clone();
            (c, p)
        }
        Source::RigModel(model) => {
            let mut c = Character::new(model.clone())?;
            let p = c
                .start_poses_with(&take.cmu.poses[..=SEED_END], None, Noise::Seed(NOISE_SEED))?
                .clone();
            (c, p)
        }
        Source::Model { model, action } => {
            let mut c = Character::new(model.clone())?;
            let seed = model_window(&take.frames25, 0, SEED_END_25 + 1, ExpMapTarget::H36m);
            let p = c
                .start(seed.view(), *action, Noise::Seed(NOISE_SEED))?
                .clone();
            (c, p)
        }
    };
    let here = &real.poses[SEED_END];
    let align = Align {
        turn: wrap_angle(rig.steering.heading_of(here) - character.heading_of(&pose)),
        from: floor2(pose.root_translation),
        to: floor2(here.root_translation),
    };
    Ok((character, align, pose))
}

#[derive(Clone, Copy, Debug)]
enum Scenario {
    Turn90,
    Turn180,
    Stop,
    SpeedUp,
}

impl Scenario {
    const ALL: [Scenario; 4] = [
        Scenario::Turn90,
        Scenario::Turn180,
        Scenario::Stop,
        Scenario::SpeedUp,
    ];

    fn name(self) -> &'static str {
        match self {
            Scenario::Turn90 => "turn 90",
            Scenario::Turn180 => "turn 180",
            Scenario::Stop => "stop",
            Scenario::SpeedUp => "speed up 1.2 -> 2.5 m/s",
        }
    }

    fn goal(self, facing: f32) -> Goal {
        let walk = |f: f32| Goal {
            velocity: direction_of(f) * WALK_SPEED,
            facing: wrap_angle(f),
        };
        match self {
            Scenario::Turn90 => walk(facing + std::f32::consts::FRAC_PI_2),
            Scenario::Turn180 => walk(facing + std::f32::consts::PI),
            Scenario::Stop => Goal {
                velocity: Vec2::ZERO,
                facing,
            },
            Scenario::SpeedUp => Goal {
                velocity: direction_of(facing) * FAST_SPEED,
                facing,
            },
        }
    }
}

struct Answer {
    scenario: Scenario,
    heading_s: Option<f64>,
    speed_s: Option<f64>,
    /// Ground speed over the run's last second (m/s).
    late_speed: f32,
}

/// One goal change after a 2 s walk from 16_16's first second.
fn respond(
    controller: &Controller,
    rig: &RigKit,
    take: &TestTake,
    real: &RealTake,
    scenario: Scenario,
) -> Result<(Answer, Array3<f64>), BoxError> {
    let (mut c, align, start_pose) = start(controller, rig, take, real)?;
    let facing = wrap_angle(real.trajectory[SEED_END].facing - align.turn);
    c.set_goal(Some(Goal {
        velocity: direction_of(facing) * WALK_SPEED,
        facing,
    }));
    let mut poses = vec![start_pose];
    for _ in 0..WARM_UP_FRAMES {
        poses.push(c.advance(DT)?.clone());
    }
    let goal = scenario.goal(facing);
    c.set_goal(Some(goal));
    let goal_speed = goal.velocity.length();
    let window = (SPEED_WINDOW_S / DT).round() as usize;
    let (mut heading, mut speed) = (Hold::default(), Hold::default());
    let mut roots = Vec::new();
    for f in 1..=SCENARIO_FRAMES {
        let pose = c.advance(DT)?.clone();
        let now = f as f64 * DT;
        let off = wrap_angle(c.heading_of(&pose) - goal.facing)
            .abs()
            .to_degrees();
        heading.offer(now, off <= HEADING_TOLERANCE_DEG);
        roots.push(floor2(pose.root_translation));
        if roots.len() > window {
            let v = (roots[roots.len() - 1] - roots[roots.len() - 1 - window]).length()
                / SPEED_WINDOW_S as f32;
            let ok = if goal_speed > 0.0 {
                (v - goal_speed).abs() <= SPEED_TOLERANCE * goal_speed
            } else {
                v <= SPEED_TOLERANCE * WALK_SPEED
            };
            speed.offer(now, ok);
        }
        poses.push(pose);
    }
    let n = roots.len();
    let late_speed = (roots[n - 1] - roots[n - 1 - window]).length() / SPEED_WINDOW_S as f32;
    Ok((
        Answer {
            scenario,
            heading_s: heading.reached(),
            speed_s: speed.reached(),
            late_speed,
        },
        positions_of(&rig.skeleton, &poses),
    ))
}

struct Replay {
    take: String,
    mean_m: f32,
    max_m: f32,
    ndms: f64,
    skating: f64,
}

/// A test take's own smoothed root path as timed goals, from its first second.
fn replay(
    controller: &Controller,
    rig: &RigKit,
    take: &TestTake,
    real: &RealTake,
) -> Result<(Replay, Array3<f64>), BoxError> {
    let (mut c, align, start_pose) = start(controller, rig, take, real)?;
    let mut poses = vec![start_pose];
    let (mut sum, mut max, mut n) = (0.0f32, 0.0f32, 0usize);
    for i in SEED_END + 1..real.poses.len() {
        let (v, facing) = real.goal(i - 1);
        c.set_goal(Some(align.goal_to_controller(v, facing)));
        let pose = c.advance(DT)?.clone();
        let d = (align.to_real(floor2(pose.root_translation))
            - floor2(real.poses[i].root_translation))
        .length();
        sum += d;
        max = max.max(d);
        n += 1;
        poses.push(pose);
    }
    Ok((
        Replay {
            take: take.name.clone(),
            mean_m: sum / n.max(1) as f32,
            max_m: max,
            ndms: 0.0,
            skating: 0.0,
        },
        positions_of(&rig.skeleton, &poses),
    ))
}

struct Square {
    corners_reached: usize,
    /// The first loop's corner times minus the ideal (s).
    first_loop_late_s: Vec<f64>,
    /// The mean time per side over every side walked (s).
    side_s: f64,
    us_per_frame: f64,
}

/// 60 s of looping 4 m square waypoints at 1.2 m/s from 16_16's first second.
fn square(
    controller: &Controller,
    rig: &RigKit,
    take: &TestTake,
    real: &RealTake,
) -> Result<(Square, Array3<f64>), BoxError> {
    let (mut c, align, start_pose) = start(controller, rig, take, real)?;
    let facing = wrap_angle(real.trajectory[SEED_END].facing - align.turn);
    let origin = floor2(start_pose.root_translation);
    let (ahead, side) = (
        direction_of(facing) * SQUARE_SIDE,
        direction_of(facing + std::f32::consts::FRAC_PI_2) * SQUARE_SIDE,
    );
    let corners = vec![origin + ahead, origin + ahead + side, origin + side, origin];
    let mut waypoints = Waypoints::new(corners, WALK_SPEED, SQUARE_RADIUS, true);
    let mut poses = Vec::with_capacity(SQUARE_FRAMES + 1);
    poses.push(start_pose.clone());
    let mut pose = start_pose;
    let mut reached = Vec::new();
    let mut next = waypoints.next_index();
    let mut time = 0.0;
    for f in 1..=SQUARE_FRAMES {
        let goal = waypoints.goal(floor2(pose.root_translation), c.heading_of(&pose));
        if waypoints.next_index() != next {
            reached.push((f - 1) as f64 * DT);
            next = waypoints.next_index();
        }
        c.set_goal(Some(goal));
        let t = Instant::now();
        let p = c.advance(DT)?;
        time += t.elapsed().as_secs_f64();
        pose.clone_from(p);
        poses.push(pose.clone());
    }
    let ideal = f64::from(SQUARE_SIDE / WALK_SPEED);
    let first_loop_late_s = reached
        .iter()
        .take(4)
        .enumerate()
        .map(|(k, t)| t - (k + 1) as f64 * ideal)
        .collect();
    let side_s = if reached.is_empty() {
        f64::NAN
    } else {
        reached.last().expect("a corner") / reached.len() as f64
    };
    Ok((
        Square {
            corners_reached: reached.len(),
            first_loop_late_s,
            side_s,
            us_per_frame: time / SQUARE_FRAMES as f64 * 1e6,
        },
        positions_of(&rig.skeleton, &poses),
    ))
}

struct Row {
    controller: String,
    rig: &'static str,
    ndms: f64,
    real_ndms: f64,
    skating: f64,
    real_skating: f64,
    scenarios: Vec<Answer>,
    replays: Vec<Replay>,
    square: Square,
    square_ndms: f64,
    square_skating: f64,
    /// Posture realism against the test takes: Fréchet distance, upper-arm elevation EMD
    /// (degrees), share of frames with an upper arm above the test takes' 99th percentile.
    posture: [f64; 3],
    /// The same of the training takes (real-vs-real).
    real_posture: [f64; 3],
    held_bytes: usize,
    file_bytes: usize,
}

fn print_posture(rows: &[Row]) {
    println!("\nPosture realism against the test takes' postures on the same rig (`motion_metrics::posture`; real-vs-real: the training takes):\n");
    println!("| controller | rig | Fréchet, leg lengths² (real-vs-real) | upper-arm elevation EMD, degrees (real-vs-real) | frames with an upper arm above the real p99 (real-vs-real) |");
    println!("|---|---|---|---|---|");
    for r in rows {
        println!(
            "| {} | {} | {:.3} ({:.3}) | {:.1} ({:.1}) | {:.3} ({:.3}) |",
            r.controller,
            r.rig,
            r.posture[0],
            r.real_posture[0],
            r.posture[1],
            r.real_posture[1],
            r.posture[2],
            r.real_posture[2]
        );
    }
}

fn print_tables(rows: &[Row], real_skating: &[(f64, f64)]) {
    println!("| controller | rig | NDMS (real-vs-real) | skating (real test takes) | turn 90: heading / speed s | turn 180: heading / speed s | stop: speed s | speed-up to 2.5 m/s: speed s (speed after 4 s) | replay root distance mean / max m | replay NDMS | us per frame | MB held / file |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let s = &r.scenarios;
        let mean = r.replays.iter().map(|x| x.mean_m).sum::<f32>() / r.replays.len().max(1) as f32;
        let max = r.replays.iter().map(|x| x.max_m).fold(0.0f32, f32::max);
        let replay_ndms =
            r.replays.iter().map(|x| x.ndms).sum::<f64>() / r.replays.len().max(1) as f64;
        println!(
            "| {} | {} | {:.3} ({:.3}) | {:.3} ({:.3}) | {} / {} | {} / {} | {} | {} ({:.2}) | {:.2} / {:.2} | {:.3} | {:.1} | {:.2} / {:.2} |",
            r.controller,
            r.rig,
            r.ndms,
            r.real_ndms,
            r.skating,
            r.real_skating,
            secs(s[0].heading_s),
            secs(s[0].speed_s),
            secs(s[1].heading_s),
            secs(s[1].speed_s),
            secs(s[2].speed_s),
            secs(s[3].speed_s),
            s[3].late_speed,
            mean,
            max,
            replay_ndms,
            r.square.us_per_frame,
            r.held_bytes as f64 / 1e6,
            r.file_bytes as f64 / 1e6,
        );
    }
    println!(
        "\nReplay per test take (root distance mean / max m, NDMS against the take, skating):\n"
    );
    print!("| controller |");
    for x in &rows[0].replays {
        print!(" {} |", x.take);
    }
    println!();
    println!("|---|{}", "---|".repeat(rows[0].replays.len()));
    for r in rows {
        print!("| {} |", r.controller);
        for x in &r.replays {
            print!(
                " {:.2} / {:.2}, {:.3}, {:.3} |",
                x.mean_m, x.max_m, x.ndms, x.skating
            );
        }
        println!();
    }
    for (k, rig) in ["CMU rig", "H3.6M"].iter().enumerate() {
        print!("| real take ({rig}): skating |");
        for s in real_skating {
            print!(" {:.3} |", if k == 0 { s.0 } else { s.1 });
        }
        println!();
    }
    println!(
        "\n60 s of 4 m square waypoints at 1.2 m/s (ideal: a corner every 3.33 s, 18 in 60 s):\n"
    );
    println!("| controller | corners reached | first loop: corner time - ideal, s | mean s per side | skating | NDMS |");
    println!("|---|---|---|---|---|---|");
    for r in rows {
        let late: Vec<String> = r
            .square
            .first_loop_late_s
            .iter()
            .map(|t| format!("{t:+.2}"))
            .collect();
        println!(
            "| {} | {} | {} | {:.2} | {:.3} | {:.3} |",
            r.controller,
            r.square.corners_reached,
            if late.is_empty() {
                "-".to_string()
            } else {
                late.join(" / ")
            },
            r.square.side_s,
            r.square_skating,
            r.square_ndms,
        );
    }
}

fn rows_json(
    rows: &[Row],
    real_cmu_ndms: f64,
    real_h36m_ndms: f64,
    real_cmu_skating: f64,
    real_h36m_skating: f64,
) -> serde_json::Value {
    let f = |v: f64| {
        if v.is_finite() {
            serde_json::json!(v)
        } else {
            serde_json::Value::Null
        }
    };
    serde_json::json!({
        "test_takes": TEST_TAKES,
        "fps": FPS,
        "real": {
            "ndms_training_vs_test_cmu": real_cmu_ndms,
            "ndms_training_vs_test_h36m": real_h36m_ndms,
            "skating_test_cmu": real_cmu_skating,
            "skating_test_h36m": real_h36m_skating,
        },
        "controllers": rows.iter().map(|r| serde_json::json!({
            "controller": r.controller,
            "rig": r.rig,
            "ndms": f(r.ndms),
            "skating": f(r.skating),
            "responsiveness": r.scenarios.iter().map(|a| serde_json::json!({
                "scenario": a.scenario.name(),
                "heading_s": a.heading_s,
                "speed_s": a.speed_s,
                "late_speed_m_s": a.late_speed,
            })).collect::<Vec<_>>(),
            "replays": r.replays.iter().map(|x| serde_json::json!({
                "take": x.take,
                "root_distance_mean_m": x.mean_m,
                "root_distance_max_m": x.max_m,
                "ndms": f(x.ndms),
                "skating": f(x.skating),
            })).collect::<Vec<_>>(),
            "square": {
                "corners_reached": r.square.corners_reached,
                "first_loop_late_s": r.square.first_loop_late_s,
                "mean_side_s": f(r.square.side_s),
                "skating": f(r.square_skating),
                "ndms": f(r.square_ndms),
            },
            "us_per_frame": r.square.us_per_frame,
            "held_bytes": r.held_bytes,
            "file_bytes": r.file_bytes,
        })).collect::<Vec<_>>(),
    })
}
