use std::path::PathBuf;

use super::*;
use crate::formats::expmap_bvh::ExpMapTarget;
use crate::model::Character;
use crate::seed::load_seed;

fn model() -> Arc<MotionModel> {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../weights/vgru_d_multi.safetensors");
    Arc::new(MotionModel::load(path).expect("shipped weights"))
}

fn seed(model: &MotionModel) -> Array2<f64> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/walk_seed.bvh");
    load_seed(&path, ExpMapTarget::H36m, model.config().fps, 50.0, None)
        .expect("the example seed")
        .frames
}

fn close(a: &Pose, b: &Pose) -> f32 {
    let rotations = a
        .local_rotations
        .iter()
        .zip(&b.local_rotations)
        .map(|(p, q)| (*p - *q).length().min((*p + *q).length()))
        .fold(0.0f32, f32::max);
    rotations.max((a.root_translation - b.root_translation).length())
}

#[test]
fn a_crowd_moves_like_its_characters_alone() {
    let model = model();
    let seed = seed(&model);
    let mut crowd = Crowd::new(model.clone()).unwrap();
    let mut alone = Vec::new();
    let mut ids = Vec::new();
    for (action, rng) in [("walking", 1), ("eating", 2)] {
        ids.push(
            crowd
                .add(seed.view(), Some(action), rng, GroundingConfig::default())
                .unwrap(),
        );
        let mut c = Character::new(model.clone()).unwrap();
        c.start_from_clip(seed.view(), Some(action), Noise::Seed(rng))
            .unwrap();
        alone.push(c);
    }
    for (id, c) in ids.iter().zip(&mut alone) {
        let first = c.advance(0.0).unwrap().clone();
        assert!(close(crowd.pose(*id).unwrap(), &first) < 1e-5);
    }
    let mut worst = 0.0f32;
    for tick in 0..120 {
        if tick == 60 {
            crowd.set_action(ids[1], "smoking").unwrap();
            alone[1].set_action("smoking", 0).unwrap();
        }
        crowd.advance(1.0 / 60.0).unwrap();
        for (id, c) in ids.iter().zip(&mut alone) {
            let pose = c.advance(1.0 / 60.0).unwrap();
            worst = worst.max(close(crowd.pose(*id).unwrap(), pose));
        }
    }
    assert!(worst < 1e-3, "crowd and lone characters differ by {worst}");
    assert_eq!(crowd.action(ids[1]), Some("smoking"));
}

#[test]
fn members_join_and_leave_and_the_others_go_on_without_a_jump() {
    // A second member joins at tick 50 and leaves a tick later (two batch restarts, the first
    // member re-seeded from what it generated): its root moves no more over those ticks than
    // it does anywhere else in the run.
    let model = model();
    let seed = seed(&model);
    let mut crowd = Crowd::new(model).unwrap();
    let a = crowd
        .add(seed.view(), Some("walking"), 1, GroundingConfig::default())
        .unwrap();
    let mut last = crowd.pose(a).unwrap().root_translation;
    let (mut around, mut elsewhere) = (0.0f32, 0.0f32);
    let mut b = None;
    for tick in 0..150 {
        if tick == 50 {
            b = Some(
                crowd
                    .add(seed.view(), Some("eating"), 2, GroundingConfig::default())
                    .unwrap(),
            );
            assert_eq!(crowd.len(), 2);
        }
        if tick == 51 {
            assert!(crowd.remove(b.unwrap()));
            assert!(!crowd.remove(b.unwrap()));
        }
        crowd.advance(1.0 / 60.0).unwrap();
        let now = crowd.pose(a).unwrap().root_translation;
        let moved = (now - last).length();
        if (50..54).contains(&tick) {
            around = around.max(moved);
        } else {
            elsewhere = elsewhere.max(moved);
        }
        last = now;
    }
    assert!(
        around <= elsewhere,
        "the root moved {around} m in a tick at the restarts, {elsewhere} m at most elsewhere"
    );
    assert_eq!(crowd.members().collect::<Vec<_>>(), vec![a]);
}

