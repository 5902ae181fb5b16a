//! Steering a character with `Character::set_goal` (root-motion warping, `motion_core::steering`)
//! on the shipped model walking after the example seed: the heading convention is the direction
//! it walks, 90 and 180 degree turns are done within 1.2 s, a stop goal holds the root, and ticks
//! allocate nothing with or without a goal. The square course on a steady walker is a unit test
//! of `motion_core::steering`. Motion matching (`motion_core::matching`) steps without
//! allocating, plays a database built from takes through `Character`, and, on the training walks
//! (data tests), answers every goal change.
use std::path::PathBuf;
use std::sync::Arc;

use glam::{Vec2, Vec3};
use motion::core::formats::expmap_bvh::ExpMapTarget;
use motion::core::grounding::find_body_parts;
use motion::core::grounding::GroundingConfig;
use motion::core::matching::{Matcher, MatchingDatabase};
use motion::core::model::{Character, Crowd, MotionModel, Noise};
use motion::core::pose::{Pose, PoseDecoder};
use motion::core::root::RootEncoding;
use motion::core::seed::load_seed;
use motion::core::skeleton::Skeleton;
use motion::core::steering::{direction_of, facing_of, Goal, Waypoints};
use motion::metrics::ndms::{NdmsConfig, NdmsDatabase, NnMethod};
use motion::metrics::responsiveness::{measure, positions_of, RealMotion};

mod common;
use common::allocations;

const TICK: f64 = 1.0 / 60.0;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shipped model walking after the example seed.
fn walker() -> (Character, Pose) {
    walker_with_noise(3)
}

/// The shipped model walking after the example seed, noise seed `noise`.
fn walker_with_noise(noise: u64) -> (Character, Pose) {
    walker_of("vgru_d_multi", noise)
}

/// The shipped weights `weights/{file}.safetensors` walking after the example seed, noise seed
/// `noise`.
fn walker_of(file: &str, noise: u64) -> (Character, Pose) {
    let model = Arc::new(
        MotionModel::load(repo().join(format!("weights/{file}.safetensors")))
            .expect("shipped weights"),
    );
    let config = model.config().clone();
    let seed = load_seed(
        &repo().join("examples/walk_seed.bvh"),
        ExpMapTarget::H36m,
        config.fps,
        50.0,
        None,
    )
    .unwrap();
    let mut character = Character::new(model).unwrap();
    let first = character
        .start_from_clip(seed.frames.view(), Some("walking"), Noise::Seed(noise))
        .unwrap()
        .clone();
    (character, first)
}

fn floor_xz(p: Vec3) -> Vec2 {
    Vec2::new(p.x, p.z)
}

/// Foot skating: the fraction of ticks with a foot point under 5 cm moving faster than 0.5 m/s
/// on the floor (the definition of the plausibility metric).
struct Skating {
    feet: Vec<usize>,
    previous: Option<Vec<Vec3>>,
    positions: Vec<Vec3>,
    world: Vec<glam::Quat>,
    skating: usize,
    ticks: usize,
}

impl Skating {
    fn new(character: &Character) -> Skating {
        let skeleton = character.skeleton();
        let parts = find_body_parts(skeleton).unwrap();
        let feet = parts
            .legs
            .iter()
            .flat_map(|l| l.foot_points.iter().copied())
            .collect();
        Skating {
            feet,
            previous: None,
            positions: vec![Vec3::ZERO; skeleton.len()],
            world: vec![glam::Quat::IDENTITY; skeleton.len()],
            skating: 0,
            ticks: 0,
        }
    }

    fn observe(&mut self, character: &Character, pose: &Pose) {
        pose.world_positions_into(character.skeleton(), &mut self.positions, &mut self.world);
        let now: Vec<Vec3> = self.feet.iter().map(|&j| self.positions[j]).collect();
        if let Some(before) = &self.previous {
            let slides = now.iter().zip(before).any(|(a, b)| {
                a.y < 0.05 && (floor_xz(*a) - floor_xz(*b)).length() / TICK as f32 > 0.5
            });
            self.skating += usize::from(slides);
            self.ticks += 1;
        }
        self.previous = Some(now);
    }

    fn fraction(&self) -> f64 {
        self.skating as f64 / self.ticks.max(1) as f64
    }
}

