use std::path::PathBuf;

use ndarray::Array2;

use super::*;
use crate::formats::expmap_bvh::ExpMapTarget;
use crate::seed::load_seed;
use crate::steering::facing_of;

/// The example's procedural walk (3 s at 25 Hz, 0.7 m/s along +z) as H3.6M exp-map frames.
fn walk() -> Array2<f64> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/walk_seed.bvh");
    load_seed(&path, ExpMapTarget::H36m, 25.0, 25.0, None)
        .expect("the example seed")
        .frames
}

#[test]
fn bad_clips_are_refused_with_what_is_wrong() {
    let narrow = Array2::<f64>::zeros((40, 98));
    assert!(matches!(
        MatchingDatabase::h36m(&[narrow.view()]),
        Err(MatchingError::Width {
            clip: 0,
            got: 98,
            want: 99
        })
    ));
    let mut bad = walk();
    bad[[7, 20]] = f64::NAN;
    assert!(matches!(
        MatchingDatabase::h36m(&[bad.view()]),
        Err(MatchingError::NotFinite { clip: 0, frame: 7 })
    ));
    let short = walk().slice(ndarray::s![..20, ..]).to_owned();
    assert!(matches!(
        MatchingDatabase::h36m(&[short.view()]),
        Err(MatchingError::TooShort(26))
    ));
}

#[test]
fn a_walk_database_walks_where_it_is_sent() {
    let clip = walk();
    let db = Arc::new(MatchingDatabase::h36m(&[clip.view()]).unwrap());
    assert_eq!(db.frames(), clip.nrows());
    assert!(db.searchable_frames() > 10);
    // Sent along +x at the clip's own speed: after 6 s it has travelled about that far along
    // +x, facing +x, its feet on the floor.
    let mut m = Matcher::new(db.clone());
    let goal = Goal::towards(Vec2::new(0.7, 0.0), 0.0);
    m.set_goal(Some(goal));
    let mut start = None;
    let mut lowest = f32::INFINITY;
    let mut positions = vec![Vec3::ZERO; db.skeleton().len()];
    let mut world = vec![Quat::IDENTITY; db.skeleton().len()];
    for t in 0..150 {
        let pose = m.step().clone();
        if t == 25 {
            start = Some(pose.root_translation);
        }
        pose.world_positions_into(db.skeleton(), &mut positions, &mut world);
        lowest = lowest.min(positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min));
    }
    let pose = m.step().clone();
    let travelled = pose.root_translation - start.unwrap();
    let heading = m.heading_of(&pose);
    assert!(
        (travelled.x - 0.7 * 5.0).abs() < 1.0 && travelled.z.abs() < 1.0,
        "travelled {travelled}"
    );
    assert!(
        wrap_angle(heading - goal.facing).abs() < 0.2,
        "heading {heading} for {}",
        goal.facing
    );
    assert!(lowest.abs() < 0.05, "lowest joint at {lowest} m");
    assert!((facing_of(Vec2::new(1.0, 0.0)) - goal.facing).abs() < 1e-6);
}