#[test]
fn bad_members_are_refused_with_what_is_wrong() {
    let model = model();
    let seed = seed(&model);
    let mut crowd = Crowd::new(model).unwrap();
    let unknown = crowd.add(seed.view(), Some("juggling"), 0, GroundingConfig::default());
    assert!(matches!(
        unknown,
        Err(CharacterError::Generate(
            GenerateError::UnknownAction { .. }
        ))
    ));
    let short = crowd.add(
        seed.slice(s![..10, ..]),
        Some("walking"),
        0,
        GroundingConfig::default(),
    );
    assert!(matches!(
        short,
        Err(CharacterError::Generate(GenerateError::TooFewSeedFrames {
            got: 10,
            ..
        }))
    ));
    let mut bad = seed.clone();
    let last = bad.nrows() - 1;
    bad[[last, 7]] = f64::NAN;
    assert!(matches!(
        crowd.add(bad.view(), Some("walking"), 0, GroundingConfig::default()),
        Err(CharacterError::Generate(GenerateError::NonFiniteSeed {
            dim: 7,
            ..
        }))
    ));
    assert!(crowd.is_empty());
    crowd.advance(0.1).unwrap(); // nothing to do
    let a = crowd
        .add(seed.view(), Some("walking"), 0, GroundingConfig::default())
        .unwrap();
    assert!(crowd.set_action(a, "juggling").is_err());
    assert_eq!(crowd.action(a), Some("walking"));
    crowd.remove(a);
    assert!(matches!(
        crowd.set_action(a, "eating"),
        Err(CharacterError::Generate(GenerateError::NoSuchRow { .. }))
    ));
    assert!(!crowd.set_goal(a, None));
}

#[test]
fn a_database_crowd_plays_its_members_on_the_databases_rig() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../weights/matching_cmu.safetensors");
    let source = MotionSource::load(path).expect("the shipped database");
    let mut crowd = Crowd::new(source).unwrap();
    assert!(crowd.model().is_none());
    // Exp-map seeds are for learned models.
    let frames = Array2::<f32>::zeros((50, 99));
    assert!(matches!(
        crowd.add(frames.view(), None, 0, GroundingConfig::default()),
        Err(CharacterError::NeedsPoses)
    ));
    let a = crowd.add_poses(&[], GroundingConfig::default()).unwrap();
    let b = crowd.add_poses(&[], GroundingConfig::default()).unwrap();
    assert_eq!(crowd.len(), 2);
    assert_eq!(crowd.members().collect::<Vec<_>>(), vec![a, b]);
    let joints = crowd.skeleton().len();
    assert_eq!(crowd.pose(a).unwrap().local_rotations.len(), joints);
    crowd.set_action(a, "walking").unwrap();
    let start = [a, b].map(|id| crowd.pose(id).unwrap().root_translation);
    assert!(crowd.set_goal(a, Some(Goal::towards(glam::Vec2::new(1.2, 0.0), 0.0))));
    assert!(crowd.set_goal(b, Some(Goal::towards(glam::Vec2::new(0.0, -1.2), 0.0))));
    for _ in 0..240 {
        crowd.advance(1.0 / 60.0).unwrap();
    }
    let moved = [a, b].map(|id| crowd.pose(id).unwrap().root_translation - start[id.0 as usize]);
    assert!(moved[0].x > 2.5 && moved[0].z.abs() < 1.5, "{:?}", moved[0]);
    assert!(
        moved[1].z < -2.5 && moved[1].x.abs() < 1.5,
        "{:?}",
        moved[1]
    );
    assert!(crowd.remove(a));
    assert_eq!(crowd.len(), 1);
    crowd.advance(1.0 / 60.0).unwrap();
    // A learned model's crowd takes exp-map seeds only.
    let mut models = Crowd::new(model()).unwrap();
    assert!(matches!(
        models.add_poses(&[], GroundingConfig::default()),
        Err(CharacterError::NeedsFrames)
    ));
}