#[test]
fn the_pelvis_faces_the_walk() {
    // Unsteered: the heading convention of the goals is the direction the model walks.
    let (mut character, first) = walker();
    let mut last = floor_xz(first.root_translation);
    let mut facing_errors = Vec::new();
    let mut skating = Skating::new(&character);
    for k in 0..(8.0 / TICK) as usize {
        let pose = character.advance(TICK).unwrap().clone();
        skating.observe(&character, &pose);
        let here = floor_xz(pose.root_translation);
        // Every 0.5 s in which it walked (its walk slows to a shuffle at times).
        if k % 30 == 29 {
            if (here - last).length() > 0.15 {
                let d = (facing_of(here - last) - character.heading_of(&pose))
                    .rem_euclid(std::f32::consts::TAU);
                facing_errors.push(d.min(std::f32::consts::TAU - d));
            }
            last = here;
        }
    }
    eprintln!("unsteered walk over 8 s: skating {:.3}", skating.fraction());
    facing_errors.sort_by(f32::total_cmp);
    assert!(facing_errors.len() >= 5, "{facing_errors:?}");
    let median = facing_errors[facing_errors.len() / 2];
    assert!(median < 0.5, "the pelvis faces the walk: {facing_errors:?}");
}

/// Seconds until `character`'s heading is within 10 degrees of `goal`'s facing, ticking at 60 Hz
/// (at most `limit`), with the skating fraction of those ticks.
fn time_to_face(character: &mut Character, goal: Goal, limit: f64) -> (Option<f64>, f64) {
    character.set_goal(Some(goal));
    let mut skating = Skating::new(character);
    let mut time = 0.0;
    let mut faced = None;
    while time < limit {
        let pose = character.advance(TICK).unwrap().clone();
        time += TICK;
        skating.observe(character, &pose);
        let d = (character.heading_of(&pose) - goal.facing).rem_euclid(std::f32::consts::TAU);
        if faced.is_none() && d.min(std::f32::consts::TAU - d) < 10f32.to_radians() {
            faced = Some(time);
        }
    }
    (faced, skating.fraction())
}

#[test]
fn a_steered_character_turns_to_its_goal_and_stops_on_request() {
    let (mut character, first) = walker();
    let heading = character.heading_of(&first);
    for _ in 0..60 {
        character.advance(TICK).unwrap();
    }
    for turn in [std::f32::consts::FRAC_PI_2, std::f32::consts::PI] {
        let facing = heading + turn;
        let goal = Goal::towards(direction_of(facing) * 0.4, 0.0);
        let (faced, skating) = time_to_face(&mut character, goal, 2.0);
        eprintln!(
            "turn {turn:.2} rad: heading within 10 degrees after {faced:?} s, skating {skating:.3}"
        );
        let faced = faced.unwrap_or_else(|| panic!("a {turn} rad turn not done in 2 s"));
        assert!(faced < 1.2, "a {turn} rad turn took {faced} s");
    }
    // Stop: the root stays put (the legs keep the model's motion).
    character.set_goal(Some(Goal {
        velocity: Vec2::ZERO,
        facing: heading,
    }));
    for _ in 0..30 {
        character.advance(TICK).unwrap();
    }
    let at = floor_xz(character.advance(0.0).unwrap().root_translation);
    let mut furthest = 0.0f32;
    for _ in 0..120 {
        let here = floor_xz(character.advance(TICK).unwrap().root_translation);
        furthest = furthest.max((here - at).length());
    }
    assert!(furthest < 0.25, "a stopped character moved {furthest} m");
}

