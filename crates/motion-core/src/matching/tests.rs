use std::path::PathBuf;

use ndarray::Array2;

use std::sync::Arc;

use glam::{Quat, Vec2, Vec3};

use super::*;
use crate::formats::expmap_bvh::ExpMapTarget;
use crate::seed::load_seed;
use crate::steering::facing_of;
use crate::steering::{wrap_angle, Goal};

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
    let short = walk().slice(ndarray::s![..3, ..]).to_owned();
    assert!(matches!(
        MatchingDatabase::h36m(&[short.view()]),
        Err(MatchingError::TooShort(13))
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

/// A scratch folder for one test (removed first if a run before left it).
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("motion-matching-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn example_seed() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/walk_seed.bvh")
}

/// The CMU takes (`MOTION_DATA_DIR`, default `<repo>/../shared/data`), or `None` after a
/// visible SKIPPED line.
fn cmu_takes(test: &str) -> Option<PathBuf> {
    let root = std::env::var_os("MOTION_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let dir = root.join("cmu_locomotion");
    if dir.join("16_15.bvh").is_file() {
        Some(dir)
    } else {
        println!("SKIPPED: {test} needs the CMU takes at {}", dir.display());
        None
    }
}

#[test]
fn a_folder_of_takes_gives_a_database_that_round_trips_through_its_file() {
    let dir = scratch("roundtrip");
    std::fs::copy(example_seed(), dir.join("a.bvh")).unwrap();
    std::fs::copy(example_seed(), dir.join("b.bvh")).unwrap();
    std::fs::write(dir.join("broken.bvh"), "HIERARCHY\nROOT Hips\n{\n").unwrap();
    // A take of 10 frames (0.4 s) is too short.
    let text = std::fs::read_to_string(example_seed()).unwrap();
    let cut = text.find("Frames:").unwrap();
    let motion: Vec<&str> = text[cut..].lines().collect();
    let short = format!(
        "{}Frames: 10\n{}\n{}\n",
        &text[..cut],
        motion[1],
        motion[2..12].join("\n")
    );
    std::fs::write(dir.join("short.bvh"), short).unwrap();
    std::fs::write(dir.join("notes.txt"), "not a take").unwrap();
    let takes = crate::takes::read_takes(&dir, &crate::takes::TakeOptions::default()).unwrap();
    assert_eq!(takes.takes.len(), 2);
    let skipped: Vec<String> = takes
        .skipped
        .iter()
        .map(|s| s.path.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(skipped, ["broken.bvh", "short.bvh"], "{:?}", takes.skipped);
    assert!(
        takes.skipped[1].reason.contains("shorter"),
        "{:?}",
        takes.skipped[1]
    );
    // 3 s at 25 Hz resampled to 30 Hz.
    assert_eq!(takes.takes[0].len(), 89);
    assert_eq!(takes.rig.mm_per_unit, 1.0);
    // Contacts: both feet touch the floor some of the time, and not all of it.
    let on: usize = takes.takes[0]
        .contacts
        .iter()
        .flatten()
        .filter(|c| **c)
        .count();
    assert!(on > 30 && on < 170, "{on} foot-frames in contact of 180");
    let mut db = MatchingDatabase::from_takes(&takes, DEFAULT_WEIGHTS).unwrap();
    db.set_licence("test frames");
    db.set_provenance("made by", "a test");
    let file = dir.join("db.safetensors");
    db.save(&file).unwrap();
    let back = MatchingDatabase::load(&file).unwrap();
    assert_eq!(back.frames(), db.frames());
    assert_eq!(back.takes(), db.takes());
    assert_eq!(back.licence(), "test frames");
    assert_eq!(
        back.provenance().get("made by").map(String::as_str),
        Some("a test")
    );
    assert_eq!(back.skeleton().len(), db.skeleton().len());
    for f in [0, 17, db.frames() - 1] {
        let (a, b) = (db.pose(f), back.pose(f));
        for (qa, qb) in a.local_rotations.iter().zip(&b.local_rotations) {
            // f16 rotations: within 0.1 degree.
            assert!(qa.angle_between(*qb) < 0.1f32.to_radians(), "frame {f}");
        }
        assert!((a.root_translation - b.root_translation).length() < 1e-6);
        for (x, y) in db.features(f).iter().zip(back.features(f)) {
            assert!((x - y).abs() < 2e-3 * (1.0 + x.abs()), "frame {f}: {x} {y}");
        }
    }
    // The kd-tree finds what brute force finds.
    for f in (0..back.frames()).step_by(7) {
        let mut q = *back.features(f);
        q[3] += 0.3;
        q[20] -= 0.2;
        let (a, da) = back.nearest(&q);
        let (b, db_) = back.nearest_brute_force(&q);
        assert!(
            (da - db_).abs() < 1e-5 * (1.0 + db_),
            "{a} {da} vs {b} {db_}"
        );
    }
    // A file that is not a database, and a damaged one, are refused by name.
    std::fs::write(dir.join("bad.safetensors"), b"nonsense").unwrap();
    let e = MatchingDatabase::load(dir.join("bad.safetensors")).unwrap_err();
    assert!(e.to_string().contains("bad.safetensors"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cmu_takes_on_two_rigs_make_a_database_that_walks_a_square() {
    let Some(dir) = cmu_takes("cmu_takes_on_two_rigs_make_a_database_that_walks_a_square") else {
        return;
    };
    let options = crate::takes::TakeOptions {
        rig: Some(dir.join("16_15.bvh")),
        ..Default::default()
    };
    let takes = crate::takes::read_takes(&dir, &options).unwrap();
    assert!(takes.skipped.is_empty(), "{:?}", takes.skipped);
    assert_eq!(takes.takes.len(), 46);
    // The 120 Hz 3dsMax-named takes went onto the 30 Hz ASF-named rig.
    let retargeted: Vec<&str> = takes
        .takes
        .iter()
        .filter(|t| t.retargeted)
        .map(|t| t.name.as_str())
        .collect();
    assert_eq!(retargeted, ["131_01", "131_02"]);
    assert_eq!(takes.rig.mm_per_unit, 10.0);
    let db = Arc::new(MatchingDatabase::from_takes(&takes, DEFAULT_WEIGHTS).unwrap());
    let bvh = crate::formats::bvh::read_bvh(dir.join("16_15.bvh")).unwrap();
    let seed =
        crate::takes::seed_poses_on_rig(bvh, db.skeleton(), db.mm_per_unit(), db.fps(), None)
            .unwrap();
    let mut m = Matcher::new(db.clone());
    let start = m.start(&seed).unwrap().clone();
    let origin = Vec2::new(start.root_translation.x, start.root_translation.z);
    let facing = m.heading_of(&start);
    // A 4 m square turning left, at 1.2 m/s.
    let corners: Vec<Vec2> = [(0.0, 4.0), (4.0, 4.0), (4.0, 0.0), (0.0, 0.0)]
        .iter()
        .map(|&(x, z)| origin + features::rotate(Vec2::new(-x, z), facing))
        .collect();
    let mut path = crate::steering::Waypoints::new(corners.clone(), 1.2, 0.5, false);
    let mut reached = vec![None; 4];
    for f in 0..1500 {
        let p = m.pose().root_translation;
        let here = Vec2::new(p.x, p.z);
        let goal = path.goal(here, m.heading_of(&m.pose().clone()));
        m.set_goal(Some(goal));
        m.step();
        let p = m.pose().root_translation;
        for (k, c) in corners.iter().enumerate() {
            if reached[k].is_none()
                && (k == 0 || reached[k - 1].is_some())
                && (Vec2::new(p.x, p.z) - *c).length() < 1.0
            {
                reached[k] = Some(f as f32 / 30.0);
            }
        }
    }
    for (k, t) in reached.iter().enumerate() {
        let ideal = 4.0 * (k + 1) as f32 / 1.2;
        let t = t.unwrap_or_else(|| panic!("corner {k} not reached: {reached:?}"));
        assert!(
            t < ideal + 2.0,
            "corner {k} at {t} s, ideal {ideal}: {reached:?}"
        );
    }
}