/// Drives `weights/{file}.safetensors` after the example seed, noise seeds `0..seeds`, with
/// `Waypoints` around a square of `side` metres (left turns from its heading, or right turns
/// with `right`) at `speed` m/s: every corner within 1 m by the ideal time plus `slack` seconds,
/// and foot skating over the whole course no worse than real S5 walking's (0.39).
fn walks_a_square(file: &str, seeds: u64, side: f32, speed: f32, right: bool, slack: f64) {
    for noise in 0..seeds {
        let (mut character, first) = walker_of(file, noise);
        let heading = character.heading_of(&first);
        let start = floor_xz(first.root_translation);
        let turn = if right { 1.0 } else { -1.0 } * std::f32::consts::FRAC_PI_2;
        let (ahead, left) = (direction_of(heading), direction_of(heading + turn));
        let corners: Vec<Vec2> = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
            .iter()
            .map(|&(a, b)| start + (ahead * a + left * b) * side)
            .collect();
        let leg = f64::from(side / speed);
        let mut path = Waypoints::new(corners.clone(), speed, 0.3, false);
        let mut skating = Skating::new(&character);
        let (mut reached, mut time, mut here, mut facing) = ([None; 4], 0.0, start, heading);
        while path.target().is_some() && time < 4.0 * leg + slack + 10.0 {
            for (k, corner) in corners.iter().enumerate() {
                if (*corner - here).length() < 1.0 && k <= path.next_index() {
                    reached[k].get_or_insert(time);
                }
            }
            character.set_goal(Some(path.goal(here, facing)));
            let pose = character.advance(TICK).unwrap().clone();
            skating.observe(&character, &pose);
            facing = character.heading_of(&pose);
            here = floor_xz(pose.root_translation);
            time += TICK;
        }
        eprintln!(
            "{file} noise {noise} {}: corners reached at {reached:?} s (ideal {:.1} s apart), skating {:.3}",
            if right { "right" } else { "left" },
            leg,
            skating.fraction()
        );
        for (k, at) in reached.iter().enumerate() {
            let ideal = leg * (k + 1) as f64;
            let at = at.unwrap_or_else(|| panic!("{file} noise {noise}: corner {k} not reached"));
            assert!(
                at <= ideal + slack,
                "{file} noise {noise}: corner {k} at {at} s, ideal {ideal} s"
            );
        }
        assert!(
            skating.fraction() <= 0.39,
            "{file} noise {noise}: skating {}",
            skating.fraction()
        );
    }
}

#[test]
fn the_shipped_model_walks_a_square_of_waypoints_with_its_feet_planted() {
    // VGRU-d, root-motion warping: a 4 m square at 0.4 m/s (its own walk averages about 0.5 m/s).
    walks_a_square("vgru_d_multi", 4, 4.0, 0.4, false, 2.0);
}

#[test]
fn the_locomotion_model_walks_a_square_of_waypoints_by_its_control() {
    // goal-gru, told where to go by its control (and warped), deterministic: the same 4 m
    // square at 0.6 m/s with left turns and with right turns, every corner within 2 s of the
    // ideal (its legs stride slower than its root travels: with the body held to its flat held
    // feet, as when nobody steers, it is up to 5 s late; the root leads a steered character).
    walks_a_square("goal_gru_h36m", 1, 4.0, 0.6, false, 2.0);
    walks_a_square("goal_gru_h36m", 1, 4.0, 0.6, true, 2.0);
}

#[test]
fn a_character_steered_by_its_control_allocates_nothing_per_tick() {
    // goal-gru: the goal's control each model frame, and a generator's own control (no goal).
    let (mut character, _) = walker_of("goal_gru_h36m", 0);
    character.set_goal(Some(Goal::towards(Vec2::new(0.6, 0.0), 0.0)));
    for _ in 0..30 {
        character.advance(TICK).unwrap();
    }
    let mut generator =
        motion::core::model::Generator::new(character.generator_mut().unwrap().model().clone());
    let seed = ndarray::Array2::<f32>::zeros((50, 99));
    generator.start(seed.view(), None, Noise::Seed(0)).unwrap();
    generator.step().unwrap();
    let before = allocations();
    for k in 0..240 {
        if k % 60 == 0 {
            let turn = direction_of(k as f32 * 0.5);
            character.set_goal(Some(Goal::towards(turn * 0.6, 0.0)));
        }
        character.advance(TICK).unwrap();
        generator.step().unwrap();
    }
    assert_eq!(allocations() - before, 0);
}

#[test]
fn steering_allocates_nothing_per_tick() {
    let (mut character, _) = walker();
    character.set_goal(Some(Goal::towards(Vec2::new(1.0, 0.0), 0.0)));
    for _ in 0..30 {
        character.advance(TICK).unwrap();
    }
    let before = allocations();
    for k in 0..240 {
        if k % 60 == 0 {
            let turn = direction_of(k as f32 * 0.5);
            character.set_goal(Some(Goal::towards(turn * 1.2, 0.0)));
        }
        character.advance(TICK).unwrap();
    }
    assert_eq!(allocations() - before, 0);
}

#[test]
fn ticks_allocate_nothing_without_a_goal() {
    let (mut character, first) = walker();
    let mut pose = first;
    for _ in 0..30 {
        character.advance(TICK).unwrap();
    }
    let before = allocations();
    for _ in 0..240 {
        pose.clone_from(character.advance(TICK).unwrap());
    }
    assert_eq!(allocations() - before, 0);
}

/// A motion-matching database of the example's procedural walk (no data needed).
fn example_walk_matcher() -> Matcher {
    let clip = load_seed(
        &repo().join("examples/walk_seed.bvh"),
        ExpMapTarget::H36m,
        25.0,
        25.0,
        None,
    )
    .unwrap()
    .frames;
    Matcher::new(Arc::new(MatchingDatabase::h36m(&[clip.view()]).unwrap()))
}

#[test]
fn motion_matching_steps_allocate_nothing() {
    let mut matcher = example_walk_matcher();
    matcher.set_goal(Some(Goal::towards(Vec2::new(0.7, 0.0), 0.0)));
    for _ in 0..30 {
        matcher.step();
    }
    let before = allocations();
    for k in 0..240 {
        if k % 60 == 0 {
            let turn = direction_of(k as f32 * 0.5);
            matcher.set_goal(Some(Goal::towards(turn * 0.7, 0.0)));
        }
        matcher.step();
    }
    assert_eq!(allocations() - before, 0);
}

/// The H3.6M dataset (`MOTION_DATA_DIR`, default `<repo>/../shared/data`), or `None` with a
/// visible message.
fn dataset() -> Option<PathBuf> {
    let dataset = motion::core::protocol::dataset_dir(&common::data_root());
    if dataset.join("S1/walking_1.txt.gz").is_file() {
        Some(dataset)
    } else {
        eprintln!(
            "SKIPPED: motion matching on the H3.6M walks needs the H3.6M data at {} (set MOTION_DATA_DIR)",
            dataset.display()
        );
        None
    }
}

#[test]
fn motion_matching_on_the_training_walks_answers_every_goal_change() {
    // The baseline `examples/steering_compare.rs` reports: built from the training subjects'
    // walking takes, it turns to 90 and 180 degree goals within a second, stops, and its body
    // moves like real walking.
    let Some(dataset) = dataset() else { return };
    let mut clips = Vec::new();
    for subject in ["S1", "S6", "S7", "S8", "S9", "S11"] {
        clips.extend(
            motion::core::protocol::load_subject_sequences(&dataset, subject, "walking").unwrap(),
        );
    }
    let views: Vec<_> = clips.iter().map(|c| c.view()).collect();
    let database = Arc::new(MatchingDatabase::h36m(&views).unwrap());
    let make = || -> Result<Matcher, Box<dyn std::error::Error + Send + Sync>> {
        Ok(Matcher::new(database.clone()))
    };
    // NDMS against the motion words of the same takes, decoded as the engine decodes them.
    let skeleton = Arc::new(Skeleton::h36m());
    let takes: Vec<_> = clips
        .iter()
        .map(|clip| {
            let mut decoder = PoseDecoder::new(skeleton.clone(), RootEncoding::Deltas, 2);
            positions_of(&skeleton, &decoder.decode_all(clip.view()))
        })
        .collect();
    let views: Vec<_> = takes.iter().map(|t| t.view()).collect();
    let words =
        NdmsDatabase::from_sequences(NdmsConfig::h36m_body_frame(), &views, NnMethod::default())
            .unwrap();
    let real = RealMotion {
        body_speed: 0.42,
        ndms: Some(&words),
    };
    let report = measure("motion matching", make, real, database.bytes()).unwrap();
    eprintln!("{report:?}");
    for s in &report.scenarios[..2] {
        let t = s.heading_s.unwrap_or(f64::INFINITY);
        assert!(t < 1.0, "{:?}: heading after {t} s", s.scenario);
    }
    assert!(report.scenarios[2].speed_s.is_some(), "it never stopped");
    assert!(
        (0.5..2.0).contains(&report.body_speed_ratio),
        "body speed {} of real walking's",
        report.body_speed_ratio
    );
    // Playing the takes the words come from, blended at its jumps and turned by the goals.
    let ndms = report.ndms.expect("a database was given");
    assert!((0.5..=1.0).contains(&ndms), "NDMS {ndms}");
}

#[test]
fn a_crowd_allocates_nothing_per_advance() {
    // Three characters of the shipped model as one batch, steered: after the first advance
    // (which starts the batch), advancing allocates nothing.
    let model = Arc::new(
        MotionModel::load(repo().join("weights/vgru_d_multi.safetensors"))
            .expect("shipped weights"),
    );
    let seed = load_seed(
        &repo().join("examples/walk_seed.bvh"),
        ExpMapTarget::H36m,
        model.config().fps,
        50.0,
        None,
    )
    .unwrap();
    let mut crowd = Crowd::new(model).unwrap();
    let ids: Vec<_> = (0..3)
        .map(|k| {
            crowd
                .add(
                    seed.frames.view(),
                    Some("walking"),
                    k,
                    GroundingConfig::default(),
                )
                .unwrap()
        })
        .collect();
    for _ in 0..30 {
        crowd.advance(TICK).unwrap();
    }
    let before = allocations();
    for k in 0..240 {
        if k % 60 == 0 {
            for (i, &id) in ids.iter().enumerate() {
                let turn = direction_of(k as f32 * 0.5 + i as f32);
                crowd.set_goal(id, Some(Goal::towards(turn * 0.5, 0.0)));
            }
        }
        crowd.advance(TICK).unwrap();
    }
    assert_eq!(allocations() - before, 0);
}

/// The control a `goal-gru` model reads, as the engine computes it from decoded poses
/// (`GoalControl` over `Steering`'s heading), equals `training/locomotion.py`'s definition
/// computed straight from the integrated root (rotation row 2 as the forward, y up) on real S5
/// walking: the past second at frame `t + 25` is the future second at frame `t`.
#[test]
fn the_engine_control_matches_the_training_definition_on_real_walking() {
    use motion::core::formats::h36m_text::{downsample_protocol, read_expmap_text};
    use motion::core::motion::RootEncoding;
    use motion::core::pose::PoseDecoder;
    use motion::core::root::integrate_root;
    use motion::core::skeleton::Skeleton;
    use motion::core::steering::{GoalControl, Steering};

    let path = common::data_root().join("h3.6m/dataset/S5/walking_1.txt.gz");
    if !path.exists() {
        eprintln!(
            "SKIPPED: {} not found (set MOTION_DATA_DIR)",
            path.display()
        );
        return;
    }
    let frames = downsample_protocol(read_expmap_text(&path).unwrap().view());
    let k = 25;
    let roots = integrate_root(frames.view(), 2);
    let heading = |t: usize| {
        let r = &roots[t].rotation;
        r[2][0].atan2(r[2][2])
    };
    let skeleton = Arc::new(Skeleton::h36m());
    let mut decoder = PoseDecoder::new(Arc::clone(&skeleton), RootEncoding::Deltas, 2);
    let steering = Steering::new(&skeleton, 0.04).unwrap();
    let mut control = GoalControl::new(k, 0.04);
    let mut worst = [0.0f64; 3];
    for (t, row) in frames.rows().into_iter().enumerate() {
        let pose = decoder.push(row.as_slice().unwrap());
        let root = Vec2::new(pose.root_translation.x, pose.root_translation.z);
        control.record(root, steering.heading_of(pose));
        if t < k {
            continue;
        }
        let got = control.control(None);
        let s = t - k;
        let (h0, h1) = (heading(s), heading(t));
        let d: Vec<f64> = (0..3)
            .map(|i| (roots[t].translation[i] - roots[s].translation[i]) / 1000.0)
            .collect();
        let forward = d[0] * h0.sin() + d[2] * h0.cos();
        let side = d[0] * h0.cos() - d[2] * h0.sin();
        let turn = (h1 - h0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        for (w, (g, e)) in worst.iter_mut().zip(got.iter().zip([forward, side, turn])) {
            *w = w.max((f64::from(*g) - e).abs());
        }
    }
    println!(
        "worst |engine - definition|: forward {:.2e} side {:.2e} turn {:.2e}",
        worst[0], worst[1], worst[2]
    );
    assert!(worst.iter().all(|&w| w < 1e-3), "{worst:?}");
}

#[test]
fn the_game_default_walks_a_square_of_waypoints_with_its_feet_planted() {
    // The engines' default (the action-conditioned intention model), root-motion warping: the
    // same 4 m square at 0.4 m/s for noise seeds 0-7, every corner within 2 s of the ideal.
    walks_a_square("intention_actions", 8, 4.0, 0.4, false, 2.0);
}

#[test]
fn a_character_plays_a_database_from_a_seed_in_the_seeds_coordinates() {
    let dir = std::env::temp_dir().join(format!("motion-character-db-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let example_seed = || repo().join("examples/walk_seed.bvh");
    std::fs::copy(example_seed(), dir.join("walk.bvh")).unwrap();
    let takes = motion::core::takes::read_takes(&dir, &motion::core::takes::TakeOptions::default())
        .unwrap();
    let db = Arc::new(
        MatchingDatabase::from_takes(&takes, motion::core::matching::DEFAULT_WEIGHTS).unwrap(),
    );
    let bvh = motion::core::formats::bvh::read_bvh(example_seed()).unwrap();
    let seed = motion::core::takes::seed_poses_on_rig(
        bvh,
        db.skeleton(),
        db.mm_per_unit(),
        db.fps(),
        None,
    )
    .unwrap();
    let mut character = motion::core::model::Character::new(db.clone()).unwrap();
    let first = character.start_poses(&seed[..45]).unwrap().clone();
    // The first pose is the seed's last, unchanged.
    assert!((first.root_translation - seed[44].root_translation).length() < 1e-5);
    // Sent along +x: it goes there, on the floor, at 60 Hz ticks.
    character.set_goal(Some(Goal::towards(Vec2::new(0.7, 0.0), 0.0)));
    let mut positions = vec![Vec3::ZERO; db.skeleton().len()];
    let mut world = vec![glam::Quat::IDENTITY; db.skeleton().len()];
    let mut lowest = f32::INFINITY;
    let mut last = first.root_translation;
    let mut largest_step = 0.0f32;
    for _ in 0..360 {
        let pose = character.advance(1.0 / 60.0).unwrap().clone();
        pose.world_positions_into(db.skeleton(), &mut positions, &mut world);
        lowest = lowest.min(positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min));
        largest_step = largest_step.max((pose.root_translation - last).length());
        last = pose.root_translation;
    }
    let travelled = last - first.root_translation;
    assert!(
        travelled.x > 2.5 && travelled.z.abs() < 1.5,
        "travelled {travelled}"
    );
    assert!(
        lowest > -0.03 && lowest < 0.08,
        "lowest joint at {lowest} m"
    );
    // No pop: at most 4 cm of root per 60 Hz tick (2.4 m/s).
    assert!(largest_step < 0.04, "{largest_step}");
    // A database has no exp-map start.
    let frames = ndarray::Array2::<f64>::zeros((50, 99));
    assert!(matches!(
        character.start(frames.view(), None, motion::core::model::Noise::Seed(0)),
        Err(motion::core::model::CharacterError::NeedsPoses)
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_database_character_allocates_nothing_per_tick() {
    // The shipped motion-matching database, steered through turns and a stop at 60 Hz ticks:
    // searches, jumps, blends, grounding and resampling allocate nothing.
    let source =
        motion::core::model::MotionSource::load(repo().join("weights/matching_cmu.safetensors"))
            .unwrap();
    let mut character = Character::new(source).unwrap();
    character.set_goal(Some(Goal::towards(Vec2::new(1.2, 0.0), 0.0)));
    for _ in 0..30 {
        character.advance(TICK).unwrap();
    }
    let before = allocations();
    for k in 0..480 {
        if k % 60 == 0 {
            let speed = if k % 240 == 180 { 0.0 } else { 1.2 };
            let turn = direction_of(k as f32 * 0.8);
            character.set_goal(Some(Goal::towards(turn * speed, k as f32 * 0.8)));
        }
        character.advance(TICK).unwrap();
    }
    assert_eq!(allocations() - before, 0);
}
